//! Sections 3-5 (paper Figures 4, 5, 6): the Cornell box with the ColorChecker, seen by the Pixel
//! 4a camera at full field of view.
//!
//! The built-in `cornell-box-mcc` scene is rendered at a reduced resolution (the full sensor's
//! field of view), passed through the pixel4a optics (in focus) and captured by the full
//! 4032 x 3024 pixel4a sensor (noise on; the centre position's auto-exposure is used for all
//! three positions), then bilinearly demosaicked. Render pixels map to sensor pixels through the
//! irradiance image's sample spacing (the sensor centres the irradiance on itself).
//!
//! - Figure 4: the demosaicked image and its sRGB preview (camsim_isp::ColorPipeline fitted for
//!   the pixel4a QE under the box's light); saturated pixels in the light's image, the floor in
//!   the short block's shadow against the lit floor, and the R/G ratio of the blocks' faces toward
//!   the red and the green wall (inter-reflection), all located by projecting world points.
//! - Figure 5: the chart at left, centre and right: RGB along a line through the gray series, the
//!   R/G ratio of the gray patches (must fall from left to right) and the mean scene luminance.
//! - Figure 6: three gray patches in the linear range: mean and standard deviation per CFA channel
//!   on the raw mosaic; the same irradiance captured noise-free at the same exposure separates
//!   sensor noise from render noise and illumination gradients: std(noisy - noise-free) is
//!   compared with the noise model's prediction at that mean (shot + read + DSNU + PRNU +
//!   quantization, `Sensor::predicted_noise_dn`).

use crate::plot::{Canvas, Figure, Series, Style, CHANNEL_COLORS};
use crate::report::Html;
use crate::util::{f, save_png, BoxSpectra, FigurePng};
use crate::{Check, QualityParams, Result, Stages, ValidateError, ValidateOptions};
use camsim_analysis::chart::{
    chart_patch_rects, chart_patch_stats_rgb, line_profile, ChartCorners,
};
use camsim_analysis::image::Moments;
use camsim_analysis::{Plane, Rect};
use camsim_core::colorimetry::Cmfs;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::{RawImage, SpectralImage};
use camsim_isp::RgbImage;
use camsim_optics::Optics;
use camsim_scene3d::builtin::{self, BuiltinOptions, MccPosition};
use camsim_scene3d::{Geometry, SceneDescription};
use camsim_sensor::{Capture, Exposure, NoiseSwitches, Sensor};
use serde::Serialize;

/// Patches (0-based chart order) whose R/G is compared between positions: neutral 8 ... black.
pub const GRAY_RG_PATCHES: std::ops::Range<usize> = 19..24;
/// Auto-exposure of the Cornell box: the brightest filter's 99th percentile of the noise-free signal at this
/// fraction of the voltage swing (the light itself still saturates; the chart stays linear).
pub const AUTO_EXPOSURE_FRACTION: f64 = 0.5;

/// Render-to-sensor pixel mapping (both centred on the optical axis).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PixelMap {
    /// Sensor pixels per render pixel.
    pub scale: f64,
    /// Render width and height.
    pub render: (usize, usize),
    /// Sensor width and height.
    pub sensor: (usize, usize),
}

impl PixelMap {
    /// Sensor [x, y] of render raster [x, y].
    pub fn to_sensor(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.render.0 as f64 / 2.0) * self.scale + self.sensor.0 as f64 / 2.0,
            (p[1] - self.render.1 as f64 / 2.0) * self.scale + self.sensor.1 as f64 / 2.0,
        ]
    }
}

/// The ColorChecker at one position.
#[derive(Debug, Clone, Serialize)]
pub struct PositionResult {
    /// left, center or right.
    pub position: String,
    /// Exposure, s.
    pub exposure_s: f64,
    /// Mean luminance of the rendered radiance image, cd/m^2.
    pub mean_luminance_cd_m2: f64,
    /// Outer corners of the 4 x 6 patch grid in sensor pixels [x, y] (TL, TR, BR, BL).
    pub chart_corners_px: [[f64; 2]; 4],
    /// Mean demosaicked RGB (DN above black) of the six gray patches, white to black.
    pub gray_patch_rgb: Vec<[f64; 3]>,
    /// R/G of the gray series: sum of R over sum of G of the gray patches [`GRAY_RG_PATCHES`]
    /// (neutral 8 to black; the white patch is left out because render noise spikes clip there).
    pub gray_rg_ratio: f64,
    /// Line profile through the gray series: distance from the chart's left edge, pixels.
    pub profile_distance_px: Vec<f64>,
    /// Profile R, G, B (demosaicked DN above black).
    pub profile_rgb: Vec<[f64; 3]>,
    /// Samples per pixel the render took (all `box_spp` unless an opt-in time budget stopped it).
    pub render_samples_per_pixel: u32,
    /// Render time, s.
    pub render_seconds: f64,
    /// Rays per second of the render.
    pub render_rays_per_second: f64,
}

/// The qualitative features of Figure 4, measured.
#[derive(Debug, Clone, Serialize)]
pub struct ImageFeatures {
    /// The light's image (inner part of its bounding box), sensor pixels.
    pub light_rect: Rect,
    /// Fraction of raw pixels at the white level there.
    pub light_saturated_fraction: f64,
    /// Mean Rec. 709 luminance of demosaicked DN on the floor in the short block's shadow.
    pub shadow_floor_dn: f64,
    /// The same on the lit floor near the front.
    pub lit_floor_dn: f64,
    /// shadow / lit.
    pub shadow_to_lit_ratio: f64,
    /// R/G on the tall block's face toward the red wall.
    pub rg_face_toward_red_wall: f64,
    /// R/G on the short block's face toward the green wall.
    pub rg_face_toward_green_wall: f64,
    /// R/G of the lit floor (reference).
    pub rg_lit_floor: f64,
}

/// One channel of one noise region.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseChannel {
    /// R, G or B.
    pub channel: String,
    /// Pixels.
    pub n: usize,
    /// Mean DN above black of the noisy capture.
    pub mean_dn: f64,
    /// Mean DN above black of the noise-free capture.
    pub noise_free_mean_dn: f64,
    /// Raw within-region standard deviation of the noisy capture (as the paper), DN.
    pub raw_std_dn: f64,
    /// Standard deviation of (noisy - noise-free), DN: the sensor noise alone.
    pub sensor_noise_std_dn: f64,
    /// The noise model's prediction at the noise-free mean, DN.
    pub predicted_std_dn: f64,
    /// sensor_noise_std / predicted.
    pub ratio: f64,
    /// sensor_noise_std - predicted, DN.
    pub difference_dn: f64,
}

/// One noise region.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseRegion {
    /// Patch name.
    pub name: String,
    /// Region in sensor pixels.
    pub rect: Rect,
    /// R, G, B.
    pub channels: Vec<NoiseChannel>,
}

/// Sections 3-5 results.
#[derive(Debug, Clone, Serialize)]
pub struct SceneResults {
    /// Render resolution.
    pub render_px: (usize, usize),
    /// Samples per pixel asked for.
    pub samples_per_pixel: u32,
    /// Sensor size (cols, rows).
    pub sensor_px: (usize, usize),
    /// Render-to-sensor mapping.
    pub pixel_map: PixelMap,
    /// Left, center, right.
    pub positions: Vec<PositionResult>,
    /// Figure 4 features.
    pub features: ImageFeatures,
    /// Figure 6 regions.
    pub noise: Vec<NoiseRegion>,
    /// Largest |sensor_noise_std / predicted - 1|.
    pub noise_max_relative_deviation: f64,
    /// Largest |sensor_noise_std - predicted|, DN.
    pub noise_max_difference_dn: f64,
    /// Largest |raw_std - predicted|, DN (the paper's comparison).
    pub noise_max_raw_difference_dn: f64,
    /// Checks.
    pub checks: Vec<Check>,
    /// Figures.
    pub figures: Vec<FigurePng>,
}

struct Captured {
    raw: RawImage,
    rgb: RgbImage,
    irr: Option<SpectralImage>,
    map: PixelMap,
    scene: SceneDescription,
    corners: ChartCorners,
    result: PositionResult,
}

fn planes_of(rgb: &RgbImage) -> Result<[Plane; 3]> {
    Ok([
        Plane::new(rgb.rows, rgb.cols, rgb.r.clone())?,
        Plane::new(rgb.rows, rgb.cols, rgb.g.clone())?,
        Plane::new(rgb.rows, rgb.cols, rgb.b.clone())?,
    ])
}

/// The patch grid's outer corners from the patch centres (chart order; render raster).
fn grid_corners(centers: &[[f64; 2]], map: &PixelMap) -> ChartCorners {
    let c = |i: usize| map.to_sensor(centers[i]);
    let (c0, c5, c18, c23) = (c(0), c(5), c(18), c(23));
    // Half a patch pitch beyond the outer patch centres.
    let u = [(c5[0] - c0[0]) / 10.0, (c5[1] - c0[1]) / 10.0];
    let v = [(c18[0] - c0[0]) / 6.0, (c18[1] - c0[1]) / 6.0];
    let u2 = [(c23[0] - c18[0]) / 10.0, (c23[1] - c18[1]) / 10.0];
    let v2 = [(c23[0] - c5[0]) / 6.0, (c23[1] - c5[1]) / 6.0];
    ChartCorners {
        top_left: [c0[0] - u[0] - v[0], c0[1] - u[1] - v[1]],
        top_right: [c5[0] + u[0] - v2[0], c5[1] + u[1] - v2[1]],
        bottom_right: [c23[0] + u2[0] + v2[0], c23[1] + u2[1] + v2[1]],
        bottom_left: [c18[0] - u2[0] + v[0], c18[1] - u2[1] + v[1]],
    }
}

#[allow(clippy::too_many_arguments)]
fn capture_position(
    opts: &ValidateOptions,
    p: &QualityParams,
    spectra: &BoxSpectra,
    pos: MccPosition,
    name: &str,
    exposure: Option<f64>,
    keep_irradiance: bool,
    st: &mut Stages,
) -> Result<Captured> {
    let grid = p.grid;
    let mut bo = BuiltinOptions {
        resolution: Some(p.box_render),
        samples_per_pixel: p.box_spp,
        mcc_position: pos,
        grid,
        seed: opts.seed,
        ..BuiltinOptions::default()
    };
    spectra.apply(&mut bo);
    let sensor = Sensor::preset("pixel4a")?;
    let optics = Optics::preset("pixel4a")?;
    let mut scene = builtin::scene("cornell-box-mcc", &bo)?;
    scene.settings.time_budget_s = p.box_time_budget_s;
    // The pipeline's one field-of-view rule (as `simulate` renders a 3D scene): the render covers
    // exactly the sensor seen from the lens at its image distance.
    camsim_pipeline::render::match_camera_to_sensor(
        &mut scene,
        &sensor,
        optics.config(),
        p.box_render.0,
        p.box_render.1,
    )?;
    let out = st.run(
        &format!("images: render Cornell box, chart {name}"),
        |prog| Ok(camsim_render::render(&scene, prog)?),
    )?;
    let radiance = out.radiance;
    let cmfs = Cmfs::on(&grid);
    let w: Vec<f64> = cmfs
        .y
        .iter()
        .map(|y| y * LUMINOUS_EFFICACY_LM_PER_W)
        .collect();
    let mean_luminance = radiance.mean_weighted_integral(&w);
    let (irr, frame) = st.run(&format!("images: optics + sensor, chart {name}"), |_| {
        let cap = match exposure {
            Some(t) => Capture::seconds(t),
            None => Capture {
                exposure: Exposure::Auto {
                    target_fraction: AUTO_EXPOSURE_FRACTION,
                },
                ..Capture::default()
            },
        }
        .with_seed(opts.seed.wrapping_add(200));
        // The pipeline's own wiring of optics into sensor.
        let imaged = camsim_pipeline::image_radiance(&radiance, &optics, &sensor, &cap)?;
        Ok((imaged.irradiance, imaged.frame))
    })?;
    drop(radiance);
    let map = PixelMap {
        scale: irr.sample_spacing_m / sensor.pixel_pitch_m(),
        render: p.box_render,
        sensor: (sensor.cols(), sensor.rows()),
    };
    let raw = frame
        .raw
        .into_iter()
        .next()
        .ok_or_else(|| ValidateError::invalid("sensor", "no frame"))?;
    let rgb = st.run(&format!("images: demosaic, chart {name}"), |_| {
        Ok(camsim_isp::demosaic_bilinear(&raw))
    })?;
    let (centers, _) = builtin::mcc_patch_centers_on(&scene.camera, &bo.mcc_position)?;
    let corners = grid_corners(&centers, &map);
    let planes = planes_of(&rgb)?;
    let stats = chart_patch_stats_rgb(&planes, &corners, 0.5)?;
    let gray: Vec<[f64; 3]> = stats[18..24].iter().map(|s| s.mean).collect();
    let rg_set = &stats[GRAY_RG_PATCHES];
    let rg = rg_set.iter().map(|g| g.mean[0]).sum::<f64>()
        / rg_set.iter().map(|g| g.mean[1]).sum::<f64>();
    let (p0, p1) = corners.row_line(3);
    let len = ((p1[0] - p0[0]).powi(2) + (p1[1] - p0[1]).powi(2)).sqrt();
    let samples = (len.round() as usize).clamp(2, 800);
    let prof = line_profile(&planes, p0, p1, samples)?;
    let result = PositionResult {
        position: name.to_string(),
        exposure_s: frame.exposure_s,
        mean_luminance_cd_m2: mean_luminance,
        chart_corners_px: [
            corners.top_left,
            corners.top_right,
            corners.bottom_right,
            corners.bottom_left,
        ],
        gray_patch_rgb: gray,
        gray_rg_ratio: rg,
        profile_distance_px: prof.iter().map(|q| q.distance_px).collect(),
        profile_rgb: prof.iter().map(|q| q.rgb).collect(),
        render_samples_per_pixel: out.samples_per_pixel.iter().copied().max().unwrap_or(0),
        render_seconds: out.stats.seconds,
        render_rays_per_second: out.stats.rays_per_second,
    };
    Ok(Captured {
        raw,
        rgb,
        irr: if keep_irradiance { Some(irr) } else { None },
        map,
        scene,
        corners,
        result,
    })
}

/// Mean of three planes at projected world points (bilinear), R, G, B.
fn sample_world(
    planes: &[Plane; 3],
    scene: &SceneDescription,
    map: &PixelMap,
    pts: &[[f64; 3]],
) -> [f64; 3] {
    let mut s = [0.0; 3];
    let mut n = 0.0;
    for p in pts {
        if let Some(r) = builtin::project_to_raster(&scene.camera, *p) {
            let q = map.to_sensor(r);
            let v: Vec<Option<f64>> = planes
                .iter()
                .map(|pl| pl.sample_bilinear(q[0], q[1]))
                .collect();
            if v.iter().all(|x| x.is_some()) {
                for c in 0..3 {
                    s[c] += v[c].unwrap();
                }
                n += 1.0;
            }
        }
    }
    if n > 0.0 {
        s.map(|v| v / n)
    } else {
        [f64::NAN; 3]
    }
}

/// A grid of floor points (y = 0) around (x, z), +-half, metres.
fn floor_patch(x: f64, z: f64, half: f64) -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for i in 0..7 {
        for j in 0..7 {
            v.push([
                x - half + 2.0 * half * i as f64 / 6.0,
                0.0,
                z - half + 2.0 * half * j as f64 / 6.0,
            ]);
        }
    }
    v
}

/// Points on a vertical block face between top corners a and b (x, z in m), inner part.
fn face_points(a: [f64; 2], b: [f64; 2], height_m: f64) -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for i in 0..9 {
        let u = 0.25 + 0.5 * i as f64 / 8.0;
        for j in 0..9 {
            let h = height_m * (0.2 + 0.6 * j as f64 / 8.0);
            v.push([a[0] + u * (b[0] - a[0]), h, a[1] + u * (b[1] - a[1])]);
        }
    }
    v
}

fn luma(rgb: [f64; 3]) -> f64 {
    let w = camsim_analysis::image::LUMINANCE_WEIGHTS_REC709;
    w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2]
}

fn features(c: &Captured) -> Result<ImageFeatures> {
    let planes = planes_of(&c.rgb)?;
    // The light's image: project its vertices.
    let light = c
        .scene
        .shapes
        .iter()
        .find(|s| s.name.as_deref() == Some("light"))
        .ok_or_else(|| ValidateError::invalid("cornell-box-mcc", "has no shape named 'light'"))?;
    let Geometry::Triangles { positions, .. } = &light.geometry else {
        return Err(ValidateError::invalid("light", "is not a triangle mesh"));
    };
    let (mut x0, mut y0, mut x1, mut y1) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    );
    for p in positions {
        if let Some(r) = builtin::project_to_raster(&c.scene.camera, *p) {
            let q = c.map.to_sensor(r);
            x0 = x0.min(q[0]);
            x1 = x1.max(q[0]);
            y0 = y0.min(q[1]);
            y1 = y1.max(q[1]);
        }
    }
    let (cols, rows) = (c.raw.cols as f64, c.raw.rows as f64);
    // Inner 60 % of the bounding box, clipped to the sensor.
    let (cx, cy, hw, hh) = (
        (x0 + x1) / 2.0,
        (y0 + y1) / 2.0,
        0.3 * (x1 - x0),
        0.3 * (y1 - y0),
    );
    let rx0 = (cx - hw).clamp(0.0, cols - 1.0) as usize;
    let rx1 = (cx + hw).clamp(1.0, cols) as usize;
    let ry0 = (cy - hh).clamp(0.0, rows - 1.0) as usize;
    let ry1 = (cy + hh).clamp(1.0, rows) as usize;
    let light_rect = Rect::new(
        ry0,
        rx0,
        ry1.saturating_sub(ry0).max(1),
        rx1.saturating_sub(rx0).max(1),
    );
    let white = c.raw.white_level_dn;
    let mut sat = 0usize;
    let mut tot = 0usize;
    for r in light_rect.row..light_rect.row_end().min(c.raw.rows) {
        for col in light_rect.col..light_rect.col_end().min(c.raw.cols) {
            tot += 1;
            if c.raw.at(r, col) as f64 >= white {
                sat += 1;
            }
        }
    }
    // Shadow: the floor beside the short block's face toward the green wall (umbra: every line
    // to the light passes through the 165 mm block); lit: the open floor near the front.
    let shadow = sample_world(&planes, &c.scene, &c.map, &floor_patch(0.07, 0.14, 0.012));
    let lit = sample_world(&planes, &c.scene, &c.map, &floor_patch(0.40, 0.06, 0.012));
    // Block faces (Cornell data page vertices): tall block's +x face (toward the red wall),
    // short block's -x face (toward the green wall).
    let red_face = sample_world(
        &planes,
        &c.scene,
        &c.map,
        &face_points([0.472, 0.406], [0.423, 0.247], 0.33),
    );
    let green_face = sample_world(
        &planes,
        &c.scene,
        &c.map,
        &face_points([0.130, 0.065], [0.082, 0.225], 0.165),
    );
    Ok(ImageFeatures {
        light_rect,
        light_saturated_fraction: if tot > 0 {
            sat as f64 / tot as f64
        } else {
            0.0
        },
        shadow_floor_dn: luma(shadow),
        lit_floor_dn: luma(lit),
        shadow_to_lit_ratio: luma(shadow) / luma(lit),
        rg_face_toward_red_wall: red_face[0] / red_face[1],
        rg_face_toward_green_wall: green_face[0] / green_face[1],
        rg_lit_floor: lit[0] / lit[1],
    })
}

fn noise_regions(c: &Captured, sensor: &Sensor) -> Result<Vec<NoiseRegion>> {
    let irr = c
        .irr
        .as_ref()
        .ok_or_else(|| ValidateError::invalid("noise", "the centre irradiance was not kept"))?;
    let t = c.result.exposure_s;
    let nf = sensor
        .with_noise(NoiseSwitches::none())
        .compute(irr, &Capture::seconds(t))?;
    let nf = &nf.raw[0];
    let raw = &c.raw;
    let regions = chart_patch_rects(&c.corners, 0.6, raw.rows, raw.cols)?;
    let black = raw.black_level_dn;
    let max_dn = raw.white_level_dn;
    // Gray patches whose noise-free mean lies in the linear range in every channel.
    let mut cand = Vec::new();
    for reg in &regions[18..24] {
        let m = camsim_analysis::roi::raw_rect_moments(nf, &reg.rect)?;
        let means = m.map(|v| v.mean());
        if means
            .iter()
            .all(|v| *v > 0.04 * max_dn && *v < 0.85 * max_dn)
        {
            cand.push((means[1], reg.clone()));
        }
    }
    cand.sort_by(|a, b| b.0.total_cmp(&a.0));
    let chosen: Vec<_> = match cand.len() {
        0..=3 => cand,
        n => vec![cand[0].clone(), cand[n / 2].clone(), cand[n - 1].clone()],
    };
    let mut out = Vec::new();
    for (_, reg) in chosen {
        let mut noisy = [Moments::default(); 3];
        let mut clean = [Moments::default(); 3];
        let mut diff = [Moments::default(); 3];
        for r in reg.rect.row..reg.rect.row_end() {
            for col in reg.rect.col..reg.rect.col_end() {
                let ch = raw.cfa.channel_at(r, col).index();
                let a = raw.at(r, col) as f64 - black;
                let b = nf.at(r, col) as f64 - nf.black_level_dn;
                noisy[ch].push(a);
                clean[ch].push(b);
                diff[ch].push(a - b);
            }
        }
        let channels = (0..3)
            .map(|ch| {
                let pred = sensor.predicted_noise_dn(clean[ch].mean(), t).total;
                NoiseChannel {
                    channel: ["R", "G", "B"][ch].into(),
                    n: noisy[ch].n,
                    mean_dn: noisy[ch].mean(),
                    noise_free_mean_dn: clean[ch].mean(),
                    raw_std_dn: noisy[ch].std(),
                    sensor_noise_std_dn: diff[ch].std(),
                    predicted_std_dn: pred,
                    ratio: diff[ch].std() / pred,
                    difference_dn: diff[ch].std() - pred,
                }
            })
            .collect();
        out.push(NoiseRegion {
            name: reg.name.clone(),
            rect: reg.rect,
            channels,
        });
    }
    Ok(out)
}

/// Run sections 3-5.
pub(crate) fn run(
    opts: &ValidateOptions,
    p: &QualityParams,
    spectra: &BoxSpectra,
    st: &mut Stages,
) -> Result<SceneResults> {
    let sensor = Sensor::preset("pixel4a")?;
    let center = capture_position(
        opts,
        p,
        spectra,
        MccPosition::Center,
        "center",
        None,
        true,
        st,
    )?;
    let t = center.result.exposure_s;
    let feats = features(&center)?;
    let noise = st.run("noise: noise-free capture and regions", |_| {
        noise_regions(&center, &sensor)
    })?;
    let mut figures = Vec::new();
    // Figure 4 and the centre panel of Figure 5 / 6 from the centre capture.
    figures.extend(image_figures(opts, p, spectra, &center, &noise)?);
    let center_result = center.result.clone();
    let map = center.map;
    drop(center);
    let mut positions = Vec::new();
    let mut thumbs = Vec::new();
    for (pos, name) in [(MccPosition::Left, "left"), (MccPosition::Right, "right")] {
        let c = capture_position(opts, p, spectra, pos, name, Some(t), false, st)?;
        thumbs.push((name, position_thumbnail(p, spectra, &c)?));
        positions.push(c.result);
    }
    positions.insert(1, center_result);

    let mut checks = Vec::new();
    let rg: Vec<f64> = positions.iter().map(|q| q.gray_rg_ratio).collect();
    checks.push(Check {
        name: "R/G of the gray series falls from left (red wall) to right (green wall)".into(),
        passed: rg[0] > rg[1] && rg[1] > rg[2],
        detail: format!("left {:.4}, center {:.4}, right {:.4}", rg[0], rg[1], rg[2]),
    });
    checks.push(Check {
        name: "light source saturates".into(),
        passed: feats.light_saturated_fraction > 0.0,
        detail: format!(
            "{:.1} % of the light's pixels at the white level",
            100.0 * feats.light_saturated_fraction
        ),
    });
    checks.push(Check {
        name: "shadow beside the short block darker than the lit floor".into(),
        passed: feats.shadow_to_lit_ratio < 0.5,
        detail: format!("shadow / lit = {:.3} (< 0.5)", feats.shadow_to_lit_ratio),
    });
    checks.push(Check {
        name: "inter-reflection: block face toward the red wall redder than the face toward the green wall".into(),
        passed: feats.rg_face_toward_red_wall > feats.rg_face_toward_green_wall,
        detail: format!("R/G {:.3} vs {:.3} (lit floor {:.3})", feats.rg_face_toward_red_wall, feats.rg_face_toward_green_wall, feats.rg_lit_floor),
    });
    let mut max_rel: f64 = 0.0;
    let mut max_diff: f64 = 0.0;
    let mut max_raw: f64 = 0.0;
    for r in &noise {
        for ch in &r.channels {
            max_rel = max_rel.max((ch.ratio - 1.0).abs());
            max_diff = max_diff.max(ch.difference_dn.abs());
            max_raw = max_raw.max((ch.raw_std_dn - ch.predicted_std_dn).abs());
        }
    }
    checks.push(Check {
        name: "sensor noise (noisy - noise-free) within 10 % of the noise model in every region and channel".into(),
        passed: noise.len() == 3 && max_rel <= 0.10,
        detail: format!(
            "{} regions; largest |measured / predicted - 1| = {:.3}, largest difference {:.2} DN (raw within-region std: {:.2} DN)",
            noise.len(),
            max_rel,
            max_diff,
            max_raw
        ),
    });
    figures.extend(profile_figures(opts, &positions, thumbs)?);
    let mut res = SceneResults {
        render_px: p.box_render,
        samples_per_pixel: p.box_spp,
        sensor_px: (sensor.cols(), sensor.rows()),
        pixel_map: map,
        positions,
        features: feats,
        noise,
        noise_max_relative_deviation: max_rel,
        noise_max_difference_dn: max_diff,
        noise_max_raw_difference_dn: max_raw,
        checks,
        figures,
    };
    add_noise_figures(opts, &mut res)?;
    Ok(res)
}

// ---------------------------------------------------------------- images

/// Box-average an RGB image by an integer factor.
fn downsample(img: &RgbImage, k: usize) -> RgbImage {
    let (rows, cols) = (img.rows / k, img.cols / k);
    let mut o = RgbImage::zeros(rows.max(1), cols.max(1));
    let inv = 1.0 / (k * k) as f32;
    for r in 0..rows {
        for c in 0..cols {
            let mut s = [0.0f32; 3];
            for dr in 0..k {
                let base = (r * k + dr) * img.cols + c * k;
                for dc in 0..k {
                    s[0] += img.r[base + dc];
                    s[1] += img.g[base + dc];
                    s[2] += img.b[base + dc];
                }
            }
            let i = r * cols + c;
            o.r[i] = s[0] * inv;
            o.g[i] = s[1] * inv;
            o.b[i] = s[2] * inv;
        }
    }
    o
}

/// Downsampling factor of the embedded previews (at most 672 pixels wide, so the report stays small).
fn preview_factor(cols: usize) -> usize {
    cols.div_ceil(672).max(1)
}

fn light_of(spectra: &BoxSpectra) -> camsim_core::Spectrum {
    spectra
        .light
        .clone()
        .unwrap_or_else(builtin::cornell_light_relative)
}

/// sRGB preview, downsampled: [`report_preview`] of the pixel4a under the box's light.
fn srgb_preview(
    p: &QualityParams,
    spectra: &BoxSpectra,
    rgb: &RgbImage,
    exposure_scale: Option<f64>,
) -> Result<(Canvas, usize, f64)> {
    let sensor = Sensor::preset("pixel4a")?;
    // Clipped highlights (the lamp) render neutral, not in the false colour white balance gives them.
    let saturation_dn = sensor.max_dn() as f64 - sensor.black_level_dn();
    report_preview(
        rgb,
        &sensor,
        light_of(spectra),
        p.grid,
        exposure_scale,
        saturation_dn,
    )
}

/// The report's sRGB preview of demosaicked camera RGB `rgb` (DN above black, clipping at
/// `saturation_dn`) made by `sensor` under `illuminant`: box-averaged to at most 672 pixels
/// wide, then the pipeline's ISP ([`camsim_pipeline::Isp`], the paper's; the colour fit on
/// `grid`) at `exposure_scale` (None: automatic). The same ISP as `camsim simulate`'s preview
/// and `camsim isp`. Returns the image, the downsampling factor and the exposure scale used.
pub fn report_preview(
    rgb: &RgbImage,
    sensor: &Sensor,
    illuminant: camsim_core::Spectrum,
    grid: camsim_core::WavelengthGrid,
    exposure_scale: Option<f64>,
    saturation_dn: f64,
) -> Result<(Canvas, usize, f64)> {
    let mut isp = camsim_pipeline::Isp::new(illuminant, grid);
    isp.exposure_scale = exposure_scale;
    let k = preview_factor(rgb.cols);
    let small = downsample(rgb, k);
    // A k x k box average has 1/k of one pixel's noise, and is a mean of raw values the ADC
    // clipped at 0 (minus the black level, black-subtracted).
    let black = camsim_pipeline::RawBlack {
        noise_factor: 1.0 / k as f64,
        clip_dn: Some(-sensor.black_level_dn()),
    };
    let (img, report) = isp.render(&small, sensor, saturation_dn, &black)?;
    Ok((
        Canvas {
            w: img.cols,
            h: img.rows,
            data: img.data,
        },
        k,
        report.exposure_scale,
    ))
}

fn position_thumbnail(p: &QualityParams, spectra: &BoxSpectra, c: &Captured) -> Result<Vec<u8>> {
    let (mut img, k, _) = srgb_preview(p, spectra, &c.rgb, None)?;
    draw_gray_box(&mut img, &c.corners, k as f64);
    Ok(img.png()?)
}

fn draw_gray_box(img: &mut Canvas, corners: &ChartCorners, k: f64) {
    // The gray series' row of the chart (Figure 5's red boxes).
    let a = corners.point(0.0, 0.75);
    let b = corners.point(1.0, 0.75);
    let c = corners.point(1.0, 1.0);
    let d = corners.point(0.0, 1.0);
    let s = |p: [f64; 2]| [p[0] / k, p[1] / k];
    for (p, q) in [(a, b), (b, c), (c, d), (d, a)] {
        img.line(s(p), s(q), [255, 0, 0]);
    }
}

fn image_figures(
    opts: &ValidateOptions,
    p: &QualityParams,
    spectra: &BoxSpectra,
    c: &Captured,
    noise: &[NoiseRegion],
) -> Result<Vec<FigurePng>> {
    let mut out = Vec::new();
    let k = preview_factor(c.rgb.cols);
    // (a) The demosaicked sensor data as they are: camera RGB, scaled so the 99th percentile is
    // near 1, sRGB transfer function, no colour correction.
    let small = downsample(&c.rgb, k);
    let mut vals: Vec<f32> = small.g.iter().step_by(7).copied().collect();
    let idx = ((vals.len().max(1) - 1) as f64 * 0.99) as usize;
    let p99 = if vals.is_empty() {
        1.0
    } else {
        *vals.select_nth_unstable_by(idx, |a, b| a.total_cmp(b)).1 as f64
    };
    let sc = if p99 > 0.0 { 1.0 / p99 } else { 1.0 };
    let mut data = vec![0u8; small.pixels() * 3];
    for i in 0..small.pixels() {
        for (ch, plane) in [&small.r, &small.g, &small.b].iter().enumerate() {
            data[i * 3 + ch] = camsim_core::colorimetry::srgb_encode_u8(plane[i] as f64 * sc);
        }
    }
    let raw_img = Canvas {
        w: small.cols,
        h: small.rows,
        data,
    };
    out.push(save_png(
        &opts.out_dir,
        "fig4a_demosaicked.png",
        "Figure 4a: simulated Pixel 4a raw image of the Cornell box with the ColorChecker, bilinearly demosaicked, camera RGB (no colour correction), sRGB transfer curve.",
        raw_img.png()?,
    )?);
    // (b) The sRGB preview with the gray series and the noise regions marked.
    let (mut prev, k2, _) = srgb_preview(p, spectra, &c.rgb, None)?;
    out.push(save_png(
        &opts.out_dir,
        "fig4b_preview.png",
        "Figure 4b: sRGB preview (ColorPipeline: QE fitted to XYZ on the ColorChecker under the box's light, Bradford to D65).",
        prev.png()?,
    )?);
    draw_gray_box(&mut prev, &c.corners, k2 as f64);
    for r in noise {
        let kk = k2 as f64;
        prev.rect(
            r.rect.col as f64 / kk,
            r.rect.row as f64 / kk,
            r.rect.col_end() as f64 / kk,
            r.rect.row_end() as f64 / kk,
            [255, 255, 0],
        );
    }
    out.push(save_png(
        &opts.out_dir,
        "fig5b_center.png",
        "Figure 5b / 6b: chart at the centre; red: the gray series; yellow: the three noise regions.",
        prev.png()?,
    )?);
    Ok(out)
}

fn profile_figures(
    opts: &ValidateOptions,
    positions: &[PositionResult],
    thumbs: Vec<(&str, Vec<u8>)>,
) -> Result<Vec<FigurePng>> {
    let mut out = Vec::new();
    for (name, png) in thumbs {
        let letter = if name == "left" { 'a' } else { 'c' };
        out.push(save_png(
            &opts.out_dir,
            &format!("fig5{letter}_{name}.png"),
            &format!("Figure 5{letter}: chart at the {name}; red: the gray series."),
            png,
        )?);
    }
    let ymax = positions
        .iter()
        .flat_map(|q| q.profile_rgb.iter().flat_map(|v| v.iter().cloned()))
        .fold(0.0, f64::max)
        * 1.05;
    for (i, q) in positions.iter().enumerate() {
        let letter = ['d', 'e', 'f'][i];
        let mut fig = Figure::new(
            format!(
                "Figure 5{letter}: gray series, chart {} (R/G {:.3})",
                q.position, q.gray_rg_ratio
            ),
            "position along the gray series (pixels)",
            "digital value above black (DN)",
        )
        .ranges(None, Some((0.0, ymax.max(1.0))));
        for c in 0..3 {
            fig = fig.with(Series::xy(
                ["R", "G", "B"][c],
                q.profile_distance_px.clone(),
                q.profile_rgb.iter().map(|v| v[c]).collect(),
                Style::Line,
                CHANNEL_COLORS[c],
            ));
        }
        out.push(save_png(
            &opts.out_dir,
            &format!("fig5{letter}_profile_{}.png", q.position),
            &format!("Figure 5{letter}: demosaicked digital values along a line through the gray series, chart {}.", q.position),
            fig.png()?,
        )?);
    }
    Ok(out)
}

fn noise_figures(opts: &ValidateOptions, r: &SceneResults) -> Result<Vec<FigurePng>> {
    let mut out = Vec::new();
    let mut fig = Figure::new(
        "Figure 6c: mean digital values (DN)",
        "noise-free mean (DN)",
        "noisy mean (DN)",
    );
    let mut fig2 = Figure::new(
        "Figure 6d: standard deviations (DN)",
        "predicted std, noise model (DN)",
        "measured std (DN)",
    );
    for c in 0..3 {
        let x: Vec<f64> = r
            .noise
            .iter()
            .map(|g| g.channels[c].noise_free_mean_dn)
            .collect();
        let y: Vec<f64> = r.noise.iter().map(|g| g.channels[c].mean_dn).collect();
        fig = fig.with(Series::xy(
            ["R", "G", "B"][c],
            x,
            y,
            Style::Points,
            CHANNEL_COLORS[c],
        ));
        let xp: Vec<f64> = r
            .noise
            .iter()
            .map(|g| g.channels[c].predicted_std_dn)
            .collect();
        let ys: Vec<f64> = r
            .noise
            .iter()
            .map(|g| g.channels[c].sensor_noise_std_dn)
            .collect();
        let yr: Vec<f64> = r.noise.iter().map(|g| g.channels[c].raw_std_dn).collect();
        fig2 = fig2.with(Series::xy(
            format!("{} noisy - noise-free", ["R", "G", "B"][c]),
            xp.clone(),
            ys,
            Style::Points,
            CHANNEL_COLORS[c],
        ));
        let light = CHANNEL_COLORS[c].map(|v| ((v as u32 + 255) / 2) as u8);
        fig2 = fig2.with(Series::xy(
            format!("{} raw within region", ["R", "G", "B"][c]),
            xp,
            yr,
            Style::Points,
            light,
        ));
    }
    out.push(save_png(
        &opts.out_dir,
        "fig6c_means.png",
        "Figure 6c: mean DN of the three regions, noisy vs noise-free capture.",
        fig.with_identity_line().png()?,
    )?);
    out.push(save_png(
        &opts.out_dir,
        "fig6d_std.png",
        "Figure 6d: standard deviation per region and channel against the noise model: std(noisy - noise-free) (dark) and the raw within-region std (light), dashed y = x.",
        fig2.with_identity_line().png()?,
    )?);
    Ok(out)
}

impl SceneResults {
    /// Write sections 3-5 into the report.
    pub fn report(&self, h: &mut Html) {
        let fig = |h: &mut Html, prefix: &str, figs: &[FigurePng]| {
            for fg in figs.iter().filter(|f| f.file.starts_with(prefix)) {
                h.figure(&fg.png, &fg.caption);
            }
        };
        h.h2("3. Images (Figure 4)", "images");
        h.p(&format!(
            "The built-in cornell-box-mcc scene rendered at {} x {} pixels, {} samples per pixel (the full Pixel 4a field of view), \
             pixel4a optics (in focus), the full {} x {} pixel4a sensor with noise, bilinear demosaic.",
            self.render_px.0, self.render_px.1, self.samples_per_pixel, self.sensor_px.0, self.sensor_px.1
        ));
        fig(h, "fig4", &self.figures);
        let ft = &self.features;
        h.table(
            &["feature", "value"],
            &[
                vec![
                    "light source: saturated fraction of its pixels".into(),
                    f(ft.light_saturated_fraction, 3),
                ],
                vec![
                    "floor in the short block's shadow (luminance DN)".into(),
                    f(ft.shadow_floor_dn, 1),
                ],
                vec!["lit floor (luminance DN)".into(), f(ft.lit_floor_dn, 1)],
                vec!["shadow / lit".into(), f(ft.shadow_to_lit_ratio, 3)],
                vec![
                    "R/G, tall block face toward the red wall".into(),
                    f(ft.rg_face_toward_red_wall, 3),
                ],
                vec![
                    "R/G, short block face toward the green wall".into(),
                    f(ft.rg_face_toward_green_wall, 3),
                ],
                vec!["R/G, lit floor".into(), f(ft.rg_lit_floor, 3)],
            ],
        );
        h.h2(
            "4. Digital values along the gray series (Figure 5)",
            "digital-values",
        );
        fig(h, "fig5", &self.figures);
        let rows: Vec<Vec<String>> = self
            .positions
            .iter()
            .map(|q| {
                vec![
                    q.position.clone(),
                    f(q.gray_rg_ratio, 4),
                    f(q.mean_luminance_cd_m2, 2),
                    f(q.exposure_s * 1e3, 3),
                ]
            })
            .collect();
        h.table(
            &[
                "chart position",
                "R/G (gray patches)",
                "mean scene luminance (cd/m2)",
                "exposure (ms)",
            ],
            &rows,
        );
        h.h2("5. Noise (Figure 6)", "noise");
        h.p("Three gray patches in the linear range of the centre image, raw CFA pixels per channel. The same irradiance captured \
             noise-free at the same exposure removes the render's Monte Carlo noise and the illumination gradient: the standard \
             deviation of (noisy - noise-free) is the sensor noise alone and is compared with the noise model at that mean \
             (shot + read + DSNU + PRNU + quantization). The raw within-region standard deviation (the paper's figure) is listed too.");
        fig(h, "fig6", &self.figures);
        let mut rows = Vec::new();
        for r in &self.noise {
            for c in &r.channels {
                rows.push(vec![
                    r.name.clone(),
                    c.channel.clone(),
                    c.n.to_string(),
                    f(c.mean_dn, 1),
                    f(c.raw_std_dn, 2),
                    f(c.sensor_noise_std_dn, 2),
                    f(c.predicted_std_dn, 2),
                    f(c.ratio, 3),
                    f(c.difference_dn, 2),
                ]);
            }
        }
        h.table(
            &[
                "region",
                "channel",
                "pixels",
                "mean (DN)",
                "raw std (DN)",
                "std(noisy - noise-free) (DN)",
                "predicted std (DN)",
                "ratio",
                "difference (DN)",
            ],
            &rows,
        );
        h.p(&format!(
            "Largest difference between measured and predicted standard deviation: {:.2} DN (sensor noise), {:.2} DN (raw within-region std).",
            self.noise_max_difference_dn, self.noise_max_raw_difference_dn
        ));
    }
}

/// Add the noise figures (called by `run` once the regions are known).
pub(crate) fn add_noise_figures(opts: &ValidateOptions, r: &mut SceneResults) -> Result<()> {
    let figs = noise_figures(opts, r)?;
    r.figures.extend(figs);
    Ok(())
}
