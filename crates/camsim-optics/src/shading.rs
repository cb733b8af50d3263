//! Lens shading (relative illumination): cos^4 falloff, a relative-illumination table, and a
//! low-order 2D polynomial fitted to a flat-field raw capture.

use crate::error::{OpticsError, Result};
use camsim_core::{CfaChannel, RawImage};
use serde::{Deserialize, Serialize};

/// Exponents (i, j) of the monomials x^i y^j with i + j <= order, in a fixed order
/// (by total degree, then decreasing i).
pub fn monomials(order: usize) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    for d in 0..=order {
        for i in (0..=d).rev() {
            v.push((i, d - i));
        }
    }
    v
}

/// A fitted flat-field shading: for each CFA colour (R, G, B) a polynomial
/// `sum_k c_k x^i_k y^j_k` in normalized image coordinates x = (col + 0.5) / cols * 2 - 1,
/// y = (row + 0.5) / rows * 2 - 1 (both in [-1, 1], centre 0), normalized so its maximum over the
/// image is 1 (relative illumination).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadingFit {
    /// Polynomial order (total degree).
    pub order: usize,
    /// Rows of the flat field that was fitted (for reference).
    pub rows: usize,
    /// Columns of the flat field that was fitted.
    pub cols: usize,
    /// Coefficients for red, in the order of [`monomials`].
    pub red: Vec<f64>,
    /// Coefficients for green (both green sites).
    pub green: Vec<f64>,
    /// Coefficients for blue.
    pub blue: Vec<f64>,
    /// RMS of (data - fit) / fit over all pixels, percent (includes the capture's noise).
    pub rms_residual_percent: f64,
    /// The capture's pixel noise, RMS percent of the fit, estimated from differences of
    /// neighbouring same-colour pixels (sqrt(<(v1 - v2)^2> / 2)); the part of the residual above
    /// it is what the polynomial failed to explain. 0 in files written before it was recorded.
    #[serde(default)]
    pub noise_percent: f64,
}

/// Largest residual (percent) the shading may leave beyond the pixel noise: a smooth lens
/// falloff (cos^4, vignetting) is fitted by an order-4 polynomial to a few 0.1 % (see the
/// crate's shading tests), and integrating spheres are uniform to about 1 %; a scene that is not
/// a flat field (a chart) leaves tens to thousands of percent.
pub const MAX_EXCESS_RESIDUAL_PERCENT: f64 = 3.0;
/// Smallest relative illumination accepted anywhere in the image: even a wide phone lens keeps
/// cos^4(40 deg) = 0.34 at the corner; a fit going below 0.05 (or negative) is not a lens shading.
pub const MIN_RELATIVE_ILLUMINATION: f64 = 0.05;
/// Largest rise (fraction of the maximum) of the fitted shading along a ray going out from its
/// maximum: lens falloff is monotonic; the noise of an order-4 fit of a flat field wiggles by
/// < 0.3 %.
pub const MAX_OUTWARD_RISE: f64 = 0.02;

/// Which fitted channel the spectral optics applies (see `ShadingModel`).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum ShadingChannel {
    /// The mean of the R, G and B polynomials (default).
    #[default]
    Mean,
    /// Red.
    R,
    /// Green.
    G,
    /// Blue.
    B,
}

/// For a fixed y, the coefficients of the polynomial in x: `cx[i] = sum_j c_ij y^j` (so a row of
/// an image costs O(order) per pixel, no allocation per pixel).
pub fn row_coefficients(coef: &[f64], order: usize, y: f64) -> Vec<f64> {
    let mut cx = vec![0.0; order + 1];
    for (c, (i, j)) in coef.iter().zip(monomials(order)) {
        cx[i] += c * y.powi(j as i32);
    }
    cx
}

/// Evaluate `sum cx[i] x^i` (Horner).
#[inline]
pub fn horner(cx: &[f64], x: f64) -> f64 {
    cx.iter().rev().fold(0.0, |acc, c| acc * x + c)
}

fn poly_eval(coef: &[f64], order: usize, x: f64, y: f64) -> f64 {
    horner(&row_coefficients(coef, order, y), x)
}

impl ShadingFit {
    /// Coefficients of a channel.
    pub fn coefficients(&self, ch: CfaChannel) -> &[f64] {
        match ch {
            CfaChannel::R => &self.red,
            CfaChannel::G => &self.green,
            CfaChannel::B => &self.blue,
        }
    }

    /// Relative illumination of channel `ch` at normalized coordinates (x, y) in [-1, 1].
    pub fn eval(&self, ch: CfaChannel, x: f64, y: f64) -> f64 {
        poly_eval(self.coefficients(ch), self.order, x, y)
    }

    /// The value the spectral optics applies: one channel, or the mean of the three.
    pub fn eval_for(&self, which: ShadingChannel, x: f64, y: f64) -> f64 {
        match which {
            ShadingChannel::Mean => {
                (self.eval(CfaChannel::R, x, y)
                    + self.eval(CfaChannel::G, x, y)
                    + self.eval(CfaChannel::B, x, y))
                    / 3.0
            }
            ShadingChannel::R => self.eval(CfaChannel::R, x, y),
            ShadingChannel::G => self.eval(CfaChannel::G, x, y),
            ShadingChannel::B => self.eval(CfaChannel::B, x, y),
        }
    }

    /// TOML text of the fit (the shading file `camsim fit-shading` writes).
    pub fn to_toml(&self) -> String {
        let mut s = String::from(
            "# camsim lens shading fit: relative illumination per CFA colour as a 2D polynomial\n\
             # sum c_k x^i y^j (i + j <= order) in normalized coordinates x, y in [-1, 1] (image centre 0),\n\
             # normalized to 1 at its maximum. Coefficient order: by total degree, then decreasing power of x.\n",
        );
        s.push_str(&toml::to_string(self).unwrap_or_default());
        s
    }

    /// Read a shading file; `what` names it in errors.
    pub fn from_toml(text: &str, what: &str) -> Result<Self> {
        let fit: ShadingFit = toml::from_str(text).map_err(|e| OpticsError::Parse {
            what: what.to_string(),
            message: e.to_string(),
        })?;
        let n = monomials(fit.order).len();
        for (name, c) in [
            ("red", &fit.red),
            ("green", &fit.green),
            ("blue", &fit.blue),
        ] {
            if c.len() != n {
                return Err(OpticsError::Parse {
                    what: what.to_string(),
                    message: format!(
                        "`{name}` has {} coefficients; order {} needs {n}",
                        c.len(),
                        fit.order
                    ),
                });
            }
            if c.iter().any(|v| !v.is_finite()) {
                return Err(OpticsError::Parse {
                    what: what.to_string(),
                    message: format!("`{name}` has a non-finite coefficient"),
                });
            }
        }
        fit.check().map_err(|m| OpticsError::Parse {
            what: what.to_string(),
            message: m,
        })?;
        Ok(fit)
    }

    /// Read a shading file (the TOML `camsim fit-shading` writes); errors name the file.
    pub fn from_file(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| OpticsError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// The lens-shading correction gains of a `rows x cols` frame whose CFA is `layout`, row-major:
    /// 1 / the relative illumination at each pixel's centre (normalized coordinates, so a frame
    /// of another size than the fitted one maps onto the same field) of its filter's channel, r,
    /// g and b their own polynomials and any other filter (w, c, ir, ...) the mean of the three.
    /// The relative illumination is taken as at least [`MIN_RELATIVE_ILLUMINATION`] (what
    /// [`ShadingFit::check`] accepts), so no gain exceeds 20.
    pub fn correction_gains(
        &self,
        rows: usize,
        cols: usize,
        layout: &camsim_core::CfaLayout,
    ) -> Vec<f32> {
        use rayon::prelude::*;
        // Each tile filter's channel: R, G, B, or None for the mean.
        let channel: Vec<Option<CfaChannel>> = layout
            .filters()
            .iter()
            .map(|f| match f.as_str() {
                "r" => Some(CfaChannel::R),
                "g" => Some(CfaChannel::G),
                "b" => Some(CfaChannel::B),
                _ => None,
            })
            .collect();
        let mut gains = vec![0.0f32; rows * cols];
        gains
            .par_chunks_mut(cols.max(1))
            .enumerate()
            .for_each(|(r, line)| {
                let y = (r as f64 + 0.5) / rows as f64 * 2.0 - 1.0;
                let cx = [&self.red, &self.green, &self.blue]
                    .map(|c| row_coefficients(c, self.order, y));
                for (c, g) in line.iter_mut().enumerate() {
                    let x = (c as f64 + 0.5) / cols as f64 * 2.0 - 1.0;
                    let ri = match channel[layout.filter_at(r, c)] {
                        Some(ch) => horner(&cx[ch.index()], x),
                        None => cx.iter().map(|k| horner(k, x)).sum::<f64>() / 3.0,
                    };
                    *g = (1.0 / ri.max(MIN_RELATIVE_ILLUMINATION)) as f32;
                }
            });
        gains
    }

    /// Check that this is a lens shading fitted to a flat field: the residual beyond the pixel
    /// noise is at most [`MAX_EXCESS_RESIDUAL_PERCENT`]; every channel's relative illumination lies
    /// in [[`MIN_RELATIVE_ILLUMINATION`], 1] over the image (within 1e-6 above 1: it is normalized
    /// to its maximum) and falls off monotonically from its maximum (rise < [`MAX_OUTWARD_RISE`]
    /// along 32 rays, 64 steps each). The message says which test failed and by how much.
    pub fn check(&self) -> std::result::Result<(), String> {
        let excess = (self.rms_residual_percent.powi(2) - self.noise_percent.powi(2))
            .max(0.0)
            .sqrt();
        if !(excess <= MAX_EXCESS_RESIDUAL_PERCENT) {
            return Err(format!(
                "not a flat field: the fitted shading leaves an RMS residual of {:.1} % against a pixel noise of {:.1} % \
                 ({excess:.1} % unexplained; at most {MAX_EXCESS_RESIDUAL_PERCENT} % for a uniformly lit field)",
                self.rms_residual_percent, self.noise_percent
            ));
        }
        for ch in [CfaChannel::R, CfaChannel::G, CfaChannel::B] {
            let coef = self.coefficients(ch);
            // Values on a 65 x 65 grid over the image (corners included), and the maximum.
            let n = 64;
            let at = |i: usize, j: usize| {
                poly_eval(
                    coef,
                    self.order,
                    -1.0 + 2.0 * i as f64 / n as f64,
                    -1.0 + 2.0 * j as f64 / n as f64,
                )
            };
            let (mut lo, mut hi, mut arg) = (f64::INFINITY, f64::NEG_INFINITY, (0.0, 0.0));
            for i in 0..=n {
                for j in 0..=n {
                    let v = at(i, j);
                    lo = lo.min(v);
                    if v > hi {
                        hi = v;
                        arg = (
                            -1.0 + 2.0 * i as f64 / n as f64,
                            -1.0 + 2.0 * j as f64 / n as f64,
                        );
                    }
                }
            }
            if !(lo >= MIN_RELATIVE_ILLUMINATION && hi <= 1.0 + 1e-6) {
                return Err(format!(
                    "channel {}: relative illumination ranges from {lo:.3} to {hi:.3}; a lens shading lies in [{MIN_RELATIVE_ILLUMINATION}, 1] \
                     (is the input a flat field?)",
                    ch.letter()
                ));
            }
            for k in 0..32 {
                let th = 2.0 * std::f64::consts::PI * k as f64 / 32.0;
                let (dx, dy) = (th.cos(), th.sin());
                let mut run_min = hi;
                let mut t = 0.0;
                let step = 2.0 * 2f64.sqrt() / 64.0;
                loop {
                    t += step;
                    let (x, y) = (arg.0 + t * dx, arg.1 + t * dy);
                    if x.abs() > 1.0 || y.abs() > 1.0 {
                        break;
                    }
                    let v = poly_eval(coef, self.order, x, y);
                    if v - run_min > MAX_OUTWARD_RISE * hi {
                        return Err(format!(
                            "channel {}: the fitted shading rises from {run_min:.3} to {v:.3} going out from its maximum at \
                             ({:.2}, {:.2}) towards ({x:.2}, {y:.2}); lens falloff is monotonic (is the input a flat field?)",
                            ch.letter(),
                            arg.0,
                            arg.1
                        ));
                    }
                    run_min = run_min.min(v);
                }
            }
        }
        Ok(())
    }
}

/// Solve the symmetric positive definite system `a x = b` (n x n, row-major) by Gaussian
/// elimination with partial pivoting; None if singular.
pub(crate) fn solve(mut a: Vec<f64>, mut b: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let p = (col..n).max_by(|i, j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        if a[p * n + col].abs() < 1e-300 {
            return None;
        }
        if p != col {
            for k in 0..n {
                a.swap(p * n + k, col * n + k);
            }
            b.swap(p, col);
        }
        for r in col + 1..n {
            let f = a[r * n + col] / a[col * n + col];
            if f != 0.0 {
                for k in col..n {
                    a[r * n + k] -= f * a[col * n + k];
                }
                b[r] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let mut s = b[r];
        for k in r + 1..n {
            s -= a[r * n + k] * x[k];
        }
        x[r] = s / a[r * n + r];
    }
    Some(x)
}

/// Fit a lens-shading polynomial of total degree `order` (0..=8) to a raw flat field (a uniform
/// field, e.g. an integrating sphere). For each CFA colour: subtract the black level, drop
/// saturated samples, average the colour's samples over blocks of the image (about 64 x 48 blocks;
/// a low-order polynomial changes by < 1e-4 over a block), fit the block means at the blocks'
/// mean normalized coordinates by linear least squares (normal equations), then scale the
/// polynomial to 1 at its maximum over the image. The residual is the RMS over all unsaturated
/// pixels of (value - fit) / fit, in percent (it includes the capture's noise). The fit is refused
/// when the input is not a flat field ([`ShadingFit::check`]).
pub fn fit_flat_field(raw: &RawImage, order: usize) -> Result<ShadingFit> {
    if order > 8 {
        return Err(OpticsError::config(
            "order",
            format!("{order}: the shading polynomial order must be 0..=8"),
        ));
    }
    if raw.dn.len() != raw.rows * raw.cols || raw.rows < 4 || raw.cols < 4 {
        return Err(OpticsError::Input(format!(
            "flat field {} x {} is too small or inconsistent",
            raw.rows, raw.cols
        )));
    }
    let terms = monomials(order);
    let nt = terms.len();
    let (rows, cols) = (raw.rows, raw.cols);
    let nbc = 64.min(cols / 2).max(1);
    let nbr = 48.min(rows / 2).max(1);
    let xn = |c: usize| (c as f64 + 0.5) / cols as f64 * 2.0 - 1.0;
    let yn = |r: usize| (r as f64 + 0.5) / rows as f64 * 2.0 - 1.0;
    let sat = raw.white_level_dn;
    let mut fits: Vec<Vec<f64>> = Vec::new();
    for ch in [CfaChannel::R, CfaChannel::G, CfaChannel::B] {
        // Block sums: value, x, y, count.
        let mut acc = vec![[0.0f64; 4]; nbr * nbc];
        for r in 0..rows {
            let br = r * nbr / rows;
            for c in 0..cols {
                if raw.cfa.channel_at(r, c) != ch {
                    continue;
                }
                let v = raw.dn[r * cols + c] as f64;
                if v >= sat {
                    continue;
                }
                let b = &mut acc[br * nbc + c * nbc / cols];
                b[0] += v - raw.black_level_dn;
                b[1] += xn(c);
                b[2] += yn(r);
                b[3] += 1.0;
            }
        }
        let mut ata = vec![0.0; nt * nt];
        let mut atb = vec![0.0; nt];
        let mut phi = vec![0.0; nt];
        let mut used = 0usize;
        for b in &acc {
            if b[3] < 1.0 {
                continue;
            }
            used += 1;
            let (v, x, y) = (b[0] / b[3], b[1] / b[3], b[2] / b[3]);
            for (k, (i, j)) in terms.iter().enumerate() {
                phi[k] = x.powi(*i as i32) * y.powi(*j as i32);
            }
            // Weight by the sample count (equal weight per pixel).
            for p in 0..nt {
                atb[p] += b[3] * phi[p] * v;
                for q in 0..nt {
                    ata[p * nt + q] += b[3] * phi[p] * phi[q];
                }
            }
        }
        if used < nt {
            return Err(OpticsError::Input(format!(
                "flat field: only {used} usable blocks of channel {} for {nt} polynomial terms (too small or saturated)",
                ch.letter()
            )));
        }
        let mut coef = solve(ata, atb, nt).ok_or_else(|| {
            OpticsError::Input(format!(
                "flat field: the shading fit for channel {} is singular",
                ch.letter()
            ))
        })?;
        // Normalize to 1 at the maximum over the image (evaluated on a 129 x 129 grid plus corners).
        let mut mx = f64::NEG_INFINITY;
        for i in 0..=128 {
            for j in 0..=128 {
                let x = -1.0 + 2.0 * i as f64 / 128.0;
                let y = -1.0 + 2.0 * j as f64 / 128.0;
                mx = mx.max(poly_eval(&coef, order, x, y));
            }
        }
        if !(mx > 0.0) {
            return Err(OpticsError::Input(format!(
                "flat field: channel {} has no signal above the black level",
                ch.letter()
            )));
        }
        coef.iter_mut().for_each(|c| *c /= mx);
        // Keep the absolute scale for the residual.
        fits.push(coef.iter().map(|c| c * mx).collect());
        fits.push(coef);
    }
    // Pixel noise: differences of same-colour neighbours two columns apart (the shading changes
    // by < 1e-3 over two pixels), var(v1 - v2) = 2 var(v), relative to the fit.
    let (mut nss, mut nn) = (0.0f64, 0usize);
    for r in 0..rows {
        let y = yn(r);
        let rc: Vec<Vec<f64>> = (0..3)
            .map(|ch| row_coefficients(&fits[2 * ch], order, y))
            .collect();
        for c in 0..cols.saturating_sub(2) {
            let (a, b) = (raw.dn[r * cols + c] as f64, raw.dn[r * cols + c + 2] as f64);
            if a >= sat || b >= sat {
                continue;
            }
            let fit = horner(&rc[raw.cfa.channel_at(r, c).index()], xn(c + 1));
            if fit > 0.0 {
                nss += ((a - b) / fit).powi(2) / 2.0;
                nn += 1;
            }
        }
    }
    // Residual over all pixels, relative to the (absolute) fit.
    let (mut ss, mut n) = (0.0f64, 0usize);
    for r in 0..rows {
        let y = yn(r);
        let rc: Vec<Vec<f64>> = (0..3)
            .map(|ch| row_coefficients(&fits[2 * ch], order, y))
            .collect();
        for c in 0..cols {
            let v = raw.dn[r * cols + c] as f64;
            if v >= sat {
                continue;
            }
            let ch = raw.cfa.channel_at(r, c).index();
            let fit = horner(&rc[ch], xn(c));
            if fit > 0.0 {
                let e = (v - raw.black_level_dn - fit) / fit;
                ss += e * e;
                n += 1;
            }
        }
    }
    let fit = ShadingFit {
        order,
        rows,
        cols,
        red: fits[1].clone(),
        green: fits[3].clone(),
        blue: fits[5].clone(),
        // No pixel with a positive fit: the fit is useless, report an infinite residual.
        rms_residual_percent: if n > 0 {
            (ss / n as f64).sqrt() * 100.0
        } else {
            f64::INFINITY
        },
        noise_percent: if nn > 0 {
            (nss / nn as f64).sqrt() * 100.0
        } else {
            0.0
        },
    };
    fit.check()
        .map_err(|m| OpticsError::Input(format!("flat field: {m}")))?;
    Ok(fit)
}
