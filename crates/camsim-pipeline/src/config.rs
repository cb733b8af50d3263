//! The config door: [`SimulateConfig`] (`camsim simulate CONFIG.toml`, Python's config dicts,
//! dataset samples) and the one way any source becomes a checked config,
//! [`SimulateConfig::from_value`]. The sections build the stage objects ([`SimulateConfig::optics`],
//! [`SimulateConfig::sensor`], [`SimulateConfig::capture`]).

use crate::capture::{CaptureRequest, CONFIG_KEYS};
use crate::{PipelineError, Result};
use camsim_core::WavelengthGrid;
use camsim_optics::{Optics, OpticsConfig};
use camsim_scene::SceneConfig;
use camsim_sensor::{Capture, Sensor, SensorConfig};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The whole-pipeline config (`camsim simulate CONFIG.toml`). Exactly one of `[scene]` (a 2D
/// chart) and `[render]` (a 3D scene) is given.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// The scene's light is modulated in time (LED flicker, pulse-width modulation): all of it
    /// (a 2D scene's illuminant; every light of a 3D scene), integrated over each sensor row's
    /// own exposure window (`[capture] shutter`, frame times). The stated radiance is the
    /// light's time mean. `{ frequency_hz = 90.0, duty = 0.1, phase = 0.0 }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker: Option<camsim_sensor::Flicker>,
    /// Light groups that flicker each in its own way, by group name (3D scenes): `[light_flicker]
    /// sign = { frequency_hz = 90.0, duty = 0.1 }` modulates the lights of group `sign` (pbrt
    /// `"string lightgroup"`, overlay `[[light_group]]`) and leaves the others steady. The
    /// render splits its radiance by group in the same pass, the optics image each modulated
    /// group apart, and each sensor row integrates each group over its own window
    /// (`[capture] shutter`, frame times). Not with `[flicker]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_flicker: Option<std::collections::BTreeMap<String, camsim_sensor::Flicker>>,
    /// The preview's ISP.
    #[serde(default, skip_serializing_if = "IspSection::is_default")]
    pub isp: IspSection,
}

/// `[isp]`: how simulate renders its preview.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IspSection {
    /// Tone curve of the preview: "clip" (clip at white), "reinhard" (Reinhard et al. 2002,
    /// global, with burn-out) or "filmic" (ACES fit, Narkowicz 2016); the last two also set the
    /// exposure (the log-average luminance at 0.18). Absent: "reinhard" for a merged HDR frame
    /// (an `[hdr]` sensor, an exposure bracket), "clip" for a single frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tone_map: Option<camsim_isp::tone::ToneMap>,
    /// Column and row noise correction of the raw (first): "off" (default) or "sensor" (the
    /// offsets of each column and row of the sensor's fixed dark frame, subtracted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub column_correction: Option<camsim_isp::line_noise::ColumnCorrection>,
    /// Defect-pixel correction of the raw: "off" (default), "sensor" (the sensor's defect list)
    /// or "detect" (pixels off the median of their same-filter 5 x 5 neighbours by more than
    /// `defect_sigmas`); each is replaced by that median.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defect_correction: Option<camsim_isp::defect_correction::DefectCorrection>,
    /// Threshold of `defect_correction = "detect"`, robust sigmas (1.4826 MAD) of the residual
    /// from the same-filter median. Default 6.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defect_sigmas: Option<f64>,
    /// Denoising of the raw: "off" (default) or "nlm" (non-local means, Buades, Coll and Morel
    /// 2005, per CFA sub-lattice, with the sensor's shot and read noise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise: Option<camsim_isp::denoise::Denoise>,
    /// Strength of `denoise`: h = 0.4 x strength x sigma. Default 1 ('auto': sigma from the
    /// sensor's noise model at each pixel's signal).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise_strength: Option<f64>,
    /// Lens-shading correction of the raw: a shading file (the TOML `camsim fit-shading` writes
    /// from a flat field; relative to the config). Each pixel's signal above black is divided by
    /// its filter's relative illumination at its place, after the denoising and before the
    /// demosaic. Absent: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lens_shading: Option<PathBuf>,
    /// Unsharp mask of the demosaicked image: `{ radius_px, amount, threshold }` (Gaussian sigma,
    /// pixels; gain of the detail; details at most `threshold` DN are left alone). Absent: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sharpen: Option<camsim_isp::sharpen::UnsharpMask>,
    /// JPEG quality (IJG, 1-100) of a JPEG preview. Absent: 90 where a JPEG is written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jpeg_quality: Option<u8>,
}

impl IspSection {
    fn is_default(&self) -> bool {
        *self == IspSection::default()
    }
}

fn default_seed() -> u64 {
    1
}

/// `[render]`: a 3D scene.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    /// A built-in scene, by name (`camsim presets` lists them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub builtin: Option<String>,
    /// Or a scene file (relative to the config file): pbrt-v4, glTF 2.0 (`.gltf`, `.glb`) or
    /// OBJ, told apart by its content. `file` is another name for this key.
    #[serde(default, alias = "file", skip_serializing_if = "Option::is_none")]
    pub pbrt: Option<PathBuf>,
    /// Optional overlay TOML (moves objects, sets reflectances and the light), relative to the config.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overlay: Option<PathBuf>,
    /// Optional overlay written inline, the same tables as an overlay file (`[render.overlay_inline.light]`,
    /// `[[render.overlay_inline.object]]`, ...), applied after `overlay`; datasets vary its keys.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Map<String, serde_json::Value>>")]
    pub overlay_inline: Option<toml::Table>,
    /// Folder the inline overlay's relative spectrum and mesh paths resolve against (the config
    /// file's; set when the config is read from a file, else the current folder).
    #[serde(skip)]
    pub overlay_inline_base: Option<PathBuf>,
    /// Scene composition (`[render.compose]`: asset manifests, `[[render.compose.spawn]]`
    /// placement, `[render.compose.physics]` settling), applied after the overlays with the
    /// config's `seed`; its relative paths resolve against the config's folder. Datasets vary
    /// it through `[[vary]]` keys and the sample's seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compose: Option<camsim_compose::ComposeSpec>,
    /// The seed `[render.compose]` draws from [default: the config's `seed`]. A dataset rig's
    /// cameras ([[rig]]) share their sample's composition through it while each renders and
    /// reads out with a seed of its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compose_seed: Option<u64>,
    /// Move the camera in its own frame once the scene (and a composition's camera sampler)
    /// placed it (`[render.camera_offset]`): a rig camera's extrinsics relative to the rig
    /// (docs/src/compose.md, "Camera rigs").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_offset: Option<CameraOffset>,
    /// Samples per pixel (default: the scene's own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_per_pixel: Option<u32>,
    /// Image width and height in pixels (default: the scene's own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<[usize; 2]>,
    /// Light-group weights, `{ sky = 0.01, headlights = 1 }`: the render splits its radiance by
    /// group of lights (pbrt `"string lightgroup"`, overlay `[[light_group]]`; lights without
    /// one are in `default`) in one pass, and the scene image is the weighted sum (groups not
    /// named here weigh 1) before optics and sensor ([`crate::light_groups`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_groups: Option<std::collections::BTreeMap<String, f64>>,
    /// Adaptive sampling (`[render.adaptive]`): each pixel stops once the render's noise is a
    /// fraction of the sensor's own temporal noise there (or a relative error, with
    /// `relative_error`); `samples_per_pixel` is then the most any pixel takes
    /// (docs/src/adaptive.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveSection>,
    /// Denoise the rendered film (`[render.denoise]`) with Intel Open Image Denoise, a library
    /// camsim opens at run time (`pip install oidn` ships one): for training data, not for lens
    /// or sensor studies, whose figures it changes (docs/src/adaptive.md, "Denoised radiance").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise: Option<DenoiseSection>,
    /// How a glTF or OBJ `pbrt`/`file` is read (`[render.asset]`: the glTF scene and camera,
    /// the OBJ's unit and up axis); refused for a pbrt-v4 file or a built-in.
    #[serde(default, skip_serializing_if = "AssetReadSection::is_default")]
    pub asset: AssetReadSection,
}

/// `[render.camera_offset]`: a pose relative to the scene's camera, in that camera's frame (x
/// right, y up, z forward, as the image): translated, then turned by yaw, pitch and roll about
/// the moved centre ([`camsim_scene3d::SceneDescription::move_camera_in_own_frame`]). A camera that moves during
/// the exposure carries the offset camera with it, fixed to it as on one rig.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraOffset {
    /// Translation in the camera's frame, m: a stereo pair's right camera is `[baseline, 0, 0]`.
    #[serde(default)]
    pub translation_m: [f64; 3],
    /// Turn toward the camera's right (+x), degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Turn toward the camera's up (+y), degrees.
    #[serde(default)]
    pub pitch_deg: f64,
    /// Roll turning the camera's right axis toward its up axis, degrees.
    #[serde(default)]
    pub roll_deg: f64,
}

impl CameraOffset {
    /// Every number finite.
    pub fn check(&self, key: &str) -> Result<()> {
        let all = self
            .translation_m
            .iter()
            .chain([&self.yaw_deg, &self.pitch_deg, &self.roll_deg]);
        if all.clone().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(PipelineError::config(format!(
                "{key}: translation_m, yaw_deg, pitch_deg and roll_deg must be finite numbers"
            )))
        }
    }
}

/// `[render.asset]` (and `camsim render --gltf-scene/--gltf-camera/--obj-scale-m/--obj-up`):
/// choices the glTF and OBJ readers take (docs/src/assets.md).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AssetReadSection {
    /// glTF: the scene to read, by name or index [default: the file's `scene`, else the first].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    /// glTF: the camera to look through, by node or camera name or index [default: the first
    /// in the scene's node order; camsim's framing camera when the file has none].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<String>,
    /// OBJ: metres per file unit (OBJ has no units) [default: 1, metres; 0.01 for centimetres].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj_scale_m: Option<f64>,
    /// OBJ: the file's up axis, `"y"` or `"z"` [default: y, the OBJ/glTF convention].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj_up_axis: Option<String>,
}

impl AssetReadSection {
    fn is_default(&self) -> bool {
        *self == AssetReadSection::default()
    }

    /// The readers' options (image `width` when the file gives no aspect), checked: errors name
    /// the key.
    pub fn read_options(&self, width: usize) -> crate::Result<camsim_assets::ReadOptions> {
        let mut o = camsim_assets::ReadOptions {
            scene: self.scene.clone(),
            camera: self.camera.clone(),
            width,
            ..Default::default()
        };
        if let Some(m) = self.obj_scale_m {
            if !(m.is_finite() && m > 0.0) {
                return Err(crate::PipelineError::config(format!(
                    "render.asset.obj_scale_m: {m} is not a positive number of metres per unit"
                )));
            }
            o.obj_scale_m = m;
        }
        if let Some(a) = &self.obj_up_axis {
            o.obj_up_axis = camsim_assets::UpAxis::parse(a).map_err(|e| {
                crate::PipelineError::config(format!("render.asset.obj_up_axis: {e}"))
            })?;
        }
        Ok(o)
    }
}

/// `[render.denoise]`: where the denoiser's library is.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DenoiseSection {
    /// The OIDN shared library (`libOpenImageDenoise.so.*`, e.g. `oidn/lib.linux.x64/` in the
    /// `oidn` wheel), relative to the config file [default: `$CAMSIM_OIDN_LIBRARY`, else the
    /// system's library path].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub library: Option<PathBuf>,
}

impl DenoiseSection {
    /// The render setting of this section.
    pub fn settings(&self) -> camsim_scene3d::scene::DenoiseSettings {
        camsim_scene3d::scene::DenoiseSettings {
            library: self.library.clone(),
        }
    }
}

/// `[render.adaptive]`: when a pixel of the render has enough samples (`crate::adaptive`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveSection {
    /// The render's noise allowed, as a fraction of the sensor's temporal noise (photon shot,
    /// read, DSNU, dark shot and quantization noise at the pixel's own signal) [0.2: the rendered
    /// noise adds sqrt(1 + 0.2^2) - 1 = 2 % to the raw's temporal noise; 0.1 adds 0.5 % for 4x
    /// the samples].
    #[serde(default = "default_noise_fraction")]
    pub noise_fraction: f64,
    /// Or a relative standard error of each pixel's luminance (0.01: 1 %), as `camsim render
    /// --adaptive-error`, instead of the sensor's noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_error: Option<f64>,
    /// Samples every pixel takes before its first test, rounded up to passes of 8 [32].
    #[serde(default = "default_min_samples")]
    pub min_samples: u32,
}

fn default_noise_fraction() -> f64 {
    0.2
}

fn default_min_samples() -> u32 {
    32
}

impl Default for AdaptiveSection {
    fn default() -> Self {
        AdaptiveSection {
            noise_fraction: default_noise_fraction(),
            relative_error: None,
            min_samples: default_min_samples(),
        }
    }
}

/// `[optics]`: a preset name, a TOML file, or an inline config.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OpticsSection {
    /// Built-in lens, by name (`camsim presets` lists them); default "pixel4a".
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
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SensorSection {
    /// Built-in sensor, by name (`camsim presets` lists them); default "pixel4a".
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
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// this order. Replaces `exposure_ms` (giving both is an error). The preview and run.json's
    /// exposure_s / mean figures are those of the first raw (noise_free.exr, noise_free_0001.exr,
    /// ... one per raw); run.json lists every raw's exposure time as results.frame_exposures_s.
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
    /// `"global"` (default: every row integrates over the same window), `{ rolling = {
    /// line_time_us = 10.0, direction = "top-down" } }` (sensor row r starts r line times later)
    /// or `{ global_reset = { line_time_us = 10.0, direction = "top-down", mechanical_shutter =
    /// false } }` (every row starts at the frame's start and row r is read r line times after
    /// the first: it integrates that much longer; with a mechanical shutter only its dark
    /// current does).
    #[serde(
        default,
        skip_serializing_if = "crate::timing::ShutterConfig::is_global"
    )]
    pub shutter: crate::timing::ShutterConfig,
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
            shutter: crate::timing::ShutterConfig::Global,
        }
    }
}

/// The sections whose `config` table may override a `preset` key by key.
const PRESET_SECTIONS: [&str; 2] = ["optics", "sensor"];

/// The preset name of a section that also has an inline `config` table (a preset overridden
/// key by key), or None.
fn preset_override<T: PresetTable>(section: Option<&T>) -> Option<String> {
    let s = section?;
    if !s.has_config() {
        return None;
    }
    s.preset_name()
}

/// The two table types a config arrives as (TOML text, any other serde value).
trait PresetTable {
    fn has_config(&self) -> bool;
    fn preset_name(&self) -> Option<String>;
}

impl PresetTable for toml::Value {
    fn has_config(&self) -> bool {
        self.get("config").is_some()
    }
    fn preset_name(&self) -> Option<String> {
        self.get("preset")
            .map(|p| p.as_str().map_or_else(|| p.to_string(), str::to_string))
    }
}

impl PresetTable for serde_json::Value {
    fn has_config(&self) -> bool {
        self.get("config").is_some_and(|c| !c.is_null())
    }
    fn preset_name(&self) -> Option<String> {
        self.get("preset")
            .filter(|p| !p.is_null())
            .map(|p| p.as_str().map_or_else(|| p.to_string(), str::to_string))
    }
}

/// `[optics] preset = "pixel4a"` plus `[optics.config] f_number = 2.8` (and the same for
/// `[sensor]`): the preset's whole config with the given keys put over it (tables merged key by
/// key, anything else replaced), written back as the section's inline config. Keys the preset's
/// config does not have stay, so the typed read that follows refuses them by name.
fn merge_presets(v: &mut serde_json::Value) -> Result<()> {
    for section in PRESET_SECTIONS {
        let Some(name) = preset_override(v.get(section)) else {
            continue;
        };
        let sec = v
            .get_mut(section)
            .and_then(|s| s.as_object_mut())
            .expect("preset_override found a table");
        if sec.get("file").is_some_and(|f| !f.is_null()) {
            return Err(PipelineError::config(format!(
                "[{section}] give preset or file, not both"
            )));
        }
        let preset = match section {
            "optics" => serde_json::to_value(OpticsConfig::preset(&name)?),
            _ => serde_json::to_value(Sensor::preset(&name)?.config()),
        }
        .map_err(|e| PipelineError::config(format!("[{section}] preset {name}: {e}")))?;
        let overrides = sec
            .remove("config")
            .expect("preset_override found a config");
        if !overrides.is_object() {
            return Err(PipelineError::config(format!(
                "[{section}] config must be a table"
            )));
        }
        let mut merged = preset;
        if section == "sensor" {
            drop_replaced_sensor_keys(&mut merged, &overrides);
        }
        merge_into(&mut merged, overrides);
        sec.remove("preset");
        sec.insert("config".into(), merged);
    }
    Ok(())
}

/// Before a `[sensor.config]` table goes over a sensor preset: where the override gives one of
/// two keys that state the same setting ([`camsim_sensor::config::ALTERNATIVE_KEYS`]: `cfa` or
/// `cfa_pattern`, `iso` or `analog_gain`), the preset's other key goes, so the override replaces
/// the preset's setting instead of clashing with it; a `[qe]` table with a `file` replaces the
/// preset's whole `[qe]` table (its inline curves and named filters) and its QE correction.
fn drop_replaced_sensor_keys(preset: &mut serde_json::Value, over: &serde_json::Value) {
    let given = |v: &serde_json::Value, k: &str| v.get(k).is_some_and(|x| !x.is_null());
    let Some(p) = preset.as_object_mut() else {
        return;
    };
    for (a, b) in camsim_sensor::config::ALTERNATIVE_KEYS {
        for (mine, other) in [(a, b), (b, a)] {
            if given(over, mine) && !given(over, other) {
                p.remove(other);
            }
        }
    }
    // The QE correction is fitted to the preset's curves (`QeConfig::correction`): it goes with them.
    if over.get("qe").is_some_and(|q| given(q, "file")) {
        p.remove("qe");
        p.remove("qe_correction");
    }
}

/// Put `over` over `base`: tables key by key (recursively), any other value replaced.
fn merge_into(base: &mut serde_json::Value, over: serde_json::Value) {
    match (base, over) {
        (serde_json::Value::Object(b), serde_json::Value::Object(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge_into(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

/// The built-in default run (`camsim simulate` with no config).
pub const DEFAULT_CONFIG: &str = include_str!("../../../examples/macbeth-d65.toml");

impl SimulateConfig {
    /// The built-in default run ([`DEFAULT_CONFIG`]: `camsim simulate` with no config, Python's
    /// `camsim.simulate()` with no argument).
    pub fn builtin_default() -> SimulateConfig {
        toml::from_str(DEFAULT_CONFIG).expect("the built-in default config parses (tested)")
    }

    /// The one config door: a config from any serde value (a TOML table, a JSON value, a Python
    /// dict, a dataset sample's table, a TOML text deserializer), checked
    /// ([`Self::check_scene_source`]) and with its relative paths made relative to `base_dir`
    /// ([`Self::resolve_paths`]; `Path::new("")` keeps them as written, relative to the current
    /// folder). Every other way in ([`Self::load`], [`Self::from_toml_str`]) ends here.
    pub fn from_value<'de, D>(value: D, base_dir: &Path) -> Result<SimulateConfig>
    where
        D: serde::Deserializer<'de>,
        D::Error: std::fmt::Display,
    {
        let mut v = serde_json::Value::deserialize(value)
            .map_err(|e| PipelineError::Config(e.to_string().trim_end().to_string()))?;
        merge_presets(&mut v)?;
        let cfg = SimulateConfig::deserialize(v)
            .map_err(|e| PipelineError::Config(e.to_string().trim_end().to_string()))?;
        cfg.finish(base_dir)
    }

    /// Read a TOML config, or a run.json written by an earlier run (its `config`); paths in it
    /// are relative to the file's folder. Errors name the file.
    pub fn load(path: &Path) -> Result<SimulateConfig> {
        let base = path.parent().unwrap_or(Path::new("."));
        if path.extension().is_some_and(|e| e == "json") {
            let v = crate::records::read_json(path)?;
            let c = v.get("config").cloned().unwrap_or(v);
            return SimulateConfig::deserialize(c)
                .map_err(|e| PipelineError::file(path, format!("not a camsim run.json: {e}")))?
                .finish(base)
                .map_err(|e| PipelineError::file(path, e));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::file(path, format!("cannot read: {e}")))?;
        let located = |e: PipelineError| match e {
            PipelineError::Config(m) => PipelineError::file(path, m),
            e => e,
        };
        let cfg = Self::from_toml_str(&text, base).map_err(located)?;
        // Capture values checked now, before any work, and located in the file by their key.
        cfg.capture_request().map_err(|e| match e {
            PipelineError::Config(msg) => match key_line(&text, &msg) {
                Some(line) => PipelineError::file(path, format!("line {line}: {msg}")),
                None => PipelineError::file(path, msg),
            },
            other => other,
        })?;
        Ok(cfg)
    }

    /// Parse a TOML config from text, its relative paths made relative to `base_dir`
    /// (`Path::new("")`: as written). The message of an error names the key, line and column.
    pub fn from_toml_str(text: &str, base_dir: &Path) -> Result<SimulateConfig> {
        // A preset overridden key by key goes through the value door (the merge needs the
        // whole table; its errors name the key, without a line); any other text is read
        // straight from the TOML, so its errors carry the line and column.
        if let Ok(table) = toml::from_str::<toml::Table>(text) {
            if PRESET_SECTIONS
                .iter()
                .any(|s| preset_override(table.get(*s)).is_some())
            {
                return Self::from_value(toml::Value::Table(table), base_dir);
            }
        }
        Self::from_deserializer(toml::Deserializer::new(text), base_dir).map_err(|e| match e {
            // The [scene] table is tagged by `kind`, which hides the key's position from
            // toml's first message: find the offending key's own line and column.
            PipelineError::Config(m) => PipelineError::Config(
                camsim_scene::config::locate_scene_error(text, Some("scene"))
                    .map(|l| l.trim_end().to_string())
                    .unwrap_or(m),
            ),
            e => e,
        })
    }

    /// [`Self::from_value`] without the preset merge (TOML text that overrides no preset).
    fn from_deserializer<'de, D>(value: D, base_dir: &Path) -> Result<SimulateConfig>
    where
        D: serde::Deserializer<'de>,
        D::Error: std::fmt::Display,
    {
        let cfg = SimulateConfig::deserialize(value)
            .map_err(|e| PipelineError::Config(e.to_string().trim_end().to_string()))?;
        cfg.finish(base_dir)
    }

    /// The checks and path resolution of [`Self::from_value`].
    fn finish(mut self, base_dir: &Path) -> Result<SimulateConfig> {
        self.check_scene_source()?;
        self.resolve_paths(base_dir);
        Ok(self)
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
            if let Some(d) = &mut r.denoise {
                d.library.as_mut().map(fix);
            }
            r.overlay_inline_base = Some(base.to_path_buf());
        }
        self.optics.file.as_mut().map(fix);
        if let Some(b) = self.optics.config.as_mut().and_then(|c| c.blur.as_mut()) {
            b.lens_file.as_mut().map(fix);
            b.rtf_file.as_mut().map(fix);
            if let Some(m) = &mut b.measured_psf {
                m.files.iter_mut().for_each(|f| fix(&mut f.file));
            }
        }
        if let Some(m) = self
            .optics
            .config
            .as_mut()
            .and_then(|c| c.aperture.as_mut())
            .and_then(|a| a.mask.as_mut())
        {
            fix(m);
        }
        if let Some(f) = self.optics.config.as_mut().and_then(|c| c.flare.as_mut()) {
            f.mask.as_mut().map(fix);
            f.phase_mask.as_mut().map(fix);
        }
        self.isp.lens_shading.as_mut().map(fix);
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

    /// The `[capture]` table as a checked request ([`CaptureRequest`]: the one check of the
    /// exposure values, with the keys of this table in its messages).
    pub fn capture_request(&self) -> Result<CaptureRequest> {
        let c = &self.capture;
        CaptureRequest::new(
            c.exposure_ms,
            c.exposures_ms.as_deref(),
            c.auto_target_fraction,
            c.frames,
            self.seed,
            CONFIG_KEYS,
        )
    }

    /// The bracket's exposure times, s (`capture.exposures_ms`), or `None` for one exposure.
    pub fn bracket_exposures_s(&self) -> Result<Option<Vec<f64>>> {
        Ok(self.capture_request()?.bracket_s)
    }

    /// The sensor capture of one exposure (`capture.exposure_ms` or auto-exposure).
    pub fn capture(&self) -> Result<Capture> {
        Ok(self.capture_request()?.capture())
    }
}

/// The line (1-based) in TOML `text` of the key a config message starts with
/// (`capture.exposure_ms = -1: ...`, `capture.exposures_ms[2] = ...`), if the text has it.
fn key_line(text: &str, message: &str) -> Option<usize> {
    let dotted = message.split([' ', ':']).next()?;
    let doc = toml_edit::ImDocument::parse(text).ok()?;
    let mut item = doc.as_item();
    for seg in dotted.split('.') {
        let (key, index) = match seg.split_once('[') {
            Some((k, rest)) => (k, rest.trim_end_matches(']').parse::<usize>().ok()),
            None => (seg, None),
        };
        item = item.get(key)?;
        if let Some(i) = index {
            item = item.get(i)?;
        }
    }
    let span = item.span()?;
    Some(text.get(..span.start)?.matches('\n').count() + 1)
}
