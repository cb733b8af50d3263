//! The scene in time: transforms that vary over time (pbrt-v4's `AnimatedTransform`, constant
//! velocities, trajectories, a hand-shake model), the shutter window the camera rays sample, and
//! which shapes, lights and camera move.
//!
//! A moving thing's geometry is stored in its *reference pose* (for pbrt-v4 animated transforms
//! the start transform; for velocities the pose at time 0), and [`Motion::delta`] is the
//! world-space transform from that pose to the pose at time `t`: `world_from_object(t) *
//! world_from_object(reference)^-1`. A scene without any [`Motion`] is the static scene exactly:
//! the renderer then draws no time and does no work for time at all.
//!
//! Interpolation follows pbrt-v4 (4th ed. sec. 3.9): each key matrix is decomposed as `M = T R S`
//! (translation, a rotation by polar decomposition, Shoemake & Duff 1992, and the remaining
//! scale/shear), and between keys T and S are interpolated linearly and R by spherical linear
//! interpolation of its quaternion along the shorter arc.

use crate::transform::{inverse, Transform};

/// A unit quaternion `[w, x, y, z]` (rotation by `2 acos(w)` about `(x, y, z)`).
pub type Quat = [f64; 4];

/// One key of an animated transform, decomposed (pbrt-v4 `AnimatedTransform::Decompose`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    /// Time of the key, s.
    pub time_s: f64,
    /// Translation, m.
    pub translation_m: [f64; 3],
    /// Rotation (a proper rotation; a mirror lives in `scale`).
    pub rotation: Quat,
    /// The rest of the linear part (scale and shear): `M3x3 = R S`.
    pub scale: [[f64; 3]; 3],
}

impl Keyframe {
    /// Decompose `m` (affine) at time `time_s`. `None` for a singular or projective matrix.
    pub fn from_transform(time_s: f64, m: &Transform) -> Option<Keyframe> {
        if m.m[3] != [0.0, 0.0, 0.0, 1.0] || m.m.iter().flatten().any(|v| !v.is_finite()) {
            return None;
        }
        let a: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| m.m[i][j]));
        let mut r = polar_rotation(&a)?;
        // A mirror (negative determinant) stays in S, so that R is a proper rotation and has a
        // quaternion: M = (-R)(-S).
        if det3x3(&r) < 0.0 {
            r = r.map(|row| row.map(|v| -v));
        }
        // S = R^-1 M = R^T M.
        let scale = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|k| r[k][i] * a[k][j]).sum())
        });
        Some(Keyframe {
            time_s,
            translation_m: [m.m[0][3], m.m[1][3], m.m[2][3]],
            rotation: quat_from_matrix(&r),
            scale,
        })
    }

    /// The matrix `T R S`.
    pub fn to_transform(&self) -> Transform {
        let r = quat_to_matrix(&self.rotation);
        let mut t = Transform::identity();
        for i in 0..3 {
            for j in 0..3 {
                t.m[i][j] = (0..3).map(|k| r[i][k] * self.scale[k][j]).sum();
            }
            t.m[i][3] = self.translation_m[i];
        }
        t
    }

    /// The pose a fraction `u` in [0, 1] of the way from `self` to `next`.
    fn lerp(&self, next: &Keyframe, u: f64) -> Keyframe {
        let l = |a: f64, b: f64| a + (b - a) * u;
        Keyframe {
            time_s: l(self.time_s, next.time_s),
            translation_m: std::array::from_fn(|i| l(self.translation_m[i], next.translation_m[i])),
            rotation: slerp(&self.rotation, &next.rotation, u),
            scale: std::array::from_fn(|i| {
                std::array::from_fn(|j| l(self.scale[i][j], next.scale[i][j]))
            }),
        }
    }
}

/// One factor of a [`Motion`]: a transform that is a function of time.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionPart {
    /// The same transform at every time.
    Fixed(Transform),
    /// Keys (at least one, sorted by time), interpolated as pbrt-v4's `AnimatedTransform`; held
    /// at the first key before it and the last after it. The reference pose is the first key.
    Keys(Vec<Keyframe>),
    /// Constant velocity: `Translate(v t) Translate(pivot) Rotate(|w| t, w) Translate(-pivot)`,
    /// t in s, `angular_velocity_deg_s` the rotation axis scaled by the rate (right-hand rule).
    /// The reference pose (identity) is at t = 0.
    Velocity {
        velocity_m_s: [f64; 3],
        angular_velocity_deg_s: [f64; 3],
        pivot_m: [f64; 3],
    },
    /// A hand-shake model (camera motion as ISETCam models it: a random walk of orientation).
    /// From t = 0 (identity; held before) the angular velocity about the frame's x and y axes
    /// (pitch and yaw for a camera) is piecewise constant over steps of `step_s`, each component
    /// drawn from a normal distribution with standard deviation `rms_deg_s` (the RMS angular
    /// velocity per axis), independently per step, from `seed`.
    Shake {
        rms_deg_s: f64,
        step_s: f64,
        seed: u64,
    },
}

/// Where a [`MotionPart::Shake`] draws its steps: `camsim_core::rng::keyed(seed, stage, 0,
/// step)`.
const SHAKE_STAGE: u64 = 0x0053_4841_4B45; // "SHAKE"

impl MotionPart {
    /// The transform at time `t_s`.
    pub fn at(&self, t_s: f64) -> Transform {
        match self {
            MotionPart::Fixed(m) => *m,
            MotionPart::Keys(keys) => keys_at(keys, t_s).to_transform(),
            MotionPart::Velocity {
                velocity_m_s: v,
                angular_velocity_deg_s: w,
                pivot_m: p,
            } => {
                let rate = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
                let rot = if rate > 0.0 {
                    Transform::translate(*p)
                        .then_apply_to(&Transform::rotate(rate * t_s, *w))
                        .then_apply_to(&Transform::translate([-p[0], -p[1], -p[2]]))
                } else {
                    Transform::identity()
                };
                Transform::translate([v[0] * t_s, v[1] * t_s, v[2] * t_s]).then_apply_to(&rot)
            }
            MotionPart::Shake {
                rms_deg_s,
                step_s,
                seed,
            } => {
                let keys = shake_keys(*rms_deg_s, *step_s, *seed, t_s);
                keys_at(&keys, t_s).to_transform()
            }
        }
    }

    /// The pose the stored geometry has (see the module docs).
    pub fn reference(&self) -> Transform {
        match self {
            MotionPart::Fixed(m) => *m,
            MotionPart::Keys(keys) => keys[0].to_transform(),
            MotionPart::Velocity { .. } | MotionPart::Shake { .. } => Transform::identity(),
        }
    }

    /// Whether the part never changes.
    pub fn is_static(&self) -> bool {
        match self {
            MotionPart::Fixed(_) => true,
            MotionPart::Keys(keys) => keys.windows(2).all(|w| {
                w[0].translation_m == w[1].translation_m
                    && w[0].scale == w[1].scale
                    && (w[0].rotation == w[1].rotation
                        || w[0].rotation == w[1].rotation.map(|v| -v))
            }),
            MotionPart::Velocity {
                velocity_m_s,
                angular_velocity_deg_s,
                ..
            } => velocity_m_s
                .iter()
                .chain(angular_velocity_deg_s)
                .all(|v| *v == 0.0),
            MotionPart::Shake { rms_deg_s, .. } => *rms_deg_s == 0.0,
        }
    }

    /// The part with a [`MotionPart::Shake`] turned into its keys up to `t_end_s` (what a
    /// renderer evaluates per ray); other parts unchanged.
    pub fn compiled(&self, t_end_s: f64) -> MotionPart {
        match self {
            MotionPart::Shake {
                rms_deg_s,
                step_s,
                seed,
            } => MotionPart::Keys(shake_keys(*rms_deg_s, *step_s, *seed, t_end_s)),
            p => p.clone(),
        }
    }

    /// Times where the part's velocity may jump in `(t0, t1)` (keys, shake steps): a bound
    /// sampler must include them.
    fn breakpoints(&self, t0: f64, t1: f64, out: &mut Vec<f64>) {
        match self {
            MotionPart::Keys(keys) => {
                out.extend(keys.iter().map(|k| k.time_s).filter(|t| *t > t0 && *t < t1))
            }
            MotionPart::Shake { step_s, .. } => {
                let first = (t0.max(0.0) / step_s).ceil() as u64;
                let last = (t1 / step_s).floor().max(0.0) as u64;
                // At most 4096 steps are listed (a longer window is sampled uniformly).
                out.extend(
                    (first..=last.min(first + 4096))
                        .map(|k| k as f64 * step_s)
                        .filter(|t| *t > t0 && *t < t1),
                );
            }
            _ => {}
        }
    }
}

/// The pose of `keys` at `t_s`: held before the first and after the last key, interpolated
/// between (pbrt-v4 `AnimatedTransform::Interpolate`).
fn keys_at(keys: &[Keyframe], t_s: f64) -> Keyframe {
    let i = keys.partition_point(|k| k.time_s <= t_s);
    if i == 0 {
        return keys[0];
    }
    if i == keys.len() {
        return keys[keys.len() - 1];
    }
    let (a, b) = (&keys[i - 1], &keys[i]);
    let span = b.time_s - a.time_s;
    if !(span > 0.0) {
        return *b;
    }
    a.lerp(b, (t_s - a.time_s) / span)
}

/// The keys of a [`MotionPart::Shake`] from 0 to the first step boundary at or after `t_end_s`.
/// Each step composes a rotation by the step's angular velocity times its length in the moving
/// frame (a body-frame random walk), so slerp between consecutive keys turns at exactly that
/// constant rate.
fn shake_keys(rms_deg_s: f64, step_s: f64, seed: u64, t_end_s: f64) -> Vec<Keyframe> {
    use rand_distr::{Distribution, StandardNormal};
    let identity = Keyframe::from_transform(0.0, &Transform::identity()).expect("identity");
    if !(step_s > 0.0 && rms_deg_s > 0.0 && t_end_s > 0.0 && t_end_s.is_finite()) {
        return vec![identity];
    }
    let steps = ((t_end_s / step_s).ceil() as u64).max(1);
    let mut keys = Vec::with_capacity(steps as usize + 1);
    keys.push(identity);
    let mut q: Quat = [1.0, 0.0, 0.0, 0.0];
    for k in 0..steps {
        let mut rng = camsim_core::rng::keyed(seed, SHAKE_STAGE, 0, k);
        let wx: f64 = StandardNormal.sample(&mut rng);
        let wy: f64 = StandardNormal.sample(&mut rng);
        let (ax, ay) = (wx * rms_deg_s * step_s, wy * rms_deg_s * step_s);
        let angle = (ax * ax + ay * ay).sqrt();
        if angle > 0.0 {
            let (s, c) = (angle.to_radians() / 2.0).sin_cos();
            let dq = [c, s * ax / angle, s * ay / angle, 0.0];
            q = quat_normalize(&quat_mul(&q, &dq));
        }
        keys.push(Keyframe {
            time_s: (k + 1) as f64 * step_s,
            rotation: q,
            ..identity
        });
    }
    keys
}

/// A transform that varies with time: `world_from_object(t) = parts[0](t) parts[1](t) ...`
/// (the outermost first), and the geometry it moves stored at `world_from_object(reference)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    pub parts: Vec<MotionPart>,
}

impl Motion {
    /// A pbrt-v4 `AnimatedTransform` from the transforms at the start and end times; `None`
    /// when a transform is singular or projective.
    pub fn between(start: &Transform, t0_s: f64, end: &Transform, t1_s: f64) -> Option<Motion> {
        let a = Keyframe::from_transform(t0_s, start)?;
        let b = Keyframe::from_transform(t1_s, end)?;
        let keys = if t1_s > t0_s { vec![a, b] } else { vec![a] };
        Some(Motion {
            parts: vec![MotionPart::Keys(keys)],
        })
    }

    /// One part.
    pub fn single(part: MotionPart) -> Motion {
        Motion { parts: vec![part] }
    }

    /// `world_from_object(t)`.
    pub fn at(&self, t_s: f64) -> Transform {
        self.parts.iter().fold(Transform::identity(), |acc, p| {
            acc.then_apply_to(&p.at(t_s))
        })
    }

    /// `world_from_object` of the stored geometry.
    pub fn reference(&self) -> Transform {
        self.parts.iter().fold(Transform::identity(), |acc, p| {
            acc.then_apply_to(&p.reference())
        })
    }

    /// The world-space move from the stored pose to the pose at `t_s`:
    /// `at(t) reference()^-1` (identity for a singular reference).
    pub fn delta(&self, t_s: f64) -> Transform {
        let inv = inverse(&self.reference()).unwrap_or_default();
        self.at(t_s).then_apply_to(&inv)
    }

    /// Whether nothing in it changes with time.
    pub fn is_static(&self) -> bool {
        self.parts.iter().all(MotionPart::is_static)
    }

    /// The motion with `outer` applied after it in world space (an overlay's move of an object
    /// that already moves: `world_from_object(t) = outer(t) ...`).
    pub fn then(&self, outer: MotionPart) -> Motion {
        let mut parts = vec![outer];
        parts.extend(self.parts.iter().cloned());
        Motion { parts }
    }

    /// Every part [`MotionPart::compiled`] up to `t_end_s`.
    pub fn compiled(&self, t_end_s: f64) -> Motion {
        Motion {
            parts: self.parts.iter().map(|p| p.compiled(t_end_s)).collect(),
        }
    }

    /// Sorted times in `[t0, t1]` at which to sample the motion to bound it: `n` uniform steps
    /// plus every key and step boundary inside.
    pub fn sample_times(&self, t0_s: f64, t1_s: f64, n: usize) -> Vec<f64> {
        let n = n.max(1);
        let mut ts: Vec<f64> = (0..=n)
            .map(|i| t0_s + (t1_s - t0_s) * i as f64 / n as f64)
            .collect();
        for p in &self.parts {
            p.breakpoints(t0_s, t1_s, &mut ts);
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup();
        ts
    }
}

/// The rows of a row-by-row readout as the renderer sees them: render row `y` (0 at the top of
/// the image) is delayed by `row0_delay_s + per_row_delay_s * y`. A rolling shutter shifts the
/// row's whole window by it (the row integrates for the shutter's length, later); a global
/// reset read row by row (`global_reset`) starts every row when the shutter opens and ends the
/// row's window that much later (the row integrates longer; the render is the time average over
/// the row's window, and the sensor integrates it over the row's own time). The pipeline
/// derives the delays from the sensor's line time, its readout direction and the optics'
/// mapping of sensor rows to render rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowReadout {
    /// Delay of render row 0, s.
    pub row0_delay_s: f64,
    /// Delay added per render row, s (negative when the readout runs from the bottom up).
    pub per_row_delay_s: f64,
    /// Every row starts at the shutter's opening; only its end is delayed.
    pub global_reset: bool,
}

/// When the camera rays sample the scene: pbrt-v4's `shutteropen`/`shutterclose` (each camera
/// ray's time is uniform in the window), optionally shifted row by row (a rolling shutter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shutter {
    /// Window start, s (pbrt-v4 `shutteropen`, default 0).
    pub open_s: f64,
    /// Window end, s (pbrt-v4 `shutterclose`, default 1).
    pub close_s: f64,
    /// A row-by-row readout (a rolling shutter, or a global reset read row by row): each row's
    /// window is delayed ([`RowReadout`]).
    pub rolling: Option<RowReadout>,
}

impl Default for Shutter {
    fn default() -> Self {
        Shutter {
            open_s: 0.0,
            close_s: 1.0,
            rolling: None,
        }
    }
}

impl Shutter {
    /// The window `[start, end]` of render row `y`, s.
    #[inline]
    pub fn row_window_s(&self, y: usize) -> (f64, f64) {
        match self.rolling {
            None => (self.open_s, self.close_s),
            Some(r) => {
                let d = r.row0_delay_s + r.per_row_delay_s * y as f64;
                let start = if r.global_reset { 0.0 } else { d };
                (self.open_s + start, self.close_s + d)
            }
        }
    }

    /// The earliest start and latest end over rows `0..height`, s.
    pub fn span_s(&self, height: usize) -> (f64, f64) {
        let (a0, a1) = self.row_window_s(0);
        let (b0, b1) = self.row_window_s(height.saturating_sub(1));
        (a0.min(b0), a1.max(b1))
    }
}

/// The time dimension of a render: the shutter and what moves during it. Kept in
/// [`crate::scene::RenderSettings`] (whose literals all end in `..Default::default()`), so that
/// shapes, cameras and scenes keep their fields; moving things are named by their index in
/// `SceneDescription::shapes` / `lights`. The default is a static scene.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeSettings {
    pub shutter: Shutter,
    /// The camera's motion (`world_from_camera(t)`; the stored `camera_to_world` is its
    /// reference pose).
    pub camera: Option<Motion>,
    /// Moving shapes: (index into `SceneDescription::shapes`, motion), at most one per shape.
    pub shapes: Vec<(usize, Motion)>,
    /// Moving non-shape lights: (index into `SceneDescription::lights`, motion).
    pub lights: Vec<(usize, Motion)>,
    /// Optical flow to compute: for each interval `dt` (s), where the surface seen first through
    /// each pixel centre at its row's window start has moved to in the image `dt` later
    /// (`camsim_render::RenderOutput::flow`).
    pub flow_intervals_s: Vec<f64>,
}

impl TimeSettings {
    /// Whether anything moves (else a render does no work for time: the static scene exactly).
    pub fn has_motion(&self) -> bool {
        self.camera.as_ref().is_some_and(|m| !m.is_static())
            || self.shapes.iter().any(|(_, m)| !m.is_static())
            || self.lights.iter().any(|(_, m)| !m.is_static())
    }

    /// The motion of shape `i`, if it moves.
    pub fn shape_motion(&self, i: usize) -> Option<&Motion> {
        self.shapes.iter().find(|(k, _)| *k == i).map(|(_, m)| m)
    }

    /// Set (or compose onto) the motion of shape `i`: `outer` applies after any motion it has.
    pub fn move_shape(&mut self, i: usize, outer: MotionPart) {
        match self.shapes.iter_mut().find(|(k, _)| *k == i) {
            Some((_, m)) => *m = m.then(outer),
            None => self.shapes.push((i, Motion::single(outer))),
        }
    }

    /// After shapes were removed or reordered: `new_index(old)` is a shape's new index, `None`
    /// if it is gone (its motion goes too).
    pub fn remap_shapes(&mut self, new_index: impl Fn(usize) -> Option<usize>) {
        self.shapes = std::mem::take(&mut self.shapes)
            .into_iter()
            .filter_map(|(i, m)| new_index(i).map(|j| (j, m)))
            .collect();
    }
}

/// The rotation factor of the polar decomposition of `a` (pbrt-v4 4th ed. sec. 3.9.1:
/// `R_{i+1} = (R_i + (R_i^T)^-1) / 2` until it stops changing); `None` if singular.
fn polar_rotation(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let mut r = *a;
    for _ in 0..100 {
        let inv = inverse3x3(&r)?;
        let next: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (r[i][j] + inv[j][i])));
        let change = (0..3)
            .map(|i| (0..3).map(|j| (next[i][j] - r[i][j]).abs()).sum::<f64>())
            .fold(0.0, f64::max);
        r = next;
        if change < 1e-14 {
            break;
        }
    }
    Some(r)
}

fn det3x3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

fn inverse3x3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let d = det3x3(m);
    if !(d.abs() > 1e-300) || !d.is_finite() {
        return None;
    }
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]
    };
    // inverse = adjugate / det; adj[i][j] = cofactor(j, i).
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| c(j, i) / d)
    }))
}

/// The quaternion of a proper rotation matrix (Shoemake 1985: from the largest of the trace and
/// the diagonal, for accuracy).
pub fn quat_from_matrix(r: &[[f64; 3]; 3]) -> Quat {
    let tr = r[0][0] + r[1][1] + r[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (r[2][1] - r[1][2]) / s,
            (r[0][2] - r[2][0]) / s,
            (r[1][0] - r[0][1]) / s,
        ]
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        [
            (r[2][1] - r[1][2]) / s,
            0.25 * s,
            (r[0][1] + r[1][0]) / s,
            (r[0][2] + r[2][0]) / s,
        ]
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        [
            (r[0][2] - r[2][0]) / s,
            (r[0][1] + r[1][0]) / s,
            0.25 * s,
            (r[1][2] + r[2][1]) / s,
        ]
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        [
            (r[1][0] - r[0][1]) / s,
            (r[0][2] + r[2][0]) / s,
            (r[1][2] + r[2][1]) / s,
            0.25 * s,
        ]
    };
    quat_normalize(&q)
}

/// The rotation matrix of a unit quaternion.
pub fn quat_to_matrix(q: &Quat) -> [[f64; 3]; 3] {
    let [w, x, y, z] = *q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn quat_normalize(q: &Quat) -> Quat {
    let l = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| v / l)
}

/// Hamilton product `a b` (rotate by `b`, then by `a`).
pub fn quat_mul(a: &Quat, b: &Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// Spherical linear interpolation along the shorter arc (pbrt-v4 `Slerp` with the
/// `AnimatedTransform` constructor's sign flip): constant angular velocity from `a` (u = 0) to
/// `b` (u = 1).
pub fn slerp(a: &Quat, b: &Quat, u: f64) -> Quat {
    let mut b = *b;
    let mut dot: f64 = (0..4).map(|i| a[i] * b[i]).sum();
    if dot < 0.0 {
        b = b.map(|v| -v);
        dot = -dot;
    }
    // The angle between them, robustly for nearly equal quaternions (pbrt-v4 `AngleBetween`).
    let diff = (0..4).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
    let theta = if dot < 0.9995 {
        dot.clamp(-1.0, 1.0).acos()
    } else {
        2.0 * (diff / 2.0).asin()
    };
    if theta < 1e-9 {
        return quat_normalize(&std::array::from_fn(|i| a[i] + (b[i] - a[i]) * u));
    }
    let s = theta.sin();
    let (wa, wb) = (((1.0 - u) * theta).sin() / s, (u * theta).sin() / s);
    quat_normalize(&std::array::from_fn(|i| wa * a[i] + wb * b[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Transform, b: &Transform, tol: f64) -> bool {
        a.m.iter()
            .flatten()
            .zip(b.m.iter().flatten())
            .all(|(x, y)| (x - y).abs() < tol)
    }

    #[test]
    fn decomposition_recomposes_including_mirrors_and_shear() {
        let m = Transform::translate([1.0, -2.0, 0.5])
            .then_apply_to(&Transform::rotate(73.0, [0.3, 1.0, -0.2]))
            .then_apply_to(&Transform::scale([2.0, 0.5, 1.5]));
        let k = Keyframe::from_transform(0.0, &m).unwrap();
        assert!(close(&k.to_transform(), &m, 1e-12));
        // A mirrored camera (pbrt `Scale -1 1 1`): R stays proper, the mirror goes into S.
        let mirror = Transform::rotate(20.0, [0.0, 1.0, 0.0])
            .then_apply_to(&Transform::scale([-1.0, 1.0, 1.0]));
        let k = Keyframe::from_transform(0.0, &mirror).unwrap();
        assert!(det3x3(&quat_to_matrix(&k.rotation)) > 0.0);
        assert!(close(&k.to_transform(), &mirror, 1e-12));
        let mut shear = Transform::identity();
        shear.m[0][1] = 0.4;
        let k = Keyframe::from_transform(0.0, &shear).unwrap();
        assert!(close(&k.to_transform(), &shear, 1e-12));
    }

    /// Rotation about a fixed axis interpolates at constant angular velocity (the arc, not the
    /// chord): at a quarter of the interval the angle is a quarter of the way.
    #[test]
    fn keys_rotate_at_constant_rate_and_translate_linearly() {
        let a = Transform::identity();
        let b = Transform::translate([4.0, 0.0, 0.0])
            .then_apply_to(&Transform::rotate(120.0, [0.0, 0.0, 1.0]));
        let m = Motion::between(&a, 1.0, &b, 3.0).unwrap();
        let want = Transform::translate([1.0, 0.0, 0.0])
            .then_apply_to(&Transform::rotate(30.0, [0.0, 0.0, 1.0]));
        assert!(close(&m.at(1.5), &want, 1e-12));
        // Held outside the key times.
        assert!(close(&m.at(0.0), &a, 1e-12));
        assert!(close(&m.at(9.0), &b, 1e-12));
        assert!(close(&m.delta(1.0), &Transform::identity(), 1e-12));
    }

    #[test]
    fn velocity_turns_about_the_pivot_past_half_a_turn() {
        let m = Motion::single(MotionPart::Velocity {
            velocity_m_s: [0.0, 1.0, 0.0],
            angular_velocity_deg_s: [0.0, 0.0, 270.0],
            pivot_m: [1.0, 0.0, 0.0],
        });
        // After 1 s: turned 270 degrees about (1, 0, 0) and moved up 1 m; the pivot itself
        // only translates.
        let p = m.at(1.0).apply_point([1.0, 0.0, 0.0]);
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 1.0).abs() < 1e-12);
        let q = m.at(1.0).apply_point([2.0, 0.0, 0.0]);
        assert!(
            (q[0] - 1.0).abs() < 1e-12 && (q[1] - 0.0).abs() < 1e-12,
            "{q:?}"
        );
        assert!(!m.is_static());
    }

    #[test]
    fn shake_is_a_seeded_random_walk_with_the_rms_rate() {
        let part = MotionPart::Shake {
            rms_deg_s: 2.0,
            step_s: 1e-3,
            seed: 5,
        };
        let keys = shake_keys(2.0, 1e-3, 5, 4.0);
        assert_eq!(keys, shake_keys(2.0, 1e-3, 5, 4.0));
        assert_ne!(keys, shake_keys(2.0, 1e-3, 6, 4.0));
        // The per-step angle over the step length is the angular speed; its mean square over
        // 4000 steps is 2 rms^2 (two axes), within a few standard errors.
        let mut sum2 = 0.0;
        for w in keys.windows(2) {
            let d = quat_mul(
                &[
                    w[0].rotation[0],
                    -w[0].rotation[1],
                    -w[0].rotation[2],
                    -w[0].rotation[3],
                ],
                &w[1].rotation,
            );
            let angle_deg = 2.0 * d[0].clamp(-1.0, 1.0).acos().to_degrees();
            sum2 += (angle_deg / 1e-3).powi(2);
        }
        let ms = sum2 / (keys.len() - 1) as f64;
        assert!((ms / 8.0 - 1.0).abs() < 0.1, "mean square rate {ms} vs 8");
        // `at` agrees with the compiled keys.
        let c = part.compiled(0.01);
        assert!(close(&part.at(0.0042), &c.at(0.0042), 1e-12));
    }
}
