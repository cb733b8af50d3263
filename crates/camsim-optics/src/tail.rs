//! The diffraction far tail beyond a trimmed PSF kernel, added on a coarse grid.
//!
//! A kernel of side k = 2h + 1 samples leaves the PSF energy beyond its window out. Around an
//! aperture's PSF that far field is the edge-diffraction tail, whose ring average is
//! I(r) = lambda N / (pi^3 r^3) per unit area and unit total energy (the asymptote of the Airy
//! pattern, Born & Wolf, *Principles of Optics*, sec. 8.5.2: [2 J1(v)/v]^2 with J1(v)^2 averaged to
//! 1 / (pi v), v = pi r / (lambda N)); it integrates to the energy 2 lambda N / (pi^2 r) outside
//! radius r that [`crate::Wavefront::kernel_size`] uses. Dark patches next to bright ones get
//! that light from far away (ISETCam's whole-image OTF keeps it; a trimmed, renormalized kernel
//! moves it onto the bright patch itself).
//!
//! [`FarTail`] adds it: the kernel carries 1 - e of the energy, e the tail outside its square
//! window, and the rest is the tail convolved with the image on a grid of D x D blocks (D odd),
//! whose result is interpolated back (bilinear between block centres). Per fine sample
//! T(dx, dy) = a / rho^3, rho = |(dx, dy)| in samples, a = lambda N / (pi^3 spacing), zero inside
//! the window; on the coarse grid each block offset holds the mean of T over its D x D fine offsets.
//! Its shape does not depend on the wavelength (only `a` does), so one kernel spectrum serves
//! every band.

use crate::conv::Fft2;
use crate::wavefront::fast_fft_len;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// Coarse grids are at most this many blocks on a side (the FFT plane twice that).
const COARSE_TARGET: usize = 256;
/// ... and at most this many when the kernel window is small (the block must not exceed it).
const COARSE_MAX: usize = 1024;

/// Tail amplitude `a` of T = a / rho^3 per sample at `spacing_m` for lambda and the working
/// f-number N (see the module comment).
pub fn tail_amplitude(wavelength_nm: f64, working_f_number: f64, spacing_m: f64) -> f64 {
    wavelength_nm * 1e-9 * working_f_number / (PI.powi(3) * spacing_m)
}

/// Energy of T = a / rho^3 outside the square |x|, |y| <= s (s in samples, to the window's outer
/// edges): 8 x the integral over theta in [0, pi/4] of a cos(theta) / s = 4 sqrt(2) a / s.
pub fn energy_outside_square(a: f64, s: f64) -> f64 {
    4.0 * std::f64::consts::SQRT_2 * a / s
}

/// The far-tail convolution for one output size and kernel window.
pub struct FarTail {
    /// Block side, fine samples (odd).
    pub block: usize,
    /// Half-width of the kernel window, samples (the window is 2h + 1 wide).
    pub half_width: usize,
    /// The coarse kernel for a = 1.
    kernel: CoarseKernel,
}

/// A radially symmetric kernel on a grid of D x D blocks (D odd) for one output size: the
/// convolution of an image's block sums with the kernel's block means by FFT, interpolated back
/// bilinearly between block centres (the far diffraction tail here, the veiling-glare spread
/// function of [`crate::glare`]).
pub(crate) struct CoarseKernel {
    block: usize,
    out_rows: usize,
    out_cols: usize,
    coarse_rows: usize,
    coarse_cols: usize,
    fft: Fft2,
    fft_rows: usize,
    fft_cols: usize,
    spectrum: Vec<Complex64>,
}

impl CoarseKernel {
    /// Plans the kernel for `out_rows` x `out_cols` outputs with blocks of `block` samples;
    /// `block_mean(br, bc)` is the kernel's mean over the block at block offset (br, bc) >= 0
    /// (one quadrant; the kernel is mirrored into the others).
    pub(crate) fn new(
        out_rows: usize,
        out_cols: usize,
        block: usize,
        block_mean: impl Fn(i64, i64) -> f64 + Sync,
    ) -> CoarseKernel {
        let (coarse_rows, coarse_cols) = (out_rows.div_ceil(block), out_cols.div_ceil(block));
        // A linear convolution of the coarse output with offsets up to +-(n - 1): period >= 2n - 1.
        let (fft_rows, fft_cols) = (fast_fft_len(2 * coarse_rows), fast_fft_len(2 * coarse_cols));
        let fft = Fft2::new(fft_rows, fft_cols);
        let quadrant: Vec<f64> = (0..coarse_rows * coarse_cols)
            .into_par_iter()
            .map(|i| block_mean((i / coarse_cols) as i64, (i % coarse_cols) as i64))
            .collect();
        let mut plane = vec![0.0f64; fft_rows * fft_cols];
        for br in 0..coarse_rows {
            for bc in 0..coarse_cols {
                let v = quadrant[br * coarse_cols + bc];
                for r in [br, (fft_rows - br) % fft_rows] {
                    for c in [bc, (fft_cols - bc) % fft_cols] {
                        plane[r * fft_cols + c] = v;
                    }
                }
            }
        }
        let spectrum = fft.forward(&plane);
        CoarseKernel {
            block,
            out_rows,
            out_cols,
            coarse_rows,
            coarse_cols,
            fft,
            fft_rows,
            fft_cols,
            spectrum,
        }
    }

    /// The FFT plane's size in bytes (for the memory check before planning).
    pub(crate) fn plane_bytes(out_rows: usize, out_cols: usize, block: usize) -> u64 {
        let n =
            fast_fft_len(2 * out_rows.div_ceil(block)) * fast_fft_len(2 * out_cols.div_ceil(block));
        n as u64 * 40
    }

    /// Writes the kernel times `gain` convolved with the source into `out_band` (`out_rows` x
    /// `out_cols`, overwritten): the source is `rows` x `cols` samples placed at (`pad_r`,
    /// `pad_c`) of the output, scaled by `scale` and, where given, by `shade` (per source
    /// sample).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn convolve(
        &self,
        src: &[f32],
        rows: usize,
        cols: usize,
        (pad_r, pad_c): (usize, usize),
        scale: f32,
        shade: Option<&[f32]>,
        gain: f64,
        out_band: &mut [f32],
    ) {
        let d = self.block;
        let (fr, fc) = (self.fft_rows, self.fft_cols);
        let mut plane = vec![0.0f64; fr * fc];
        // Block sums: per source row into a row of block accumulators (f32 over at most `block`
        // samples each; contiguous runs of columns per block, so the sums vectorize), then into the
        // plane.
        let runs: Vec<(usize, std::ops::Range<usize>)> = (0..self.coarse_cols)
            .filter_map(|bc| {
                let lo = (bc * d).saturating_sub(pad_c).min(cols);
                let hi = ((bc + 1) * d).saturating_sub(pad_c).min(cols);
                (lo < hi).then_some((bc, lo..hi))
            })
            .collect();
        let mut acc = vec![0.0f32; self.coarse_cols];
        for r in 0..rows {
            let row = &src[r * cols..(r + 1) * cols];
            match shade {
                None => runs
                    .iter()
                    .for_each(|(bc, cs)| acc[*bc] += row[cs.clone()].iter().sum::<f32>()),
                Some(sh) => {
                    let w = &sh[r * cols..(r + 1) * cols];
                    runs.iter().for_each(|(bc, cs)| {
                        acc[*bc] += row[cs.clone()]
                            .iter()
                            .zip(&w[cs.clone()])
                            .map(|(v, w)| v * w)
                            .sum::<f32>()
                    })
                }
            }
            if (r + pad_r + 1) % d == 0 || r + 1 == rows {
                let br = (r + pad_r) / d;
                plane[br * fc..br * fc + self.coarse_cols]
                    .iter_mut()
                    .zip(&acc)
                    .for_each(|(p, v)| *p += *v as f64 * scale as f64);
                acc.fill(0.0);
            }
        }
        let mut spec = self.fft.forward(&plane);
        spec.iter_mut()
            .zip(&self.spectrum)
            .for_each(|(s, k)| *s *= *k * gain);
        let coarse = self.fft.inverse(spec);
        // Bilinear interpolation between block centres (fine coordinate i d + (d - 1) / 2), held
        // beyond the outer centres: per output row the coarse row interpolated in y, then in x.
        let centre = (d as f64 - 1.0) / 2.0;
        let locate = |x: usize, n: usize| -> (usize, usize, f64) {
            let t = ((x as f64 - centre) / d as f64).clamp(0.0, (n - 1) as f64);
            let i0 = (t.floor() as usize).min(n - 1);
            let i1 = (i0 + 1).min(n - 1);
            (i0, i1, t - i0 as f64)
        };
        // Output columns in runs between neighbouring block centres (c0, c1), with their weights.
        let fx: Vec<f32> = (0..self.out_cols)
            .map(|c| locate(c, self.coarse_cols).2 as f32)
            .collect();
        let mut col_runs: Vec<(usize, usize, std::ops::Range<usize>)> = Vec::new();
        for c in 0..self.out_cols {
            let (c0, c1, _) = locate(c, self.coarse_cols);
            match col_runs.last_mut() {
                Some((a, b, range)) if *a == c0 && *b == c1 => range.end = c + 1,
                _ => col_runs.push((c0, c1, c..c + 1)),
            }
        }
        let mut line = vec![0.0f32; self.coarse_cols];
        for (r, orow) in out_band
            .chunks_exact_mut(self.out_cols)
            .enumerate()
            .take(self.out_rows)
        {
            let (r0, r1, fy) = locate(r, self.coarse_rows);
            let (a0, a1) = (
                &coarse[r0 * fc..r0 * fc + self.coarse_cols],
                &coarse[r1 * fc..r1 * fc + self.coarse_cols],
            );
            // Round-off of the coarse FFT may leave tiny negatives where no light is.
            line.iter_mut()
                .zip(a0.iter().zip(a1))
                .for_each(|(l, (u, v))| *l = (u + (v - u) * fy).max(0.0) as f32);
            for (c0, c1, range) in &col_runs {
                let (u, dv) = (line[*c0], line[*c1] - line[*c0]);
                orow[range.clone()]
                    .iter_mut()
                    .zip(&fx[range.clone()])
                    .for_each(|(o, w)| *o = u + dv * w);
            }
        }
    }
}

fn odd_at_least(x: usize) -> usize {
    x.max(1) | 1
}

impl FarTail {
    /// Plans the tail for a `out_rows` x `out_cols` output blurred with a window of half-width `h`.
    pub fn new(out_rows: usize, out_cols: usize, h: usize) -> FarTail {
        let side = out_rows.max(out_cols);
        let mut block = odd_at_least(side.div_ceil(COARSE_TARGET));
        if block > h.max(1) {
            // Keep the block within the window where the grid stays affordable.
            let largest_odd_in_window = if h % 2 == 1 {
                h
            } else {
                h.saturating_sub(1).max(1)
            };
            block = largest_odd_in_window.max(odd_at_least(side.div_ceil(COARSE_MAX)));
        }
        // Block means of T (a = 1) over the fine offsets outside the window.
        let d = block as i64;
        let hw = h as i64;
        let half = (d - 1) / 2;
        let kernel = CoarseKernel::new(out_rows, out_cols, block, |br, bc| {
            let mut s = 0.0;
            for u in -half..=half {
                let dy = br * d + u;
                for w in -half..=half {
                    let dx = bc * d + w;
                    if dy.abs() <= hw && dx.abs() <= hw {
                        continue;
                    }
                    let rho2 = (dx * dx + dy * dy) as f64;
                    s += 1.0 / (rho2 * rho2.sqrt());
                }
            }
            s / (d * d) as f64
        });
        FarTail {
            block,
            half_width: h,
            kernel,
        }
    }

    /// Fraction of the PSF energy the tail carries (outside the window) for amplitude `a`.
    pub fn energy(&self, a: f64) -> f64 {
        energy_outside_square(a, self.half_width as f64 + 0.5)
    }

    /// Writes the tail of one band into `out_band` (`out_rows` x `out_cols`, overwritten): the
    /// source is `rows` x `cols` samples placed at (`pad_r`, `pad_c`) of the output, scaled by
    /// `scale` and, where given, by `shade` (per source sample); `a` is the band's tail amplitude.
    #[allow(clippy::too_many_arguments)]
    pub fn write_band(
        &self,
        src: &[f32],
        rows: usize,
        cols: usize,
        (pad_r, pad_c): (usize, usize),
        scale: f32,
        shade: Option<&[f32]>,
        a: f64,
        out_band: &mut [f32],
    ) {
        self.kernel
            .convolve(src, rows, cols, (pad_r, pad_c), scale, shade, a, out_band);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The discrete tail (block means of a / rho^3 outside the window) holds the closed-form energy
    /// 4 sqrt(2) a / s, up to what leaves a finite grid (2 pi a / R beyond radius R).
    #[test]
    fn discrete_tail_holds_the_closed_form_energy() {
        for (h, n) in [(10usize, 600usize), (35, 2000), (3, 400)] {
            let t = FarTail::new(n, n, h);
            // The coarse kernel's sum is its spectrum at DC (all offsets, weighted by D^2 fine
            // samples per block).
            let sum = t.kernel.spectrum[0].re * (t.block * t.block) as f64;
            let reach = ((t.kernel.coarse_rows - 1) * t.block) as f64;
            let want = energy_outside_square(1.0, h as f64 + 0.5) - 2.0 * PI / reach;
            assert!(
                (sum / want - 1.0).abs() < 0.02,
                "h {h}, block {}: sum {sum} vs {want}",
                t.block
            );
        }
    }

    /// A uniform field far from its edges receives the tail energy the window leaves out (a
    /// conservation check of the coarse convolution and the interpolation), and nothing is
    /// negative.
    #[test]
    fn uniform_field_receives_the_tail_energy_in_its_middle() {
        let (rows, cols, h) = (900usize, 1200usize, 12usize);
        let t = FarTail::new(rows, cols, h);
        assert!(t.block > 1 && t.block <= h, "block {}", t.block);
        let src = vec![1.0f32; rows * cols];
        let mut out = vec![7.0f32; rows * cols];
        let a = 0.02;
        t.write_band(&src, rows, cols, (0, 0), 1.0, None, a, &mut out);
        assert!(out.iter().all(|v| *v >= 0.0));
        // At the centre the tail from a field of half-size R is the full tail less 2 pi a / R
        // (roughly: the field is a rectangle, so bound it between its inscribed and circumscribed
        // circles).
        let mid = out[(rows / 2) * cols + cols / 2] as f64;
        let full = energy_outside_square(a, h as f64 + 0.5);
        let (r_in, r_out) = (
            rows as f64 / 2.0,
            ((rows * rows + cols * cols) as f64).sqrt() / 2.0,
        );
        let (lo, hi) = (full - 2.0 * PI * a / r_in, full - 2.0 * PI * a / r_out);
        assert!(
            mid > lo * 0.99 && mid < hi * 1.01,
            "centre {mid} outside [{lo}, {hi}]"
        );
        // A corner gets about a quarter of it.
        let corner = out[0] as f64;
        assert!(
            corner > 0.2 * lo && corner < 0.3 * hi,
            "corner {corner}, full {full}"
        );
    }
}
