//! Materials compiled for the tracer ([`Mat`]) and the compile step from
//! [`crate::scene::Material`] (validation, spectrum tables, the coatings' layer parameters). Their
//! evaluation at a hit (the per-hit choice of a `mix`, the alpha test, the BSDF at the path's
//! wavelengths) is the tracer's, in `integrator/material_eval.rs`.

use crate::bsdf::TrowbridgeReitz;
use crate::error::RenderError;
use crate::image_tex::ImageTex;
use crate::scene::{ConductorOptics, HairAbsorption, LayerWalk, Material, Roughness};
use crate::spectral::{SpectrumTable, WavelengthSampler};
use crate::texture::{compile_float_texture, compile_texture, FTex, Tex};

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
    /// The glTF 2.0 metallic-roughness material (`crate::bsdf::gltf`), boxed (five textures).
    GltfPbr(Box<GltfMat>),
    /// Material `base` with the roughness `(u, v)` evaluated per hit.
    VaryingRoughness {
        base: u32,
        u: FTex,
        v: FTex,
        remap: bool,
    },
}

/// The glTF 2.0 metallic-roughness material compiled: textures evaluated per hit; `f0_scale`
/// is `((ior - 1) / (ior + 1))^2`.
#[derive(Debug, Clone)]
pub(crate) struct GltfMat {
    pub(crate) base: Tex,
    pub(crate) metallic: FTex,
    pub(crate) roughness: FTex,
    pub(crate) specular: FTex,
    pub(crate) specular_color: Tex,
    pub(crate) f0_scale: f32,
}

/// A coating's layer (pbrt-v4 `LayeredBxDF` parameters), compiled: the medium's albedo texture
/// is evaluated per hit.
#[derive(Debug, Clone)]
pub(crate) struct Walk {
    pub(crate) thickness: f32,
    pub(crate) albedo: Tex,
    pub(crate) g: f32,
    pub(crate) max_depth: u32,
    pub(crate) n_samples: u32,
}

/// A conductor's optical constants, compiled.
#[derive(Debug, Clone)]
pub(crate) enum CondOptics {
    EtaK(u32, u32),
    Reflectance(Tex),
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
    images: &mut Vec<crate::image_tex::ImageTex>,
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
    images: &mut Vec<crate::image_tex::ImageTex>,
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
        Material::GltfPbr(g) => {
            if !(g.ior.is_finite() && g.ior >= 1.0) {
                return Err(err(format!("glTF ior {} must be >= 1", g.ior)));
            }
            let r0 = (g.ior - 1.0) / (g.ior + 1.0);
            Mat::GltfPbr(Box::new(GltfMat {
                base: compile_texture(&g.base_color, mi, ws, tables, images)?,
                metallic: compile_float_texture(&g.metallic, mi)?,
                roughness: compile_float_texture(&g.roughness, mi)?,
                specular: compile_float_texture(&g.specular, mi)?,
                specular_color: compile_texture(&g.specular_color, mi, ws, tables, images)?,
                f0_scale: (r0 * r0) as f32,
            }))
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
