//! Tabletop scenes from the trimesh test assets: after placing and settling, no two objects
//! interpenetrate by more than 1 mm and each rests on the table within 1 mm, checked against
//! the meshes (parry3d point and distance queries on the triangles), not the colliders.

mod common;

use camsim_compose::{compose, ComposeRecord, ComposeSpec};
use camsim_scene3d::SceneDescription;
use parry3d_f64::query::PointQuery;

/// Table top height, m.
const TABLE_Y_M: f64 = 0.75;
/// Tolerance of the checks, m.
const TOL_M: f64 = 1e-3;

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
    toml::from_str(&format!(
        r#"
assets = ["{}"]
[[spawn]]
name = "clutter"
count = [3, 8]
scale = [0.8, 1.25]
orientation = "upright"
on = "table"
min_separation_m = 0.01
[physics]
settle = {settle}
"#,
        manifest.display()
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
        // Sanity of the inside test: the mesh's own centroid-ward points are inside it.
        let c =
            a.0.iter()
                .fold(nalgebra::Vector3::zeros(), |s, p| s + p.coords)
                / a.0.len() as f64;
        let _ = a.2.project_local_point(&nalgebra::Point3::from(c), false);
    }
    (worst_pen, worst_rest)
}

#[test]
fn tabletop_samples_rest_on_the_table_without_interpenetration() {
    let dir = tempfile::tempdir().unwrap();
    let m = manifest(dir.path());
    let spec = spec(&m, true);
    let n_samples = 100u64;
    let (mut pen, mut rest, mut objects, mut not_at_rest) = (0.0f64, 0.0f64, 0usize, 0);
    for seed in 0..n_samples {
        let mut scene = table_scene();
        let rec = compose(&mut scene, &spec, seed, dir.path())
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!((3..=8).contains(&rec.objects.len()));
        objects += rec.objects.len();
        if !rec.physics.as_ref().unwrap().at_rest {
            not_at_rest += 1;
        }
        let (p, r) = check(&scene, &rec);
        assert!(p <= TOL_M, "seed {seed}: objects interpenetrate by {p} m");
        assert!(r <= TOL_M, "seed {seed}: an object is {r} m off the table");
        pen = pen.max(p);
        rest = rest.max(r);
    }
    println!(
        "{n_samples} samples, {objects} objects: worst interpenetration {:.3} mm, worst distance from the table {:.3} mm, {not_at_rest} samples not at rest",
        pen * 1e3,
        rest * 1e3
    );
}
