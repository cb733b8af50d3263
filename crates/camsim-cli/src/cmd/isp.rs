//! `camsim isp`: raw DNG -> demosaic -> white balance -> colour matrix -> sRGB PNG, through the
//! application layer's [`camsim::Isp`].

use crate::common::say;
use anyhow::{bail, Result};
use camsim::analysis::chart::ChartCorners;
use camsim::core::WavelengthGrid;
use camsim::isp::ccm::CcmObjective;
use camsim::isp::cfa_render::RcccClear;
use camsim::isp::defect_correction::DefectCorrection;
use camsim::isp::denoise::Denoise;
use camsim::isp::line_noise::ColumnCorrection;
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

/// A value by the name the configs give it (the ISP's kebab-case names).
fn parse_kebab<T: serde::de::DeserializeOwned>(s: &str) -> std::result::Result<T, String> {
    serde_json::from_value(serde_json::Value::String(s.to_string())).map_err(|e| {
        let e = e.to_string();
        // serde's "unknown variant `x`, expected one of `a`, `b`" names the choices.
        e.split(" at line").next().unwrap_or(&e).to_string()
    })
}

fn parse_sharpen(s: &str) -> std::result::Result<camsim::isp::sharpen::UnsharpMask, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}': give RADIUS_PX,AMOUNT[,THRESHOLD] (numbers)"))?;
    let usm = match v.as_slice() {
        [r, a] => camsim::isp::sharpen::UnsharpMask {
            radius_px: *r,
            amount: *a,
            threshold: 0.0,
        },
        [r, a, t] => camsim::isp::sharpen::UnsharpMask {
            radius_px: *r,
            amount: *a,
            threshold: *t,
        },
        _ => return Err(format!("'{s}': give RADIUS_PX,AMOUNT[,THRESHOLD]")),
    };
    usm.validate().map_err(|e| format!("'{s}': {e}"))?;
    Ok(usm)
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
    after_help = "Examples:\n  camsim isp --in out/raw/raw.dng --sensor pixel4a --illuminant D65 --out out/preview.png\n  camsim isp --in out/raw/raw.dng --demosaic malvar --white-balance gray-world --out out/preview-malvar.png\n  camsim isp --in ../shared/data/dng/canon-550d-colorchecker-passport.dng --demosaic adaptive-laplacian --white-balance white-patch --ccm chart --corners 662,579,1299,572,1303,970,654,977 --out out/canon.png\n  camsim isp --in out/raw-rgbw/raw.dng --sensor pixel4a --out out/preview-rgbw.png\n  camsim isp --in out/raw-quad/raw.dng --sensor pixel4a --bin --out out/preview-quad.png\n  camsim isp --in out/defects/raw.dng --sensor pixel4a --defect-correction detect --denoise nlm --sharpen 1.0,0.5 --out out/defects-corrected.jpg\n  camsim isp --in out/flat/raw.dng --lens-shading out/flat-shading.toml --white-balance gray-world --out out/flat-corrected.png   (the flat field of `camsim fit-shading --help`)"
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
    /// Column and row noise correction first: off, or sensor (subtract the offsets of each
    /// column and row of --sensor's fixed dark frame; the frame must be the sensor's size).
    #[arg(long, default_value = "off", value_parser = parse_kebab::<ColumnCorrection>, value_name = "off|sensor")]
    pub column_correction: ColumnCorrection,
    /// Defect-pixel correction: off, sensor (--sensor's defect list) or detect (pixels off the
    /// median of their same-filter 5 x 5 neighbours by more than --defect-sigmas), each replaced
    /// by that median.
    #[arg(long, default_value = "off", value_parser = parse_kebab::<DefectCorrection>, value_name = "off|sensor|detect")]
    pub defect_correction: DefectCorrection,
    /// Threshold of --defect-correction detect, robust sigmas (1.4826 MAD).
    #[arg(long, default_value_t = 6.0, value_parser = crate::common::positive_f64)]
    pub defect_sigmas: f64,
    /// Denoising of the raw: off, or nlm (non-local means per CFA sub-lattice, Buades, Coll and
    /// Morel 2005, its strength from --sensor's shot and read noise).
    #[arg(long, default_value = "off", value_parser = parse_kebab::<Denoise>, value_name = "off|nlm")]
    pub denoise: Denoise,
    /// Strength of --denoise nlm: h = 0.4 x strength x sigma.
    #[arg(long, default_value_t = 1.0, value_parser = crate::common::positive_f64)]
    pub denoise_strength: f64,
    /// Unsharp mask of the demosaicked image: RADIUS_PX,AMOUNT[,THRESHOLD_DN] (Gaussian sigma in
    /// pixels, gain of the detail, details at most THRESHOLD DN above black left alone).
    #[arg(long, value_parser = parse_sharpen, value_name = "RADIUS_PX,AMOUNT[,THRESHOLD]")]
    pub sharpen: Option<camsim::isp::sharpen::UnsharpMask>,
    /// Tone curve of the preview: clip, reinhard (Reinhard et al. 2002) or filmic (ACES fit,
    /// Narkowicz 2016); the last two also set the exposure.
    #[arg(long, default_value = "clip", value_parser = parse_kebab::<camsim::isp::tone::ToneMap>, value_name = "clip|reinhard|filmic")]
    pub tone_map: camsim::isp::tone::ToneMap,
    /// Lens-shading correction: a shading file `camsim fit-shading` wrote from a flat field; each
    /// pixel's signal above black is divided by its filter's relative illumination (after
    /// --denoise, before the demosaic).
    #[arg(long, value_name = "SHADING.toml")]
    pub lens_shading: Option<PathBuf>,
    /// Fixed exposure scale (linear sRGB = scale x colour matrix x camera DN above black, white
    /// balance included), as `--json` reports it: the same scale renders frames of different brightness
    /// alike, and the scale `camsim unprocess` used gives its photo back. Default: automatic
    /// (the 99th-percentile luminance at 0.9 of white).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub exposure_scale: Option<f64>,
    /// JPEG quality (IJG, 1-100) when --out ends in .jpg or .jpeg.
    #[arg(long, default_value_t = camsim::pipeline::isp::DEFAULT_JPEG_QUALITY, value_parser = clap::value_parser!(u8).range(1..=100))]
    pub jpeg_quality: u8,
    /// Output image: an 8-bit sRGB PNG, or a baseline JPEG when the name ends in .jpg / .jpeg.
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
    isp.column_correction = a.column_correction;
    isp.defect_correction = a.defect_correction;
    isp.defect_sigmas = a.defect_sigmas;
    isp.denoise = a.denoise;
    isp.denoise_strength = a.denoise_strength;
    isp.sharpen = a.sharpen;
    isp.tone_map = a.tone_map;
    isp.exposure_scale = a.exposure_scale;
    if let Some(p) = &a.lens_shading {
        isp.lens_shading = Some(std::sync::Arc::new(
            camsim::optics::shading::ShadingFit::from_file(p)
                .map_err(|e| anyhow::anyhow!("--lens-shading: {e}"))?,
        ));
    }
    isp.jpeg_quality = Some(a.jpeg_quality);
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
    let jpeg = a
        .out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
    if jpeg {
        camsim::io::atomic::write_bytes_atomic(&a.out, &isp.jpeg(p)?)?;
    } else {
        camsim::io::raster::write_png8_rgb(&a.out, p.rows, p.cols, &p.data)?;
    }
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
