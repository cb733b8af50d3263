//! Rigid-body settling (`[render.compose.physics]`): the spawned objects fall under gravity onto
//! the scene and one another until they rest, with rapier3d (f64, `enhanced-determinism`), and
//! their resting poses are written back into the scene's shapes.
//!
//! - Spawned objects are dynamic bodies of uniform density (`density_kg_m3`); their collider is
//!   the convex hull of the mesh (`shape = "convex_hull"`) or a convex decomposition
//!   (`"decomposition"`: V-HACD, Mamou and Ghorbel 2009, parry's implementation), in the
//!   object's own frame.
//! - Everything the scene had before composing is static: its triangles as one triangle-mesh
//!   collider, its spheres as balls; a spawn's support plane (`on = { point_m, normal }`) is a
//!   static slab under its rectangle (rapier's broad phase takes no unbounded half-space).
//! - The simulation steps `timestep_s` at a time until every body moves slower than
//!   `rest_velocity_m_s` (a point at the body's bounding radius, so the spin counts too) for
//!   [`REST_STEPS`] steps in a row, or `max_steps` steps have run.
//!
//! No random number is drawn: the result depends on the placed poses only (so on the sample's
//! seed), and rapier runs on the calling thread, so the bytes are the same for any thread count.

use crate::manifest::AssetMesh;
use crate::{ComposeError, Result};
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use parry3d_f64::shape::SharedShape;
use serde::{Deserialize, Serialize};

/// Consecutive steps below the rest velocity that end the simulation.
pub const REST_STEPS: u32 = 10;

/// The overlap rapier leaves in a resting contact, m (its `allowed_linear_error`, with
/// `length_unit` 1 m).
pub const ALLOWED_OVERLAP_M: f64 = 2e-5;

/// Natural frequency of rapier's soft contact constraints, Hz: the stiffer, the less a loaded
/// contact sinks (a stack of 5 boxes of 0.1 m settles within 0.14 mm of the rigid heights at
/// 240 Hz, 2.9 mm at rapier's default 30 Hz: `tests/it/settle_stack.rs`).
pub const CONTACT_FREQUENCY_HZ: f64 = 240.0;

/// Grid the convex-hull collider's vertices are snapped to, m (object frame): the collider
/// departs from the mesh's hull by at most sqrt(3)/2 of it (0.087 mm).
pub const HULL_SNAP_M: f64 = 1e-4;

/// Which collider a spawned object gets.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum CollisionShape {
    /// The convex hull of the mesh (fast; a concave object cannot hold another in its hollow).
    #[default]
    ConvexHull,
    /// A set of convex parts (V-HACD, parry's default parameters: 64^3 voxels), closer to a
    /// concave mesh; the decomposition is computed once per asset.
    Decomposition,
}

fn default_true() -> bool {
    true
}
fn default_max_steps() -> u32 {
    2000
}
fn default_rest_velocity() -> f64 {
    0.005
}
fn default_timestep() -> f64 {
    1.0 / 240.0
}
fn default_gravity() -> f64 {
    // Standard gravity, CGPM 1901 (9.80665 m/s^2).
    9.80665
}
fn default_density() -> f64 {
    1000.0
}
fn default_friction() -> f64 {
    0.6
}
fn default_angular_damping() -> f64 {
    2.0
}

/// `[render.compose.physics]`: settle the spawned objects with rigid-body dynamics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PhysicsSpec {
    /// Run the simulation (default true; false keeps the placed poses).
    #[serde(default = "default_true")]
    pub settle: bool,
    /// Most simulation steps (default 2000); a scene not at rest by then keeps the last poses
    /// and its record says `at_rest = false`.
    #[serde(default = "default_max_steps")]
    pub max_steps: u32,
    /// Speed below which a body is at rest, m/s (default 0.005), of its centre and of a point
    /// at its bounding radius.
    #[serde(default = "default_rest_velocity")]
    pub rest_velocity_m_s: f64,
    /// Time step, s (default 1/240).
    #[serde(default = "default_timestep")]
    pub timestep_s: f64,
    /// Gravitational acceleration along the compose `up` axis, downwards, m/s^2 (default
    /// 9.80665, standard gravity).
    #[serde(default = "default_gravity")]
    pub gravity_m_s2: f64,
    /// The spawned objects' collider: `convex_hull` (default) or `decomposition`.
    #[serde(default)]
    pub shape: CollisionShape,
    /// Density of the spawned objects, kg/m^3 (default 1000, water).
    #[serde(default = "default_density")]
    pub density_kg_m3: f64,
    /// Coulomb friction coefficient of every contact (dimensionless, default 0.6; rapier
    /// combines two colliders' by their mean).
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Coefficient of restitution (dimensionless, default 0: objects do not bounce).
    #[serde(default)]
    pub restitution: f64,
    /// Angular damping rate, 1/s (default 2): dw/dt = -rate w besides the contacts, standing in
    /// for the rolling resistance rapier does not model, so a round-bottomed object stops
    /// rocking (without it a bottle rocks for many seconds).
    #[serde(default = "default_angular_damping")]
    pub angular_damping_per_s: f64,
    /// Linear damping rate, 1/s (default 0: free fall is not slowed).
    #[serde(default)]
    pub linear_damping_per_s: f64,
}

impl Default for PhysicsSpec {
    fn default() -> Self {
        PhysicsSpec {
            settle: true,
            max_steps: default_max_steps(),
            rest_velocity_m_s: default_rest_velocity(),
            timestep_s: default_timestep(),
            gravity_m_s2: default_gravity(),
            shape: CollisionShape::ConvexHull,
            density_kg_m3: default_density(),
            friction: default_friction(),
            restitution: 0.0,
            angular_damping_per_s: default_angular_damping(),
            linear_damping_per_s: 0.0,
        }
    }
}

impl PhysicsSpec {
    /// Check the numbers; errors name the key under `key`.
    pub fn validate(&self, key: &str) -> Result<()> {
        let pos = |v: f64, k: &str| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(ComposeError::new(
                    format!("{key}.{k}"),
                    format!("{v} must be a positive number"),
                ))
            }
        };
        pos(self.rest_velocity_m_s, "rest_velocity_m_s")?;
        pos(self.timestep_s, "timestep_s")?;
        pos(self.density_kg_m3, "density_kg_m3")?;
        if !(self.gravity_m_s2 >= 0.0 && self.gravity_m_s2.is_finite()) {
            return Err(ComposeError::new(
                format!("{key}.gravity_m_s2"),
                format!("{} must be a non-negative number", self.gravity_m_s2),
            ));
        }
        if !(self.friction >= 0.0 && self.friction.is_finite()) {
            return Err(ComposeError::new(
                format!("{key}.friction"),
                format!("{} must be a non-negative number", self.friction),
            ));
        }
        for (v, k) in [
            (self.angular_damping_per_s, "angular_damping_per_s"),
            (self.linear_damping_per_s, "linear_damping_per_s"),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(ComposeError::new(
                    format!("{key}.{k}"),
                    format!("{v} must be a non-negative number"),
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(ComposeError::new(
                format!("{key}.restitution"),
                format!("{} must be in [0, 1]", self.restitution),
            ));
        }
        if self.max_steps == 0 {
            return Err(ComposeError::new(
                format!("{key}.max_steps"),
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

/// What the simulation did (part of the sample's compose record).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct PhysicsRecord {
    /// Steps simulated.
    pub steps: u32,
    /// Simulated time, s.
    pub simulated_s: f64,
    /// Every body came to rest before `max_steps`.
    pub at_rest: bool,
    /// The fastest point speed of any body at the last step, m/s.
    pub max_speed_m_s: f64,
}

fn points(v: &[[f64; 3]]) -> Vec<Point3<f64>> {
    v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect()
}

/// Run `f`, turning a panic inside parry (degenerate input it does not check) into an error.
fn guarded<T>(what: &str, f: impl FnOnce() -> Option<T>) -> std::result::Result<T, String> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Some(v)) => Ok(v),
        Ok(None) => Err(format!("{what} failed (is the mesh flat or degenerate?)")),
        Err(_) => Err(format!("{what} failed on degenerate geometry")),
    }
}

/// The vertices of the mesh's convex hull (asset frame, m), computed once per asset.
pub fn hull_points(mesh: &AssetMesh) -> std::result::Result<&[[f64; 3]], String> {
    mesh.hull
        .get_or_init(|| {
            let pts = points(&mesh.positions);
            guarded("the convex hull", || {
                parry3d_f64::transformation::try_convex_hull(&pts).ok()
            })
            .and_then(|(v, i)| {
                if i.len() < 4 {
                    Err("the convex hull is flat: the mesh has no volume".into())
                } else {
                    Ok(v.iter().map(|p| [p.x, p.y, p.z]).collect())
                }
            })
        })
        .as_deref()
        .map_err(|e| e.clone())
}

/// The convex parts of the mesh's V-HACD decomposition (their vertices, asset frame, m),
/// computed once per asset.
pub fn decomposition_parts(mesh: &AssetMesh) -> std::result::Result<&[Vec<[f64; 3]>], String> {
    mesh.parts
        .get_or_init(|| {
            use parry3d_f64::transformation::vhacd::{VHACDParameters, VHACD};
            let pts = points(&mesh.positions);
            guarded("the convex decomposition", || {
                let v = VHACD::decompose(&VHACDParameters::default(), &pts, &mesh.indices, true);
                let hulls = v.compute_exact_convex_hulls(&pts, &mesh.indices);
                let parts: Vec<Vec<[f64; 3]>> = hulls
                    .into_iter()
                    .filter(|(_, i)| i.len() >= 4)
                    .map(|(v, _)| v.iter().map(|p| [p.x, p.y, p.z]).collect())
                    .collect();
                (!parts.is_empty()).then_some(parts)
            })
        })
        .as_deref()
        .map_err(|e| e.clone())
}

/// The collider of an asset scaled by `scale` (the object's own frame: the asset frame times
/// `scale`).
pub fn collider_shape(
    mesh: &AssetMesh,
    scale: f64,
    kind: CollisionShape,
) -> std::result::Result<SharedShape, String> {
    let scaled = |v: &[[f64; 3]]| -> Vec<Point3<f64>> {
        v.iter()
            .map(|p| Point3::new(p[0] * scale, p[1] * scale, p[2] * scale))
            .collect()
    };
    match kind {
        CollisionShape::ConvexHull => {
            let mut pts = scaled(hull_points(mesh)?);
            // Vertices on a HULL_SNAP_M grid: a near-flat base (fuze.obj's has a vertex 6 um
            // below its face) becomes one face, not a face and a tip the contact flips between.
            for p in pts.iter_mut() {
                p.coords = p.coords.map(|c| (c / HULL_SNAP_M).round() * HULL_SNAP_M);
            }
            guarded("the convex hull", || SharedShape::convex_hull(&pts))
        }
        CollisionShape::Decomposition => {
            let mut parts = Vec::new();
            for p in decomposition_parts(mesh)? {
                let pts = scaled(p);
                if let Ok(s) = guarded("a convex part", || SharedShape::convex_hull(&pts)) {
                    parts.push((Isometry3::identity(), s));
                }
            }
            if parts.is_empty() {
                return Err("the convex decomposition has no part with volume".into());
            }
            Ok(SharedShape::compound(parts))
        }
    }
}

/// One dynamic body: its collider in its own frame, its pose, the radius of its bounding
/// sphere about the frame's origin (m).
pub struct Body {
    pub shape: SharedShape,
    pub pose: Isometry3<f64>,
    pub radius_m: f64,
}

/// The static world: shapes at poses.
#[derive(Default, Clone)]
pub struct Statics {
    pub shapes: Vec<(Isometry3<f64>, SharedShape)>,
}

/// Settle `bodies` among `statics` with gravity `-gravity_m_s2 * up`; their poses are updated
/// in place.
pub fn settle(
    bodies: &mut [Body],
    statics: &Statics,
    up: Vector3<f64>,
    spec: &PhysicsSpec,
) -> PhysicsRecord {
    use rapier3d_f64::prelude::*;
    let mut rbs = RigidBodySet::new();
    let mut cols = ColliderSet::new();
    for (iso, s) in &statics.shapes {
        cols.insert(
            ColliderBuilder::new(s.clone())
                .position(*iso)
                .friction(spec.friction)
                .restitution(spec.restitution)
                .build(),
        );
    }
    let handles: Vec<RigidBodyHandle> = bodies
        .iter()
        .map(|b| {
            let h = rbs.insert(
                RigidBodyBuilder::dynamic()
                    .position(b.pose)
                    .angular_damping(spec.angular_damping_per_s)
                    .linear_damping(spec.linear_damping_per_s)
                    .can_sleep(false)
                    .build(),
            );
            cols.insert_with_parent(
                ColliderBuilder::new(b.shape.clone())
                    .density(spec.density_kg_m3)
                    .friction(spec.friction)
                    .restitution(spec.restitution)
                    .build(),
                h,
                &mut rbs,
            );
            h
        })
        .collect();
    let params = IntegrationParameters {
        dt: spec.timestep_s,
        // Resting contacts keep an overlap of ALLOWED_OVERLAP_M (rapier's default is 1 mm) and
        // are stiff springs (CONTACT_FREQUENCY_HZ; rapier's default 30 Hz lets a 5-box stack
        // sink 3 mm): the interpenetration the composed scene keeps.
        normalized_allowed_linear_error: ALLOWED_OVERLAP_M,
        contact_natural_frequency: CONTACT_FREQUENCY_HZ,
        num_solver_iterations: std::num::NonZeroUsize::new(8).expect("8 > 0"),
        ..IntegrationParameters::default()
    };
    let gravity = -up * spec.gravity_m_s2;
    let mut pipeline = PhysicsPipeline::new();
    let mut islands = IslandManager::new();
    let mut broad = DefaultBroadPhase::new();
    let mut narrow = NarrowPhase::new();
    let mut ij = ImpulseJointSet::new();
    let mut mj = MultibodyJointSet::new();
    let mut ccd = CCDSolver::new();
    let (mut steps, mut calm, mut max_speed) = (0u32, 0u32, 0.0f64);
    while steps < spec.max_steps {
        pipeline.step(
            &gravity,
            &params,
            &mut islands,
            &mut broad,
            &mut narrow,
            &mut rbs,
            &mut cols,
            &mut ij,
            &mut mj,
            &mut ccd,
            None,
            &(),
            &(),
        );
        steps += 1;
        max_speed = handles
            .iter()
            .zip(bodies.iter())
            .map(|(h, b)| {
                let rb = &rbs[*h];
                rb.linvel().norm() + rb.angvel().norm() * b.radius_m
            })
            .fold(0.0, f64::max);
        if max_speed < spec.rest_velocity_m_s {
            calm += 1;
            if calm >= REST_STEPS {
                break;
            }
        } else {
            calm = 0;
        }
    }
    for (h, b) in handles.iter().zip(bodies.iter_mut()) {
        b.pose = *rbs[*h].position();
    }
    PhysicsRecord {
        steps,
        simulated_s: steps as f64 * spec.timestep_s,
        at_rest: calm >= REST_STEPS,
        max_speed_m_s: max_speed,
    }
}

/// A pose as a camsim transform (rotation, then translation).
pub fn pose_transform(pose: &Isometry3<f64>, scale: f64) -> camsim_scene3d::Transform {
    let r = pose.rotation.to_rotation_matrix();
    let t = pose.translation.vector;
    let mut m = camsim_scene3d::Transform::identity();
    for i in 0..3 {
        for j in 0..3 {
            m.m[i][j] = r[(i, j)] * scale;
        }
        m.m[i][3] = t[i];
    }
    m
}

/// `[w, x, y, z]` of a rotation.
pub fn quaternion_wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}
