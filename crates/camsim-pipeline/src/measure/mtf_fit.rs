//! The lens defocus and pixel crosstalk fitted to a measured system MTF (`camsim fit mtf`): the
//! fit itself is camsim-optics' (`camsim_optics::mtf_fit`); this writes its table and plot.

use super::write_text;
use crate::Result;
use camsim_io::measurements::MeasuredMtf;
use camsim_io::plot::{Figure, Series};
use camsim_optics::mtf_fit::{fit_mtf, MtfFit, MtfFitOptions, SystemMtfModel};
use std::fmt::Write as _;
use std::path::Path;

/// The fitted model against the measurement.
#[derive(Debug, Clone)]
pub struct MtfFitReport {
    /// The measured curve.
    pub measured: MeasuredMtf,
    /// The fitted model.
    pub model: SystemMtfModel,
    /// The fitted values and residuals (fit.json).
    pub fit: MtfFit,
}

/// Fit `start`'s free parameters (`opts.fit`) to `measured`.
pub fn fit_measured_mtf(
    measured: MeasuredMtf,
    start: &SystemMtfModel,
    opts: &MtfFitOptions,
) -> std::result::Result<MtfFitReport, camsim_optics::OpticsError> {
    let (model, fit) = fit_mtf(&measured.freq_cyc_per_mm, &measured.mtf, start, opts)?;
    Ok(MtfFitReport {
        measured,
        model,
        fit,
    })
}

impl MtfFitReport {
    /// mtf.csv: measured and fitted MTF at the measured frequencies.
    pub fn csv(&self) -> Result<String> {
        let m = &self.measured;
        let fitted = self.model.mtf(&m.freq_cyc_per_mm)?;
        let mut csv = String::from("frequency_cy_per_mm,mtf_measured,mtf_fit\n");
        for ((f, y), g) in m.freq_cyc_per_mm.iter().zip(&m.mtf).zip(&fitted) {
            let _ = writeln!(csv, "{f:.4},{y:.5},{g:.5}");
        }
        Ok(csv)
    }

    /// The measured curve and the fit drawn continuously from 0 to the largest measured
    /// frequency; `title` names the measurement.
    pub fn figure(&self, title: &str) -> Result<Figure> {
        let m = &self.measured;
        let r = &self.fit;
        let f_end = m.freq_cyc_per_mm.last().copied().unwrap_or(0.0);
        let dense: Vec<f64> = (0..=200).map(|i| f_end * i as f64 / 200.0).collect();
        let curve = self.model.mtf(&dense)?;
        let meas = Series::new(
            "measured",
            m.freq_cyc_per_mm
                .iter()
                .copied()
                .zip(m.mtf.iter().copied())
                .collect(),
        )
        .colored([20, 20, 20]);
        let fit = Series::new(
            format!(
                "fit: defocus {:.3} um, crosstalk sigma {:.2} um (RMS {:.3})",
                r.defocus_um, r.crosstalk_sigma_um, r.rms
            ),
            dense.iter().copied().zip(curve).collect(),
        )
        .dashed()
        .colored([214, 39, 40]);
        Ok(Figure::new(
            format!("MTF fit: {title}"),
            "spatial frequency (cycles/mm on the sensor)",
            "MTF",
        )
        .with(meas)
        .with(fit)
        .ranges(Some((0.0, f_end)), Some((0.0, 1.05)))
        .sized(900, 600))
    }

    /// Write mtf.csv and fit.json into `dir` and the plot to `plot` (a `.png` path).
    pub fn write_files(&self, dir: &Path, plot: &Path, title: &str) -> Result<()> {
        write_text(&dir.join("mtf.csv"), &self.csv()?)?;
        camsim_io::atomic::write_json_atomic(&dir.join("fit.json"), &self.fit)?;
        self.figure(title)?.write_png(plot)?;
        Ok(())
    }
}
