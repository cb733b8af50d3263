//! camsim-pipeline: one config that wires the stages (scene or 3D render -> optics -> sensor ->
//! isp) and the end-to-end run that writes the standard files. Wiring only: each stage's
//! physics lives in its own crate.

pub mod emva;
pub mod error;
pub mod outputs;
pub mod render;
pub mod sequence;
mod simulation;
pub mod timing;

pub use error::{PipelineError, Result};
pub use outputs::{Output, OutputSet};
pub use sequence::FrameFlow;
pub use simulation::{
    image_radiance, simulate, write_id_maps, Imaged, Rgb8Image, RunInfo, SimulateOptions,
    Simulation,
};
pub use timing::{FrameTime, ReadoutDirection, ShutterConfig};

use camsim_core::{SpectralImage, WavelengthGrid};
use camsim_io::dng::DngMetadata;
use camsim_isp::ColorPipeline;
use camsim_optics::{Optics, OpticsConfig};
use camsim_scene::SceneConfig;
use camsim_sensor::{Capture, Exposure, Sensor, SensorConfig};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The whole-pipeline config (`camsim simulate CONFIG.toml`). Exactly one of `[scene]` (a 2D
/// chart) and `[render]` (a 3D scene) is given.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulateConfig {
    /// Seed of the temporal sensor noise and of the renderer (integer).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Wavelength grid `{ start_nm, step_nm, count }`; default 400-700 nm every 10 nm.
    #[serde(default)]
    pub wavelengths: WavelengthGrid,
    /// A 2D scene (see camsim-scene: kind = "uniform" | "macbeth" | "slanted_edge" | "file").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<SceneConfig>,
    /// A 3D scene rendered by the path tracer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<RenderSection>,
    /// The lens.
    #[serde(default)]
    pub optics: OpticsSection,
    /// The sensor.
    #[serde(default)]
    pub sensor: SensorSection,
    /// Exposure and frames.
    #[serde(default)]
    pub capture: CaptureSection,
}

fn default_seed() -> u64 {
    1
}

/// `[render]`: a 3D scene.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    /// A built-in scene: "cornell-box", "cornell-box-mcc", "slanted-edge".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub builtin: Option<String>,
    /// Or a pbrt-v4 scene file (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pbrt: Option<PathBuf>,
    /// Optional overlay TOML (moves objects, sets reflectances and the light), relative to the config.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overlay: Option<PathBuf>,
    /// Optional overlay written inline, the same tables as an overlay file (`[render.overlay_inline.light]`,
    /// `[[render.overlay_inline.object]]`, ...), applied after `overlay`; datasets vary its keys.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overlay_inline: Option<toml::Table>,
    /// Folder the inline overlay's relative spectrum and mesh paths resolve against (the config
    /// file's; set when the config is read from a file, else the current folder).
    #[serde(skip)]
    pub overlay_inline_base: Option<PathBuf>,
    /// Samples per pixel (default: the scene's own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_per_pixel: Option<u32>,
    /// Image width and height in pixels (default: the scene's own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<[usize; 2]>,
}

/// `[optics]`: a preset name, a TOML file, or an inline config.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpticsSection {
    /// Built-in lens: "pixel4a" (default), "pixel4a-measured" or "diffraction-limited".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// Or a lens TOML file (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// Or the lens itself, inline (the same keys as a lens file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<OpticsConfig>,
}

impl Default for OpticsSection {
    fn default() -> Self {
        OpticsSection {
            preset: Some("pixel4a".into()),
            file: None,
            config: None,
        }
    }
}

/// `[sensor]`: a preset name, a TOML file, or an inline config, with an optional window size.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSection {
    /// Built-in sensor: "pixel4a" (default), "pixel4a-raw10", "imx363", "ideal".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// Or a sensor TOML file (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// Or the sensor itself, inline.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<SensorConfig>,
    /// Use a window of this many rows (pixels) centred on the optical axis (default: full sensor).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<usize>,
    /// Window columns, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cols: Option<usize>,
}

impl Default for SensorSection {
    fn default() -> Self {
        SensorSection {
            preset: Some("pixel4a".into()),
            file: None,
            config: None,
            rows: None,
            cols: None,
        }
    }
}

/// `[capture]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaptureSection {
    /// Exposure time, ms. Absent: auto-exposure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_ms: Option<f64>,
    /// Auto-exposure target: the 99th percentile of the brightest colour filter's signal (taken
    /// over that filter's own pixels) reaches this fraction of the voltage swing (0, 1]. Default 0.9.
    #[serde(default = "default_target")]
    pub auto_target_fraction: f64,
    /// Frames of the same exposure (>= 1); with `exposures_ms`, frames per exposure.
    #[serde(default = "default_frames")]
    pub frames: usize,
    /// Exposure bracketing / burst (ISETCam: a vector of exposure times): one raw per entry (x
    /// `frames`), ms, each with its own temporal noise, written raw.dng, raw_0001.dng, ... in
    /// this order. Replaces `exposure_ms` (giving both is an error). The preview, noise_free.exr
    /// and run.json's exposure_s / mean figures are those of the first raw; run.json lists every
    /// raw's exposure time as results.frame_exposures_s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposures_ms: Option<Vec<f64>>,
    /// Scene time at which the first frame's exposure starts, ms (3D scenes: what moves is
    /// where it is then; default: the pbrt camera's `shutteropen`, 0 for built-in scenes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_ms: Option<f64>,
    /// Time from one frame's start to the next, ms (bursts and brackets; default: back to back,
    /// each frame starting when the one before ends).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_interval_ms: Option<f64>,
    /// A video: `frames` frames at this rate, frames per second (the frame interval 1/fps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps: Option<f64>,
    /// `"global"` (default: every row integrates over the same window) or `{ rolling = {
    /// line_time_us = 10.0, direction = "top-down" } }` (sensor row r starts r line times later).
    #[serde(default, skip_serializing_if = "timing::ShutterConfig::is_global")]
    pub shutter: timing::ShutterConfig,
}

fn default_target() -> f64 {
    0.9
}
fn default_frames() -> usize {
    1
}

impl Default for CaptureSection {
    fn default() -> Self {
        CaptureSection {
            exposure_ms: None,
            auto_target_fraction: 0.9,
            frames: 1,
            exposures_ms: None,
            start_ms: None,
            frame_interval_ms: None,
            fps: None,
            shutter: timing::ShutterConfig::Global,
        }
    }
}

/// The built-in default run (`camsim simulate` with no config).
pub const DEFAULT_CONFIG: &str = include_str!("../../../examples/macbeth-d65.toml");

impl SimulateConfig {
    pub fn builtin_default() -> SimulateConfig {
        toml::from_str(DEFAULT_CONFIG).expect("the built-in default config parses (tested)")
    }

    /// Read a TOML config, or a run.json written by an earlier run.
    pub fn load(path: &Path) -> Result<SimulateConfig> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::file(path, format!("cannot read: {e}")))?;
        let mut cfg: SimulateConfig = if path.extension().is_some_and(|e| e == "json") {
            let v: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| PipelineError::file(path, format!("not valid JSON: {e}")))?;
            let c = v.get("config").cloned().unwrap_or(v);
            serde_json::from_value(c)
                .map_err(|e| PipelineError::file(path, format!("not a camsim run.json: {e}")))?
        } else {
            Self::from_toml_text(&text).map_err(|e| PipelineError::file(path, e))?
        };
        cfg.check_scene_source()
            .map_err(|e| PipelineError::file(path, e))?;
        // Paths inside the config are relative to the config file.
        let base = path.parent().unwrap_or(Path::new("."));
        cfg.resolve_paths(base);
        Ok(cfg)
    }

    /// Parse a TOML config from text (paths in it stay as written: relative to the current
    /// folder). The message of an error names the key, line and column.
    pub fn from_toml_str(text: &str) -> Result<SimulateConfig> {
        let cfg = Self::from_toml_text(text).map_err(PipelineError::Config)?;
        cfg.check_scene_source()?;
        Ok(cfg)
    }

    fn from_toml_text(text: &str) -> std::result::Result<SimulateConfig, String> {
        toml::from_str(text).map_err(|e| {
            // The [scene] table is tagged by `kind`, which hides the key's position from
            // toml's first message: find the offending key's own line and column.
            let msg = camsim_scene::config::locate_scene_error(text, Some("scene"))
                .unwrap_or_else(|| e.to_string());
            msg.trim_end().to_string()
        })
    }

    /// The config as TOML text (every field, defaults filled in).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a SimulateConfig serializes to TOML")
    }

    /// Exactly one of `[scene]` (2D) and `[render]` (3D) must be given.
    pub fn check_scene_source(&self) -> Result<()> {
        match (&self.scene, &self.render) {
            (Some(_), Some(_)) => Err(PipelineError::config(
                "give either [scene] (2D) or [render] (3D), not both",
            )),
            (None, None) => Err(PipelineError::config(
                "the config has neither a [scene] nor a [render] table",
            )),
            _ => Ok(()),
        }
    }

    /// Make the relative paths in the config (scene, pbrt, overlay, lens, sensor and QE files)
    /// relative to `base` (the folder of the file the config came from).
    pub fn resolve_paths(&mut self, base: &Path) {
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        if let Some(r) = &mut self.render {
            r.pbrt.as_mut().map(fix);
            r.overlay.as_mut().map(fix);
            r.overlay_inline_base = Some(base.to_path_buf());
        }
        self.optics.file.as_mut().map(fix);
        if let Some(b) = self.optics.config.as_mut().and_then(|c| c.blur.as_mut()) {
            b.lens_file.as_mut().map(fix);
            b.rtf_file.as_mut().map(fix);
        }
        self.sensor.file.as_mut().map(fix);
        if let Some(c) = &mut self.sensor.config {
            c.qe.file.as_mut().map(fix);
        }
        // Scene files: the radiance EXR, the photograph and display, illuminant and reflectance files.
        if let Some(scene) = &mut self.scene {
            scene.resolve_paths(base);
        }
    }

    pub fn optics(&self) -> Result<Optics> {
        let o = &self.optics;
        Ok(match (&o.preset, &o.file, &o.config) {
            (_, _, Some(c)) => Optics::from_config(c)?,
            (_, Some(f), None) => Optics::from_config(&OpticsConfig::from_file(f)?)?,
            (Some(p), None, None) => Optics::preset(p)?,
            (None, None, None) => Optics::preset("pixel4a")?,
        })
    }

    pub fn sensor(&self) -> Result<Sensor> {
        let s = &self.sensor;
        let sensor = match (&s.preset, &s.file, &s.config) {
            (_, _, Some(c)) => Sensor::from_config_named(c.clone(), "[sensor.config]")?,
            (_, Some(f), None) => Sensor::from_file(f)?,
            (Some(p), None, None) => Sensor::preset(p)?,
            (None, None, None) => Sensor::preset("pixel4a")?,
        };
        Ok(match (s.rows, s.cols) {
            (None, None) => sensor,
            (r, c) => sensor.window(r.unwrap_or(sensor.rows()), c.unwrap_or(sensor.cols()))?,
        })
    }

    /// The bracket's exposure times, s (`capture.exposures_ms`), or `None` for one exposure.
    pub fn bracket_exposures_s(&self) -> Result<Option<Vec<f64>>> {
        let c = &self.capture;
        let Some(list) = &c.exposures_ms else {
            return Ok(None);
        };
        if c.exposure_ms.is_some() {
            return Err(PipelineError::config(
                "give either capture.exposure_ms or capture.exposures_ms (a bracket), not both",
            ));
        }
        if list.is_empty() {
            return Err(PipelineError::config(
                "capture.exposures_ms is empty: give at least one exposure time, ms",
            ));
        }
        if let Some((i, ms)) = list
            .iter()
            .enumerate()
            .find(|(_, ms)| !(ms.is_finite() && **ms >= 0.0))
        {
            return Err(PipelineError::config(format!(
                "capture.exposures_ms[{i}] = {ms}: must be a finite time >= 0 ms"
            )));
        }
        Ok(Some(list.iter().map(|ms| ms * 1e-3).collect()))
    }

    pub fn capture(&self) -> Result<Capture> {
        let c = &self.capture;
        if c.frames == 0 {
            return Err(PipelineError::config("capture.frames must be at least 1"));
        }
        self.bracket_exposures_s()?;
        let exposure = match c.exposure_ms {
            Some(ms) if !(ms >= 0.0 && ms.is_finite()) => {
                return Err(PipelineError::config(format!(
                    "capture.exposure_ms = {ms}: must be >= 0"
                )))
            }
            Some(ms) => Exposure::Seconds(ms * 1e-3),
            None => {
                if !(c.auto_target_fraction > 0.0 && c.auto_target_fraction <= 1.0) {
                    return Err(PipelineError::config(format!(
                        "capture.auto_target_fraction = {}: must be in (0, 1]",
                        c.auto_target_fraction
                    )));
                }
                Exposure::Auto {
                    target_fraction: c.auto_target_fraction,
                }
            }
        };
        Ok(Capture {
            exposure,
            frames: c.frames,
            seed: self.seed,
        })
    }
}

/// Stage 1: the scene radiance (2D chart or 3D render).
/// `progress(stage, done, total)` is called as long steps advance.
pub fn scene_radiance(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<SpectralImage> {
    Ok(scene_stage(cfg, sensor, optics, progress)?.0)
}

/// [`scene_radiance`] with the object and material id maps of a rendered 3D scene (None for 2D
/// charts and scene files).
pub fn scene_stage(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<(SpectralImage, Option<camsim_render::IdMaps>)> {
    cfg.wavelengths.validate()?;
    cfg.check_scene_source()?;
    match (&cfg.scene, &cfg.render) {
        (Some(_), Some(_)) | (None, None) => unreachable!("checked by check_scene_source"),
        (Some(s), None) => Ok((
            camsim_scene::create(s, &cfg.wavelengths)
                .map_err(|e| PipelineError::Scene(e.to_string()))?,
            None,
        )),
        (None, Some(r)) => render::render_section(r, cfg, sensor, optics, progress)
            .map(|(img, ids)| (img, Some(ids))),
    }
}

/// Progress callback: (stage name, steps done, steps in all).
pub type Progress<'a> = dyn Fn(&str, u64, u64) + Sync + 'a;

/// What raw.png holds, for run.json: the mosaic scaled from `bits` bits to the 16-bit range.
pub fn raw_png_note(bits: u32) -> serde_json::Value {
    serde_json::json!({
        "scale": format!("16-bit value = round(DN x 65535 / {}), DN the {bits}-bit ADC value", (1u64 << bits) - 1),
        "adc_bits": bits,
        "invert": format!("DN = round(value x {} / 65535)", (1u64 << bits) - 1),
    })
}

/// The colour pipeline for a sensor under the scene's illuminant (D65 when unknown).
pub fn color_pipeline(
    sensor: &Sensor,
    grid: &WavelengthGrid,
    scene: Option<&SceneConfig>,
) -> Result<ColorPipeline> {
    let illum = match scene.and_then(camsim_scene::scene_illuminant) {
        Some(r) => r?,
        None => camsim_core::tables::illuminant("D65")?,
    };
    ColorPipeline::fit(&sensor.channel_qe(grid), grid, &illum)
        .map_err(|e| PipelineError::config(format!("colour pipeline: {e}")))
}

/// DNG metadata: camera name, the colour matrix and neutral fitted by the ISP, and the run's
/// config as the image description.
pub fn dng_metadata(
    sensor: &Sensor,
    color: &ColorPipeline,
    cfg: Option<&SimulateConfig>,
) -> Result<DngMetadata> {
    Ok(DngMetadata {
        camera_model: format!("camsim {}", sensor.name()),
        color_matrix1: Some(color.xyz_to_camera()),
        as_shot_neutral: Some(color.as_shot_neutral()),
        description: cfg.map(serde_json::to_string).transpose()?,
        // Only a sensor that states its ISO (`iso`) gets the EXIF tag: the DNGs of the other
        // presets stay byte-identical.
        iso: sensor.config().iso,
        ..DngMetadata::default()
    })
}

/// A sensor from a preset name or a TOML file path.
pub fn load_sensor(spec: &str) -> Result<Sensor> {
    let p = Path::new(spec);
    if spec.ends_with(".toml") || p.exists() {
        Ok(Sensor::from_file(p)?)
    } else {
        Ok(Sensor::preset(spec)?)
    }
}

/// A lens from a preset name or a TOML file path.
pub fn load_lens(spec: &str) -> Result<OpticsConfig> {
    let p = Path::new(spec);
    if spec.ends_with(".toml") || p.exists() {
        Ok(OpticsConfig::from_file(p)?)
    } else {
        Ok(OpticsConfig::preset(spec)?)
    }
}

/// A raw mosaic from a DNG, or from a 16-bit PNG/TIFF mosaic with the CFA pattern given
/// (`cfa`), black level `black_dn` and ADC `bits` (PNG/TIFF carry none of these).
pub fn load_raw(
    path: &Path,
    cfa: Option<camsim_core::CfaPattern>,
    black_dn: f64,
    bits: u32,
) -> Result<camsim_core::RawImage> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "dng" {
        return Ok(camsim_io::dng::read_dng(path)?.0);
    }
    if !matches!(ext.as_str(), "png" | "tif" | "tiff") {
        return Err(PipelineError::file(
            path,
            "not a raw file camsim reads (DNG, or a 16-bit PNG/TIFF mosaic with --cfa)",
        ));
    }
    let cfa = cfa.ok_or_else(|| {
        PipelineError::file(
            path,
            "a PNG/TIFF mosaic needs its CFA pattern (--cfa RGGB|GRBG|GBRG|BGGR)",
        )
    })?;
    if !(1..=16).contains(&bits) {
        return Err(PipelineError::config(format!(
            "--bits {bits}: must be 1..16"
        )));
    }
    let (rows, cols, dn) = camsim_io::raster::read_mosaic_16(path)?;
    let mut raw = camsim_core::RawImage::new(rows, cols, cfa, bits)?;
    raw.dn = dn;
    raw.black_level_dn = black_dn;
    Ok(raw)
}

/// Where the patch grid of a `macbeth` scene lands on the sensor: its outer corners `[x, y]` in
/// sensor pixels (pixel (r, c) covers [c, c + 1) x [r, r + 1)), in the order top-left (dark
/// skin), top-right (bluish green), bottom-right (black), bottom-left (white). The grid is taken
/// through the middle of the chart's outer border, so it spans 6 x 4 equal patch pitches and its
/// cells are centred on the patches. `Ok(None)` when the config's scene is not a Macbeth chart.
///
/// The mapping is the pipeline's own: scene samples of 2 d tan(fov / 2) / cols_scene
/// (`camsim_scene::sample_spacing_m`), scaled onto the sensor plane by v / d with v the thin-lens
/// image distance of the focus distance (as `Optics::compute`: no inversion, centred on the
/// axis), and a `rows x cols` sensor window of `pixel_pitch_m` centred on the axis (as
/// `Sensor::compute`).
pub fn macbeth_chart_corners_px(
    cfg: &SimulateConfig,
    optics: &OpticsConfig,
    pixel_pitch_m: f64,
    rows: usize,
    cols: usize,
) -> Result<Option<[[f64; 2]; 4]>> {
    let Some(SceneConfig::Macbeth(m)) = &cfg.scene else {
        return Ok(None);
    };
    if !(pixel_pitch_m > 0.0 && pixel_pitch_m.is_finite()) {
        return Err(PipelineError::config(format!(
            "pixel pitch {pixel_pitch_m} m is not a positive number"
        )));
    }
    let layout = camsim_scene::MacbethLayout {
        patch_px: m.patch_size_px,
        border_px: m.border_px,
    };
    let (scene_rows, scene_cols) = (layout.rows() as f64, layout.cols() as f64);
    let f_m = optics.focal_length_mm * 1e-3;
    let d_m = m.distance_m;
    let Some(v_m) =
        camsim_optics::lens::image_distance_m(f_m, optics.focus_distance_m.unwrap_or(d_m))
    else {
        return Err(PipelineError::config(format!(
            "focus distance inside the focal length ({f_m} m): no real image"
        )));
    };
    let spacing_img_m = camsim_scene::sample_spacing_m(m.fov_deg, d_m, layout.cols()) * v_m / d_m;
    let k = spacing_img_m / pixel_pitch_m; // sensor pixels per scene sample
    if !(k > 0.0 && k.is_finite()) {
        return Err(PipelineError::config(
            "scene.fov_deg / distance_m give no finite image scale",
        ));
    }
    let to_sensor = |x: f64, y: f64| {
        [
            cols as f64 / 2.0 + (x - scene_cols / 2.0) * k,
            rows as f64 / 2.0 + (y - scene_rows / 2.0) * k,
        ]
    };
    let h = m.border_px as f64 / 2.0;
    Ok(Some([
        to_sensor(h, h),
        to_sensor(scene_cols - h, h),
        to_sensor(scene_cols - h, scene_rows - h),
        to_sensor(h, scene_rows - h),
    ]))
}

/// Mean luminance of a radiance image, cd/m^2: 683 lm/W x sum over bands of ybar L d(lambda)
/// (CIE 1931 photopic luminous efficiency).
pub fn mean_luminance_cd_m2(radiance: &SpectralImage) -> f64 {
    use rayon::prelude::*;
    let cmfs = camsim_core::colorimetry::Cmfs::on(&radiance.grid);
    // 683 lm/W sum_b y_bar_b L_b dl, averaged over the pixels (CIE 015:2018 eq. 7.1). Bands in
    // parallel, each summed in 8 lanes: a full-frame radiance has ~280 M samples, and one serial
    // f64 sum over them took half a second after the run (the `simulate` output overhead).
    let total: f64 = (0..radiance.bands())
        .into_par_iter()
        .map(|b| {
            let v = radiance.band(b);
            let mut lanes = [0f64; 8];
            let chunks = v.chunks_exact(8);
            let rest: f64 = chunks.remainder().iter().map(|x| *x as f64).sum();
            for c in chunks {
                for (l, x) in lanes.iter_mut().zip(c) {
                    *l += *x as f64;
                }
            }
            (lanes.iter().sum::<f64>() + rest) * cmfs.y[b]
        })
        .sum();
    total * camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * radiance.grid.step_nm
        / radiance.pixels() as f64
}
