//! camsim-pipeline: camsim's application layer. Every recipe that combines stages, or reads or
//! writes camsim's own files, lives here once; the `camsim` binary (camsim-cli) and the Python
//! package (camsim-python) are doors that parse their arguments, call one of these functions
//! through the `camsim` facade crate, and print or return the result. The physics stays in the
//! stage crates (camsim-scene, -render, -optics, -sensor, -isp, -analysis); file formats stay in
//! camsim-io.
//!
//! # Map
//!
//! | module | what | used by |
//! |---|---|---|
//! | [`config`] | [`SimulateConfig`] and the one config door [`SimulateConfig::from_value`] (files, TOML text, Python dicts, dataset samples) | everything |
//! | [`inputs`] | sensors and lenses by preset or file, one [`SensorOverrides`] (window, ISO, CFA, noise), raw and measured images from files | `sensor`, `isp`, `analyze`, Python |
//! | [`scene`] | stage 1 of a config (2D chart or 3D render), where a chart lands on the sensor | `simulate`, `analyze chart`, `render --config` |
//! | [`adaptive`] | adaptive sampling's target from the capture: the render's noise as a fraction of the sensor's temporal noise | `simulate`, `render --config`, datasets |
//! | [`render`] | 3D scenes: load (built-in, pbrt-v4, overlays), match the camera to the sensor, render and write | `render`, `simulate` |
//! | [`capture`] | optics into sensor ([`image_radiance`]), a capture request (one exposure, bracket, HDR) and its raw files | `simulate`, `sensor`, `validate`, Python |
//! | [`isp`] | [`Isp`]: ISETCam's `ip` as a value (demosaic, white balance, colour matrix) with [`Isp::compute`], and the DNG colour metadata | `simulate`, `isp`, `sensor`, `validate`, Python |
//! | [`simulation`] | [`simulate`]: the whole pipeline in memory, and [`Simulation::write`] | `simulate`, `dataset`, Python |
//! | [`records`] | run.json ([`RunRecord`]) and render.json ([`RenderRecord`]) as serde structs, written and read only here | `simulate`, `render`, `analyze`, Python |
//! | [`labels`] | training-data labels (instances, normals, albedo, boxes, depth) on the raw image's grid, and the cameras' K and extrinsics | `simulate`, `dataset`, Python |
//! | [`light_groups`] | the weighted sum of a render's light groups (`[render] light_groups`) | `simulate`, `dataset` |
//! | [`measure`] | the measurements on plain request structs: SFR of any image, chart and ROI statistics, EMVA 1288 series (simulate, write, read, analyse), demosaic quality, QE fit | `analyze`, `fit`, `sensor --emva-series`, Python |
//! | [`sequence`] | a capture in time: each raw frame's exposure window renders a moving 3D scene (bursts, video, rolling shutter), optical flow on the sensor grid | `simulate` |
//! | [`timing`] | frame windows (`start_ms`, `fps`, `frame_interval_ms`), the shutter (global, rolling) and its row map through the lens | `simulate` |
//! | [`outputs`] | which files a run writes (`--save`) | `simulate`, `dataset` |
//!
//! # Where a new recipe goes
//!
//! A new way to combine stages (motion blur over a capture window, a video, a new label map for
//! training data, a new measurement) is a function here, in the module of the table above that
//! it extends (a new module when it is a new kind of recipe), taking a plain request struct and
//! returning a result struct; when it writes files, a `write_*` method on the result that writes
//! into an [`camsim_io::atomic::OutputDir`]. When it is chosen by name, give it a name table
//! (`camsim_core::names::NameTable`) beside its type and add the table to the facade's
//! catalogue (`camsim::names`), which `camsim presets` and Python's `camsim.presets` list.
//! Then expose it through the `camsim` facade (re-exported as `camsim::pipeline`), and give
//! the CLI a subcommand file (`crates/camsim-cli/src/cmd/`) and Python a function
//! (`crates/camsim-python/src/`) that only parse, call and print or return. A test that runs it
//! through both doors and compares the numbers keeps them together.

pub mod adaptive;
pub mod capture;
pub mod config;
pub mod error;
pub mod inputs;
pub mod isp;
pub mod labels;
pub mod light_groups;
pub mod measure;
pub mod outputs;
pub mod records;
pub mod render;
pub mod scene;
pub mod sequence;
pub mod simulation;
pub mod timing;

pub use capture::{image_radiance, CaptureRequest, Captured, HdrReadouts, Imaged};
pub use config::{
    AdaptiveSection, AssetReadSection, CaptureSection, DenoiseSection, IspSection, OpticsSection,
    RenderSection, SensorSection, SimulateConfig, DEFAULT_CONFIG,
};
pub use error::{PipelineError, Result};
pub use inputs::{
    load_lens, load_raw, load_sensor, raw_from_mosaic, MeasuredImage, MosaicFormat, SensorOverrides,
};
pub use isp::{CcmSource, Isp, IspOutput, RawBlack};
pub use outputs::{Output, OutputSet};
pub use records::{RenderRecord, RunRecord};
pub use scene::{
    macbeth_chart_corners_px, mean_luminance_cd_m2, scene_radiance, scene_stage, scene_stage_with,
    SceneStage,
};
pub use sequence::FrameFlow;
pub use simulation::{simulate, write_id_maps, Rgb8Image, RunInfo, SimulateOptions, Simulation};
pub use timing::{FrameTime, ReadoutDirection, ShutterConfig};

/// Progress callback: (stage name, steps done, steps in all).
pub type Progress<'a> = dyn Fn(&str, u64, u64) + Sync + 'a;
