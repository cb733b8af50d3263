//! `camsim fit`: fit model parameters to measurements.

use crate::common::{self, say};
use anyhow::{bail, Result};
use camsim::analysis::qefit::MatrixForm;
use camsim::io::measurements::read_qe_means;
use camsim::pipeline::measure::qe_fit::{fit_qe, QeFitRequest};
use std::path::PathBuf;

#[derive(clap::Subcommand)]
pub enum Command {
    Qe(QeArgs),
    Mtf(super::fit_mtf::Args),
}

/// Fit the 3x3 matrix M that corrects a sensor's published QE, [r', g', b'] = [r, g, b] M (the
/// paper's eq. 1), to measured mean RGB values of ColorChecker patches under several lights.
///
/// The prediction is physical: the radiance of each patch (light x N. Ohta 1997 reflectance, or
/// --reflectances) is scaled to --luminance-cd-m2, turned into irradiance through a lens of
/// --f-number (E = pi L / (1 + 4 N^2)), integrated with the sensor's QE over the pixel area for
/// --exposure-ms, and converted to DN with the sensor's conversion gain. The fit is least
/// squares: unconstrained, diagonal-only, or the paper's lower-triangular non-negative form.
/// Writes fit.json, residuals.csv, scatter_before.png, scatter_after.png and the corrected
/// sensor as a TOML preset.
#[derive(clap::Args)]
#[command(
    after_help = "The measured CSV has a header `light,patch,r,g,b` (patch 1-24 in the ColorChecker's order, mean DN \
above black of each channel over the patch), one line per light and patch, e.g.\n  D65,1,123.4,210.2,98.7\n\
examples/qe-means-pixel4a.csv holds such values for the pixel4a preset (noise-free, the defaults below).\n\
Examples:\n  camsim fit qe --measured examples/qe-means-pixel4a.csv --sensor imx363 --out out/fit-qe\n  \
camsim fit qe --measured examples/qe-means-pixel4a.csv --lights A,F2,D65 --form unconstrained --json --out out/fit-qe-full"
)]
pub struct QeArgs {
    /// Measured means: CSV `light,patch,r,g,b` (DN above black).
    #[arg(long)]
    pub measured: PathBuf,
    /// The lights, by built-in name (A, D65, F2, F11, ...) or spectrum file, named as in the CSV's
    /// light column (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = ["A".to_string(), "F2".to_string(), "D65".to_string()])]
    pub lights: Vec<String>,
    /// The sensor whose QE is corrected (preset or TOML); its QE, pixel area and gain predict the
    /// patch means.
    #[arg(long, default_value = "imx363")]
    pub sensor: String,
    /// Matrix form: paper (lower-triangular, non-negative, as the paper's M), unconstrained (all 9
    /// entries), diagonal (a gain per channel).
    #[arg(long, default_value = "paper", value_parser = ["paper", "lower", "unconstrained", "full", "diagonal"])]
    pub form: String,
    /// Luminance of a perfect white under each light in the measurement, cd/m^2 (the white patch
    /// 19 is scaled to this).
    #[arg(long, default_value_t = 100.0, value_parser = positive)]
    pub luminance_cd_m2: f64,
    /// Lens f-number of the measurement (sensor irradiance = pi L / (1 + 4 N^2)).
    #[arg(long, default_value_t = 1.73, value_parser = positive)]
    pub f_number: f64,
    /// Exposure time of the measurement, ms.
    #[arg(long, default_value_t = 10.0, value_parser = positive)]
    pub exposure_ms: f64,
    /// Also print fit.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for fit.json, residuals.csv, scatter_before.png, scatter_after.png and
    /// sensor_corrected.toml (created if missing).
    #[arg(long, default_value = "out/fit-qe")]
    pub out: PathBuf,
}

/// A finite number > 0.
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a number > 0")),
    }
}

fn parse_form(s: &str) -> Result<MatrixForm> {
    Ok(match s {
        "paper" | "lower" => MatrixForm::PaperLowerNonNegative,
        "unconstrained" | "full" => MatrixForm::Unconstrained,
        "diagonal" => MatrixForm::Diagonal,
        _ => bail!("--form '{s}': use paper, unconstrained or diagonal"),
    })
}

pub fn qe_cmd(a: QeArgs) -> Result<()> {
    let form = parse_form(&a.form)?;
    let sensor = camsim::pipeline::load_sensor(&a.sensor)?;
    // Measured rows (the file is checked before the lights are loaded).
    let rows = read_qe_means(&a.measured)?;
    let req = QeFitRequest {
        lights: a.lights.clone(),
        luminance_cd_m2: a.luminance_cd_m2,
        f_number: a.f_number,
        exposure_ms: a.exposure_ms,
        form,
    };
    let report = fit_qe(&sensor, &rows, &req, &a.measured.display().to_string())?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.measured.as_path()])?;
    report.write_files(&staged)?;
    let fit = &report.fit;
    if a.json {
        println!("{}", serde_json::to_string_pretty(fit)?);
    }
    let m = &fit.m;
    say(format!(
        "M = [{:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}], RMS {:.2} -> {:.2} DN; corrected sensor: {}",
        m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
        fit.rms_before, fit.rms_after, a.out.join("sensor_corrected.toml").display()
    ));
    common::commit(staged)?;
    Ok(())
}

pub fn run(c: Command) -> Result<()> {
    match c {
        Command::Qe(a) => qe_cmd(a),
        Command::Mtf(a) => super::fit_mtf::run(a),
    }
}
