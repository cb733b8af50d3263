//! Bilinear demosaicking of a Bayer mosaic, as used in the paper (Lyu et al., "Validation of image
//! systems simulation technology using a Cornell Box": "we demosaicked the measured and simulated
//! raw sensor image data using a bilinear interpolation").
//!
//! Each missing colour at a pixel is the mean of the nearest samples of that colour in the 3x3
//! neighbourhood: green at a red/blue site from its four edge neighbours, red/blue at a green site
//! from the two neighbours in the row or column that carries them, red at a blue site (and blue at
//! a red site) from the four diagonal neighbours. Bilinear interpolation reproduces any function
//! that is linear in (row, col) exactly. At the image border only the neighbours inside the image
//! are averaged ("averaging the available neighbours"), which keeps constant images constant.

use camsim_core::error::{CoreError, Result};
use camsim_core::{CfaPattern, RawImage};
use rayon::prelude::*;

/// A linear RGB image in planar layout (one row-major f32 plane per channel), in the sensor's
/// native colour space. After [`demosaic_bilinear`] the values are black-level-subtracted DN
/// (they can be slightly negative where noise pushed a pixel below the black level).
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Image height, pixels.
    pub rows: usize,
    /// Image width, pixels.
    pub cols: usize,
    /// Red plane, row-major, `rows * cols`.
    pub r: Vec<f32>,
    /// Green plane, row-major, `rows * cols`.
    pub g: Vec<f32>,
    /// Blue plane, row-major, `rows * cols`.
    pub b: Vec<f32>,
}

impl RgbImage {
    /// A black image.
    pub fn zeros(rows: usize, cols: usize) -> RgbImage {
        let n = rows * cols;
        RgbImage {
            rows,
            cols,
            r: vec![0.0; n],
            g: vec![0.0; n],
            b: vec![0.0; n],
        }
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.rows * self.cols
    }

    /// The plane of channel `c` (0 = R, 1 = G, 2 = B).
    pub fn plane(&self, c: usize) -> &[f32] {
        match c {
            0 => &self.r,
            1 => &self.g,
            _ => &self.b,
        }
    }

    /// (R, G, B) at one pixel.
    pub fn at(&self, row: usize, col: usize) -> [f32; 3] {
        let i = row * self.cols + col;
        [self.r[i], self.g[i], self.b[i]]
    }
}

/// [`demosaic_bilinear`] for input that may be malformed: errors (instead of panicking) when
/// `raw.dn` does not hold `rows * cols` values, and refuses an output that would not fit in memory.
pub fn try_demosaic_bilinear(raw: &RawImage) -> Result<RgbImage> {
    raw.require_bayer("bilinear demosaic")?;
    if raw.dn.len() != raw.rows * raw.cols {
        return Err(CoreError::invalid(
            "raw image",
            format!(
                "{} values for {} x {} pixels",
                raw.dn.len(),
                raw.rows,
                raw.cols
            ),
        ));
    }
    camsim_core::mem::check_alloc(
        (raw.rows * raw.cols * 12) as u64,
        "the demosaicked RGB image",
    )?;
    Ok(demosaic_bilinear(raw))
}

/// Bilinear demosaic of `raw` (any of the four Bayer patterns), black level subtracted.
/// Rows are processed in parallel with rayon; no per-pixel allocation. `raw.dn` must hold
/// `rows * cols` values (the [`RawImage`] invariant; [`try_demosaic_bilinear`] checks it).
pub fn demosaic_bilinear(raw: &RawImage) -> RgbImage {
    let (rows, cols) = (raw.rows, raw.cols);
    let mut out = RgbImage::zeros(rows, cols);
    if rows == 0 || cols == 0 {
        return out;
    }
    let black = raw.black_level_dn as f32;
    let cfa = raw.cfa;
    let dn = &raw.dn;
    out.r
        .par_chunks_mut(cols)
        .zip(out.g.par_chunks_mut(cols))
        .zip(out.b.par_chunks_mut(cols))
        .enumerate()
        .for_each(|(y, ((rr, gr), br))| {
            let mut planes: [&mut [f32]; 3] = [rr, gr, br];
            demosaic_row(dn, rows, cols, cfa, black, y, &mut planes);
        });
    out
}

/// One output row. Interior pixels take the fast path (all eight neighbours exist); border
/// pixels average whichever neighbours of the wanted colour lie inside the image.
#[allow(clippy::needless_range_loop)]
fn demosaic_row(
    dn: &[u16],
    rows: usize,
    cols: usize,
    cfa: CfaPattern,
    black: f32,
    y: usize,
    out: &mut [&mut [f32]; 3],
) {
    let v = |yy: usize, xx: usize| dn[yy * cols + xx] as f32 - black;
    let interior_row = y > 0 && y + 1 < rows;
    // Channel of the pixel, of its row neighbours and of its column neighbours, by column parity.
    let own_of = [cfa.channel_at(y, 0).index(), cfa.channel_at(y, 1).index()];
    let horiz_of = [own_of[1], own_of[0]];
    let vert_of = [
        cfa.channel_at(y + 1, 0).index(),
        cfa.channel_at(y + 1, 1).index(),
    ];
    for x in 0..cols {
        if interior_row && x > 0 && x + 1 < cols {
            let c = v(y, x);
            let (up, down, left, right) = (v(y - 1, x), v(y + 1, x), v(y, x - 1), v(y, x + 1));
            let (own, horiz_ch, vert_ch) = (own_of[x & 1], horiz_of[x & 1], vert_of[x & 1]);
            let mut px = [0.0f32; 3];
            px[own] = c;
            if horiz_ch == vert_ch {
                // Red or blue site: green from the 4-cross, the other colour from the diagonals.
                px[horiz_ch] = 0.25 * (up + down + left + right);
                let other = 3 - own - horiz_ch;
                px[other] =
                    0.25 * (v(y - 1, x - 1) + v(y - 1, x + 1) + v(y + 1, x - 1) + v(y + 1, x + 1));
            } else {
                // Green site: one colour along the row, the other along the column.
                px[horiz_ch] = 0.5 * (left + right);
                px[vert_ch] = 0.5 * (up + down);
            }
            out[0][x] = px[0];
            out[1][x] = px[1];
            out[2][x] = px[2];
        } else {
            // Border: mean of the in-image samples of each colour in the 3x3 neighbourhood,
            // taking the nearest ring that has any (the pixel itself for its own colour).
            let own = cfa.channel_at(y, x).index();
            for ch in 0..3 {
                if ch == own {
                    out[ch][x] = v(y, x);
                    continue;
                }
                // Edge neighbours first (distance 1), then diagonals (distance sqrt 2): this is
                // exactly the interior rule restricted to what exists.
                let mut sum = 0.0f32;
                let mut n = 0u32;
                for (dy, dx) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                    let (yy, xx) = (y as i64 + dy, x as i64 + dx);
                    if yy >= 0 && xx >= 0 && (yy as usize) < rows && (xx as usize) < cols {
                        let (yy, xx) = (yy as usize, xx as usize);
                        if cfa.channel_at(yy, xx).index() == ch {
                            sum += v(yy, xx);
                            n += 1;
                        }
                    }
                }
                if n == 0 {
                    for (dy, dx) in [(-1i64, -1i64), (-1, 1), (1, -1), (1, 1)] {
                        let (yy, xx) = (y as i64 + dy, x as i64 + dx);
                        if yy >= 0 && xx >= 0 && (yy as usize) < rows && (xx as usize) < cols {
                            let (yy, xx) = (yy as usize, xx as usize);
                            if cfa.channel_at(yy, xx).index() == ch {
                                sum += v(yy, xx);
                                n += 1;
                            }
                        }
                    }
                }
                out[ch][x] = if n > 0 { sum / n as f32 } else { 0.0 };
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use camsim_core::CfaPattern;

    /// Every Bayer phase.
    pub(crate) const PATTERNS: [CfaPattern; 4] = [
        CfaPattern::Rggb,
        CfaPattern::Grbg,
        CfaPattern::Gbrg,
        CfaPattern::Bggr,
    ];

    /// A 16-bit mosaic with value `f(y, x, channel) + black` at each pixel.
    pub(crate) fn mosaic(
        rows: usize,
        cols: usize,
        cfa: CfaPattern,
        black: f64,
        f: impl Fn(usize, usize, usize) -> f64,
    ) -> RawImage {
        let mut raw = RawImage::new(rows, cols, cfa, 16).unwrap();
        raw.black_level_dn = black;
        for y in 0..rows {
            for x in 0..cols {
                let ch = cfa.channel_at(y, x).index();
                raw.dn[y * cols + x] = (f(y, x, ch) + black).round() as u16;
            }
        }
        raw
    }

    #[test]
    fn constant_channels_demosaic_to_constants_everywhere_for_every_pattern() {
        let levels = [1000.0, 2500.0, 400.0];
        for cfa in PATTERNS {
            for (rows, cols) in [(7, 9), (8, 8), (2, 2), (1, 5), (5, 1)] {
                let raw = mosaic(rows, cols, cfa, 64.0, |_, _, ch| levels[ch]);
                let rgb = demosaic_bilinear(&raw);
                // A 1-pixel-wide image lacks one colour entirely (its value is 0 there); every
                // colour the image holds must come out exactly constant.
                let present: Vec<usize> = (0..rows)
                    .flat_map(|y| (0..cols).map(move |x| cfa.channel_at(y, x).index()))
                    .collect();
                for (ch, &level) in levels.iter().enumerate() {
                    let expect = if present.contains(&ch) {
                        level as f32
                    } else {
                        0.0
                    };
                    for i in 0..rows * cols {
                        assert_eq!(
                            rgb.plane(ch)[i],
                            expect,
                            "{cfa:?} {rows}x{cols} pixel {i} channel {ch}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn linear_ramp_is_exact_in_the_interior_for_every_pattern() {
        // Bilinear interpolation is exact for f = a + b*row + c*col (each channel its own plane).
        let coef = [(100.0, 3.0, 5.0), (200.0, 7.0, 2.0), (50.0, 1.0, 11.0)];
        let f = |y: usize, x: usize, ch: usize| {
            coef[ch].0 + coef[ch].1 * y as f64 + coef[ch].2 * x as f64
        };
        for cfa in PATTERNS {
            let (rows, cols) = (12, 15);
            let raw = mosaic(rows, cols, cfa, 16.0, f);
            let rgb = demosaic_bilinear(&raw);
            for y in 1..rows - 1 {
                for x in 1..cols - 1 {
                    let px = rgb.at(y, x);
                    for ch in 0..3 {
                        assert!(
                            (px[ch] as f64 - f(y, x, ch)).abs() < 1e-3,
                            "{cfa:?} ({y},{x}) ch {ch}: {} vs {}",
                            px[ch],
                            f(y, x, ch)
                        );
                    }
                }
            }
            // The sampled colour is passed through unchanged everywhere, border included.
            for y in 0..rows {
                for x in 0..cols {
                    let ch = cfa.channel_at(y, x).index();
                    assert_eq!(rgb.at(y, x)[ch] as f64, f(y, x, ch));
                }
            }
        }
    }

    #[test]
    fn interpolates_from_the_right_neighbours() {
        // A single bright red sample in an RGGB mosaic spreads to its 8 neighbours with the
        // bilinear weights: 1/2 to the 4 edge neighbours (green sites, 2 red samples each),
        // 1/4 to the 4 diagonals (blue sites, 4 red samples each).
        let mut raw = RawImage::new(7, 7, CfaPattern::Rggb, 12).unwrap();
        raw.dn[2 * 7 + 2] = 400; // (2,2) is red in RGGB
        let rgb = demosaic_bilinear(&raw);
        assert_eq!(rgb.at(2, 2)[0], 400.0);
        for (y, x) in [(1, 2), (3, 2), (2, 1), (2, 3)] {
            assert_eq!(rgb.at(y, x)[0], 200.0);
        }
        for (y, x) in [(1, 1), (1, 3), (3, 1), (3, 3)] {
            assert_eq!(rgb.at(y, x)[0], 100.0);
        }
        assert_eq!(rgb.at(4, 4)[0], 0.0);
        assert!(rgb.g.iter().chain(&rgb.b).all(|v| *v == 0.0));
    }

    #[test]
    fn malformed_raw_is_an_error() {
        let mut raw = RawImage::new(4, 4, CfaPattern::Rggb, 12).unwrap();
        assert!(try_demosaic_bilinear(&raw).is_ok());
        raw.dn.pop();
        assert!(try_demosaic_bilinear(&raw)
            .unwrap_err()
            .to_string()
            .contains("15 values"));
    }
}
