//! Labels of a render for training data (pbrt's and Blender's "arbitrary output values"): per
//! pixel the object instance, the surface normal (world and camera frame) and the albedo (the
//! material's reflectance, spectral and as linear sRGB) of the first surface through the pixel
//! centre (the ray of the depth and id maps); per instance its 3D box (oriented by its
//! transform, sized by its geometry), how much of it is visible, and how much of it lies outside
//! the frame; and the pinhole camera's intrinsics and extrinsics.
//!
//! Conventions. The camera frame is OpenCV's: x right, y down, z forward (the optical axis), m,
//! origin at the pinhole (a lens camera's entrance pupil). `K` has pixel centres at integer
//! coordinates (u = fx X / Z + cx, pixel (r, c) centred at u = c, v = r). 2D boxes are in
//! COCO's pixel-edge convention: pixel (r, c) covers [c, c + 1) x [r, r + 1), so a box is
//! `[x0, y0, x1, y1]` with `x1` one past the last column. Normals face the camera (the side the
//! pixel sees), shading normals where a mesh has them. Instance ids are 1-based (0 = no surface),
//! numbered in the order their first shape appears in the scene.

use crate::camera::CameraRig;
use crate::geometry::Ray;
use crate::integrator::Tracer;
use crate::materials::Mat;
use crate::math::V3;
use crate::motion::{PathTime, TimeCache};
use crate::scene::{Geometry, SceneDescription, Transform};
use crate::spectral::{Lambdas, WavelengthSampler};
use crate::texture::TexCtx;
use camsim_core::WavelengthGrid;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Surfaces followed through one pixel when counting which instances it would see unoccluded.
const MAX_LAYERS: usize = 64;

/// Which per-pixel labels a render computes besides the instance map (each costs memory).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LabelRequest {
    /// Surface normals, world and camera frame (2 x 12 bytes per pixel).
    pub normals: bool,
    /// Albedo: spectral (4 bytes per band and pixel) and linear sRGB (12 bytes per pixel).
    pub albedo: bool,
    /// Each instance's full (amodal) silhouette, occluders ignored ([`Labels::amodal`]): every
    /// surface along each pixel's ray is followed (up to 64), on a traced grid as on the
    /// render's.
    pub amodal: bool,
}

/// The pinhole camera of a render (the rays of its depth, id and label maps) in OpenCV's
/// conventions (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PinholeCamera {
    /// Image width and height, pixels.
    pub width: usize,
    pub height: usize,
    /// Intrinsics `[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`, pixels.
    pub k: [[f64; 3]; 3],
    /// World (the scene file's coordinates) to camera, 4 x 4, m. A pbrt scene's world is
    /// left-handed, so for a `LookAt` camera the 3 x 3 part has determinant -1.
    pub world_to_camera: [[f64; 4]; 4],
}

impl PinholeCamera {
    /// Camera coordinates (m) of world point `p`.
    pub fn to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.world_to_camera;
        std::array::from_fn(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
    }

    /// A world direction in the camera frame (unit length).
    pub fn direction_to_camera(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.world_to_camera;
        normalize(std::array::from_fn(|i| {
            m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2]
        }))
    }

    /// Pixel coordinates `[u, v]` (OpenCV: centres at integers) of camera point `p` (z > 0).
    pub fn project(&self, p: [f64; 3]) -> [f64; 2] {
        let k = &self.k;
        [
            k[0][0] * p[0] / p[2] + k[0][2],
            k[1][1] * p[1] / p[2] + k[1][2],
        ]
    }
}

/// An oriented 3D box in camera coordinates (OpenCV frame, m).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Box3d {
    /// Centre, m.
    pub center_m: [f64; 3],
    /// Edge lengths along `axes[0]`, `axes[1]`, `axes[2]`, m.
    pub size_m: [f64; 3],
    /// The box's unit axes in camera coordinates (a right-handed set): the rows of the rotation
    /// from box to camera frame.
    pub axes: [[f64; 3]; 3],
    /// The 8 corners, m: corner `i` is `center + sum_k (bit k of i ? +1 : -1) size_k / 2 axes_k`.
    pub corners_m: [[f64; 3]; 8],
}

/// An instance's own named 3D keypoints in camera coordinates (OpenCV frame, m).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Keypoints3d {
    pub names: Vec<String>,
    /// Edges between points, 0-based indices into `names`.
    pub skeleton: Vec<[usize; 2]>,
    pub points_m: Vec<[f64; 3]>,
}

/// The camera-frame keypoints of the instance whose first shape is `i0` (see
/// [`Instance::keypoints_3d`]); `moved` as in [`box_3d`].
fn keypoints_3d(
    scene: &SceneDescription,
    i0: usize,
    cam: &PinholeCamera,
    moved: &dyn Fn(usize) -> Option<Transform>,
) -> Option<Keypoints3d> {
    let k = scene.shapes.get(i0)?.tags.keypoints.as_ref()?;
    let d = moved(i0);
    Some(Keypoints3d {
        names: k.names.clone(),
        skeleton: k.skeleton.clone(),
        points_m: k
            .points_m
            .iter()
            .map(|p| cam.to_camera(d.as_ref().map_or(*p, |d| d.apply_point(*p))))
            .collect(),
    })
}

/// One object instance of a render.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Instance {
    /// Its id in the instance maps (1-based).
    pub id: u32,
    /// Its shapes' name (pbrt `Attribute "shape" "string name"`, the object's name for a pbrt
    /// `ObjectInstance`), or `shape N`.
    pub name: String,
    /// The material of its first shape (its `MakeNamedMaterial` name, or `material N`).
    pub material: String,
    /// Its semantic category (`ShapeTags::category` of its first shape), when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub category: Option<String>,
    /// Its shapes' object ids (1 + index in the scene's shapes).
    pub object_ids: Vec<u32>,
    /// Oriented box around its geometry; `None` for an instance without geometry extent.
    pub box_3d: Option<Box3d>,
    /// Its own 3D keypoints (`ShapeTags::keypoints` of its first shape: an asset manifest's),
    /// in the camera frame; `None`: keypoint labels use its box's centre and corners.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keypoints_3d: Option<Keypoints3d>,
    /// Pixels whose centre ray meets the instance anywhere, in front of other surfaces or not
    /// (its unoccluded area inside the frame, render pixels).
    pub unoccluded_px: u64,
    /// Pixels where it is the first surface (its visible area, render pixels).
    pub visible_px: u64,
    /// `visible_px / unoccluded_px` (0 when never met).
    pub visible_fraction: f64,
    /// Fraction of its 3D box's projected 2D extent outside the frame (0: inside, 1: outside or
    /// behind the camera), KITTI's truncation.
    pub truncation: f64,
}

/// The labels of a render (module docs for the conventions).
#[derive(Debug, Clone, PartialEq)]
pub struct Labels {
    pub width: usize,
    pub height: usize,
    /// Instance id per pixel, row-major (0: no surface).
    pub instance_id: Vec<u32>,
    /// Object id per pixel (1 + shape index, [`crate::IdMaps`]' numbering; 0: no surface).
    pub object_id: Vec<u32>,
    /// Distance along the optical axis from the pinhole to the surface, m (infinite: none).
    pub depth_m: Vec<f32>,
    /// Unit surface normal per pixel in world coordinates (zero where no surface).
    pub normal_world: Option<Vec<[f32; 3]>>,
    /// The same in camera coordinates (OpenCV frame).
    pub normal_camera: Option<Vec<[f32; 3]>>,
    /// Reflectance of the first surface's material at each band of `grid`, band-sequential
    /// (`albedo[b * pixels + p]`), fraction: a diffuse material's reflectance texture (a coated
    /// diffuse's base, a diffuse transmitter's reflectance times its scale), a conductor's or
    /// dielectric's normal-incidence Fresnel reflectance. 0 where no surface.
    pub albedo: Option<Vec<f32>>,
    /// The albedo as linear sRGB under D65 (a perfect white reflector is (1, 1, 1)).
    pub albedo_srgb: Option<Vec<[f32; 3]>>,
    /// With [`LabelRequest::amodal`]: per instance (`amodal[k - 1]` for id k) the pixels
    /// (row-major indices, ascending) whose ray meets it anywhere, in front of other surfaces or
    /// behind them: its full silhouette inside the frame (BOP's `mask`, COCO-amodal's mask).
    pub amodal: Option<Vec<Vec<u32>>>,
    /// The wavelength grid of `albedo`.
    pub grid: WavelengthGrid,
    /// The instances, `instances[k - 1]` has id k.
    pub instances: Vec<Instance>,
    /// The pinhole camera of the maps.
    pub camera: PinholeCamera,
}

/// A tight 2D box of one instance in an instance map (COCO pixel-edge convention).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Box2d {
    /// Instance id.
    pub id: u32,
    /// `[x0, y0, x1, y1]`, pixels: columns x0..x1 and rows y0..y1 (ends exclusive).
    pub bbox: [u32; 4],
    /// Pixels of the instance in the map.
    pub pixels: u64,
}

/// The tight box and pixel count of every instance id present in `map` (`width` columns), in id
/// order.
pub fn boxes_2d(map: &[u32], width: usize) -> Vec<Box2d> {
    let mut acc: Vec<Option<Box2d>> = Vec::new();
    for (i, &id) in map.iter().enumerate() {
        if id == 0 {
            continue;
        }
        let (x, y) = ((i % width) as u32, (i / width) as u32);
        if acc.len() <= id as usize {
            acc.resize(id as usize + 1, None);
        }
        let b = acc[id as usize].get_or_insert(Box2d {
            id,
            bbox: [x, y, x + 1, y + 1],
            pixels: 0,
        });
        b.bbox = [
            b.bbox[0].min(x),
            b.bbox[1].min(y),
            b.bbox[2].max(x + 1),
            b.bbox[3].max(y + 1),
        ];
        b.pixels += 1;
    }
    acc.into_iter().flatten().collect()
}

/// Per shape its instance id (1-based), and the instances (names, shapes), in scene order.
fn instance_table(scene: &SceneDescription) -> (Vec<u32>, Vec<Instance>) {
    let mut by_key: HashMap<u32, u32> = HashMap::new();
    let mut of_shape = Vec::with_capacity(scene.shapes.len());
    let mut instances: Vec<Instance> = Vec::new();
    let legend = crate::ids::IdMaps::from_object_ids(scene, 0, 0, Vec::new());
    for (si, s) in scene.shapes.iter().enumerate() {
        let existing = s.tags.instance.and_then(|k| by_key.get(&k).copied());
        let id = match existing {
            Some(id) => id,
            None => {
                let id = instances.len() as u32 + 1;
                if let Some(k) = s.tags.instance {
                    by_key.insert(k, id);
                }
                let mat = crate::ids::surface_material(scene, s.material);
                instances.push(Instance {
                    id,
                    name: legend.objects[si].clone(),
                    material: legend.materials.get(mat).cloned().unwrap_or_default(),
                    category: s.tags.category.clone(),
                    object_ids: Vec::new(),
                    box_3d: None,
                    keypoints_3d: None,
                    unoccluded_px: 0,
                    visible_px: 0,
                    visible_fraction: 0.0,
                    truncation: 1.0,
                });
                id
            }
        };
        instances[id as usize - 1].object_ids.push(si as u32 + 1);
        of_shape.push(id);
    }
    (of_shape, instances)
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0; 3]
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Orthonormal axes of a transform's linear part (Gram-Schmidt on its columns, x first); the
/// world axes when it is degenerate.
fn frame_axes(t: Option<&Transform>) -> [[f64; 3]; 3] {
    let world = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let Some(t) = t else { return world };
    let col = |j: usize| [t.m[0][j], t.m[1][j], t.m[2][j]];
    let a = normalize(col(0));
    let b0 = col(1);
    let d = dot(b0, a);
    let b = normalize([b0[0] - d * a[0], b0[1] - d * a[1], b0[2] - d * a[2]]);
    let c = cross(a, b);
    if dot(a, a) < 0.5 || dot(b, b) < 0.5 || dot(c, c) < 0.5 {
        return world;
    }
    [a, b, c]
}

/// The extent `[min, max]` of a shape's geometry along `a`, m: `a` a unit axis and `len` 1, or
/// `a = A^T u` for the geometry moved by linear map `A` (extent along the unit axis `u` of the
/// moved geometry, less the move's offset) with `len = |a|` (a sphere's radius scales by it: the
/// support function of an ellipsoid `A` ball is `r |A^T u|`).
fn extent_along(g: &Geometry, a: [f64; 3], len: f64) -> [f64; 2] {
    match g {
        Geometry::Triangles {
            positions, indices, ..
        } => {
            let mut e = [f64::INFINITY, f64::NEG_INFINITY];
            // Only vertices used by a triangle count (a mesh may carry unused ones).
            for tri in indices {
                for &i in tri {
                    if let Some(p) = positions.get(i as usize) {
                        let d = dot(*p, a);
                        e = [e[0].min(d), e[1].max(d)];
                    }
                }
            }
            e
        }
        // A partial sphere's box is its whole sphere's (an upper bound).
        Geometry::Sphere { center, radius } | Geometry::PartialSphere { center, radius, .. } => {
            let d = dot(*center, a);
            [d - radius * len, d + radius * len]
        }
        // Bezier segments lie in their control points' convex hull; plus half the widest width.
        Geometry::Curves(c) => {
            let r = 0.5 * c.width_m[0].max(c.width_m[1]) as f64 * len;
            let mut e = [f64::INFINITY, f64::NEG_INFINITY];
            for p in &c.points {
                let d = dot(p.map(f64::from), a);
                e = [e[0].min(d - r), e[1].max(d + r)];
            }
            e
        }
    }
}

/// The oriented world-space box of `shapes` in the frame of the first one's transform, as
/// camera-frame [`Box3d`]. `moved(shape index)`: a moving shape's move from its stored pose to
/// the labels' time (the box follows it: exact for a rigid move with uniform scale).
fn box_3d(
    scene: &SceneDescription,
    shapes: &[u32],
    cam: &PinholeCamera,
    moved: &dyn Fn(usize) -> Option<Transform>,
) -> Option<Box3d> {
    let i0 = *shapes.first()? as usize - 1;
    let first = &scene.shapes[i0];
    let axes_w = match (moved(i0), first.tags.object_to_world.as_ref()) {
        (None, o2w) => frame_axes(o2w),
        (Some(d), Some(o2w)) => frame_axes(Some(&d.then_apply_to(o2w))),
        (Some(d), None) => frame_axes(Some(&d)),
    };
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &o in shapes {
        let g = &scene.shapes[o as usize - 1].geometry;
        let d = moved(o as usize - 1);
        for k in 0..3 {
            let e = match &d {
                None => extent_along(g, axes_w[k], 1.0),
                Some(d) => {
                    // dot(A x + t, u) = dot(x, A^T u) + dot(t, u).
                    let u = axes_w[k];
                    let at: [f64; 3] =
                        std::array::from_fn(|j| (0..3).map(|i| d.m[i][j] * u[i]).sum());
                    let off = dot([d.m[0][3], d.m[1][3], d.m[2][3]], u);
                    let e = extent_along(g, at, dot(at, at).sqrt());
                    [e[0] + off, e[1] + off]
                }
            };
            lo[k] = lo[k].min(e[0]);
            hi[k] = hi[k].max(e[1]);
        }
    }
    if (0..3).any(|k| !(hi[k] >= lo[k]) || !hi[k].is_finite() || !lo[k].is_finite()) {
        return None;
    }
    let mid: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let center_w: [f64; 3] = std::array::from_fn(|i| (0..3).map(|k| mid[k] * axes_w[k][i]).sum());
    let size_m: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    let mut axes: [[f64; 3]; 3] = std::array::from_fn(|k| cam.direction_to_camera(axes_w[k]));
    // The camera frame may mirror the world (pbrt's left-handed world): flip the third axis to
    // keep a rotation (the box is symmetric about its centre, so it is the same box).
    if dot(cross(axes[0], axes[1]), axes[2]) < 0.0 {
        axes[2] = axes[2].map(|v| -v);
    }
    let center_m = cam.to_camera(center_w);
    let corners_m = std::array::from_fn(|i| {
        std::array::from_fn(|c| {
            center_m[c]
                + (0..3)
                    .map(|k| {
                        let s = if i >> k & 1 == 1 { 0.5 } else { -0.5 };
                        s * size_m[k] * axes[k][c]
                    })
                    .sum::<f64>()
        })
    });
    Some(Box3d {
        center_m,
        size_m,
        axes,
        corners_m,
    })
}

/// KITTI truncation of a camera-frame box: 1 - (area of its projected 2D extent inside the
/// frame) / (that extent's area). The 12 edges are clipped to z >= `NEAR` before projecting.
fn truncation(b: &Box3d, cam: &PinholeCamera) -> f64 {
    const NEAR: f64 = 1e-3;
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut add = |p: [f64; 3]| {
        // Pixel-edge coordinates (u + 1/2).
        let q = cam.project(p);
        for k in 0..2 {
            lo[k] = lo[k].min(q[k] + 0.5);
            hi[k] = hi[k].max(q[k] + 0.5);
        }
    };
    for i in 0..8usize {
        for k in 0..3 {
            let j = i ^ (1 << k);
            if j < i {
                continue;
            }
            let (a, c) = (b.corners_m[i], b.corners_m[j]);
            match (a[2] >= NEAR, c[2] >= NEAR) {
                (true, true) => {
                    add(a);
                    add(c);
                }
                (false, false) => {}
                (ina, _) => {
                    let t = (NEAR - a[2]) / (c[2] - a[2]);
                    let m: [f64; 3] = std::array::from_fn(|n| a[n] + t * (c[n] - a[n]));
                    add(m);
                    add(if ina { a } else { c });
                }
            }
        }
    }
    let area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
    if !(area > 0.0 && area.is_finite()) {
        // Degenerate (flat, or behind the camera): inside or out by its centre.
        return if lo[0].is_finite() && lo[0] >= 0.0 && hi[0] <= cam.width as f64 {
            0.0
        } else {
            1.0
        };
    }
    let (w, h) = (cam.width as f64, cam.height as f64);
    let inside =
        (hi[0].min(w) - lo[0].max(0.0)).max(0.0) * (hi[1].min(h) - lo[1].max(0.0)).max(0.0);
    (1.0 - inside / area).clamp(0.0, 1.0)
}

/// Fresnel reflectance at normal incidence of a conductor of complex index `eta + i k` relative
/// to the outside: ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2) (Born & Wolf, Principles of Optics,
/// sec. 14.2; a dielectric is k = 0).
fn normal_reflectance(eta: f32, k: f32) -> f32 {
    ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
}

impl Tracer {
    /// The reflectance of compiled material `m` at one wavelength (see [`Labels::albedo`]).
    fn albedo_at(&self, m: u32, ctx: &TexCtx, l: &Lambdas<1>) -> f32 {
        let v = match &self.materials[m as usize] {
            Mat::Diffuse(t) | Mat::CoatedDiffuse { r: t, .. } => self.eval_texture(t, ctx, l)[0],
            // The base colour (the albedo glTF and the G-buffers of rasterizers report).
            Mat::GltfPbr(g) => self.eval_texture(&g.base, ctx, l)[0],
            Mat::DiffuseTransmission { r, scale, .. } => self.eval_texture(r, ctx, l)[0] * scale,
            Mat::Conductor { optics, .. } => {
                let (e, k) = self.conductor_constants(optics, ctx, l);
                normal_reflectance(e[0], k[0])
            }
            Mat::CoatedConductor { eta, optics, .. } => {
                // The conductor relative to its coating, as the BSDF takes it.
                let (e, k) = self.conductor_constants(optics, ctx, l);
                normal_reflectance(e[0] / eta, k[0] / eta)
            }
            Mat::Dielectric { eta, .. } => {
                normal_reflectance(self.tables[*eta as usize].eval_path(l)[0], 0.0)
            }
            Mat::ThinDielectric { eta, .. } => {
                // A slab's reflectance with its internal reflections: R + T^2 R / (1 - R^2) =
                // 2 R / (1 + R) (pbrt-v4 ThinDielectricBxDF).
                let r = normal_reflectance(self.tables[*eta as usize].eval_path(l)[0], 0.0);
                2.0 * r / (1.0 + r)
            }
            Mat::VaryingRoughness { base, .. }
            | Mat::Bumped { base, .. }
            | Mat::MediumBoundary { base } => return self.albedo_at(*base, ctx, l),
            // A fibre given by its colour (its multiple-scattering albedo); by absorption: none.
            Mat::Hair {
                absorption,
                from_color: true,
                ..
            } => self.eval_texture(absorption, ctx, l)[0],
            Mat::Hair { .. } => 0.0,
            Mat::Mix { .. } | Mat::AlphaMasked { .. } | Mat::Interface => 0.0,
        };
        v.clamp(0.0, 1.0)
    }
}

/// One row of per-pixel labels.
struct Row {
    instance: Vec<u32>,
    object: Vec<u32>,
    depth: Vec<f32>,
    normal_world: Vec<[f32; 3]>,
    normal_camera: Vec<[f32; 3]>,
    /// Pixel-major here (`albedo[x * bands + b]`), band-sequential in [`Labels`].
    albedo: Vec<f32>,
    albedo_srgb: Vec<[f32; 3]>,
    /// Every instance met through each pixel (each once per pixel): (column, instance id).
    met: Vec<[u32; 2]>,
}

/// Linear sRGB per unit reflectance in each band of `grid` under D65, normalized so that a
/// perfect reflector gives (1, 1, 1): XYZ = sum_b R_b S_b (xbar, ybar, zbar)_b / sum_b S_b ybar_b
/// (CIE 015:2018 eq. 7.2-7.4), then the sRGB matrix (IEC 61966-2-1).
fn srgb_weights(grid: &WavelengthGrid) -> Vec<[f32; 3]> {
    let cmfs = camsim_core::colorimetry::Cmfs::on(grid);
    let d65 = camsim_core::tables::illuminant("D65")
        .map(|s| s.resample(grid).values)
        .unwrap_or_else(|_| vec![1.0; grid.len()]);
    let white_y: f64 = (0..grid.len()).map(|b| cmfs.y[b] * d65[b]).sum();
    (0..grid.len())
        .map(|b| {
            let xyz = [cmfs.x[b], cmfs.y[b], cmfs.z[b]].map(|c| c * d65[b] / white_y);
            camsim_core::colorimetry::xyz_to_linear_srgb(xyz).map(|v| v as f32)
        })
        .collect()
}

/// Where label pixels look: continuous raster positions of `scene`'s camera (pixel (i, j)
/// covers [i, i + 1) x [j, j + 1)), one per label pixel of a `width` x `height` grid, row-major;
/// NaN: the pixel sees nothing of the render (outside its frame).
#[derive(Debug, Clone, PartialEq)]
pub struct RasterPositions {
    pub width: usize,
    pub height: usize,
    pub xy: Vec<[f32; 2]>,
}

/// The labels of `scene` on another pixel grid: label pixel k is the surface the camera's
/// pinhole ray through raster position `raster.xy[k]` meets (exact, no resampling: ids are
/// never blended). `instances` are the render's own ([`Labels::instances`] of its grid: visible
/// fractions and truncation are measured there).
pub fn trace_labels(
    scene: &SceneDescription,
    request: LabelRequest,
    raster: &RasterPositions,
    instances: &[Instance],
) -> Result<Labels, crate::RenderError> {
    let rig = CameraRig::new(&scene.camera).map_err(crate::RenderError::Camera)?;
    if raster.xy.len() != raster.width * raster.height {
        return Err(crate::RenderError::Settings(format!(
            "{} raster positions for a {} x {} label grid",
            raster.xy.len(),
            raster.width,
            raster.height
        )));
    }
    let ws = WavelengthSampler::new(&scene.settings.grid);
    let tracer = Tracer::new(scene, &ws)?;
    let mut out = compute(scene, &tracer, &rig, &ws, request, Some(raster))?;
    out.instances = instances.to_vec();
    Ok(out)
}

/// The labels of `scene` as seen by `rig` (`tracer` compiled for `ws`): on the render's grid
/// (pixel centres), or at `raster`'s positions.
pub(crate) fn compute(
    scene: &SceneDescription,
    tracer: &Tracer,
    rig: &CameraRig,
    ws: &WavelengthSampler,
    request: LabelRequest,
    raster: Option<&RasterPositions>,
) -> Result<Labels, crate::RenderError> {
    let (width, height) = match raster {
        Some(r) => (r.width, r.height),
        None => (scene.camera.width, scene.camera.height),
    };
    let grid = scene.settings.grid;
    let bands = grid.len();
    let pixels = width * height;
    camsim_core::mem::MemoryBudget::new(format!("the labels of a {width} x {height} render"))
        .bytes(
            "label maps",
            (pixels as u64).saturating_mul(crate::budget::label_bytes_per_pixel(
                request.normals,
                request.albedo,
                bands,
            )),
        )
        .check(crate::budget::ADVICE)?;
    // The labels' instant in a moving scene: each pixel sees the scene at the start of its
    // render row's window (the instant of the depth, id and flow maps' first hit); the camera
    // model and the 3D boxes are those of the frame's start (the earliest row's).
    let motion = tracer.motion.as_deref();
    let shutter = &scene.settings.time.shutter;
    let last_row = scene.camera.height.saturating_sub(1);
    let row_start_s = |py: f32| shutter.row_window_s((py.max(0.0) as usize).min(last_row)).0;
    let frame_start_s = shutter.span_s(scene.camera.height).0;
    let stored_camera = pinhole_camera(scene, rig, None)?;
    let camera = match motion.and_then(|m| m.camera_delta_at(frame_start_s)) {
        None => stored_camera.clone(),
        Some(d) => pinhole_camera(scene, rig, Some(&d))?,
    };
    let (of_shape, mut instances) = instance_table(scene);
    let lambdas: Vec<Lambdas<1>> = (0..bands)
        .map(|b| ws.locate([grid.wavelength_nm(b) as f32]))
        .collect();
    let srgb_w = srgb_weights(&grid);
    // A world normal in the camera frame of the pixel's instant (the stored camera's frame of
    // the normal moved back with the camera).
    let to_cam = |n: V3, pt: &PathTime| {
        let n = match motion.and_then(|m| m.camera_pose(pt)) {
            Some(p) => p.to_ref.vector(n),
            None => n,
        };
        stored_camera
            .direction_to_camera([n.x as f64, n.y as f64, n.z as f64])
            .map(|v| v as f32)
    };
    let rows: Vec<Row> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut row = Row {
                instance: vec![0; width],
                object: vec![0; width],
                depth: vec![f32::INFINITY; width],
                normal_world: Vec::new(),
                normal_camera: Vec::new(),
                albedo: Vec::new(),
                albedo_srgb: Vec::new(),
                met: Vec::new(),
            };
            if request.normals {
                row.normal_world = vec![[0.0; 3]; width];
                row.normal_camera = vec![[0.0; 3]; width];
            }
            if request.albedo {
                row.albedo = vec![0.0; width * bands];
                row.albedo_srgb = vec![[0.0; 3]; width];
            }
            let mut seen = [0u32; MAX_LAYERS];
            let cache = TimeCache::new(motion);
            for x in 0..width {
                let [px, py] = match raster {
                    None => [x as f32 + 0.5, y as f32 + 0.5],
                    Some(rp) => {
                        let [px, py] = rp.xy[y * width + x];
                        if !(px.is_finite() && py.is_finite()) {
                            continue;
                        }
                        [px, py]
                    }
                };
                let pt = match motion {
                    None => PathTime::STATIC,
                    Some(_) => cache.at(row_start_s(py)),
                };
                let r = tracer.camera_ray(rig.ray(px, py), &pt);
                let Some((sh, pi)) = tracer.first_hit(&r, &pt) else {
                    continue;
                };
                let id = of_shape[pi.shape as usize];
                row.instance[x] = id;
                row.object[x] = pi.shape + 1;
                row.depth[x] = (sh.p - r.o).dot(tracer.camera_vector(rig.forward, &pt));
                // The side the camera sees: the geometric normal toward the ray's origin, the
                // shading normal on its side.
                let ng = sh.ng.face_forward(-r.d);
                let ns = sh.ns.face_forward(ng);
                if request.normals {
                    row.normal_world[x] = [ns.x, ns.y, ns.z];
                    row.normal_camera[x] = to_cam(ns, &pt);
                }
                if request.albedo {
                    let m = tracer.resolve_material(pi.material, sh.p, -r.d);
                    let ctx = TexCtx::at(&sh);
                    let mut rgb = [0f32; 3];
                    for (b, l) in lambdas.iter().enumerate() {
                        let a = tracer.albedo_at(m, &ctx, l);
                        row.albedo[x * bands + b] = a;
                        for c in 0..3 {
                            rgb[c] += a * srgb_w[b][c];
                        }
                    }
                    row.albedo_srgb[x] = rgb;
                }
                // Every surface along the ray: which instances the pixel would see unoccluded
                // (on the render's own grid, and for amodal silhouettes).
                if raster.is_some() && !request.amodal {
                    continue;
                }
                let mut n_seen = 1;
                seen[0] = id;
                let mut hit = sh;
                for _ in 1..MAX_LAYERS {
                    let next = Ray {
                        o: Tracer::offset(hit.p, hit.ng.face_forward(r.d), hit.err),
                        d: r.d,
                    };
                    let Some((sh2, pi2)) = tracer.first_hit(&next, &pt) else {
                        break;
                    };
                    let id2 = of_shape[pi2.shape as usize];
                    if !seen[..n_seen].contains(&id2) && n_seen < MAX_LAYERS {
                        seen[n_seen] = id2;
                        n_seen += 1;
                    }
                    hit = sh2;
                }
                row.met
                    .extend(seen[..n_seen].iter().map(|&id| [x as u32, id]));
            }
            row
        })
        .collect();

    let mut instance_id = Vec::with_capacity(pixels);
    let mut object_id = Vec::with_capacity(pixels);
    let mut depth_m = Vec::with_capacity(pixels);
    let mut normal_world = Vec::new();
    let mut normal_camera = Vec::new();
    let mut albedo = Vec::new();
    let mut albedo_srgb = Vec::new();
    if request.albedo {
        albedo = vec![0f32; pixels * bands];
    }
    let mut amodal: Vec<Vec<u32>> = vec![Vec::new(); instances.len()];
    for (y, row) in rows.into_iter().enumerate() {
        for &[x, id] in &row.met {
            if raster.is_none() {
                instances[id as usize - 1].unoccluded_px += 1;
            }
            if request.amodal {
                amodal[id as usize - 1].push((y * width) as u32 + x);
            }
        }
        for &id in &row.instance {
            if id != 0 {
                instances[id as usize - 1].visible_px += 1;
            }
        }
        instance_id.extend_from_slice(&row.instance);
        object_id.extend_from_slice(&row.object);
        depth_m.extend_from_slice(&row.depth);
        normal_world.extend_from_slice(&row.normal_world);
        normal_camera.extend_from_slice(&row.normal_camera);
        if request.albedo {
            for x in 0..width {
                for b in 0..bands {
                    albedo[b * pixels + y * width + x] = row.albedo[x * bands + b];
                }
            }
        }
        albedo_srgb.extend_from_slice(&row.albedo_srgb);
    }
    for inst in instances.iter_mut() {
        inst.visible_fraction = if inst.unoccluded_px > 0 {
            inst.visible_px as f64 / inst.unoccluded_px as f64
        } else {
            0.0
        };
        let moved = |i| motion.and_then(|m| m.shape_delta_at(i, frame_start_s));
        inst.box_3d = box_3d(scene, &inst.object_ids, &camera, &moved);
        inst.keypoints_3d = inst
            .object_ids
            .first()
            .and_then(|&o| keypoints_3d(scene, o as usize - 1, &camera, &moved));
        inst.truncation = inst
            .box_3d
            .as_ref()
            .map(|b| truncation(b, &camera))
            .unwrap_or(1.0);
    }
    Ok(Labels {
        width,
        height,
        instance_id,
        object_id,
        depth_m,
        normal_world: request.normals.then_some(normal_world),
        normal_camera: request.normals.then_some(normal_camera),
        albedo: request.albedo.then_some(albedo),
        albedo_srgb: request.albedo.then_some(albedo_srgb),
        amodal: request.amodal.then_some(amodal),
        grid,
        instances,
        camera,
    })
}

/// The pinhole camera of `rig`: intrinsics from its ray generation, extrinsics from the scene's
/// camera transform with the origin moved to the pinhole and y turned down; `moved`: the
/// camera's world-space move from its stored pose (a moving camera at the labels' time).
fn pinhole_camera(
    scene: &SceneDescription,
    rig: &CameraRig,
    moved: Option<&Transform>,
) -> Result<PinholeCamera, crate::RenderError> {
    let c = &scene.camera;
    let [fx, fy, cx, cy] = rig.pinhole_intrinsics(c.width, c.height);
    let not_invertible = || crate::RenderError::Camera("camera_to_world is not invertible".into());
    let stored = camsim_scene3d::xform::inverse(&c.camera_to_world).ok_or_else(not_invertible)?;
    let o = rig.pinhole_origin();
    // The pinhole's depth in the camera frame (the same in every pose).
    let pz = stored.apply_point([o.x as f64, o.y as f64, o.z as f64])[2];
    let inv = match moved {
        None => stored,
        Some(d) => camsim_scene3d::xform::inverse(&d.then_apply_to(&c.camera_to_world))
            .ok_or_else(not_invertible)?,
    };
    let mut m = [[0.0; 4]; 4];
    for j in 0..4 {
        m[0][j] = inv.m[0][j];
        m[1][j] = -inv.m[1][j];
        m[2][j] = inv.m[2][j];
        m[3][j] = inv.m[3][j];
    }
    m[2][3] -= pz;
    Ok(PinholeCamera {
        width: c.width,
        height: c.height,
        k: [[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]],
        world_to_camera: m,
    })
}
