//! Object and material id maps of a render: for each pixel, which shape and which material the
//! ray through the pixel centre meets first (the same ray as the depth map), the ground truth of
//! segmentation datasets.
//!
//! Ids are 1-based indices into the scene's shapes and materials (`SceneDescription::shapes`,
//! `SceneDescription::materials`); 0 is "no surface" (the ray escapes). The legend names each id:
//! the shape's name (pbrt `Attribute "shape" "string name"`, or the built-in scenes' names) or
//! `shape N`; the material's `MakeNamedMaterial` name or `material N`.

use crate::scene::{Material, SceneDescription};
use std::collections::BTreeMap;

/// What each id of an [`IdMaps`] stands for (only the ids present in the image).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct IdLegend {
    /// The id of "no surface": 0.
    pub background: u32,
    /// How the ids are defined.
    pub note: &'static str,
    /// Object id -> shape name.
    pub objects: BTreeMap<u32, String>,
    /// Material id -> material name.
    pub materials: BTreeMap<u32, String>,
}

/// Per-pixel object and material ids, row-major, with their legend.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdMaps {
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// 1 + index of the shape met first through each pixel centre; 0 where the ray escapes.
    pub object_id: Vec<u32>,
    /// 1 + index of that shape's material; 0 where the ray escapes.
    pub material_id: Vec<u32>,
    /// Name of object id `k` at index `k - 1`.
    pub objects: Vec<String>,
    /// Name of material id `k` at index `k - 1`.
    pub materials: Vec<String>,
}

impl IdMaps {
    /// The id maps of `scene` from its per-pixel object ids (1-based shape index, 0 = none).
    pub fn from_object_ids(
        scene: &SceneDescription,
        width: usize,
        height: usize,
        object_id: Vec<u32>,
    ) -> IdMaps {
        let material_id = object_id
            .iter()
            .map(
                |&o| match o.checked_sub(1).and_then(|s| scene.shapes.get(s as usize)) {
                    Some(shape) => surface_material(scene, shape.material) as u32 + 1,
                    None => 0,
                },
            )
            .collect();
        let objects = scene
            .shapes
            .iter()
            .enumerate()
            .map(|(i, s)| s.name.clone().unwrap_or_else(|| format!("shape {i}")))
            .collect();
        let mut materials: Vec<String> = (0..scene.materials.len())
            .map(|i| format!("material {i}"))
            .collect();
        // Named materials keep their names; one material under several names lists them all.
        let mut named: Vec<(&String, &usize)> = scene.named_materials.iter().collect();
        named.sort();
        for (name, &i) in named {
            if let Some(m) = materials.get_mut(i) {
                *m = if m.starts_with("material ") {
                    name.clone()
                } else {
                    format!("{m}, {name}")
                };
            }
        }
        IdMaps {
            width,
            height,
            object_id,
            material_id,
            objects,
            materials,
        }
    }

    /// The legend of the ids that appear in the image (serializes as
    /// `{"background": 0, "objects": {"1": name, ...}, "materials": {...}, "note": ...}`).
    pub fn legend(&self) -> IdLegend {
        let used = |ids: &[u32], names: &[String]| -> BTreeMap<u32, String> {
            let mut seen = vec![false; names.len() + 1];
            for &i in ids {
                if let Some(s) = seen.get_mut(i as usize) {
                    *s = true;
                }
            }
            (1..seen.len())
                .filter(|&k| seen[k])
                .map(|k| (k as u32, names[k - 1].clone()))
                .collect()
        };
        IdLegend {
            background: 0,
            note: "object_id / material_id = 1 + index of the shape / material met first by the ray through each pixel centre; 0 = the ray escapes",
            objects: used(&self.object_id, &self.objects),
            materials: used(&self.material_id, &self.materials),
        }
    }

    /// The largest id in either map.
    pub fn max_id(&self) -> u32 {
        self.object_id
            .iter()
            .chain(&self.material_id)
            .copied()
            .max()
            .unwrap_or(0)
    }
}

/// The material a shape's surface is made of: an alpha cut-out or a medium boundary wraps the
/// shape's material ([`Material::AlphaMasked`], [`Material::MediumInterface`]) without being
/// one, so its id is the wrapped material's.
pub(crate) fn surface_material(scene: &SceneDescription, mut m: usize) -> usize {
    // Wrappers nest at most once per shape; the bound only guards against a malformed scene.
    for _ in 0..8 {
        match scene.materials.get(m) {
            Some(
                Material::AlphaMasked { material, .. } | Material::MediumInterface { material, .. },
            ) => m = *material,
            _ => break,
        }
    }
    m
}
