//! Motion in overlays (issue 28): cameras and objects that move during the exposure without
//! writing pbrt transforms. Keys (all optional; see [`crate::overlay`]):
//!
//! ```toml
//! [camera]
//! velocity_m_s = [0.5, 0.0, 0.0]          # world frame, m/s
//! angular_velocity_deg_s = [0.0, 30.0, 0.0] # about the camera's own x (pitch), y (yaw), z (roll)
//! trajectory = "path.csv"                  # time_s, x_m, y_m, z_m, then look_x_m, look_y_m,
//!                                          # look_z_m (and up_x, up_y, up_z) or qw, qx, qy, qz
//! shake = { rms_deg_s = 2.0, seed = 1, step_ms = 1.0 }   # hand shake: random walk of rotation
//!
//! [[object]]
//! name = "fan"
//! angular_velocity_deg_s = [0.0, 0.0, 720.0]   # world axes, deg/s, about pivot_m
//! velocity_m_s = [0.1, 0.0, 0.0]               # world frame, m/s
//! pivot_m = [0.0, 0.0, 1.0]                    # default: centre of the objects' bounding box
//! ```
//!
//! Time is the scene's, s: a velocity moves things from where the scene puts them at t = 0; a
//! trajectory gives the camera's pose at its rows' times, interpolated between them (position
//! linearly, orientation by slerp) and held outside them. The camera's motions compose as
//! `world_from_camera(t) = Translate(v t) base(t) Rotate(w t) shake(t)` (base: the trajectory, or
//! the scene's camera with any pbrt motion it has). An object's velocity applies after any pbrt
//! motion of it.

use super::{union_bounds, CameraOverlay, ObjectOverlay};
use crate::scene::{SceneDescription, Shape, Transform};
use camsim_scene3d::motion::{quat_to_matrix, Keyframe, Motion, MotionPart};
use serde::Deserialize;
use std::path::Path;

/// `[camera] shake`: ISETCam-style camera shake, a random walk of the camera's orientation.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShakeSpec {
    /// RMS angular velocity per axis (pitch and yaw), deg/s.
    pub rms_deg_s: f64,
    /// Seed of the walk (default 1).
    pub seed: Option<u64>,
    /// Length of a step of constant angular velocity, ms (default 1).
    pub step_ms: Option<f64>,
}

fn finite3(v: [f64; 3], key: &str) -> Result<[f64; 3], String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(format!(
            "{key} = {v:?}: every component must be a finite number"
        ))
    }
}

/// Apply `[camera]`'s motion keys (after its pose keys).
pub(crate) fn apply_camera_motion(
    scene: &mut SceneDescription,
    c: &CameraOverlay,
    base_dir: &Path,
) -> Result<(), String> {
    if c.velocity_m_s.is_none()
        && c.angular_velocity_deg_s.is_none()
        && c.trajectory.is_none()
        && c.shake.is_none()
    {
        return Ok(());
    }
    let base = match &c.trajectory {
        Some(file) => {
            let path = if Path::new(file).is_absolute() {
                Path::new(file).to_path_buf()
            } else {
                base_dir.join(file)
            };
            let mirrored = crate::xform::det3(&scene.camera.camera_to_world) < 0.0;
            let keys = read_trajectory(&path, mirrored)?;
            scene.camera.camera_to_world = keys[0].to_transform();
            vec![MotionPart::Keys(keys)]
        }
        None => match scene.settings.time.camera.take() {
            Some(m) => m.parts,
            None => vec![MotionPart::Fixed(scene.camera.camera_to_world)],
        },
    };
    let mut parts = Vec::new();
    if let Some(v) = c.velocity_m_s {
        parts.push(MotionPart::Velocity {
            velocity_m_s: finite3(v, "camera.velocity_m_s")?,
            angular_velocity_deg_s: [0.0; 3],
            pivot_m: [0.0; 3],
        });
    }
    parts.extend(base);
    if let Some(w) = c.angular_velocity_deg_s {
        parts.push(MotionPart::Velocity {
            velocity_m_s: [0.0; 3],
            angular_velocity_deg_s: finite3(w, "camera.angular_velocity_deg_s")?,
            pivot_m: [0.0; 3],
        });
    }
    if let Some(s) = &c.shake {
        let step_ms = s.step_ms.unwrap_or(1.0);
        if !(s.rms_deg_s.is_finite() && s.rms_deg_s >= 0.0) {
            return Err(format!(
                "camera.shake.rms_deg_s = {}: must be >= 0 deg/s",
                s.rms_deg_s
            ));
        }
        if !(step_ms.is_finite() && step_ms > 0.0) {
            return Err(format!("camera.shake.step_ms = {step_ms}: must be > 0 ms"));
        }
        parts.push(MotionPart::Shake {
            rms_deg_s: s.rms_deg_s,
            step_s: step_ms * 1e-3,
            seed: s.seed.unwrap_or(1),
        });
    }
    scene.settings.time.camera = Some(Motion { parts });
    Ok(())
}

/// A camera trajectory: CSV with a header naming `time_s`, `x_m`, `y_m`, `z_m` and either
/// `look_x_m`, `look_y_m`, `look_z_m` (optionally `up_x`, `up_y`, `up_z`, default +y) or `qw`,
/// `qx`, `qy`, `qz` (the camera's orientation: its x, y, z axes, right, up and forward, in the
/// world); times strictly increasing. `mirrored`: the scene's camera shows a mirrored
/// (right-handed) view, kept for every pose. The error names the file and line.
pub(crate) fn read_trajectory(path: &Path, mirrored: bool) -> Result<Vec<Keyframe>, String> {
    let name = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("camera.trajectory: {name}: {e}"))?;
    let recs = camsim_core::csv_records::records(&bytes, true).map_err(|(line, e)| {
        format!(
            "camera.trajectory: {name}:{line}: {}",
            camsim_core::csv_records::error_message(&e)
        )
    })?;
    let Some(((_, head), rows)) = recs.split_first() else {
        return Err(format!("camera.trajectory: {name}: the file is empty"));
    };
    let col = |n: &str| head.iter().position(|h| h == n);
    let need = |n: &str| {
        col(n).ok_or_else(|| {
            format!("camera.trajectory: {name}:1: no column \"{n}\" (need time_s, x_m, y_m, z_m and look_x_m, look_y_m, look_z_m or qw, qx, qy, qz)")
        })
    };
    let (t, x, y, z) = (need("time_s")?, need("x_m")?, need("y_m")?, need("z_m")?);
    let look = ["look_x_m", "look_y_m", "look_z_m"].map(col);
    let up = ["up_x", "up_y", "up_z"].map(col);
    let quat = ["qw", "qx", "qy", "qz"].map(col);
    let by_look = look.iter().all(Option::is_some);
    if !by_look && !quat.iter().all(Option::is_some) {
        return Err(format!("camera.trajectory: {name}:1: give the columns look_x_m, look_y_m, look_z_m or qw, qx, qy, qz"));
    }
    if rows.is_empty() {
        return Err(format!(
            "camera.trajectory: {name}: no poses after the header"
        ));
    }
    let mut keys: Vec<Keyframe> = Vec::with_capacity(rows.len());
    for (line, r) in rows {
        let at = |i: usize| -> Result<f64, String> {
            let s = r.get(i).unwrap_or("");
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("camera.trajectory: {name}:{line}: \"{s}\" in column \"{}\" is not a number", &head[i]))
        };
        let time_s = at(t)?;
        if let Some(prev) = keys.last() {
            if !(time_s > prev.time_s) {
                return Err(format!(
                    "camera.trajectory: {name}:{line}: time {time_s} s is not after {} s (times must increase)",
                    prev.time_s
                ));
            }
        }
        let pos = [at(x)?, at(y)?, at(z)?];
        let c2w = if by_look {
            let l = [
                at(look[0].unwrap())?,
                at(look[1].unwrap())?,
                at(look[2].unwrap())?,
            ];
            let u = match up {
                [Some(a), Some(b), Some(c)] => [at(a)?, at(b)?, at(c)?],
                _ => [0.0, 1.0, 0.0],
            };
            crate::camera::look_at_camera_to_world(pos, l, u, mirrored).ok_or_else(|| {
                format!("camera.trajectory: {name}:{line}: the position, look-at point and up vector are degenerate")
            })?
        } else {
            let q = [
                at(quat[0].unwrap())?,
                at(quat[1].unwrap())?,
                at(quat[2].unwrap())?,
                at(quat[3].unwrap())?,
            ];
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(n > 0.0) {
                return Err(format!(
                    "camera.trajectory: {name}:{line}: the quaternion is zero"
                ));
            }
            let r = quat_to_matrix(&q.map(|v| v / n));
            let mut m = Transform::translate(pos);
            for i in 0..3 {
                for j in 0..3 {
                    m.m[i][j] = r[i][j];
                }
            }
            if mirrored {
                m = m.then_apply_to(&Transform::scale([-1.0, 1.0, 1.0]));
            }
            m
        };
        keys.push(
            Keyframe::from_transform(time_s, &c2w).ok_or_else(|| {
                format!("camera.trajectory: {name}:{line}: the pose is degenerate")
            })?,
        );
    }
    Ok(keys)
}

/// Apply an `[[object]]`'s motion keys to the shapes `targets` (after its other changes).
pub(crate) fn apply_object_motion(
    scene: &mut SceneDescription,
    o: &ObjectOverlay,
    targets: &[usize],
    key: &str,
) -> Result<(), String> {
    if o.velocity_m_s.is_none() && o.angular_velocity_deg_s.is_none() {
        return Ok(());
    }
    let v = finite3(
        o.velocity_m_s.unwrap_or([0.0; 3]),
        &format!("{key}: velocity_m_s"),
    )?;
    let w = finite3(
        o.angular_velocity_deg_s.unwrap_or([0.0; 3]),
        &format!("{key}: angular_velocity_deg_s"),
    )?;
    let pivot = match o.pivot_m {
        Some(p) => p,
        None => {
            let refs: Vec<&Shape> = targets.iter().map(|&k| &scene.shapes[k]).collect();
            let (lo, hi) = union_bounds(&refs);
            [0, 1, 2].map(|i| (lo[i] + hi[i]) / 2.0)
        }
    };
    for &k in targets {
        scene.settings.time.move_shape(
            k,
            MotionPart::Velocity {
                velocity_m_s: v,
                angular_velocity_deg_s: w,
                pivot_m: pivot,
            },
        );
    }
    Ok(())
}

/// After the shapes `targets` were moved by `t`: any motion they already have now starts from
/// the moved pose (`world(t) = t old(t)`).
pub(crate) fn moved_shapes(scene: &mut SceneDescription, targets: &[usize], t: &Transform) {
    for &k in targets {
        if scene.settings.time.shape_motion(k).is_some() {
            scene.settings.time.move_shape(k, MotionPart::Fixed(*t));
        }
    }
}

/// After the shapes `removed` (sorted old indices) were taken out and `inserted` new ones put
/// in at index `at` (of the shortened list): the moving shapes' new indices.
pub(crate) fn shapes_replaced(
    scene: &mut SceneDescription,
    removed: &[usize],
    at: usize,
    inserted: usize,
) {
    scene.settings.time.remap_shapes(|i| {
        if removed.binary_search(&i).is_ok() {
            return None;
        }
        let j = i - removed.partition_point(|&r| r < i);
        Some(if j >= at { j + inserted } else { j })
    });
}
