//! Veiling glare as a glare spread function (GSF, `[glare]`): the light that stray reflections
//! and scattering inside the lens spread over the whole image, as an additive far tail.
//!
//! The GSF moves the fraction G of every point's energy from its PSF into the tail
//!   g(r) = G (p - 1) r0^(2p - 2) / (pi (r^2 + r0^2)^p)      (per unit area, p > 1),
//! which integrates to G over the plane (int_0^inf 2 pi r (r^2 + r0^2)^-p dr = pi r0^(2 - 2p) /
//! (p - 1)); the energy it puts beyond radius R is G (r0^2 / (R^2 + r0^2))^(p - 1). The
//! irradiance becomes E' = (1 - G) E + g * E. The normalized profile is the Moffat profile
//! (A. F. J. Moffat 1969, A&A 3, 455: (beta - 1) / (pi alpha^2) (1 + r^2 / alpha^2)^-beta, here
//! alpha = r0, beta = p), whose far part falls as r^-2p (p = 1.5: r^-3, the fall of aperture
//! diffraction's tail; smaller p for wide-angle scattering).
//!
//! [`GlarePlan`] applies it on a coarse grid like [`crate::tail`]: the image summed over D x D
//! blocks (D odd, at most the core radius where affordable), convolved by FFT with the block
//! means of g (exact sums over the block's fine offsets within 16 blocks of the centre, the
//! centre value times D^2 beyond), and interpolated back bilinearly between block centres. Light
//! the tail carries past the image's edge is lost (it leaves the sensor).

use crate::error::{OpticsError, Result};
use crate::tail::CoarseKernel;
use std::f64::consts::PI;

/// Coarse grids are at most this many blocks on a side when the block can stay within the core.
const COARSE_TARGET: usize = 256;
/// ... and at most this many when a small core radius asks for small blocks.
const COARSE_MAX: usize = 1024;
/// Blocks within this many block steps of the centre get exact block means of g.
const NEAR_BLOCKS: i64 = 16;

/// The glare spread function's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlareSpread {
    /// Fraction G of the energy moved into the tail, [0, 1).
    pub fraction: f64,
    /// Exponent p (> 1) of g ~ (r^2 + r0^2)^-p.
    pub exponent: f64,
    /// Core radius r0, m.
    pub core_radius_m: f64,
}

impl GlareSpread {
    /// Checked parameters (errors name the `glare.*` key).
    pub fn new(fraction: f64, exponent: f64, core_radius_m: f64) -> Result<Self> {
        if !(0.0..1.0).contains(&fraction) {
            return Err(OpticsError::config(
                "glare.fraction",
                format!("{fraction} is not a fraction of the energy in [0, 1)"),
            ));
        }
        if !(exponent > 1.0 && exponent <= 10.0) {
            return Err(OpticsError::config(
                "glare.exponent",
                format!("{exponent}: the tail (r^2 + r0^2)^-p holds finite energy only for p > 1 (at most 10)"),
            ));
        }
        if !(core_radius_m > 0.0 && core_radius_m.is_finite() && core_radius_m < 1.0) {
            return Err(OpticsError::config(
                "glare.core_radius_um",
                format!(
                    "{} um is not a positive radius (below 1 m)",
                    core_radius_m * 1e6
                ),
            ));
        }
        Ok(GlareSpread {
            fraction,
            exponent,
            core_radius_m,
        })
    }

    /// g(r) per unit area (m^-2), r in m.
    pub fn density_per_m2(&self, r_m: f64) -> f64 {
        let r0 = self.core_radius_m;
        let p = self.exponent;
        self.fraction * (p - 1.0) * r0.powf(2.0 * p - 2.0) / (PI * (r_m * r_m + r0 * r0).powf(p))
    }

    /// Energy of g beyond radius r (m): G (r0^2 / (r^2 + r0^2))^(p - 1).
    pub fn energy_beyond(&self, r_m: f64) -> f64 {
        let r0sq = self.core_radius_m * self.core_radius_m;
        self.fraction * (r0sq / (r_m * r_m + r0sq)).powf(self.exponent - 1.0)
    }
}

fn odd_at_least(x: usize) -> usize {
    x.max(1) | 1
}

/// The GSF planned for one image size and sample spacing.
pub struct GlarePlan {
    spread: GlareSpread,
    /// Block side, samples (odd).
    pub block: usize,
    rows: usize,
    cols: usize,
    /// The unit-energy GSF on the coarse grid.
    kernel: CoarseKernel,
}

impl GlarePlan {
    /// Plans the GSF for `rows` x `cols` images at `spacing_m`.
    pub fn new(spread: GlareSpread, rows: usize, cols: usize, spacing_m: f64) -> Result<GlarePlan> {
        if rows == 0 || cols == 0 || !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(OpticsError::Input(format!(
                "glare of a {rows} x {cols} image at spacing {spacing_m} m"
            )));
        }
        let side = rows.max(cols);
        let r0_px = spread.core_radius_m / spacing_m;
        let mut block = odd_at_least(side.div_ceil(COARSE_TARGET));
        if block as f64 > r0_px {
            let within = (r0_px.floor() as usize).max(1);
            let within = if within % 2 == 1 { within } else { within - 1 };
            block = within.max(odd_at_least(side.div_ceil(COARSE_MAX)));
        }
        camsim_core::mem::check_alloc(
            CoarseKernel::plane_bytes(rows, cols, block),
            "the glare spread function's FFT plane",
        )?;
        // The unit-energy kernel per fine sample: g / G at the sample centre times the sample
        // area; the centre sample holds the energy within the disc of the sample's area.
        let unit = GlareSpread {
            fraction: 1.0,
            ..spread
        };
        let a2 = spacing_m * spacing_m;
        let fine = |dx: i64, dy: i64| -> f64 {
            if dx == 0 && dy == 0 {
                1.0 - unit.energy_beyond(spacing_m / PI.sqrt())
            } else {
                let r = ((dx * dx + dy * dy) as f64).sqrt() * spacing_m;
                unit.density_per_m2(r) * a2
            }
        };
        let d = block as i64;
        let half = (d - 1) / 2;
        let kernel = CoarseKernel::new(rows, cols, block, |br, bc| {
            if br.max(bc) > NEAR_BLOCKS {
                // The block mean of a smooth tail: its centre value (relative error ~ (D / r)^2).
                return fine(bc * d, br * d);
            }
            let mut s = 0.0;
            for u in -half..=half {
                for w in -half..=half {
                    s += fine(bc * d + w, br * d + u);
                }
            }
            s / (d * d) as f64
        });
        Ok(GlarePlan {
            spread,
            block,
            rows,
            cols,
            kernel,
        })
    }

    /// Replace `band` (`rows` x `cols`) by (1 - G) band + g * band.
    pub fn apply(&self, band: &mut [f32]) {
        let g = self.spread.fraction;
        if g == 0.0 {
            return;
        }
        let tail = self.tail(band);
        band.iter_mut()
            .zip(&tail)
            .for_each(|(v, t)| *v = ((1.0 - g) * *v as f64 + g * *t as f64) as f32);
    }

    /// The unit-energy tail of `band`: g / G convolved with it (bilinear from the coarse grid).
    pub fn tail(&self, band: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0f32; self.rows * self.cols];
        self.kernel
            .convolve(band, self.rows, self.cols, (0, 0), 1.0, None, 1.0, &mut out);
        out
    }
}
