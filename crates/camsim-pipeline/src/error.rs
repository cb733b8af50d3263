//! Typed errors of the pipeline: each stage's own error, or a message about the config or a file
//! the pipeline reads.

use std::path::PathBuf;

/// Everything the pipeline can fail with.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A config value or combination that cannot run (the message names the key).
    #[error("{0}")]
    Config(String),
    /// A file the pipeline read or was asked to read (the message says what is wrong with it).
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// The scene stage (2D charts, scene files, pbrt-v4 scenes and overlays).
    #[error("{0}")]
    Scene(String),
    #[error(transparent)]
    Core(#[from] camsim_core::CoreError),
    #[error(transparent)]
    Optics(#[from] camsim_optics::OpticsError),
    #[error(transparent)]
    Sensor(#[from] camsim_sensor::SensorError),
    #[error(transparent)]
    Render(#[from] camsim_render::RenderError),
    #[error(transparent)]
    Io(#[from] camsim_io::IoError),
    #[error(transparent)]
    Analysis(#[from] camsim_analysis::AnalysisError),
    /// An EMVA series request refused, by its fields' neutral names (each door spells them).
    #[error(transparent)]
    Series(#[from] crate::measure::emva::SeriesError),
    #[error("cannot encode run metadata: {0}")]
    Json(#[from] serde_json::Error),
}

/// Result of the pipeline.
pub type Result<T, E = PipelineError> = std::result::Result<T, E>;

impl PipelineError {
    pub(crate) fn config(msg: impl Into<String>) -> Self {
        PipelineError::Config(msg.into())
    }
    pub(crate) fn file(path: &std::path::Path, message: impl std::fmt::Display) -> Self {
        PipelineError::File {
            path: path.to_path_buf(),
            message: message.to_string(),
        }
    }
}
