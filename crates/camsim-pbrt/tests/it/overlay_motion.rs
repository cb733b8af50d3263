//! Motion in overlays (issue 28): object velocity and spin about a pivot, camera velocity and
//! angular velocity about its own axes, a trajectory CSV, hand shake, against closed forms.

use camsim_pbrt::overlay;
use camsim_scene3d::builtin::{self, BuiltinOptions};
use camsim_scene3d::motion::MotionPart;
use camsim_scene3d::SceneDescription;
use std::path::Path;

fn mcc() -> SceneDescription {
    builtin::scene("cornell-box-mcc", &BuiltinOptions::default()).unwrap()
}

fn apply_in(s: &mut SceneDescription, t: &str, dir: &Path) -> Result<(), String> {
    overlay::apply(s, t, "test.toml", dir).map_err(|e| e.to_string())
}

fn apply(s: &mut SceneDescription, t: &str) -> Result<(), String> {
    apply_in(s, t, Path::new("/nonexistent"))
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < tol)
}

/// A block moving at v and spinning at w about +y through the pivot: a point at `p` is, t later,
/// `pivot + R_y(w t) (p - pivot) + v t` (R_y: x' = x cos + z sin, z' = -x sin + z cos).
#[test]
fn object_moves_and_spins_about_its_pivot() {
    let mut s = mcc();
    assert!(!s.settings.time.has_motion());
    apply(
        &mut s,
        "[[object]]\nname = \"tall_block\"\nvelocity_m_s = [0.2, 0.0, 0.0]\nangular_velocity_deg_s = [0.0, 90.0, 0.0]\npivot_m = [0.1, 0.0, 0.2]\n",
    )
    .unwrap();
    assert!(s.settings.time.has_motion());
    let blocks: Vec<usize> = (0..s.shapes.len())
        .filter(|&k| s.shapes[k].name.as_deref() == Some("tall_block"))
        .collect();
    assert!(!blocks.is_empty());
    let (pivot, p, t) = ([0.1, 0.0, 0.2], [0.3, 0.1, 0.2], 0.5);
    let th = (90.0f64 * t).to_radians();
    let r = [p[0] - pivot[0], p[1] - pivot[1], p[2] - pivot[2]];
    let want = [
        pivot[0] + r[0] * th.cos() + r[2] * th.sin() + 0.2 * t,
        pivot[1] + r[1],
        pivot[2] - r[0] * th.sin() + r[2] * th.cos(),
    ];
    for &k in &blocks {
        let m = s.settings.time.shape_motion(k).expect("the block moves");
        assert!(close(m.delta(0.0).apply_point(p), p, 1e-12));
        let got = m.delta(t).apply_point(p);
        assert!(close(got, want, 1e-9), "{got:?} vs {want:?}");
    }
    // Nothing else moves.
    assert_eq!(s.settings.time.shapes.len(), blocks.len());
}

/// The camera translates at v in the world and yaws at w about its own y axis: at t its centre
/// is `c0 + v t` and it looks along `world_from_camera0 (sin wt, 0, cos wt)`.
#[test]
fn camera_velocity_and_yaw_about_its_own_axis() {
    let mut s = mcc();
    let c0 = s.camera.camera_to_world;
    apply(
        &mut s,
        "[camera]\nvelocity_m_s = [0.5, 0.0, 0.0]\nangular_velocity_deg_s = [0.0, 30.0, 0.0]\n",
    )
    .unwrap();
    let m = s.settings.time.camera.as_ref().expect("the camera moves");
    let t = 0.2;
    let at = m.at(t);
    let o = c0.apply_point([0.0; 3]);
    assert!(close(
        at.apply_point([0.0; 3]),
        [o[0] + 0.5 * t, o[1], o[2]],
        1e-9
    ));
    let th = (30.0f64 * t).to_radians();
    let want = c0.apply_vector([th.sin(), 0.0, th.cos()]);
    assert!(close(at.apply_vector([0.0, 0.0, 1.0]), want, 1e-9));
    assert!(close(m.at(0.0).apply_point([0.0; 3]), o, 1e-12));
}

/// A trajectory CSV: the position halfway between two keys is halfway between them; the view
/// turns from one look-at point to the other; bad rows are refused naming file and line.
#[test]
fn trajectory_interpolates_and_names_bad_lines() {
    let dir = std::env::temp_dir().join(format!("camsim_traj_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("path.csv"),
        "time_s,x_m,y_m,z_m,look_x_m,look_y_m,look_z_m\n0,0,0,0,0,0,1\n1,1,0,0,1,0,1\n",
    )
    .unwrap();
    let mut s = mcc();
    apply_in(&mut s, "[camera]\ntrajectory = \"path.csv\"\n", &dir).unwrap();
    let m = s.settings.time.camera.as_ref().expect("the camera moves");
    assert!(close(
        m.at(0.5).apply_point([0.0; 3]),
        [0.5, 0.0, 0.0],
        1e-9
    ));
    // Both poses look along +z: the forward axis stays +z, held after the last key.
    assert!(close(
        m.at(2.0).apply_vector([0.0, 0.0, 1.0]),
        [0.0, 0.0, 1.0],
        1e-9
    ));
    assert!(close(
        m.at(2.0).apply_point([0.0; 3]),
        [1.0, 0.0, 0.0],
        1e-9
    ));

    std::fs::write(
        dir.join("bad.csv"),
        "time_s,x_m,y_m,z_m,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,1,0,0,1,0,0,0\n",
    )
    .unwrap();
    let e = apply_in(&mut mcc(), "[camera]\ntrajectory = \"bad.csv\"\n", &dir).unwrap_err();
    assert!(e.contains("bad.csv:3") && e.contains("increase"), "{e}");
    std::fs::write(dir.join("cols.csv"), "time_s,x_m,y_m,z_m\n0,0,0,0\n").unwrap();
    let e = apply_in(&mut mcc(), "[camera]\ntrajectory = \"cols.csv\"\n", &dir).unwrap_err();
    assert!(e.contains("cols.csv:1") && e.contains("qw"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Hand shake adds a seeded random walk to the camera; a negative RMS rate is refused by key.
#[test]
fn shake_is_a_camera_motion_and_bad_rates_are_refused() {
    let mut s = mcc();
    apply(&mut s, "[camera]\nshake = { rms_deg_s = 2.0, seed = 7 }\n").unwrap();
    let m = s.settings.time.camera.as_ref().unwrap();
    assert!(m.parts.iter().any(|p| matches!(
        p,
        MotionPart::Shake { rms_deg_s, seed: 7, step_s } if *rms_deg_s == 2.0 && *step_s == 1e-3
    )));
    assert!(!m.is_static());
    let e = apply(&mut mcc(), "[camera]\nshake = { rms_deg_s = -1.0 }\n").unwrap_err();
    assert!(e.contains("camera.shake.rms_deg_s"), "{e}");
    let e = apply(
        &mut mcc(),
        "[[object]]\nname = \"tall_block\"\nremove = true\nvelocity_m_s = [1.0, 0.0, 0.0]\n",
    )
    .unwrap_err();
    assert!(e.contains("remove = true"), "{e}");
}

/// Removing a shape before a moving one keeps the motion on the moving shape (indices remapped).
#[test]
fn removing_shapes_keeps_motion_on_the_right_shape() {
    let mut s = mcc();
    apply(
        &mut s,
        "[[object]]\nname = \"tall_block\"\nvelocity_m_s = [1.0, 0.0, 0.0]\n\n[[object]]\nname = \"short_block\"\nremove = true\n",
    )
    .unwrap();
    assert!(!s.settings.time.shapes.is_empty());
    for (k, _) in &s.settings.time.shapes {
        assert_eq!(s.shapes[*k].name.as_deref(), Some("tall_block"));
    }
}
