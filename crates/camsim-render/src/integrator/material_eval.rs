//! Materials evaluated at a hit: `mix` choices, the alpha test, a conductor's optical constants
//! and the BSDF of a compiled material ([`crate::materials::Mat`]) at the path's wavelengths.

use super::Tracer;
use crate::bsdf::{Bsdf, Layer, TrowbridgeReitz};
use crate::materials::{CondOptics, Mat, Walk};
use crate::math::V3;
use crate::spectral::Lambdas;
use crate::texture::{eval_float, TexCtx};

impl Tracer {
    /// Material `m` with every `mix` resolved for this hit (pbrt-v4 `MixMaterial::ChooseMaterial`:
    /// `materials[1]` when a hash of the hit point, the direction and the two materials, as a
    /// uniform number in [0, 1), is below `amount`).
    #[inline]
    pub(crate) fn resolve_material(&self, mut m: u32, p: V3, wo: V3) -> u32 {
        // Cycles are refused at compile time; the bound only guards against a deep chain.
        for _ in 0..64 {
            match &self.materials[m as usize] {
                Mat::Mix { materials, amount } => {
                    m = if *amount <= 0.0 {
                        materials[0]
                    } else if *amount >= 1.0
                        || mix_hash(p, wo, materials[0], materials[1]) < *amount
                    {
                        materials[1]
                    } else {
                        materials[0]
                    };
                }
                // The alpha test ran before (`alpha_keeps`): the surface is the base material.
                Mat::AlphaMasked { base, .. } | Mat::MediumBoundary { base } => m = *base,
                _ => return m,
            }
        }
        m
    }

    /// A conductor's `(eta, k)` at the path's wavelengths (tables, or pbrt-v4's
    /// `ConductorMaterial` conversion of a reflectance: eta = 1, k = 2 sqrt(r) / sqrt(1 - r)).
    #[inline]
    pub(crate) fn conductor_constants<const N: usize>(
        &self,
        optics: &CondOptics,
        ctx: &TexCtx,
        lambdas: &Lambdas<N>,
    ) -> ([f32; N], [f32; N]) {
        match optics {
            CondOptics::EtaK(e, k) => (
                self.tables[*e as usize].eval_path(lambdas),
                self.tables[*k as usize].eval_path(lambdas),
            ),
            CondOptics::Reflectance(tex) => {
                let r = self.eval_texture(tex, ctx, lambdas);
                let k = std::array::from_fn(|i| {
                    let r = r[i].clamp(0.0, 0.9999);
                    2.0 * r.sqrt() / (1.0 - r).sqrt()
                });
                ([1.0; N], k)
            }
        }
    }

    /// A coating's layer at a hit: the medium's albedo at the path's wavelengths, clamped to
    /// [0, 1].
    #[inline]
    fn layer_at<const N: usize>(&self, w: &Walk, ctx: &TexCtx, lambdas: &Lambdas<N>) -> Layer<N> {
        let albedo = self
            .eval_texture(&w.albedo, ctx, lambdas)
            .map(|a| a.clamp(0.0, 1.0));
        Layer {
            thickness: w.thickness,
            albedo,
            g: w.g,
            max_depth: w.max_depth,
            n_samples: w.n_samples,
            pbrt_v4_exit_weight: self.layered_exit_pbrt_v4,
        }
    }

    /// pbrt-v4's alpha test of a hit (4th ed. §7.1.1, `GeometricPrimitive::Intersect`) on a
    /// surface with material `m`: false when the hit must be ignored and the ray continued.
    /// `a = alpha(uv)`; `a >= 1` keeps, `a <= 0` ignores, otherwise the hit is kept when a
    /// deterministic hash of the ray (`origin`, `dir`), uniform in [0, 1), is at most `a`
    /// (pbrt-v4 `HashFloat(r.o, r.d)`). Materials without alpha keep every hit.
    #[inline]
    pub(crate) fn alpha_keeps(&self, m: u32, ctx: &TexCtx, origin: V3, dir: V3) -> bool {
        let Mat::AlphaMasked { alpha, .. } = &self.materials[m as usize] else {
            return true;
        };
        let a = eval_float(alpha, ctx);
        if a >= 1.0 {
            return true;
        }
        if a <= 0.0 || a.is_nan() {
            return false;
        }
        mix_hash(origin, dir, ALPHA_HASH_TAG, m) <= a
    }

    /// The BSDF of (non-mix, non-interface) material `m` at a hit, at the path's wavelengths,
    /// for a path arriving from outside (`outside`, the side the oriented geometric normal points
    /// to) or inside. The flag is true when the material is dispersive and the path must keep
    /// only its hero wavelength (pbrt-v4 `SampledWavelengths::TerminateSecondary`).
    #[inline]
    pub(crate) fn bsdf_at<const N: usize>(
        &self,
        m: u32,
        ctx: &TexCtx,
        lambdas: &Lambdas<N>,
        outside: bool,
    ) -> (Bsdf<N>, bool) {
        let side = |eta: f32| if outside { eta } else { 1.0 / eta };
        match &self.materials[m as usize] {
            Mat::Diffuse(tex) => (
                Bsdf::Diffuse {
                    reflectance: self.eval_texture(tex, ctx, lambdas),
                },
                false,
            ),
            Mat::CoatedConductor {
                eta,
                coat,
                optics,
                base,
                walk,
            } => {
                // pbrt-v4 CoatedConductorMaterial: the conductor's constants relative to the
                // coating (ce /= ieta, ck /= ieta).
                let (ce, ck) = self.conductor_constants(optics, ctx, lambdas);
                (
                    Bsdf::CoatedConductor {
                        eta: *eta,
                        coat: *coat,
                        c_eta: ce.map(|v| v / eta),
                        c_k: ck.map(|v| v / eta),
                        base: *base,
                        layer: self.layer_at(walk, ctx, lambdas),
                    },
                    false,
                )
            }
            Mat::Conductor { optics, distrib } => {
                let (eta, k) = self.conductor_constants(optics, ctx, lambdas);
                (
                    Bsdf::Conductor {
                        eta,
                        k,
                        distrib: *distrib,
                    },
                    false,
                )
            }
            Mat::Dielectric {
                eta,
                dispersive,
                distrib,
            } => {
                let e = self.tables[*eta as usize].eval_path(lambdas)[0];
                (
                    Bsdf::Dielectric {
                        eta: side(e),
                        distrib: *distrib,
                    },
                    *dispersive,
                )
            }
            Mat::ThinDielectric { eta, dispersive } => (
                Bsdf::ThinDielectric {
                    eta: self.tables[*eta as usize].eval_path(lambdas)[0],
                },
                *dispersive,
            ),
            Mat::DiffuseTransmission { r, t, scale } => {
                let (mut r, mut t) = (
                    self.eval_texture(r, ctx, lambdas),
                    self.eval_texture(t, ctx, lambdas),
                );
                for i in 0..N {
                    r[i] = (r[i] * scale).clamp(0.0, 1.0);
                    t[i] = (t[i] * scale).clamp(0.0, 1.0);
                }
                (Bsdf::DiffuseTransmission { r, t }, false)
            }
            Mat::CoatedDiffuse {
                r,
                eta,
                distrib,
                walk,
            } => {
                let mut rho = self.eval_texture(r, ctx, lambdas);
                for v in rho.iter_mut() {
                    *v = v.clamp(0.0, 1.0);
                }
                (
                    Bsdf::CoatedDiffuse {
                        reflectance: rho,
                        eta: *eta,
                        distrib: *distrib,
                        layer: self.layer_at(walk, ctx, lambdas),
                    },
                    false,
                )
            }
            Mat::Hair {
                absorption,
                from_color,
                eta,
                beta_m,
                beta_n,
                alpha_deg,
            } => {
                let a = self.eval_texture(absorption, ctx, lambdas);
                let sigma_a = if *from_color {
                    a.map(|c| crate::bsdf::hair::sigma_a_from_color(c, *beta_n))
                } else {
                    a.map(|s| s.max(0.0))
                };
                // The offset across the fibre from the curve's v (see `h_from_v`).
                let h = crate::bsdf::hair::h_from_v(ctx.uv[1]);
                (
                    Bsdf::Hair(crate::bsdf::hair::Hair::new(
                        h, *eta, sigma_a, *beta_m, *beta_n, *alpha_deg,
                    )),
                    false,
                )
            }
            Mat::GltfPbr(g) => {
                let base = self.eval_texture(&g.base, ctx, lambdas);
                let tint = self.eval_texture(&g.specular_color, ctx, lambdas);
                let spec = eval_float(&g.specular, ctx).clamp(0.0, 1.0);
                // KHR_materials_specular: F0 = min(r0^2 tint, 1) specular, F90 = specular.
                let f0 = tint.map(|t| (g.f0_scale * t).min(1.0) * spec);
                (
                    Bsdf::GltfPbr(crate::bsdf::gltf::GltfBrdf::new(
                        base,
                        eval_float(&g.metallic, ctx),
                        eval_float(&g.roughness, ctx),
                        f0,
                        spec,
                    )),
                    false,
                )
            }
            Mat::VaryingRoughness { base, u, v, remap } => {
                let (mut bsdf, terminate) = self.bsdf_at(*base, ctx, lambdas, outside);
                let (ru, rv) = (eval_float(u, ctx).max(0.0), eval_float(v, ctx).max(0.0));
                // pbrt-v4 TrowbridgeReitzDistribution::RoughnessToAlpha: alpha = sqrt(roughness).
                let d = if *remap {
                    TrowbridgeReitz {
                        alpha_x: ru.sqrt(),
                        alpha_y: rv.sqrt(),
                    }
                } else {
                    TrowbridgeReitz {
                        alpha_x: ru,
                        alpha_y: rv,
                    }
                };
                match &mut bsdf {
                    Bsdf::Conductor { distrib, .. }
                    | Bsdf::Dielectric { distrib, .. }
                    | Bsdf::CoatedDiffuse { distrib, .. } => *distrib = d,
                    _ => {}
                }
                (bsdf, terminate)
            }
            // Unwrapped by the tracer first (`Tracer::shading_normal`); the base as a fallback.
            Mat::Bumped { base, .. } => self.bsdf_at(*base, ctx, lambdas, outside),
            // Resolved before (mix, alpha) or handled by the tracer (interface): never reached.
            Mat::Mix { .. }
            | Mat::Interface
            | Mat::AlphaMasked { .. }
            | Mat::MediumBoundary { .. } => (
                Bsdf::Diffuse {
                    reflectance: [0.0; N],
                },
                false,
            ),
        }
    }
}

/// Distinguishes the alpha test's hash from a `mix` choice's (material indices are far below).
const ALPHA_HASH_TAG: u32 = 0xA1FA_0000;

/// Deterministic uniform number in [0, 1) for a `mix` decision at a hit (pbrt-v4 hashes the
/// point, the direction and the two materials; here a SplitMix64-style mix of their bits,
/// Steele et al. 2014).
#[inline]
pub(crate) fn mix_hash(p: V3, wo: V3, a: u32, b: u32) -> f32 {
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15 ^ ((a as u64) << 32 | b as u64);
    for v in [p.x, p.y, p.z, wo.x, wo.y, wo.z] {
        h ^= v.to_bits() as u64;
        h = h.wrapping_add(0x9E37_79B9_7F4A_7C15);
        h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h ^= h >> 31;
    }
    (h >> 40) as f32 / (1u64 << 24) as f32
}
