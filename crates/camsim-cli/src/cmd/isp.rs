//! `camsim isp`: raw DNG -> demosaic -> white balance -> colour matrix -> sRGB PNG.

use crate::common::say;
use anyhow::{bail, Context, Result};
use camsim_analysis::chart::{self, ChartCorners};
use camsim_analysis::Plane;
use camsim_core::WavelengthGrid;
use camsim_isp::ccm::{self, CcmObjective};
use camsim_isp::output::DisplayModel;
use camsim_isp::white_balance::{self, WHITE_PATCH_PERCENTILE};
use camsim_isp::{ColorPipeline, DemosaicMethod, WhiteBalanceMethod};
use std::path::PathBuf;

/// Where the colour matrix comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CcmSource {
    /// Fitted on the ColorChecker from the sensor's QE under the illuminant (no image data).
    Qe,
    /// Fitted on the ColorChecker photographed in the image (its corners from --corners or the
    /// run.json beside a camsim DNG).
    Chart,
}

fn parse_ccm(s: &str) -> std::result::Result<CcmSource, String> {
    match s {
        "qe" => Ok(CcmSource::Qe),
        "chart" => Ok(CcmSource::Chart),
        _ => Err(format!("'{s}' is not one of qe, chart")),
    }
}

fn parse_str<T: std::str::FromStr<Err = camsim_core::error::CoreError>>(
    s: &str,
) -> std::result::Result<T, String> {
    s.parse::<T>().map_err(|e| e.to_string())
}

fn parse_percentile(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=100.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a percentile in [0, 100]")),
    }
}

/// Demosaic a raw DNG and render an sRGB image. Demosaicking: bilinear (the paper's method),
/// Malvar-He-Cutler 2004 or Hamilton-Adams adaptive. White balance: from the known illuminant and
/// the sensor QE, gray world, white patch, or none. Colour matrix: fitted by least squares on the
/// ColorChecker from the sensor QE under the illuminant (--ccm qe, white balance and Bradford
/// adaptation to D65 included), or on the chart photographed in the image (--ccm chart: the 24
/// patch means after white balance, fitted to the chart's XYZ under D65). Then XYZ -> linear sRGB
/// -> sRGB transfer function (IEC 61966-2-1).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim isp --in out/raw/raw.dng --sensor pixel4a --illuminant D65 --out out/preview.png\n  camsim isp --in out/raw/raw.dng --demosaic malvar --white-balance gray-world --out out/preview-malvar.png\n  camsim isp --in ../shared/data/dng/canon-550d-colorchecker-passport.dng --demosaic adaptive-laplacian --white-balance white-patch --ccm chart --corners 662,579,1299,572,1303,970,654,977 --out out/canon.png\n  camsim isp --in out/raw-rgbw/raw.dng --sensor pixel4a --out out/preview-rgbw.png\n  camsim isp --in out/raw-quad/raw.dng --sensor pixel4a --bin --out out/preview-quad.png"
)]
pub struct Args {
    /// Raw DNG.
    #[arg(long = "in")]
    pub input: PathBuf,
    /// The sensor that made it (its QE sets the colour matrix of --ccm qe and the gains of
    /// --white-balance illuminant): preset or TOML file.
    #[arg(long, default_value = "pixel4a")]
    pub sensor: String,
    /// Scene illuminant for white balance and the colour fit: built-in name or spectrum file.
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Demosaicking method: bilinear, malvar (ISETCam 'laplacian'), adaptive-laplacian (Hamilton-Adams).
    #[arg(long, default_value = "bilinear", value_parser = parse_str::<DemosaicMethod>)]
    pub demosaic: DemosaicMethod,
    /// White balance: illuminant (from --illuminant and the sensor QE), gray-world, white-patch, none.
    #[arg(long, default_value = "illuminant", value_parser = parse_str::<WhiteBalanceMethod>)]
    pub white_balance: WhiteBalanceMethod,
    /// Percentile of R+G+B above which pixels count as white for --white-balance white-patch.
    #[arg(long, default_value_t = WHITE_PATCH_PERCENTILE, value_parser = parse_percentile)]
    pub white_patch_percentile: f64,
    /// Colour matrix: qe (fitted from the sensor QE) or chart (fitted on the ColorChecker in the image).
    #[arg(long, default_value = "qe", value_parser = parse_ccm)]
    pub ccm: CcmSource,
    /// What --ccm chart minimises: linear-srgb, xyz or cielab.
    #[arg(long, default_value = "linear-srgb", value_parser = parse_str::<CcmObjective>)]
    pub ccm_objective: CcmObjective,
    /// The chart's four outer corners for --ccm chart, X,Y pixels of the top-left (dark skin),
    /// top-right, bottom-right (black) and bottom-left (white) corners; default: from the run.json
    /// beside a camsim DNG.
    #[arg(long, value_parser = crate::cmd::analyze::parse_corners, allow_hyphen_values = true, value_name = "X,Y,X,Y,X,Y,X,Y")]
    pub corners: Option<ChartCorners>,
    /// The photographed chart's 24 patch reflectances for --ccm chart (CSV `wavelength_nm` + 24
    /// columns, or an ISETCam `.mat` in macbethChart.mat's layout); default N. Ohta's ColorChecker
    /// (a simulated chart made with `reflectances = FILE` needs the same file here).
    #[arg(long, value_name = "FILE")]
    pub chart_reflectances: Option<PathBuf>,
    /// Also print the gains, the matrix and (--ccm chart) the per-patch CIEDE2000 as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Bin 2x2 same-filter blocks first (Quad Bayer -> Bayer at half the size, 4x the signal).
    #[arg(long)]
    pub bin: bool,
    /// Output PNG.
    #[arg(long, default_value = "out/preview.png")]
    pub out: PathBuf,
    /// Overwrite --out even when camsim did not write it (a file camsim wrote, recognised by its
    /// signature, is replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    let _claim = crate::common::claim_out_file(&a.out, a.force)?;
    // The chart's reflectances serve only the chart fit: read (and check) them before any work.
    let chart_reflectances = match (&a.chart_reflectances, a.ccm) {
        (None, _) => None,
        (Some(p), CcmSource::Chart) => Some(camsim_scene::load_chart_reflectances(p, "--chart-reflectances")?),
        (Some(_), _) => bail!("--chart-reflectances is for --ccm chart (the colour matrix fitted on the photographed chart)"),
    };
    let (raw, _info) = camsim_io::dng::read_dng(&a.input)?;
    let sensor = camsim_pipeline::load_sensor(&a.sensor)?;
    let grid = WavelengthGrid::default();
    let illum = camsim_scene::load_illuminant(&a.illuminant, "--illuminant")?;
    let qe = sensor.channel_qe(&grid);
    let raw = if a.bin {
        camsim_isp::cfa_general::bin_2x2(&raw)?
    } else {
        raw
    };
    let mut rgb = crate::cmd::isp_cfa::demosaic_general(&raw, &sensor, a.demosaic)?;
    let saturation_dn = raw.white_level_dn - raw.black_level_dn;
    let gains = match a.white_balance {
        WhiteBalanceMethod::None => [1.0; 3],
        WhiteBalanceMethod::GrayWorld => white_balance::gray_world_gains(&rgb)?,
        WhiteBalanceMethod::WhitePatch => {
            white_balance::white_patch_gains(&rgb, a.white_patch_percentile, Some(saturation_dn))?
        }
        WhiteBalanceMethod::Illuminant => white_balance::illuminant_gains(&qe, &grid, &illum)?,
    };
    let mut report = serde_json::json!({
        "input": a.input.display().to_string(),
        "demosaic": a.demosaic.name(),
        "white_balance": a.white_balance.name(),
        "white_balance_gains": gains,
    });
    let srgb = match a.ccm {
        CcmSource::Qe => {
            let color = ColorPipeline::fit(&qe, &grid, &illum)?;
            // The pipeline's matrix includes the illuminant's white balance diag(1 / as_shot_neutral).
            // Another method's gains g replace it: camera values are first scaled by
            // as_shot_neutral * g, so what g takes to neutral renders neutral. With the illuminant
            // method the pipeline is used as it is (the paper's preview, unchanged).
            let mut clip = saturation_dn;
            if a.white_balance != WhiteBalanceMethod::Illuminant {
                let asn = color.as_shot_neutral();
                let pre = [asn[0] * gains[0], asn[1] * gains[1], asn[2] * gains[2]];
                white_balance::apply_gains(&mut rgb, pre);
                // Saturated pixels (s in every channel) become s * pre; clip where the channel
                // saturated first so clipped highlights stay neutral.
                clip *= gains.iter().cloned().fold(f64::INFINITY, f64::min);
            }
            report["camera_to_linear_srgb"] = serde_json::json!(color.camera_to_srgb());
            color.render_srgb8_clipped(&rgb, None, Some(clip))
        }
        CcmSource::Chart => {
            white_balance::apply_gains(&mut rgb, gains);
            let corners = match a.corners {
                Some(c) => c,
                None => crate::cmd::analyze::corners_from_run_json(
                    &a.input,
                    raw.rows,
                    raw.cols,
                    raw.pixel_pitch_m,
                )?,
            };
            let planes = [0, 1, 2].map(|c| Plane::new(rgb.rows, rgb.cols, rgb.plane(c).to_vec()));
            let [r, g, b] = planes;
            let planes = [r?, g?, b?];
            let stats = chart::chart_patch_stats_rgb(&planes, &corners, 0.5)
                .context("--ccm chart: measuring the patches")?;
            drop(planes);
            let camera: Vec<[f64; 3]> = stats.iter().map(|s| s.mean).collect();
            let d65 = camsim_core::tables::illuminant("D65")?;
            let (target, white) = match &chart_reflectances {
                Some(r) => ccm::chart_xyz(r, &d65, &grid)?,
                None => ccm::macbeth_xyz(&d65, &grid)?,
            };
            let m =
                ccm::fit_ccm(&camera, &target, white, a.ccm_objective).context("--ccm chart")?;
            let de = ccm::ccm_delta_e2000(&m, &camera, &target, white);
            let mean = de.iter().sum::<f64>() / de.len() as f64;
            let max = de.iter().cloned().fold(0.0, f64::max);
            say(format!(
                "chart fit ({}): CIEDE2000 mean {mean:.2}, max {max:.2} over 24 patches",
                a.ccm_objective
            ));
            if !(mean.is_finite()) {
                bail!("--ccm chart: the fit gave no finite colour error (are the corners on the chart?)");
            }
            report["ccm_objective"] = serde_json::json!(a.ccm_objective.to_string());
            report["camera_to_xyz"] = serde_json::json!(m);
            report["patch_camera_rgb"] = serde_json::json!(camera);
            report["patch_delta_e2000"] = serde_json::json!(de);
            report["delta_e2000_mean"] = serde_json::json!(mean);
            report["delta_e2000_max"] = serde_json::json!(max);
            camsim_isp::output::render_rgb8(&rgb, &m, &DisplayModel::srgb(), 1.0)?
        }
    };
    camsim_io::raster::write_png8_rgb(&a.out, rgb.rows, rgb.cols, &srgb)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    say(format!(
        "wrote {} ({} x {})",
        a.out.display(),
        rgb.cols,
        rgb.rows
    ));
    Ok(())
}
