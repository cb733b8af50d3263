//! The block layout of the shift-variant blur ([`crate::shift_variant`]): the image cut into
//! blocks of one FFT tile, each with its field height and azimuth; mirror-image blocks that share
//! a kernel spectrum ([`flip_spectrum`]); and a block's kernel, the two neighbouring field PSFs
//! mixed in field height and rotated to the block's azimuth ([`block_kernel`]).

use crate::conv::KernelSpectrum;
use crate::wavefront::Wavefront;

/// A block whose kernel is built and the mirror blocks (flip in x, flip in y) that reuse its
/// spectrum.
pub(crate) type BlockGroup = (Block, Vec<(Block, bool, bool)>);

/// One block of the shift-variant blur: its rows and columns, field-height index and weight, azimuth.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Block {
    pub(crate) r0: usize,
    pub(crate) c0: usize,
    pub(crate) nr: usize,
    pub(crate) nc: usize,
    pub(crate) i: usize,
    pub(crate) tt: f32,
    pub(crate) cphi: f64,
    pub(crate) sphi: f64,
}

/// Spans (start, length, index of the mirror span) of side `t` from 0.
pub(crate) fn plain_spans(n: usize, t: usize) -> Vec<(usize, usize, usize)> {
    (0..n.div_ceil(t))
        .map(|j| (j * t, t.min(n - j * t), j))
        .collect()
}

/// Spans of side <= `t` laid out symmetrically about n / 2 (mirror of [a, b) is [n - b, n - a)),
/// with the index of each span's mirror: for odd n a centre span of odd length, then spans of `t`
/// outward, cut at the ends.
pub(crate) fn symmetric_spans(n: usize, t: usize) -> Vec<(usize, usize, usize)> {
    let (centre, mut lo) = if n.is_multiple_of(2) {
        (None, n / 2)
    } else {
        let tc = (if t % 2 == 1 { t } else { t - 1 }).min(n);
        let a = (n - tc) / 2;
        (Some((a, tc)), a + tc)
    };
    let mut upper = Vec::new();
    while lo < n {
        let len = t.min(n - lo);
        upper.push((lo, len));
        lo += len;
    }
    let mut v: Vec<(usize, usize)> = upper.iter().rev().map(|(a, l)| (n - a - l, *l)).collect();
    v.extend(centre);
    v.extend(upper);
    let m = v.len();
    v.into_iter()
        .enumerate()
        .map(|(j, (a, l))| (a, l, m - 1 - j))
        .collect()
}

/// Whether a wavefront is mirror-symmetric about its local x axis (the meridian): no Zernike
/// term odd in y (OSA m < 0) above round-off.
pub(crate) fn meridional(w: &Wavefront) -> bool {
    let c = w.zernike_um();
    let big = c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    c.iter()
        .enumerate()
        .all(|(j, v)| crate::zernike::osa_to_nm(j).1 >= 0 || v.abs() <= 1e-9 * big.max(1e-12))
}

/// The spectrum (layout of [`TileConvolver::kernel_spectrum_in`]: column frequency v major, row
/// frequency u minor, v = 0..F/2) of the kernel mirrored in x (`fx`: k(y, K-1-x)) and/or in y
/// (`fy`: k(K-1-y, x)), from the spectrum S of k: by the DFT shift and reversal theorems and the
/// Hermitian symmetry of a real kernel, S(u, -v) = conj S(-u, v):
/// x: exp(-2 pi i v (K-1) / F) conj S(-u, v); y: exp(-2 pi i u (K-1) / F) S(-u, v);
/// both: exp(-2 pi i (u + v) (K-1) / F) conj S(u, v). `phase[u]` = exp(-2 pi i u (K-1) / F).
pub(crate) fn flip_spectrum(
    src: &KernelSpectrum,
    dst: &mut KernelSpectrum,
    f: usize,
    phase: &[rustfft::num_complex::Complex32],
    fx: bool,
    fy: bool,
) {
    dst.0.resize(src.0.len(), Default::default());
    for (v, (col_s, col_d)) in src
        .0
        .chunks_exact(f)
        .zip(dst.0.chunks_exact_mut(f))
        .enumerate()
    {
        for (u, d) in col_d.iter_mut().enumerate() {
            let neg = (f - u) % f;
            *d = match (fx, fy) {
                (true, false) => phase[v] * col_s[neg].conj(),
                (false, true) => phase[u] * col_s[neg],
                (true, true) => phase[u] * phase[v] * col_s[u].conj(),
                (false, false) => col_s[u],
            };
        }
    }
}

/// The blocks of a `rows` x `cols` image cut into tiles of side `t` (laid out symmetrically about
/// the axis when `mirrored`), each with its field height (a fractional index into `n_h` heights
/// from 0 to `half_diag_m`) and azimuth; grouped with the mirror blocks that reuse its spectrum.
pub(crate) fn block_groups(
    rows: usize,
    cols: usize,
    t: usize,
    mirrored: bool,
    n_h: usize,
    half_diag_m: f64,
    spacing_m: f64,
) -> Vec<BlockGroup> {
    let (spans_r, spans_c) = if mirrored {
        (symmetric_spans(rows, t), symmetric_spans(cols, t))
    } else {
        (plain_spans(rows, t), plain_spans(cols, t))
    };
    // Each block's field height (as a fractional index into the heights) and azimuth.
    let dh = half_diag_m / (n_h - 1) as f64;
    let block = |a: usize, bc: usize| -> Block {
        let ((r0, nr, _), (c0, nc, _)) = (spans_r[a], spans_c[bc]);
        let y = (r0 as f64 + nr as f64 / 2.0 - rows as f64 / 2.0) * spacing_m;
        let x = (c0 as f64 + nc as f64 / 2.0 - cols as f64 / 2.0) * spacing_m;
        let u = (x.hypot(y) / dh).min((n_h - 1) as f64);
        let i = (u.floor() as usize).min(n_h - 2);
        let phi = y.atan2(x);
        Block {
            r0,
            c0,
            nr,
            nc,
            i,
            tt: (u - i as f64) as f32,
            cphi: phi.cos(),
            sphi: phi.sin(),
        }
    };
    // Groups: a block whose kernel is built, and the mirror blocks (flip x, flip y) that reuse
    // its spectrum.
    let mut groups: Vec<BlockGroup> = Vec::new();
    for (a, &(_, _, ma)) in spans_r.iter().enumerate() {
        for (bc, &(_, _, mb)) in spans_c.iter().enumerate() {
            if !mirrored {
                groups.push((block(a, bc), Vec::new()));
                continue;
            }
            // The representative lies at or past the axis in both directions.
            if ma < a || mb < bc {
                continue;
            }
            let mut m = Vec::new();
            if mb != bc {
                m.push((block(a, mb), true, false));
            }
            if ma != a {
                m.push((block(ma, bc), false, true));
            }
            if ma != a && mb != bc {
                m.push((block(ma, mb), true, true));
            }
            groups.push((block(a, bc), m));
        }
    }
    groups
}

/// Phase factors of the flips ([`flip_spectrum`]): exp(-2 pi i u (K - 1) / F) for u = 0..F.
pub(crate) fn flip_phases(k: usize, f: usize) -> Vec<rustfft::num_complex::Complex32> {
    (0..f)
        .map(|u| {
            let a = -2.0 * std::f64::consts::PI * (u * (k - 1)) as f64 / f as f64;
            rustfft::num_complex::Complex32::new(a.cos() as f32, a.sin() as f32)
        })
        .collect()
}

/// Block `rep`'s `k` x `k` kernel into `kernel`: the field PSFs of heights `rep.i` and `rep.i + 1`
/// mixed linearly; for `s` > 1 (PSFs `s` times finer) rotated to the block's azimuth, each fine
/// sample binned into the image cell its rotated position falls in, and renormalized to unit
/// sum. `Err(sum)` when the kernel holds no energy.
pub(crate) fn block_kernel(
    psfs: &[Vec<f32>],
    rep: &Block,
    k: usize,
    s: usize,
    kernel: &mut [f32],
) -> std::result::Result<(), f32> {
    let Block {
        i, tt, cphi, sphi, ..
    } = *rep;
    let (a, bb) = (&psfs[i], &psfs[i + 1]);
    if s == 1 {
        kernel
            .iter_mut()
            .zip(a.iter().zip(bb))
            .for_each(|(kv, (x, y))| *kv = x + tt * (y - x));
    } else {
        let ks = k * s;
        let hf = (ks / 2) as f32;
        let hk = (k / 2) as f32;
        let inv_s = 1.0 / s as f32;
        kernel.iter_mut().for_each(|v| *v = 0.0);
        let (cp, sp) = (cphi as f32, sphi as f32);
        let kf = k as f32;
        for r in 0..ks {
            let yf = (r as f32 - hf) * inv_s;
            let (row_a, row_b) = (&a[r * ks..(r + 1) * ks], &bb[r * ks..(r + 1) * ks]);
            // Rotate the local (radial x, tangential y) offset to azimuth phi. Runs of fine
            // samples that land in one image cell (about s in a row) are summed in a register and
            // stored once (no store-to-load chain through the cell).
            let (bx, by) = (hk + 0.5 - yf * sp, hk + 0.5 + yf * cp);
            let (mut cell, mut run) = (usize::MAX, 0.0f32);
            for c in 0..ks {
                let v = row_a[c] + tt * (row_b[c] - row_a[c]);
                let xf = (c as f32 - hf) * inv_s;
                let xr = xf * cp + bx;
                let yr = xf * sp + by;
                let idx = if xr >= 0.0 && yr >= 0.0 && xr < kf && yr < kf {
                    yr as usize * k + xr as usize
                } else {
                    usize::MAX
                };
                if idx != cell {
                    if cell != usize::MAX {
                        kernel[cell] += run;
                    }
                    (cell, run) = (idx, 0.0);
                }
                run += v;
            }
            if cell != usize::MAX {
                kernel[cell] += run;
            }
        }
    }
    let sum: f32 = kernel.iter().sum();
    if sum.is_nan() || sum <= 0.0 {
        return Err(sum);
    }
    if s > 1 {
        kernel.iter_mut().for_each(|v| *v /= sum);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conv::TileConvolver;

    /// The flipped spectra equal the spectra of the flipped kernels (an asymmetric kernel, all
    /// three flips), and the symmetric spans mirror each other and tile the axis.
    #[test]
    fn flipped_spectrum_is_the_spectrum_of_the_flipped_kernel() {
        let (k, f) = (7usize, 32usize);
        let conv = TileConvolver::with_tile(k, f);
        let kern: Vec<f32> = (0..k * k)
            .map(|i| ((i * 37 % 11) as f32 + 0.3 * (i / k) as f32) / 50.0)
            .collect();
        let phase: Vec<rustfft::num_complex::Complex32> = (0..f)
            .map(|u| {
                let a = -2.0 * std::f64::consts::PI * (u * (k - 1)) as f64 / f as f64;
                rustfft::num_complex::Complex32::new(a.cos() as f32, a.sin() as f32)
            })
            .collect();
        let spec = conv.kernel_spectrum(&kern);
        for (fx, fy) in [(true, false), (false, true), (true, true)] {
            let flipped: Vec<f32> = (0..k * k)
                .map(|i| {
                    let (r, c) = (i / k, i % k);
                    let (r, c) = (
                        if fy { k - 1 - r } else { r },
                        if fx { k - 1 - c } else { c },
                    );
                    kern[r * k + c]
                })
                .collect();
            let want = conv.kernel_spectrum(&flipped);
            let mut got = KernelSpectrum(Vec::new());
            flip_spectrum(&spec, &mut got, f, &phase, fx, fy);
            let err = got
                .0
                .iter()
                .zip(&want.0)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0f32, f32::max);
            assert!(err < 1e-6, "flip ({fx}, {fy}): {err}");
        }
        for (n, t) in [(3024usize, 414usize), (301, 60), (7, 4), (5, 9)] {
            let sp = symmetric_spans(n, t);
            assert_eq!(sp.iter().map(|s| s.1).sum::<usize>(), n);
            assert!(sp.windows(2).all(|w| w[0].0 + w[0].1 == w[1].0) && sp[0].0 == 0);
            for (j, &(a, l, m)) in sp.iter().enumerate() {
                assert!(l <= t);
                assert_eq!((sp[m].0, sp[m].1, sp[m].2), (n - a - l, l, j));
            }
        }
    }
}
