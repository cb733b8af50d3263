//! Single-channel f32 planes, rectangles, and CFA channel sub-grids of a raw mosaic.
//!
//! Coordinates: pixel (row, col) covers x in [col, col + 1) and y in [row, row + 1); its centre is
//! at (col + 0.5, row + 0.5). Continuous points are given as `[x, y]` = [column, row] in pixels.

use crate::error::{AnalysisError, Result};
use camsim_core::{CfaChannel, CfaPattern, RawImage};
use serde::{Deserialize, Serialize};

/// A rectangle of pixels: rows `row .. row + rows`, columns `col .. col + cols`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rect {
    /// First row (pixels from the top).
    pub row: usize,
    /// First column (pixels from the left).
    pub col: usize,
    /// Height, pixels.
    pub rows: usize,
    /// Width, pixels.
    pub cols: usize,
}

impl Rect {
    /// A rectangle from its first row, first column, height and width.
    pub fn new(row: usize, col: usize, rows: usize, cols: usize) -> Rect {
        Rect {
            row,
            col,
            rows,
            cols,
        }
    }

    /// One past the last row.
    pub fn row_end(&self) -> usize {
        self.row.saturating_add(self.rows)
    }

    /// One past the last column.
    pub fn col_end(&self) -> usize {
        self.col.saturating_add(self.cols)
    }

    /// Number of pixels.
    pub fn area(&self) -> usize {
        self.rows * self.cols
    }

    /// Error unless the rectangle is non-empty and lies inside a `rows x cols` image.
    pub fn check_inside(&self, rows: usize, cols: usize, what: &str) -> Result<()> {
        if self.rows == 0 || self.cols == 0 {
            return Err(AnalysisError::invalid(
                what,
                format!("rectangle {self} is empty"),
            ));
        }
        if self.row.checked_add(self.rows).is_none_or(|e| e > rows)
            || self.col.checked_add(self.cols).is_none_or(|e| e > cols)
        {
            return Err(AnalysisError::invalid(
                what,
                format!("rectangle {self} does not fit in the {rows} x {cols} image"),
            ));
        }
        Ok(())
    }
}

impl std::fmt::Display for Rect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "rows {}..{}, columns {}..{}",
            self.row,
            self.row_end(),
            self.col,
            self.col_end()
        )
    }
}

/// A single-channel image of f32 values, row-major (`data[row * cols + col]`). The unit is the
/// caller's (DN above black for raw data, W/(m^2 nm) for an irradiance band, ...).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    /// Height, pixels.
    pub rows: usize,
    /// Width, pixels.
    pub cols: usize,
    /// Values, row-major, `rows * cols`.
    pub data: Vec<f32>,
}

impl Plane {
    /// Wrap row-major data, checking its length.
    pub fn new(rows: usize, cols: usize, data: Vec<f32>) -> Result<Plane> {
        if rows == 0 || cols == 0 {
            return Err(AnalysisError::invalid(
                "plane",
                format!("{rows} x {cols} has no pixels"),
            ));
        }
        if rows.checked_mul(cols) != Some(data.len()) {
            return Err(AnalysisError::invalid(
                "plane",
                format!("{} values for {rows} x {cols} pixels", data.len()),
            ));
        }
        Ok(Plane { rows, cols, data })
    }

    /// A plane of zeros, refusing sizes that do not fit in memory.
    pub fn zeros(rows: usize, cols: usize) -> Result<Plane> {
        let n = rows.checked_mul(cols).filter(|n| *n > 0).ok_or_else(|| {
            AnalysisError::invalid("plane", format!("{rows} x {cols} is not a valid size"))
        })?;
        camsim_core::mem::check_alloc(n as u64 * 4, &format!("a {rows} x {cols} plane"))?;
        Ok(Plane {
            rows,
            cols,
            data: vec![0.0; n],
        })
    }

    /// A plane computed from `f(row, col)`.
    pub fn from_fn(
        rows: usize,
        cols: usize,
        mut f: impl FnMut(usize, usize) -> f32,
    ) -> Result<Plane> {
        let mut p = Plane::zeros(rows, cols)?;
        for r in 0..rows {
            for c in 0..cols {
                p.data[r * cols + c] = f(r, c);
            }
        }
        Ok(p)
    }

    /// Value at (row, col).
    #[inline]
    pub fn at(&self, row: usize, col: usize) -> f32 {
        self.data[row * self.cols + col]
    }

    /// One row as a slice.
    #[inline]
    pub fn row(&self, row: usize) -> &[f32] {
        &self.data[row * self.cols..(row + 1) * self.cols]
    }

    /// The whole plane as a rectangle.
    pub fn full_rect(&self) -> Rect {
        Rect::new(0, 0, self.rows, self.cols)
    }

    /// Copy of the pixels inside `rect` (error if it does not fit).
    pub fn crop(&self, rect: &Rect) -> Result<Plane> {
        rect.check_inside(self.rows, self.cols, "crop")?;
        let mut data = Vec::with_capacity(rect.area());
        for r in rect.row..rect.row_end() {
            data.extend_from_slice(&self.row(r)[rect.col..rect.col_end()]);
        }
        Ok(Plane {
            rows: rect.rows,
            cols: rect.cols,
            data,
        })
    }

    /// The transposed plane (rows become columns).
    pub fn transpose(&self) -> Plane {
        let mut data = vec![0.0f32; self.data.len()];
        for r in 0..self.rows {
            for c in 0..self.cols {
                data[c * self.rows + r] = self.data[r * self.cols + c];
            }
        }
        Plane {
            rows: self.cols,
            cols: self.rows,
            data,
        }
    }

    /// Bilinear interpolation at the continuous point (x, y) (pixel centres at +0.5), clamped
    /// to the image; `None` when the point lies outside the image.
    pub fn sample_bilinear(&self, x: f64, y: f64) -> Option<f64> {
        if !(x >= 0.0 && y >= 0.0 && x <= self.cols as f64 && y <= self.rows as f64) {
            return None;
        }
        let u = (x - 0.5).clamp(0.0, (self.cols - 1) as f64);
        let v = (y - 0.5).clamp(0.0, (self.rows - 1) as f64);
        let c0 = u.floor() as usize;
        let r0 = v.floor() as usize;
        let c1 = (c0 + 1).min(self.cols - 1);
        let r1 = (r0 + 1).min(self.rows - 1);
        let fu = u - c0 as f64;
        let fv = v - r0 as f64;
        let a = self.at(r0, c0) as f64 * (1.0 - fu) + self.at(r0, c1) as f64 * fu;
        let b = self.at(r1, c0) as f64 * (1.0 - fu) + self.at(r1, c1) as f64 * fu;
        Some(a * (1.0 - fv) + b * fv)
    }

    /// Mean and sample standard deviation (n - 1 in the denominator) of the pixels in `rect`,
    /// and their number.
    pub fn stats(&self, rect: &Rect) -> Result<(f64, f64, usize)> {
        rect.check_inside(self.rows, self.cols, "region statistics")?;
        let mut acc = Moments::default();
        for r in rect.row..rect.row_end() {
            for v in &self.row(r)[rect.col..rect.col_end()] {
                acc.push(*v as f64);
            }
        }
        Ok((acc.mean(), acc.std(), acc.n))
    }
}

/// Running mean and variance (Welford 1962), numerically stable for large counts.
#[derive(Debug, Clone, Copy, Default)]
pub struct Moments {
    /// Number of values.
    pub n: usize,
    mean: f64,
    m2: f64,
}

impl Moments {
    /// Add one value.
    #[inline]
    pub fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }
    /// Mean (0 when empty).
    pub fn mean(&self) -> f64 {
        self.mean
    }
    /// Sample variance with n - 1 in the denominator (0 for fewer than two values).
    pub fn var(&self) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.m2 / (self.n - 1) as f64
        }
    }
    /// Population variance with n in the denominator (0 when empty).
    pub fn var_population(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.m2 / self.n as f64
        }
    }
    /// Sample standard deviation (n - 1).
    pub fn std(&self) -> f64 {
        self.var().sqrt()
    }
}

/// Position (row, col) within the 2x2 Bayer block of `ch`. For green, `which_green` picks the
/// first (0, default) or second (1) green of the block in the pattern's reading order
/// (top-left, top-right, bottom-left, bottom-right); it is ignored for red and blue.
pub fn cfa_channel_offset(
    cfa: CfaPattern,
    ch: CfaChannel,
    which_green: Option<usize>,
) -> Result<(usize, usize)> {
    let want = if ch == CfaChannel::G {
        which_green.unwrap_or(0)
    } else {
        0
    };
    if want > 1 {
        return Err(AnalysisError::invalid(
            "green channel",
            format!("which_green must be 0 or 1, got {want}"),
        ));
    }
    cfa.channels()
        .iter()
        .enumerate()
        .filter(|(_, c)| **c == ch)
        .nth(want)
        .map(|(i, _)| (i / 2, i % 2))
        .ok_or_else(|| {
            AnalysisError::invalid(
                "cfa channel",
                format!("{} is not in pattern {}", ch.letter(), cfa.name()),
            )
        })
}

/// The whole mosaic as a plane of DN above black (`dn - black_level_dn`).
pub fn raw_plane(raw: &RawImage) -> Result<Plane> {
    check_raw(raw)?;
    let black = raw.black_level_dn as f32;
    Ok(Plane {
        rows: raw.rows,
        cols: raw.cols,
        data: raw.dn.iter().map(|v| *v as f32 - black).collect(),
    })
}

/// The sub-grid of one CFA channel (every other row and column, starting at the channel's
/// position in the 2x2 block), black subtracted, in DN. Sub-grid pixel (i, j) is sensor pixel
/// (2 i + dr, 2 j + dc) with (dr, dc) from [`cfa_channel_offset`]; its pitch is twice the sensor's.
pub fn cfa_channel_plane(
    raw: &RawImage,
    ch: CfaChannel,
    which_green: Option<usize>,
) -> Result<Plane> {
    check_bayer_raw(raw)?;
    let (dr, dc) = cfa_channel_offset(raw.cfa, ch, which_green)?;
    let rows = (raw.rows - dr).div_ceil(2);
    let cols = (raw.cols - dc).div_ceil(2);
    if rows == 0 || cols == 0 {
        return Err(AnalysisError::invalid(
            "raw image",
            format!(
                "{} x {} is too small for a CFA sub-grid",
                raw.rows, raw.cols
            ),
        ));
    }
    let black = raw.black_level_dn as f32;
    let mut data = Vec::with_capacity(rows * cols);
    for i in 0..rows {
        let r = 2 * i + dr;
        let line = &raw.dn[r * raw.cols..(r + 1) * raw.cols];
        data.extend((0..cols).map(|j| line[2 * j + dc] as f32 - black));
    }
    Ok(Plane { rows, cols, data })
}

/// The sub-grid rectangle of a channel covering the sensor-pixel rectangle `rect`: the sub-grid
/// pixels whose sensor pixels lie inside `rect`.
pub fn sub_grid_rect(rect: &Rect, offset: (usize, usize)) -> Rect {
    let first = |start: usize, d: usize| {
        if start <= d {
            0
        } else {
            (start - d).div_ceil(2)
        }
    };
    let end = |stop: usize, d: usize| if stop <= d { 0 } else { (stop - d).div_ceil(2) };
    let r0 = first(rect.row, offset.0);
    let c0 = first(rect.col, offset.1);
    let r1 = end(rect.row_end(), offset.0);
    let c1 = end(rect.col_end(), offset.1);
    Rect::new(r0, c0, r1.saturating_sub(r0), c1.saturating_sub(c0))
}

/// Error unless the raw frame's sizes agree with its data.
/// [`check_raw`] for the per-channel statistics, which read the 2x2 Bayer layout: a frame with
/// another CFA (RGBW, Quad Bayer, ...) is refused rather than read as Bayer.
pub(crate) fn check_bayer_raw(raw: &RawImage) -> Result<()> {
    check_raw(raw)?;
    raw.require_bayer("CFA channel statistics")
        .map_err(|e| AnalysisError::invalid("raw image", e.to_string()))
}

pub(crate) fn check_raw(raw: &RawImage) -> Result<()> {
    if raw.rows == 0 || raw.cols == 0 || raw.rows.checked_mul(raw.cols) != Some(raw.dn.len()) {
        return Err(AnalysisError::invalid(
            "raw image",
            format!(
                "{} values for {} x {} pixels",
                raw.dn.len(),
                raw.rows,
                raw.cols
            ),
        ));
    }
    if !raw.black_level_dn.is_finite() {
        return Err(AnalysisError::invalid(
            "raw image",
            format!("black level {} is not a number", raw.black_level_dn),
        ));
    }
    Ok(())
}

/// Luminance weights of Rec. ITU-R BT.709 (R, G, B), as `sfrmat` uses by default: camsim's one
/// luminance of RGB data ([`luminance`]).
pub const LUMINANCE_WEIGHTS_REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The luminance of three planes of equal size (a demosaicked image): the Rec. 709 weighted sum
/// [`LUMINANCE_WEIGHTS_REC709`], the one luminance every camsim measurement of RGB data uses (the
/// CLI, Python and `camsim validate` measure the same number). A spectral image's luminance is
/// [`spectral_luminance`].
pub fn luminance(planes: &[Plane; 3]) -> Result<Plane> {
    check_rgb(planes)?;
    let w = LUMINANCE_WEIGHTS_REC709.map(|v| v as f32);
    let data = (0..planes[0].data.len())
        .map(|i| w[0] * planes[0].data[i] + w[1] * planes[1].data[i] + w[2] * planes[2].data[i])
        .collect();
    Ok(Plane {
        rows: planes[0].rows,
        cols: planes[0].cols,
        data,
    })
}

/// The luminance of a spectral image up to a constant: sum over bands of the CIE 1931 photopic
/// luminous efficiency ybar(lambda) times the band (CIE 015:2018 eq. 7.1 without 683 lm/W and
/// d(lambda), which do not change a normalised measurement such as the SFR).
pub fn spectral_luminance(img: &camsim_core::SpectralImage) -> Result<Plane> {
    let cmfs = camsim_core::colorimetry::Cmfs::on(&img.grid);
    let mut y = vec![0f32; img.pixels()];
    for b in 0..img.bands() {
        let w = cmfs.y[b] as f32;
        for (o, v) in y.iter_mut().zip(img.band(b)) {
            *o += w * v;
        }
    }
    Plane::new(img.rows, img.cols, y)
}

/// Error unless three planes share one size.
pub(crate) fn check_rgb(planes: &[Plane; 3]) -> Result<()> {
    for (i, p) in planes.iter().enumerate() {
        if p.rows * p.cols != p.data.len() || p.rows == 0 {
            return Err(AnalysisError::invalid(
                "rgb planes",
                format!(
                    "plane {i} has {} values for {} x {}",
                    p.data.len(),
                    p.rows,
                    p.cols
                ),
            ));
        }
        if p.rows != planes[0].rows || p.cols != planes[0].cols {
            return Err(AnalysisError::invalid(
                "rgb planes",
                format!(
                    "plane {i} is {} x {} but plane 0 is {} x {}",
                    p.rows, p.cols, planes[0].rows, planes[0].cols
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw_with(cfa: CfaPattern) -> RawImage {
        let mut raw = RawImage::new(6, 8, cfa, 12).unwrap();
        raw.black_level_dn = 64.0;
        for r in 0..6 {
            for c in 0..8 {
                // Encode the channel and position so the sub-grid can be checked exactly.
                raw.dn[r * 8 + c] =
                    100 + 1000 * cfa.channel_at(r, c).index() as u16 + (r * 8 + c) as u16;
            }
        }
        raw
    }

    #[test]
    fn channel_sub_grids_hold_only_their_channel_at_twice_the_pitch() {
        for cfa in [
            CfaPattern::Rggb,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
            CfaPattern::Bggr,
        ] {
            let raw = raw_with(cfa);
            for (ch, g) in [
                (CfaChannel::R, None),
                (CfaChannel::G, Some(0)),
                (CfaChannel::G, Some(1)),
                (CfaChannel::B, None),
            ] {
                let p = cfa_channel_plane(&raw, ch, g).unwrap();
                let (dr, dc) = cfa_channel_offset(cfa, ch, g).unwrap();
                assert_eq!((p.rows, p.cols), (3, 4));
                for i in 0..3 {
                    for j in 0..4 {
                        let (r, c) = (2 * i + dr, 2 * j + dc);
                        assert_eq!(cfa.channel_at(r, c), ch);
                        assert_eq!(p.at(i, j), raw.at(r, c) as f32 - 64.0);
                    }
                }
            }
            let g0 = cfa_channel_offset(cfa, CfaChannel::G, Some(0)).unwrap();
            let g1 = cfa_channel_offset(cfa, CfaChannel::G, Some(1)).unwrap();
            assert_ne!(g0, g1);
            assert!(cfa_channel_offset(cfa, CfaChannel::G, Some(2)).is_err());
        }
    }

    #[test]
    fn a_non_bayer_frame_is_refused_by_the_channel_statistics() {
        let mut raw = raw_with(CfaPattern::Rggb);
        raw.layout = Some(camsim_core::cfa::CfaLayout::parse("RGBW").unwrap());
        let e = cfa_channel_plane(&raw, CfaChannel::R, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("RGBW"), "{e}");
        // (The region statistics refuse it too: crate::roi's tests.)
        // The whole mosaic needs no layout: still readable.
        assert!(raw_plane(&raw).is_ok());
    }

    #[test]
    fn sub_grid_rect_selects_exactly_the_channel_pixels_inside() {
        for off in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            for rect in [
                Rect::new(0, 0, 6, 8),
                Rect::new(1, 2, 3, 5),
                Rect::new(2, 1, 1, 1),
                Rect::new(3, 3, 2, 2),
            ] {
                let s = sub_grid_rect(&rect, off);
                let mut expect = vec![];
                for r in rect.row..rect.row_end() {
                    for c in rect.col..rect.col_end() {
                        if r % 2 == off.0 && c % 2 == off.1 {
                            expect.push(((r - off.0) / 2, (c - off.1) / 2));
                        }
                    }
                }
                let mut got = vec![];
                for i in s.row..s.row_end() {
                    for j in s.col..s.col_end() {
                        got.push((i, j));
                    }
                }
                assert_eq!(got, expect, "rect {rect} offset {off:?}");
            }
        }
    }

    #[test]
    fn crop_transpose_stats_and_bad_sizes() {
        let p = Plane::from_fn(4, 5, |r, c| (r * 10 + c) as f32).unwrap();
        let c = p.crop(&Rect::new(1, 2, 2, 3)).unwrap();
        assert_eq!(c.data, vec![12.0, 13.0, 14.0, 22.0, 23.0, 24.0]);
        let t = p.transpose();
        assert_eq!((t.rows, t.cols), (5, 4));
        assert_eq!(t.at(3, 2), p.at(2, 3));
        // Mean and sample std of 12,13,14,22,23,24: mean 18, var = (36+25+16+16+25+36)/5 = 30.8.
        let (m, s, n) = p.stats(&Rect::new(1, 2, 2, 3)).unwrap();
        assert_eq!(n, 6);
        assert!((m - 18.0).abs() < 1e-12 && (s - 30.8f64.sqrt()).abs() < 1e-12);
        assert!(p.crop(&Rect::new(3, 0, 2, 1)).is_err());
        assert!(p.stats(&Rect::new(0, 0, 0, 1)).is_err());
        assert!(Plane::new(2, 2, vec![0.0; 3]).is_err());
        assert!(p.crop(&Rect::new(usize::MAX, 0, 2, 1)).is_err());
        // Bilinear sampling reproduces a linear function exactly.
        let v = p.sample_bilinear(2.25, 1.75).unwrap();
        assert!((v - ((1.75 - 0.5) * 10.0 + (2.25 - 0.5))).abs() < 1e-9);
        assert!(p.sample_bilinear(-1.0, 0.0).is_none());
    }
}
