//! Image environment lights (pbrt-v4 `ImageInfiniteLight`): the sphere-to-image mappings
//! (equal-area octahedral, pbrt-v4's; latitude-longitude), nearest-texel radiance with per-texel
//! RGB -> illuminant-spectrum uplift, and importance sampling by a piecewise-constant 2D
//! distribution over the texels (pbrt-v4 `PiecewiseConstant2D`; pbrt-v4 4th ed. §A.5 and §12.5).
//!
//! Because radiance is looked up at the nearest texel and the distribution is constant per
//! texel, the sampled density and the looked-up radiance always refer to the same texel.
//!
//! A map's texels are linear RGB (uplifted per texel) or the coefficients of a three-function
//! spectral basis (`EnvironmentMap::basis`, the CIE daylight basis of the spectral sky): the
//! mappings, the texel distribution and the sampling are the same code for both; only the
//! texel's spectrum differs (the private `Texels`).

use crate::math::V3;
use crate::scene::{EnvMapping, EnvironmentMap};
use crate::spectral::{Lambdas, SpectrumTable, WavelengthSampler};
use crate::uplift::SigmoidPolynomial;
use std::f64::consts::PI;

pub use camsim_scene3d::envmap::{
    equal_area_sphere_to_square, equal_area_square_to_sphere, latlong_to_sphere, sphere_to_latlong,
};

/// Sampling weight of each texel: the mean of its RGB channels (pbrt-v4 uses the channel
/// average too), or for a basis map the mean over 380-780 nm of its spectrum `sum c_k B_k`
/// (the basis means taken at 5 nm), times sin(theta) at the row centre for lat-long maps
/// (their texels' solid angle), so that texels are picked in proportion to their power.
pub fn texel_weights(map: &EnvironmentMap) -> Vec<f64> {
    let (w, h) = (map.width, map.height);
    let basis_mean = map.basis.as_ref().map(|b| {
        let mean = |s: &camsim_core::Spectrum| {
            (0..=80)
                .map(|i| s.eval(380.0 + 5.0 * i as f64))
                .sum::<f64>()
                / 81.0
        };
        [mean(&b[0]), mean(&b[1]), mean(&b[2])]
    });
    (0..w * h)
        .map(|i| {
            let c = map.rgb[i];
            let mean = match basis_mean {
                None => (c[0] as f64 + c[1] as f64 + c[2] as f64) / 3.0,
                Some(m) => c[0] as f64 * m[0] + c[1] as f64 * m[1] + c[2] as f64 * m[2],
            };
            match map.mapping {
                EnvMapping::EqualAreaOctahedral => mean.max(0.0),
                EnvMapping::LatLong => {
                    mean.max(0.0) * (PI * ((i / w) as f64 + 0.5) / h as f64).sin()
                }
            }
        })
        .collect()
}

/// An RGB image whose texels are illuminant spectra (pbrt-v4 `RGBIlluminantSpectrum`): per texel
/// `2 m` (m the largest channel) and the Jakob-Hanika sigmoid polynomial of `rgb / 2m`, so the
/// spectrum is `2m S(lambda)` times the colour space's illuminant. Shared by the environment and
/// projection lights; evaluation allocates nothing.
#[derive(Debug, Clone)]
pub(crate) struct RgbIlluminants {
    scale: Vec<f32>,
    poly: Vec<SigmoidPolynomial>,
}

impl RgbIlluminants {
    /// Uplift every texel once (non-negative RGB; black texels stay 0).
    pub(crate) fn new(rgb: &[[f32; 3]]) -> RgbIlluminants {
        let (mut scale, mut poly) = (Vec::with_capacity(rgb.len()), Vec::with_capacity(rgb.len()));
        for c in rgb {
            let mx = c[0].max(c[1]).max(c[2]);
            if mx > 0.0 {
                let s = 2.0 * mx;
                scale.push(s);
                poly.push(crate::uplift::rgb_to_coefficients([
                    c[0] / s,
                    c[1] / s,
                    c[2] / s,
                ]));
            } else {
                scale.push(0.0);
                poly.push(SigmoidPolynomial::constant(0.0));
            }
        }
        RgbIlluminants { scale, poly }
    }

    /// Texel `texel`'s spectrum at the path's wavelengths, in the units of `illuminant`.
    #[inline]
    pub(crate) fn eval<const N: usize>(
        &self,
        texel: usize,
        illuminant: &SpectrumTable,
        lambdas: &Lambdas<N>,
    ) -> [f32; N] {
        let s = self.scale[texel];
        if s == 0.0 {
            return [0.0; N];
        }
        let il = illuminant.eval_path(lambdas);
        let p = &self.poly[texel];
        std::array::from_fn(|i| s * p.eval(lambdas.nm[i] as f64) as f32 * il[i])
    }
}

/// What a texel's three values mean.
#[derive(Debug, Clone)]
enum Texels {
    /// Linear RGB, uplifted as illuminant spectra.
    Rgb(RgbIlluminants),
    /// Coefficients of three basis spectra, tabulated with their signs (negative sums clamp to 0).
    Basis {
        coeffs: Vec<[f32; 3]>,
        basis: Box<[SpectrumTable; 3]>,
    },
}

/// A compiled environment light.
#[derive(Debug, Clone)]
pub(crate) struct EnvLight {
    width: usize,
    height: usize,
    mapping: EnvMapping,
    texels: Texels,
    /// Rows of the world-to-light and light-to-world rotations.
    to_light: [V3; 3],
    to_world: [V3; 3],
    /// Row marginal CDF (height + 1 entries) and per-row conditional CDFs (width + 1 each),
    /// normalised to end at 1; `row_sum` (unnormalised) and `total` for densities.
    row_cdf: Vec<f64>,
    col_cdf: Vec<f64>,
    weight: Vec<f64>,
    /// Mean texel weight over the image (the integral of the piecewise-constant function on the
    /// unit square).
    mean_weight: f64,
    /// Mean radiance scale over the sphere (for the power estimate).
    pub mean_scale: f64,
}

impl EnvLight {
    pub(crate) fn new(map: &EnvironmentMap, ws: &WavelengthSampler) -> Result<EnvLight, String> {
        let (w, h) = (map.width, map.height);
        if w == 0 || h == 0 || map.rgb.len() != w * h {
            return Err(format!(
                "environment map of {w} x {h} texels has {} values",
                map.rgb.len()
            ));
        }
        match map.mapping {
            EnvMapping::EqualAreaOctahedral if w != h => {
                return Err(format!(
                    "an equal-area environment map must be square, not {w} x {h}"
                ))
            }
            EnvMapping::LatLong if w != 2 * h => {
                return Err(format!(
                    "a lat-long environment map must be twice as wide as high, not {w} x {h}"
                ))
            }
            _ => {}
        }
        match &map.basis {
            None => {
                if map
                    .rgb
                    .iter()
                    .flatten()
                    .any(|v| !(v.is_finite() && *v >= 0.0))
                {
                    return Err("environment map has a negative or non-finite texel".into());
                }
            }
            Some(b) => {
                if map.rgb.iter().flatten().any(|v| !v.is_finite()) {
                    return Err("environment map has a non-finite basis coefficient".into());
                }
                if b.iter().flat_map(|s| &s.values).any(|v| !v.is_finite()) {
                    return Err("environment map basis spectrum is not finite".into());
                }
            }
        }
        let m = &map.light_to_world.m;
        let to_world = [
            V3::from_f64([m[0][0], m[0][1], m[0][2]]),
            V3::from_f64([m[1][0], m[1][1], m[1][2]]),
            V3::from_f64([m[2][0], m[2][1], m[2][2]]),
        ];
        if to_world.iter().any(|r| !r.is_finite()) {
            return Err("environment light transform is not finite".into());
        }
        // The transform's linear part is a rotation for pbrt scenes; invert it generally.
        let inv = crate::xform::inverse(&map.light_to_world)
            .ok_or("environment light transform is singular")?;
        let to_light = [
            V3::from_f64([inv.m[0][0], inv.m[0][1], inv.m[0][2]]),
            V3::from_f64([inv.m[1][0], inv.m[1][1], inv.m[1][2]]),
            V3::from_f64([inv.m[2][0], inv.m[2][1], inv.m[2][2]]),
        ];
        let texels = match &map.basis {
            None => Texels::Rgb(RgbIlluminants::new(&map.rgb)),
            Some(b) => Texels::Basis {
                coeffs: map.rgb.clone(),
                basis: Box::new(std::array::from_fn(|k| {
                    SpectrumTable::new_signed(&b[k], 1.0, ws)
                })),
            },
        };
        let weight = texel_weights(map);
        let mut row_cdf = vec![0.0; h + 1];
        let mut col_cdf = vec![0.0; (w + 1) * h];
        for y in 0..h {
            let base = y * (w + 1);
            for x in 0..w {
                col_cdf[base + x + 1] = col_cdf[base + x] + weight[y * w + x];
            }
            let row_sum = col_cdf[base + w];
            row_cdf[y + 1] = row_cdf[y] + row_sum;
            for x in 1..=w {
                col_cdf[base + x] = if row_sum > 0.0 {
                    col_cdf[base + x] / row_sum
                } else {
                    x as f64 / w as f64
                };
            }
        }
        let total = row_cdf[h];
        if !(total > 0.0 && total.is_finite()) {
            return Err("environment map is black everywhere".into());
        }
        for v in row_cdf.iter_mut() {
            *v /= total;
        }
        let mean_weight = total / (w * h) as f64;
        let mean_scale = match map.mapping {
            EnvMapping::EqualAreaOctahedral => total / (w * h) as f64,
            EnvMapping::LatLong => total / (w * h) as f64 * PI / 2.0,
        };
        Ok(EnvLight {
            width: w,
            height: h,
            mapping: map.mapping,
            texels,
            to_light,
            to_world,
            row_cdf,
            col_cdf,
            weight,
            mean_weight,
            mean_scale,
        })
    }

    fn rotate(rows: &[V3; 3], v: V3) -> V3 {
        V3::new(rows[0].dot(v), rows[1].dot(v), rows[2].dot(v))
    }

    /// Jacobian |d(u,v)/d omega|: density per steradian of a unit density on the square, given
    /// sin(theta) of the direction (used by the lat-long mapping only).
    #[inline]
    fn square_to_solid_angle(&self, sin_theta: f64) -> f64 {
        match self.mapping {
            EnvMapping::EqualAreaOctahedral => 1.0 / (4.0 * PI),
            EnvMapping::LatLong => {
                if sin_theta > 0.0 {
                    1.0 / (2.0 * PI * PI * sin_theta)
                } else {
                    0.0
                }
            }
        }
    }

    /// Texel seen along world direction `dir` (unit), and the sampling density per steradian of
    /// that direction.
    #[inline]
    pub(crate) fn lookup(&self, dir: V3) -> (usize, f32) {
        let d = Self::rotate(&self.to_light, dir).normalize();
        let d = [d.x as f64, d.y as f64, d.z as f64];
        let (u, v) = match self.mapping {
            EnvMapping::EqualAreaOctahedral => equal_area_sphere_to_square(d),
            EnvMapping::LatLong => sphere_to_latlong(d),
        };
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        let texel = y * self.width + x;
        let pdf_uv = self.weight[texel] / self.mean_weight;
        (
            texel,
            (pdf_uv * self.square_to_solid_angle(d[0].hypot(d[1]))) as f32,
        )
    }

    /// Density per steradian of sampling world direction `dir`.
    #[inline]
    pub(crate) fn pdf_dir(&self, dir: V3) -> f32 {
        self.lookup(dir).1
    }

    /// Sample a world direction: (direction, texel, density per steradian).
    #[inline]
    pub(crate) fn sample(&self, u0: f32, u1: f32) -> Option<(V3, usize, f32)> {
        let (w, h) = (self.width, self.height);
        // Row from the marginal, then column from the row's conditional (inversion).
        let pick = |cdf: &[f64], u: f64| -> (usize, f64) {
            let n = cdf.len() - 1;
            let i = cdf
                .partition_point(|c| *c <= u)
                .saturating_sub(1)
                .min(n - 1);
            let span = cdf[i + 1] - cdf[i];
            let t = if span > 0.0 {
                ((u - cdf[i]) / span).clamp(0.0, 1.0)
            } else {
                0.5
            };
            (i, t)
        };
        let (y, ty) = pick(&self.row_cdf, u1 as f64);
        let (x, tx) = pick(&self.col_cdf[y * (w + 1)..(y + 1) * (w + 1)], u0 as f64);
        let texel = y * w + x;
        if self.weight[texel] <= 0.0 {
            return None;
        }
        // Keep the point inside its texel (by 1e-4 of a texel) so that the f32 direction maps
        // back to the same texel.
        let tx = tx.clamp(1e-4, 1.0 - 1e-4);
        let ty = ty.clamp(1e-4, 1.0 - 1e-4);
        let (u, v) = ((x as f64 + tx) / w as f64, (y as f64 + ty) / h as f64);
        let d = match self.mapping {
            EnvMapping::EqualAreaOctahedral => equal_area_square_to_sphere(u, v),
            EnvMapping::LatLong => latlong_to_sphere(u, v),
        };
        let wi = Self::rotate(&self.to_world, V3::from_f64(d)).normalize();
        if !wi.is_finite() {
            return None;
        }
        // Density and texel from the direction itself, so they equal what `lookup` reports
        // when a BSDF ray escapes along `wi` (consistent MIS weights).
        let (texel, pdf) = self.lookup(wi);
        (pdf > 0.0).then_some((wi, texel, pdf))
    }

    /// Radiance of `texel` at the path's wavelengths, W/(sr m^2 nm): `2m S(lambda) illuminant`
    /// for RGB texels, `max(0, sum_k c_k B_k(lambda)) illuminant` for basis texels.
    #[inline]
    pub(crate) fn radiance<const N: usize>(
        &self,
        texel: usize,
        illuminant: &SpectrumTable,
        lambdas: &Lambdas<N>,
    ) -> [f32; N] {
        match &self.texels {
            Texels::Rgb(t) => t.eval(texel, illuminant, lambdas),
            Texels::Basis { coeffs, basis } => {
                let c = coeffs[texel];
                let il = illuminant.eval_path(lambdas);
                let b: [[f32; N]; 3] = std::array::from_fn(|k| basis[k].eval_path(lambdas));
                std::array::from_fn(|i| {
                    (c[0] * b[0][i] + c[1] * b[1][i] + c[2] * b[2][i]).max(0.0) * il[i]
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_map(mapping: EnvMapping, w: usize, h: usize) -> EnvironmentMap {
        let mut rgb = vec![[0.02f32, 0.03, 0.04]; w * h];
        for y in h / 4..h / 4 + 2 {
            for x in w / 3..w / 3 + 2 {
                rgb[y * w + x] = [40.0, 30.0, 20.0];
            }
        }
        EnvironmentMap {
            width: w,
            height: h,
            rgb,
            mapping,
            illuminant: camsim_core::Spectrum::new(vec![300.0, 900.0], vec![1.0, 1.0], "flat")
                .unwrap(),
            basis: None,
            light_to_world: crate::scene::Transform::rotate(25.0, [0.3, 1.0, 0.2]),
        }
    }

    /// Importance sampling and uniform sphere sampling estimate the same integral (the map's
    /// mean texel weight times 4 pi, and the irradiance on a tilted surface), the sampled
    /// density equals `pdf_dir` of the sampled direction, and the density integrates to 1.
    #[test]
    fn importance_sampling_agrees_with_uniform_sampling() {
        use rand::Rng;
        for (mapping, w, h) in [
            (EnvMapping::EqualAreaOctahedral, 32, 32),
            (EnvMapping::LatLong, 64, 32),
        ] {
            let map = test_map(mapping, w, h);
            let ws = WavelengthSampler::new(&camsim_core::WavelengthGrid::default());
            let env = EnvLight::new(&map, &ws).unwrap();
            let weight_of = |dir: V3| {
                let (texel, _) = env.lookup(dir);
                let c = map.rgb[texel];
                (c[0] + c[1] + c[2]) as f64 / 3.0
            };
            let n_dir = V3::new(0.3, -0.5, 0.8).normalize();
            let f = |dir: V3| weight_of(dir) * n_dir.dot(dir).max(0.0) as f64;
            let mut rng = camsim_core::rng::seeded(9);
            let n = 400_000;
            let (mut imp, mut imp2, mut uni, mut uni2) = (0.0, 0.0, 0.0, 0.0);
            for _ in 0..n {
                let (u0, u1): (f32, f32) = (rng.gen(), rng.gen());
                let (wi, _, pdf) = env.sample(u0, u1).expect("sample");
                let p2 = env.pdf_dir(wi);
                // f32 directions: the lat-long Jacobian 1 / sin(theta) is re-evaluated at the
                // rounded direction.
                assert!(
                    (p2 / pdf - 1.0).abs() < 5e-3,
                    "{mapping:?}: sample pdf {pdf} vs pdf_dir {p2}"
                );
                let v = f(wi) / pdf as f64;
                imp += v;
                imp2 += v * v;
                let d = crate::sampling::uniform_sphere(rng.gen(), rng.gen());
                let v = f(d) * 4.0 * PI;
                uni += v;
                uni2 += v * v;
            }
            let nf = n as f64;
            let (mi, mu) = (imp / nf, uni / nf);
            let (si, su) = (
                ((imp2 / nf - mi * mi) / nf).sqrt(),
                ((uni2 / nf - mu * mu) / nf).sqrt(),
            );
            assert!(
                (mi - mu).abs() < 4.0 * (si * si + su * su).sqrt(),
                "{mapping:?}: importance {mi} +- {si}, uniform {mu} +- {su}"
            );
            assert!(
                si < 0.5 * su,
                "{mapping:?}: importance sampling should reduce the error ({si} vs {su})"
            );
            // The density integrates to 1: midpoint rule over the image, 4 x 4 points per
            // texel, through the mapping's area element (4 pi, or 2 pi^2 sin(theta) du dv).
            let k = 4;
            let mut pdf_int = 0.0;
            for j in 0..h * k {
                for i in 0..w * k {
                    let (u, v) = (
                        (i as f64 + 0.5) / (w * k) as f64,
                        (j as f64 + 0.5) / (h * k) as f64,
                    );
                    let (d, area) = match mapping {
                        EnvMapping::EqualAreaOctahedral => {
                            (equal_area_square_to_sphere(u, v), 4.0 * PI)
                        }
                        EnvMapping::LatLong => {
                            (latlong_to_sphere(u, v), 2.0 * PI * PI * (PI * v).sin())
                        }
                    };
                    let dw = EnvLight::rotate(&env.to_world, V3::from_f64(d));
                    pdf_int += env.pdf_dir(dw) as f64 * area / (w * h * k * k) as f64;
                }
            }
            assert!(
                (pdf_int - 1.0).abs() < 1e-3,
                "{mapping:?}: density integrates to {pdf_int}"
            );
        }
    }
}
