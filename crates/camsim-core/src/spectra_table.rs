//! A table of spectra sampled at common wavelengths ([`SpectraTable`]): what a spectra CSV
//! ([`crate::spectrum_csv`]) and an ISETCam MATLAB file ([`crate::mat`]) both read into.

use crate::error::{CoreError, Result};
use crate::grid::WavelengthGrid;
use crate::spectrum::Spectrum;
use std::path::Path;

/// Largest spectra file read into memory, bytes (a spectra table is kilobytes; this rejects a
/// wrong file quickly).
pub const MAX_SPECTRA_FILE_BYTES: u64 = 256 << 20;

/// Several spectra sampled at the same wavelengths (a CSV file's columns, an ISETCam `data` matrix).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectraTable {
    /// Sample wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// One name per column (the CSV header, or ISETCam `filterNames`, or `data_1..n`).
    pub names: Vec<String>,
    /// `columns[j][i]` is spectrum `j` at `wavelengths_nm[i]` (unit as the file says).
    pub columns: Vec<Vec<f64>>,
}

impl SpectraTable {
    /// Build a table, checking it (see [`SpectraTable::validate`]); `what` names it in errors.
    pub fn new(
        wavelengths_nm: Vec<f64>,
        names: Vec<String>,
        columns: Vec<Vec<f64>>,
        what: &str,
    ) -> Result<Self> {
        let t = SpectraTable {
            wavelengths_nm,
            names,
            columns,
        };
        t.validate(what)?;
        Ok(t)
    }

    /// Check: at least one wavelength and one column, one name per column, unique non-empty names
    /// without commas or line breaks, every column as long as the wavelengths, finite values,
    /// positive strictly increasing wavelengths.
    pub fn validate(&self, what: &str) -> Result<()> {
        if self.wavelengths_nm.is_empty() {
            return Err(CoreError::invalid(what, "no wavelengths"));
        }
        if self.columns.is_empty() {
            return Err(CoreError::invalid(
                what,
                "no spectra (only a wavelength column)",
            ));
        }
        if self.names.len() != self.columns.len() {
            return Err(CoreError::invalid(
                what,
                format!(
                    "{} names for {} columns",
                    self.names.len(),
                    self.columns.len()
                ),
            ));
        }
        for (j, n) in self.names.iter().enumerate() {
            if n.trim().is_empty() {
                return Err(CoreError::invalid(
                    what,
                    format!("column {} has an empty name", j + 2),
                ));
            }
            if n.contains([',', '\n', '\r']) || n.starts_with('#') {
                return Err(CoreError::invalid(
                    what,
                    format!("column name '{n}' contains ',', a line break or starts with '#'"),
                ));
            }
            if self.names[..j].contains(n) {
                return Err(CoreError::invalid(
                    what,
                    format!("column name '{n}' appears twice"),
                ));
            }
        }
        for (i, w) in self.wavelengths_nm.iter().enumerate() {
            if !w.is_finite() || *w <= 0.0 {
                return Err(CoreError::invalid(
                    what,
                    format!("wavelength {} is {w}, not a positive number", i + 1),
                ));
            }
            if i > 0 && *w <= self.wavelengths_nm[i - 1] {
                return Err(CoreError::invalid(
                    what,
                    format!(
                        "wavelengths must increase, but {w} nm follows {} nm",
                        self.wavelengths_nm[i - 1]
                    ),
                ));
            }
        }
        for (j, c) in self.columns.iter().enumerate() {
            if c.len() != self.wavelengths_nm.len() {
                return Err(CoreError::invalid(
                    what,
                    format!(
                        "column '{}' has {} values for {} wavelengths",
                        self.names[j],
                        c.len(),
                        self.wavelengths_nm.len()
                    ),
                ));
            }
            if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                return Err(CoreError::invalid(
                    what,
                    format!(
                        "column '{}' at {} nm is {}, not a finite number",
                        self.names[j], self.wavelengths_nm[i], c[i]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Number of spectra (columns).
    pub fn len(&self) -> usize {
        self.columns.len()
    }

    /// True when the table holds no spectra.
    pub fn is_empty(&self) -> bool {
        self.columns.is_empty()
    }

    /// Index of the column named `name`: exact match first, then case-insensitive.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name).or_else(|| {
            self.names
                .iter()
                .position(|n| n.eq_ignore_ascii_case(name.trim()))
        })
    }

    /// The column named `name` (exact, else case-insensitive) as a [`Spectrum`]; the error lists
    /// the names there are.
    pub fn spectrum(&self, name: &str) -> Result<Spectrum> {
        match self.index_of(name) {
            Some(j) => self.spectrum_at(j),
            None => Err(CoreError::invalid(
                format!("spectrum '{name}'"),
                format!("no such column; the table has: {}", self.names.join(", ")),
            )),
        }
    }

    /// Column `index` (0-based) as a [`Spectrum`].
    pub fn spectrum_at(&self, index: usize) -> Result<Spectrum> {
        let values = self.columns.get(index).ok_or_else(|| {
            CoreError::invalid(
                "spectra table",
                format!(
                    "column {index} requested but the table has {} columns",
                    self.len()
                ),
            )
        })?;
        let what = self
            .names
            .get(index)
            .map(String::as_str)
            .unwrap_or("spectrum");
        Spectrum::new(self.wavelengths_nm.clone(), values.clone(), what)
    }

    /// Every column as a [`Spectrum`], in order.
    pub fn spectra(&self) -> Result<Vec<Spectrum>> {
        (0..self.len()).map(|j| self.spectrum_at(j)).collect()
    }

    /// The uniform grid of the wavelengths (error if they are not uniformly spaced).
    pub fn grid(&self) -> Result<WavelengthGrid> {
        WavelengthGrid::from_wavelengths(&self.wavelengths_nm)
    }

    /// Every column linearly resampled onto `grid` (zero outside the sampled range).
    pub fn resampled(&self, grid: &WavelengthGrid) -> Result<SpectraTable> {
        let columns = self.spectra()?.iter().map(|s| s.sample(grid)).collect();
        Ok(SpectraTable {
            wavelengths_nm: grid.wavelengths_nm(),
            names: self.names.clone(),
            columns,
        })
    }
}

/// Read a file into a string, refusing files over [`MAX_SPECTRA_FILE_BYTES`].
pub(crate) fn read_limited(path: &Path) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).map_err(|e| CoreError::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    if !meta.is_file() {
        return Err(CoreError::file(path, "not a regular file"));
    }
    if meta.len() > MAX_SPECTRA_FILE_BYTES {
        return Err(CoreError::file(
            path,
            format!(
                "{} bytes is too large for a spectra file (limit {} MiB)",
                meta.len(),
                MAX_SPECTRA_FILE_BYTES >> 20
            ),
        ));
    }
    std::fs::read(path).map_err(|e| CoreError::Io {
        path: path.to_path_buf(),
        source: e,
    })
}
