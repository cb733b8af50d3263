use std::path::PathBuf;

/// Errors from the spectral core. Every variant names what was wrong (file, line, key or value),
/// so the CLI can print it as it is and exit with code 2.
#[derive(Debug, thiserror::Error)]
pub enum CoreError {
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("{path}, line {line}: {message}")]
    Line {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// Work refused before it was allocated ([`crate::mem::MemoryBudget`]): the stage, the
    /// estimate, its largest parts, the limit and what to do.
    #[error("{0}")]
    OutOfMemory(String),
    /// Output refused before it was written ([`crate::mem::check_disk`]).
    #[error("{0}")]
    OutOfDisk(String),
    /// A name that is not in its family's table ([`crate::names::NameTable`]).
    #[error("unknown {family} '{name}'; known: {known}")]
    UnknownName {
        family: String,
        name: String,
        known: String,
    },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl CoreError {
    pub fn invalid(what: impl Into<String>, message: impl Into<String>) -> Self {
        CoreError::Invalid {
            what: what.into(),
            message: message.into(),
        }
    }
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        CoreError::File {
            path: path.into(),
            message: message.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, CoreError>;
