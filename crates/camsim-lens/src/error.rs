//! Errors of lens files and lens tracing. Every message names the file and the surface (or key)
//! that is wrong.

use std::path::PathBuf;

/// An error reading or checking a lens.
#[derive(Debug, thiserror::Error)]
pub enum LensError {
    /// A file could not be read.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The text is not a lens file of the expected format (`what` names the file; `line` is
    /// 1-based where the format has lines, 0 for the JSON parser's own position in `message`).
    #[error("{what}{}: {message}", if *line > 0 { format!(", line {line}") } else { String::new() })]
    Parse {
        /// File or lens name.
        what: String,
        /// 1-based line (0: none).
        line: usize,
        /// The problem.
        message: String,
    },
    /// A surface of the prescription is impossible (`surface` is 1-based, object side first).
    #[error("{what}: surface {surface}: {message}")]
    Surface {
        /// File or lens name.
        what: String,
        /// 1-based surface number, object side first.
        surface: usize,
        /// The problem.
        message: String,
    },
    /// The lens as a whole is impossible (no stop, no power, ...).
    #[error("{what}: {message}")]
    Lens {
        /// File or lens name.
        what: String,
        /// The problem.
        message: String,
    },
}

/// Result of lens operations.
pub type Result<T> = std::result::Result<T, LensError>;
