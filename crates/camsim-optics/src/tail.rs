//! The far tail of the PSF, beyond the convolution kernel, added at low resolution.
//!
//! The kernel of [`crate::optics::Optics::compute`] holds the PSF within a square of half-width
//! h samples; the energy outside it (a fraction eps of about `psf.tail_energy`) is not dropped or
//! folded into the core (that darkens dark patches next to bright ones by ~eps x the contrast),
//! but spread with the asymptotic shape of the PSF far from its core: the diffraction by the
//! pupil's hard edge, whose intensity falls as 1/r^3 (Airy pattern: I(r) -> lambda N / (pi^3 r^3)
//! for a unit-energy PSF, the derivative of the encircled-energy asymptote 1 - 2 lambda N /
//! (pi^2 r); Born & Wolf sec. 8.5.2; an aberrated pupil with the same hard edge has the same
//! asymptote beyond its geometric blur). The amplitude comes from the measured eps of each band,
//! not from the Airy constant: T(r) = eps H / (4 sqrt 2) / r^3 outside the kernel square of
//! half-width H = h + 1/2 samples, since the integral of 1/r^3 outside a square of half-width H is
//! 8 int_0^{pi/4} cos(theta) / H dtheta = 4 sqrt(2) / H.
//!
//! The tail is smooth, so it is convolved on a grid of s x s blocks (block sums of the
//! irradiance times eps, an FFT convolution with the block-integrated tail, bilinear interpolation
//! back), which costs a few percent of the fine blur. Light the tail carries beyond the output
//! frame is lost, as it is in the camera.

use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;

use crate::wavefront::fast_fft_len;

/// The block-integrated far-tail kernel and the coarse-grid FFT plans for one geometry.
pub struct FarTail {
    /// Block side, samples.
    pub s: usize,
    /// Input rows and columns (samples).
    rows: usize,
    cols: usize,
    /// Coarse input blocks.
    rin: usize,
    cin: usize,
    /// Coarse output grid: blocks -er..rin+er (rows) and -ec..cin+ec (columns).
    er: usize,
    ec: usize,
    /// FFT sizes.
    pr: usize,
    pc: usize,
    /// Output frame and the position of input sample (0, 0) in it.
    out_rows: usize,
    out_cols: usize,
    off_r: usize,
    off_c: usize,
    /// Spectrum of the tail kernel (pr x pc, row-major), including the 1/(pr pc) of the inverse.
    spectrum: Vec<Complex32>,
    fwd_r: std::sync::Arc<dyn rustfft::Fft<f32>>,
    fwd_c: std::sync::Arc<dyn rustfft::Fft<f32>>,
    inv_r: std::sync::Arc<dyn rustfft::Fft<f32>>,
    inv_c: std::sync::Arc<dyn rustfft::Fft<f32>>,
}

/// Unit-energy tail density at (x, y) samples from the source for a kernel of half-width `h`
/// samples: zero inside the kernel's footprint (the square of half-width H = h + 1/2),
/// (H / (4 sqrt 2)) / r^3 outside.
fn tail_density(x: f64, y: f64, h: usize) -> f64 {
    let big_h = h as f64 + 0.5;
    if x.abs() < big_h && y.abs() < big_h {
        return 0.0;
    }
    let r2 = x * x + y * y;
    big_h / (4.0 * std::f64::consts::SQRT_2) / (r2 * r2.sqrt())
}

impl FarTail {
    /// The tail for a kernel of half-width `h` samples, an input of `rows x cols` samples and an
    /// output frame `out_rows x out_cols` holding input sample (0, 0) at (`off_r`, `off_c`).
    pub fn new(h: usize, rows: usize, cols: usize, out_rows: usize, out_cols: usize, off_r: usize, off_c: usize) -> FarTail {
        // Blocks: about 192 across the longer side, never wider than the kernel's half-width
        // (the tail starts there and half its energy lies within 2 H).
        let s = (rows.max(cols).div_ceil(192)).clamp(1, h.max(1));
        let (rin, cin) = (rows.div_ceil(s), cols.div_ceil(s));
        let (er, ec) = (off_r.div_ceil(s) + 1, off_c.div_ceil(s) + 1);
        let (rout, cout) = (rin + 2 * er, cin + 2 * ec);
        // Offsets between an input block and an output block span rin + rout - 1 values: an FFT of
        // at least that size convolves without wrap-around.
        let pr = fast_fft_len(rin + rout - 1);
        let pc = fast_fft_len(cin + cout - 1);
        // Block-integrated kernel: energy from a source at a block's centre into the block at
        // offset (dr, dc), summed over sample centres (m x m sub-samples of each block far out).
        let near = (h / s) as i64 + 2;
        let mut ker = vec![Complex32::new(0.0, 0.0); pr * pc];
        let (dr_max, dc_max) = ((rin + er) as i64, (cin + ec) as i64);
        for dr in -dr_max..=dr_max {
            for dc in -dc_max..=dc_max {
                let full = dr.abs() <= near && dc.abs() <= near;
                let m = if full { s } else { s.min(4) };
                let w = (s * s) as f64 / (m * m) as f64;
                let mut e = 0.0;
                for u in 0..m {
                    for v in 0..m {
                        let y = (dr * s as i64) as f64 + ((u as f64 + 0.5) * s as f64 / m as f64 - 0.5 * s as f64);
                        let x = (dc * s as i64) as f64 + ((v as f64 + 0.5) * s as f64 / m as f64 - 0.5 * s as f64);
                        e += tail_density(x, y, h);
                    }
                }
                let (i, j) = (dr.rem_euclid(pr as i64) as usize, dc.rem_euclid(pc as i64) as usize);
                ker[i * pc + j] = Complex32::new((e * w) as f32, 0.0);
            }
        }
        let mut planner = FftPlanner::<f32>::new();
        let (fwd_r, fwd_c) = (planner.plan_fft_forward(pc), planner.plan_fft_forward(pr));
        let (inv_r, inv_c) = (planner.plan_fft_inverse(pc), planner.plan_fft_inverse(pr));
        let mut t = FarTail {
            s,
            rows,
            cols,
            rin,
            cin,
            er,
            ec,
            pr,
            pc,
            out_rows,
            out_cols,
            off_r,
            off_c,
            spectrum: Vec::new(),
            fwd_r,
            fwd_c,
            inv_r,
            inv_c,
        };
        t.fft2(&mut ker, true);
        let scale = 1.0 / (pr * pc) as f32;
        ker.iter_mut().for_each(|c| *c *= scale);
        t.spectrum = ker;
        t
    }

    /// In-place 2D FFT of a pr x pc row-major array.
    fn fft2(&self, a: &mut [Complex32], forward: bool) {
        let (pr, pc) = (self.pr, self.pc);
        let (fr, fc) = if forward { (&self.fwd_r, &self.fwd_c) } else { (&self.inv_r, &self.inv_c) };
        for row in a.chunks_exact_mut(pc) {
            fr.process(row);
        }
        let mut col = vec![Complex32::new(0.0, 0.0); pr];
        for c in 0..pc {
            for r in 0..pr {
                col[r] = a[r * pc + c];
            }
            fc.process(&mut col);
            for r in 0..pr {
                a[r * pc + c] = col[r];
            }
        }
    }

    /// Add the far tail of up to two bands to their output planes. `load(k, r, dst)` writes row
    /// `r` of band k's tail source (irradiance x eps of its PSF, input geometry) into `dst`
    /// (`cols` long); `outs[k]` is band k's output plane.
    pub fn add(&self, outs: &mut [&mut [f32]], mut load: impl FnMut(usize, usize, &mut [f32])) {
        let (s, pc) = (self.s, self.pc);
        let mut a = vec![Complex32::new(0.0, 0.0); self.pr * pc];
        let mut row = vec![0.0f32; self.cols];
        for k in 0..outs.len().min(2) {
            for r in 0..self.rows {
                load(k, r, &mut row);
                let line = &mut a[(r / s) * pc..(r / s) * pc + self.cin];
                for (j, chunk) in row.chunks(s).enumerate() {
                    let v: f32 = chunk.iter().sum();
                    if k == 0 {
                        line[j].re += v;
                    } else {
                        line[j].im += v;
                    }
                }
            }
        }
        self.fft2(&mut a, true);
        a.iter_mut().zip(&self.spectrum).for_each(|(x, k)| *x *= *k);
        self.fft2(&mut a, false);
        // Coarse output block I (from -er) sits at index I mod pr; its centre is at input sample
        // I s + (s - 1) / 2. Bilinear interpolation of block energy / s^2 at each output sample.
        let (rout, cout) = (self.rin + 2 * self.er, self.cin + 2 * self.ec);
        let at = |i: usize, j: usize| {
            let (ii, jj) = ((i as i64 - self.er as i64).rem_euclid(self.pr as i64) as usize, (j as i64 - self.ec as i64).rem_euclid(pc as i64) as usize);
            a[ii * pc + jj]
        };
        let coord = |p: usize, off: usize, e: usize, n: usize| {
            // Position in coarse-output-grid units (block 0 of the output grid = input block -e).
            let u = ((p as f64 - off as f64) - (s as f64 - 1.0) / 2.0) / s as f64 + e as f64;
            let u = u.clamp(0.0, (n - 1) as f64);
            let i0 = (u.floor() as usize).min(n.saturating_sub(2));
            (i0, (u - i0 as f64) as f32)
        };
        let xs: Vec<(usize, f32)> = (0..self.out_cols).map(|c| coord(c, self.off_c, self.ec, cout)).collect();
        let norm = 1.0 / (s * s) as f32;
        let mut line = vec![Complex32::new(0.0, 0.0); cout];
        for r in 0..self.out_rows {
            let (i0, fy) = coord(r, self.off_r, self.er, rout);
            let i1 = (i0 + 1).min(rout - 1);
            for (j, l) in line.iter_mut().enumerate() {
                *l = (at(i0, j) * (1.0 - fy) + at(i1, j) * fy) * norm;
            }
            for (k, out) in outs.iter_mut().enumerate().take(2) {
                let orow = &mut out[r * self.out_cols..(r + 1) * self.out_cols];
                for (o, &(j0, fx)) in orow.iter_mut().zip(&xs) {
                    let j1 = (j0 + 1).min(cout - 1);
                    let v = line[j0] * (1.0 - fx) + line[j1] * fx;
                    *o += if k == 0 { v.re } else { v.im };
                }
            }
        }
    }
}
