//! Spawning and placement (`[[render.compose.spawn]]`): draw assets from the library, scale and
//! orient them, and place them on a support, inside a box or on a grid, without
//! interpenetration.
//!
//! Each entry draws `count = [min, max]` objects (uniform integer), each asset with equal
//! probability or, with `weights = { category = w }`, a category with probability `w / sum w`
//! (only the listed categories) and then an asset of it with equal probability; `replacement =
//! false` draws an asset at most once. Each object gets a scale factor uniform in `scale = [min,
//! max]` (on top of the manifest's `scale_to_m`), an orientation (`upright`: the asset's +y along
//! the compose `up` axis, turned about it by a uniform angle; `uniform`: uniform on SO(3)
//! (Shoemake 1992, Graphics Gems III "Uniform random rotations"); `none`: as the file has it) and
//! a place from one sampler:
//! - `on = "name"`: a point uniform by area on the upward-facing triangles (normal within
//!   `max_slope_deg` of `up`) of the scene's shapes of that name (`*` wildcards), the object's
//!   centre of mass (its collider's, uniform density) above it and its lowest point
//!   [`CLEARANCE_M`] above it;
//! - `on = { point_m, normal, extent_m }`: the same on a rectangle of a plane (`extent_m` along
//!   the plane's axes: world x projected on the plane, then `normal x` that);
//! - `inside = { min_m, max_m }`: the object's bounding box inside the box, its centre uniform;
//! - `grid = { origin_m, spacing_m, count, jitter_m }`: each object in its own cell (cells in a
//!   random order), its bounding-box centre at the cell's point moved by a uniform jitter.
//!
//! On a support, the object's base (its hull's points within max(1 mm, 2 % of its height) of
//! its lowest) must lie over the support (over its upward triangles, at their height, or inside
//! the plane's rectangle): it does not overhang an edge it would tip over. A candidate is
//! also refused when its collider (see [`crate::physics::CollisionShape`]) intersects
//! the scene's geometry or comes closer than `min_separation_m` to (or intersects) an object
//! placed before it; then orientation and place are drawn again, at most `max_tries` times,
//! after which the entry fails with an error naming it and the constraint that refused most.

use crate::manifest::{Asset, Library};
use crate::physics::{self, CollisionShape, Statics};
use crate::{ComposeError, Result};
use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::shape::SharedShape;
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How far above its support an object is put, m (0.1 mm): it touches nothing, so the overlap
/// tests can tell it from one that sinks into the support.
pub const CLEARANCE_M: f64 = 1e-4;

fn default_count() -> [u32; 2] {
    [1, 1]
}
fn default_scale() -> [f64; 2] {
    [1.0, 1.0]
}
fn default_true() -> bool {
    true
}
fn default_tries() -> u32 {
    100
}
fn default_slope() -> f64 {
    10.0
}
fn default_extent() -> [f64; 2] {
    [1.0, 1.0]
}

/// How a spawned object is turned.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Orientation {
    /// The asset's +y along `up`, turned about it by an angle uniform in [0, 360) degrees.
    #[default]
    Upright,
    /// Uniform on the rotation group SO(3) (Shoemake 1992).
    Uniform,
    /// As the file has it.
    None,
}

/// A support: a scene object by name, or a plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Support {
    /// The upward-facing triangles of the scene's shapes of this name (`*` wildcards).
    Object(String),
    /// A rectangle of a plane.
    Plane(PlaneSupport),
}

/// `on = { point_m, normal, extent_m }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlaneSupport {
    /// A point of the plane, the centre of the rectangle, m.
    pub point_m: [f64; 3],
    /// The plane's upward normal (dimensionless, normalised here).
    pub normal: [f64; 3],
    /// The rectangle's size along the plane's first axis (world x projected on the plane, or
    /// world z when the normal is along x) and second (normal x first), m (default [1, 1]).
    #[serde(default = "default_extent")]
    pub extent_m: [f64; 2],
}

/// `inside = { min_m, max_m }`: an axis-aligned box, m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoxVolume {
    /// The box's lowest corner, m.
    pub min_m: [f64; 3],
    /// The box's highest corner, m.
    pub max_m: [f64; 3],
}

/// `grid = { origin_m, spacing_m, count, jitter_m }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GridPlacement {
    /// The point of cell (0, 0, 0), m.
    pub origin_m: [f64; 3],
    /// Distance between cell points along x, y, z, m.
    pub spacing_m: [f64; 3],
    /// Cells along x, y, z.
    pub count: [u32; 3],
    /// Largest offset from the cell point along each axis, m (uniform; default 0).
    #[serde(default)]
    pub jitter_m: f64,
}

/// `[[render.compose.spawn]]`: one group of objects drawn from the library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpawnSpec {
    /// The entry's name in errors and records (default `spawn[i]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// How many objects, `[min, max]` inclusive, uniform (default [1, 1]).
    #[serde(default = "default_count")]
    pub count: [u32; 2],
    /// Draw with replacement: an asset may appear several times (default true).
    #[serde(default = "default_true")]
    pub replacement: bool,
    /// Relative weight of each category drawn (dimensionless); only the categories listed
    /// are drawn. Default: every asset equally likely.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<BTreeMap<String, f64>>,
    /// Scale factor range `[min, max]`, uniform, on top of the manifest's `scale_to_m`
    /// (dimensionless, default [1, 1]).
    #[serde(default = "default_scale")]
    pub scale: [f64; 2],
    /// `upright` (default), `uniform` or `none`.
    #[serde(default)]
    pub orientation: Orientation,
    /// Place on a support: a scene object's name, or `{ point_m, normal, extent_m }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on: Option<Support>,
    /// Place inside a box `{ min_m, max_m }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inside: Option<BoxVolume>,
    /// Place on a grid `{ origin_m, spacing_m, count, jitter_m }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<GridPlacement>,
    /// Steepest support triangle `on = "name"` places on, degrees from `up` (default 10).
    #[serde(default = "default_slope")]
    pub max_slope_deg: f64,
    /// Least distance between this entry's objects' colliders and those placed before, m
    /// (default 0: they may touch, not overlap).
    #[serde(default)]
    pub min_separation_m: f64,
    /// Draws of orientation and place per object before the entry fails (default 100).
    #[serde(default = "default_tries")]
    pub max_tries: u32,
}

/// A placed object: which entry and asset, its scale factor, its pose (object frame = asset
/// frame times `scale_to_m` then `scale`, to world) and its collider in its own frame.
#[derive(Clone)]
pub struct Placed {
    pub spawn: usize,
    pub asset: usize,
    pub scale: f64,
    pub pose: Isometry3<f64>,
    pub shape: SharedShape,
    /// Bounding radius of the collider about the object frame's origin, m.
    pub radius_m: f64,
}

/// `compose.spawn[i]` or `compose.spawn[i] ("name")`.
pub fn entry_key(key: &str, i: usize, s: &SpawnSpec) -> String {
    match &s.name {
        Some(n) => format!("{key}[{i}] (\"{n}\")"),
        None => format!("{key}[{i}]"),
    }
}

impl SpawnSpec {
    /// Check the keys that need no scene; errors name them under `key`.
    pub fn validate(&self, key: &str, library: &Library) -> Result<()> {
        let e = |k: &str, m: String| Err(ComposeError::new(format!("{key}.{k}"), m));
        if self.count[0] > self.count[1] {
            return e("count", format!("{:?}: min above max", self.count));
        }
        if !(self.scale[0] > 0.0 && self.scale[1] >= self.scale[0] && self.scale[1].is_finite()) {
            return e(
                "scale",
                format!("{:?} must be [min, max] with 0 < min <= max", self.scale),
            );
        }
        let n_samplers = [
            self.on.is_some(),
            self.inside.is_some(),
            self.grid.is_some(),
        ]
        .iter()
        .filter(|b| **b)
        .count();
        if n_samplers != 1 {
            return Err(ComposeError::new(
                key,
                "give exactly one of on, inside and grid (where the objects go)",
            ));
        }
        if !(self.min_separation_m >= 0.0 && self.min_separation_m.is_finite()) {
            return e(
                "min_separation_m",
                format!("{} must be a non-negative number", self.min_separation_m),
            );
        }
        if !(self.max_slope_deg >= 0.0 && self.max_slope_deg < 90.0) {
            return e(
                "max_slope_deg",
                format!("{} must be in [0, 90)", self.max_slope_deg),
            );
        }
        if self.max_tries == 0 {
            return e("max_tries", "must be at least 1".into());
        }
        if let Some(w) = &self.weights {
            let cats = library.categories();
            for (c, v) in w {
                if !(*v >= 0.0 && v.is_finite()) {
                    return e(
                        &format!("weights.{c}"),
                        format!("{v} must be a non-negative number"),
                    );
                }
                if !cats.contains(&c.as_str()) {
                    return e(
                        &format!("weights.{c}"),
                        format!(
                            "no asset of category {c:?} in the library (categories: {})",
                            cats.join(", ")
                        ),
                    );
                }
            }
            if !(w.values().sum::<f64>() > 0.0) {
                return e("weights", "the weights sum to 0".into());
            }
        }
        if !self.replacement {
            let available = self.candidates(library).len();
            if self.count[1] as usize > available {
                return e(
                    "count",
                    format!(
                        "up to {} objects without replacement, but only {available} assets can be drawn",
                        self.count[1]
                    ),
                );
            }
        }
        match (&self.on, &self.inside, &self.grid) {
            (Some(Support::Plane(p)), _, _) => {
                if norm(p.normal) == 0.0 || !p.normal.iter().all(|v| v.is_finite()) {
                    return e("on.normal", format!("{:?} is not a direction", p.normal));
                }
                if !p.extent_m.iter().all(|v| *v >= 0.0 && v.is_finite()) {
                    return e("on.extent_m", format!("{:?} must be >= 0", p.extent_m));
                }
            }
            (_, Some(b), _) if !(0..3).all(|k| b.min_m[k] <= b.max_m[k]) => {
                return e(
                    "inside",
                    format!("min_m {:?} must not exceed max_m {:?}", b.min_m, b.max_m),
                );
            }
            (_, _, Some(g)) => {
                let cells: u64 = g.count.iter().map(|&c| c as u64).product();
                if cells < self.count[1] as u64 {
                    return e(
                        "grid.count",
                        format!(
                            "{:?} is {cells} cells for up to {} objects",
                            g.count, self.count[1]
                        ),
                    );
                }
                if !(g.jitter_m >= 0.0 && g.jitter_m.is_finite()) {
                    return e("grid.jitter_m", format!("{} must be >= 0", g.jitter_m));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// The assets this entry may draw, with their weights.
    fn candidates(&self, library: &Library) -> Vec<(usize, f64)> {
        match &self.weights {
            None => (0..library.assets.len()).map(|i| (i, 1.0)).collect(),
            Some(w) => {
                // Category weight shared among its assets: a category is drawn with probability
                // w / sum w, then one of its assets uniformly.
                let mut n_in: BTreeMap<&str, usize> = BTreeMap::new();
                for a in &library.assets {
                    *n_in.entry(a.category.as_str()).or_default() += 1;
                }
                library
                    .assets
                    .iter()
                    .enumerate()
                    .filter_map(|(i, a)| {
                        let wc = *w.get(&a.category)?;
                        (wc > 0.0).then(|| (i, wc / n_in[a.category.as_str()] as f64))
                    })
                    .collect()
            }
        }
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// Index drawn with probability proportional to `w` (all >= 0, sum > 0).
fn draw_weighted(rng: &mut impl Rng, w: &[f64]) -> usize {
    let total: f64 = w.iter().sum();
    let mut u = rng.gen::<f64>() * total;
    for (i, x) in w.iter().enumerate() {
        if u < *x {
            return i;
        }
        u -= x;
    }
    w.iter().rposition(|x| *x > 0.0).unwrap_or(0)
}

/// The rotation taking +y to `up`.
fn y_to(up: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::y(), up).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

fn draw_rotation(
    rng: &mut impl Rng,
    o: Orientation,
    up: &Unit<Vector3<f64>>,
) -> UnitQuaternion<f64> {
    use std::f64::consts::TAU;
    match o {
        Orientation::None => UnitQuaternion::identity(),
        Orientation::Upright => {
            let yaw = rng.gen::<f64>() * TAU;
            UnitQuaternion::from_axis_angle(up, yaw) * y_to(up)
        }
        Orientation::Uniform => {
            // Shoemake 1992: q = (sqrt(1-u1) sin 2 pi u2, sqrt(1-u1) cos 2 pi u2,
            // sqrt(u1) sin 2 pi u3, sqrt(u1) cos 2 pi u3) is uniform on the unit 3-sphere.
            let (u1, u2, u3): (f64, f64, f64) = (rng.gen(), rng.gen(), rng.gen());
            let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
            let q = nalgebra::Quaternion::new(
                b * (TAU * u3).cos(),
                a * (TAU * u2).sin(),
                a * (TAU * u2).cos(),
                b * (TAU * u3).sin(),
            );
            UnitQuaternion::from_quaternion(q)
        }
    }
}

/// Area-weighted upward triangles of a support.
struct SupportTriangles {
    tris: Vec<[Vector3<f64>; 3]>,
    cumulative: Vec<f64>,
}

impl SupportTriangles {
    fn sample(&self, rng: &mut impl Rng) -> Vector3<f64> {
        let total = *self.cumulative.last().unwrap_or(&0.0);
        let u = rng.gen::<f64>() * total;
        let k = self
            .cumulative
            .partition_point(|c| *c <= u)
            .min(self.tris.len() - 1);
        let [a, b, c] = self.tris[k];
        // Uniform in a triangle (Osada et al. 2002, eq. 1):
        // (1 - sqrt r1) a + sqrt r1 (1 - r2) b + sqrt r1 r2 c.
        let (r1, r2): (f64, f64) = (rng.gen(), rng.gen());
        let s = r1.sqrt();
        a * (1.0 - s) + b * (s * (1.0 - r2)) + c * (s * r2)
    }

    /// Whether a support triangle lies under `q` (along `up`) within `tol` of `q`'s height.
    fn under(&self, q: &Vector3<f64>, up: &Vector3<f64>, tol: f64) -> bool {
        let (e1, e2) = plane_axes(up);
        let q2 = [q.dot(&e1), q.dot(&e2)];
        let h = q.dot(up);
        self.tris.iter().any(|[a, b, c]| {
            let (a2, b2, c2) = (
                [a.dot(&e1), a.dot(&e2)],
                [b.dot(&e1), b.dot(&e2)],
                [c.dot(&e1), c.dot(&e2)],
            );
            // Barycentric coordinates of q2 in the projected triangle.
            let det = (b2[0] - a2[0]) * (c2[1] - a2[1]) - (c2[0] - a2[0]) * (b2[1] - a2[1]);
            if det.abs() < 1e-300 {
                return false;
            }
            let u = ((q2[0] - a2[0]) * (c2[1] - a2[1]) - (c2[0] - a2[0]) * (q2[1] - a2[1])) / det;
            let v = ((b2[0] - a2[0]) * (q2[1] - a2[1]) - (q2[0] - a2[0]) * (b2[1] - a2[1])) / det;
            let eps = 1e-12;
            if u < -eps || v < -eps || u + v > 1.0 + eps {
                return false;
            }
            let ht = a.dot(up) * (1.0 - u - v) + b.dot(up) * u + c.dot(up) * v;
            (h - ht).abs() <= tol
        })
    }
}

/// Two unit axes orthogonal to the unit vector `n` (and to each other).
fn plane_axes(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let r = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::z()
    };
    let e1 = (r - n * n.dot(&r)).normalize();
    (e1, n.cross(&e1))
}

/// The points of `pts` (rotated hull vertices) that the object stands on: within
/// `max(1 mm, 2 % of its height)` of its lowest point along `n`, and that tolerance.
fn base_points(pts: &[Vector3<f64>], n: &Vector3<f64>) -> (Vec<Vector3<f64>>, f64) {
    let lo = pts.iter().map(|q| q.dot(n)).fold(f64::INFINITY, f64::min);
    let hi = pts
        .iter()
        .map(|q| q.dot(n))
        .fold(f64::NEG_INFINITY, f64::max);
    let tol = (0.02 * (hi - lo)).max(1e-3);
    (
        pts.iter()
            .filter(|q| q.dot(n) - lo <= tol)
            .copied()
            .collect(),
        tol,
    )
}

fn support_triangles(
    scene: &camsim_scene3d::SceneDescription,
    pattern: &str,
    up: &Vector3<f64>,
    max_slope_deg: f64,
    key: &str,
) -> Result<SupportTriangles> {
    let cos_max = max_slope_deg.to_radians().cos();
    let mut tris = Vec::new();
    let mut cumulative = Vec::new();
    let mut total = 0.0;
    let mut matched = 0;
    for s in &scene.shapes {
        if !s
            .name
            .as_deref()
            .is_some_and(|n| camsim_pbrt::overlay::glob_match(pattern, n))
        {
            continue;
        }
        matched += 1;
        if let camsim_scene3d::Geometry::Triangles {
            positions, indices, ..
        } = &s.geometry
        {
            for t in indices {
                let [a, b, c] = t.map(|i| v3(positions[i as usize]));
                let n = (b - a).cross(&(c - a));
                let area2 = n.norm();
                // Winding as the file gives it; a reversed shape faces the other way.
                let sign = if s.reverse_orientation { -1.0 } else { 1.0 };
                if area2 > 0.0 && sign * n.dot(up) / area2 >= cos_max {
                    total += 0.5 * area2;
                    tris.push([a, b, c]);
                    cumulative.push(total);
                }
            }
        }
    }
    if matched == 0 {
        let mut names: Vec<&str> = scene
            .shapes
            .iter()
            .filter_map(|s| s.name.as_deref())
            .collect();
        names.sort_unstable();
        names.dedup();
        return Err(ComposeError::new(
            format!("{key}.on"),
            format!(
                "no scene object is named {pattern:?} (objects: {})",
                names.join(", ")
            ),
        ));
    }
    if tris.is_empty() {
        return Err(ComposeError::new(
            format!("{key}.on"),
            format!(
                "{pattern:?} has no triangle facing up (within max_slope_deg of up): nothing to stand on"
            ),
        ));
    }
    Ok(SupportTriangles { tris, cumulative })
}

enum Sampler {
    Surface {
        tris: SupportTriangles,
        normal: Vector3<f64>,
    },
    Plane {
        centre: Vector3<f64>,
        normal: Vector3<f64>,
        axes: [Vector3<f64>; 2],
        extent: [f64; 2],
    },
    Inside(BoxVolume),
    Grid {
        g: GridPlacement,
        order: Vec<[u32; 3]>,
    },
}

/// Why candidates were refused, counted.
#[derive(Default)]
struct Refusals {
    scene: u32,
    separation: u32,
    fit: u32,
    overhang: u32,
}

impl Refusals {
    fn worst(&self, min_sep: f64) -> String {
        let mut v = [
            (
                self.scene,
                "it would intersect the scene's geometry".to_string(),
            ),
            (
                self.separation,
                if min_sep > 0.0 {
                    format!("min_separation_m = {min_sep} from the objects placed before")
                } else {
                    "it would intersect an object placed before".to_string()
                },
            ),
            (self.fit, "it does not fit inside the box".to_string()),
            (
                self.overhang,
                "its base would overhang the support's edge".to_string(),
            ),
        ];
        v.sort_by_key(|r| std::cmp::Reverse(r.0));
        v.iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, m)| format!("{m} ({n} times)"))
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// Place the objects of every entry (in order; each entry its own keyed stream
/// `stream(seed, SPAWN, i)`); `statics` is the scene's geometry before composing.
#[allow(clippy::too_many_arguments)]
pub fn place_all(
    spawns: &[SpawnSpec],
    library: &Library,
    scene: &camsim_scene3d::SceneDescription,
    statics: &Statics,
    up: &Unit<Vector3<f64>>,
    seed: u64,
    collider: CollisionShape,
    key: &str,
) -> Result<Vec<Placed>> {
    let mut placed: Vec<Placed> = Vec::new();
    for (i, s) in spawns.iter().enumerate() {
        let ekey = entry_key(key, i, s);
        let mut rng = crate::stream(seed, crate::stage::SPAWN, i as u64);
        let n = rng.gen_range(s.count[0]..=s.count[1]) as usize;
        let mut sampler = match (&s.on, &s.inside, &s.grid) {
            (Some(Support::Object(name)), _, _) => Sampler::Surface {
                tris: support_triangles(scene, name, up, s.max_slope_deg, &ekey)?,
                normal: up.into_inner(),
            },
            (Some(Support::Plane(p)), _, _) => {
                let (nrm, axes) = plane_frame(p);
                Sampler::Plane {
                    centre: v3(p.point_m),
                    normal: nrm,
                    axes,
                    extent: p.extent_m,
                }
            }
            (_, Some(b), _) => Sampler::Inside(b.clone()),
            (_, _, Some(g)) => {
                let mut order = Vec::new();
                for a in 0..g.count[0] {
                    for b in 0..g.count[1] {
                        for c in 0..g.count[2] {
                            order.push([a, b, c]);
                        }
                    }
                }
                // Fisher-Yates shuffle (Knuth TAOCP vol. 2, algorithm P).
                for k in (1..order.len()).rev() {
                    let j = rng.gen_range(0..=k);
                    order.swap(k, j);
                }
                Sampler::Grid {
                    g: g.clone(),
                    order,
                }
            }
            _ => return Err(ComposeError::new(&ekey, "no placement sampler")),
        };
        let mut cands = s.candidates(library);
        for k in 0..n {
            if cands.is_empty() {
                return Err(ComposeError::new(
                    format!("{ekey}.count"),
                    "no asset left to draw without replacement",
                ));
            }
            let w: Vec<f64> = cands.iter().map(|c| c.1).collect();
            let pick = draw_weighted(&mut rng, &w);
            let ai = cands[pick].0;
            if !s.replacement {
                cands.remove(pick);
            }
            let asset = &library.assets[ai];
            let scale = if s.scale[1] > s.scale[0] {
                rng.gen_range(s.scale[0]..=s.scale[1])
            } else {
                s.scale[0]
            };
            let what = format!(
                "{ekey}: object {k} ({}, category {:?})",
                asset.path.display(),
                asset.category
            );
            let shape = physics::collider_shape(&asset.mesh, scale, collider)
                .map_err(|m| ComposeError::new(&what, m))?;
            let hull: Vec<Vector3<f64>> = physics::hull_points(&asset.mesh)
                .map_err(|m| ComposeError::new(&what, m))?
                .iter()
                .map(|p| v3(*p) * scale)
                .collect();
            let radius_m = hull.iter().map(|p| p.norm()).fold(0.0, f64::max);
            // Centre of mass of the collider at uniform density, object frame.
            let com_local = shape.mass_properties(1.0).local_com.coords;
            let mut refusals = Refusals::default();
            let mut done = None;
            for _ in 0..s.max_tries {
                let rot = draw_rotation(&mut rng, s.orientation, up);
                let pts: Vec<Vector3<f64>> = hull.iter().map(|p| rot * p).collect();
                let (mut lo, mut hi) = (
                    Vector3::repeat(f64::INFINITY),
                    Vector3::repeat(f64::NEG_INFINITY),
                );
                for p in &pts {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                let centre = (lo + hi) / 2.0;
                let com = rot * com_local;
                let on_surface = |p: Vector3<f64>, nrm: &Vector3<f64>| {
                    // Lowest point CLEARANCE_M above p along nrm, the centre of mass over p (so
                    // an object standing on its base does not tip over the support's edge).
                    let m = pts.iter().map(|q| q.dot(nrm)).fold(f64::INFINITY, f64::min);
                    let c_perp = com - nrm * com.dot(nrm);
                    let p_perp = p - nrm * p.dot(nrm);
                    p_perp - c_perp + nrm * (p.dot(nrm) + CLEARANCE_M - m)
                };
                let t = match &mut sampler {
                    Sampler::Surface { tris, normal } => {
                        let p = tris.sample(&mut rng);
                        let t = on_surface(p, normal);
                        // The base must stand on the support, not overhang its edge.
                        let (base, tol) = base_points(&pts, normal);
                        if !base
                            .iter()
                            .all(|q| tris.under(&(q + t - *normal * CLEARANCE_M), normal, tol))
                        {
                            refusals.overhang += 1;
                            continue;
                        }
                        t
                    }
                    Sampler::Plane {
                        centre: c0,
                        normal,
                        axes,
                        extent,
                    } => {
                        let (a, b): (f64, f64) = (rng.gen(), rng.gen());
                        let p = *c0
                            + axes[0] * ((a - 0.5) * extent[0])
                            + axes[1] * ((b - 0.5) * extent[1]);
                        let t = on_surface(p, normal);
                        let (base, _) = base_points(&pts, normal);
                        let inside = base.iter().all(|q| {
                            let d = q + t - *c0;
                            (0..2).all(|k| d.dot(&axes[k]).abs() <= extent[k] / 2.0)
                        });
                        if !inside {
                            refusals.overhang += 1;
                            continue;
                        }
                        t
                    }
                    Sampler::Inside(bx) => {
                        let half = (hi - lo) / 2.0;
                        let mut q = Vector3::zeros();
                        let mut fits = true;
                        for d in 0..3 {
                            let (a, b) = (bx.min_m[d] + half[d], bx.max_m[d] - half[d]);
                            if a > b {
                                fits = false;
                            }
                            q[d] = if b > a { rng.gen_range(a..=b) } else { a };
                        }
                        if !fits {
                            refusals.fit += 1;
                            continue;
                        }
                        q - centre
                    }
                    Sampler::Grid { g, order } => {
                        let cell = order[k];
                        let mut q = Vector3::zeros();
                        for d in 0..3 {
                            let j = if g.jitter_m > 0.0 {
                                rng.gen_range(-g.jitter_m..=g.jitter_m)
                            } else {
                                0.0
                            };
                            q[d] = g.origin_m[d] + cell[d] as f64 * g.spacing_m[d] + j;
                        }
                        q - centre
                    }
                };
                let pose = Isometry3::from_parts(Translation3::from(t), rot);
                let hits_scene = statics.shapes.iter().any(|(iso, st)| {
                    parry3d_f64::query::intersection_test(&pose, &*shape, iso, &**st)
                        .unwrap_or(true)
                });
                if hits_scene {
                    refusals.scene += 1;
                    continue;
                }
                let aabb = shape.compute_aabb(&pose);
                let too_close = placed.iter().any(|o| {
                    let ob = o.shape.compute_aabb(&o.pose);
                    if !aabb.loosened(s.min_separation_m).intersects(&ob) {
                        return false;
                    }
                    if s.min_separation_m > 0.0 {
                        parry3d_f64::query::distance(&pose, &*shape, &o.pose, &*o.shape)
                            .map_or(true, |d| d < s.min_separation_m)
                    } else {
                        parry3d_f64::query::intersection_test(&pose, &*shape, &o.pose, &*o.shape)
                            .unwrap_or(true)
                    }
                });
                if too_close {
                    refusals.separation += 1;
                    continue;
                }
                done = Some(pose);
                break;
            }
            let pose = done.ok_or_else(|| {
                ComposeError::new(
                    &what,
                    format!(
                        "no place found in max_tries = {}: {}",
                        s.max_tries,
                        refusals.worst(s.min_separation_m)
                    ),
                )
            })?;
            placed.push(Placed {
                spawn: i,
                asset: ai,
                scale,
                pose,
                shape,
                radius_m,
            });
        }
    }
    Ok(placed)
}

/// A plane support's unit normal and its rectangle's axes (world x projected on the plane, or
/// world z when the normal is along x; then normal x that).
pub fn plane_frame(p: &PlaneSupport) -> (Vector3<f64>, [Vector3<f64>; 2]) {
    let nrm = v3(p.normal).normalize();
    let x = Vector3::x();
    let first = if (x - nrm * nrm.dot(&x)).norm() > 1e-6 {
        (x - nrm * nrm.dot(&x)).normalize()
    } else {
        let z = Vector3::z();
        (z - nrm * nrm.dot(&z)).normalize()
    };
    (nrm, [first, nrm.cross(&first)])
}

/// A plane support as a static collider: a slab 1 m thick under the plane, reaching 1 m beyond
/// its rectangle (rapier's broad phase takes no unbounded half-space).
pub fn plane_static(p: &PlaneSupport) -> (Isometry3<f64>, SharedShape) {
    let (n, [a, b]) = plane_frame(p);
    let rot = UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(
        nalgebra::Matrix3::from_columns(&[a, n, b]),
    ));
    let centre = v3(p.point_m) - n * 0.5;
    (
        Isometry3::from_parts(Translation3::from(centre), rot),
        SharedShape::cuboid(p.extent_m[0] / 2.0 + 1.0, 0.5, p.extent_m[1] / 2.0 + 1.0),
    )
}

/// A closed convex mesh's convex-polyhedron collider: `Some` when the mesh encloses its
/// hull's volume (to 0.1 %; the divergence theorem, V = sum a . (b x c) / 6 over the
/// triangles). Convex-convex contacts rest still where a convex body on a triangle mesh jitters
/// across the triangles' shared edges (rapier 0.25).
fn convex_collider(positions: &[[f64; 3]], indices: &[[u32; 3]]) -> Option<SharedShape> {
    if positions.len() < 4
        || indices
            .iter()
            .any(|t| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return None;
    }
    let pts: Vec<Point3<f64>> = positions
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
    let vol = |v: &[Point3<f64>], ix: &[[u32; 3]]| -> f64 {
        ix.iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| v[i as usize].coords);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum::<f64>()
    };
    let (hv, hi) =
        std::panic::catch_unwind(|| parry3d_f64::transformation::try_convex_hull(&pts).ok())
            .ok()
            .flatten()?;
    let v_hull = vol(&hv, &hi).abs();
    let v_mesh = vol(&pts, indices).abs();
    if !(v_hull > 0.0) || (v_mesh - v_hull).abs() > 1e-3 * v_hull {
        return None;
    }
    SharedShape::convex_hull(&pts)
}

/// The static world of a scene: its closed convex meshes as convex colliders, its other
/// triangles as one triangle mesh, its spheres as balls (partial spheres and curves are left
/// out).
pub fn scene_statics(scene: &camsim_scene3d::SceneDescription) -> Statics {
    use camsim_scene3d::Geometry;
    let mut verts = Vec::new();
    let mut idx = Vec::new();
    let mut out = Statics::default();
    for s in &scene.shapes {
        match &s.geometry {
            Geometry::Triangles {
                positions, indices, ..
            } => {
                if let Some(c) = convex_collider(positions, indices) {
                    out.shapes.push((Isometry3::identity(), c));
                    continue;
                }
                let base = verts.len() as u32;
                verts.extend(positions.iter().map(|p| Point3::new(p[0], p[1], p[2])));
                idx.extend(
                    indices
                        .iter()
                        .filter(|t| t.iter().all(|&i| (i as usize) < positions.len()))
                        .map(|t| t.map(|i| i + base)),
                );
            }
            Geometry::Sphere { center, radius } if *radius > 0.0 => {
                out.shapes.push((
                    Isometry3::translation(center[0], center[1], center[2]),
                    SharedShape::ball(*radius),
                ));
            }
            _ => {}
        }
    }
    if !idx.is_empty() {
        use parry3d_f64::shape::TriMeshFlags;
        let mesh = SharedShape::trimesh_with_flags(
            verts.clone(),
            idx.clone(),
            TriMeshFlags::FIX_INTERNAL_EDGES,
        )
        .or_else(|_| SharedShape::trimesh(verts, idx));
        if let Ok(m) = mesh {
            out.shapes.push((Isometry3::identity(), m));
        }
    }
    out
}

/// The asset of a placed object.
pub fn asset_of<'a>(library: &'a Library, p: &Placed) -> &'a Asset {
    &library.assets[p.asset]
}
