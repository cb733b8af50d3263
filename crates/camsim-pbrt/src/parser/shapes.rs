//! `Shape`: one function per pbrt-v4 shape kind building its object-space [`Geometry`], then
//! the shape moved to world space, with its alpha, material, area light and medium, and added to
//! the scene or to the object being defined.

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

use super::super::params::ParamList;
use super::super::xform::{self, apply_normal, cross, det3, dot, inverse, sub};
use super::super::{ply, Loc, PbrtError};
use super::{PendingShape, SceneBuilder};
use crate::scene::{FloatTexture, Geometry, Shape, Transform};
use std::path::Path;

/// The shape kinds `Shape` accepts.
const SHAPE_KINDS: &str =
    "trianglemesh, bilinearmesh, plymesh, sphere, disk, cylinder, loopsubdiv, curve";

/// A shape's `alpha`: the whole shape is cut out (a constant 0), and the alpha tested per hit
/// (see [`PendingShape::alpha`]).
type Alpha = (bool, Option<(String, FloatTexture)>);

impl SceneBuilder {
    /// `Shape "ty" ...` at `loc` in `file`.
    pub(super) fn shape(
        &mut self,
        ty: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<(), PbrtError> {
        let ctm = self.gs.ctm;
        let inv =
            inverse(&ctm).ok_or_else(|| loc.err("Shape: the current transform is singular"))?;
        let (cut_out, alpha) = self.shape_alpha(params)?;
        self.ignore_params(params, &["faceIndices", "S", "emissionfilename"], "Shape");
        let geometry = match ty {
            "trianglemesh" | "bilinearmesh" => self.polygon_mesh(ty, params, loc)?,
            "plymesh" => self.ply_mesh(params, loc, file)?,
            "sphere" => sphere(params, loc)?,
            "disk" => crate::shapes::disk(
                params.float("height", 0.0)?,
                params.float("radius", 1.0)?,
                params.float("innerradius", 0.0)?,
                params.float("phimax", 360.0)?,
            )
            .map_err(|e| loc.err(format!("Shape \"disk\": {e}")))?,
            "cylinder" => crate::shapes::cylinder(
                params.float("radius", 1.0)?,
                params.float("zmin", -1.0)?,
                params.float("zmax", 1.0)?,
                params.float("phimax", 360.0)?,
            )
            .map_err(|e| loc.err(format!("Shape \"cylinder\": {e}")))?,
            "loopsubdiv" => loop_subdiv(params, loc)?,
            "curve" => {
                if self.gs.area_light.is_some() {
                    return Err(loc.err("Shape \"curve\": an area light on a curve is not supported (pbrt-v4 cannot sample curves either)"));
                }
                self.curve(params, loc)?
            }
            other => {
                return Err(loc.err(format!(
                    "Shape \"{other}\" is not supported ({SHAPE_KINDS})"
                )))
            }
        };
        params.check_unused(&format!("Shape \"{ty}\""))?;
        let (geometry, reverse_orientation) =
            self.to_world(geometry, &ctm, &inv, alpha.is_none(), ty, loc)?;
        if cut_out {
            self.note(
                loc,
                format!("Shape \"{ty}\" with alpha 0 is invisible: dropped"),
            );
            return Ok(());
        }
        let shape = Shape {
            name: self.gs.name.clone(),
            geometry,
            material: 0,
            area_light: None,
            reverse_orientation,
            tags: camsim_scene3d::ShapeTags {
                category: None,
                object_to_world: Some(ctm),
                ..Default::default()
            },
        };
        let pending = PendingShape {
            shape,
            mat: self.gs.material.clone(),
            light: self.gs.area_light.clone(),
            single: matches!(ty, "disk" | "cylinder"),
            alpha,
            medium: self.gs.medium.clone(),
            motion: self.ctm_motion(loc)?,
        };
        self.add_shape(pending, loc)
    }

    /// Alpha (pbrt-v4 4th ed. §7.1.1): a constant 1 is opaque; a constant 0 cuts the whole
    /// shape out (dropped, exactly what pbrt-v4's alpha test does for every hit); a fraction
    /// or a float texture is tested per hit by the tracer (`Material::AlphaMasked`).
    fn shape_alpha(&mut self, params: &ParamList) -> Result<Alpha, PbrtError> {
        let mut cut_out = false;
        let mut alpha = None;
        if let Some(p) = params.get("alpha", &["float", "texture"])? {
            let key = format!(
                "{} {:?}",
                p.ty,
                p.strings().ok().or_else(|| p
                    .nums()
                    .ok()
                    .map(|v| v.iter().map(|x| x.to_string()).collect()))
            );
            let tex = self.float_texture_param(params, "alpha", 1.0)?;
            match (p.ty.as_str(), &tex) {
                (_, FloatTexture::Constant(a)) if *a >= 1.0 => {}
                ("float", FloatTexture::Constant(a)) if *a <= 0.0 => cut_out = true,
                (_, FloatTexture::Constant(a)) if !a.is_finite() => {
                    return Err(p.loc.err(format!("Shape: alpha {a} is not finite")));
                }
                // On an area light the mask also gates its emission (pbrt-v4
                // `DiffuseAreaLight::AlphaMasked`, applied by the renderer to hits and samples).
                _ => alpha = Some((key, tex)),
            }
        }
        Ok((cut_out, alpha))
    }

    /// `trianglemesh` (`P`, `indices`, `uv`, `N`) and `bilinearmesh` (the same with four
    /// indices per patch; each patch becomes two triangles).
    fn polygon_mesh(
        &mut self,
        ty: &str,
        params: &ParamList,
        loc: &Loc,
    ) -> Result<Geometry, PbrtError> {
        let per = if ty == "trianglemesh" { 3 } else { 4 };
        let p = params
            .tuples("P", &["point3"], 3)?
            .ok_or_else(|| loc.err(format!("Shape \"{ty}\": no \"point3 P\"")))?;
        let idx = mesh_indices(ty, params, per, p.len(), loc)?;
        let uv = params.tuples("uv", &["point2"], 2)?;
        let n = params.tuples("N", &["normal3"], 3)?;
        if let Some(uv) = &uv {
            if uv.len() != p.len() {
                return Err(loc.err(format!(
                    "Shape \"{ty}\": {} uv for {} vertices",
                    uv.len(),
                    p.len()
                )));
            }
        }
        if let Some(n) = &n {
            if n.len() != p.len() {
                return Err(loc.err(format!(
                    "Shape \"{ty}\": {} normals for {} vertices",
                    n.len(),
                    p.len()
                )));
            }
        }
        let (mut p, mut uv, mut n, mut idx) = (p, uv, n, idx);
        if per == 4 && uv.is_none() {
            (p, uv, n, idx) = bilinear_patch_uv(p, n, &idx);
        }
        let tris: Vec<[u32; 3]> = if per == 3 {
            idx.chunks(3)
                .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32])
                .collect()
        } else {
            // pbrt-v4 bilinear patch vertices p00 p10 p01 p11; perimeter p00 p10 p11 p01.
            self.note(
                loc,
                "bilinearmesh: each patch is rendered as two triangles (exact for planar patches)",
            );
            idx.chunks(4)
                .flat_map(|c| {
                    [
                        [c[0] as u32, c[1] as u32, c[3] as u32],
                        [c[0] as u32, c[3] as u32, c[2] as u32],
                    ]
                })
                .collect()
        };
        Ok(Geometry::mesh(
            p.iter().map(|v| [v[0], v[1], v[2]]).collect(),
            tris,
            uv.map(|u| u.iter().map(|v| [v[0] as f32, v[1] as f32]).collect()),
            n.map(|u| u.iter().map(|v| [v[0], v[1], v[2]]).collect()),
        ))
    }

    /// `plymesh`: `filename`, ASCII or binary PLY ([`ply`]); quads become two triangles.
    fn ply_mesh(
        &mut self,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<Geometry, PbrtError> {
        let fname = params
            .string("filename")?
            .ok_or_else(|| loc.err("Shape \"plymesh\": no \"string filename\""))?;
        if params.get("displacement", &["texture", "float"])?.is_some() {
            return Err(loc.err("Shape \"plymesh\": displacement is not supported"));
        }
        self.ignore_params(params, &["edgelength"], "plymesh");
        let path = self.resolve(file, &fname);
        let m = ply::read_ply(&path).map_err(|e| loc.err(format!("Shape \"plymesh\": {e}")))?;
        if m.quads > 0 {
            self.note(
                loc,
                format!(
                    "plymesh {fname}: {} quads rendered as two triangles each",
                    m.quads
                ),
            );
        }
        Ok(Geometry::mesh(m.positions, m.triangles, m.uvs, m.normals))
    }

    /// An object-space shape moved to world space by `ctm` (inverse `inv`); returns the
    /// geometry and its `reverse_orientation`. `uv_free`: the shape has no alpha (with no
    /// emission image either, an emitting sphere's uv does not matter).
    fn to_world(
        &self,
        geometry: Geometry,
        ctm: &Transform,
        inv: &Transform,
        uv_free: bool,
        ty: &str,
        loc: &Loc,
    ) -> Result<(Geometry, bool), PbrtError> {
        let swaps = det3(ctm) < 0.0;
        Ok(match geometry {
            g @ (Geometry::PartialSphere { .. } | Geometry::Curves(_)) => {
                self.transform_whole(g, ctm, ty, loc)?
            }
            Geometry::Sphere { center, radius } => {
                self.sphere_to_world(center, radius, ctm, swaps, uv_free, loc)?
            }
            Geometry::Triangles {
                positions,
                indices,
                uvs,
                normals,
                ..
            } => self.triangles_to_world(positions, indices, uvs, normals, ctm, inv, swaps),
            #[allow(unreachable_patterns)]
            g => (g, false),
        })
    }

    /// A shape moved as a whole by [`xform::transform_shape`] (partial spheres, curves).
    fn transform_whole(
        &self,
        geometry: Geometry,
        ctm: &Transform,
        ty: &str,
        loc: &Loc,
    ) -> Result<(Geometry, bool), PbrtError> {
        let mut s = Shape {
            name: None,
            geometry,
            material: 0,
            area_light: None,
            reverse_orientation: self.gs.reverse_orientation,
            tags: Default::default(),
        };
        xform::transform_shape(&mut s, ctm).map_err(|e| loc.err(format!("Shape \"{ty}\": {e}")))?;
        Ok((s.geometry, s.reverse_orientation))
    }

    /// A full sphere in world space: still a sphere when the CTM only moves and scales it (or
    /// its uv does not matter), else a partial sphere with the full range in its turned frame.
    fn sphere_to_world(
        &self,
        center: [f64; 3],
        radius: f64,
        ctm: &Transform,
        swaps: bool,
        uv_free: bool,
        loc: &Loc,
    ) -> Result<(Geometry, bool), PbrtError> {
        let (c, r) = xform::sphere_under(ctm, center, radius)
            .map_err(|e| loc.err(format!("Shape \"sphere\": {e}")))?;
        let s = r / radius;
        let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|a| {
            let v = ctm.apply_vector(a);
            [v[0] / s, v[1] / s, v[2] / s]
        });
        let turned = (0..3)
            .any(|i| (0..3).any(|k| (axes[i][k] - if i == k { 1.0 } else { 0.0 }).abs() > 1e-12));
        let uv_free_light = self
            .gs
            .area_light
            .as_ref()
            .is_some_and(|l| l.image.is_none())
            && uv_free;
        if turned && !uv_free_light {
            // A rotated (or mirrored) sphere keeps its object frame so that its uv
            // (pbrt-v4: u = phi / 2 pi, v = 1 - theta / pi in the object frame) turns
            // with it: a partial sphere with the full range. Emitters whose emission
            // does not depend on uv (no image, no alpha) stay full spheres (cone
            // sampling; their uv is taken in the world frame).
            let full = Geometry::PartialSphere {
                center,
                radius,
                axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                z_min: -radius,
                z_max: radius,
                phi_max_deg: 360.0,
            };
            self.transform_whole(full, ctm, "sphere", loc)
        } else {
            Ok((
                Geometry::Sphere {
                    center: c,
                    radius: r,
                },
                self.gs.reverse_orientation ^ swaps,
            ))
        }
    }

    /// A triangle mesh in world space. With shading normals each triangle's winding faces them
    /// (pbrt-v4 `Triangle`) and the orientation flag is spent; without, `ReverseOrientation` XOR
    /// a handedness-swapping CTM flips the geometric normal.
    #[allow(clippy::too_many_arguments)]
    fn triangles_to_world(
        &self,
        positions: Vec<[f64; 3]>,
        mut indices: Vec<[u32; 3]>,
        uvs: Option<Vec<[f32; 2]>>,
        normals: Option<Vec<[f64; 3]>>,
        ctm: &Transform,
        inv: &Transform,
        swaps: bool,
    ) -> (Geometry, bool) {
        let positions: Vec<[f64; 3]> = positions.iter().map(|p| ctm.apply_point(*p)).collect();
        match normals {
            Some(ns) => {
                let sign = if self.gs.reverse_orientation {
                    -1.0
                } else {
                    1.0
                };
                let ns: Vec<[f64; 3]> = ns
                    .iter()
                    .map(|n| {
                        let w = apply_normal(inv, *n);
                        [sign * w[0], sign * w[1], sign * w[2]]
                    })
                    .collect();
                // Face each triangle's winding toward its shading normals (pbrt-v4 Triangle).
                for t in indices.iter_mut() {
                    let (a, b, c) = (
                        positions[t[0] as usize],
                        positions[t[1] as usize],
                        positions[t[2] as usize],
                    );
                    let g = cross(sub(b, a), sub(c, a));
                    let s = [0, 1, 2].iter().fold([0.0; 3], |acc, &k| {
                        let n = ns[t[k] as usize];
                        [acc[0] + n[0], acc[1] + n[1], acc[2] + n[2]]
                    });
                    if dot(g, s) < 0.0 {
                        t.swap(1, 2);
                    }
                }
                (Geometry::mesh(positions, indices, uvs, Some(ns)), false)
            }
            None => (
                Geometry::mesh(positions, indices, uvs, None),
                self.gs.reverse_orientation ^ swaps,
            ),
        }
    }

    /// The shape into the object being defined (`ObjectBegin`), or into the scene.
    fn add_shape(&mut self, pending: PendingShape, loc: &Loc) -> Result<(), PbrtError> {
        if let Some((oname, list, _)) = &mut self.current_object {
            if pending.light.is_some() {
                return Err(loc.err(format!(
                    "area lights inside object instances are not supported (object \"{oname}\")"
                )));
            }
            let mut pending = pending;
            if pending.shape.name.is_none() {
                pending.shape.name = Some(oname.clone());
            }
            list.push(pending);
        } else {
            self.shapes.push(pending);
        }
        Ok(())
    }
}

/// A mesh's `indices` (`per` per face, each below `n_vertices`); without them, P must be
/// exactly one face.
fn mesh_indices(
    ty: &str,
    params: &ParamList,
    per: usize,
    n_vertices: usize,
    loc: &Loc,
) -> Result<Vec<i64>, PbrtError> {
    match params.ints("indices")? {
        Some((v, l)) => {
            if v.is_empty() || v.len() % per != 0 {
                return Err(l.err(format!(
                    "Shape \"{ty}\": {} indices is not a multiple of {per}",
                    v.len()
                )));
            }
            if let Some(bad) = v.iter().find(|&&i| i < 0 || i as usize >= n_vertices) {
                return Err(l.err(format!(
                    "Shape \"{ty}\": index {bad} is out of range (0..{n_vertices})"
                )));
            }
            Ok(v)
        }
        None => {
            if n_vertices == per {
                Ok((0..per as i64).collect())
            } else {
                Err(loc.err(format!("Shape \"{ty}\": \"integer indices\" is required unless P has exactly {per} vertices")))
            }
        }
    }
}

/// Vertices, uv, normals and indices of a bilinear mesh.
type PatchMesh = (
    Vec<Vec<f64>>,
    Option<Vec<Vec<f64>>>,
    Option<Vec<Vec<f64>>>,
    Vec<i64>,
);

/// pbrt-v4's bilinear patch without "uv" is parameterized (0,0), (1,0), (0,1), (1,1) at p00,
/// p10, p01, p11, patch by patch: vertices shared between patches are duplicated to carry each
/// patch's own uv (a triangle's default uv would not match).
fn bilinear_patch_uv(op: Vec<Vec<f64>>, on: Option<Vec<Vec<f64>>>, idx: &[i64]) -> PatchMesh {
    let corners = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let mut p = Vec::with_capacity(idx.len());
    let mut uvs = Vec::with_capacity(idx.len());
    let mut normals = on.as_ref().map(|_| Vec::with_capacity(idx.len()));
    for (k, &i) in idx.iter().enumerate() {
        p.push(op[i as usize].clone());
        uvs.push(corners[k % 4].to_vec());
        if let (Some(dst), Some(src)) = (normals.as_mut(), on.as_ref()) {
            dst.push(src[i as usize].clone());
        }
    }
    (p, Some(uvs), normals, (0..idx.len() as i64).collect())
}

/// `sphere`: `radius`, centred at the CTM's origin; `zmin`, `zmax`, `phimax` make it partial.
fn sphere(params: &ParamList, loc: &Loc) -> Result<Geometry, PbrtError> {
    let r = params.float("radius", 1.0)?;
    if !(r > 0.0) {
        return Err(loc.err(format!("Shape \"sphere\": radius {r} must be positive")));
    }
    // pbrt-v4 Sphere (4th ed. §6.2): z range clamped to [-r, r], phimax to [0, 360].
    let (z0, z1) = (params.float("zmin", -r)?, params.float("zmax", r)?);
    let phi_max_deg = params.float("phimax", 360.0)?;
    if !(z0.is_finite() && z1.is_finite() && phi_max_deg.is_finite()) {
        return Err(loc.err("Shape \"sphere\": zmin, zmax and phimax must be finite"));
    }
    let (z_min, z_max) = (z0.min(z1).clamp(-r, r), z0.max(z1).clamp(-r, r));
    let phi_max_deg = phi_max_deg.clamp(0.0, 360.0);
    if !(z_max > z_min && phi_max_deg > 0.0) {
        return Err(loc.err(format!(
            "Shape \"sphere\": zmin {z0}, zmax {z1}, phimax {phi_max_deg} leave no surface"
        )));
    }
    Ok(if z_min <= -r && z_max >= r && phi_max_deg >= 360.0 {
        Geometry::Sphere {
            center: [0.0; 3],
            radius: r,
        }
    } else {
        Geometry::PartialSphere {
            center: [0.0; 3],
            radius: r,
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            z_min,
            z_max,
            phi_max_deg,
        }
    })
}

/// `loopsubdiv`: `levels`, `P`, `indices`, Loop-subdivided and moved to the limit surface as
/// pbrt-v4 does ([`crate::shapes::loop_subdivide`]).
fn loop_subdiv(params: &ParamList, loc: &Loc) -> Result<Geometry, PbrtError> {
    let levels = params.int("levels", 3)?;
    let p = params
        .tuples("P", &["point3"], 3)?
        .ok_or_else(|| loc.err("Shape \"loopsubdiv\": no \"point3 P\""))?;
    let (idx, iloc) = params
        .ints("indices")?
        .ok_or_else(|| loc.err("Shape \"loopsubdiv\": no \"integer indices\""))?;
    if idx.is_empty() || idx.len() % 3 != 0 {
        return Err(iloc.err(format!(
            "Shape \"loopsubdiv\": {} indices is not a multiple of 3",
            idx.len()
        )));
    }
    if let Some(bad) = idx.iter().find(|&&i| i < 0 || i as usize >= p.len()) {
        return Err(iloc.err(format!(
            "Shape \"loopsubdiv\": index {bad} is out of range (0..{})",
            p.len()
        )));
    }
    if !(0..=12).contains(&levels) {
        return Err(loc.err(format!(
            "Shape \"loopsubdiv\": levels {levels} must be 0..12"
        )));
    }
    let pos: Vec<[f64; 3]> = p.iter().map(|v| [v[0], v[1], v[2]]).collect();
    let tris: Vec<[u32; 3]> = idx
        .chunks(3)
        .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32])
        .collect();
    let (positions, indices, normals) =
        crate::shapes::loop_subdivide(&pos, &tris, levels as u32, true)
            .map_err(|e| loc.err(format!("Shape \"loopsubdiv\": {e}")))?;
    Ok(Geometry::mesh(positions, indices, None, Some(normals)))
}
