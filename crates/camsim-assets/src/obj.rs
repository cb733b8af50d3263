//! Wavefront OBJ and MTL -> [`SceneDescription`], through the `tobj` crate (tinyobjloader's
//! rules: polygons triangulated as fans, negative indices relative to the end, `o` and `g`
//! starting objects).
//!
//! What is read (also `docs/src/assets.md`):
//! - `v` (with optional vertex colours `v x y z r g b`: per-vertex linear factors of the base
//!   colour, interpolated over each triangle as glTF's `COLOR_0`; NaN reads as white), `vt`, `vn`, `f` (any polygon; a face of fewer than three vertices is
//!   dropped), negative indices, `o` and `g` (each its own object instance, named after it),
//!   `mtllib` / `usemtl` (a missing `.mtl` gives grey materials with a note).
//! - MTL, read as the glTF metallic-roughness material ([`GltfPbr`], so OBJ and glTF assets
//!   shade alike): `Kd` (base colour) and `map_Kd` (sRGB), `Ks` (its mean is the specular
//!   weight; absent: 0, no specular), `Ns` (roughness `1 - sqrt(Ns / 1000)` when `Pr` is
//!   absent, Blender's importer's mapping), `Ni` (ior), `d` / `Tr` and `map_d` (alpha,
//!   stochastic), `illum` 4, 6, 7, 9 (glass: a dielectric of index `Ni`), `Ke` (emission in
//!   cd/m^2 as glTF's emissive strength; two-sided, as Blender and most tools emit from both
//!   faces) and `map_Ke`; the PBR extension `Pr`, `Pm` (metallic), `map_Pr`, `map_Pm`;
//!   `norm` and `map_Bump` / `bump` (`-bm` scale) images that hold tangent-space normals as
//!   normal maps, in the frame of MikkTSpace tangents (`crate::tangents`; a height-map bump is
//!   noted and not applied); `map_Ks`, `map_Ns`, `Ps`, `Pc`, `Pcr`, `aniso` noted and not read.
//! - Units and axes: none in OBJ: `ReadOptions::obj_scale_m` (default 1 m per unit) and
//!   `ReadOptions::obj_up_axis` (default Y).

use crate::texture::DecodedImage;
use crate::units::photometric_spectrum;
use crate::{AssetError, ReadOptions, Result};
use camsim_core::mem::MemoryBudget;
use camsim_core::Spectrum;
use camsim_scene3d::{
    AreaLight, FloatTexture, Geometry, GltfPbr, Material, NormalPerturbation, SceneDescription,
    Shape, ShapeTags, TexelFilter, Texture, Transform, WrapMode,
};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Read an OBJ file (and its MTL files) as a scene with the framing camera.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<SceneDescription> {
    let err = |m: String| AssetError::new(path, m);
    if !(opts.obj_scale_m > 0.0 && opts.obj_scale_m.is_finite()) {
        return Err(err(format!(
            "scale {} m per unit must be > 0",
            opts.obj_scale_m
        )));
    }
    let size = std::fs::metadata(path)
        .map_err(|e| err(format!("cannot open: {e}")))?
        .len();
    // tobj keeps positions, uvs and normals as f32 and the index lists; camsim's copy is f64:
    // about 4x the text in all.
    MemoryBudget::new(format!("reading {}", path.display()))
        .bytes("the mesh", size.saturating_mul(4))
        .check("split the asset")
        .map_err(|e| err(e.to_string()))?;
    let lo = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let raw = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let text = clean_obj_text(&String::from_utf8_lossy(&raw));
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mtl_dir = dir.clone();
    let (models, mtl) = tobj::load_obj_buf(&mut text.as_bytes(), &lo, |p| {
        tobj::load_mtl(mtl_dir.join(p))
    })
    .map_err(|e| {
        let line = first_bad_line(&text)
            .map(|(n, l)| format!(" (line {n} after joining continued lines: {l:?})"))
            .unwrap_or_default();
        err(format!("cannot read the OBJ: {e}{line}"))
    })?;
    let mut notes = BTreeSet::new();
    let materials = match mtl {
        Ok(m) => m,
        Err(e) => {
            if text.lines().any(|l| l.trim_start().starts_with("mtllib")) {
                notes.insert(format!(
                    "OBJ: its mtllib could not be read ({e}); grey materials are used"
                ));
            }
            Vec::new()
        }
    };
    let frame = opts
        .obj_up_axis
        .to_y_up()
        .then_apply_to(&Transform::scale([opts.obj_scale_m; 3]));
    let mut b = MtlBuilder {
        dir,
        path: path.to_path_buf(),
        materials: Vec::new(),
        named: HashMap::new(),
        cache: HashMap::new(),
        images: HashMap::new(),
        notes,
    };
    let mut shapes = Vec::new();
    // Instances by object name: `g` groups of one name (and the faces after a repeated `o`)
    // are one instance.
    let mut instance_of: HashMap<String, u32> = HashMap::new();
    for (mi, m) in models.iter().enumerate() {
        let mesh = &m.mesh;
        let nv = mesh.positions.len() / 3;
        if nv == 0 || mesh.indices.len() < 3 {
            continue;
        }
        let what = format!("object {:?}", m.name);
        let positions: Vec<[f64; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| frame.apply_point([p[0] as f64, p[1] as f64, p[2] as f64]))
            .collect();
        if let Some(i) = positions
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(err(format!("{what}: vertex {} is not finite", i + 1)));
        }
        let mut indices: Vec<[u32; 3]> = mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        if let Some(bad) = indices.iter().flatten().find(|&&i| i as usize >= nv) {
            return Err(err(format!(
                "{what}: index {bad} is past its {nv} vertices"
            )));
        }
        indices.retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
        if indices.is_empty() {
            continue;
        }
        let normals = (mesh.normals.len() == 3 * nv).then(|| {
            mesh.normals
                .chunks_exact(3)
                .map(|n| {
                    let v = frame.apply_vector([n[0] as f64, n[1] as f64, n[2] as f64]);
                    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    if l > 0.0 {
                        v.map(|x| x / l)
                    } else {
                        [0.0, 1.0, 0.0]
                    }
                })
                .collect::<Vec<_>>()
        });
        let uvs = (mesh.texcoords.len() == 2 * nv).then(|| {
            mesh.texcoords
                .chunks_exact(2)
                .map(|t| [t[0], t[1]])
                .collect::<Vec<_>>()
        });
        // Vertex colours (`v x y z r g b`): per vertex, linear factors of the base colour as
        // glTF's COLOR_0; a colour that is not finite (NaN) reads as white, with a note.
        let colors = (mesh.vertex_color.len() == 3 * nv).then(|| {
            let mut bad = 0usize;
            let c: Vec<[f32; 4]> = mesh
                .vertex_color
                .chunks_exact(3)
                .map(|c| {
                    if c.iter().all(|v| v.is_finite()) {
                        [c[0], c[1], c[2], 1.0]
                    } else {
                        bad += 1;
                        [1.0; 4]
                    }
                })
                .collect();
            if bad > 0 {
                b.notes.insert(format!(
                    "OBJ: {what}: {bad} vertex colours are not finite (NaN) and read as white"
                ));
            }
            c
        });
        let (material, area_light) =
            b.material(mesh.material_id.map(|i| (i, &materials)), colors.is_some())?;
        let name = if m.name.is_empty() || m.name == "unnamed_object" {
            format!("object{mi}")
        } else {
            m.name.clone()
        };
        let next = instance_of.len() as u32;
        let inst = *instance_of.entry(name.clone()).or_insert(next);
        let mut geometry = Geometry::mesh(positions, indices, uvs, normals);
        if let Geometry::Triangles { colors: slot, .. } = &mut geometry {
            *slot = colors;
        }
        // A normal map's tangent frame: MikkTSpace tangents (OBJ has no tangents; OBJ's v runs
        // up the image as camsim's does), else dp/du with a note.
        if normal_mapped(&b.materials, material)
            && !crate::tangents::mikktspace(&mut geometry, false)
        {
            b.notes.insert(format!(
                "OBJ: {what}: MikkTSpace found no tangents (no uvs?); the normal map's frame is dp/du"
            ));
        }
        shapes.push(Shape {
            name: Some(name),
            geometry,
            material,
            area_light,
            reverse_orientation: false,
            tags: ShapeTags {
                category: None,
                instance: Some(inst),
                object_to_world: Some(frame),
                light_group: None,
                keypoints: None,
            },
        });
    }
    let mut scene = SceneDescription {
        camera: crate::framing_camera([0.0; 3], [0.0; 3], opts.width),
        shapes,
        materials: std::mem::take(&mut b.materials),
        named_materials: std::mem::take(&mut b.named),
        lights: Vec::new(),
        settings: Default::default(),
        focus_distance_m: None,
        notes: Vec::new(),
        media: Default::default(),
        light_groups: Vec::new(),
    };
    scene.settings.time.shutter.open_s = 0.0;
    scene.settings.time.shutter.close_s = 0.0;
    let (lo, hi) = crate::scene_bounds(&scene);
    scene.camera = crate::framing_camera(lo, hi, opts.width);
    b.notes.insert(
        "OBJ: the file has no camera; camsim's framing camera looks at the scene (40 deg vertical field from +z, raised 20 deg)".into(),
    );
    scene.notes = b.notes.into_iter().collect();
    Ok(scene)
}

/// The OBJ text as tobj takes it: lines continued by a trailing `\\` joined (the OBJ
/// specification allows them; Rhino writes them) and `usemtl` statements without a name (the
/// default material) dropped.
fn clean_obj_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut pending = String::new();
    for line in text.lines() {
        let l = line.trim_end();
        if let Some(head) = l.strip_suffix('\\') {
            pending.push_str(head);
            pending.push(' ');
            continue;
        }
        pending.push_str(l);
        let t = pending.trim();
        if !(t == "usemtl" || t.starts_with("usemtl ") && t[6..].trim().is_empty()) {
            out.push_str(&pending);
        }
        out.push('\n');
        pending.clear();
    }
    out.push_str(&pending);
    out
}

/// The first line that is not a plain OBJ statement with numbers where numbers belong, for an
/// error message (tobj's errors do not say where).
fn first_bad_line(text: &str) -> Option<(usize, String)> {
    for (n, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        let ok = match w.next() {
            None => true,
            Some(s) if s.starts_with('#') => true,
            Some("v" | "vt" | "vn" | "vp") => w.all(|x| x.parse::<f64>().is_ok()),
            Some("f" | "l" | "p") => w.all(|x| {
                x.split('/')
                    .all(|i| i.is_empty() || i.parse::<i64>().is_ok_and(|v| v != 0))
            }),
            Some(
                "o" | "g" | "s" | "mtllib" | "usemtl" | "cstype" | "deg" | "curv" | "parm" | "end"
                | "surf",
            ) => true,
            Some(_) => false,
        };
        if !ok {
            return Some((n + 1, line.chars().take(80).collect()));
        }
    }
    None
}

/// Material `i` (or the one under its alpha mask) is normal-mapped.
fn normal_mapped(materials: &[Material], mut i: usize) -> bool {
    for _ in 0..4 {
        match materials.get(i) {
            Some(Material::Bumped {
                perturbation: NormalPerturbation::NormalMap(_),
                ..
            }) => return true,
            Some(Material::AlphaMasked { material, .. }) => i = *material,
            _ => return false,
        }
    }
    false
}

struct MtlBuilder {
    dir: PathBuf,
    path: PathBuf,
    materials: Vec<Material>,
    named: HashMap<String, usize>,
    cache: crate::MaterialCache,
    images: HashMap<String, Arc<DecodedImage>>,
    notes: BTreeSet<String>,
}

/// A map statement's file name and its `-bm` value (other options skipped: `-o`, `-s`, `-t`
/// take 1-3 numbers, `-mm` 2, the rest 1).
fn map_args(spec: &str) -> (String, f64) {
    let words: Vec<&str> = spec.split_whitespace().collect();
    let mut i = 0;
    let mut bm = 1.0;
    while i < words.len() && words[i].starts_with('-') && words[i].len() > 1 {
        let opt = words[i];
        i += 1;
        let max_args = match opt {
            "-o" | "-s" | "-t" => 3,
            "-mm" => 2,
            _ => 1,
        };
        let mut taken = 0;
        while taken < max_args
            && i < words.len()
            && (words[i].parse::<f64>().is_ok() || matches!(words[i], "on" | "off"))
        {
            if opt == "-bm" && taken == 0 {
                bm = words[i].parse().unwrap_or(1.0);
            }
            i += 1;
            taken += 1;
        }
    }
    (words[i.min(words.len())..].join(" "), bm)
}

impl MtlBuilder {
    fn err(&self, m: String) -> AssetError {
        AssetError::new(&self.path, m)
    }

    fn image(&mut self, name: &str, what: &str) -> Result<Arc<DecodedImage>> {
        if let Some(i) = self.images.get(name) {
            return Ok(i.clone());
        }
        let p = self.dir.join(name.replace('\\', "/"));
        let i = Arc::new(DecodedImage::open(&p).map_err(|e| {
            self.err(format!(
                "{what} wants {} ({name:?}), which cannot be read: {e}",
                p.display()
            ))
        })?);
        self.images.insert(name.to_string(), i.clone());
        Ok(i)
    }

    fn float_map(
        &mut self,
        name: &str,
        what: &str,
        ch: usize,
        factor: f64,
    ) -> Result<FloatTexture> {
        let img = self.image(name, what)?;
        Ok(img.channel(ch, factor, |v| v, WrapMode::Repeat, TexelFilter::Bilinear))
    }

    fn material(
        &mut self,
        m: Option<(usize, &Vec<tobj::Material>)>,
        vertex_colored: bool,
    ) -> Result<(usize, Option<AreaLight>)> {
        let key = (m.map(|(i, _)| i), vertex_colored);
        if let Some(v) = self.cache.get(&key) {
            return Ok(v.clone());
        }
        let mtl = m.and_then(|(i, all)| all.get(i));
        let label = mtl.map_or("default".to_string(), |m| m.name.clone());
        let what = |k: &str| format!("material {label:?} {k}");
        let p = |k: &str| -> Option<f64> {
            mtl.and_then(|m| m.unknown_param.get(k))
                .and_then(|v| v.split_whitespace().next()?.parse().ok())
        };
        let kd = mtl
            .and_then(|m| m.diffuse)
            .map(|c| c.map(|v| v as f64))
            .unwrap_or([0.8; 3]);
        let image = match mtl.and_then(|m| m.diffuse_texture.clone()) {
            Some(spec) => {
                let (name, _) = map_args(&spec);
                let img = self.image(&name, &what("map_Kd"))?;
                Some(img.base_color(kd, WrapMode::Repeat, TexelFilter::Bilinear))
            }
            None => None,
        };
        // Base colour = Kd x map_Kd x the vertex colour (glTF's rule).
        let base_color = crate::texture::base_color(image, kd, vertex_colored);
        let rough_from_ns = mtl
            .and_then(|m| m.shininess)
            .map(|ns| 1.0 - (ns.clamp(0.0, 1000.0) as f64 / 1000.0).sqrt());
        let roughness = match mtl.and_then(|m| m.unknown_param.get("map_Pr")).cloned() {
            Some(spec) => self.float_map(
                &map_args(&spec).0,
                &what("map_Pr"),
                0,
                p("Pr").unwrap_or(1.0),
            )?,
            None => {
                FloatTexture::Constant(p("Pr").or(rough_from_ns).unwrap_or(1.0).clamp(0.0, 1.0))
            }
        };
        let metallic = match mtl.and_then(|m| m.unknown_param.get("map_Pm")).cloned() {
            Some(spec) => self.float_map(
                &map_args(&spec).0,
                &what("map_Pm"),
                0,
                p("Pm").unwrap_or(1.0),
            )?,
            None => FloatTexture::Constant(p("Pm").unwrap_or(0.0).clamp(0.0, 1.0)),
        };
        let specular = mtl
            .and_then(|m| m.specular)
            .map(|k| ((k[0] + k[1] + k[2]) as f64 / 3.0).clamp(0.0, 1.0))
            .unwrap_or(0.0);
        let mut ior = mtl
            .and_then(|m| m.optical_density)
            .map(|v| v as f64)
            .unwrap_or(1.5);
        if !(ior >= 1.0 && ior.is_finite()) {
            self.notes.insert(format!(
                "OBJ: {}: Ni {ior} below 1 is read as 1.5",
                what("Ni")
            ));
            ior = 1.5;
        }
        for k in [
            "map_Ks", "map_Ns", "Ps", "Pc", "Pcr", "aniso", "anisor", "map_Ke",
        ] {
            let present = match k {
                "map_Ks" => mtl.is_some_and(|m| m.specular_texture.is_some()),
                "map_Ns" => mtl.is_some_and(|m| m.shininess_texture.is_some()),
                _ => p(k).is_some_and(|v| v != 0.0 && !(k == "Pcr" && p("Pc") == Some(0.0))),
            };
            if present {
                self.notes
                    .insert(format!("OBJ: MTL statement {k} is not read"));
            }
        }
        let illum = mtl.and_then(|m| m.illumination_model).unwrap_or(2);
        let mut mat = if matches!(illum, 4 | 6 | 7 | 9) {
            Material::Dielectric {
                eta: Spectrum::from_pairs(&[(300.0, ior), (900.0, ior)]),
                roughness: camsim_scene3d::Roughness::SMOOTH,
            }
        } else {
            Material::GltfPbr(Box::new(GltfPbr {
                base_color,
                metallic,
                roughness,
                specular: FloatTexture::Constant(specular),
                specular_color: Texture::Constant(Spectrum::from_pairs(&[
                    (300.0, 1.0),
                    (900.0, 1.0),
                ])),
                ior,
            }))
        };
        // Normal maps (`norm`, or `map_Bump` holding tangent-space normals).
        let bump = mtl.and_then(|m| {
            m.unknown_param
                .get("norm")
                .cloned()
                .or(m.normal_texture.clone())
        });
        if let Some(spec) = bump {
            let (name, bm) = map_args(&spec);
            let img = self.image(&name, &what("normal map"))?;
            let mean = img.rgba.iter().fold([0.0f64; 3], |a, p| {
                [a[0] + p[0] as f64, a[1] + p[1] as f64, a[2] + p[2] as f64]
            });
            let n = img.rgba.len().max(1) as f64;
            let (mr, mg, mb) = (mean[0] / n, mean[1] / n, mean[2] / n);
            if mb > 0.7 && (mr - 0.5).abs() < 0.15 && (mg - 0.5).abs() < 0.15 {
                let normals = img.normal_map(bm as f32);
                self.materials.push(mat);
                mat = Material::Bumped {
                    material: self.materials.len() - 1,
                    perturbation: NormalPerturbation::NormalMap(Arc::new(normals)),
                };
            } else {
                self.notes.insert(format!(
                    "OBJ: {} {name:?} is a height map; height bumps are not applied",
                    what("bump")
                ));
            }
        }
        // Alpha: d, or 1 - Tr; map_d's first channel. `Tr 1` alone (no `d`) would make the
        // material invisible; MeshLab and other exporters write it for opaque materials (Tr as
        // an opacity), so it is read as opaque, with a note.
        let tr = p("Tr");
        if mtl.and_then(|m| m.dissolve).is_none() && tr.is_some_and(|t| t >= 1.0) {
            self.notes.insert(format!(
                "OBJ: material {label:?}: `Tr 1` without `d` is read as opaque (exporters such as MeshLab write Tr as an opacity; as a transparency it would hide the object); write `d 0` for an invisible material"
            ));
        }
        let d = mtl
            .and_then(|m| m.dissolve)
            .map(|v| v as f64)
            .or(tr.filter(|t| *t < 1.0).map(|t| 1.0 - t))
            .unwrap_or(1.0)
            .clamp(0.0, 1.0);
        let alpha = match mtl.and_then(|m| m.dissolve_texture.clone()) {
            Some(spec) => Some(self.float_map(&map_args(&spec).0, &what("map_d"), 0, d)?),
            None => (d < 1.0).then_some(FloatTexture::Constant(d)),
        };
        self.materials.push(mat);
        let mut idx = self.materials.len() - 1;
        if let Some(alpha) = alpha {
            self.materials.push(Material::AlphaMasked {
                material: idx,
                alpha,
            });
            idx = self.materials.len() - 1;
        }
        if mtl.is_some() {
            self.named.entry(label.clone()).or_insert(idx);
        }
        let ke = mtl
            .and_then(|m| m.emissive)
            .map(|c| c.map(|v| v as f64))
            .unwrap_or([0.0; 3]);
        let area = photometric_spectrum(ke, 1.0).map(|radiance| AreaLight {
            radiance,
            two_sided: true,
            image: None,
        });
        self.cache.insert(key, (idx, area.clone()));
        Ok((idx, area))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_options_are_skipped() {
        assert_eq!(
            map_args("-bm 0.5 normal map.png"),
            ("normal map.png".into(), 0.5)
        );
        assert_eq!(
            map_args("-o 0.1 0.2 -s 2 2 1 tex.png"),
            ("tex.png".into(), 1.0)
        );
        assert_eq!(map_args("-clamp on a.jpg"), ("a.jpg".into(), 1.0));
        assert_eq!(map_args("fuze uv.jpg"), ("fuze uv.jpg".into(), 1.0));
    }
}
