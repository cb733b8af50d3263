//! `camsim compare`: two cameras side by side on the standard targets (not to be confused with
//! [`crate::compare`], the measured-versus-simulated region comparison).
//!
//! Each camera (a sensor preset or TOML file, an optional pixel pitch override, a lens) is
//! simulated with the pipeline's stages ([`camsim_pipeline::image_radiance`]) on
//!
//! 1. an ISO 12233 slanted edge: the e-SFR of the bilinear-demosaicked luminance (MTF in cycles
//!    per pixel and cycles/mm, MTF50) and its CPIQ acutance at a viewing condition;
//! 2. a uniform grey field, both cameras at the same exposure time (the shorter of the two
//!    auto-exposures, so neither clips): SNR per CFA channel (mean / std, and dB) and the
//!    normalised noise power spectrum of the green sub-grid;
//! 3. the ColorChecker under D65: bilinear demosaic, white balance from the illuminant, a 3x3
//!    colour matrix fitted on the 24 patches (linear sRGB least squares), and CIEDE2000 per patch
//!    against the chart's true colours (the ISP chain of `camsim isp --ccm chart`);
//! 4. ISETCam's zone plate: the modulation of the demosaicked luminance against radial frequency
//!    in every orientation at once ([`crate::zone_plate`]), beside the slanted-edge MTF;
//!
//! and `report.html`, `results.json` and the PNG plots (MTF curves overlaid, SNR bars, NPS curves,
//! ΔE00 bars per patch) are written.

use crate::plot::{Figure, Series, Style};
use crate::report::Html;
use crate::util::{f, save_png, FigurePng};
use crate::{Result, ValidateError};
use camsim_analysis::acutance::{acutance, ViewingCondition};
use camsim_analysis::chart::{self, ChartCorners, PATCH_NAMES};
use camsim_analysis::noise::{nps, snr_raw, NpsOptions, Snr};
use camsim_analysis::sfr::{self, SfrOptions};
use camsim_analysis::visual_noise::VisualNoise;
use camsim_analysis::{Plane, Rect};
use camsim_core::{CfaChannel, RawImage, WavelengthGrid};
use camsim_isp::ccm::{self, CcmObjective};
use camsim_optics::{Optics, OpticsConfig};
use camsim_pipeline::SimulateConfig;
use camsim_sensor::{Capture, Exposure, Sensor};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One camera of the comparison.
#[derive(Debug, Clone, Serialize)]
pub struct CameraSpec {
    /// Sensor preset name or sensor TOML file.
    pub sensor: String,
    /// Pixel pitch override, um (None: the sensor's own).
    pub pixel_pitch_um: Option<f64>,
    /// Lens preset name or lens TOML file.
    pub lens: String,
}

impl CameraSpec {
    /// A camera from a sensor and lens spec.
    pub fn new(sensor: impl Into<String>, lens: impl Into<String>) -> CameraSpec {
        CameraSpec {
            sensor: sensor.into(),
            pixel_pitch_um: None,
            lens: lens.into(),
        }
    }

    /// A short label for legends.
    pub fn label(&self) -> String {
        match self.pixel_pitch_um {
            Some(p) => format!("{} ({p} um)", self.sensor),
            None => self.sensor.clone(),
        }
    }

    fn load(&self) -> Result<(Sensor, OpticsConfig)> {
        let mut sensor = camsim_pipeline::load_sensor(&self.sensor)?;
        if let Some(p) = self.pixel_pitch_um {
            if !(p > 0.0 && p.is_finite() && p <= 1000.0) {
                return Err(ValidateError::invalid(
                    "pixel pitch",
                    format!("{p} um must be in (0, 1000]"),
                ));
            }
            let mut cfg = sensor.config().clone();
            cfg.pixel_pitch_um = p;
            sensor =
                Sensor::from_config_named(cfg, &format!("{} with a {p} um pitch", self.sensor))?;
        }
        let lens = camsim_pipeline::load_lens(&self.lens)?;
        Ok((sensor, lens))
    }
}

/// Options of [`compare_cameras`].
#[derive(Debug, Clone, Serialize)]
pub struct CameraCompareOptions {
    /// The first camera.
    pub a: CameraSpec,
    /// The second camera.
    pub b: CameraSpec,
    /// Side of the square sensor window of the edge and the uniform field, pixels (the chart uses
    /// `size_px` x 4/3 `size_px`).
    pub size_px: usize,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Viewing distance for the acutance, m; the picture (the sensor's full height) is shown
    /// `display_height_m` high.
    pub viewing_distance_m: f64,
    /// Height of the shown picture, m.
    pub display_height_m: f64,
    /// Output folder (report.html, results.json, PNGs); None: compute only.
    pub out_dir: Option<PathBuf>,
    /// The command line, for the report.
    pub command_line: String,
}

impl CameraCompareOptions {
    /// Defaults: a 128-pixel window, seed 1, a 0.1 m high picture (a 4 x 6 inch print's short
    /// side) viewed from 0.4 m.
    pub fn new(a: CameraSpec, b: CameraSpec) -> CameraCompareOptions {
        CameraCompareOptions {
            a,
            b,
            size_px: 128,
            seed: 1,
            viewing_distance_m: 0.4,
            display_height_m: 0.1,
            out_dir: None,
            command_line: String::new(),
        }
    }
}

/// Sharpness of one camera.
#[derive(Debug, Clone, Serialize)]
pub struct MtfMetrics {
    /// Frequencies, cycles/pixel.
    pub freq_cy_per_px: Vec<f64>,
    /// Frequencies, cycles/mm on the sensor.
    pub freq_cy_per_mm: Vec<f64>,
    /// MTF (SFR) of the demosaicked luminance.
    pub mtf: Vec<f64>,
    /// Frequency where the MTF falls to 0.5, cycles/pixel.
    pub mtf50_cy_per_px: Option<f64>,
    /// The same in cycles/mm.
    pub mtf50_cy_per_mm: Option<f64>,
    /// CPIQ acutance at the viewing condition.
    pub acutance: f64,
    /// Pixels per degree of the viewing condition.
    pub pixels_per_degree: f64,
    /// Edge angle found, degrees.
    pub edge_angle_deg: f64,
}

/// Zone-plate MTF of one camera ([`crate::zone_plate`]).
#[derive(Debug, Clone, Serialize)]
pub struct ZonePlateMetrics {
    /// Annulus centre frequencies, cycles/pixel.
    pub freq_cy_per_px: Vec<f64>,
    /// The same in cycles/mm on the sensor.
    pub freq_cy_per_mm: Vec<f64>,
    /// In-phase modulation of the demosaicked luminance / the scene's modulation.
    pub mtf: Vec<f64>,
    /// First frequency where it falls below 0.5, cycles/pixel.
    pub mtf50_cy_per_px: Option<f64>,
    /// Sensor pixels per scene sample of the zone plate scene.
    pub sensor_px_per_sample: f64,
}

/// Noise of one camera on the uniform field.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseMetrics {
    /// Exposure time (the same for both cameras), s.
    pub exposure_s: f64,
    /// SNR per CFA channel R, G, B (DN above black).
    pub snr: [Snr; 3],
    /// Green mean as a fraction of the ADC range above black.
    pub green_fraction_of_range: f64,
    /// Radial frequencies of the NPS, cycles per sensor pixel.
    pub nps_freq_cy_per_px: Vec<f64>,
    /// Normalised NPS (NPS / mean^2) of the green sub-grid, per (green sample)^2.
    pub nnps: Vec<f64>,
    /// ISO 15739 visual noise of the field as the camera renders it (bilinear demosaic, white
    /// balance and the chart-fitted colour matrix to XYZ, the field shown as the 50 % grey it
    /// is: CIE L*u*v* against its mean XYZ / 0.5), at the viewing condition of the acutance.
    pub visual_noise: VisualNoise,
}

/// Colour accuracy of one camera on the ColorChecker.
#[derive(Debug, Clone, Serialize)]
pub struct ColorMetrics {
    /// Exposure time (auto), s.
    pub exposure_s: f64,
    /// CIEDE2000 per patch (standard order).
    pub patch_delta_e2000: Vec<f64>,
    /// Mean over the 24 patches.
    pub mean_delta_e2000: f64,
    /// Largest.
    pub max_delta_e2000: f64,
    /// The fitted camera (white balanced) -> XYZ matrix.
    pub camera_to_xyz: [[f64; 3]; 3],
}

/// Everything measured on one camera.
#[derive(Debug, Clone, Serialize)]
pub struct CameraMetrics {
    /// Legend label.
    pub label: String,
    /// The spec.
    pub spec: CameraSpec,
    /// Pixel pitch used, um.
    pub pixel_pitch_um: f64,
    /// Sharpness.
    pub mtf: MtfMetrics,
    /// Noise.
    pub noise: NoiseMetrics,
    /// Colour.
    pub color: ColorMetrics,
    /// Zone-plate MTF.
    pub zone_plate: ZonePlateMetrics,
}

/// The comparison (written as results.json).
#[derive(Debug, Clone, Serialize)]
pub struct CameraComparison {
    /// camsim version.
    pub camsim_version: String,
    /// Options used.
    pub options: CameraCompareOptions,
    /// First camera.
    pub a: CameraMetrics,
    /// Second camera.
    pub b: CameraMetrics,
    /// Figure files.
    pub figures: Vec<FigurePng>,
}

struct Loaded {
    sensor: Sensor,
    lens: OpticsConfig,
    optics: Optics,
}

fn scene_config(text: &str) -> Result<SimulateConfig> {
    Ok(SimulateConfig::from_toml_str(
        text,
        std::path::Path::new(""),
    )?)
}

/// Horizontal field of view that spans `extent_m` on the sensor behind a lens of focal length
/// `f_mm` (object far away), degrees.
fn fov_deg(extent_m: f64, f_mm: f64) -> f64 {
    2.0 * (0.5 * extent_m / (f_mm * 1e-3)).atan().to_degrees()
}

fn capture_one(
    cam: &Loaded,
    cfg: &SimulateConfig,
    rows: usize,
    cols: usize,
    exposure: Exposure,
    seed: u64,
) -> Result<(RawImage, f64)> {
    let sensor = cam.sensor.window(rows, cols)?;
    let scene = cfg
        .scene
        .as_ref()
        .ok_or_else(|| ValidateError::invalid("compare", "scene config without a [scene]"))?;
    let radiance = camsim_scene::create(scene, &cfg.wavelengths)
        .map_err(|e| ValidateError::invalid("scene", e.to_string()))?;
    let capture = Capture {
        exposure,
        frames: 1,
        seed,
        global_reset: None,
        light: None,
    };
    let imaged = camsim_pipeline::image_radiance(&radiance, &cam.optics, &sensor, &capture)?;
    let raw = imaged
        .frame
        .raw
        .into_iter()
        .next()
        .ok_or_else(|| ValidateError::invalid("sensor", "no frame returned"))?;
    Ok((raw, imaged.frame.exposure_s))
}

fn rgb_planes(raw: &RawImage) -> Result<[Plane; 3]> {
    let rgb = camsim_isp::try_demosaic_bilinear(raw)?;
    let [r, g, b] = [0, 1, 2].map(|c| Plane::new(rgb.rows, rgb.cols, rgb.plane(c).to_vec()));
    Ok([r?, g?, b?])
}

fn measure_mtf(cam: &Loaded, opts: &CameraCompareOptions, max_pitch_m: f64) -> Result<MtfMetrics> {
    let n = opts.size_px;
    // The chart spans 1.4 x the wider camera's window so the edge fills both windows.
    let fov = fov_deg(1.4 * n as f64 * max_pitch_m, cam.lens.focal_length_mm);
    // Two scene samples per pixel of this camera (the edge must be sharper than the pixels).
    let scene_px = ((2.8 * n as f64 * max_pitch_m / cam.sensor.pixel_pitch_m()).ceil() as usize)
        .clamp(64, 2048);
    let cfg = scene_config(&format!(
        "[scene]\nkind = \"slanted_edge\"\nmean_luminance_cd_m2 = 100.0\nfov_deg = {fov}\ndistance_m = 1.0\nilluminant = \"D65\"\n\
         rows = {scene_px}\ncols = {scene_px}\nangle_deg = 5.0\nbright_reflectance = 0.8\ndark_reflectance = 0.1\n"
    ))?;
    let (raw, _) = capture_one(
        cam,
        &cfg,
        n,
        n,
        Exposure::Auto {
            target_fraction: 0.7,
        },
        opts.seed,
    )?;
    let planes = rgb_planes(&raw)?;
    let y = camsim_analysis::image::luminance(&planes)?;
    let roi = sfr::find_edge_roi(&y)?;
    let pitch_mm = cam.sensor.pixel_pitch_m() * 1e3;
    let s = sfr::sfr(
        &y,
        Some(roi),
        &SfrOptions {
            pixel_pitch_mm: Some(pitch_mm),
            ..SfrOptions::default()
        },
    )?;
    // Up to the Nyquist frequency (0.5 cycles/pixel) and a little beyond, as plotted.
    let keep = s
        .freq_cyc_per_sensor_px
        .iter()
        .take_while(|f| **f <= 1.0)
        .count();
    let freq = s.freq_cyc_per_sensor_px[..keep].to_vec();
    let mtf = s.mtf[..keep].to_vec();
    let mtf50 = sfr::crossing(&freq, &mtf, 0.5);
    let viewing = ViewingCondition {
        image_height_px: cam.sensor.rows(),
        display_height_m: opts.display_height_m,
        viewing_distance_m: opts.viewing_distance_m,
    };
    let ppd = viewing.pixels_per_degree()?;
    let ac = acutance(&freq, &mtf, ppd)?;
    Ok(MtfMetrics {
        freq_cy_per_mm: freq.iter().map(|f| f / pitch_mm).collect(),
        freq_cy_per_px: freq,
        mtf,
        mtf50_cy_per_px: mtf50,
        mtf50_cy_per_mm: mtf50.map(|f| f / pitch_mm),
        acutance: ac.acutance,
        pixels_per_degree: ppd,
        edge_angle_deg: s.edge_angle_deg,
    })
}

/// The zone plate's MTF: an N x N zone plate (amplitude 0.8) seen at ~0.5 sensor pixels per scene
/// sample, N = 4 x the window side, so its local frequency reaches ~0.5 cycles/pixel at the
/// window's edge midpoints (f = r_px / (N k^2)) while the scene stays sampled at 4 samples per
/// cycle or finer there.
fn measure_zone_plate(cam: &Loaded, opts: &CameraCompareOptions) -> Result<ZonePlateMetrics> {
    let n = opts.size_px;
    let samples = 4 * n;
    let amplitude = 0.8;
    let pitch_m = cam.sensor.pixel_pitch_m();
    let fov = fov_deg(0.5 * samples as f64 * pitch_m, cam.lens.focal_length_mm);
    let distance_m = 1.2;
    let cfg = scene_config(&format!(
        "[scene]\nkind = \"zone_plate\"\nmean_luminance_cd_m2 = 100.0\nfov_deg = {fov}\ndistance_m = {distance_m}\nilluminant = \"D65\"\n\
         size_px = {samples}\namplitude = {amplitude}\nphase_deg = 0.0\n"
    ))?;
    // Sensor pixels per scene sample: the thin-lens image scale (as macbeth_chart_corners_px).
    let f_m = cam.lens.focal_length_mm * 1e-3;
    let v_m =
        camsim_optics::lens::image_distance_m(f_m, cam.lens.focus_distance_m.unwrap_or(distance_m))
            .ok_or_else(|| {
                ValidateError::invalid(
                    "zone plate",
                    "focus distance inside the focal length: no real image",
                )
            })?;
    let k = camsim_scene::sample_spacing_m(fov, distance_m, samples) * v_m / distance_m / pitch_m;
    let (raw, _) = capture_one(
        cam,
        &cfg,
        n,
        n,
        Exposure::Auto {
            target_fraction: 0.7,
        },
        opts.seed,
    )?;
    let planes = rgb_planes(&raw)?;
    let y = camsim_analysis::image::luminance(&planes)?;
    let geom = crate::zone_plate::ZonePlateGeometry {
        size_samples: samples,
        sensor_px_per_sample: k,
        amplitude,
        phase_rad: 0.0,
    };
    let (freq, mtf) = crate::zone_plate::zone_plate_mtf(
        &y.data,
        y.rows,
        y.cols,
        raw.black_level_dn,
        &geom,
        0.02,
        0.5,
    );
    let pitch_mm = pitch_m * 1e3;
    let mtf50 = sfr::crossing(&freq, &mtf, 0.5);
    Ok(ZonePlateMetrics {
        freq_cy_per_mm: freq.iter().map(|f| f / pitch_mm).collect(),
        freq_cy_per_px: freq,
        mtf,
        mtf50_cy_per_px: mtf50,
        sensor_px_per_sample: k,
    })
}

fn uniform_config(cam: &Loaded, n: usize, max_pitch_m: f64) -> Result<SimulateConfig> {
    let fov = fov_deg(1.4 * n as f64 * max_pitch_m, cam.lens.focal_length_mm);
    scene_config(&format!(
        "[scene]\nkind = \"uniform\"\nmean_luminance_cd_m2 = 100.0\nfov_deg = {fov}\ndistance_m = 1.0\nilluminant = \"D65\"\n\
         reflectance = 0.5\nrows = 32\ncols = 32\n"
    ))
}

/// Reflectance of the uniform field ([`uniform_config`]).
const FIELD_REFLECTANCE: f64 = 0.5;

#[allow(clippy::too_many_arguments)]
fn measure_noise(
    cam: &Loaded,
    cfg: &SimulateConfig,
    n: usize,
    exposure_s: f64,
    seed: u64,
    camera_to_xyz: &[[f64; 3]; 3],
    grid: &WavelengthGrid,
    pixels_per_degree: f64,
) -> Result<NoiseMetrics> {
    let (raw, exposure_s) = capture_one(cam, cfg, n, n, Exposure::Seconds(exposure_s), seed)?;
    // The central region, away from the optics' edge fall-off at the window border.
    let m = n / 8;
    let rect = Rect::new(m, m, n - 2 * m, n - 2 * m);
    let snr = snr_raw(&raw, &rect)?;
    // The field through the same colour path as the chart (measure_color), to XYZ.
    let mut rgb = camsim_isp::try_demosaic_bilinear(&raw)?;
    let d65 = camsim_core::tables::illuminant("D65")?;
    let gains =
        camsim_isp::white_balance::illuminant_gains(&cam.sensor.channel_qe(grid), grid, &d65)?;
    camsim_isp::white_balance::apply_gains(&mut rgb, gains);
    let cam_planes = [0, 1, 2].map(|c| rgb.plane(c));
    let xyz = {
        let plane = |x: usize| {
            Plane::from_fn(rect.rows, rect.cols, |r, c| {
                let i = (rect.row + r) * rgb.cols + rect.col + c;
                (0..3)
                    .map(|k| camera_to_xyz[x][k] * cam_planes[k][i] as f64)
                    .sum::<f64>() as f32
            })
        };
        [plane(0)?, plane(1)?, plane(2)?]
    };
    let white = [0, 1, 2].map(|c| {
        xyz[c].data.iter().map(|v| *v as f64).sum::<f64>()
            / (xyz[c].data.len() as f64 * FIELD_REFLECTANCE)
    });
    let visual_noise =
        camsim_analysis::visual_noise::visual_noise(&xyz, None, white, pixels_per_degree)?;
    let g = camsim_analysis::cfa_channel_plane(&raw, CfaChannel::G, Some(0))?;
    let roi_px = (g.rows.min(g.cols) / 2).clamp(4, 64);
    let r = nps(
        &g,
        None,
        &NpsOptions {
            roi_px,
            ..NpsOptions::default()
        },
    )?;
    let mean2 = r.mean * r.mean;
    Ok(NoiseMetrics {
        exposure_s,
        snr,
        green_fraction_of_range: snr[1].mean / (raw.white_level_dn - raw.black_level_dn),
        // Green sub-grid samples are 2 sensor pixels apart.
        nps_freq_cy_per_px: r.radial_freq_cy_per_px.iter().map(|f| f / 2.0).collect(),
        nnps: r
            .radial_nps
            .iter()
            .map(|v| if mean2 > 0.0 { v / mean2 } else { f64::NAN })
            .collect(),
        visual_noise,
    })
}

fn measure_color(
    cam: &Loaded,
    opts: &CameraCompareOptions,
    min_extent_m: f64,
    grid: &WavelengthGrid,
) -> Result<ColorMetrics> {
    let rows = opts.size_px;
    let cols = (opts.size_px * 4 / 3 + 1) & !1;
    // The chart (6 x 4 patches of 16 samples, 2-sample borders) spans 80 % of the narrower window.
    let fov = fov_deg(0.8 * min_extent_m, cam.lens.focal_length_mm);
    let cfg = scene_config(&format!(
        "[scene]\nkind = \"macbeth\"\nmean_luminance_cd_m2 = 100.0\nfov_deg = {fov}\ndistance_m = 1.2\nilluminant = \"D65\"\n\
         patch_size_px = 16\nborder_px = 2\n"
    ))?;
    // Auto-exposure to half range: the white patch (~2 % of the window) holds the brightest
    // filter's 99th percentile, so it sits at half the swing, well inside the linear range
    // (before the percentile was taken per filter, a target near full range clipped it).
    let (raw, exposure_s) = capture_one(
        cam,
        &cfg,
        rows,
        cols,
        Exposure::Auto {
            target_fraction: 0.5,
        },
        opts.seed,
    )?;
    let mut rgb = camsim_isp::try_demosaic_bilinear(&raw)?;
    let d65 = camsim_core::tables::illuminant("D65")?;
    let gains =
        camsim_isp::white_balance::illuminant_gains(&cam.sensor.channel_qe(grid), grid, &d65)?;
    camsim_isp::white_balance::apply_gains(&mut rgb, gains);
    let planes = {
        let [r, g, b] = [0, 1, 2].map(|c| Plane::new(rgb.rows, rgb.cols, rgb.plane(c).to_vec()));
        [r?, g?, b?]
    };
    let corners = camsim_pipeline::macbeth_chart_corners_px(
        &cfg,
        &cam.lens,
        cam.sensor.pixel_pitch_m(),
        rows,
        cols,
    )?
    .ok_or_else(|| ValidateError::invalid("compare", "the chart scene is not a Macbeth chart"))?;
    let corners = ChartCorners {
        top_left: corners[0],
        top_right: corners[1],
        bottom_right: corners[2],
        bottom_left: corners[3],
    };
    let stats = chart::chart_patch_stats_rgb(&planes, &corners, 0.5)?;
    let camera: Vec<[f64; 3]> = stats.iter().map(|s| s.mean).collect();
    let (target, white) = ccm::macbeth_xyz(&d65, grid)?;
    let m = ccm::fit_ccm(&camera, &target, white, CcmObjective::LinearSrgb)?;
    let de = ccm::ccm_delta_e2000(&m, &camera, &target, white);
    let mean = de.iter().sum::<f64>() / de.len().max(1) as f64;
    let max = de.iter().cloned().fold(0.0, f64::max);
    if !mean.is_finite() {
        return Err(ValidateError::invalid(
            "colour fit",
            "no finite colour error (is the chart inside the window?)",
        ));
    }
    Ok(ColorMetrics {
        exposure_s,
        patch_delta_e2000: de,
        mean_delta_e2000: mean,
        max_delta_e2000: max,
        camera_to_xyz: m,
    })
}

/// Simulate both cameras, measure them and (with `out_dir`) write the report.
pub fn compare_cameras(
    opts: &CameraCompareOptions,
    progress: &(dyn Fn(&str, u64, u64) + Sync),
) -> Result<CameraComparison> {
    if !(16..=1024).contains(&opts.size_px) {
        return Err(ValidateError::invalid(
            "size",
            format!("{} pixels: must be 16 to 1024", opts.size_px),
        ));
    }
    for (what, v) in [
        ("viewing distance", opts.viewing_distance_m),
        ("display height", opts.display_height_m),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(ValidateError::invalid(
                what,
                format!("{v} m must be positive"),
            ));
        }
    }
    let load = |spec: &CameraSpec| -> Result<Loaded> {
        let (sensor, lens) = spec.load()?;
        let optics = Optics::from_config(&lens)?;
        Ok(Loaded {
            sensor,
            lens,
            optics,
        })
    };
    let cams = [load(&opts.a)?, load(&opts.b)?];
    let n = opts.size_px;
    let max_pitch_m = cams
        .iter()
        .map(|c| c.sensor.pixel_pitch_m())
        .fold(0.0, f64::max);
    let grid = WavelengthGrid::default();
    let chart_cols = (n * 4 / 3 + 1) & !1;
    let min_extent_m = cams
        .iter()
        .map(|c| c.sensor.pixel_pitch_m() * chart_cols as f64)
        .fold(f64::INFINITY, f64::min);

    progress("slanted edge", 0, 4);
    let mtf = [
        measure_mtf(&cams[0], opts, max_pitch_m)?,
        measure_mtf(&cams[1], opts, max_pitch_m)?,
    ];
    progress("zone plate", 1, 4);
    let zone = [
        measure_zone_plate(&cams[0], opts)?,
        measure_zone_plate(&cams[1], opts)?,
    ];
    progress("uniform field", 2, 4);
    // The same exposure time for both: the shorter of the two auto-exposures at half range.
    let ucfg = [
        uniform_config(&cams[0], n, max_pitch_m)?,
        uniform_config(&cams[1], n, max_pitch_m)?,
    ];
    let mut exposure_s = f64::INFINITY;
    for (cam, cfg) in cams.iter().zip(&ucfg) {
        let (_, t) = capture_one(
            cam,
            cfg,
            n,
            n,
            Exposure::Auto {
                target_fraction: 0.5,
            },
            opts.seed,
        )?;
        exposure_s = exposure_s.min(t);
    }
    progress("ColorChecker", 3, 4);
    let color = [
        measure_color(&cams[0], opts, min_extent_m, &grid)?,
        measure_color(&cams[1], opts, min_extent_m, &grid)?,
    ];
    // Visual noise through each camera's chart-fitted colour matrix, at the acutance's viewing.
    let noise = [0, 1].map(|i| {
        measure_noise(
            &cams[i],
            &ucfg[i],
            n,
            exposure_s,
            opts.seed,
            &color[i].camera_to_xyz,
            &grid,
            mtf[i].pixels_per_degree,
        )
    });
    let [na, nb] = noise;
    let noise = [na?, nb?];
    progress("report", 4, 4);

    let [mtf_a, mtf_b] = mtf;
    let [noise_a, noise_b] = noise;
    let [color_a, color_b] = color;
    let [zone_a, zone_b] = zone;
    let metrics = |spec: &CameraSpec, cam: &Loaded, mtf, noise, color, zone_plate| CameraMetrics {
        label: spec.label(),
        spec: spec.clone(),
        pixel_pitch_um: cam.sensor.pixel_pitch_m() * 1e6,
        mtf,
        noise,
        color,
        zone_plate,
    };
    let mut a = metrics(&opts.a, &cams[0], mtf_a, noise_a, color_a, zone_a);
    let mut b = metrics(&opts.b, &cams[1], mtf_b, noise_b, color_b, zone_b);
    if a.label == b.label {
        a.label = format!("A: {}", a.label);
        b.label = format!("B: {}", b.label);
    }
    let mut result = CameraComparison {
        camsim_version: env!("CARGO_PKG_VERSION").to_string(),
        options: opts.clone(),
        a,
        b,
        figures: Vec::new(),
    };
    if let Some(dir) = &opts.out_dir {
        write_report(&mut result, dir)?;
    }
    Ok(result)
}

const COLOR_A: [u8; 3] = [40, 70, 210];
const COLOR_B: [u8; 3] = [210, 90, 30];

/// Outline of a bar chart as one polyline: bar i spans [x_i + offset - width/2, x_i + offset + width/2].
fn bars(label: &str, x: &[f64], y: &[f64], color: [u8; 3]) -> Series {
    Series::xy(label, x.to_vec(), y.to_vec(), Style::Bar, color)
}

fn write_report(r: &mut CameraComparison, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ValidateError::file(dir, format!("cannot create the output folder: {e}")))?;
    let (a, b) = (&r.a, &r.b);
    let mut figs = Vec::new();

    let mtf_fig = Figure::new(
        "MTF of the demosaicked luminance, slanted edge (cycles/mm)",
        "cycles/mm on the sensor",
        "MTF",
    )
    .with(Series::xy(
        &a.label,
        a.mtf.freq_cy_per_mm.clone(),
        a.mtf.mtf.clone(),
        Style::Line,
        COLOR_A,
    ))
    .with(Series::xy(
        &b.label,
        b.mtf.freq_cy_per_mm.clone(),
        b.mtf.mtf.clone(),
        Style::Line,
        COLOR_B,
    ))
    .ranges(None, Some((0.0, 1.1)));
    figs.push(save_png(
        dir,
        "compare_mtf.png",
        "MTF (ISO 12233 e-SFR) of both cameras against sensor-plane frequency",
        mtf_fig.png()?,
    )?);

    let zp_fig = Figure::new(
        "Zone-plate MTF (demosaicked luminance, all orientations) and slanted edge",
        "cycles/mm on the sensor",
        "MTF",
    )
    .with(Series::xy(
        format!("{} zone plate", a.label),
        a.zone_plate.freq_cy_per_mm.clone(),
        a.zone_plate.mtf.clone(),
        Style::Line,
        COLOR_A,
    ))
    .with(Series::xy(
        format!("{} zone plate", b.label),
        b.zone_plate.freq_cy_per_mm.clone(),
        b.zone_plate.mtf.clone(),
        Style::Line,
        COLOR_B,
    ))
    .with(Series::xy(
        format!("{} edge", a.label),
        a.mtf.freq_cy_per_mm.clone(),
        a.mtf.mtf.clone(),
        Style::Dashed,
        COLOR_A,
    ))
    .with(Series::xy(
        format!("{} edge", b.label),
        b.mtf.freq_cy_per_mm.clone(),
        b.mtf.mtf.clone(),
        Style::Dashed,
        COLOR_B,
    ))
    .ranges(None, Some((0.0, 1.1)));
    figs.push(save_png(
        dir,
        "compare_zone_plate.png",
        "Zone-plate MTF (lines; in-phase modulation per annulus of radial frequency, all orientations) beside the slanted-edge MTF (dashed)",
        zp_fig.png()?,
    )?);

    let ch = [0.0, 1.0, 2.0];
    let snr_db = |m: &CameraMetrics| m.noise.snr.map(|s| s.snr_db).to_vec();
    let snr_fig = Figure::new(
        "SNR of a uniform field, same exposure (dB)",
        "CFA channel",
        "SNR (dB)",
    )
    .with_categories(vec!["R".into(), "G".into(), "B".into()])
    .with(bars(&a.label, &ch, &snr_db(a), COLOR_A))
    .with(bars(&b.label, &ch, &snr_db(b), COLOR_B));
    figs.push(save_png(
        dir,
        "compare_snr.png",
        "SNR per CFA channel (20 log10 mean / std)",
        snr_fig.png()?,
    )?);

    let skip_dc = |m: &CameraMetrics| {
        (
            m.noise.nps_freq_cy_per_px[1..].to_vec(),
            m.noise.nnps[1..].to_vec(),
        )
    };
    let ((fa, na), (fb, nb)) = (skip_dc(a), skip_dc(b));
    let nps_fig = Figure::new(
        "Normalised noise power spectrum, green, uniform field (cycles/pixel)",
        "cycles/pixel",
        "NPS / mean^2",
    )
    .with(Series::xy(&a.label, fa, na, Style::Line, COLOR_A))
    .with(Series::xy(&b.label, fb, nb, Style::Line, COLOR_B));
    figs.push(save_png(
        dir,
        "compare_nps.png",
        "Radially averaged NNPS of the green sub-grid",
        nps_fig.png()?,
    )?);

    let patches: Vec<f64> = (1..=24).map(|i| i as f64).collect();
    let de_fig = Figure::new(
        "CIEDE2000 per ColorChecker patch after demosaic, WB, CCM (Delta E 2000)",
        "patch (1 dark skin ... 19 white ... 24 black)",
        "Delta E 2000",
    )
    .with_categories(Vec::new())
    .with(bars(
        &a.label,
        &patches,
        &a.color.patch_delta_e2000,
        COLOR_A,
    ))
    .with(bars(
        &b.label,
        &patches,
        &b.color.patch_delta_e2000,
        COLOR_B,
    ))
    .sized(900, 440);
    figs.push(save_png(
        dir,
        "compare_delta_e.png",
        "CIEDE2000 per patch against the chart's D65 colours",
        de_fig.png()?,
    )?);

    let mut h = Html::new(&format!("camsim compare: {} vs {}", a.label, b.label));
    h.p(&format!(
        "Two cameras simulated with camsim {} on a slanted edge, a zone plate, a uniform grey field and the ColorChecker (D65, 100 cd/m^2), \
         {} x {} pixel windows, seed {}.",
        r.camsim_version, r.options.size_px, r.options.size_px, r.options.seed
    ));
    let row = |name: &str, fa: String, fb: String| vec![name.to_string(), fa, fb];
    let o = |x: Option<f64>, d| x.map(|v| f(v, d)).unwrap_or_else(|| "-".into());
    let rows = vec![
        row(
            "pixel pitch, um",
            f(a.pixel_pitch_um, 2),
            f(b.pixel_pitch_um, 2),
        ),
        row(
            "MTF50, cycles/pixel",
            o(a.mtf.mtf50_cy_per_px, 3),
            o(b.mtf.mtf50_cy_per_px, 3),
        ),
        row(
            "MTF50, cycles/mm",
            o(a.mtf.mtf50_cy_per_mm, 1),
            o(b.mtf.mtf50_cy_per_mm, 1),
        ),
        row(
            "acutance (CPIQ CSF)",
            f(a.mtf.acutance, 3),
            f(b.mtf.acutance, 3),
        ),
        row(
            "zone-plate MTF50, cycles/pixel",
            o(a.zone_plate.mtf50_cy_per_px, 3),
            o(b.zone_plate.mtf50_cy_per_px, 3),
        ),
        row(
            "uniform field exposure, ms",
            f(a.noise.exposure_s * 1e3, 3),
            f(b.noise.exposure_s * 1e3, 3),
        ),
        row(
            "green mean, fraction of range",
            f(a.noise.green_fraction_of_range, 3),
            f(b.noise.green_fraction_of_range, 3),
        ),
        row(
            "SNR R, dB",
            f(a.noise.snr[0].snr_db, 2),
            f(b.noise.snr[0].snr_db, 2),
        ),
        row(
            "SNR G, dB",
            f(a.noise.snr[1].snr_db, 2),
            f(b.noise.snr[1].snr_db, 2),
        ),
        row(
            "SNR B, dB",
            f(a.noise.snr[2].snr_db, 2),
            f(b.noise.snr[2].snr_db, 2),
        ),
        row(
            "Visual noise (ISO 15739, the field as 50 % grey)",
            f(a.noise.visual_noise.visual_noise, 3),
            f(b.noise.visual_noise.visual_noise, 3),
        ),
        row(
            "CIEDE2000 mean",
            f(a.color.mean_delta_e2000, 2),
            f(b.color.mean_delta_e2000, 2),
        ),
        row(
            "CIEDE2000 max",
            f(a.color.max_delta_e2000, 2),
            f(b.color.max_delta_e2000, 2),
        ),
    ];
    h.h2("Summary", "summary");
    h.table(&["metric", &a.label, &b.label], &rows);
    h.p(&format!(
        "Acutance: the SFR weighted by the CPIQ contrast sensitivity (IEEE 1858-2016), for the full sensor height shown {} m \
         high at {} m ({:.1} and {:.1} pixels/degree). SNR: mean / std per CFA channel of the raw uniform field, both cameras \
         at the same exposure time (the shorter auto-exposure at half range). Colour: bilinear demosaic, white balance from \
         D65 and the sensor QE, a 3x3 matrix fitted on the 24 patches (linear sRGB least squares).",
        r.options.display_height_m, r.options.viewing_distance_m, a.mtf.pixels_per_degree, b.mtf.pixels_per_degree
    ));
    h.h2("Figures", "figures");
    for fig in &figs {
        h.figure(&fig.png, &fig.caption);
    }
    h.h2("CIEDE2000 per patch", "patches");
    let patch_rows: Vec<Vec<String>> = (0..24)
        .map(|i| {
            vec![
                format!("{} {}", i + 1, PATCH_NAMES.get(i).copied().unwrap_or("")),
                a.color
                    .patch_delta_e2000
                    .get(i)
                    .map(|v| f(*v, 2))
                    .unwrap_or_default(),
                b.color
                    .patch_delta_e2000
                    .get(i)
                    .map(|v| f(*v, 2))
                    .unwrap_or_default(),
            ]
        })
        .collect();
    h.table(&["patch", &a.label, &b.label], &patch_rows);
    h.h2("Provenance", "provenance");
    h.table(
        &["parameter", "value"],
        &[
            vec!["command".into(), r.options.command_line.clone()],
            vec!["camsim".into(), r.camsim_version.clone()],
        ],
    );
    r.figures = figs;
    camsim_io::atomic::write_bytes_atomic(&dir.join("report.html"), h.finish().as_bytes())?;
    camsim_io::atomic::write_json_atomic(&dir.join("results.json"), &*r)?;
    Ok(())
}
