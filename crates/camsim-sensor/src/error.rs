//! Errors of the sensor stage. Every message names the file (or preset), the key or the value.

use camsim_core::CoreError;

/// Errors from building a sensor or computing a capture.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    /// A config value is impossible; names the source (file or preset) and the key.
    #[error("{source_name}: {key}: {message}")]
    Config {
        /// File name or preset the config came from.
        source_name: String,
        /// The config key, e.g. `pixel_pitch_um` or `qe.r`.
        key: String,
        /// What is wrong, with the value.
        message: String,
    },
    /// The TOML text could not be parsed (syntax, unknown key, wrong type); toml's message gives line and key.
    #[error("{source_name}: {message}")]
    Parse {
        /// File name or preset the text came from.
        source_name: String,
        /// toml's message (line, column, key).
        message: String,
    },
    /// Bad input to a compute call (image, exposure, frames); names what was wrong.
    #[error("{what}: {message}")]
    Input {
        /// What was wrong (`exposure_s`, `frames`, `sensor input`...).
        what: String,
        /// Why.
        message: String,
    },
    /// An error from the spectral core (files, memory).
    #[error(transparent)]
    Core(#[from] CoreError),
}

impl SensorError {
    pub(crate) fn input(what: impl Into<String>, message: impl Into<String>) -> Self {
        SensorError::Input {
            what: what.into(),
            message: message.into(),
        }
    }
}

/// Result of the sensor stage.
pub type Result<T> = std::result::Result<T, SensorError>;
