//! Typed errors of the analysis crate. Every message names the value or region that was wrong.

use camsim_core::CoreError;

/// Errors from the analysis functions; bad input never panics.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// An argument or data set that cannot be analysed (names `what` and why).
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
    /// An error from the spectral core (memory guard, grids).
    #[error(transparent)]
    Core(#[from] CoreError),
}

impl AnalysisError {
    /// Shorthand for [`AnalysisError::Invalid`].
    pub fn invalid(what: impl Into<String>, message: impl Into<String>) -> Self {
        AnalysisError::Invalid {
            what: what.into(),
            message: message.into(),
        }
    }
}

/// Result with [`AnalysisError`].
pub type Result<T> = std::result::Result<T, AnalysisError>;
