//! camsim-dataset: synthetic camera datasets at scale.
//!
//! A dataset spec ([`spec`]) is a base `simulate` config plus variations over any of its keys
//! (grids and seeded random draws). Sample `i` is a function of (spec, i) alone: its varied
//! values, its config and its seed never depend on the machine, the number of workers or the
//! order samples run in, so the same spec gives the same bytes anywhere. Samples are grouped in
//! shards, each written atomically as a WebDataset tar file with a JSON record; a re-run skips
//! complete shards (checked by SHA-256) and redoes the rest ([`run`]). One process can run every
//! shard (`camsim dataset`), one part of n (`--shard i/n`, for Slurm arrays and Kubernetes
//! indexed Jobs), or one shard per task of a cluster engine (the Python package's Ray backend
//! calls [`run_shard`]).

pub mod bop;
pub mod coco;
pub mod run;
pub mod spec;

pub use bop::export_bop;
pub use coco::{export_coco, CategoryBy};
pub use run::{
    gather, run, run_shard, shard_complete, RunSummary, SampleRecord, ShardRecord, ShardSelect,
};
pub use spec::{DatasetOutput, DatasetSpec, Sample, DATASET_OUTPUTS};

use std::path::{Path, PathBuf};

/// What a dataset run can fail with.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The spec (the message names the key or variation).
    #[error("{source_name}: {message}")]
    Spec {
        source_name: String,
        message: String,
    },
    /// A file of the dataset folder.
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Write(#[from] camsim_io::IoError),
}

impl DatasetError {
    pub(crate) fn spec(source: impl std::fmt::Display, message: impl Into<String>) -> Self {
        DatasetError::Spec {
            source_name: source.to_string(),
            message: message.into(),
        }
    }
    pub(crate) fn file(path: &Path, message: impl Into<String>) -> Self {
        DatasetError::File {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        DatasetError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Result of this crate.
pub type Result<T, E = DatasetError> = std::result::Result<T, E>;
