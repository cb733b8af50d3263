//! Column and row noise correction: fixed per-column (and per-row) offsets of the readout
//! chains (column FPN, `camsim_sensor::defects`) estimated from a dark frame and subtracted from
//! the raw. The estimate of column c is the mean of the dark frame's column c minus the mean of
//! the whole frame (the black level stays where it is); the rows' likewise after the columns are
//! removed. Each is the mean of n_rows (n_cols) pixels, so with a per-pixel temporal noise sigma
//! in the dark frame its estimation error has variance sigma^2 / n_rows (sigma^2 / n_cols): after
//! the correction the column means of a frame vary across columns by that plus the frame's own
//! sigma^2 / n_rows, not by the column FPN's sigma_col^2. Per-pixel DSNU in the dark frame is
//! fixed as well, so its column means are part of the fixed offset and are removed with it.
//!
//! A dark frame can be one capture, the mean of several (the error falls as 1 / frames), or the
//! sensor model's own fixed offset map (`camsim_sensor::Sensor::fixed_offset_dn`, no temporal
//! noise: an exact calibration). Column gain FPN is not measurable in the dark and is not
//! corrected.

use camsim_core::error::{CoreError, Result};
use camsim_core::RawImage;
use rayon::prelude::*;

/// Where the ISP's column and row noise correction takes its dark frame from.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum ColumnCorrection {
    /// No correction (the default).
    #[default]
    Off,
    /// The sensor's own fixed dark frame (its fixed offsets at zero light, without temporal
    /// noise: a calibration averaged over many frames).
    Sensor,
}

impl ColumnCorrection {
    /// The name the configs take.
    pub fn name(self) -> &'static str {
        match self {
            ColumnCorrection::Off => "off",
            ColumnCorrection::Sensor => "sensor",
        }
    }
}

/// Per-column and per-row offsets, DN, to subtract (each set has mean 0 over the frame).
#[derive(Debug, Clone, PartialEq)]
pub struct LineOffsets {
    /// Offset of each column, DN (mean 0).
    pub column_dn: Vec<f64>,
    /// Offset of each row, DN (mean 0); empty for columns only.
    pub row_dn: Vec<f64>,
}

impl LineOffsets {
    /// Column and row offsets of a dark frame `dark_dn` (`rows x cols`, row-major, any units
    /// of DN: above black or raw): column c's mean minus the frame mean; then, with those
    /// removed, row r's mean minus the frame mean (`rows_too`; else no row offsets).
    pub fn from_dark(dark_dn: &[f32], rows: usize, cols: usize, rows_too: bool) -> Result<Self> {
        if rows == 0 || cols == 0 || dark_dn.len() != rows * cols {
            return Err(CoreError::invalid(
                "column noise correction: dark frame",
                format!("{} values for {rows} x {cols} pixels", dark_dn.len()),
            ));
        }
        if dark_dn.iter().any(|v| !v.is_finite()) {
            return Err(CoreError::invalid(
                "column noise correction: dark frame",
                "holds a value that is not finite",
            ));
        }
        // Each column's level: a trimmed mean over its rows (the central 80 % of the sorted
        // values), so a hot or stuck pixel in the dark frame does not shift its column's offset
        // (a stuck pixel at full scale would move a 64-row column's mean by ~15 DN); for
        // normal noise the 10 % trimmed mean's variance is ~1.06 x the mean's (Huber, *Robust
        // Statistics*, 1981, ch. 3).
        let col_mean: Vec<f64> = (0..cols)
            .into_par_iter()
            .map(|c| trimmed_mean((0..rows).map(|r| dark_dn[r * cols + c] as f64).collect()))
            .collect();
        let frame_mean = col_mean.iter().sum::<f64>() / cols as f64;
        let column_dn: Vec<f64> = col_mean.iter().map(|m| m - frame_mean).collect();
        let row_dn = if rows_too {
            dark_dn
                .par_chunks_exact(cols)
                .map(|line| {
                    trimmed_mean(
                        line.iter()
                            .zip(&column_dn)
                            .map(|(v, o)| *v as f64 - o)
                            .collect(),
                    ) - frame_mean
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(LineOffsets { column_dn, row_dn })
    }

    /// [`LineOffsets::from_dark`] of a dark raw frame.
    pub fn from_dark_raw(dark: &RawImage, rows_too: bool) -> Result<Self> {
        let v: Vec<f32> = dark.dn.iter().map(|d| *d as f32).collect();
        Self::from_dark(&v, dark.rows, dark.cols, rows_too)
    }

    /// [`LineOffsets::from_dark`] of the mean of several dark raw frames (the same size).
    pub fn from_dark_frames(darks: &[RawImage], rows_too: bool) -> Result<Self> {
        let first = darks
            .first()
            .ok_or_else(|| CoreError::invalid("column noise correction", "no dark frame given"))?;
        let (rows, cols) = (first.rows, first.cols);
        let mut sum = vec![0f64; rows * cols];
        for d in darks {
            if (d.rows, d.cols) != (rows, cols) || d.dn.len() != rows * cols {
                return Err(CoreError::invalid(
                    "column noise correction: dark frames",
                    format!("a {} x {} frame among {rows} x {cols} ones", d.rows, d.cols),
                ));
            }
            sum.iter_mut().zip(&d.dn).for_each(|(s, v)| *s += *v as f64);
        }
        let n = darks.len() as f64;
        let mean: Vec<f32> = sum.iter().map(|s| (s / n) as f32).collect();
        Self::from_dark(&mean, rows, cols, rows_too)
    }

    /// `raw` minus the offsets (rounded to the nearest DN, clamped to [0, white level]).
    /// Errors when the sizes differ.
    pub fn subtract(&self, raw: &RawImage) -> Result<RawImage> {
        if self.column_dn.len() != raw.cols
            || !(self.row_dn.is_empty() || self.row_dn.len() == raw.rows)
        {
            return Err(CoreError::invalid(
                "column noise correction",
                format!(
                    "offsets for {} columns and {} rows, frame {} x {}",
                    self.column_dn.len(),
                    self.row_dn.len(),
                    raw.rows,
                    raw.cols
                ),
            ));
        }
        let mut out = raw.clone();
        let white = raw.white_level_dn.max(0.0).min(u16::MAX as f64);
        out.dn
            .par_chunks_mut(raw.cols)
            .enumerate()
            .for_each(|(r, line)| {
                let ro = self.row_dn.get(r).copied().unwrap_or(0.0);
                for (v, co) in line.iter_mut().zip(&self.column_dn) {
                    *v = (*v as f64 - co - ro).round().clamp(0.0, white) as u16;
                }
            });
        Ok(out)
    }
}

/// The mean of the central 80 % of `v` (10 % dropped at each end; all of it below 10 values).
fn trimmed_mean(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let k = v.len() / 10;
    let core = &v[k..v.len() - k];
    core.iter().sum::<f64>() / core.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::rng::{keyed, stage};
    use camsim_core::CfaPattern;
    use rand_distr::{Distribution, StandardNormal};

    /// A frame at `level` DN with column offsets `col` and read noise sigma, frame key `frame`.
    fn frame(rows: usize, col: &[f64], level: f64, sigma: f64, frame: u64) -> RawImage {
        let cols = col.len();
        let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 12).unwrap();
        for r in 0..rows {
            let mut rng = keyed(3, stage::ANALYSIS, frame, r as u64);
            for c in 0..cols {
                let z: f64 = StandardNormal.sample(&mut rng);
                raw.dn[r * cols + c] = (level + col[c] + sigma * z).round() as u16;
            }
        }
        raw
    }

    /// Variance across columns of the column means.
    fn column_mean_variance(raw: &RawImage) -> f64 {
        let (rows, cols) = (raw.rows, raw.cols);
        let means: Vec<f64> = (0..cols)
            .map(|c| (0..rows).map(|r| raw.dn[r * cols + c] as f64).sum::<f64>() / rows as f64)
            .collect();
        let m = means.iter().sum::<f64>() / cols as f64;
        means.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (cols - 1) as f64
    }

    #[test]
    fn column_fpn_falls_to_its_estimation_error() {
        let (rows, cols, sigma, sigma_col) = (64, 256, 4.0, 6.0);
        let mut rng = keyed(3, stage::ANALYSIS, 99, 0);
        let col: Vec<f64> = (0..cols)
            .map(|_| sigma_col * Distribution::<f64>::sample(&StandardNormal, &mut rng))
            .collect::<Vec<f64>>();
        let dark = frame(rows, &col, 200.0, sigma, 1);
        let light = frame(rows, &col, 1500.0, sigma, 2);
        let before = column_mean_variance(&light);
        let off = LineOffsets::from_dark_raw(&dark, false).unwrap();
        let after = column_mean_variance(&off.subtract(&light).unwrap());
        // Per pixel variance sigma^2 + 1/12 (rounding of each frame) + 1/12 (rounding of the
        // correction): the estimate's error (sigma^2 + 1/12) / rows plus the frame's own
        // column-mean variance (sigma^2 + 2/12) / rows.
        let expected = (2.0 * sigma * sigma + 3.0 / 12.0) / rows as f64;
        // The sample variance of `cols` normals: relative sd sqrt(2 / (cols - 1)) = 8.9 %;
        // 4 of those either side.
        let tol = 4.0 * (2.0 / (cols - 1) as f64).sqrt();
        eprintln!("column FPN: before {before:.3}, after {after:.4}, expected {expected:.4} DN^2");
        assert!(
            (after / expected - 1.0).abs() < tol,
            "after {after} expected {expected} (before {before})"
        );
        assert!(before > 0.5 * sigma_col * sigma_col, "{before}");
    }

    #[test]
    fn row_offsets_and_bad_sizes() {
        // A dark frame with row offsets only: the estimate recovers them exactly (no noise).
        let (rows, cols) = (4, 6);
        let dark: Vec<f32> = (0..rows * cols)
            .map(|i| 100.0 + [0.0, 3.0, -1.0, -2.0][i / cols])
            .collect();
        let off = LineOffsets::from_dark(&dark, rows, cols, true).unwrap();
        assert!(off.column_dn.iter().all(|v| v.abs() < 1e-9));
        for (r, want) in [0.0, 3.0, -1.0, -2.0].iter().enumerate() {
            assert!((off.row_dn[r] - want).abs() < 1e-6, "{:?}", off.row_dn);
        }
        assert!(LineOffsets::from_dark(&dark, rows, cols + 1, true).is_err());
        let raw = RawImage::new(3, 6, CfaPattern::Rggb, 12).unwrap();
        assert!(off.subtract(&raw).is_err());
        assert!(LineOffsets::from_dark_frames(&[], false).is_err());
    }
}
