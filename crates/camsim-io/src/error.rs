//! The error type of camsim-io. Every variant names the file it is about.

use std::path::{Path, PathBuf};

/// Errors reading or writing files. The message always starts with the file's path, so the CLI
/// can print it as it is (exit code 2 for bad input).
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused a read, write, rename or create.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file's contents are not what the format requires (malformed, truncated, unsupported).
    #[error("{}: {message}", path.display())]
    Format {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong, naming the tag, channel, attribute or value.
        message: String,
    },
    /// A line of a text file (CSV) is malformed.
    #[error("{}, line {line}: {message}", path.display())]
    Line {
        /// The file concerned.
        path: PathBuf,
        /// The line, 1-based.
        line: usize,
        /// What is wrong, naming the column or value.
        message: String,
    },
    /// Data handed to a writer is inconsistent (sizes that do not match, empty images).
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file that was to be written.
        path: PathBuf,
        /// What is wrong with the data.
        message: String,
    },
    /// An error from the spectral core (grid, image or memory checks), with the file it concerns.
    #[error("{}: {source}", path.display())]
    Core {
        /// The file concerned.
        path: PathBuf,
        /// The core error.
        source: camsim_core::CoreError,
    },
    /// An I/O error raised inside a writer closure before the path is known; `write_atomic` and
    /// `with_temp_path` turn it into [`IoError::Io`] naming the file.
    #[error("{0}")]
    Stream(#[from] std::io::Error),
}

impl IoError {
    /// A [`IoError::Format`] for `path`.
    pub fn format(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        IoError::Format {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }
    /// A [`IoError::Line`] for `path`, line `line` (1-based).
    pub fn line(path: impl AsRef<Path>, line: usize, message: impl Into<String>) -> Self {
        IoError::Line {
            path: path.as_ref().to_path_buf(),
            line,
            message: message.into(),
        }
    }
    /// A [`IoError::Invalid`] for `path`.
    pub fn invalid(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        IoError::Invalid {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }
    /// A [`IoError::Io`] for `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        IoError::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
    /// A [`IoError::Core`] for `path`.
    pub fn core(path: impl AsRef<Path>, source: camsim_core::CoreError) -> Self {
        IoError::Core {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
    /// Attach `path` to a path-less [`IoError::Stream`]; other variants are returned unchanged.
    pub fn with_path(self, path: &Path) -> Self {
        match self {
            IoError::Stream(e) => IoError::io(path, e),
            other => other,
        }
    }
}

/// Result with [`IoError`].
pub type Result<T> = std::result::Result<T, IoError>;
