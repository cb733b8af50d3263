//! Materials compiled for the tracer: the per-hit choice of a `mix`, the BSDF of a material at a
//! hit and the path's wavelengths, and the compile step from [`crate::scene::Material`]
//! (validation, spectrum tables, the coatings' layer parameters).

use crate::bsdf::{Bsdf, Layer, TrowbridgeReitz};
use crate::integrator::{ImageTex, Tracer};
use crate::math::V3;
use crate::render::RenderError;
use crate::scene::{ConductorOptics, HairAbsorption, LayerWalk, Material, Roughness};
use crate::spectral::{Lambdas, SpectrumTable, WavelengthSampler};
use crate::texture::{compile_float_texture, compile_texture, eval_float, FTex, Tex, TexCtx};

/// A compiled material; new BSDFs add a variant here and an arm in [`Tracer::bsdf_at`].
#[derive(Debug, Clone)]
pub(crate) enum Mat {
    Diffuse(Tex),
    /// Tables of eta and k (index into `Tracer::tables`), or a reflectance texture.
    Conductor {
        optics: CondOptics,
        distrib: TrowbridgeReitz,
    },
    /// Index table (held beyond its data); `dispersive` when it varies with wavelength.
    Dielectric {
        eta: u32,
        dispersive: bool,
        distrib: TrowbridgeReitz,
    },
    ThinDielectric {
        eta: u32,
        dispersive: bool,
    },
    DiffuseTransmission {
        r: Tex,
        t: Tex,
        scale: f32,
    },
    CoatedDiffuse {
        r: Tex,
        eta: f32,
        distrib: TrowbridgeReitz,
        walk: Walk,
    },
    CoatedConductor {
        eta: f32,
        coat: TrowbridgeReitz,
        optics: CondOptics,
        base: TrowbridgeReitz,
        walk: Walk,
    },
    Mix {
        materials: [u32; 2],
        amount: f32,
    },
    Interface,
    /// A shape's alpha cut-out over material `base` (tested by [`Tracer::alpha_keeps`]).
    AlphaMasked {
        base: u32,
        alpha: FTex,
    },
    /// Material `base` with its shading normal perturbed per hit (`crate::bump`).
    Bumped {
        base: u32,
        perturb: crate::bump::Perturb,
    },
    /// A medium boundary over material `base` (the media are in `Tracer::media`).
    MediumBoundary {
        base: u32,
    },
    /// A hair fibre: `sigma_a` (or the colour it is derived from) per hit, and the fibre's
    /// constants (roughness clamped to [0.01, 1] as pbrt-v4 `HairMaterial::GetBxDF`).
    Hair {
        absorption: Tex,
        from_color: bool,
        eta: f32,
        beta_m: f32,
        beta_n: f32,
        alpha_deg: f32,
    },
    /// Material `base` with the roughness `(u, v)` evaluated per hit.
    VaryingRoughness {
        base: u32,
        u: FTex,
        v: FTex,
        remap: bool,
    },
}

/// A coating's layer (pbrt-v4 `LayeredBxDF` parameters), compiled: the medium's albedo texture
/// is evaluated per hit.
#[derive(Debug, Clone)]
pub(crate) struct Walk {
    thickness: f32,
    albedo: Tex,
    g: f32,
    max_depth: u32,
    n_samples: u32,
}

/// A conductor's optical constants, compiled.
#[derive(Debug, Clone)]
pub(crate) enum CondOptics {
    EtaK(u32, u32),
    Reflectance(Tex),
}

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

/// A roughness as the Trowbridge-Reitz distribution, refusing negative or non-finite values.
fn distribution(r: &Roughness, material_index: usize) -> Result<TrowbridgeReitz, RenderError> {
    let (ax, ay) = r.alphas();
    if !(ax >= 0.0 && ay >= 0.0 && ax.is_finite() && ay.is_finite()) {
        return Err(RenderError::Material {
            index: material_index,
            message: format!("roughness ({}, {}) must be finite and >= 0", r.u, r.v),
        });
    }
    Ok(TrowbridgeReitz {
        alpha_x: ax as f32,
        alpha_y: ay as f32,
    })
}

/// A spectrum used as an index of refraction (or extinction): tabulated holding its end values
/// (an index is never zero beyond the data), and whether it varies with wavelength.
/// A conductor's optical constants in render form: eta and k as spectrum tables, or a
/// reflectance texture (turned into eta = 1, k at each hit, pbrt-v4 `ConductorMaterial`).
/// A coating's layer: thickness (optical depth, finite and >= 0, checked by the caller), the
/// medium's albedo texture, `g` in (-1, 1), `max_depth`, `n_samples` >= 1.
fn compile_walk(
    walk: &LayerWalk,
    thickness: f64,
    material_index: usize,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    images: &mut Vec<crate::integrator::ImageTex>,
) -> Result<Walk, RenderError> {
    let err = |message: String| RenderError::Material {
        index: material_index,
        message,
    };
    if !(walk.g > -1.0 && walk.g < 1.0) {
        return Err(err(format!(
            "coating medium g {} must lie in (-1, 1)",
            walk.g
        )));
    }
    if walk.n_samples == 0 {
        return Err(err("coating nsamples must be >= 1".into()));
    }
    Ok(Walk {
        thickness: thickness as f32,
        albedo: compile_texture(&walk.albedo, material_index, ws, tables, images)?,
        g: walk.g as f32,
        max_depth: walk.max_depth,
        n_samples: walk.n_samples,
    })
}

fn compile_conductor_optics(
    optics: &ConductorOptics,
    material_index: usize,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    images: &mut Vec<crate::integrator::ImageTex>,
) -> Result<CondOptics, RenderError> {
    Ok(match optics {
        ConductorOptics::EtaK { eta, k } => {
            let (e, _) = index_table(eta, "conductor eta", material_index, ws, tables, false)?;
            let (k, _) = index_table(k, "conductor k", material_index, ws, tables, false)?;
            CondOptics::EtaK(e, k)
        }
        ConductorOptics::Reflectance(t) => {
            CondOptics::Reflectance(compile_texture(t, material_index, ws, tables, images)?)
        }
    })
}

fn index_table(
    s: &camsim_core::Spectrum,
    what: &str,
    material_index: usize,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    positive: bool,
) -> Result<(u32, bool), RenderError> {
    let err = |message: String| RenderError::Material {
        index: material_index,
        message,
    };
    if s.values
        .iter()
        .any(|v| !v.is_finite() || *v < 0.0 || (positive && *v <= 0.0))
    {
        return Err(err(format!(
            "{what} must be {} (got {:?})",
            if positive { "> 0" } else { ">= 0" },
            s.values
        )));
    }
    let held = s
        .clone()
        .with_extrapolation(camsim_core::spectrum::Extrapolation::Hold);
    let v0 = s.values[0];
    let dispersive = s
        .values
        .iter()
        .any(|v| (v - v0).abs() > 1e-9 * v0.abs().max(1.0));
    tables.push(SpectrumTable::new(&held, 1.0, ws));
    Ok(((tables.len() - 1) as u32, dispersive))
}

pub(crate) fn compile_material(
    m: &Material,
    mi: usize,
    n_materials: usize,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    images: &mut Vec<ImageTex>,
) -> Result<Mat, RenderError> {
    let err = |message: String| RenderError::Material { index: mi, message };
    Ok(match m {
        Material::Diffuse { reflectance } => {
            Mat::Diffuse(compile_texture(reflectance, mi, ws, tables, images)?)
        }
        Material::Conductor { optics, roughness } => {
            let optics = compile_conductor_optics(optics, mi, ws, tables, images)?;
            Mat::Conductor {
                optics,
                distrib: distribution(roughness, mi)?,
            }
        }
        Material::CoatedConductor {
            interface_eta,
            interface_roughness,
            thickness,
            conductor,
            conductor_roughness,
            walk,
        } => {
            if !(interface_eta.is_finite() && *interface_eta > 0.0) {
                return Err(err(format!(
                    "coated conductor interface eta {interface_eta} must be > 0"
                )));
            }
            if !(thickness.is_finite() && *thickness >= 0.0) {
                return Err(err(format!(
                    "coated conductor thickness {thickness} must be >= 0"
                )));
            }
            let optics = compile_conductor_optics(conductor, mi, ws, tables, images)?;
            Mat::CoatedConductor {
                eta: *interface_eta as f32,
                coat: distribution(interface_roughness, mi)?,
                optics,
                base: distribution(conductor_roughness, mi)?,
                walk: compile_walk(walk, *thickness, mi, ws, tables, images)?,
            }
        }
        Material::Dielectric { eta, roughness } => {
            let (eta, dispersive) = index_table(eta, "dielectric eta", mi, ws, tables, true)?;
            Mat::Dielectric {
                eta,
                dispersive,
                distrib: distribution(roughness, mi)?,
            }
        }
        Material::ThinDielectric { eta } => {
            let (eta, dispersive) = index_table(eta, "thin dielectric eta", mi, ws, tables, true)?;
            Mat::ThinDielectric { eta, dispersive }
        }
        Material::DiffuseTransmission {
            reflectance,
            transmittance,
            scale,
        } => {
            if !(scale.is_finite() && *scale >= 0.0) {
                return Err(err(format!(
                    "diffuse transmission scale {scale} must be finite and >= 0"
                )));
            }
            Mat::DiffuseTransmission {
                r: compile_texture(reflectance, mi, ws, tables, images)?,
                t: compile_texture(transmittance, mi, ws, tables, images)?,
                scale: *scale as f32,
            }
        }
        Material::CoatedDiffuse {
            reflectance,
            roughness,
            eta,
            thickness,
            walk,
        } => {
            if !(eta.is_finite() && *eta > 0.0) {
                return Err(err(format!("coated diffuse eta {eta} must be > 0")));
            }
            if !(thickness.is_finite() && *thickness >= 0.0) {
                return Err(err(format!(
                    "coated diffuse thickness {thickness} must be >= 0"
                )));
            }
            Mat::CoatedDiffuse {
                r: compile_texture(reflectance, mi, ws, tables, images)?,
                eta: *eta as f32,
                distrib: distribution(roughness, mi)?,
                walk: compile_walk(walk, *thickness, mi, ws, tables, images)?,
            }
        }
        Material::Mix { materials, amount } => {
            if let Some(bad) = materials.iter().find(|&&i| i >= n_materials) {
                return Err(err(format!(
                    "mix refers to material {bad} but the scene has {n_materials}"
                )));
            }
            if !amount.is_finite() {
                return Err(err(format!("mix amount {amount} is not finite")));
            }
            Mat::Mix {
                materials: [materials[0] as u32, materials[1] as u32],
                amount: *amount as f32,
            }
        }
        Material::Interface => Mat::Interface,
        Material::Hair {
            absorption,
            eta,
            beta_m,
            beta_n,
            alpha_deg,
        } => {
            if !(eta.is_finite() && *eta > 0.0) {
                return Err(err(format!("hair eta {eta} must be > 0")));
            }
            if !(beta_m.is_finite() && beta_n.is_finite() && alpha_deg.is_finite()) {
                return Err(err(format!(
                    "hair beta_m {beta_m}, beta_n {beta_n} and alpha {alpha_deg} must be finite"
                )));
            }
            let (tex, from_color) = match absorption {
                HairAbsorption::SigmaA(t) => (t, false),
                HairAbsorption::Color(t) => (t, true),
            };
            Mat::Hair {
                absorption: compile_texture(tex, mi, ws, tables, images)?,
                from_color,
                eta: *eta as f32,
                beta_m: beta_m.clamp(0.01, 1.0) as f32,
                beta_n: beta_n.clamp(0.01, 1.0) as f32,
                alpha_deg: *alpha_deg as f32,
            }
        }
        Material::VaryingRoughness {
            material,
            u,
            v,
            remap,
        } => {
            if *material >= n_materials {
                return Err(err(format!(
                    "varying roughness refers to material {material} but the scene has {n_materials}"
                )));
            }
            Mat::VaryingRoughness {
                base: *material as u32,
                u: compile_float_texture(u, mi)?,
                v: compile_float_texture(v, mi)?,
                remap: *remap,
            }
        }
        Material::Bumped {
            material,
            perturbation,
        } => {
            if *material >= n_materials {
                return Err(err(format!(
                    "bump map refers to material {material} but the scene has {n_materials}"
                )));
            }
            Mat::Bumped {
                base: *material as u32,
                perturb: crate::bump::compile(perturbation, mi)?,
            }
        }
        Material::MediumInterface { material, .. } => {
            if *material >= n_materials {
                return Err(err(format!(
                    "medium boundary refers to material {material} but the scene has {n_materials}"
                )));
            }
            Mat::MediumBoundary {
                base: *material as u32,
            }
        }
        Material::AlphaMasked { material, alpha } => {
            if *material >= n_materials {
                return Err(err(format!(
                    "alpha mask refers to material {material} but the scene has {n_materials}"
                )));
            }
            Mat::AlphaMasked {
                base: *material as u32,
                alpha: compile_float_texture(alpha, mi)?,
            }
        }
    })
}

/// Refuse `mix` (and alpha-mask) materials that (through others) contain themselves.
pub(crate) fn check_mix_cycles(materials: &[Mat]) -> Result<(), RenderError> {
    // 0 = unvisited, 1 = on the stack, 2 = done (iterative depth-first search).
    let mut state = vec![0u8; materials.len()];
    for start in 0..materials.len() {
        if state[start] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = 1;
        while let Some(&mut (node, ref mut next)) = stack.last_mut() {
            let children: &[u32] = match &materials[node] {
                Mat::Mix { materials, .. } => materials,
                Mat::AlphaMasked { base, .. }
                | Mat::VaryingRoughness { base, .. }
                | Mat::Bumped { base, .. }
                | Mat::MediumBoundary { base } => std::slice::from_ref(base),
                _ => &[],
            };
            if *next < children.len() {
                let c = children[*next] as usize;
                *next += 1;
                match state[c] {
                    0 => {
                        state[c] = 1;
                        stack.push((c, 0));
                    }
                    1 => {
                        return Err(RenderError::Material {
                            index: node,
                            message: "mix materials form a cycle".into(),
                        })
                    }
                    _ => {}
                }
            } else {
                state[node] = 2;
                stack.pop();
            }
        }
    }
    Ok(())
}
