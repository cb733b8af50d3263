//! Material randomization (`[[render.compose.materials]]`): per object, a base colour drawn as a
//! *spectral* reflectance from a set (the 24 ColorChecker patches built in, or any spectra file:
//! camsim is spectral, so it draws spectra, not RGB), or an image texture drawn from a folder,
//! and roughness and metallic drawn from ranges. The object's material becomes the glTF 2.0
//! metallic-roughness material ([`camsim_scene3d::GltfPbr`]) with those inputs; wrappers it had
//! (alpha cut-outs, normal maps, media boundaries) are kept around the new material.
//!
//! One draw per object instance (all shapes of one instance share it), from the keyed stream
//! (seed, [`crate::stage::MATERIALS`], entry and instance), so a draw does not depend on which
//! other objects the scene holds or on the worker count. What was drawn is returned as
//! [`MaterialDraw`]s for the sample's record.

use crate::{stage, stream, ComposeError, Result};
use camsim_core::Spectrum;
use camsim_scene3d::{FloatTexture, GltfPbr, Material, SceneDescription, Texture};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One `[[render.compose.materials]]` entry: which objects, and what to draw for each.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialRandomSpec {
    /// Objects by name, a `*`-wildcard pattern over shape names (`"mug_*"`); default `"*"`:
    /// every named object. Emitters (area lights) are never changed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<String>,
    /// Only objects of these categories (a manifest's or an overlay's `category`); default:
    /// any category, or none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub categories: Vec<String>,
    /// The reflectance set a base colour is drawn from, uniformly: `"macbeth"` (N. Ohta's 24
    /// ColorChecker reflectances, built in) or a spectra file relative to the config (CSV:
    /// `wavelength_nm` then one column per reflectance, fractions 0..1; or an ISETCam `.mat`).
    /// Default: the object keeps its base colour.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectances: Option<String>,
    /// A folder of images (PNG, JPEG, TIFF), one drawn per object as its base-colour texture
    /// (sRGB decoded, tiled over the object's uv); relative to the config. Not with
    /// `reflectances`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub textures: Option<PathBuf>,
    /// Perceptual roughness range `[min, max]` (glTF's, 0..1; GGX alpha = roughness^2), drawn
    /// uniformly; default: the object's own (0.5 where it had none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roughness: Option<[f64; 2]>,
    /// Metalness range `[min, max]` (0..1), drawn uniformly; default: the object's own (0 where
    /// it had none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metallic: Option<[f64; 2]>,
}

/// What one object received.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialDraw {
    /// The object's (first shape's) name.
    pub object: String,
    /// The entry of `[[render.compose.materials]]` that drew it.
    pub entry: usize,
    /// The drawn reflectance: the set and the spectrum's name in it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectance: Option<String>,
    /// The drawn texture file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<PathBuf>,
    /// Drawn perceptual roughness (absent: kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roughness: Option<f64>,
    /// Drawn metalness (absent: kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub metallic: Option<f64>,
}

/// What a checked entry draws from.
enum BaseColours {
    Keep,
    Spectra {
        set: String,
        names: Vec<String>,
        spectra: Vec<Spectrum>,
    },
    Textures(Vec<PathBuf>),
}

fn check_range(key: &str, r: Option<[f64; 2]>) -> Result<()> {
    if let Some([lo, hi]) = r {
        if !(lo >= 0.0 && hi <= 1.0 && lo <= hi) {
            return Err(ComposeError::new(
                key,
                format!("[{lo}, {hi}]: give [min, max] with 0 <= min <= max <= 1"),
            ));
        }
    }
    Ok(())
}

fn base_colours(spec: &MaterialRandomSpec, key: &str, base_dir: &Path) -> Result<BaseColours> {
    match (&spec.reflectances, &spec.textures) {
        (Some(_), Some(_)) => Err(ComposeError::new(
            key,
            "give `reflectances` or `textures`, not both",
        )),
        (None, None) => Ok(BaseColours::Keep),
        (Some(set), None) if set.eq_ignore_ascii_case("macbeth") => Ok(BaseColours::Spectra {
            set: "macbeth".into(),
            names: camsim_core::tables::MACBETH_PATCH_NAMES
                .iter()
                .map(|s| s.to_string())
                .collect(),
            spectra: camsim_core::tables::macbeth_reflectances(),
        }),
        (Some(file), None) => {
            let path = base_dir.join(file);
            let what = format!("{key}.reflectances");
            let table = camsim_core::spectrum_csv::load_spectra(&path)
                .map_err(|e| ComposeError::new(&what, e.to_string()))?;
            let spectra = table
                .spectra()
                .map_err(|e| ComposeError::new(&what, e.to_string()))?;
            if spectra.is_empty() {
                return Err(ComposeError::new(
                    what,
                    format!("{}: holds no spectra", path.display()),
                ));
            }
            for (name, s) in table.names.iter().zip(&spectra) {
                if s.values.iter().any(|v| !(*v >= 0.0 && *v <= 1.0)) {
                    return Err(ComposeError::new(
                        what,
                        format!(
                            "{}: column {name:?} is not a reflectance (values outside 0..1; give fractions, not percent)",
                            path.display()
                        ),
                    ));
                }
            }
            Ok(BaseColours::Spectra {
                set: path.display().to_string(),
                names: table.names.clone(),
                spectra,
            })
        }
        (None, Some(folder)) => {
            let dir = base_dir.join(folder);
            let what = format!("{key}.textures");
            let entries = std::fs::read_dir(&dir).map_err(|e| {
                ComposeError::new(&what, format!("{}: cannot read: {e}", dir.display()))
            })?;
            let mut files: Vec<PathBuf> = entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.extension()
                        .and_then(|e| e.to_str())
                        .map(|e| {
                            matches!(
                                e.to_ascii_lowercase().as_str(),
                                "png" | "jpg" | "jpeg" | "tif" | "tiff"
                            )
                        })
                        .unwrap_or(false)
                })
                .collect();
            // Sorted, so the draw does not depend on the file system's listing order.
            files.sort();
            if files.is_empty() {
                return Err(ComposeError::new(
                    what,
                    format!("{}: no PNG, JPEG or TIFF images in it", dir.display()),
                ));
            }
            Ok(BaseColours::Textures(files))
        }
    }
}

/// The material a wrapper chain ends in (alpha cut-outs, normal maps, media boundaries and
/// varying roughness wrap another material by index).
fn innermost(materials: &[Material], mut m: usize) -> usize {
    for _ in 0..64 {
        match &materials[m] {
            Material::AlphaMasked { material, .. }
            | Material::Bumped { material, .. }
            | Material::MediumInterface { material, .. }
            | Material::VaryingRoughness { material, .. } => m = *material,
            _ => break,
        }
    }
    m
}

/// A copy of the wrapper chain at `m` around `new_inner` (a varying roughness is dropped when the
/// roughness is drawn: the draw replaces it). Returns the new chain's index.
fn rewrap(
    materials: &mut Vec<Material>,
    m: usize,
    new_inner: usize,
    drop_roughness: bool,
) -> usize {
    let wrapped = match materials[m].clone() {
        Material::AlphaMasked { material, alpha } => Material::AlphaMasked {
            material: rewrap(materials, material, new_inner, drop_roughness),
            alpha,
        },
        Material::Bumped {
            material,
            perturbation,
        } => Material::Bumped {
            material: rewrap(materials, material, new_inner, drop_roughness),
            perturbation,
        },
        Material::MediumInterface {
            material,
            inside,
            outside,
        } => Material::MediumInterface {
            material: rewrap(materials, material, new_inner, drop_roughness),
            inside,
            outside,
        },
        Material::VaryingRoughness {
            material,
            u,
            v,
            remap,
        } => {
            let inner = rewrap(materials, material, new_inner, drop_roughness);
            if drop_roughness {
                return inner;
            }
            Material::VaryingRoughness {
                material: inner,
                u,
                v,
                remap,
            }
        }
        _ => return new_inner,
    };
    materials.push(wrapped);
    materials.len() - 1
}

/// The glTF material an object's own material becomes before the draws replace its inputs: a
/// glTF material as it is; a diffuse or coated diffuse one keeps its reflectance as the base
/// colour; anything else starts from a mid-grey dielectric.
fn starting_point(m: &Material) -> GltfPbr {
    let flat = |v: f64| Texture::Constant(Spectrum::from_pairs(&[(300.0, v), (900.0, v)]));
    let mut g = GltfPbr {
        base_color: flat(0.5),
        metallic: FloatTexture::Constant(0.0),
        roughness: FloatTexture::Constant(0.5),
        specular: FloatTexture::Constant(1.0),
        specular_color: flat(1.0),
        ior: 1.5,
    };
    match m {
        Material::GltfPbr(p) => g = (**p).clone(),
        Material::Diffuse { reflectance } | Material::CoatedDiffuse { reflectance, .. } => {
            g.base_color = reflectance.clone()
        }
        _ => {}
    }
    g
}

/// Apply every entry of `specs` to `scene` with the sample's `seed`; relative files resolve
/// against `base_dir`. Errors name the entry's key (`compose.materials.K`).
pub fn apply(
    scene: &mut SceneDescription,
    specs: &[MaterialRandomSpec],
    seed: u64,
    base_dir: &Path,
) -> Result<Vec<MaterialDraw>> {
    let mut draws = Vec::new();
    for (entry, spec) in specs.iter().enumerate() {
        let key = format!("compose.materials.{entry}");
        check_range(&format!("{key}.roughness"), spec.roughness)?;
        check_range(&format!("{key}.metallic"), spec.metallic)?;
        let colours = base_colours(spec, &key, base_dir)?;
        let pattern = spec.objects.as_deref().unwrap_or("*");
        // The matching shapes grouped by object instance, in the order they first appear.
        let mut groups: Vec<(u64, Vec<usize>)> = Vec::new();
        let mut group_of: HashMap<u64, usize> = HashMap::new();
        for (i, s) in scene.shapes.iter().enumerate() {
            let Some(name) = s.name.as_deref() else {
                continue;
            };
            if s.area_light.is_some() || !camsim_pbrt::overlay::glob_match(pattern, name) {
                continue;
            }
            if !spec.categories.is_empty()
                && !s
                    .tags
                    .category
                    .as_ref()
                    .is_some_and(|c| spec.categories.contains(c))
            {
                continue;
            }
            // An instance's key is its id; a shape outside any instance is keyed by its index.
            let k = s
                .tags
                .instance
                .map_or((1u64 << 40) | i as u64, |id| id as u64);
            let g = *group_of.entry(k).or_insert_with(|| {
                groups.push((k, Vec::new()));
                groups.len() - 1
            });
            groups[g].1.push(i);
        }
        if groups.is_empty() {
            return Err(ComposeError::new(
                format!("{key}.objects"),
                format!(
                    "no object matches {pattern:?}{}",
                    if spec.categories.is_empty() {
                        String::new()
                    } else {
                        format!(" in categories {:?}", spec.categories)
                    }
                ),
            ));
        }
        for (k, shapes) in groups {
            let mut rng = stream(seed, stage::MATERIALS, ((entry as u64) << 48) ^ k);
            let mut draw = MaterialDraw {
                object: scene.shapes[shapes[0]].name.clone().unwrap_or_default(),
                entry,
                reflectance: None,
                texture: None,
                roughness: None,
                metallic: None,
            };
            let base_color =
                match &colours {
                    BaseColours::Keep => None,
                    BaseColours::Spectra {
                        set,
                        names,
                        spectra,
                    } => {
                        let j = rng.gen_range(0..spectra.len());
                        draw.reflectance = Some(format!("{set}: {}", names[j]));
                        Some(Texture::Constant(spectra[j].clone()))
                    }
                    BaseColours::Textures(files) => {
                        let j = rng.gen_range(0..files.len());
                        draw.texture = Some(files[j].clone());
                        Some(camsim_assets::base_color_texture(&files[j]).map_err(|e| {
                            ComposeError::new(format!("{key}.textures"), e.to_string())
                        })?)
                    }
                };
            let uniform = |rng: &mut rand_pcg::Pcg64, [lo, hi]: [f64; 2]| {
                if hi > lo {
                    rng.gen_range(lo..hi)
                } else {
                    lo
                }
            };
            draw.roughness = spec.roughness.map(|r| uniform(&mut rng, r));
            draw.metallic = spec.metallic.map(|r| uniform(&mut rng, r));
            // One new material per original material of the object (its shapes may differ).
            let mut made: HashMap<usize, usize> = HashMap::new();
            for i in shapes {
                let original = scene.shapes[i].material;
                let index = match made.get(&original) {
                    Some(&m) => m,
                    None => {
                        let inner = innermost(&scene.materials, original);
                        let mut g = starting_point(&scene.materials[inner]);
                        if let Some(b) = &base_color {
                            g.base_color = b.clone();
                        }
                        if let Some(r) = draw.roughness {
                            g.roughness = FloatTexture::Constant(r);
                        }
                        if let Some(m) = draw.metallic {
                            g.metallic = FloatTexture::Constant(m);
                        }
                        scene.materials.push(Material::GltfPbr(Box::new(g)));
                        let new_inner = scene.materials.len() - 1;
                        let m = rewrap(
                            &mut scene.materials,
                            original,
                            new_inner,
                            draw.roughness.is_some(),
                        );
                        made.insert(original, m);
                        m
                    }
                };
                scene.shapes[i].material = index;
            }
            draws.push(draw);
        }
    }
    Ok(draws)
}
