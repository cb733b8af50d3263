//! Every file of `../shared/assets/trimesh/` read as trimesh 5.2.0 (an independent loader)
//! reads it (`expected.csv`: faces, bounds after the node transforms, total surface area):
//! the same face count, bounds within 1e-5 relative and area within 1e-4 relative; the two
//! glTF files whose `.bin` is missing are refused naming it.

use camsim_assets::{mesh_area, read_scene, scene_bounds, ReadOptions};
use camsim_scene3d::Geometry;
use std::path::Path;

fn dir() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/assets/trimesh"
    ))
}

fn parse3(s: &str) -> [f64; 3] {
    let v: Vec<f64> = s.split_whitespace().map(|x| x.parse().unwrap()).collect();
    [v[0], v[1], v[2]]
}

#[test]
fn reads_every_file_as_trimesh_does() {
    let mut rdr = csv::Reader::from_path(dir().join("expected.csv")).expect("expected.csv");
    let mut checked = 0;
    let mut failures = Vec::new();
    for rec in rdr.records() {
        let r = rec.unwrap();
        let file = &r[0];
        let path = dir().join(file);
        let result = read_scene(&path, &ReadOptions::default());
        if r[1].starts_with("no") {
            let e = result.expect_err(file).to_string();
            // The message names the missing buffer file and the URI that wanted it.
            assert!(e.contains(".bin") && e.contains("uri"), "{file}: {e}");
            checked += 1;
            continue;
        }
        let scene = match result {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{file}: {e}"));
                continue;
            }
        };
        let (mut faces, mut area) = (0usize, 0.0f64);
        for s in &scene.shapes {
            if let Geometry::Triangles {
                positions, indices, ..
            } = &s.geometry
            {
                faces += indices.len();
                area += mesh_area(positions, indices);
            }
        }
        let want_faces: usize = r[4].parse().unwrap();
        let want_area: f64 = r[7].parse().unwrap();
        if faces != want_faces {
            failures.push(format!("{file}: {faces} faces, trimesh {want_faces}"));
        }
        if (area - want_area).abs() > 1e-4 * want_area.max(1e-12) {
            failures.push(format!("{file}: area {area}, trimesh {want_area}"));
        }
        if want_faces > 0 {
            let (lo, hi) = scene_bounds(&scene);
            let (wlo, whi) = (parse3(&r[5]), parse3(&r[6]));
            let size = (0..3).map(|k| whi[k] - wlo[k]).fold(0.0, f64::max);
            for k in 0..3 {
                if (lo[k] - wlo[k]).abs() > 1e-5 * size || (hi[k] - whi[k]).abs() > 1e-5 * size {
                    failures.push(format!(
                        "{file}: bounds {lo:?}..{hi:?}, trimesh {wlo:?}..{whi:?}"
                    ));
                    break;
                }
            }
        }
        checked += 1;
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(checked, 32);
}
