//! # camsim as a library
//!
//! camsim simulates a digital camera end to end: the spectral radiance of a scene (2D charts or
//! 3D path-traced scenes), the optics that turn it into spectral irradiance at the sensor, and the
//! image sensor that turns that into raw digital values, plus the ISP preview. This crate is the
//! one entry point for Rust programs: the whole pipeline in memory with [`simulate`], each stage on
//! its own through the re-exported stage crates, and writing files as a separate, explicit step
//! ([`Simulation::write`]).
//!
//! ```
//! use camsim::{simulate, OutputSet, RunInfo, SimulateConfig, SimulateOptions};
//!
//! // The built-in default: a Macbeth chart under D65 through the Pixel 4a lens and sensor.
//! let mut config = SimulateConfig::builtin_default();
//! config.seed = 7;
//! config.capture.exposure_ms = Some(10.0);
//! config.sensor.rows = Some(120); // a small window keeps this example fast
//! config.sensor.cols = Some(160);
//! let sim = simulate(&config, &SimulateOptions::default(), &|_stage, _done, _total| {})?;
//! println!("mean DN r/g/b {:?}, {} frame(s)", sim.mean_dn_rgb, sim.frames.len());
//! let raw = &sim.frames[0]; // ADC values, raw.dn[r * raw.cols + c]
//! assert_eq!((raw.rows, raw.cols), (120, 160));
//! // Files only when asked for: raw.dng, preview.png and run.json here.
//! let dir = std::env::temp_dir().join(format!("camsim-doc-example-{}", std::process::id()));
//! sim.write(&dir, &OutputSet::default(), Default::default(), &RunInfo::default())?;
//! assert!(dir.join("raw.dng").is_file() && dir.join("preview.png").is_file());
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok::<(), camsim::Error>(())
//! ```
//!
//! Stages alone (the same functions the pipeline calls):
//!
//! - [`scene`]: `scene::create(&SceneConfig, &WavelengthGrid)` -> radiance ([`SpectralImage`]);
//!   [`render`]: `render::render(&SceneDescription, progress)` for 3D scenes, whose description
//!   ([`scene3d`]: `scene3d::SceneDescription`, `scene3d::builtin` scenes) comes from a pbrt-v4
//!   file via [`pbrt`] (`pbrt::parse_file`, TOML overlays `pbrt::overlay::apply`).
//! - [`optics`]: `optics::Optics::preset("pixel4a")?.compute(&radiance)` -> irradiance.
//! - [`sensor`]: `sensor::Sensor::preset("pixel4a")?.compute(&irradiance, &Capture)` -> raw frames.
//! - [`isp`]: `isp::demosaic_bilinear(&raw)`, `isp::ColorPipeline` for colour.
//! - [`analysis`]: SFR/MTF, chart and ROI statistics, EMVA 1288, QE fits on any stage's images.
//! - [`io`]: spectral OpenEXR, DNG, PNG readers and writers.
//! - [`dataset`]: many captures from a spec of variations, as WebDataset shards with a manifest.
//! - [`validate`]: the paper's Cornell box validation and the two-camera comparison.
//!
//! Every recipe that combines stages or reads and writes camsim's own files is in [`pipeline`]
//! (the application layer: config door, capture requests, the [`Isp`], run and render records,
//! the measurements); the `camsim` command line and the Python package only parse, call this
//! crate and print or return. [`names`] is the catalogue of every name table.
//!
//! Errors are typed ([`Error`]: each stage's own error type); the library reads only the files a
//! config names and never the environment or the command line.

pub use camsim_analysis as analysis;
pub use camsim_core as core;
pub use camsim_dataset as dataset;
pub use camsim_io as io;
pub use camsim_isp as isp;
pub use camsim_optics as optics;
pub use camsim_pbrt as pbrt;
pub use camsim_pipeline as pipeline;
pub use camsim_render as render;
pub use camsim_scene as scene;
pub use camsim_scene3d as scene3d;
pub use camsim_sensor as sensor;
pub use camsim_validate as validate;

pub mod names;

pub use camsim_core::{RawImage, SpectralImage, WavelengthGrid};
pub use camsim_io::exr::{ExrCompression, ExrOptions, ExrPrecision};
pub use camsim_pipeline::render::{field_of_view_deg, sensor_image_distance_m};
pub use camsim_pipeline::{
    simulate, CaptureRequest, Isp, Output, OutputSet, PipelineError as Error, Progress, Rgb8Image,
    RunInfo, RunRecord, SensorOverrides, SimulateConfig, SimulateOptions, Simulation,
};

/// Result with camsim's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The README's Rust example, compiled by `cargo test --doc -p camsim` so that it cannot fall
/// behind the API (it is `no_run`: it writes into `out/`).
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeExample;
