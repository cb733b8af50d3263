//! camsim's own records, written and read only here: a run's `run.json` ([`RunRecord`], written
//! by `camsim simulate`, read back to repeat a run or to find a chart's corners) and a render's
//! `render.json` ([`RenderRecord`]). Both are written with their keys in alphabetical order at
//! every level (through `serde_json::Value`), as camsim always wrote them.

use crate::{PipelineError, Result, SimulateConfig};
use camsim_analysis::chart::ChartCorners;
use camsim_io::atomic::write_json_atomic;
use camsim_optics::OpticsConfig;
use camsim_sensor::SensorConfig;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `run.json`: what a run did, enough to repeat it (`camsim simulate run.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunRecord {
    /// With labels (a 3D scene, `simulate(labels)`): the cameras of the render's and the raw
    /// image's grids, K and extrinsics in OpenCV's conventions (`crate::labels::SimLabels::cameras_json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<serde_json::Value>,
    /// What `[render.compose]` drew: each object's asset, category, scale and final pose, and
    /// the settling's steps (the sample's composed scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compose: Option<camsim_compose::ComposeRecord>,
    /// The camsim version that wrote it.
    pub camsim_version: String,
    /// The command line, when a command ran it.
    pub command: Option<String>,
    /// The effective config (every default filled in).
    pub config: SimulateConfig,
    /// The config file it came from, if any.
    pub config_file: Option<String>,
    /// What each written file holds (or why it was not written).
    #[serde(default)]
    pub files: serde_json::Map<String, serde_json::Value>,
    /// The lens used.
    pub optics: OpticsConfig,
    /// The outputs asked for, as `--save` takes them.
    pub outputs: String,
    /// The run's figures.
    pub results: RunResults,
    /// The sensor used (its window).
    pub sensor: SensorConfig,
    /// Seconds per stage ("scene_s", "optics_s", "sensor_s", "isp_s", "total_s").
    #[serde(default)]
    pub times: serde_json::Map<String, serde_json::Value>,
}

/// `run.json`'s `results`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunResults {
    /// Exposure time used, s (the first raw's).
    pub exposure_s: f64,
    /// An exposure bracket: each raw's exposure time, s, in file order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_exposures_s: Option<Vec<f64>>,
    /// Raw frames written.
    pub frames: usize,
    /// Sensor-plane sample spacing, um.
    pub irradiance_sample_spacing_um: f64,
    /// Irradiance size [rows, cols, bands].
    pub irradiance_size: [usize; 3],
    /// Whether the scene's camera was a lens camera (its render is the irradiance).
    pub lens_camera: bool,
    /// Mean DN of the first frame per channel r, g, b (black level included).
    pub mean_dn_rgb: [f64; 3],
    /// Noise-free mean electrons per channel r, g, b.
    pub mean_electrons_rgb: [f64; 3],
    /// Radiance size [rows, cols, bands] (None for a lens camera).
    pub radiance_size: Option<[usize; 3]>,
    /// Mean scene luminance, cd/m^2 (None for a lens camera).
    pub scene_mean_luminance_cd_m2: Option<f64>,
    /// Each raw's window in the scene's time, file order ([`crate::timing`]).
    #[serde(default)]
    pub frame_times: Vec<crate::timing::FrameTime>,
    /// The shutter: kind, and for a rolling one its direction, line time and readout time
    /// ([`crate::timing::ShutterConfig::describe`]).
    #[serde(default)]
    pub shutter: serde_json::Value,
    /// The 3D scene moves: every frame was rendered in its own window.
    #[serde(default)]
    pub scene_moves: bool,
    /// An `[hdr]` sensor's merge (None for other sensors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hdr: Option<HdrResults>,
    /// With the noise-free image: PSNR and SSIM of the raw and of the preview against their
    /// noise-free counterparts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quality: Option<CaptureQuality>,
    /// A 3D scene: the samples its render took per pixel (and the adaptive target).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render_samples: Option<RenderSamples>,
}

/// run.json's `results.hdr`: the figures of an `[hdr]` sensor's merge
/// ([`camsim_sensor::HdrModel`]), in electrons of the high readout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HdrResults {
    /// "dcg" or "split-pixel".
    pub mode: camsim_sensor::HdrMode,
    /// Signal at which the merge switches to the low readout, e-.
    pub switch_e: f64,
    /// Largest merged signal (the low readout's saturation), e-.
    pub max_merged_e: f64,
    /// Temporal noise at dark (the high readout's read noise and quantization), e-.
    pub noise_floor_e: f64,
    /// 20 log10(max_merged_e / noise_floor_e), dB.
    pub dynamic_range_db: f64,
    /// Low-readout sensitivity relative to the high one (split pixel; 1 for DCG).
    pub sensitivity_ratio: f64,
}

impl HdrResults {
    pub fn of(m: &camsim_sensor::HdrModel) -> Self {
        HdrResults {
            mode: m.mode,
            switch_e: m.switch_e,
            max_merged_e: m.max_merged_e(),
            noise_floor_e: m.noise_floor_e(),
            dynamic_range_db: m.dynamic_range_db(),
            sensitivity_ratio: m.ratio,
        }
    }
}

/// Read and parse a JSON file, naming it in errors.
pub fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| PipelineError::file(path, format!("cannot read: {e}")))?;
    serde_json::from_str(&text)
        .map_err(|e| PipelineError::file(path, format!("not valid JSON: {e}")))
}

/// `value` as JSON with its keys in alphabetical order at every level, written atomically.
fn write_sorted(path: &Path, value: &impl Serialize) -> Result<()> {
    let v = serde_json::to_value(value)?;
    Ok(write_json_atomic(path, &v)?)
}

impl RunRecord {
    /// The record as JSON (keys in alphabetical order).
    pub fn to_value(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a run record serializes")
    }

    /// Write `path` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_sorted(path, self)
    }

    /// Read a run.json; errors name the file.
    pub fn read(path: &Path) -> Result<RunRecord> {
        serde_json::from_value(read_json(path)?)
            .map_err(|e| PipelineError::file(path, format!("not a camsim run.json: {e}")))
    }

    /// The chart's corners in a frame of this run: the pipeline's own mapping of a `macbeth`
    /// scene onto the sensor window ([`crate::macbeth_chart_corners_px`]) with the run's lens
    /// and the sensor's own pitch (a DNG's FocalPlaneXResolution is a rounded rational). `None`
    /// when the scene is not a Macbeth chart.
    pub fn chart_corners(&self, rows: usize, cols: usize) -> Result<Option<ChartCorners>> {
        let c = crate::macbeth_chart_corners_px(
            &self.config,
            &self.optics,
            self.sensor.pixel_pitch_um * 1e-6,
            rows,
            cols,
        )?;
        Ok(c.map(|c| ChartCorners {
            top_left: c[0],
            top_right: c[1],
            bottom_right: c[2],
            bottom_left: c[3],
        }))
    }
}

/// The corners of the chart in `image`, a DNG written by `camsim simulate`, from the run.json
/// beside it (`rows` x `cols` the image's size). Errors say how to give them instead.
pub fn chart_corners_beside(image: &Path, rows: usize, cols: usize) -> Result<ChartCorners> {
    let run = image.with_file_name("run.json");
    if !run.is_file() {
        return Err(PipelineError::file(
            image,
            "no chart corners given and no run.json beside it (camsim simulate writes one); give the chart's corners (--corners X,Y,X,Y,X,Y,X,Y)",
        ));
    }
    let rec = RunRecord::read(&run)?;
    rec.chart_corners(rows, cols)
        .map_err(|e| PipelineError::file(&run, format!("cannot place the chart: {e}")))?
        .ok_or_else(|| {
            PipelineError::file(
                &run,
                "the scene is not a macbeth chart; give the chart's corners (--corners)",
            )
        })
}

/// What raw.png holds, for run.json: the mosaic scaled from `bits` bits to the 16-bit range.
pub fn raw_png_note(bits: u32) -> serde_json::Value {
    serde_json::json!({
        "scale": format!("16-bit value = round(DN x 65535 / {}), DN the {bits}-bit ADC value", (1u64 << bits) - 1),
        "adc_bits": bits,
        "invert": format!("DN = round(value x {} / 65535)", (1u64 << bits) - 1),
    })
}

/// `render.json`: a render's settings, the samples actually taken and the ray statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderRecord {
    /// The camsim version that wrote it.
    pub camsim_version: String,
    /// The command line, when a command ran it.
    pub command: Option<String>,
    /// Horizontal field of view, degrees.
    pub horizontal_fov_deg: f64,
    /// Maximum path depth.
    pub max_depth: u32,
    /// Notes of the scene reader (ignored or approximated parameters).
    pub notes: Vec<String>,
    /// Image size [width, height].
    pub resolution: [usize; 2],
    /// The samples actually taken per pixel (fewer than asked when a time budget stopped it).
    pub samples_per_pixel: u32,
    /// The samples asked for (with adaptive sampling, the most any pixel takes).
    pub samples_per_pixel_requested: u32,
    /// The mean samples per pixel (less than `samples_per_pixel` when adaptive sampling
    /// stopped pixels early; samples.exr has each pixel's).
    #[serde(default)]
    pub samples_per_pixel_mean: f64,
    /// The adaptive-sampling target, when the render had one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveRecord>,
    /// The denoiser library the radiance went through (`[render.denoise]`, `--denoise`);
    /// absent: the unbiased film. variance.exr is the film's before denoising.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoised_with: Option<String>,
    /// The scene: a file or a built-in name.
    pub scene: Option<String>,
    /// Render seed.
    pub seed: u64,
    /// Ray counts and speed.
    pub stats: RenderStatsRecord,
    /// The opt-in wall-clock limit, s.
    pub time_budget_s: Option<f64>,
    /// Wavelengths traced together per path.
    pub wavelengths_per_path: usize,
}

/// The mean of a render's per-pixel sample counts.
fn mean_samples(out: &camsim_render::RenderOutput) -> f64 {
    let n = out.samples_per_pixel.len().max(1) as f64;
    out.samples_per_pixel.iter().map(|s| *s as f64).sum::<f64>() / n
}

/// An adaptive-sampling target as recorded (`camsim_scene3d::scene::AdaptiveSampling` without
/// its band weights): each pixel stopped when every channel's variance of the mean was within
/// `relative^2 m^2 + shot m + floor^2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdaptiveRecord {
    /// Samples before the first test.
    pub min_samples: u32,
    /// "luminance_cd_m2" (a relative target) or "electrons" (the sensor's noise, one channel
    /// per colour filter).
    pub channel_unit: String,
    /// Channels tested.
    pub channels: usize,
    pub relative: f64,
    pub shot: f64,
    pub floor: f64,
}

impl AdaptiveRecord {
    /// The record of `a`.
    pub fn of(a: &camsim_scene3d::scene::AdaptiveSampling) -> AdaptiveRecord {
        AdaptiveRecord {
            min_samples: a.min_samples,
            channel_unit: if a.channels.is_empty() {
                "luminance_cd_m2".into()
            } else {
                "electrons".into()
            },
            channels: a.channels.len().max(1),
            relative: a.relative,
            shot: a.shot,
            floor: a.floor,
        }
    }
}

/// `run.json`'s `results.render_samples`: the samples a 3D scene's render took per pixel (the
/// first frame's, when the scene moves).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderSamples {
    /// The most a pixel could take (`samples_per_pixel`).
    pub requested_per_pixel: u32,
    /// Mean, least and most taken.
    pub mean_per_pixel: f64,
    pub min_per_pixel: u32,
    pub max_per_pixel: u32,
    /// With adaptive sampling: the share of pixels that took every sample allowed, 0-1. There
    /// the render's noise is still above the target (at a well-exposed pixel rendered 1:1 with
    /// the sensor, a fifth of the shot noise can need far more than 1024 samples).
    #[serde(default)]
    pub at_most_share: f64,
    /// The adaptive-sampling target, when `[render.adaptive]` set one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveRecord>,
    /// The denoiser library the render went through (`[render.denoise]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoised_with: Option<String>,
}

impl RenderSamples {
    /// The samples `out` took rendering `scene`.
    pub fn of(
        scene: &camsim_scene3d::SceneDescription,
        out: &camsim_render::RenderOutput,
    ) -> RenderSamples {
        let s = &out.samples_per_pixel;
        RenderSamples {
            requested_per_pixel: scene.settings.samples_per_pixel,
            mean_per_pixel: mean_samples(out),
            min_per_pixel: s.iter().copied().min().unwrap_or(0),
            max_per_pixel: s.iter().copied().max().unwrap_or(0),
            at_most_share: if scene.settings.adaptive.is_some() && !s.is_empty() {
                let cap = scene.settings.samples_per_pixel;
                s.iter().filter(|n| **n >= cap).count() as f64 / s.len() as f64
            } else {
                0.0
            },
            adaptive: scene.settings.adaptive.as_ref().map(AdaptiveRecord::of),
            denoised_with: out.denoised_with.as_ref().map(|p| p.display().to_string()),
        }
    }
}

/// `render.json`'s `stats` (camsim_render::RenderStats).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RenderStatsRecord {
    pub bounce_rays: u64,
    pub camera_rays: u64,
    pub rays_per_second: f64,
    pub samples_per_second: f64,
    pub seconds: f64,
    pub shadow_rays: u64,
}

impl RenderRecord {
    /// The record of rendering `scene` into `out` (`scene_name`: its file or built-in name).
    pub fn new(
        scene: &camsim_scene3d::SceneDescription,
        out: &camsim_render::RenderOutput,
        scene_name: Option<String>,
        command: Option<String>,
    ) -> RenderRecord {
        let s = &out.stats;
        RenderRecord {
            camsim_version: env!("CARGO_PKG_VERSION").into(),
            command,
            horizontal_fov_deg: scene.camera.horizontal_fov_deg(),
            max_depth: scene.settings.max_depth,
            notes: scene.notes.clone(),
            resolution: [out.radiance.cols, out.radiance.rows],
            samples_per_pixel: out.samples_per_pixel.iter().copied().max().unwrap_or(0),
            samples_per_pixel_requested: scene.settings.samples_per_pixel,
            samples_per_pixel_mean: mean_samples(out),
            adaptive: scene.settings.adaptive.as_ref().map(AdaptiveRecord::of),
            denoised_with: out.denoised_with.as_ref().map(|p| p.display().to_string()),
            scene: scene_name,
            seed: scene.settings.seed,
            stats: RenderStatsRecord {
                bounce_rays: s.bounce_rays,
                camera_rays: s.camera_rays,
                rays_per_second: s.rays_per_second,
                samples_per_second: s.samples_per_second,
                seconds: s.seconds,
                shadow_rays: s.shadow_rays,
            },
            time_budget_s: scene.settings.time_budget_s,
            wavelengths_per_path: scene.settings.wavelengths_per_path,
        }
    }

    /// Write `path` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_sorted(path, self)
    }

    /// Read a render.json; errors name the file.
    pub fn read(path: &Path) -> Result<RenderRecord> {
        serde_json::from_value(read_json(path)?)
            .map_err(|e| PipelineError::file(path, format!("not a camsim render.json: {e}")))
    }
}

/// A capture's full-reference quality against its noise-free counterpart
/// ([`camsim_analysis::quality`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CaptureQuality {
    /// The raw mosaic, DN above black against the noise-free DN above black; peak (and SSIM
    /// range) the white level above black.
    pub raw: camsim_analysis::quality::Quality,
    /// The 8-bit preview against the ISP's preview of the noise-free raw (rounded to DN) at
    /// the same exposure scale; peak 255. None where the ISP cannot render the frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<camsim_analysis::quality::Quality>,
}
