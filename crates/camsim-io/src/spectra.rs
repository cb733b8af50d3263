//! Spectra tables written as CSV files (the format of `camsim_core::spectrum_csv`), through the
//! one atomic writer ([`crate::atomic`]): a reader never sees a partial file.

use crate::atomic::write_bytes_atomic;
use crate::error::{IoError, Result};
use camsim_core::spectrum_csv::{format_spectra_csv, SpectraTable};
use std::path::Path;

/// Write a table as CSV (`camsim_core::spectrum_csv::format_spectra_csv`), atomically.
pub fn write_spectra_csv(path: impl AsRef<Path>, table: &SpectraTable) -> Result<()> {
    write_spectra_csv_with_comments(path, table, &[])
}

/// [`write_spectra_csv`] with `# ` comment lines at the top (source, units).
pub fn write_spectra_csv_with_comments(
    path: impl AsRef<Path>,
    table: &SpectraTable,
    comments: &[&str],
) -> Result<()> {
    let path = path.as_ref();
    let text = format_spectra_csv(table, comments).map_err(|e| IoError::Core {
        path: path.to_path_buf(),
        source: e,
    })?;
    write_bytes_atomic(path, text.as_bytes())
}
