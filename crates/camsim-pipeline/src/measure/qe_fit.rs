//! The QE correction fit of the paper (eq. 1): the 3x3 matrix M, [r', g', b'] = [r, g, b] M, that
//! takes a sensor's published QE to measured ColorChecker patch means under several lights.
//!
//! The prediction is physical: the radiance of each patch (light x N. Ohta 1997 reflectance) is
//! scaled so the white patch (19) reaches `luminance_cd_m2`, turned into irradiance through a
//! lens of `f_number` (E = pi L / (1 + 4 N^2), ISETCam oiCalculateIrradiance), integrated with the
//! sensor's QE over the photodetector area for the exposure, and converted to DN with the
//! sensor's conversion gain.

use super::write_text;
use crate::{PipelineError, Result};
use camsim_analysis::qefit::{self, MatrixForm, QeFit};
use camsim_core::{tables, WavelengthGrid};
use camsim_io::atomic::OutputDir;
use camsim_io::measurements::PatchMeans;
use camsim_io::plot::{Figure, Series, Style, CHANNEL_COLORS};
use camsim_sensor::Sensor;
use std::fmt::Write as _;

/// The measurement the means come from.
#[derive(Debug, Clone, PartialEq)]
pub struct QeFitRequest {
    /// The lights by name as the measurements name them (built-in names or spectrum files).
    pub lights: Vec<String>,
    /// Luminance of a perfect white under each light, cd/m^2.
    pub luminance_cd_m2: f64,
    /// Lens f-number of the measurement.
    pub f_number: f64,
    /// Exposure time, ms.
    pub exposure_ms: f64,
    /// The matrix form fitted.
    pub form: MatrixForm,
}

/// The fit and its inputs.
#[derive(Debug, Clone)]
pub struct QeFitReport {
    /// The fitted matrix and residuals.
    pub fit: QeFit,
    /// Measured means, DN, per row of the input.
    pub measured: Vec<[f64; 3]>,
    /// Predicted with the published QE, DN.
    pub predicted: Vec<[f64; 3]>,
    /// Predicted with the corrected QE, DN.
    pub corrected: Vec<[f64; 3]>,
    /// The sensor with the correction (composed with any it had).
    pub corrected_sensor: camsim_sensor::SensorConfig,
}

/// Fit the QE correction of `sensor` to the measured `rows`; `source` names them in errors.
pub fn fit_qe(
    sensor: &Sensor,
    rows: &[PatchMeans],
    req: &QeFitRequest,
    source: &str,
) -> Result<QeFitReport> {
    let grid = WavelengthGrid::default();
    let refl = tables::macbeth_reflectances();
    let cmfs = camsim_core::colorimetry::Cmfs::on(&grid);
    let mut lights = std::collections::HashMap::new();
    for name in &req.lights {
        let s = camsim_scene::load_illuminant(name, "lights")?;
        // Scale so the white patch (19) reaches the luminance.
        let white: Vec<f64> = refl[18].product_on(&s, &grid);
        let k = req.luminance_cd_m2 / cmfs.luminance_cd_m2(&white);
        lights.insert(name.clone(), s.scaled(k));
    }
    let mut measured = Vec::with_capacity(rows.len());
    let mut radiances = Vec::with_capacity(rows.len());
    for row in rows {
        let light = lights.get(&row.light).ok_or_else(|| {
            PipelineError::Config(format!(
                "{source}, line {}: light '{}' is not among the lights ({})",
                row.line,
                row.light,
                req.lights.join(", ")
            ))
        })?;
        measured.push(row.rgb);
        radiances.push(refl[row.patch - 1].product_on(light, &grid));
    }
    // Etendue x time: pi / (1 + 4 N^2) x photodetector area x exposure (ISETCam oiCalculateIrradiance).
    let scale = std::f64::consts::PI / (1.0 + 4.0 * req.f_number * req.f_number)
        * sensor.photodetector_area_m2()
        * req.exposure_ms
        * 1e-3;
    let k = sensor.k_dn_per_e();
    let predicted: Vec<[f64; 3]> =
        qefit::predict_rgb(&sensor.channel_qe(&grid), &grid, &radiances, scale)?
            .into_iter()
            .map(|e| e.map(|v| v * k))
            .collect();
    let fit = qefit::fit_qe_matrix(&measured, &predicted, req.form)?;
    let corrected = qefit::apply_matrix(&predicted, &fit.m);
    // The corrected sensor: compose with any correction it already has.
    let mut cfg = sensor.config().clone();
    cfg.qe_correction = Some(match cfg.qe_correction {
        Some(old) => camsim_isp::color::mat3_mul(&old, &fit.m),
        None => fit.m,
    });
    cfg.name = format!("{} (QE corrected)", cfg.name);
    Ok(QeFitReport {
        fit,
        measured,
        predicted,
        corrected,
        corrected_sensor: cfg,
    })
}

impl QeFitReport {
    /// residuals.csv: measured, predicted and fitted means per row.
    pub fn csv(&self) -> String {
        let mut csv =
            String::from("row,meas_r,meas_g,meas_b,pred_r,pred_g,pred_b,fit_r,fit_g,fit_b\n");
        for (i, ((m, p), q)) in self
            .measured
            .iter()
            .zip(&self.predicted)
            .zip(&self.corrected)
            .enumerate()
        {
            let _ = writeln!(
                csv,
                "{i},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
                m[0], m[1], m[2], p[0], p[1], p[2], q[0], q[1], q[2]
            );
        }
        csv
    }

    /// The predicted means against the measured ones, per channel.
    fn scatter(&self, title: &str, pts: &[[f64; 3]]) -> Figure {
        let mut fig = Figure::new(title, "measured (DN)", "predicted (DN)")
            .with_identity_line()
            .sized(700, 700);
        for c in 0..3 {
            fig = fig.with(Series::xy(
                ["R", "G", "B"][c],
                self.measured.iter().map(|m| m[c]).collect(),
                pts.iter().map(|p| p[c]).collect(),
                Style::Points,
                CHANNEL_COLORS[c],
            ));
        }
        fig
    }

    /// Write fit.json, residuals.csv, scatter_before.png, scatter_after.png and
    /// sensor_corrected.toml into `out`.
    pub fn write_files(&self, out: &OutputDir) -> Result<()> {
        write_text(&out.join("residuals.csv"), &self.csv())?;
        self.scatter("Published QE", &self.predicted)
            .write_png(&out.join("scatter_before.png"))?;
        self.scatter("Corrected QE (fitted M)", &self.corrected)
            .write_png(&out.join("scatter_after.png"))?;
        let toml = toml::to_string_pretty(&self.corrected_sensor)
            .map_err(|e| PipelineError::config(format!("the corrected sensor: {e}")))?;
        write_text(&out.join("sensor_corrected.toml"), &toml)?;
        camsim_io::atomic::write_json_atomic(&out.join("fit.json"), &self.fit)?;
        Ok(())
    }
}
