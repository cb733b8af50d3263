//! `camsim fit mtf`: fit the lens defocus and a sensor crosstalk blur to a measured MTF.

use crate::common::{self, say};
use anyhow::{bail, Result};
use camsim::io::measurements::read_mtf_csv;
use camsim::optics::mtf_fit::{FitParams, MtfFitOptions, SystemMtfModel};
use camsim::pipeline::measure::mtf_fit::fit_measured_mtf;
use std::path::PathBuf;

/// Fit the defocus of the lens and, optionally, a Gaussian pixel-crosstalk blur to a measured
/// system MTF (a slanted-edge SFR of a real camera, on axis).
///
/// The model is the product of three transfer functions:
/// MTF(f) = MTF_lens(f; c4) x |sinc(f p)| x exp(-2 pi^2 sigma^2 f^2):
/// camsim's wavefront lens (a diffraction-limited pupil of --f-number with an OSA defocus term c4
/// over the lens pupil, at --wavelength-nm), the pixel aperture (pitch p, 100 % fill factor) and
/// a Gaussian of standard deviation sigma for carrier diffusion and optical crosstalk between
/// pixels. The fit minimises the RMS difference at the measured frequencies up to --max-freq.
/// It prints the fitted values, the RMS residual and the MTF50 of fit and measurement.
#[derive(clap::Args)]
#[command(
    after_help = "The measured CSV has a header naming two columns, the frequency in cycles/mm on the sensor \
and the modulation (`mtf_percent`: percent; `mtf`: fraction), then one point per line, increasing frequency:\n  \
frequency_cy_per_mm,mtf_percent\n  9.17,97.78\n\
Outputs:\n  \
fit.json        fitted defocus (um over the lens pupil, waves, um over ISETCam's 8 mm pupil), crosstalk\n                  \
sigma (um), RMS and largest residual, MTF50 of fit and measurement (cycles/mm)\n  \
mtf.csv         measured and fitted MTF at the measured frequencies\n  \
mtf_fit.png     the measured curve and the fit (or the file --plot names)\n\
Examples:\n  \
camsim fit mtf --measured ../shared/data/isetcornellbox/pixel4a-measured-mtf-in-focus.csv --out out/fit-mtf\n  \
camsim fit mtf --measured ../shared/data/isetcornellbox/pixel4a-measured-mtf-in-focus.csv --fit defocus --json --out out/fit-defocus"
)]
pub struct Args {
    /// Measured MTF: CSV `frequency_cy_per_mm,mtf_percent` (or `...,mtf` as a fraction).
    #[arg(long)]
    pub measured: PathBuf,
    /// Parameters to fit, comma separated: defocus, crosstalk (the others keep their given value).
    #[arg(long, value_delimiter = ',', default_values_t = ["defocus".to_string(), "crosstalk".to_string()], value_parser = ["defocus", "crosstalk"])]
    pub fit: Vec<String>,
    /// Starting (or fixed) defocus c4 over the lens pupil, um.
    #[arg(long, default_value_t = 0.0, value_parser = common::non_negative_f64)]
    pub defocus_um: f64,
    /// Starting (or fixed) crosstalk Gaussian sigma, um in the sensor plane.
    #[arg(long, default_value_t = 0.0, value_parser = common::non_negative_f64)]
    pub crosstalk_um: f64,
    /// Only measured points up to this frequency count, cycles/mm.
    #[arg(long, default_value_t = 250.0, value_parser = common::positive_f64)]
    pub max_freq: f64,
    /// Lens f-number (Pixel 4a: 1.73).
    #[arg(long, default_value_t = 1.73, value_parser = common::positive_f64)]
    pub f_number: f64,
    /// Lens focal length, mm (Pixel 4a: 4.38; sets the pupil the defocus is given over).
    #[arg(long, default_value_t = 4.38, value_parser = common::positive_f64)]
    pub focal_length_mm: f64,
    /// Wavelength of the lens MTF, nm.
    #[arg(long, default_value_t = 550.0, value_parser = common::positive_f64)]
    pub wavelength_nm: f64,
    /// Pixel pitch, um (Pixel 4a: 1.4); 0 leaves the pixel aperture out.
    #[arg(long, default_value_t = 1.4, value_parser = common::non_negative_f64)]
    pub pixel_pitch_um: f64,
    /// PNG plot of measurement and fit, a `.png` file (default: mtf_fit.png in --out).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also print fit.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for fit.json, mtf.csv and the plot (created if missing).
    #[arg(long, default_value = "out/fit-mtf")]
    pub out: PathBuf,
    /// Overwrite the --plot file even when camsim did not write it (a plot camsim wrote is
    /// replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    if let Some(p) = &a.plot {
        if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            bail!(
                "--plot '{}': the plot is a PNG file; give a name ending in .png",
                p.display()
            );
        }
    }
    let m = read_mtf_csv(&a.measured)?;
    let fit = FitParams {
        defocus: a.fit.iter().any(|s| s == "defocus"),
        crosstalk: a.fit.iter().any(|s| s == "crosstalk"),
    };
    if !(fit.defocus || fit.crosstalk) {
        bail!("--fit: name defocus, crosstalk or both");
    }
    let start = SystemMtfModel {
        f_number: a.f_number,
        focal_length_mm: a.focal_length_mm,
        wavelength_nm: a.wavelength_nm,
        pixel_pitch_um: a.pixel_pitch_um,
        fill_factor: 1.0,
        defocus_um: a.defocus_um,
        crosstalk_sigma_um: a.crosstalk_um,
    };
    let opts = MtfFitOptions {
        fit,
        max_freq_cyc_per_mm: a.max_freq,
        ..MtfFitOptions::default()
    };
    let report = fit_measured_mtf(m, &start, &opts)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.measured.display()))?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.measured.as_path()])?;
    let (plot_path, _claim) = match &a.plot {
        Some(p) => (p.clone(), Some(common::claim_out_file(p, a.force)?)),
        None => (staged.join("mtf_fit.png"), None),
    };
    let title = a
        .measured
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    report.write_files(staged.path(), &plot_path, &title)?;
    let result = &report.fit;
    if a.json {
        println!("{}", serde_json::to_string_pretty(result)?);
    }
    let f50 = |v: Option<f64>| v.map_or("none".to_string(), |x| format!("{x:.1}"));
    say(format!(
        "defocus {:.4} um over the {:.3} mm lens pupil ({:.3} waves at {} nm; {:.3} um over 8 mm), crosstalk sigma {:.3} um; \
RMS {:.4} over {} points (largest {:.4}); MTF50 fit {} vs measured {} cycles/mm",
        result.defocus_um,
        a.focal_length_mm / a.f_number,
        result.defocus_waves,
        a.wavelength_nm,
        result.defocus_um_over_8mm,
        result.crosstalk_sigma_um,
        result.rms,
        result.points,
        result.max_abs,
        f50(result.mtf50_fit_cyc_per_mm),
        f50(result.mtf50_measured_cyc_per_mm)
    ));
    common::commit(staged)?;
    Ok(())
}
