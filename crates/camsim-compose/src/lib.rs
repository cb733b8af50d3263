//! camsim stage 1 (3D): scene composition. Edits a [`camsim_scene3d::SceneDescription`] from
//! outside, after a reader (`camsim-pbrt`, `camsim-assets`) or a built-in made it and before the
//! renderer sees it: the datasets' "put 3 to 12 objects from my asset folder on a table, let them
//! settle, light them with a random sky, look at them from a random viewpoint".
//!
//! - [`manifest`]: asset libraries (a folder, a glob, a CSV/JSON manifest), checked up front.
//! - [`spawn`]: draw assets, scale and orient them, place them on a support, in a box or on a grid
//!   without interpenetration.
//! - [`physics`]: settle the placed objects with rapier3d (convex hulls or a convex
//!   decomposition, static supports), recording the resting poses.
//! - [`environment`]: equirectangular HDR maps and a spectral sky model as the scene's light.
//! - [`camera`]: camera samplers (a spherical shell around a target) and view validation.
//! - [`materials`]: material randomization (reflectance spectra drawn from a set).
//!
//! Every draw comes from the sample's seed through keyed streams ([`stream`]), so a sample's
//! scene is the same for any worker or thread count. The renderer is never imported here.

pub mod camera;
pub mod environment;
pub mod manifest;
pub mod materials;
pub mod physics;
pub mod spawn;

use camsim_scene3d::SceneDescription;
use std::path::Path;

/// A composition step that cannot be done: the key or asset at fault and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct ComposeError {
    /// The spec key (`compose.spawn.0.count`) or asset path the message is about.
    pub key: String,
    pub message: String,
}

impl ComposeError {
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        ComposeError {
            key: key.into(),
            message: message.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, ComposeError>;

fn default_cache_mib() -> f64 {
    512.0
}
fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// `[render.compose]`: compose the scene from an asset library (spawn, place, settle), per
/// sample from its seed. Applied after the scene file and its overlays.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ComposeSpec {
    /// Asset sources, relative to the config: CSV or JSON manifests (columns or fields `path`,
    /// `category`, `scale_to_m` (default 1), `up_axis` (`y` or `z`, default `y`), `licence`,
    /// `keypoints` (a JSON file of the asset's own keypoints)), folders, globs (`models/*.glb`, `models/**/*.obj`) or asset files (glTF, GLB, OBJ, PLY,
    /// pbrt-v4). Every asset is read and checked before anything is spawned.
    #[serde(default)]
    pub assets: Vec<String>,
    /// Memory budget of the process-wide parsed-asset cache, MiB (default 512); least recently
    /// used assets leave it first.
    #[serde(default = "default_cache_mib")]
    pub asset_cache_mib: f64,
    /// The scene's up direction (dimensionless; default [0, 1, 0], +y): upright objects stand
    /// along it, supports face it, gravity pulls against it.
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Groups of objects to draw and place, in order (`[[render.compose.spawn]]`).
    #[serde(default)]
    pub spawn: Vec<spawn::SpawnSpec>,
    /// Settle the spawned objects with rigid-body dynamics (`[render.compose.physics]`);
    /// absent: they keep their placed poses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physics: Option<physics::PhysicsSpec>,
    /// New materials for objects, drawn per object (`[[render.compose.materials]]`: spectral
    /// reflectances from a set, textures from a folder, roughness and metallic ranges), applied
    /// after the objects are settled, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<materials::MaterialRandomSpec>,
    /// The scene's light from the sky or an environment map (`[render.compose.environment]`);
    /// absent: the scene keeps its own lights.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub environment: Option<environment::EnvironmentSpec>,
    /// Where the camera looks from (`[render.compose.camera]`: a spherical shell around the
    /// spawned group's centre, an object or a point, with view validation); absent: the scene's
    /// camera. In `simulate` the lens and sensor set the field of view (`fov_deg` is for
    /// `camsim render`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<camera::CameraSamplerSpec>,
}

impl Default for ComposeSpec {
    fn default() -> Self {
        ComposeSpec {
            assets: Vec::new(),
            asset_cache_mib: default_cache_mib(),
            up: default_up(),
            spawn: Vec::new(),
            physics: None,
            materials: Vec::new(),
            environment: None,
            camera: None,
        }
    }
}

/// One spawned object as composed (part of the sample record).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct ObjectRecord {
    /// The instance's name (`<category>_<k>`).
    pub name: String,
    /// Its semantic category.
    pub category: String,
    /// The spawn entry that drew it.
    pub spawn: String,
    /// The asset file.
    pub asset: String,
    /// The asset's licence, when its manifest gives one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub licence: Option<String>,
    /// Metres per file unit (the manifest's).
    pub scale_to_m: f64,
    /// The drawn scale factor (dimensionless).
    pub scale: f64,
    /// Final pose: world = rotation (scale x asset frame) + translation; translation, m.
    pub translation_m: [f64; 3],
    /// Final pose's rotation, unit quaternion [w, x, y, z].
    pub rotation_wxyz: [f64; 4],
}

/// What [`compose`] did: the objects drawn and where they ended up, and the settling.
#[derive(
    Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct ComposeRecord {
    /// The seed everything was drawn from.
    pub seed: u64,
    pub objects: Vec<ObjectRecord>,
    /// The rigid-body simulation, when one ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physics: Option<physics::PhysicsRecord>,
    /// What each object's material drew (`materials`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schemars(with = "Vec<serde_json::Value>")]
    pub materials: Vec<materials::MaterialDraw>,
    /// The sky or map drawn (`environment`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Value>")]
    pub environment: Option<environment::EnvironmentRecord>,
    /// The camera drawn (`camera`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Value>")]
    pub camera: Option<camera::CameraRecord>,
}

/// Compose `scene` by `spec` with the sample's `seed`: load and check the asset library, place
/// every spawn entry's objects, settle them, and insert each as its own object instance (named
/// `<category>_<k>`, [`camsim_scene3d::ShapeTags::category`] its category). Relative paths
/// resolve against `base_dir`. The scene is unchanged when an error is returned.
pub fn compose(
    scene: &mut SceneDescription,
    spec: &ComposeSpec,
    seed: u64,
    base_dir: &Path,
) -> Result<ComposeRecord> {
    let up = nalgebra::Vector3::new(spec.up[0], spec.up[1], spec.up[2]);
    if !(up.norm() > 0.0 && up.iter().all(|v| v.is_finite())) {
        return Err(ComposeError::new(
            "compose.up",
            format!("{:?} is not a direction", spec.up),
        ));
    }
    let up = nalgebra::Unit::new_normalize(up);
    if !(spec.asset_cache_mib >= 0.0 && spec.asset_cache_mib.is_finite()) {
        return Err(ComposeError::new(
            "compose.asset_cache_mib",
            format!("{} must be a non-negative number", spec.asset_cache_mib),
        ));
    }
    if let Some(p) = &spec.physics {
        p.validate("compose.physics")?;
    }
    let mut record = ComposeRecord {
        seed,
        ..Default::default()
    };
    // Every step works on a copy: the scene is unchanged when one of them fails.
    let mut work = scene.clone();
    if !spec.spawn.is_empty() {
        spawn_and_settle(&mut work, spec, seed, base_dir, &up, &mut record)?;
    }
    if !spec.materials.is_empty() {
        record.materials = materials::apply(&mut work, &spec.materials, seed, base_dir)?;
    }
    if let Some(e) = &spec.environment {
        record.environment = Some(environment::apply(&mut work, e, seed, base_dir)?);
    }
    if let Some(c) = &spec.camera {
        // The default target: the spawned objects' centre (their final translations' mean).
        let target = (!record.objects.is_empty()).then(|| {
            let n = record.objects.len() as f64;
            let mut c = [0.0; 3];
            for o in &record.objects {
                for k in 0..3 {
                    c[k] += o.translation_m[k] / n;
                }
            }
            c
        });
        record.camera = Some(camera::apply(&mut work, c, seed, target)?);
    }
    *scene = work;
    Ok(record)
}

/// The asset library, the spawn entries' placements, the settling and the insertion of the
/// objects into `scene` (compose()'s working copy).
fn spawn_and_settle(
    scene: &mut SceneDescription,
    spec: &ComposeSpec,
    seed: u64,
    base_dir: &Path,
    up: &nalgebra::Unit<nalgebra::Vector3<f64>>,
    record: &mut ComposeRecord,
) -> Result<()> {
    const KEY: &str = "compose";
    let library = manifest::Library::load(
        &spec.assets,
        base_dir,
        "compose.assets",
        (spec.asset_cache_mib * 1048576.0) as usize,
    )?;
    for (i, s) in spec.spawn.iter().enumerate() {
        s.validate(&spawn::entry_key("compose.spawn", i, s), &library)?;
    }
    let kind = spec
        .physics
        .as_ref()
        .map_or(physics::CollisionShape::ConvexHull, |p| p.shape);
    let mut statics = spawn::scene_statics(scene);
    let mut placed = spawn::place_all(
        &spec.spawn,
        &library,
        scene,
        &statics,
        up,
        seed,
        kind,
        &format!("{KEY}.spawn"),
    )?;
    if let Some(p) = spec.physics.as_ref().filter(|p| p.settle) {
        for s in &spec.spawn {
            if let Some(spawn::Support::Plane(pl)) = &s.on {
                statics.shapes.push(spawn::plane_static(pl));
            }
        }
        let mut bodies: Vec<physics::Body> = placed
            .iter()
            .map(|o| physics::Body {
                shape: o.shape.clone(),
                pose: o.pose,
                radius_m: o.radius_m,
            })
            .collect();
        let r = physics::settle(&mut bodies, &statics, up.into_inner(), p);
        if !r.at_rest {
            // The objects may be caught mid-fall: say so where the user reads the run.
            scene.notes.push(format!(
                "compose.physics: stopped at max_steps = {} ({:.2} s simulated) with a body still moving at {:.3} m/s (rest below {} m/s); the objects may not rest on their supports: raise max_steps",
                r.steps, r.simulated_s, r.max_speed_m_s, p.rest_velocity_m_s
            ));
        }
        record.physics = Some(r);
        for (o, b) in placed.iter_mut().zip(bodies) {
            o.pose = b.pose;
        }
    }
    // Insert: each object through the overlay's `[[object]] add` (one instance, its materials
    // merged, its category), from the cached asset, at its final pose. `scene` is compose()'s
    // working copy: the caller's scene is unchanged on an error.
    let work = scene;
    let mut per_category: std::collections::BTreeMap<String, usize> = Default::default();
    for o in &placed {
        let asset = &library.assets[o.asset];
        let k = per_category.entry(asset.category.clone()).or_default();
        let name = format!("{}_{}", asset.category, k);
        *k += 1;
        let first = work.shapes.len();
        insert_object(work, asset, &name, o)?;
        let t = physics::pose_transform(&o.pose, o.scale);
        for s in &mut work.shapes[first..] {
            if s.tags.object_to_world.is_none() {
                s.tags.object_to_world = Some(t);
            }
        }
        let sp = &spec.spawn[o.spawn];
        record.objects.push(ObjectRecord {
            name,
            category: asset.category.clone(),
            spawn: sp
                .name
                .clone()
                .unwrap_or_else(|| format!("spawn[{}]", o.spawn)),
            asset: asset.path.display().to_string(),
            licence: asset.licence.clone(),
            scale_to_m: asset.scale_to_m,
            scale: o.scale,
            translation_m: o.pose.translation.vector.into(),
            rotation_wxyz: physics::quaternion_wxyz(&o.pose.rotation),
        });
    }
    Ok(())
}

/// Insert `asset` at `o`'s pose as the overlay's `[[object]] add` does (one instance named
/// `name`, its category, its materials merged), from the cached parse.
fn insert_object(
    scene: &mut SceneDescription,
    asset: &manifest::Asset,
    name: &str,
    o: &spawn::Placed,
) -> Result<()> {
    use camsim_pbrt::overlay::{AddSpec, ObjectOverlay, Overlay, RotateSpec, ScaleSpec};
    let (axis, angle) = o
        .pose
        .rotation
        .axis_angle()
        .map_or(([0.0, 1.0, 0.0], 0.0), |(a, t)| ([a.x, a.y, a.z], t));
    let t = o.pose.translation.vector;
    let ov = Overlay {
        object: vec![ObjectOverlay {
            name: name.to_string(),
            remove: false,
            replace: None,
            add: Some(AddSpec {
                file: asset.path.display().to_string(),
                material: None,
                at_m: None,
            }),
            category: Some(asset.category.clone()),
            scale: (o.scale != 1.0).then_some(ScaleSpec::Uniform(o.scale)),
            rotate: (angle != 0.0).then(|| RotateSpec {
                angle_deg: angle.to_degrees(),
                axis,
            }),
            translate_m: Some([t.x, t.y, t.z]),
            pivot_m: Some([0.0; 3]),
            material: None,
            velocity_m_s: None,
            angular_velocity_deg_s: None,
        }],
        ..Default::default()
    };
    let mesh = asset.mesh.clone();
    camsim_pbrt::overlay::apply_overlay_with(scene, &ov, Path::new(""), &|_| {
        let mut s = mesh.scene.clone();
        // Its keypoints ride on its shapes, moved with them to the pose.
        if let Some(k) = &asset.keypoints {
            for sh in &mut s.shapes {
                sh.tags.keypoints = Some(k.clone());
            }
        }
        Some(Ok(s))
    })
    .map_err(|m| ComposeError::new(name, m))
}

/// The keyed random stream of one composition stage of one sample: the same (seed, stage, index)
/// gives the same stream whatever else ran before it (DESIGN.md: randomness is keyed).
pub fn stream(seed: u64, stage: u64, index: u64) -> rand_pcg::Pcg64 {
    use rand::SeedableRng;
    // SplitMix64 finaliser over the three keys (Steele et al. 2014), one 128-bit state.
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let a = mix(seed ^ mix(stage.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    let b = mix(a ^ mix(index.wrapping_add(0x6a09_e667_f3bc_c909)));
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&a.to_le_bytes());
    key[8..16].copy_from_slice(&b.to_le_bytes());
    key[16..24].copy_from_slice(&mix(a ^ b).to_le_bytes());
    key[24..].copy_from_slice(&mix(b.wrapping_add(a)).to_le_bytes());
    rand_pcg::Pcg64::from_seed(key)
}

/// The stages' stream numbers (the `stage` of [`stream`]).
pub mod stage {
    pub const SPAWN: u64 = 1;
    pub const PHYSICS: u64 = 2;
    pub const ENVIRONMENT: u64 = 3;
    pub const CAMERA: u64 = 4;
    pub const MATERIALS: u64 = 5;
}
