//! A stack of boxes dropped on a floor settles to the closed-form heights: box k's centre at
//! (k + 1/2) h above the floor (rigid boxes, no overlap).

use crate::common;
use camsim_compose::{compose, ComposeSpec};

const N: usize = 5;
/// Box edge, m (cube.OBJ is a 1 m cube scaled by the manifest's scale_to_m).
const H_M: f64 = 0.1;

fn spec(dir: &std::path::Path, shape: &str) -> ComposeSpec {
    spec_steps(dir, shape, 3000)
}

fn spec_steps(dir: &std::path::Path, shape: &str, max_steps: u32) -> ComposeSpec {
    let manifest = dir.join("boxes.csv");
    std::fs::write(
        &manifest,
        format!(
            "path,category,scale_to_m\n{}/cube.OBJ,box,{H_M}\n",
            common::trimesh_dir().display()
        ),
    )
    .unwrap();
    // Cells 0.13 m apart from 0.06 m up: the boxes start 3 cm apart and fall onto each other.
    let toml = format!(
        r#"
assets = ["{}"]
[[spawn]]
name = "stack"
count = [{N}, {N}]
orientation = "upright"
grid = {{ origin_m = [0.0, 0.06, 0.0], spacing_m = [0.0, 0.13, 0.0], count = [1, {N}, 1] }}
[physics]
max_steps = {max_steps}
shape = "{shape}"
"#,
        manifest.display()
    );
    toml::from_str(&toml).unwrap()
}

#[test]
fn box_stack_settles_to_closed_form_heights() {
    stack("convex_hull");
}

/// The same with V-HACD convex parts as colliders (a cube decomposes into boxes).
#[test]
fn box_stack_of_convex_decompositions_settles_too() {
    stack("decomposition");
}

/// An empty scene with the floor: a slab whose top is y = 0.
fn floor_scene() -> camsim_scene3d::SceneDescription {
    let mut scene = common::empty_scene();
    scene.shapes.push(common::box_shape(
        "floor",
        [-2.0, -0.1, -2.0],
        [2.0, 0.0, 2.0],
    ));
    scene
}

fn stack(shape: &str) {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path(), shape);
    let mut scene = floor_scene();
    let rec = compose(&mut scene, &spec, 7, dir.path()).unwrap();
    let phys = rec.physics.as_ref().unwrap();
    assert!(phys.at_rest, "not at rest: {phys:?}");
    assert!(
        !scene.notes.iter().any(|n| n.contains("max_steps")),
        "{:?}",
        scene.notes
    );
    let mut heights: Vec<f64> = (0..N)
        .map(|k| {
            let (v, _) = common::object_mesh(&scene, &format!("box_{k}"));
            assert_eq!(v.len(), 8, "box_{k}");
            v.iter().map(|p| p.y).sum::<f64>() / v.len() as f64
        })
        .collect();
    heights.sort_by(f64::total_cmp);
    println!("{phys:?}");
    for (k, y) in heights.iter().enumerate() {
        let expect = (k as f64 + 0.5) * H_M;
        println!(
            "box {k}: centre {y:.6} m, closed form {expect:.6} m, error {:.3} mm",
            (y - expect) * 1e3
        );
    }
    for (k, y) in heights.iter().enumerate() {
        let expect = (k as f64 + 0.5) * H_M;
        assert!(
            (y - expect).abs() < 1e-3,
            "box {k}: centre at {y} m, closed form {expect} m"
        );
    }
    // The record's poses are the scene's.
    for o in &rec.objects {
        let (v, _) = common::object_mesh(&scene, &o.name);
        let c = v
            .iter()
            .fold(nalgebra::Vector3::zeros(), |a, p| a + p.coords)
            / v.len() as f64;
        // cube.OBJ is centred on its origin: the pose's translation is the box centre.
        for d in 0..3 {
            assert!((c[d] - o.translation_m[d]).abs() < 1e-9, "{o:?}");
        }
    }
}

/// Stopped before the boxes land (10 steps of 1/240 s: they are still falling): the record says
/// not at rest and the scene's notes tell the user to raise max_steps.
#[test]
fn settling_cut_short_by_max_steps_is_noted() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec_steps(dir.path(), "convex_hull", 10);
    let mut scene = floor_scene();
    let rec = compose(&mut scene, &spec, 7, dir.path()).unwrap();
    let phys = rec.physics.as_ref().unwrap();
    assert!(!phys.at_rest && phys.steps == 10, "{phys:?}");
    assert!(
        scene
            .notes
            .iter()
            .any(|n| n.contains("max_steps = 10") && n.contains("raise max_steps")),
        "{:?}",
        scene.notes
    );
}
