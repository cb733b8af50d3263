//! `camsim analyze`: measurements on camsim outputs and real camera raw files. Each subcommand
//! parses its arguments, calls the measurement of `camsim::pipeline::measure` and prints.

use crate::cmd::args::{parse_corners, parse_rect, RawInput};
use crate::common::{self, say};
use anyhow::Result;
use camsim::analysis::chart::ChartCorners;
use camsim::analysis::Rect;
use camsim::pipeline::measure::chart::{measure_chart, ChartRequest};
use camsim::pipeline::measure::roi::{measure_roi, RoiRequest};
use camsim::pipeline::measure::sfr::{measure_sfr, SfrImage, SfrRequest};
use camsim::pipeline::MeasuredImage;
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum Command {
    Sfr(SfrArgs),
    Chart(ChartArgs),
    Roi(RoiArgs),
    Emva(crate::cmd::emva::EmvaArgs),
    Demosaic(crate::cmd::demosaic_zone_plate::Args),
    Glare(GlareArgs),
    #[command(name = "dual-pixel")]
    DualPixel(DualPixelArgs),
    #[command(name = "visual-noise")]
    VisualNoise(VisualNoiseArgs),
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

pub fn sfr_cmd(a: SfrArgs) -> Result<()> {
    for p in &a.compare {
        camsim::io::measurements::read_sfr_csv(p)?; // check before measuring
    }
    let (image, warning) = SfrImage::load(&a.image, &a.raw.format())?;
    if let Some(w) = warning {
        eprintln!("camsim: warning: {w}");
    }
    let name = a.image.display().to_string();
    let req = SfrRequest {
        roi: a.roi,
        quadratic: a.quadratic,
        pixel_pitch_mm: a.pitch_um.map(|p| p * 1e-3),
        label: name.clone(),
    };
    let report = measure_sfr(&image, &req)?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    let json = report.write_files(&staged, &name, &a.compare)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    for line in report.summary() {
        say(line);
    }
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
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
    let img = MeasuredImage::load(&a.image, &a.raw.format())?;
    let (rows, cols) = img.size();
    let corners = match a.corners {
        Some(c) => c,
        None => camsim::pipeline::records::chart_corners_beside(&a.image, rows, cols)?,
    };
    let name = a.image.display().to_string();
    // Everything is measured before a file is written (no partial output on bad input).
    let report = measure_chart(
        &img,
        &ChartRequest {
            corners,
            fraction: a.fraction,
        },
        &name,
    )?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    let json = report.write_files(&staged, &name)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    say(format!(
        "24 patches ({}) -> {}",
        report.data,
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

pub fn roi_cmd(a: RoiArgs) -> Result<()> {
    // The flags' own consistency, named as flags (the measurement checks it too, for Python).
    if a.b.is_none() && !a.regions_b.is_empty() {
        anyhow::bail!("--region-b needs a second image");
    }
    if !a.regions_b.is_empty() && a.regions_b.len() != a.regions.len() {
        anyhow::bail!(
            "--region-b: give as many as --region ({}), got {}",
            a.regions.len(),
            a.regions_b.len()
        );
    }
    let ra = MeasuredImage::load(&a.a, &a.raw.format())?;
    let rb =
        a.b.as_ref()
            .map(|p| MeasuredImage::load(p, &a.raw.format()))
            .transpose()?;
    let req = RoiRequest {
        regions: a.regions.clone(),
        regions_b: a.regions_b.clone(),
        sensor: a
            .sensor
            .as_deref()
            .map(camsim::pipeline::load_sensor)
            .transpose()?,
    };
    let (label_a, label_b) = (
        a.a.display().to_string(),
        a.b.as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
    );
    let report = measure_roi(&ra, rb.as_ref(), &req, [&label_a, &label_b])?;
    let inputs: Vec<&Path> = std::iter::once(a.a.as_path())
        .chain(a.b.as_deref())
        .collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let json = report.write_files(&staged, &label_a, &label_b)?;
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

pub fn run(c: Command) -> Result<()> {
    match c {
        Command::Sfr(a) => sfr_cmd(a),
        Command::Chart(a) => chart_cmd(a),
        Command::Roi(a) => roi_cmd(a),
        Command::Emva(a) => crate::cmd::emva::run(a),
        Command::Demosaic(a) => crate::cmd::demosaic_zone_plate::run(a),
        Command::Glare(a) => glare_cmd(a),
        Command::DualPixel(a) => dual_pixel_cmd(a),
        Command::VisualNoise(a) => visual_noise_cmd(a),
    }
}

// ---------------------------------------------------------------------------------------------
/// Veiling glare on an ISO 18844 target image (a black hole in a bright surround, the
/// `glare_target` scene): the glare index = mean signal over the hole's central disc / mean
/// signal over a surround annulus, both above black. Per colour channel on raw CFA data (each on
/// its own sub-grid), per plane of a LinearRaw DNG, on the band sum of a spectral irradiance EXR,
/// or on a grey PNG/TIFF (without --cfa; --black-dn subtracted). The hole is found as the dark
/// region (below half the median level) at the image centre unless --centre and
/// --hole-diameter-px are given. Writes glare.json in --out.
#[derive(clap::Args)]
#[command(
    after_help = "Examples (the scene, optics and sensor commands of docs/src/analysis.md make the inputs):\n  camsim analyze glare out/glare-raw/raw.dng --out out/glare-index\n  camsim analyze glare out/glare-irradiance.exr --roi-fraction 0.3 --json --out out/glare-exr\n  camsim analyze glare out/glare-irradiance.exr --centre 137,137 --hole-diameter-px 64 --out out/glare-given"
)]
pub struct GlareArgs {
    /// Raw DNG (CFA or LinearRaw), a 16-bit PNG/TIFF mosaic (with --cfa) or grey image (without),
    /// or a spectral irradiance EXR.
    pub image: PathBuf,
    /// The hole's centre X,Y in sensor pixels (X = column, Y = row from the top; default: found).
    #[arg(long, value_parser = parse_xy, value_name = "X,Y")]
    pub centre: Option<[f64; 2]>,
    /// The hole's diameter, sensor pixels (default: from the dark region's area).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub hole_diameter_px: Option<f64>,
    /// Diameter of the averaged central disc as a fraction of the hole's, in (0, 1).
    #[arg(long, default_value_t = 0.2)]
    pub roi_fraction: f64,
    /// Surround annulus INNER,OUTER radii in hole radii (1 <= INNER < OUTER).
    #[arg(long, value_parser = parse_xy, default_value = "1.5,2.5", value_name = "INNER,OUTER")]
    pub surround: [f64; 2],
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print glare.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for glare.json (created if missing).
    #[arg(long, default_value = "out/glare")]
    pub out: PathBuf,
}

fn parse_xy(s: &str) -> std::result::Result<[f64; 2], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}': give two numbers A,B"))?;
    match v.as_slice() {
        [a, b] if a.is_finite() && b.is_finite() => Ok([*a, *b]),
        _ => Err(format!("'{s}': give two finite numbers A,B")),
    }
}

/// One plane to measure: its name, the plane, and how its pixel (i, j) maps to the sensor's
/// (sensor = step * sub + offset, per axis (x, y)).
struct GlarePlane {
    name: String,
    plane: camsim::analysis::Plane,
    step: f64,
    offset: [f64; 2],
    /// The level (above black) at which this plane clips, where the format says (raw DNGs).
    clip: Option<f64>,
}

fn glare_planes(a: &GlareArgs) -> Result<(Vec<GlarePlane>, &'static str)> {
    use camsim::analysis::Plane;
    let ext = a
        .image
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let whole = |name: &str, plane: Plane| GlarePlane {
        name: name.to_string(),
        plane,
        step: 1.0,
        offset: [0.0, 0.0],
        clip: None,
    };
    if ext == "exr" {
        let (img, warning) = camsim::pipeline::inputs::read_spectral_exr(&a.image)?;
        if let Some(w) = warning {
            eprintln!("camsim: warning: {w}");
        }
        let n = img.rows * img.cols;
        let mut sum = vec![0.0f32; n];
        for band in img.data.chunks_exact(n) {
            sum.iter_mut().zip(band).for_each(|(s, v)| *s += v);
        }
        return Ok((
            vec![whole("sum", Plane::new(img.rows, img.cols, sum)?)],
            "spectral irradiance, summed over bands",
        ));
    }
    if matches!(ext.as_str(), "png" | "tif" | "tiff") && a.raw.cfa.is_none() {
        let (rows, cols, dn) = camsim::io::raster::read_mosaic_16(&a.image)?;
        let data = dn
            .iter()
            .map(|v| (*v as f64 - a.raw.black_dn) as f32)
            .collect();
        return Ok((
            vec![whole("grey", Plane::new(rows, cols, data)?)],
            "grey image above --black-dn",
        ));
    }
    let img = MeasuredImage::load(&a.image, &a.raw.format())?;
    Ok(match img {
        MeasuredImage::Raw(r) => {
            use camsim::core::CfaChannel;
            let mut v = Vec::new();
            for (name, ch) in [
                ("R", CfaChannel::R),
                ("G", CfaChannel::G),
                ("B", CfaChannel::B),
            ] {
                let which = (ch == CfaChannel::G).then_some(0);
                let (dr, dc) = camsim::analysis::image::cfa_channel_offset(r.cfa, ch, which)?;
                v.push(GlarePlane {
                    name: name.to_string(),
                    plane: camsim::analysis::cfa_channel_plane(&r, ch, which)?,
                    step: 2.0,
                    offset: [dc as f64, dr as f64],
                    clip: Some(r.white_level_dn - r.black_level_dn),
                });
            }
            (
                v,
                "raw CFA (each channel on its own pixels, DN above black)",
            )
        }
        MeasuredImage::Rgb { planes, .. } => {
            let [pr, pg, pb] = *planes;
            (
                vec![whole("R", pr), whole("G", pg), whole("B", pb)],
                "LinearRaw RGB",
            )
        }
    })
}

pub fn glare_cmd(a: GlareArgs) -> Result<()> {
    use camsim::analysis::glare::{veiling_glare, GlareOptions};
    let (planes, kind) = glare_planes(&a)?;
    let mut rows = Vec::new();
    for p in &planes {
        // Sensor pixel coordinates (centres at +0.5) to the plane's: x_sub = (x - off - 0.5) / step + 0.5.
        let to_sub = |v: f64, off: f64| (v - off - 0.5) / p.step + 0.5;
        let opts = GlareOptions {
            centre_px: a
                .centre
                .map(|[x, y]| [to_sub(x, p.offset[0]), to_sub(y, p.offset[1])]),
            hole_diameter_px: a.hole_diameter_px.map(|d| d / p.step),
            roi_fraction: a.roi_fraction,
            surround_radii: a.surround,
        };
        let m = veiling_glare(&p.plane, &opts)
            .map_err(|e| anyhow::anyhow!("{} ({} channel): {e}", a.image.display(), p.name))?;
        // A clipped surround understates the surround level and so overstates the index.
        if let Some(clip) = p.clip {
            if m.surround_signal >= 0.98 * clip {
                anyhow::bail!(
                    "{} ({} channel): the surround is clipped ({:.0} DN above black, white level {:.0}): \
                     shorten the exposure so it stays below the white level",
                    a.image.display(),
                    p.name,
                    m.surround_signal,
                    clip
                );
            }
        }
        let from_sub = |v: f64, off: f64| (v - 0.5) * p.step + off + 0.5;
        rows.push(serde_json::json!({
            "channel": p.name,
            "glare_index": m.glare_index,
            "glare_percent": 100.0 * m.glare_index,
            "hole_signal": m.hole_signal,
            "surround_signal": m.surround_signal,
            "hole_pixels": m.hole_pixels,
            "surround_pixels": m.surround_pixels,
            "centre_px": [from_sub(m.centre_px[0], p.offset[0]), from_sub(m.centre_px[1], p.offset[1])],
            "hole_diameter_px": m.hole_diameter_px * p.step,
        }));
    }
    let name = a.image.display().to_string();
    let json = serde_json::json!({
        "image": name,
        "data": kind,
        "roi_fraction": a.roi_fraction,
        "surround_radii": a.surround,
        "channels": rows,
    });
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    std::fs::write(
        staged.join("glare.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    for r in &rows {
        say(format!(
            "{}: veiling glare index {:.4} % (hole {:.5}, surround {:.5}; hole diameter {:.1} px)",
            r["channel"].as_str().unwrap_or(""),
            r["glare_percent"].as_f64().unwrap_or(f64::NAN),
            r["hole_signal"].as_f64().unwrap_or(f64::NAN),
            r["surround_signal"].as_f64().unwrap_or(f64::NAN),
            r["hole_diameter_px"].as_f64().unwrap_or(f64::NAN),
        ));
    }
    say(format!("-> {}", a.out.join("glare.json").display()));
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
/// Dual-pixel disparity: how far a dual-pixel sensor's left-photodiode image of a near-vertical
/// edge lies from its right-photodiode image (`raw_left.dng` and `raw_right.dng` of a `camsim
/// simulate` run with `dual_pixel = true`), the signal a phase-detection autofocus turns into a
/// focus error. Measured on each filter's own pixels (no demosaicking) as the difference of the
/// two images' line-spread centroids in blocks of rows; for a thin lens it is 4 c / (3 pi), c the
/// circle of confusion, with opposite signs in front of and behind focus (docs/src/sensors.md).
/// Writes dual_pixel.json in --out.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim simulate examples/dual-pixel.toml --out out/dual-pixel\n  camsim analyze dual-pixel out/dual-pixel/raw_left.dng out/dual-pixel/raw_right.dng --out out/dual-pixel-af\n  camsim analyze dual-pixel out/dual-pixel/raw_left.dng out/dual-pixel/raw_right.dng --roi 0,40,96,48 --json --out out/dual-pixel-roi"
)]
pub struct DualPixelArgs {
    /// The left photodiodes' raw (DNG, or a PNG/TIFF mosaic with --cfa).
    pub left: PathBuf,
    /// The right photodiodes' raw.
    pub right: PathBuf,
    /// The region holding the edge, sensor pixels, ROW,COL,ROWS,COLS (default: the whole raw).
    #[arg(long, value_parser = parse_rect, value_name = "ROW,COL,ROWS,COLS")]
    pub roi: Option<Rect>,
    /// Rows of each filter's pixels per block (the disparity's standard error comes from the
    /// spread over blocks).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    pub block_rows: u32,
    #[command(flatten)]
    pub raw: RawInput,
    /// Also print dual_pixel.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for dual_pixel.json (created if missing).
    #[arg(long, default_value = "out/dual-pixel-af")]
    pub out: PathBuf,
}

pub fn dual_pixel_cmd(a: DualPixelArgs) -> Result<()> {
    use camsim::pipeline::measure::dual_pixel::{measure_dual_pixel, DualPixelRequest};
    let load = |p: &Path| -> Result<camsim::core::RawImage> {
        match MeasuredImage::load(p, &a.raw.format())? {
            MeasuredImage::Raw(r) => Ok(r),
            MeasuredImage::Rgb { .. } => Err(anyhow::anyhow!(
                "{}: a LinearRaw (demosaicked) DNG; give the dual-pixel sensor's CFA raws",
                p.display()
            )),
        }
    };
    let (left, right) = (load(&a.left)?, load(&a.right)?);
    let report = measure_dual_pixel(
        &left,
        &right,
        &DualPixelRequest {
            roi: a.roi,
            block_rows: a.block_rows as usize,
        },
    )
    .map_err(|e| anyhow::anyhow!("{} and {}: {e}", a.left.display(), a.right.display()))?;
    let mut json = serde_json::to_value(&report)?;
    json["left"] = a.left.display().to_string().into();
    json["right"] = a.right.display().to_string().into();
    json["sign"] = "disparity = left edge column - right edge column (left: the photodiodes that see the pupil's left half, x < 0)".into();
    let staged = common::stage_out_dir_reading(&a.out, &[a.left.as_path(), a.right.as_path()])?;
    std::fs::write(
        staged.join("dual_pixel.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    for f in &report.filters {
        say(format!(
            "{}: disparity {:+.3} px (+- {:.3}), edge at column {:.2}, slope {:.3} px/row, {} blocks",
            f.filter, f.disparity_px, f.standard_error_px, f.edge_col_px, f.slope_px_per_row, f.blocks
        ));
    }
    let um = report
        .disparity_um
        .map(|d| format!(" = {d:+.3} um on the sensor"))
        .unwrap_or_default();
    say(format!(
        "disparity {:+.3} px (+- {:.3}){um}",
        report.disparity_px, report.standard_error_px
    ));
    say(format!("-> {}", a.out.join("dual_pixel.json").display()));
    common::commit(staged)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
/// ISO 15739 visual noise of uniform patches of a display picture (an sRGB PNG, JPEG or TIFF such
/// as `camsim simulate`'s preview.png or a camera's JPEG; or a linear-sRGB OpenEXR, white = 1).
///
/// The noise a viewer sees: the patch in CIE XYZ, adapted to white E, split into a luminance and
/// two colour-opponent channels, each filtered by the eye's contrast sensitivity at the viewing
/// condition, then VN = sigma(L*) + 0.852 sigma(u*) + 0.323 sigma(v*) (ISO 15739:2013 Annex B).
/// The same picture seen from further away (more pixels per degree) has less visual noise. Writes,
/// in --out: visual_noise.json and visual_noise.csv (per patch: VN, the filtered and unfiltered
/// sigma of L*, u*, v*, the mean L*u*v*).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim simulate examples/uniform.toml --out out/grey\n  camsim analyze visual-noise out/grey/preview.png --out out/grey-vn\n  camsim analyze visual-noise out/grey/preview.png --region 32,32,128,128 --viewing-distance-m 0.6 --display-height-m 0.3 --out out/grey-vn-region\n  camsim analyze visual-noise out/grey/preview.png --pixels-per-degree 60 --json --out out/grey-vn60"
)]
pub struct VisualNoiseArgs {
    /// sRGB picture (PNG, JPEG, TIFF; 8 or 16 bit) or linear-sRGB OpenEXR.
    pub image: PathBuf,
    /// A uniform patch ROW,COL,ROWS,COLS in pixels (repeat for more; default: the central half of
    /// the picture in each direction).
    #[arg(long = "region", value_parser = parse_rect, value_name = "ROW,COL,ROWS,COLS")]
    pub regions: Vec<Rect>,
    /// Pixels per degree of visual angle (instead of the picture's height and distance).
    #[arg(long, value_parser = crate::common::positive_f64, conflicts_with_all = ["display_height_m", "viewing_distance_m"])]
    pub pixels_per_degree: Option<f64>,
    /// Height of the whole picture as shown, m (default 0.1, as `camsim compare`).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub display_height_m: Option<f64>,
    /// Viewing distance, m (default 0.4, as `camsim compare`).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub viewing_distance_m: Option<f64>,
    /// Also print visual_noise.json on stdout.
    #[arg(long)]
    pub json: bool,
    /// Output folder for visual_noise.json and visual_noise.csv (created if missing).
    #[arg(long, default_value = "out/visual-noise")]
    pub out: PathBuf,
}

pub fn visual_noise_cmd(a: VisualNoiseArgs) -> Result<()> {
    use camsim::pipeline::measure::visual_noise::{
        measure_visual_noise, DisplayImage, Viewing, VisualNoiseRequest,
    };
    let viewing = match a.pixels_per_degree {
        Some(p) => Viewing::PixelsPerDegree(p),
        None => Viewing::Picture {
            display_height_m: a.display_height_m.unwrap_or(0.1),
            viewing_distance_m: a.viewing_distance_m.unwrap_or(0.4),
        },
    };
    let image = DisplayImage::load(&a.image)?;
    let name = a.image.display().to_string();
    let report = measure_visual_noise(
        &image,
        &VisualNoiseRequest {
            regions: a.regions.clone(),
            viewing,
        },
    )
    .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.image.as_path()])?;
    let json = report.write_files(&staged, &name)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    }
    for p in &report.patches {
        say(format!(
            "{}: visual noise {:.3} (sigma L* {:.3}, u* {:.3}, v* {:.3}; unfiltered L* {:.3}) at L* {:.1}",
            p.rect, p.visual_noise, p.sigma_l_star, p.sigma_u_star, p.sigma_v_star,
            p.unfiltered_sigma_luv[0], p.mean_luv[0]
        ));
    }
    say(format!(
        "{:.2} pixels per degree -> {}",
        report.pixels_per_degree,
        a.out.join("visual_noise.csv").display()
    ));
    common::commit(staged)?;
    Ok(())
}
