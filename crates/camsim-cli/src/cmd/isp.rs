//! `camsim isp`: raw DNG -> demosaic -> white balance -> colour matrix -> sRGB PNG, through the
//! application layer's [`camsim::Isp`].

use crate::common::say;
use anyhow::{bail, Result};
use camsim::analysis::chart::ChartCorners;
use camsim::core::WavelengthGrid;
use camsim::isp::ccm::CcmObjective;
use camsim::isp::cfa_render::RcccClear;
use camsim::isp::white_balance::WHITE_PATCH_PERCENTILE;
use camsim::isp::{DemosaicMethod, WhiteBalanceMethod};
use camsim::pipeline::CcmSource;
use camsim::Isp;
use std::path::PathBuf;

/// Where the colour matrix comes from (`--ccm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CcmChoice {
    /// Fitted on the ColorChecker from the sensor's QE under the illuminant (no image data).
    Qe,
    /// Fitted on the ColorChecker photographed in the image (its corners from --corners or the
    /// run.json beside a camsim DNG).
    Chart,
}

fn parse_ccm(s: &str) -> std::result::Result<CcmChoice, String> {
    match s {
        "qe" => Ok(CcmChoice::Qe),
        "chart" => Ok(CcmChoice::Chart),
        _ => Err(format!("'{s}' is not one of qe, chart")),
    }
}

fn parse_str<T: std::str::FromStr<Err = camsim::core::error::CoreError>>(
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
/// -> sRGB transfer function (IEC 61966-2-1). A DNG of another CFA takes its own path: a
/// monochrome frame renders grey (no demosaic); RCCC renders (red, clear, clear), grey for
/// neutral surfaces, the clear channel at the R sites by --rccc-clear; any other tile (CMY, CMYG,
/// RGB-IR, N channels) is demosaicked per channel and taken to sRGB by a 3 x N matrix fitted on the
/// ColorChecker from --sensor's QE of the DNG's filters under --illuminant.
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
    #[arg(long, default_value = "bilinear", value_parser = parse_str::<DemosaicMethod>, help = format!("Demosaicking method:\n{}", camsim::isp::DEMOSAIC_METHODS.listing()))]
    pub demosaic: DemosaicMethod,
    #[arg(long, default_value = "illuminant", value_parser = parse_str::<WhiteBalanceMethod>, help = format!("White balance (illuminant: from --illuminant and the sensor QE):\n{}", camsim::isp::WHITE_BALANCE_METHODS.listing()))]
    pub white_balance: WhiteBalanceMethod,
    /// Percentile of R+G+B above which pixels count as white for --white-balance white-patch.
    #[arg(long, default_value_t = WHITE_PATCH_PERCENTILE, value_parser = parse_percentile)]
    pub white_patch_percentile: f64,
    /// Colour matrix: qe (fitted from the sensor QE) or chart (fitted on the ColorChecker in the image).
    #[arg(long, default_value = "qe", value_parser = parse_ccm)]
    pub ccm: CcmChoice,
    /// What --ccm chart minimises: linear-srgb, xyz or cielab.
    #[arg(long, default_value = "linear-srgb", value_parser = parse_str::<CcmObjective>)]
    pub ccm_objective: CcmObjective,
    /// The chart's four outer corners for --ccm chart, X,Y pixels of the top-left (dark skin),
    /// top-right, bottom-right (black) and bottom-left (white) corners; default: from the run.json
    /// beside a camsim DNG.
    #[arg(long, value_parser = crate::cmd::args::parse_corners, allow_hyphen_values = true, value_name = "X,Y,X,Y,X,Y,X,Y")]
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
    /// RCCC frames: how the clear channel is filled at the R sites: edge-aware (Hamilton-Adams
    /// directional interpolation) or analog (ISETCam's demosaicRCCC cross kernel, after Analog
    /// Devices EE-358).
    #[arg(long, default_value = "edge-aware", value_parser = parse_str::<RcccClear>)]
    pub rccc_clear: RcccClear,
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
        (Some(p), CcmChoice::Chart) => Some(camsim::scene::load_chart_reflectances(p, "--chart-reflectances")?),
        (Some(_), _) => bail!("--chart-reflectances is for --ccm chart (the colour matrix fitted on the photographed chart)"),
    };
    let (raw, _info) = camsim::io::dng::read_dng(&a.input)?;
    let sensor = camsim::pipeline::load_sensor(&a.sensor)?;
    let illuminant = camsim::scene::load_illuminant(&a.illuminant, "--illuminant")?;
    let mut isp = Isp::new(illuminant, WavelengthGrid::default());
    isp.demosaic = a.demosaic;
    isp.white_balance = a.white_balance;
    isp.white_patch_percentile = a.white_patch_percentile;
    isp.bin_2x2 = a.bin;
    isp.rccc_clear = a.rccc_clear;
    if a.ccm == CcmChoice::Chart {
        let corners: ChartCorners = match a.corners {
            Some(c) => c,
            None => {
                // The corners of the frame the ISP sees (binned: half the size).
                let (rows, cols) = if a.bin {
                    (raw.rows / 2, raw.cols / 2)
                } else {
                    (raw.rows, raw.cols)
                };
                camsim::pipeline::records::chart_corners_beside(&a.input, rows, cols)?
            }
        };
        isp.ccm = CcmSource::Chart {
            corners,
            objective: a.ccm_objective,
            reflectances: chart_reflectances,
        };
    }
    let out = isp.compute(&raw, &sensor)?;
    let r = &out.report;
    if let (Some(mean), Some(max)) = (r.delta_e2000_mean, r.delta_e2000_max) {
        say(format!(
            "chart fit ({}): CIEDE2000 mean {mean:.2}, max {max:.2} over 24 patches",
            a.ccm_objective
        ));
    }
    let p = &out.preview;
    camsim::io::raster::write_png8_rgb(&a.out, p.rows, p.cols, &p.data)?;
    if a.json {
        let mut report = serde_json::to_value(r)?;
        report["input"] = a.input.display().to_string().into();
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    say(format!(
        "wrote {} ({} x {})",
        a.out.display(),
        p.cols,
        p.rows
    ));
    Ok(())
}
