//! The tabletop scenes of the compose tests: a table, the closed meshes of
//! `shared/assets/trimesh` and the mesh-level checks.

use super as common;
use camsim_compose::{ComposeRecord, ComposeSpec};
use camsim_scene3d::SceneDescription;

/// Table top height, m.
pub const TABLE_Y_M: f64 = 0.75;
/// Tolerance of the checks, m.
pub const TOL_M: f64 = 1e-3;

/// Closed meshes of `shared/assets/trimesh` (an inside can be told from an outside), with the
/// scale that makes each a tabletop object of 6-10 cm.
pub const ASSETS: [(&str, &str, f64, &str); 6] = [
    ("box.obj", "box", 0.04, "y"),
    ("capsule.obj", "capsule", 0.03, "y"),
    ("fuze.obj", "bottle", 0.4, "z"),
    ("rabbit.obj", "rabbit", 0.02, "y"),
    ("cube.glb", "cube", 0.03, "y"),
    ("textured_tetrahedron.obj", "tetrahedron", 0.06, "y"),
];

pub fn manifest(dir: &std::path::Path) -> std::path::PathBuf {
    let m = dir.join("tabletop.csv");
    let mut text = String::from("path,category,scale_to_m,up_axis,licence\n");
    for (f, c, s, up) in ASSETS {
        text.push_str(&format!(
            "{}/{f},{c},{s},{up},MIT (trimesh)\n",
            common::trimesh_dir().display()
        ));
    }
    std::fs::write(&m, text).unwrap();
    m
}

pub fn spec(manifest: &std::path::Path, settle: bool) -> ComposeSpec {
    spec_with(manifest, settle, [3, 8], 0.01)
}

/// `count` objects at least `min_separation_m` apart (0: they may touch).
pub fn spec_with(
    manifest: &std::path::Path,
    settle: bool,
    count: [u32; 2],
    min_separation_m: f64,
) -> ComposeSpec {
    toml::from_str(&format!(
        r#"
assets = ["{}"]
[[spawn]]
name = "clutter"
count = [{}, {}]
scale = [0.8, 1.25]
orientation = "upright"
on = "table"
min_separation_m = {min_separation_m}
[physics]
settle = {settle}
"#,
        manifest.display(),
        count[0],
        count[1]
    ))
    .unwrap()
}

/// A 1.2 m square table (a slab whose top is at TABLE_Y_M) on a floor.
pub fn table_scene() -> SceneDescription {
    let mut s = common::empty_scene();
    s.shapes.push(common::box_shape(
        "floor",
        [-3.0, -0.1, -3.0],
        [3.0, 0.0, 3.0],
    ));
    s.shapes.push(common::box_shape(
        "table",
        [-0.6, TABLE_Y_M - 0.04, -0.6],
        [0.6, TABLE_Y_M, 0.6],
    ));
    s
}

/// The worst interpenetration (m) and the worst distance from the table (m) of a composed
/// scene's objects, from their triangles.
pub fn check(scene: &SceneDescription, rec: &ComposeRecord) -> (f64, f64) {
    let meshes: Vec<_> = rec
        .objects
        .iter()
        .map(|o| {
            let (v, ix) = common::object_mesh(scene, &o.name);
            assert!(!ix.is_empty(), "{} has no triangles", o.name);
            let m = common::solid(&v, &ix);
            let pts = common::samples(&v, &ix);
            (v, ix, m, pts)
        })
        .collect();
    let (tv, tix) = common::object_mesh(scene, "table");
    let table = common::solid(&tv, &tix);
    let mut worst_pen: f64 = 0.0;
    let mut worst_rest: f64 = 0.0;
    for (i, a) in meshes.iter().enumerate() {
        // On the table: the lowest point within TOL of the top, and no point inside the slab
        // deeper than TOL.
        let low = a.0.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        let d_table = parry3d_f64::query::distance(
            &nalgebra::Isometry3::identity(),
            &a.2,
            &nalgebra::Isometry3::identity(),
            &table,
        )
        .unwrap();
        worst_rest = worst_rest
            .max((low - TABLE_Y_M).abs())
            .max(d_table)
            .max(common::depth_inside(&a.3, &table));
        for b in meshes.iter().skip(i + 1) {
            let pen = common::depth_inside(&a.3, &b.2).max(common::depth_inside(&b.3, &a.2));
            worst_pen = worst_pen.max(pen);
        }
    }
    (worst_pen, worst_rest)
}
