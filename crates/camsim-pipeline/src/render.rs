//! 3D scenes in the pipeline: load (built-in or pbrt-v4, plus overlay), match the camera to the
//! sensor, render.

use crate::{Progress, RenderSection, SimulateConfig};
use anyhow::{bail, Context, Result};
use camsim_core::SpectralImage;
use camsim_optics::Optics;
use camsim_render::builtin::{self, BuiltinOptions};
use camsim_render::{RenderOutput, SceneDescription};
use camsim_sensor::Sensor;
use std::path::Path;

/// Load a scene description: a built-in by name or a pbrt-v4 file, then the overlay. Returns the
/// scene and the notes the reader made (ignored or approximated parameters).
pub fn load_scene(
    builtin_name: Option<&str>,
    pbrt: Option<&Path>,
    overlay: Option<&Path>,
    opts: &BuiltinOptions,
) -> Result<SceneDescription> {
    let mut scene = match (builtin_name, pbrt) {
        (Some(name), None) => builtin::scene(name, opts)?,
        (None, Some(path)) => {
            let mut s = camsim_render::pbrt::parse_file(path).map_err(|e| anyhow::anyhow!("{e}"))?;
            s.settings.grid = opts.grid;
            s.settings.seed = opts.seed;
            if let Some((w, h)) = opts.resolution {
                s.camera.width = w;
                s.camera.height = h;
            }
            s
        }
        (Some(_), Some(_)) => bail!("give a pbrt file or a built-in scene, not both"),
        (None, None) => bail!("give a pbrt-v4 scene file or a built-in scene (one of {})", builtin::names().join(", ")),
    };
    if let Some(o) = overlay {
        let text = std::fs::read_to_string(o).with_context(|| format!("cannot read {}", o.display()))?;
        let base = o.parent().unwrap_or(Path::new("."));
        camsim_render::overlay::apply(&mut scene, &text, &o.display().to_string(), base)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    Ok(scene)
}

/// Render, reporting progress as ("render", tiles done, tiles in all).
pub fn render_scene(scene: &SceneDescription, progress: &Progress<'_>) -> Result<RenderOutput> {
    Ok(camsim_render::render(scene, &|done, total| progress("render", done, total))?)
}

/// Set the camera's field of view to what the sensor window sees through the lens (pinhole at
/// the focal length), for an image of `width` x `height` pixels.
pub fn match_camera_to_sensor(scene: &mut SceneDescription, sensor: &Sensor, focal_length_m: f64, width: usize, height: usize) {
    let sensor_w_m = sensor.cols() as f64 * sensor.pixel_pitch_m();
    let sensor_h_m = sensor.rows() as f64 * sensor.pixel_pitch_m();
    // pbrt's fov spans the shorter image axis; the render's aspect ratio may differ from the sensor's.
    let short_m = if width >= height {
        sensor_h_m.min(sensor_w_m * height as f64 / width as f64)
    } else {
        sensor_w_m.min(sensor_h_m * width as f64 / height as f64)
    };
    scene.camera.fov_deg = 2.0 * (short_m / 2.0 / focal_length_m).atan().to_degrees();
    scene.camera.width = width;
    scene.camera.height = height;
}

/// The scene of a `[render]` section, set up as `simulate` renders it: its resolution (default:
/// the sensor window's size), samples and seed, and the camera's field of view set to the sensor
/// window seen through the lens, so the radiance covers exactly the sensor. `camsim render
/// --config` uses this too, so `render -> optics -> sensor` reproduces `simulate`.
pub fn render_section_scene(r: &RenderSection, cfg: &SimulateConfig, sensor: &Sensor, optics: &Optics) -> Result<SceneDescription> {
    let (w, h) = match r.resolution {
        Some([w, h]) => (w, h),
        None => (sensor.cols(), sensor.rows()),
    };
    let mut opts = BuiltinOptions { grid: cfg.wavelengths, seed: cfg.seed, resolution: Some((w, h)), ..BuiltinOptions::default() };
    if let Some(spp) = r.samples_per_pixel {
        opts.samples_per_pixel = spp;
    }
    let mut scene = load_scene(r.builtin.as_deref(), r.pbrt.as_deref(), r.overlay.as_deref(), &opts)?;
    if let Some(spp) = r.samples_per_pixel {
        scene.settings.samples_per_pixel = spp;
    }
    match_camera_to_sensor(&mut scene, sensor, optics.config().focal_length_mm * 1e-3, w, h);
    Ok(scene)
}

/// `simulate` with a `[render]` section: render [`render_section_scene`].
pub fn render_section(
    r: &RenderSection,
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<SpectralImage> {
    let scene = render_section_scene(r, cfg, sensor, optics)?;
    Ok(render_scene(&scene, progress)?.radiance)
}
