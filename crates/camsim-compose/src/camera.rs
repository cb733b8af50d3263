//! Camera samplers (`[compose.camera]`): put the camera on a spherical shell around a target
//! (a point, a named object's bounds centre, or the spawned group's centre), looking at it,
//! with a random distance, elevation, azimuth, roll and optionally field of view; and validate
//! the view with cheap ray casts against the scene's geometry (a coarse grid of camera rays
//! through a bounding-volume hierarchy of the scene's triangles and spheres), redrawing views
//! in which too few objects are visible enough or the background fills too much.
//!
//! Visibility of an object (every shape of one `ShapeTags::instance`, or a shape by itself) is
//! `rays whose first hit is the object, inside the frame / rays that hit the object anywhere
//! along them, over a grid 1.5 times the frame in each direction`: occlusion and truncation by
//! the frame's edges both lower it. The background is the fraction of in-frame rays whose first
//! hit is none of the counted objects (the environment, or an uncounted shape such as a floor).
//! Curves are not cast against; partial spheres count as whole spheres.

use crate::environment::{Draw, Frame};
use crate::{stage, stream, ComposeError, Result};
use camsim_scene3d::{Geometry, SceneDescription, Transform};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Which objects the view validation counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CountedObjects {
    /// Objects with a category (`ShapeTags::category`: the spawned assets, not supports).
    #[default]
    Categorised,
    /// Every object (instance, or shape without an instance).
    All,
}

/// `[compose.camera]`: where the camera of every sample goes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraSamplerSpec {
    /// The point to look at, metres (world). Default: `target_object`'s centre, else the
    /// target the composition passes in (the spawned group's centre), else the centre of the
    /// scene's bounds.
    #[serde(default)]
    pub target_m: Option<[f64; 3]>,
    /// Look at the centre of the bounds of the shapes with this `name`. Default: none.
    #[serde(default)]
    pub target_object: Option<String>,
    /// Distance from the target to the camera, metres: a value or a `[min, max]` range drawn
    /// uniformly. Default `[1, 3]`.
    #[serde(default = "default_distance")]
    pub distance_m: Draw,
    /// Elevation of the camera above the plane through the target normal to `up`, degrees
    /// (-90..90): a value or a range. Default `[10, 60]`.
    #[serde(default = "default_elevation")]
    pub elevation_deg: Draw,
    /// Azimuth of the camera about `up` through the target, degrees, from the reference
    /// horizontal axis (world +x, or +z when up is along x) toward `up x` that axis: a value
    /// or a range. Default `[0, 360]`.
    #[serde(default = "default_azimuth")]
    pub azimuth_deg: Draw,
    /// Rotation of the camera about its optical axis, degrees: a value or a range. Default 0.
    #[serde(default = "zero")]
    pub roll_deg: Draw,
    /// Field of view across the shorter image axis, degrees (1..170): a value or a range.
    /// Default: leave the scene's (the pipeline's sensor-matched field of view).
    #[serde(default)]
    pub fov_deg: Option<Draw>,
    /// The world's up axis (need not be normalised). Default `[0, 1, 0]`.
    #[serde(default = "y_up")]
    pub up: [f64; 3],
    /// A view needs at least this many counted objects each at least `min_visible_fraction`
    /// visible. Default 0 (no check).
    #[serde(default)]
    pub min_visible_objects: usize,
    /// Visible fraction (0..1) an object needs to count toward `min_visible_objects`. Default
    /// 0.5.
    #[serde(default = "half")]
    pub min_visible_fraction: f64,
    /// A view is redrawn when more than this fraction (0..1) of the frame shows no counted
    /// object. Default 1 (no check).
    #[serde(default = "one")]
    pub max_background_fraction: f64,
    /// Which objects count: `categorised` (those with a category, the spawned assets) or `all`.
    /// Default `categorised`.
    #[serde(default)]
    pub counted_objects: CountedObjects,
    /// Views drawn before giving up with an error naming the constraint. Default 50.
    #[serde(default = "default_tries")]
    pub max_tries: usize,
    /// Validation rays across the frame, `[columns, rows]` (each 4..512). Default `[48, 36]`.
    #[serde(default = "default_rays")]
    pub validation_rays: [usize; 2],
    /// Set the scene's focus distance to the camera's distance from the target. Default true.
    #[serde(default = "yes")]
    pub focus_on_target: bool,
}

fn default_distance() -> Draw {
    Draw::Range([1.0, 3.0])
}
fn default_elevation() -> Draw {
    Draw::Range([10.0, 60.0])
}
fn default_azimuth() -> Draw {
    Draw::Range([0.0, 360.0])
}
fn zero() -> Draw {
    Draw::Fixed(0.0)
}
fn y_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn half() -> f64 {
    0.5
}
fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn default_tries() -> usize {
    50
}
fn default_rays() -> [usize; 2] {
    [48, 36]
}

impl Default for CameraSamplerSpec {
    fn default() -> Self {
        CameraSamplerSpec {
            target_m: None,
            target_object: None,
            distance_m: default_distance(),
            elevation_deg: default_elevation(),
            azimuth_deg: default_azimuth(),
            roll_deg: zero(),
            fov_deg: None,
            up: y_up(),
            min_visible_objects: 0,
            min_visible_fraction: 0.5,
            max_background_fraction: 1.0,
            counted_objects: CountedObjects::Categorised,
            max_tries: default_tries(),
            validation_rays: default_rays(),
            focus_on_target: true,
        }
    }
}

/// One counted object's visibility in the accepted view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectVisibility {
    /// The object's shape name (its first named shape), or `instance <k>` / `shape <i>`.
    pub object: String,
    /// Visible fraction (see the module docs), 0..1.
    pub fraction: f64,
}

/// What [`apply`] drew, for the sample's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraRecord {
    /// The camera's position (its pinhole), metres.
    pub position_m: [f64; 3],
    /// The point looked at, metres.
    pub target_m: [f64; 3],
    pub distance_m: f64,
    pub elevation_deg: f64,
    pub azimuth_deg: f64,
    pub roll_deg: f64,
    /// Field of view across the shorter image axis, degrees.
    pub fov_deg: f64,
    /// Views drawn, the accepted one included.
    pub tries: usize,
    /// Counted objects at least `min_visible_fraction` visible (`None`: no validation ran).
    pub visible_objects: Option<usize>,
    /// Fraction of the frame showing no counted object (`None`: no validation ran).
    pub background_fraction: Option<f64>,
    /// Each counted object's visible fraction (empty when no validation ran).
    pub objects: Vec<ObjectVisibility>,
}

/// Keyed draws of one try.
const DRAWS_PER_TRY: u64 = 1;

/// Place the scene's camera as `spec` says, every draw from `seed` (the camera stage's keyed
/// streams, one per try); `target` is the composition's default target (the spawned group's
/// centre). Returns what was drawn, or an error naming the key or the constraint no view met.
pub fn apply(
    scene: &mut SceneDescription,
    spec: &CameraSamplerSpec,
    seed: u64,
    target: Option<[f64; 3]>,
) -> Result<CameraRecord> {
    let key = "compose.camera";
    let k = |f: &str| format!("{key}.{f}");
    spec.distance_m.check(&k("distance_m"), 1e-6, 1e9)?;
    spec.elevation_deg.check(&k("elevation_deg"), -90.0, 90.0)?;
    spec.azimuth_deg.check(&k("azimuth_deg"), -1e6, 1e6)?;
    spec.roll_deg.check(&k("roll_deg"), -1e6, 1e6)?;
    if let Some(f) = &spec.fov_deg {
        f.check(&k("fov_deg"), 1.0, 170.0)?;
        if scene.camera.lens.is_some() {
            return Err(ComposeError::new(
                k("fov_deg"),
                "the scene's camera has a lens (realistic or ray-transfer): its field of view is the lens's, not a key",
            ));
        }
    }
    let frame = Frame::new(spec.up).ok_or_else(|| {
        ComposeError::new(k("up"), format!("{:?} is not a usable direction", spec.up))
    })?;
    if !(0.0..=1.0).contains(&spec.min_visible_fraction) {
        return Err(ComposeError::new(
            k("min_visible_fraction"),
            format!("{} must lie within [0, 1]", spec.min_visible_fraction),
        ));
    }
    if !(0.0..=1.0).contains(&spec.max_background_fraction) {
        return Err(ComposeError::new(
            k("max_background_fraction"),
            format!("{} must lie within [0, 1]", spec.max_background_fraction),
        ));
    }
    if spec.max_tries == 0 {
        return Err(ComposeError::new(k("max_tries"), "must be at least 1"));
    }
    if spec.validation_rays.iter().any(|n| !(4..=512).contains(n)) {
        return Err(ComposeError::new(
            k("validation_rays"),
            format!("{:?}: each must lie within 4..512", spec.validation_rays),
        ));
    }
    if scene.camera.width == 0 || scene.camera.height == 0 {
        return Err(ComposeError::new(key, "the scene's camera has no pixels"));
    }
    let target_m = resolve_target(scene, spec, target)?;
    let validate = spec.min_visible_objects > 0 || spec.max_background_fraction < 1.0;
    let caster = if validate {
        let c = Caster::new(scene, spec.counted_objects);
        if c.counted.len() < spec.min_visible_objects {
            return Err(ComposeError::new(
                k("min_visible_objects"),
                format!(
                    "{} but the scene has only {} counted objects ({:?})",
                    spec.min_visible_objects,
                    c.counted.len(),
                    spec.counted_objects
                ),
            ));
        }
        Some(c)
    } else {
        None
    };
    // Keep the scene camera's handedness: a negative determinant is pbrt's `Scale -1 1 1` before
    // `LookAt` (the image shows a right-handed world unmirrored).
    let right_handed_view = camsim_scene3d::transform::det3(&scene.camera.camera_to_world) < 0.0;
    let mut best: Option<(usize, f64)> = None;
    for t in 0..spec.max_tries {
        let mut rng = stream(seed, stage::CAMERA, t as u64 * DRAWS_PER_TRY);
        let distance_m = spec.distance_m.draw(&mut rng);
        let elevation_deg = spec.elevation_deg.draw(&mut rng);
        let azimuth_deg = spec.azimuth_deg.draw(&mut rng);
        let roll_deg = spec.roll_deg.draw(&mut rng);
        let fov_deg = match &spec.fov_deg {
            Some(f) => f.draw(&mut rng),
            None => scene.camera.fov_deg,
        };
        let Some(c2w) = pose(
            &frame,
            target_m,
            distance_m,
            elevation_deg,
            azimuth_deg,
            roll_deg,
            right_handed_view,
        ) else {
            continue;
        };
        let position_m = c2w.apply_point([0.0; 3]);
        let mut record = CameraRecord {
            position_m,
            target_m,
            distance_m,
            elevation_deg,
            azimuth_deg,
            roll_deg,
            fov_deg,
            tries: t + 1,
            visible_objects: None,
            background_fraction: None,
            objects: Vec::new(),
        };
        if let Some(c) = &caster {
            let v = c.view(
                &c2w,
                fov_deg,
                scene.camera.width,
                scene.camera.height,
                spec.validation_rays,
            );
            let n_ok = v
                .fractions
                .iter()
                .filter(|f| **f >= spec.min_visible_fraction)
                .count();
            record.visible_objects = Some(n_ok);
            record.background_fraction = Some(v.background);
            record.objects = c
                .counted
                .iter()
                .zip(&v.fractions)
                .map(|(g, f)| ObjectVisibility {
                    object: c.labels[*g].clone(),
                    fraction: *f,
                })
                .collect();
            let ok =
                n_ok >= spec.min_visible_objects && v.background <= spec.max_background_fraction;
            if !ok {
                if best.is_none_or(|(n, b)| n_ok > n || (n_ok == n && v.background < b)) {
                    best = Some((n_ok, v.background));
                }
                continue;
            }
        }
        scene.camera.camera_to_world = c2w;
        scene.camera.fov_deg = fov_deg;
        if spec.focus_on_target {
            scene.focus_distance_m = Some(distance_m);
        }
        return Ok(record);
    }
    let (n, b) = best.unwrap_or((0, 1.0));
    Err(ComposeError::new(
        key,
        format!(
            "no view in max_tries = {} met min_visible_objects = {} (each >= min_visible_fraction = {}) and max_background_fraction = {}: the best view had {n} such objects and a background fraction of {b:.3}; widen distance_m / elevation_deg, lower the constraints or raise max_tries",
            spec.max_tries, spec.min_visible_objects, spec.min_visible_fraction, spec.max_background_fraction
        ),
    ))
}

/// The target point: `target_m`, else `target_object`'s bounds centre, else `target`, else the
/// centre of the scene's bounds.
fn resolve_target(
    scene: &SceneDescription,
    spec: &CameraSamplerSpec,
    target: Option<[f64; 3]>,
) -> Result<[f64; 3]> {
    if let Some(t) = spec.target_m {
        if t.iter().all(|v| v.is_finite()) {
            return Ok(t);
        }
        return Err(ComposeError::new(
            "compose.camera.target_m",
            format!("{t:?} is not finite"),
        ));
    }
    let bounds_of = |f: &dyn Fn(&camsim_scene3d::Shape) -> bool| {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for s in scene.shapes.iter().filter(|s| f(s)) {
            if matches!(s.geometry, Geometry::Curves(_)) {
                continue;
            }
            let (a, b) = camsim_scene3d::xform::shape_bounds(&s.geometry);
            for i in 0..3 {
                lo[i] = lo[i].min(a[i]);
                hi[i] = hi[i].max(b[i]);
            }
        }
        (lo.iter().chain(&hi).all(|v| v.is_finite()))
            .then(|| std::array::from_fn(|i| 0.5 * (lo[i] + hi[i])))
    };
    if let Some(name) = &spec.target_object {
        return bounds_of(&|s| s.name.as_deref() == Some(name.as_str())).ok_or_else(|| {
            ComposeError::new(
                "compose.camera.target_object",
                format!("no shape named {name:?} with bounds in the scene"),
            )
        });
    }
    if let Some(t) = target {
        return Ok(t);
    }
    bounds_of(&|_| true).ok_or_else(|| {
        ComposeError::new(
            "compose.camera",
            "no target: give target_m or target_object (the scene has no geometry to centre on)",
        )
    })
}

/// Camera-to-world of a camera on the shell: at `target + d (cos e (cos a r + sin a (up x r)) +
/// sin e up)` looking at the target, `up` the image's up, then rolled about the optical axis.
/// `right_handed_view`: as [`camsim_scene3d::look_at_camera_to_world`] (camera +x to
/// `dir x up`, pbrt's `Scale -1 1 1` then `LookAt`).
pub fn pose(
    frame: &Frame,
    target_m: [f64; 3],
    distance_m: f64,
    elevation_deg: f64,
    azimuth_deg: f64,
    roll_deg: f64,
    right_handed_view: bool,
) -> Option<Transform> {
    let (se, ce) = elevation_deg.to_radians().sin_cos();
    let (sa, ca) = azimuth_deg.to_radians().sin_cos();
    let r = frame.reference;
    let u = frame.up;
    let side = [
        u[1] * r[2] - u[2] * r[1],
        u[2] * r[0] - u[0] * r[2],
        u[0] * r[1] - u[1] * r[0],
    ];
    let dir: [f64; 3] = std::array::from_fn(|i| ce * (ca * r[i] + sa * side[i]) + se * u[i]);
    let from: [f64; 3] = std::array::from_fn(|i| target_m[i] + distance_m * dir[i]);
    // Looking straight down or up: the image's up is the reference axis instead.
    let img_up = if ce.abs() < 1e-6 { side } else { u };
    let mut c2w =
        camsim_scene3d::look_at_camera_to_world(from, target_m, img_up, right_handed_view)?;
    let (sr, cr) = roll_deg.to_radians().sin_cos();
    // Roll: camera x' = cos x + sin y, y' = -sin x + cos y (columns 0 and 1 of the rotation).
    for row in c2w.m.iter_mut().take(3) {
        let (x, y) = (row[0], row[1]);
        row[0] = cr * x + sr * y;
        row[1] = -sr * x + cr * y;
    }
    Some(c2w)
}

/// A primitive of the validation ray caster.
#[derive(Debug, Clone, Copy)]
enum Prim {
    Tri {
        p0: [f64; 3],
        e1: [f64; 3],
        e2: [f64; 3],
    },
    Sphere {
        c: [f64; 3],
        r: f64,
    },
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: first primitive and count; inner: `count == 0`, children at `first`, `first + 1`.
    first: usize,
    count: usize,
}

/// A bounding-volume hierarchy (median split on the longest axis, leaves of up to 4
/// primitives) over the scene's triangles and spheres, each tagged with its object.
struct Caster {
    prims: Vec<Prim>,
    group: Vec<usize>,
    nodes: Vec<Node>,
    /// Object index -> position in `counted` (or `usize::MAX`).
    counted_slot: Vec<usize>,
    /// Counted object indices.
    counted: Vec<usize>,
    labels: Vec<String>,
}

/// One view's visibility figures.
struct View {
    /// Per counted object (as `Caster::counted`).
    fractions: Vec<f64>,
    background: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
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

impl Caster {
    fn new(scene: &SceneDescription, counted_objects: CountedObjects) -> Caster {
        // Objects: one per instance, one per shape without an instance.
        let mut object_of_instance = std::collections::HashMap::new();
        let mut labels: Vec<String> = Vec::new();
        let mut categorised: Vec<bool> = Vec::new();
        let mut prims = Vec::new();
        let mut group = Vec::new();
        for (i, s) in scene.shapes.iter().enumerate() {
            let g = match s.tags.instance {
                Some(k) => *object_of_instance.entry(k).or_insert_with(|| {
                    labels.push(format!("instance {k}"));
                    categorised.push(false);
                    labels.len() - 1
                }),
                None => {
                    labels.push(format!("shape {i}"));
                    categorised.push(false);
                    labels.len() - 1
                }
            };
            if let Some(n) = &s.name {
                if labels[g].starts_with("instance ") || labels[g].starts_with("shape ") {
                    labels[g] = n.clone();
                }
            }
            categorised[g] |= s.tags.category.is_some();
            match &s.geometry {
                Geometry::Triangles {
                    positions, indices, ..
                } => {
                    for t in indices {
                        let p = t.map(|v| positions.get(v as usize).copied());
                        if let [Some(a), Some(b), Some(c)] = p {
                            prims.push(Prim::Tri {
                                p0: a,
                                e1: sub(b, a),
                                e2: sub(c, a),
                            });
                            group.push(g);
                        }
                    }
                }
                Geometry::Sphere { center, radius }
                | Geometry::PartialSphere { center, radius, .. } => {
                    prims.push(Prim::Sphere {
                        c: *center,
                        r: *radius,
                    });
                    group.push(g);
                }
                Geometry::Curves(_) => {}
            }
        }
        let counted: Vec<usize> = (0..labels.len())
            .filter(|g| counted_objects == CountedObjects::All || categorised[*g])
            .collect();
        let mut counted_slot = vec![usize::MAX; labels.len()];
        for (slot, g) in counted.iter().enumerate() {
            counted_slot[*g] = slot;
        }
        let mut c = Caster {
            prims,
            group,
            nodes: Vec::new(),
            counted_slot,
            counted,
            labels,
        };
        c.build();
        c
    }

    fn prim_bounds(p: &Prim) -> ([f64; 3], [f64; 3]) {
        match *p {
            Prim::Tri { p0, e1, e2 } => {
                let (b, c) = (
                    [p0[0] + e1[0], p0[1] + e1[1], p0[2] + e1[2]],
                    [p0[0] + e2[0], p0[1] + e2[1], p0[2] + e2[2]],
                );
                (
                    std::array::from_fn(|i| p0[i].min(b[i]).min(c[i])),
                    std::array::from_fn(|i| p0[i].max(b[i]).max(c[i])),
                )
            }
            Prim::Sphere { c, r } => (c.map(|v| v - r), c.map(|v| v + r)),
        }
    }

    fn build(&mut self) {
        let n = self.prims.len();
        if n == 0 {
            return;
        }
        let bounds: Vec<([f64; 3], [f64; 3])> = self.prims.iter().map(Self::prim_bounds).collect();
        let mut order: Vec<usize> = (0..n).collect();
        self.nodes.push(Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: n,
        });
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((node, start, end)) = stack.pop() {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for &p in &order[start..end] {
                for i in 0..3 {
                    lo[i] = lo[i].min(bounds[p].0[i]);
                    hi[i] = hi[i].max(bounds[p].1[i]);
                }
            }
            self.nodes[node].lo = lo;
            self.nodes[node].hi = hi;
            if end - start <= 4 {
                self.nodes[node].first = start;
                self.nodes[node].count = end - start;
                continue;
            }
            let ext = sub(hi, lo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (start + end) / 2;
            let centre = |p: usize| bounds[p].0[axis] + bounds[p].1[axis];
            order[start..end]
                .select_nth_unstable_by(mid - start, |a, b| centre(*a).total_cmp(&centre(*b)));
            let left = self.nodes.len();
            self.nodes.push(Node {
                lo,
                hi,
                first: 0,
                count: 0,
            });
            self.nodes.push(Node {
                lo,
                hi,
                first: 0,
                count: 0,
            });
            self.nodes[node].first = left;
            self.nodes[node].count = 0;
            stack.push((left, start, mid));
            stack.push((left + 1, mid, end));
        }
        let prims: Vec<Prim> = order.iter().map(|&i| self.prims[i]).collect();
        let group: Vec<usize> = order.iter().map(|&i| self.group[i]).collect();
        self.prims = prims;
        self.group = group;
    }

    /// Nearest positive hit distance of a ray with a primitive.
    fn hit(p: &Prim, o: [f64; 3], d: [f64; 3]) -> Option<f64> {
        match *p {
            // Moller and Trumbore, "Fast, minimum storage ray-triangle intersection", JGT 1997.
            Prim::Tri { p0, e1, e2 } => {
                let pv = cross(d, e2);
                let det = dot(e1, pv);
                if det.abs() < 1e-300 {
                    return None;
                }
                let inv = 1.0 / det;
                let tv = sub(o, p0);
                let u = dot(tv, pv) * inv;
                if !(0.0..=1.0).contains(&u) {
                    return None;
                }
                let qv = cross(tv, e1);
                let v = dot(d, qv) * inv;
                if v < 0.0 || u + v > 1.0 {
                    return None;
                }
                let t = dot(e2, qv) * inv;
                (t > 1e-9).then_some(t)
            }
            Prim::Sphere { c, r } => {
                let oc = sub(o, c);
                let b = dot(oc, d);
                let cc = dot(oc, oc) - r * r;
                let disc = b * b - cc;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                [-b - s, -b + s].into_iter().find(|t| *t > 1e-9)
            }
        }
    }

    /// Every object the ray meets, with its nearest hit distance, into `t_of` (per object,
    /// infinite where missed); returns the object hit first.
    fn cast(
        &self,
        o: [f64; 3],
        d: [f64; 3],
        t_of: &mut [f64],
        touched: &mut Vec<usize>,
        stack: &mut Vec<usize>,
    ) -> Option<usize> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = d.map(|v| 1.0 / v);
        let mut first: Option<(f64, usize)> = None;
        stack.clear();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            // Slab test (Kay and Kajiya 1986).
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            for i in 0..3 {
                let (a, b) = ((node.lo[i] - o[i]) * inv[i], (node.hi[i] - o[i]) * inv[i]);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                t0 = t0.max(if a.is_nan() { f64::NEG_INFINITY } else { a });
                t1 = t1.min(if b.is_nan() { f64::INFINITY } else { b });
            }
            if t0 > t1 * (1.0 + 1e-12) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            for i in node.first..node.first + node.count {
                if let Some(t) = Self::hit(&self.prims[i], o, d) {
                    let g = self.group[i];
                    if t_of[g].is_infinite() {
                        touched.push(g);
                    }
                    if t < t_of[g] {
                        t_of[g] = t;
                    }
                    if first.is_none_or(|(tf, _)| t < tf) {
                        first = Some((t, g));
                    }
                }
            }
        }
        first.map(|(_, g)| g)
    }

    /// Visibility of the counted objects and the background fraction for a pinhole camera at
    /// `c2w` (camera space +z forward, +y up) with `fov_deg` across the shorter image axis.
    fn view(
        &self,
        c2w: &Transform,
        fov_deg: f64,
        width: usize,
        height: usize,
        rays: [usize; 2],
    ) -> View {
        let tan_half = (fov_deg.to_radians() / 2.0).tan();
        let aspect = width as f64 / height as f64;
        let (hx, hy) = if aspect >= 1.0 {
            (tan_half * aspect, tan_half)
        } else {
            (tan_half, tan_half / aspect)
        };
        let o = c2w.apply_point([0.0; 3]);
        let nobj = self.labels.len();
        let (mut vis, mut total) = (vec![0usize; nobj], vec![0usize; nobj]);
        let mut t_of = vec![f64::INFINITY; nobj];
        let mut touched = Vec::new();
        let mut stack = Vec::new();
        let (mut background, mut in_frame) = (0usize, 0usize);
        // The grid extends 1.5x the frame in each direction (so truncation lowers visibility);
        // in-frame rays sit at the frame's cell centres.
        let margin = 1.5;
        let (nx, ny) = (rays[0] as i64, rays[1] as i64);
        let (ex, ey) = (
            ((margin - 1.0) / 2.0 * nx as f64).ceil() as i64,
            ((margin - 1.0) / 2.0 * ny as f64).ceil() as i64,
        );
        for j in -ey..ny + ey {
            for i in -ex..nx + ex {
                let sx = (2.0 * (i as f64 + 0.5) / nx as f64 - 1.0) * hx;
                let sy = (1.0 - 2.0 * (j as f64 + 0.5) / ny as f64) * hy;
                let d = c2w.apply_vector([sx, sy, 1.0]);
                let l = dot(d, d).sqrt();
                let d = d.map(|v| v / l);
                let inside = (0..nx).contains(&i) && (0..ny).contains(&j);
                let first = self.cast(o, d, &mut t_of, &mut touched, &mut stack);
                for g in touched.drain(..) {
                    total[g] += 1;
                    t_of[g] = f64::INFINITY;
                }
                if inside {
                    in_frame += 1;
                    match first {
                        Some(g) if self.counted_slot[g] != usize::MAX => vis[g] += 1,
                        _ => background += 1,
                    }
                }
            }
        }
        View {
            fractions: self
                .counted
                .iter()
                .map(|g| {
                    if total[*g] > 0 {
                        vis[*g] as f64 / total[*g] as f64
                    } else {
                        0.0
                    }
                })
                .collect(),
            background: background as f64 / in_frame.max(1) as f64,
        }
    }
}
