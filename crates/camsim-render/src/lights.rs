//! Light sources: diffuse area lights on triangles and spheres (one- or two-sided) and a uniform
//! infinite light. Lights are chosen with probability proportional to their power (pbrt-v4
//! `PowerLightSampler`); points on triangles are sampled uniformly by area, spheres seen from
//! outside uniformly within the cone they subtend, from inside uniformly by area.

use crate::math::V3;
use crate::sampling::{self, cone_pdf, sample_sphere_cone, sphere_cone, uniform_sphere, uniform_triangle, UNIFORM_SPHERE_PDF};
use crate::spectral::{Lambdas, SpectrumTable};
use std::f32::consts::PI;

/// The shape of a light.
#[derive(Debug, Clone, Copy)]
pub(crate) enum LightKind {
    /// Triangle `p0, p0 + e1, p0 + e2`; `n` is the unit normal of the emitting side; `area` in m^2.
    Tri { p0: V3, e1: V3, e2: V3, n: V3, area: f32 },
    /// Sphere; one-sided spheres emit outward, or inward when `inward` (ReverseOrientation).
    Sphere { center: V3, radius: f32, inward: bool },
    /// Uniform radiance from every direction.
    Infinite,
}

/// One light: shape, radiance table (W/(sr m^2 nm)), sidedness and selection probability.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LightEntry {
    pub kind: LightKind,
    pub table: u32,
    pub two_sided: bool,
    pub pmf: f32,
}

/// All lights and the power distribution used to pick one.
#[derive(Debug, Clone, Default)]
pub(crate) struct Lights {
    pub list: Vec<LightEntry>,
    cdf: Vec<f64>,
    /// Indices of infinite lights (evaluated when a ray escapes).
    pub infinite: Vec<u32>,
}

/// A sampled light direction from a reference point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LightSample<const N: usize> {
    /// Unit direction from the reference point to the light.
    pub wi: V3,
    /// Distance to the sampled point, m (infinite for the infinite light).
    pub dist: f32,
    /// The sampled point on the light, m (unused for the infinite light).
    pub p_light: V3,
    /// Unit surface normal of the light at `p_light`, as the shape defines it (zero for the
    /// infinite light); the shadow ray's end is offset along it (pbrt-v4 `SpawnRayTo`).
    pub n_light: V3,
    /// Emitted radiance toward the reference point.
    pub le: [f32; N],
    /// Density per steradian, including the light selection probability.
    pub pdf: f32,
}

impl Lights {
    /// Add a light; returns its index.
    pub(crate) fn push(&mut self, kind: LightKind, table: u32, two_sided: bool) -> u32 {
        if matches!(kind, LightKind::Infinite) {
            self.infinite.push(self.list.len() as u32);
        }
        self.list.push(LightEntry { kind, table, two_sided, pmf: 0.0 });
        (self.list.len() - 1) as u32
    }

    /// No lights at all.
    pub(crate) fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Compute selection probabilities proportional to emitted power
    /// (pbrt-v4 `DiffuseAreaLight::Phi` = pi (2 if two-sided) A L; `UniformInfiniteLight::Phi`
    /// = 4 pi pi r^2 L with r the scene's bounding radius), with L the mean radiance over the
    /// sampled wavelength range. Falls back to uniform selection when every power is zero.
    pub(crate) fn finish(&mut self, tables: &[SpectrumTable], scene_radius_m: f32) {
        let powers: Vec<f64> = self
            .list
            .iter()
            .map(|l| {
                let lmean = tables[l.table as usize].mean();
                let sides = if l.two_sided { 2.0 } else { 1.0 };
                let p = std::f64::consts::PI;
                match l.kind {
                    LightKind::Tri { area, .. } => p * sides * area as f64 * lmean,
                    LightKind::Sphere { radius, .. } => p * sides * 4.0 * p * (radius as f64).powi(2) * lmean,
                    LightKind::Infinite => 4.0 * p * p * (scene_radius_m as f64).powi(2) * lmean,
                }
            })
            .collect();
        let total: f64 = powers.iter().sum();
        let n = self.list.len();
        let probs: Vec<f64> =
            if total > 0.0 && total.is_finite() { powers.iter().map(|p| p / total).collect() } else { vec![1.0 / n as f64; n] };
        self.cdf.clear();
        let mut acc = 0.0;
        for (l, p) in self.list.iter_mut().zip(&probs) {
            l.pmf = *p as f32;
            acc += p;
            self.cdf.push(acc);
        }
    }

    /// Pick a light from a uniform number.
    #[inline]
    fn pick(&self, u: f32) -> usize {
        let u = u as f64 * self.cdf.last().copied().unwrap_or(1.0);
        let i = self.cdf.partition_point(|c| *c <= u);
        let mut i = i.min(self.list.len() - 1);
        // Never return a light with zero probability (u landed on a flat step).
        while self.list[i].pmf == 0.0 && i > 0 {
            i -= 1;
        }
        i
    }

    /// True when `light` emits from point `p` (geometric normal `ng`, as the shape defines it)
    /// toward direction `w` (pbrt-v4 `DiffuseAreaLight::L`: one-sided lights emit on the side
    /// of their normal).
    #[inline]
    pub(crate) fn emits_toward(&self, light: &LightEntry, p: V3, ng: V3, w: V3) -> bool {
        if light.two_sided {
            return true;
        }
        match light.kind {
            LightKind::Tri { n, .. } => n.dot(w) > 0.0,
            LightKind::Sphere { center, inward, .. } => {
                let out = (p - center).dot(w) > 0.0;
                let _ = ng;
                out != inward
            }
            LightKind::Infinite => false,
        }
    }

    /// Density per steradian (times the selection probability) with which [`Lights::sample`]
    /// from `p_ref` would have produced point `q` (normal `ng`) on `light`.
    #[inline]
    pub(crate) fn pdf_hit(&self, light: &LightEntry, p_ref: V3, q: V3, ng: V3) -> f32 {
        let d = q - p_ref;
        let dist2 = d.length_squared();
        match light.kind {
            LightKind::Tri { area, .. } => {
                let cos = (ng.dot(d)).abs() / dist2.sqrt();
                if cos <= 0.0 {
                    return 0.0;
                }
                light.pmf * dist2 / (cos * area)
            }
            LightKind::Sphere { center, radius, .. } => match sphere_cone(p_ref, center, radius) {
                Some((cos_max, sin2_max)) => light.pmf * cone_pdf(cos_max, sin2_max),
                None => {
                    let cos = (ng.dot(d)).abs() / dist2.sqrt();
                    if cos <= 0.0 {
                        return 0.0;
                    }
                    light.pmf * dist2 / (cos * 4.0 * PI * radius * radius)
                }
            },
            LightKind::Infinite => light.pmf * UNIFORM_SPHERE_PDF,
        }
    }

    /// Sample a light and a direction toward it from `p`.
    #[inline]
    pub(crate) fn sample<const N: usize>(
        &self,
        tables: &[SpectrumTable],
        p: V3,
        u_sel: f32,
        u0: f32,
        u1: f32,
        lambdas: &Lambdas<N>,
    ) -> Option<LightSample<N>> {
        let light = &self.list[self.pick(u_sel)];
        let (wi, dist, q_light, n_light, pdf_sa) = match light.kind {
            LightKind::Tri { p0, e1, e2, n, area } => {
                let (b1, b2) = uniform_triangle(u0, u1);
                let q = p0 + e1 * b1 + e2 * b2;
                let d = q - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = n.dot(-wi);
                if !light.two_sided && cos_l <= 0.0 {
                    return None;
                }
                let cos_l = cos_l.abs();
                if cos_l <= 0.0 || dist <= 0.0 {
                    return None;
                }
                (wi, dist, q, n, dist2 / (cos_l * area))
            }
            LightKind::Sphere { center, radius, inward } => {
                let (q, n, pdf) = match sphere_cone(p, center, radius) {
                    Some((cos_max, sin2_max)) => {
                        let (q, n) = sample_sphere_cone(p, center, radius, cos_max, sin2_max, u0, u1);
                        (q, n, cone_pdf(cos_max, sin2_max))
                    }
                    None => {
                        let n = uniform_sphere(u0, u1);
                        let q = center + n * radius;
                        let d = q - p;
                        let dist2 = d.length_squared();
                        let cos = (n.dot(d)).abs() / dist2.sqrt();
                        if cos <= 0.0 {
                            return None;
                        }
                        (q, n, dist2 / (cos * 4.0 * PI * radius * radius))
                    }
                };
                let d = q - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                if !light.two_sided && ((n.dot(-wi) > 0.0) == inward) {
                    return None;
                }
                (wi, dist, q, n, pdf)
            }
            LightKind::Infinite => (uniform_sphere(u0, u1), f32::INFINITY, V3::splat(0.0), V3::splat(0.0), sampling::UNIFORM_SPHERE_PDF),
        };
        let pdf = pdf_sa * light.pmf;
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let le = tables[light.table as usize].eval_path(lambdas);
        Some(LightSample { wi, dist, p_light: q_light, n_light, le, pdf })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::WavelengthSampler;
    use camsim_core::{Spectrum, WavelengthGrid};
    use rand::Rng;

    /// The density `sample` reports must equal what `pdf_hit` (used for MIS when a BSDF ray hits
    /// the light) computes for the same point, for every light kind; and one-sided lights never
    /// return samples from their back side.
    #[test]
    fn sample_pdf_matches_pdf_hit() {
        let ws = WavelengthSampler::new(&WavelengthGrid::default());
        let tables = vec![SpectrumTable::new(&Spectrum::new(vec![300.0, 900.0], vec![2.0, 2.0], "t").unwrap(), 1.0, &ws)];
        let mut lights = Lights::default();
        let (p0, e1, e2) = (V3::new(-0.5, 1.0, -0.5), V3::new(1.0, 0.0, 0.2), V3::new(0.1, 0.0, 1.0));
        let n = e1.cross(e2).normalize();
        lights.push(LightKind::Tri { p0, e1, e2, n, area: 0.5 * e1.cross(e2).length() }, 0, false);
        lights.push(LightKind::Sphere { center: V3::new(2.0, 0.5, 0.0), radius: 0.4, inward: false }, 0, true);
        lights.push(LightKind::Sphere { center: V3::new(0.0, 0.0, 0.0), radius: 5.0, inward: true }, 0, false);
        lights.push(LightKind::Infinite, 0, true);
        lights.finish(&tables, 5.0);
        let total: f32 = lights.list.iter().map(|l| l.pmf).sum();
        assert!((total - 1.0).abs() < 1e-6);
        let mut rng = camsim_core::rng::seeded(4);
        let p = V3::new(0.1, -0.3, 0.2);
        let mut seen = [0usize; 4];
        for _ in 0..50_000 {
            let (us, u0, u1): (f32, f32, f32) = (rng.gen(), rng.gen(), rng.gen());
            let k = lights.pick(us);
            let Some(s) = lights.sample::<4>(&tables, p, us, u0, u1, &ws.locate([500.0; 4])) else { continue };
            seen[k] += 1;
            let light = &lights.list[k];
            assert_eq!(s.le, [2.0; 4]);
            if let LightKind::Infinite = light.kind {
                assert!((s.pdf - light.pmf / (4.0 * PI)).abs() < 1e-6);
                continue;
            }
            let q = p + s.wi * s.dist;
            let ng = match light.kind {
                LightKind::Tri { n, .. } => n,
                LightKind::Sphere { center, .. } => (q - center).normalize(),
                LightKind::Infinite => unreachable!(),
            };
            assert!(lights.emits_toward(light, q, ng, -s.wi), "sample from the back of a one-sided light");
            let ph = lights.pdf_hit(light, p, q, ng);
            assert!((ph / s.pdf - 1.0).abs() < 2e-3, "light {k}: sample pdf {} vs pdf_hit {ph}", s.pdf);
        }
        assert!(seen.iter().all(|c| *c > 10), "{seen:?}");
    }
}
