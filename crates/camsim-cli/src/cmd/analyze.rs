//! `camsim analyze`: measurements on camsim outputs and real camera raw files.

use crate::common::{self, say};
use anyhow::{bail, Context, Result};
use camsim_analysis::chart::{self, ChartCorners};
use camsim_analysis::sfr::{self, SfrOptions, SfrResult};
use camsim_analysis::{Plane, Rect};
use camsim_core::{CfaChannel, CfaPattern};
use camsim_io::measurements::read_sfr_csv;
use camsim_io::plot::{LinePlot, ScatterPlot, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum Command {
    Sfr(SfrArgs),
    Chart(ChartArgs),
    Roi(RoiArgs),
    Emva(EmvaArgs),
    Demosaic(crate::cmd::demosaic_zone_plate::Args),
}

/// Where a raw file's CFA and levels come from when the file does not say (PNG/TIFF mosaics).
#[derive(clap::Args, Clone)]
pub struct RawInput {
    /// CFA pattern of a PNG/TIFF mosaic (DNG files carry their own).
    #[arg(long, value_parser = parse_cfa)]
    pub cfa: Option<CfaPattern>,
    /// Black level of a PNG/TIFF mosaic, DN.
    #[arg(long, default_value_t = 0.0, value_parser = crate::common::non_negative_f64)]
    pub black_dn: f64,
    /// ADC bits of a PNG/TIFF mosaic.
    #[arg(long, default_value_t = 16)]
    pub bits: u32,
}

fn parse_cfa(s: &str) -> std::result::Result<CfaPattern, String> {
    CfaPattern::parse(s).map_err(|e| e.to_string())
}

/// `row,col,rows,cols` in pixels.
pub fn parse_rect(s: &str) -> std::result::Result<Rect, String> {
    let v: Vec<usize> = s
        .split(',')
        .map(|t| t.trim().parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}': use ROW,COL,ROWS,COLS (whole pixels)"))?;
    match v.as_slice() {
        [r, c, h, w] if *h > 0 && *w > 0 => Ok(Rect::new(*r, *c, *h, *w)),
        _ => Err(format!("'{s}': use ROW,COL,ROWS,COLS with ROWS, COLS > 0")),
    }
}

fn parse_points(s: &str) -> std::result::Result<Vec<f64>, String> {
    s.split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{s}': not a list of numbers"))
        })
        .collect()
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    Ok(camsim_io::atomic::write_bytes_atomic(
        path,
        text.as_bytes(),
    )?)
}

// ---------------------------------------------------------------------------------------------
/// ISO 12233 slanted-edge SFR (e-SFR, as Burns' sfrmat): per colour channel on raw CFA data
/// (each channel on its own sub-grid, no demosaicking), on the luminance of the bilinear-demosaicked
/// image, or on a camsim irradiance EXR.
///
/// One frequency unit everywhere (console, sfr.json, sfr.csv, sfr.png): cycles per sensor pixel,
/// and cycles/mm on the sensor when the pixel pitch is known (camsim DNGs record it; else
/// --pitch-um). The SFR of a CFA channel reaches 0.25 cycles per sensor pixel at its own
/// Nyquist (its samples are 2 sensor pixels apart). Writes, in --out: sfr.csv (columns
/// freq_cyc_per_sensor_px, freq_cyc_per_mm when the pitch is known, then mtf_R, mtf_G, mtf_B,
/// mtf_luminance), sfr.json (per curve: MTF50 in both units, the SFR at the curve's Nyquist, the
/// edge angle, the ROI in sensor pixels) and sfr.png; --compare overlays curves from other sfr.csv
/// files (simulated vs measured, as the paper's Figure 2).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim simulate examples/slanted-edge.toml --out out/edge\n  camsim analyze sfr out/edge/raw.dng --out out/edge-sfr\n  camsim analyze sfr out/edge/raw.dng --roi 40,90,176,80 --quadratic --compare out/edge-sfr/sfr.csv --out out/edge-sfr-roi\n  camsim analyze sfr out/edge/raw.dng --pitch-um 1.4 --json --out out/edge-sfr-json"
)]
pub struct SfrArgs {
    /// Raw DNG, 16-bit PNG/TIFF mosaic (with --cfa), or spectral irradiance EXR.
    pub image: PathBuf,
    /// Region of interest ROW,COL,ROWS,COLS in sensor pixels (default: found around the slanted
    /// edge of largest contrast; a scene's vertical or horizontal frame is passed over).
    #[arg(long, value_parser = parse_rect)]
    pub roi: Option<Rect>,
    /// Fit the edge with a 2nd-order polynomial (lens distortion) instead of a line.
    #[arg(long)]
    pub quadratic: bool,
    /// Sensor pixel pitch, um, for cycles/mm (DNGs from camsim record it; for an EXR it also
    /// defines the "sensor pixel" of the frequency axis, default the EXR's sample spacing).
    #[arg(long, value_parser = parse_pitch_um)]
    pub pitch_um: Option<f64>,
    /// Overlay the curves of another sfr.csv (repeat for several).
    #[arg(long)]
    pub compare: Vec<PathBuf>,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print sfr.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for sfr.csv, sfr.json and sfr.png (created if missing).
    #[arg(long, default_value = "out/sfr")]
    pub out: PathBuf,
}

fn parse_pitch_um(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!(
            "'{s}': give the pixel pitch in um, a number > 0 (e.g. 1.4)"
        )),
    }
}

/// Named SFR curves.
type Curves = Vec<(String, SfrResult)>;

/// The SFR curves of the image, and the sensor pixel pitch in mm when known.
fn sfr_curves(a: &SfrArgs) -> Result<(Curves, Option<f64>)> {
    let ext = a
        .image
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let mut opts = SfrOptions {
        poly_order: if a.quadratic { 2 } else { 1 },
        ..SfrOptions::default()
    };
    if ext == "exr" {
        // Irradiance: a photopic-weighted sum of the bands, at the image's own sampling.
        let img = common::read_spectral_exr(&a.image)?;
        let cmfs = camsim_core::colorimetry::Cmfs::on(&img.grid);
        let mut y = vec![0f32; img.pixels()];
        for b in 0..img.bands() {
            let w = cmfs.y[b] as f32;
            for (o, v) in y.iter_mut().zip(img.band(b)) {
                *o += w * v;
            }
        }
        let spacing_mm = img.sample_spacing_m * 1e3;
        if !(spacing_mm > 0.0 && spacing_mm.is_finite()) {
            bail!("{}: the EXR records no sample spacing", a.image.display());
        }
        // Cycles/mm from the EXR's own sample spacing; "sensor pixel" = --pitch-um (or a sample).
        opts.pixel_pitch_mm = Some(spacing_mm);
        let pitch_mm = a.pitch_um.map(|p| p * 1e-3).unwrap_or(spacing_mm);
        let plane = Plane::new(img.rows, img.cols, y)?;
        let mut r = sfr::sfr(&plane, a.roi, &opts)?;
        let to_sensor_px = pitch_mm / spacing_mm; // cycles per sample -> cycles per sensor pixel
        r.freq_cyc_per_sensor_px = r
            .freq_cyc_per_sample
            .iter()
            .map(|f| f * to_sensor_px)
            .collect();
        r.mtf50_cyc_per_sensor_px = r.mtf50_cyc_per_sample.map(|f| f * to_sensor_px);
        r.nyquist_cyc_per_sensor_px = 0.5 * to_sensor_px;
        r.sample_pitch_sensor_px = 1.0 / to_sensor_px;
        return Ok((vec![("luminance".into(), r)], Some(pitch_mm)));
    }
    let raw = camsim_pipeline::load_raw(&a.image, a.raw.cfa, a.raw.black_dn, a.raw.bits)?;
    let pitch_mm = a
        .pitch_um
        .map(|p| p * 1e-3)
        .or((raw.pixel_pitch_m > 0.0 && raw.pixel_pitch_m.is_finite())
            .then_some(raw.pixel_pitch_m * 1e3));
    opts.pixel_pitch_mm = pitch_mm;
    // The ROI is found once on the whole mosaic (all channels share it).
    let roi = match a.roi {
        Some(r) => r,
        None => {
            sfr::find_edge_roi(&camsim_analysis::image::raw_plane(&raw)?).with_context(|| {
                format!(
                    "{}: finding the slanted edge (give --roi)",
                    a.image.display()
                )
            })?
        }
    };
    let mut out = Vec::new();
    for ch in [CfaChannel::R, CfaChannel::G, CfaChannel::B] {
        let r = sfr::sfr_raw_channel(&raw, ch, Some(roi), &opts).with_context(|| {
            format!(
                "{}: SFR of channel {} in ROI {roi}",
                a.image.display(),
                ch.letter()
            )
        })?;
        out.push((format!("{}", ch.letter()), r));
    }
    let rgb = camsim_isp::demosaic_bilinear(&raw);
    let planes = [0, 1, 2].map(|c| Plane::new(rgb.rows, rgb.cols, rgb.plane(c).to_vec()));
    let [r, g, b] = planes;
    let planes = [r?, g?, b?];
    // Luminance weights of ISO 12233 (Rec. 601 luma) for the demosaicked image.
    let lum = sfr::sfr_luminance(&planes, [0.299, 0.587, 0.114], Some(roi), &opts)
        .with_context(|| format!("{}: SFR of the luminance in ROI {roi}", a.image.display()))?;
    out.push(("luminance".into(), lum));
    Ok((out, pitch_mm))
}

/// The sfr.json document: per curve, MTF50 in cycles per sensor pixel and cycles/mm.
fn sfr_json(
    a: &SfrArgs,
    curves: &[(String, SfrResult)],
    pitch_mm: Option<f64>,
    roi: Option<Rect>,
) -> serde_json::Value {
    let summary: Vec<serde_json::Value> = curves
        .iter()
        .map(|(name, c)| {
            serde_json::json!({
                "curve": name,
                "mtf50_cyc_per_sensor_px": c.mtf50_cyc_per_sensor_px,
                "mtf50_cyc_per_mm": c.mtf50_cyc_per_sensor_px.and_then(|f| pitch_mm.map(|p| f / p)),
                "nyquist_cyc_per_sensor_px": c.nyquist_cyc_per_sensor_px,
                "mtf_at_nyquist": c.mtf_at_nyquist,
                "edge_angle_deg": c.edge_angle_deg,
                "rows_used": c.rows_used,
                "sample_pitch_sensor_px": c.sample_pitch_sensor_px,
            })
        })
        .collect();
    serde_json::json!({
        "image": a.image.display().to_string(),
        "frequency_unit": "cycles per sensor pixel (and cycles/mm on the sensor)",
        "pixel_pitch_um": pitch_mm.map(|p| p * 1e3),
        "roi_sensor_px": roi,
        "curves": summary,
    })
}

pub fn sfr_cmd(a: SfrArgs) -> Result<()> {
    for p in &a.compare {
        read_sfr_csv(p)?; // check before measuring
    }
    let (curves, pitch_mm) = sfr_curves(&a)?;
    // The ROI in sensor pixels: the luminance curve's (the last; full-resolution plane).
    let roi = curves.last().map(|c| c.1.roi);
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    let out = staged.path().to_path_buf();
    // CSV on a common frequency axis (cycles per sensor pixel), one column per curve.
    let f_axis: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
    let mut csv = String::from("freq_cyc_per_sensor_px");
    if pitch_mm.is_some() {
        csv.push_str(",freq_cyc_per_mm");
    }
    for (name, _) in &curves {
        write!(csv, ",mtf_{name}")?;
    }
    csv.push('\n');
    for f in &f_axis {
        write!(csv, "{f:.3}")?;
        if let Some(p) = pitch_mm {
            write!(csv, ",{:.4}", f / p)?;
        }
        for (_, c) in &curves {
            let v = if *f <= *c.freq_cyc_per_sensor_px.last().unwrap_or(&0.0) {
                sfr::interp(&c.freq_cyc_per_sensor_px, &c.mtf, *f)
            } else {
                f64::NAN
            };
            write!(csv, ",{v:.5}")?;
        }
        csv.push('\n');
    }
    write_text(&out.join("sfr.csv"), &csv)?;
    let json = sfr_json(&a, &curves, pitch_mm, roi);
    camsim_io::atomic::write_json_atomic(&out.join("sfr.json"), &json)?;
    let mut series: Vec<Series> = curves
        .iter()
        .map(|(name, c)| {
            Series::new(
                name.clone(),
                c.freq_cyc_per_sensor_px
                    .iter()
                    .zip(&c.mtf)
                    .filter(|(f, _)| **f <= 1.0)
                    .map(|(f, m)| (*f, *m))
                    .collect(),
            )
        })
        .collect();
    for path in &a.compare {
        for c in read_sfr_csv(path)? {
            series.push(dashed(
                format!("{} ({})", c.name.trim_start_matches("mtf_"), path.display()),
                c.points,
            ));
        }
    }
    LinePlot {
        title: format!("ISO 12233 SFR: {}", a.image.display()),
        x_label: "spatial frequency (cycles per sensor pixel)".into(),
        y_label: "SFR".into(),
        series,
        x_range: Some((0.0, 1.0)),
        y_range: Some((0.0, 1.1)),
    }
    .write_png(&out.join("sfr.png"), 900, 600)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    for (name, c) in &curves {
        say(format!(
            "{name:>10}: MTF50 {} cycles/sensor-pixel{}, SFR {:.3} at its Nyquist ({} cycles/sensor-pixel), edge {:.2} deg",
            c.mtf50_cyc_per_sensor_px.map(|v| format!("{v:.4}")).unwrap_or_else(|| "(not reached)".into()),
            c.mtf50_cyc_per_sensor_px.and_then(|f| pitch_mm.map(|p| format!(" = {:.1} cycles/mm", f / p))).unwrap_or_default(),
            c.mtf_at_nyquist,
            c.nyquist_cyc_per_sensor_px,
            c.edge_angle_deg
        ));
    }
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
/// An image for chart and region statistics: a raw CFA mosaic (each channel on its own pixels),
/// or demosaiced RGB planes above black (a LinearRaw DNG, as phones write).
enum StatsImage {
    Raw(camsim_core::RawImage),
    Rgb {
        planes: Box<[Plane; 3]>,
        exposure_s: f64,
    },
}

impl StatsImage {
    fn size(&self) -> (usize, usize) {
        match self {
            StatsImage::Raw(r) => (r.rows, r.cols),
            StatsImage::Rgb { planes, .. } => (planes[0].rows, planes[0].cols),
        }
    }
    fn exposure_s(&self) -> f64 {
        match self {
            StatsImage::Raw(r) => r.exposure_s,
            StatsImage::Rgb { exposure_s, .. } => *exposure_s,
        }
    }
    fn pixel_pitch_m(&self, pitch_linear_m: f64) -> f64 {
        match self {
            StatsImage::Raw(r) => r.pixel_pitch_m,
            StatsImage::Rgb { .. } => pitch_linear_m,
        }
    }
    fn kind(&self) -> &'static str {
        match self {
            StatsImage::Raw(_) => "raw CFA (each channel on its own pixels)",
            StatsImage::Rgb { .. } => "LinearRaw RGB",
        }
    }
}

/// A DNG (CFA or LinearRaw) or a PNG/TIFF mosaic; the second value is a LinearRaw DNG's pixel pitch.
fn load_stats_image(path: &Path, raw: &RawInput) -> Result<(StatsImage, f64)> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext != "dng" {
        return Ok((
            StatsImage::Raw(camsim_pipeline::load_raw(
                path,
                raw.cfa,
                raw.black_dn,
                raw.bits,
            )?),
            0.0,
        ));
    }
    Ok(match camsim_io::dng::read_dng_image(path)?.0 {
        camsim_io::dng::DngImage::Cfa(r) => (StatsImage::Raw(r), 0.0),
        camsim_io::dng::DngImage::LinearRaw(l) => {
            let plane = |k: usize| {
                let data = (0..l.rows * l.cols)
                    .map(|i| (l.dn[i * 3 + k] as f64 - l.black_level_dn[k]) as f32)
                    .collect();
                Plane::new(l.rows, l.cols, data)
            };
            let planes = Box::new([plane(0)?, plane(1)?, plane(2)?]);
            (
                StatsImage::Rgb {
                    planes,
                    exposure_s: l.exposure_s,
                },
                l.pixel_pitch_m,
            )
        }
    })
}

/// `X,Y,X,Y,X,Y,X,Y`: the chart's four corners in pixels.
pub(crate) fn parse_corners(s: &str) -> std::result::Result<ChartCorners, String> {
    let v = parse_points(s)?;
    if v.len() != 8 || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("'{s}': give 8 finite numbers X,Y of the top-left, top-right, bottom-right and bottom-left corners, got {}", v.len()));
    }
    Ok(ChartCorners {
        top_left: [v[0], v[1]],
        top_right: [v[2], v[3]],
        bottom_right: [v[4], v[5]],
        bottom_left: [v[6], v[7]],
    })
}

/// The chart's corners for a camsim DNG: from the run.json beside it (the scene's chart size,
/// field of view and distance, the lens and the sensor window), as camsim-pipeline images it.
pub(crate) fn corners_from_run_json(
    image: &Path,
    rows: usize,
    cols: usize,
    pitch_m: f64,
) -> Result<ChartCorners> {
    let run = image.with_file_name("run.json");
    if !run.is_file() {
        bail!(
            "{}: no --corners given and no run.json beside it (camsim simulate writes one); give the chart's corners with --corners X,Y,X,Y,X,Y,X,Y",
            image.display()
        );
    }
    let text = common::read_text(&run)?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", run.display()))?;
    let cfg: camsim_pipeline::SimulateConfig =
        serde_json::from_value(v.get("config").cloned().unwrap_or_default())
            .with_context(|| format!("{}: key 'config' is not a camsim config", run.display()))?;
    let optics: camsim_optics::OpticsConfig =
        serde_json::from_value(v.get("optics").cloned().unwrap_or_default())
            .with_context(|| format!("{}: key 'optics' is not a lens config", run.display()))?;
    // The sensor's own pitch (the DNG's FocalPlaneXResolution is a rounded rational).
    let pitch_m = v
        .pointer("/sensor/pixel_pitch_um")
        .and_then(|p| p.as_f64())
        .map(|p| p * 1e-6)
        .unwrap_or(pitch_m);
    let c = camsim_pipeline::macbeth_chart_corners_px(&cfg, &optics, pitch_m, rows, cols)
        .with_context(|| format!("{}: cannot place the chart", run.display()))?
        .with_context(|| {
            format!(
                "{}: the scene is not a macbeth chart; give the chart's corners with --corners",
                run.display()
            )
        })?;
    Ok(ChartCorners {
        top_left: c[0],
        top_right: c[1],
        bottom_right: c[2],
        bottom_left: c[3],
    })
}

/// ColorChecker statistics: the 24 patch regions from the chart's four outer corners (the
/// central --fraction of each patch, as ISETCam's chartRectangles), per-channel mean and sample
/// standard deviation (DN above black) on the raw CFA data (each channel on its own pixels, both
/// greens pooled) or on a LinearRaw DNG's RGB, and a line profile through the gray series on the
/// demosaicked image (the paper's Figure 5). For a DNG written by `camsim simulate` the corners
/// come from the run.json beside it; for other files give --corners. Writes patches.csv,
/// profile.csv, profile.png and chart.json in --out.
#[derive(clap::Args)]
// (Example lines stay under 100 characters: clap wraps help text at the terminal width.)
#[command(
    after_help = "Examples:\n  camsim analyze chart out/simulate/raw.dng --out out/chart\n  camsim analyze chart out/simulate/raw.dng --corners 23,42,617,42,617,438,23,438 --out out/chart2"
)]
pub struct ChartArgs {
    /// Raw DNG (CFA, or LinearRaw RGB), or a 16-bit PNG/TIFF mosaic (with --cfa).
    pub image: PathBuf,
    /// The patch grid's four outer corners, X,Y pixels (X = column, Y = row from the top), in the
    /// order top-left (dark skin), top-right (bluish green), bottom-right (black), bottom-left
    /// (white): 8 numbers. The patch pitch is 1/6 of the width and 1/4 of the height; the outer
    /// corners of the corner patches are close enough. Default: from the run.json beside a
    /// camsim DNG.
    #[arg(long, value_parser = parse_corners, allow_hyphen_values = true, value_name = "X,Y,X,Y,X,Y,X,Y")]
    pub corners: Option<ChartCorners>,
    /// Side of each measured square as a fraction of the patch pitch, in (0, 1].
    #[arg(long, default_value_t = 0.5)]
    pub fraction: f64,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print chart.json (corners, fraction and the 24 patches) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/chart")]
    pub out: PathBuf,
}

pub fn chart_cmd(a: ChartArgs) -> Result<()> {
    let (img, pitch_linear_m) = load_stats_image(&a.image, &a.raw)?;
    let (rows, cols) = img.size();
    let corners = match a.corners {
        Some(c) => c,
        None => corners_from_run_json(&a.image, rows, cols, img.pixel_pitch_m(pitch_linear_m))?,
    };
    let ctx = || {
        format!("{}: chart with corners {corners} (x,y of the dark-skin, bluish-green, black and white corners, inside its {cols} x {rows} pixels)", a.image.display())
    };
    // Everything is measured before a file is written (no partial output on bad input).
    let (patches, planes) = match &img {
        StatsImage::Raw(raw) => {
            let patches =
                chart::chart_patch_stats_raw(raw, &corners, a.fraction).with_context(ctx)?;
            // Bilinear demosaic, black subtracted (camsim-isp).
            let rgb = camsim_isp::demosaic_bilinear(raw);
            let [r, g, b] =
                [0, 1, 2].map(|k| Plane::new(rgb.rows, rgb.cols, rgb.plane(k).to_vec()));
            (patches, [r?, g?, b?])
        }
        StatsImage::Rgb { planes, .. } => (
            chart::chart_patch_stats_rgb(planes, &corners, a.fraction).with_context(ctx)?,
            (**planes).clone(),
        ),
    };
    // Gray series: the line through the centres of the bottom row.
    let (p0, p1) = corners.row_line(3);
    let n = ((p1[0] - p0[0]).hypot(p1[1] - p0[1]).ceil() as usize).max(2);
    let prof = chart::line_profile(&planes, p0, p1, n).with_context(ctx)?;

    let mut csv = String::from(
        "patch,name,mean_r_dn,mean_g_dn,mean_b_dn,std_r_dn,std_g_dn,std_b_dn,n_r,n_g,n_b\n",
    );
    for p in &patches {
        writeln!(
            csv,
            "{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{}",
            p.index,
            p.name,
            p.mean[0],
            p.mean[1],
            p.mean[2],
            p.std[0],
            p.std[1],
            p.std[2],
            p.n[0],
            p.n[1],
            p.n[2]
        )?;
    }
    let mut pcsv = String::from("distance_px,x,y,r_dn,g_dn,b_dn\n");
    for p in &prof {
        writeln!(
            pcsv,
            "{:.2},{:.2},{:.2},{:.3},{:.3},{:.3}",
            p.distance_px, p.position[0], p.position[1], p.rgb[0], p.rgb[1], p.rgb[2]
        )?;
    }
    let json = serde_json::json!({
        "image": a.image.display().to_string(), "data": img.kind(), "corners": corners, "fraction": a.fraction, "patches": patches,
    });
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    let out = staged.path().to_path_buf();
    write_text(&out.join("patches.csv"), &csv)?;
    write_text(&out.join("profile.csv"), &pcsv)?;
    let ch = |k: usize, name: &str, col: [u8; 3]| {
        let mut s = Series::new(
            name.to_string(),
            prof.iter().map(|p| (p.distance_px, p.rgb[k])).collect(),
        );
        s.color = Some(col);
        s
    };
    LinePlot {
        title: "Digital values along the gray series".into(),
        x_label: "distance along the line (pixels)".into(),
        y_label: "digital value above black (DN)".into(),
        series: vec![
            ch(0, "R", [220, 40, 40]),
            ch(1, "G", [30, 160, 60]),
            ch(2, "B", [40, 80, 220]),
        ],
        x_range: None,
        y_range: None,
    }
    .write_png(&out.join("profile.png"), 900, 500)?;
    camsim_io::atomic::write_json_atomic(&out.join("chart.json"), &json)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    say(format!(
        "24 patches ({}) -> {}",
        img.kind(),
        a.out.join("patches.csv").display()
    ));
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
/// Mean and sample standard deviation per colour channel (DN above black) in rectangles of one
/// image, or of two side by side (simulated and measured), with scatter plots of the means and of
/// the standard deviations (the paper's Figure 6) and, with --sensor, the temporal noise the
/// sensor model predicts at each mean level. Raw CFA data are measured on each channel's own
/// pixels (both greens pooled); a LinearRaw DNG on its RGB planes. Writes roi.csv and roi.json
/// (and means.png, stds.png for two images) in --out.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim analyze roi out/simulate/raw.dng --region 200,300,40,40 --sensor pixel4a --out out/roi\n  camsim analyze roi out/simulate/raw.dng --region 60,40,20,20 --region 400,580,20,20 --out out/roi2"
)]
pub struct RoiArgs {
    /// First image (simulated): raw DNG (CFA or LinearRaw RGB), or a 16-bit PNG/TIFF mosaic (with --cfa).
    pub a: PathBuf,
    /// Second image (measured), same kinds; omit to analyze one image.
    pub b: Option<PathBuf>,
    /// Rectangle ROW,COL,ROWS,COLS in pixels (repeat for more; the same in both images unless
    /// --region-b is given).
    #[arg(long = "region", value_parser = parse_rect, required = true, value_name = "ROW,COL,ROWS,COLS")]
    pub regions: Vec<Rect>,
    /// Rectangles ROW,COL,ROWS,COLS in the second image, when they differ (as many as --region).
    #[arg(long = "region-b", value_parser = parse_rect, value_name = "ROW,COL,ROWS,COLS")]
    pub regions_b: Vec<Rect>,
    /// Sensor model for the predicted temporal noise of the first image (a preset such as
    /// pixel4a, or a sensor TOML file); uses the first image's exposure time.
    #[arg(long)]
    pub sensor: Option<String>,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print roi.json (per region and channel: rect, mean_dn, std_dn, n) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/roi")]
    pub out: PathBuf,
}

fn region_stats(
    img: &StatsImage,
    rects: &[Rect],
) -> Result<Vec<camsim_analysis::roi::RegionStats>> {
    Ok(match img {
        StatsImage::Raw(r) => camsim_analysis::roi::roi_stats_raw(r, rects)?,
        StatsImage::Rgb { planes, .. } => camsim_analysis::roi::roi_stats_rgb(planes, rects)?,
    })
}

pub fn roi_cmd(a: RoiArgs) -> Result<()> {
    if a.b.is_none() && !a.regions_b.is_empty() {
        bail!("--region-b needs a second image");
    }
    if !a.regions_b.is_empty() && a.regions_b.len() != a.regions.len() {
        bail!(
            "--region-b: give as many as --region ({}), got {}",
            a.regions.len(),
            a.regions_b.len()
        );
    }
    let ra = load_stats_image(&a.a, &a.raw)?.0;
    let rb =
        a.b.as_ref()
            .map(|p| load_stats_image(p, &a.raw).map(|x| x.0))
            .transpose()?;
    let rects_b: Vec<Rect> = a
        .regions
        .iter()
        .enumerate()
        .map(|(i, r)| a.regions_b.get(i).copied().unwrap_or(*r))
        .collect();
    let sensor = a
        .sensor
        .as_deref()
        .map(camsim_pipeline::load_sensor)
        .transpose()?;
    let predict = |mean_dn: f64, exposure_s: f64| {
        sensor
            .as_ref()
            .map(|s| s.predicted_noise_dn(mean_dn, exposure_s).total)
    };
    let stats_a = region_stats(&ra, &a.regions).with_context(|| a.a.display().to_string())?;
    let stats_b = match (&rb, &a.b) {
        (Some(rb), Some(pb)) => {
            Some(region_stats(rb, &rects_b).with_context(|| pb.display().to_string())?)
        }
        _ => None,
    };
    let mut csv =
        String::from("region,channel,mean_a_dn,std_a_dn,predicted_std_a_dn,mean_b_dn,std_b_dn\n");
    let (mut means, mut stds) = (Vec::new(), Vec::new());
    for (i, sa) in stats_a.iter().enumerate() {
        for c in 0..3 {
            let pa = predict(sa.mean_dn[c], ra.exposure_s());
            let (mb, sb) = stats_b
                .as_ref()
                .map(|s| (s[i].mean_dn[c], s[i].std_dn[c]))
                .unwrap_or((f64::NAN, f64::NAN));
            writeln!(
                csv,
                "{i},{},{:.3},{:.3},{},{:.3},{:.3}",
                ["R", "G", "B"][c],
                sa.mean_dn[c],
                sa.std_dn[c],
                pa.map(|v| format!("{v:.3}")).unwrap_or_default(),
                mb,
                sb
            )?;
            if stats_b.is_some() {
                means.push((mb, sa.mean_dn[c]));
                stds.push((sb, sa.std_dn[c]));
            }
        }
    }
    let json = serde_json::json!({ "a": stats_a, "b": stats_b, "data_a": ra.kind(), "data_b": rb.as_ref().map(|r| r.kind()) });
    let inputs: Vec<&std::path::Path> = std::iter::once(a.a.as_path())
        .chain(a.b.as_deref())
        .collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let out = staged.path().to_path_buf();
    write_text(&out.join("roi.csv"), &csv)?;
    if stats_b.is_some() {
        let label_b =
            a.b.as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_default();
        for (file, title, pts) in [
            ("means.png", "Mean digital values", &means),
            ("stds.png", "Standard deviations", &stds),
        ] {
            ScatterPlot {
                title: title.into(),
                x_label: format!("{label_b} (DN)"),
                y_label: format!("{} (DN)", a.a.display()),
                series: vec![Series::new("regions x channels", pts.clone())],
                identity_line: true,
                range: None,
            }
            .write_png(&out.join(file), 700, 700)?;
        }
    }
    camsim_io::atomic::write_json_atomic(&out.join("roi.json"), &json)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    say(format!(
        "{} region(s) -> {}",
        a.regions.len(),
        a.out.join("roi.csv").display()
    ));
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
/// EMVA 1288 (release 4.0) photon-transfer characterization of a series of flat-field and dark
/// frame pairs at increasing exposure, per colour channel: system gain K (DN/e-), temporal dark
/// noise, DSNU, PRNU, saturation capacity, dark current, QE (when the photon count is known), SNR
/// curve and dynamic range. Writes, in --out: emva.json (every figure, per channel and per level),
/// ptc.png (photon transfer) and snr.png.
///
/// The series is a CSV with one level per line: a header `exposure_s,photons_per_pixel,` then the
/// frame columns, `bright_0,...,bright_<N-1>,dark_0,...,dark_<N-1>` for N frames per level (any
/// column whose name starts with `bright` or `dark` is a frame), e.g. with --frames-per-level 2:
/// `exposure_s,photons_per_pixel,bright_0,bright_1,dark_0,dark_1`. This is what
/// `camsim sensor --emva-series` writes (series.csv); for a real camera, write it yourself. Frame
/// cells are DNG (or PNG/TIFF mosaic, with --cfa) file names relative to the CSV; an empty
/// photons_per_pixel cell means the photon count is unknown (no QE then).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim sensor --emva-series --sensor imx363 --rows 64 --cols 64 --levels 12 --out out/emva\n  camsim analyze emva out/emva/series.csv --out out/emva-report"
)]
pub struct EmvaArgs {
    /// The series CSV (header `exposure_s,photons_per_pixel,bright_0,...,dark_0,...`).
    pub series: PathBuf,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print emva.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for emva.json, ptc.png and snr.png (created if missing).
    #[arg(long, default_value = "out/emva-report")]
    pub out: PathBuf,
}

pub fn emva_cmd(a: EmvaArgs) -> Result<()> {
    crate::cmd::emva::run(a)
}

pub fn run(c: Command) -> Result<()> {
    match c {
        Command::Sfr(a) => sfr_cmd(a),
        Command::Chart(a) => chart_cmd(a),
        Command::Roi(a) => roi_cmd(a),
        Command::Emva(a) => emva_cmd(a),
        Command::Demosaic(a) => crate::cmd::demosaic_zone_plate::run(a),
    }
}

/// A dashed series (model curves beside measured ones).
fn dashed(name: String, points: Vec<(f64, f64)>) -> Series {
    Series {
        dashed: true,
        ..Series::new(name, points)
    }
}
