//! camsim validate: the paper's Cornell box validation, end to end, with its report.
//!
//! [`cornell_box`] reproduces figures 2-6 of Lyu et al., "Validation of image systems simulation
//! technology using a Cornell Box" with camsim's own stages (3D path tracer -> wavefront optics ->
//! IMX363 / Pixel 4a sensor -> bilinear demosaic -> analyses) and writes `report.html`
//! (self-contained), `results.json` (every number) and the figures as PNG files:
//!
//! 1. optics (Figure 2): slanted-edge SFR per CFA channel and of the demosaicked luminance at two
//!    focus settings, beside the MTF of the optics model times the pixel aperture ([`optics_fig`]);
//! 2. sensor QE (Figure 3): the least-squares QE correction matrix M recovered from simulated
//!    ColorChecker captures under CIE A, F2 and D65 ([`qe_fig`]);
//! 3. images (Figure 4), 4. digital values along the gray series at three chart positions
//!    (Figure 5) and 5. noise in three regions against the noise model (Figure 6) ([`scene_fig`]);
//! 6. provenance: parameters, version, run times, the command.
//!
//! [`compare_cameras`] puts two cameras side by side (MTF, acutance, SNR, NPS, CIEDE2000 per
//! patch; `camsim compare`).
//!
//! [`compare()`] does the region-by-region comparison for a user's own camera (measured DNGs
//! against simulated ones, [`CompareConfig`]).

#![warn(missing_docs)]

pub mod cameras;
pub mod compare;
pub mod cycles_reference;
pub mod optics_fig;
pub mod pbrt_reference;
pub mod plot;
pub mod qe_fig;
pub mod report;
pub mod scene_fig;
mod util;
pub mod zone_plate;

pub use cameras::{compare_cameras, CameraCompareOptions, CameraComparison, CameraSpec};
pub use compare::{compare, CompareConfig, CompareResults, RegionConfig};
pub use util::FigurePng;

use camsim_core::WavelengthGrid;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How thorough the validation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// Small images and few samples: under a minute on 2 cores (CI).
    Quick,
    /// Full sensor resolution and enough samples for smooth curves: a few minutes on 2 cores
    /// (2 min 52 s measured).
    Paper,
}

/// Options of [`cornell_box`].
#[derive(Debug, Clone)]
pub struct ValidateOptions {
    /// Quick or paper quality.
    pub quality: Quality,
    /// Folder for report.html, results.json and the figure PNGs (created if missing).
    pub out_dir: PathBuf,
    /// Folder with the measured isetcornellbox spectra (`cboxIlluminant`, `cboxSurfaces` or
    /// `cboxWalls`, `.csv` or `.mat`); None: the Cornell data page's built-in spectra.
    pub data_dir: Option<PathBuf>,
    /// Seed of the renders and of the sensor's temporal noise.
    pub seed: u64,
    /// The command that produced this report (recorded for reproduction).
    pub command_line: String,
}

/// Errors of the validation. Messages name the stage and the file or value at fault.
#[derive(Debug, thiserror::Error)]
pub enum ValidateError {
    /// The renderer refused the scene.
    #[error("render: {0}")]
    Render(#[from] camsim_render::RenderError),
    /// A built-in scene could not be built.
    #[error("built-in scene: {0}")]
    Builtin(#[from] camsim_scene3d::builtin::BuiltinError),
    /// The optics stage failed.
    #[error("optics: {0}")]
    Optics(#[from] camsim_optics::OpticsError),
    /// The sensor stage failed.
    #[error("sensor: {0}")]
    Sensor(#[from] camsim_sensor::SensorError),
    /// An analysis failed.
    #[error("analysis: {0}")]
    Analysis(#[from] camsim_analysis::AnalysisError),
    /// Spectral core (tables, spectra files, memory guard).
    #[error("{0}")]
    Core(#[from] camsim_core::CoreError),
    /// Writing or reading a file.
    #[error("{0}")]
    Io(#[from] camsim_io::IoError),
    /// The pipeline's wiring of optics into sensor.
    #[error(transparent)]
    Pipeline(#[from] camsim_pipeline::PipelineError),
    /// A file could not be read or parsed.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A value is out of range.
    #[error("{what}: {message}")]
    Invalid {
        /// The key or value.
        what: String,
        /// What went wrong.
        message: String,
    },
}

impl ValidateError {
    pub(crate) fn invalid(what: impl Into<String>, message: impl Into<String>) -> Self {
        ValidateError::Invalid {
            what: what.into(),
            message: message.into(),
        }
    }
    pub(crate) fn file(path: &Path, message: impl Into<String>) -> Self {
        ValidateError::File {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

/// Result alias.
pub type Result<T> = std::result::Result<T, ValidateError>;

/// The sizes and sample counts of one quality level.
#[derive(Debug, Clone, Serialize)]
pub struct QualityParams {
    /// Slanted-edge sensor window, pixels (square).
    pub edge_window_px: usize,
    /// Extra sensor pixels rendered around the window on every side (so the blur near the window
    /// edge sees real scene, not the zero outside the render).
    pub edge_margin_px: usize,
    /// Render samples per sensor pixel pitch along each axis for the slanted edge.
    pub edge_oversampling: usize,
    /// Samples per render pixel of the slanted edge.
    pub edge_spp: u32,
    /// Side of each uniform ColorChecker patch in the QE experiment, pixels.
    pub qe_patch_px: usize,
    /// Render resolution of the Cornell box with the ColorChecker (width, height), pixels.
    pub box_render: (usize, usize),
    /// Samples per pixel of the Cornell box renders.
    pub box_spp: u32,
    /// Opt-in time budget per Cornell box render, s (the render stops between passes once past
    /// it, so the result depends on the machine). None in both quality levels: every render takes
    /// all `box_spp` samples and the report is bit-identical for a seed on any machine.
    pub box_time_budget_s: Option<f64>,
    /// Wavelength grid of the spectral computations (the slanted edge uses the same range every
    /// 20 nm).
    pub grid: WavelengthGrid,
}

impl QualityParams {
    /// The parameters of a quality level.
    pub fn of(q: Quality) -> QualityParams {
        match q {
            Quality::Quick => QualityParams {
                edge_window_px: 128,
                edge_margin_px: 24,
                edge_oversampling: 2,
                edge_spp: 16,
                qe_patch_px: 32,
                box_render: (252, 189),
                box_spp: 16,
                box_time_budget_s: None,
                grid: WavelengthGrid::default(),
            },
            Quality::Paper => QualityParams {
                edge_window_px: 512,
                edge_margin_px: 32,
                edge_oversampling: 4,
                edge_spp: 8,
                qe_patch_px: 64,
                box_render: (1008, 756),
                box_spp: 256,
                box_time_budget_s: None,
                grid: WavelengthGrid::default(),
            },
        }
    }
}

/// Run time of one stage.
#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    /// Stage name.
    pub stage: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// One named pass/fail check of the report.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    /// What is checked.
    pub name: String,
    /// Whether it holds.
    pub passed: bool,
    /// The numbers behind it.
    pub detail: String,
}

/// Provenance of a report.
#[derive(Debug, Clone, Serialize)]
pub struct Provenance {
    /// camsim version (the workspace version of this crate).
    pub camsim_version: String,
    /// The command that reproduces the report.
    pub command_line: String,
    /// Quality level.
    pub quality: Quality,
    /// Sizes and sample counts.
    pub params: QualityParams,
    /// Seed of renders and sensor noise.
    pub seed: u64,
    /// Measured spectra folder, if used.
    pub data_dir: Option<String>,
    /// Which spectra the Cornell box used (light, walls) and from where.
    pub spectra: Vec<String>,
    /// Sensor presets (TOML text as used).
    pub sensor_pixel4a_toml: String,
    /// Published-QE sensor preset (TOML text).
    pub sensor_imx363_toml: String,
    /// Optics preset (TOML text).
    pub optics_pixel4a_toml: String,
    /// Run time per stage.
    pub timings: Vec<StageTime>,
    /// Total run time, s.
    pub total_seconds: f64,
    /// Threads rayon used.
    pub threads: usize,
}

/// Everything [`cornell_box`] measured (also written as `results.json`).
#[derive(Debug, Clone, Serialize)]
pub struct ValidationResults {
    /// Figure 2: MTF at two focus settings.
    pub optics: optics_fig::OpticsResults,
    /// Figure 3: QE correction fit.
    pub qe: qe_fig::QeResults,
    /// Figures 4-6: images, digital values, noise.
    pub scene: scene_fig::SceneResults,
    /// Pass/fail checks (the paper's qualitative and quantitative claims).
    pub checks: Vec<Check>,
    /// Parameters, version, run times.
    pub provenance: Provenance,
}

/// Stage timer and progress forwarding.
pub(crate) struct Stages<'a> {
    pub progress: &'a (dyn Fn(&str, u64, u64) + Sync),
    pub timings: Vec<StageTime>,
    start: Instant,
}

impl<'a> Stages<'a> {
    pub fn new(progress: &'a (dyn Fn(&str, u64, u64) + Sync)) -> Self {
        Stages {
            progress,
            timings: Vec::new(),
            start: Instant::now(),
        }
    }
    /// Run `f` as stage `name`, timing it.
    pub fn run<T>(
        &mut self,
        name: &str,
        f: impl FnOnce(&(dyn Fn(u64, u64) + Sync)) -> Result<T>,
    ) -> Result<T> {
        let t0 = Instant::now();
        let progress = self.progress;
        let name_s = name.to_string();
        progress(&name_s, 0, 1);
        let cb = move |d: u64, t: u64| progress(&name_s, d, t);
        let r = f(&cb)?;
        progress(name, 1, 1);
        self.timings.push(StageTime {
            stage: name.to_string(),
            seconds: t0.elapsed().as_secs_f64(),
        });
        Ok(r)
    }
    pub fn total_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }
}

/// Run the paper's Cornell box validation and write `DIR/report.html`, `DIR/results.json` and
/// the figure PNGs (`DIR/fig*.png`). `progress(stage, done, total)` reports progress.
pub fn cornell_box(
    opts: &ValidateOptions,
    progress: &(dyn Fn(&str, u64, u64) + Sync),
) -> Result<ValidationResults> {
    cornell_box_with(opts, QualityParams::of(opts.quality), progress)
}

/// [`cornell_box`] with explicit sizes and sample counts (e.g. [`QualityParams::of`] with an
/// opt-in `box_time_budget_s`).
pub fn cornell_box_with(
    opts: &ValidateOptions,
    params: QualityParams,
    progress: &(dyn Fn(&str, u64, u64) + Sync),
) -> Result<ValidationResults> {
    if let Some(b) = params.box_time_budget_s {
        if !(b > 0.0 && b.is_finite()) {
            return Err(ValidateError::invalid(
                "box_time_budget_s",
                format!("{b} s must be a positive number of seconds"),
            ));
        }
    }
    std::fs::create_dir_all(&opts.out_dir).map_err(|e| {
        ValidateError::file(
            &opts.out_dir,
            format!("cannot create the output folder: {e}"),
        )
    })?;
    let spectra = util::BoxSpectra::load(opts.data_dir.as_deref(), &params.grid)?;
    let mut stages = Stages::new(progress);

    let optics = optics_fig::run(opts, &params, &spectra, &mut stages)?;
    let qe = qe_fig::run(opts, &params, &mut stages)?;
    let scene = scene_fig::run(opts, &params, &spectra, &mut stages)?;

    let mut checks = Vec::new();
    checks.extend(optics.checks.iter().cloned());
    checks.extend(qe.checks.iter().cloned());
    checks.extend(scene.checks.iter().cloned());

    let provenance = Provenance {
        camsim_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: opts.command_line.clone(),
        quality: opts.quality,
        params: params.clone(),
        seed: opts.seed,
        data_dir: opts.data_dir.as_ref().map(|p| p.display().to_string()),
        spectra: spectra.describe.clone(),
        sensor_pixel4a_toml: camsim_sensor::Sensor::preset("pixel4a")?.to_toml(),
        sensor_imx363_toml: camsim_sensor::Sensor::preset("imx363")?.to_toml(),
        optics_pixel4a_toml: camsim_optics::OpticsConfig::preset("pixel4a")?.to_toml(),
        timings: Vec::new(),
        total_seconds: 0.0,
        threads: rayon::current_num_threads(),
    };
    let mut results = ValidationResults {
        optics,
        qe,
        scene,
        checks,
        provenance,
    };
    // The report itself is the last stage.
    let t0 = Instant::now();
    let html = util::write_report(opts, &mut results, &stages)?;
    stages.timings.push(StageTime {
        stage: "report".into(),
        seconds: t0.elapsed().as_secs_f64(),
    });
    results.provenance.timings = stages.timings.clone();
    results.provenance.total_seconds = stages.total_s();
    let html = html.replace(
        util::TIMINGS_PLACEHOLDER,
        &util::timings_html(&results.provenance),
    );
    camsim_io::atomic::write_bytes_atomic(&opts.out_dir.join("report.html"), html.as_bytes())?;
    camsim_io::atomic::write_json_atomic(&opts.out_dir.join("results.json"), &results)?;
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reproducibility: no quality level stops its renders by wall clock unless asked to.
    #[test]
    fn default_quality_levels_have_no_time_budget() {
        for q in [Quality::Quick, Quality::Paper] {
            assert_eq!(QualityParams::of(q).box_time_budget_s, None, "{q:?}");
        }
    }

    #[test]
    fn a_bad_time_budget_is_an_error() {
        let opts = ValidateOptions {
            quality: Quality::Quick,
            out_dir: std::env::temp_dir().join("camsim-validate-never-created"),
            data_dir: None,
            seed: 1,
            command_line: String::new(),
        };
        for b in [0.0, -1.0, f64::NAN] {
            let params = QualityParams {
                box_time_budget_s: Some(b),
                ..QualityParams::of(Quality::Quick)
            };
            let e = cornell_box_with(&opts, params, &|_, _, _| {}).unwrap_err();
            assert!(e.to_string().contains("box_time_budget_s"), "{e}");
        }
    }
}
