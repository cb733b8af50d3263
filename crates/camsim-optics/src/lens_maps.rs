//! A traced lens's (or ray-transfer function's) distortion and relative illumination on the film
//! ([`LensMaps`]), and their application to a blurred irradiance image: a radial resampling of the
//! ideal-geometry image, then the relative illumination as a gain ([`apply_lens_maps`]). Used by
//! the shift-variant stage ([`crate::shift_variant`]) for both sources ([`crate::traced`],
//! [`crate::rtf_psf`]).

use camsim_core::SpectralImage;
use rayon::prelude::*;

/// Distortion and relative illumination of a traced lens on the film.
#[derive(Debug, Clone)]
pub struct LensMaps {
    /// Ideal (rectilinear, thin-lens) image heights, m.
    pub ideal_m: Vec<f64>,
    /// The 550 nm chief ray's film height for each, m.
    pub real_m: Vec<f64>,
    /// Film heights of the relative illumination table, m.
    pub ri_height_m: Vec<f64>,
    /// Relative illumination (1 on the axis).
    pub ri: Vec<f64>,
}

/// Distortion (radial resampling, bilinear, zero outside) and relative illumination (gain at the
/// film height) on every band of `out`, centred on the optical axis, in place.
///
/// The mapping is the same for every band, so it is evaluated once per output sample and strip of
/// rows and applied to all bands while it is in cache ([`RadialLut`]: distortion and relative
/// illumination are even in the film radius, tabulated in r^2). In place: the strips are done top
/// to bottom; before a strip is overwritten its original rows are saved in a ring that holds the
/// last `D + strip` rows, D the largest row shift of the mapping, so every source row is either
/// still untouched (below the strip) or in the ring. Bands are split into one group per worker
/// (each band's result does not depend on the grouping). No image-sized buffer: fresh pages cost
/// more than the resampling on this class of machine.
pub(crate) fn apply_lens_maps(out: &mut SpectralImage, m: &LensMaps, spacing_m: f64) {
    let (rows, cols) = (out.rows, out.cols);
    let plane = rows * cols;
    let bands = out.bands();
    let lut = RadialLut::new(m, rows, cols, spacing_m);
    const STRIP: usize = 8;
    let d_rows = lut.max_row_shift();
    let ring_rows = d_rows + STRIP + 2;
    let group = bands.div_ceil(rayon::current_num_threads().max(1)).max(1);
    out.data.par_chunks_mut(plane * group).for_each(|grp| {
        let nb = grp.len() / plane;
        let mut rings = vec![0.0f32; nb * ring_rows * cols];
        let mut taps: Vec<Tap> = Vec::with_capacity(STRIP * cols);
        for r0 in (0..rows).step_by(STRIP) {
            let r_end = (r0 + STRIP).min(rows);
            taps.clear();
            for r in r0..r_end {
                for c in 0..cols {
                    taps.push(lut.tap(r, c));
                }
            }
            // Source rows a strip may read: [lo, hi).
            let lo = r0.saturating_sub(d_rows + 1);
            let hi = (r_end + d_rows + 1).min(rows);
            for (band, ring) in grp
                .chunks_mut(plane)
                .zip(rings.chunks_mut(ring_rows * cols))
            {
                for r in r0..r_end {
                    let k = r % ring_rows;
                    ring[k * cols..(k + 1) * cols].copy_from_slice(&band[r * cols..(r + 1) * cols]);
                }
                let (head, rest) = band.split_at_mut(r_end * cols);
                let ring: &[f32] = ring;
                let rest: &[f32] = rest;
                let src_rows: Vec<&[f32]> = (lo..hi)
                    .map(|r| {
                        if r >= r_end {
                            &rest[(r - r_end) * cols..(r - r_end + 1) * cols]
                        } else {
                            let k = r % ring_rows;
                            &ring[k * cols..(k + 1) * cols]
                        }
                    })
                    .collect();
                let row = |r: i32| -> Option<&[f32]> {
                    if r >= lo as i32 && r < hi as i32 {
                        Some(src_rows[(r - lo as i32) as usize])
                    } else {
                        None
                    }
                };
                for (d, t) in head[r0 * cols..].iter_mut().zip(taps.iter()) {
                    let v = if t.inside {
                        let (a, b) = (
                            src_rows[t.row as usize - lo],
                            src_rows[t.row as usize + 1 - lo],
                        );
                        let c = t.col as usize;
                        (a[c] * (1.0 - t.fx) + a[c + 1] * t.fx) * (1.0 - t.fy)
                            + (b[c] * (1.0 - t.fx) + b[c + 1] * t.fx) * t.fy
                    } else {
                        let at = |r: i32, c: i32| match row(r) {
                            Some(x) if c >= 0 && (c as usize) < cols => x[c as usize],
                            _ => 0.0,
                        };
                        (at(t.row, t.col) * (1.0 - t.fx) + at(t.row, t.col + 1) * t.fx)
                            * (1.0 - t.fy)
                            + (at(t.row + 1, t.col) * (1.0 - t.fx)
                                + at(t.row + 1, t.col + 1) * t.fx)
                                * t.fy
                    };
                    *d = (v * t.gain).max(0.0);
                }
            }
        }
    });
}

/// One output sample's bilinear source taps: top-left source row and column, weights, gain;
/// `inside`: all four taps lie in the image.
#[derive(Clone, Copy)]
struct Tap {
    row: i32,
    col: i32,
    fx: f32,
    fy: f32,
    gain: f32,
    inside: bool,
}

/// Ideal / film height ratio and relative illumination against the squared film radius (samples^2).
#[derive(Debug, Clone)]
pub(crate) struct RadialLut {
    rows: usize,
    cols: usize,
    inv_step: f64,
    scale: Vec<f64>,
    gain: Vec<f64>,
}

impl RadialLut {
    /// Entries: over the image's r^2 the table's linear interpolation error is far below the
    /// maps' own (piecewise linear in r on 33-129 points).
    const N: usize = 16384;

    pub(crate) fn new(m: &LensMaps, rows: usize, cols: usize, spacing_m: f64) -> RadialLut {
        let r2_max = ((rows * rows + cols * cols) as f64 / 4.0 + 4.0 * (rows + cols) as f64) * 1.01;
        let step = r2_max / (Self::N - 1) as f64;
        let slope0 = if m.real_m.len() > 1 && m.real_m[1] > 0.0 {
            m.ideal_m[1] / m.real_m[1]
        } else {
            1.0
        };
        let (scale, gain) = (0..Self::N)
            .map(|i| {
                let h_real = (i as f64 * step).sqrt() * spacing_m;
                let f = if h_real > 0.0 {
                    interp_extend(&m.real_m, &m.ideal_m, h_real) / h_real
                } else {
                    slope0
                };
                (f, interp(&m.ri_height_m, &m.ri, h_real))
            })
            .unzip();
        RadialLut {
            rows,
            cols,
            inv_step: 1.0 / step,
            scale,
            gain,
        }
    }

    /// The ideal / film height ratio and the gain at film offset (`x`, `y`) samples from the
    /// axis (the one place the distortion is looked up: the resampling and the labels'
    /// [`crate::image_map::ImageMap`]).
    pub(crate) fn at(&self, x: f64, y: f64) -> (f64, f32) {
        let u = ((x * x + y * y) * self.inv_step).min((Self::N - 2) as f64);
        let i = u as usize;
        let t = u - i as f64;
        let f = self.scale[i] + t * (self.scale[i + 1] - self.scale[i]);
        let gain = (self.gain[i] + t * (self.gain[i + 1] - self.gain[i])) as f32;
        (f, gain)
    }

    /// The film radius (samples from the axis) that images ideal radius `rho_ideal`: the
    /// inverse of rho f(rho) by bisection over the table's range (rho f(rho) rises for any lens
    /// whose image does not fold back); `None` beyond the table.
    pub(crate) fn film_radius(&self, rho_ideal: f64) -> Option<f64> {
        let g = |rho: f64| rho * self.at(rho, 0.0).0;
        let rho_max = ((Self::N - 2) as f64 / self.inv_step).sqrt();
        if !rho_ideal.is_finite() || rho_ideal < 0.0 || g(rho_max) < rho_ideal {
            return None;
        }
        let (mut lo, mut hi) = (0.0f64, rho_max);
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if g(mid) < rho_ideal {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(0.5 * (lo + hi))
    }

    /// The taps of output sample (r, c).
    fn tap(&self, r: usize, c: usize) -> Tap {
        let (x, y) = (centre_offset(c, self.cols), centre_offset(r, self.rows));
        let (f, gain) = self.at(x, y);
        let (sx, sy) = (
            x * f + self.cols as f64 / 2.0 - 0.5,
            y * f + self.rows as f64 / 2.0 - 0.5,
        );
        // Far outside (beyond one sample of the image) nothing is read: the clamp keeps i32.
        let (x0, y0) = (
            sx.floor().clamp(-2.0, self.cols as f64 + 1.0),
            sy.floor().clamp(-2.0, self.rows as f64 + 1.0),
        );
        let inside =
            x0 >= 0.0 && y0 >= 0.0 && x0 + 1.0 < self.cols as f64 && y0 + 1.0 < self.rows as f64;
        Tap {
            row: y0 as i32,
            col: x0 as i32,
            fx: (sx - sx.floor()) as f32,
            fy: (sy - sy.floor()) as f32,
            gain,
            inside,
        }
    }

    /// The largest |source row - output row| over the image, rounded up, plus 2.
    fn max_row_shift(&self) -> usize {
        let half = self.rows as f64 / 2.0;
        let step = 1.0 / self.inv_step;
        let d = (0..Self::N)
            .map(|i| {
                let r = (i as f64 * step).sqrt();
                r.min(half + 1.0) * (self.scale[i] - 1.0).abs()
            })
            .fold(0.0, f64::max);
        d.ceil() as usize + 2
    }
}

/// Pixel-centre offset from the optical axis (the image centre), samples.
fn centre_offset(i: usize, n: usize) -> f64 {
    i as f64 + 0.5 - n as f64 / 2.0
}

/// Linear interpolation of `ys(xs)` at `x` (xs increasing), held at the ends.
pub(crate) fn interp(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if xs.len() == 1 || x <= xs[0] {
        return ys[0];
    }
    let n = xs.len();
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|v| *v < x);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

/// Linear interpolation that extends the end segments (for the distortion mapping past the
/// traced range).
fn interp_extend(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    let i = xs.partition_point(|v| *v < x).clamp(1, n - 1);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}
