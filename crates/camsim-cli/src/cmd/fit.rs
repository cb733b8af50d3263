//! `camsim fit`: fit model parameters to measurements.

use crate::common::{self, say};
use anyhow::{bail, Context, Result};
use camsim_analysis::qefit::{self, MatrixForm};
use camsim_core::{tables, WavelengthGrid};
use camsim_io::measurements::read_qe_means;
use camsim_io::plot::{ScatterPlot, Series};
use std::fmt::Write as _;
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
    let sensor = camsim_pipeline::load_sensor(&a.sensor)?;
    let grid = WavelengthGrid::default();
    let refl = tables::macbeth_reflectances();
    // Measured rows (the file is checked before the lights are loaded).
    let rows = read_qe_means(&a.measured)?;
    let cmfs = camsim_core::colorimetry::Cmfs::on(&grid);
    let mut lights = std::collections::HashMap::new();
    for name in &a.lights {
        let s = camsim_scene::load_illuminant(name, "--lights")?;
        // Scale so the white patch (19) reaches the luminance.
        let white: Vec<f64> = refl[18].product_on(&s, &grid);
        let k = a.luminance_cd_m2 / cmfs.luminance_cd_m2(&white);
        lights.insert(name.clone(), s.scaled(k));
    }
    let mut measured = Vec::new();
    let mut radiances = Vec::new();
    for row in &rows {
        let light = lights.get(&row.light).with_context(|| {
            format!(
                "{}, line {}: light '{}' is not in --lights",
                a.measured.display(),
                row.line,
                row.light
            )
        })?;
        measured.push(row.rgb);
        radiances.push(refl[row.patch - 1].product_on(light, &grid));
    }
    // Etendue x time: pi / (1 + 4 N^2) x photodetector area x exposure (ISETCam oiCalculateIrradiance).
    let scale = std::f64::consts::PI / (1.0 + 4.0 * a.f_number * a.f_number)
        * sensor.photodetector_area_m2()
        * a.exposure_ms
        * 1e-3;
    let k = sensor.k_dn_per_e();
    let predicted: Vec<[f64; 3]> =
        qefit::predict_rgb(&sensor.channel_qe(&grid), &grid, &radiances, scale)?
            .into_iter()
            .map(|e| e.map(|v| v * k))
            .collect();
    let fit = qefit::fit_qe_matrix(&measured, &predicted, form)?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.measured.as_path()])?;
    let out = staged.path().to_path_buf();
    let after = qefit::apply_matrix(&predicted, &fit.m);
    let mut csv = String::from("row,meas_r,meas_g,meas_b,pred_r,pred_g,pred_b,fit_r,fit_g,fit_b\n");
    for (i, ((m, p), q)) in measured.iter().zip(&predicted).zip(&after).enumerate() {
        writeln!(
            csv,
            "{i},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
            m[0], m[1], m[2], p[0], p[1], p[2], q[0], q[1], q[2]
        )?;
    }
    camsim_io::atomic::write_bytes_atomic(&out.join("residuals.csv"), csv.as_bytes())?;
    for (file, title, pts) in [
        ("scatter_before.png", "Published QE", &predicted),
        ("scatter_after.png", "Corrected QE (fitted M)", &after),
    ] {
        let series = (0..3)
            .map(|c| {
                let mut s = Series::new(
                    ["R", "G", "B"][c],
                    measured
                        .iter()
                        .zip(pts.iter())
                        .map(|(m, p)| (m[c], p[c]))
                        .collect(),
                );
                s.color = Some([[220, 40, 40], [30, 160, 60], [40, 80, 220]][c]);
                s
            })
            .collect();
        ScatterPlot {
            title: title.into(),
            x_label: "measured (DN)".into(),
            y_label: "predicted (DN)".into(),
            series,
            identity_line: true,
            range: None,
        }
        .write_png(&out.join(file), 700, 700)?;
    }
    // The corrected sensor: compose with any correction it already has.
    let mut cfg = sensor.config().clone();
    let m = match cfg.qe_correction {
        Some(old) => camsim_isp::color::mat3_mul(&old, &fit.m),
        None => fit.m,
    };
    cfg.qe_correction = Some(m);
    cfg.name = format!("{} (QE corrected)", cfg.name);
    camsim_io::atomic::write_bytes_atomic(
        &out.join("sensor_corrected.toml"),
        toml::to_string_pretty(&cfg)?.as_bytes(),
    )?;
    camsim_io::atomic::write_json_atomic(&out.join("fit.json"), &fit)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&fit)?);
    }
    say(format!(
        "M = [{:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}], RMS {:.2} -> {:.2} DN; corrected sensor: {}",
        fit.m[0][0], fit.m[0][1], fit.m[0][2], fit.m[1][0], fit.m[1][1], fit.m[1][2], fit.m[2][0], fit.m[2][1], fit.m[2][2],
        fit.rms_before, fit.rms_after, out.join("sensor_corrected.toml").display()
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
