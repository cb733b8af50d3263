//! Errors of the optics stage. Every message names the key, file or value that was wrong.

use std::path::PathBuf;

/// An error from the optics stage.
#[derive(Debug, thiserror::Error)]
pub enum OpticsError {
    /// A configuration value is impossible (`key` is the config key, e.g. `f_number`).
    #[error("optics config key `{key}`: {message}")]
    Config {
        /// The config key (dotted path) that is wrong.
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// A TOML text could not be parsed (`what` names the file or preset).
    #[error("{what}: {message}")]
    Parse {
        /// File name or preset name.
        what: String,
        /// The parser's message (includes line and column).
        message: String,
    },
    /// A file could not be read.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The input image does not fit what the optics needs.
    #[error("optics input: {0}")]
    Input(String),
    /// An error from the spectral core (memory guard, grids).
    #[error(transparent)]
    Core(#[from] camsim_core::CoreError),
}

impl OpticsError {
    /// A config error for `key`.
    pub fn config(key: impl Into<String>, message: impl Into<String>) -> Self {
        OpticsError::Config {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// Result of the optics stage.
pub type Result<T> = std::result::Result<T, OpticsError>;
