//! An asset's own keypoints (a manifest's `keypoints`, in the file's units and axes) ride on the
//! spawned object: after composing, each instance's keypoints are the manifest's points taken
//! to metres and +y up (scale_to_m; a z-up file turned -90 degrees about x) and then through the
//! object's recorded pose (scale, rotation quaternion, translation), computed here from the
//! record alone.

use crate::common;
use camsim_compose::{compose, ComposeSpec};

#[test]
fn keypoints_follow_the_recorded_pose() {
    let dir = tempfile::tempdir().unwrap();
    let cube = common::trimesh_dir().join("cube.OBJ");
    let points = [[1.0, 2.0, 3.0], [-0.5, 0.25, 0.0]];
    std::fs::write(
        dir.path().join("m.json"),
        serde_json::json!([{
            "path": cube.display().to_string(),
            "category": "cube",
            "scale_to_m": 0.1,
            "up_axis": "z",
            "keypoints": { "names": ["tip", "side"], "points": points, "skeleton": [[0, 1]] },
        }])
        .to_string(),
    )
    .unwrap();
    let spec: ComposeSpec = toml::from_str(
        "assets = [\"m.json\"]\n[[spawn]]\ncount = [3, 3]\nscale = [0.5, 2.0]\norientation = \"uniform\"\ninside = { min_m = [-2.0, 0.0, -2.0], max_m = [2.0, 2.0, 2.0] }\n",
    )
    .unwrap();
    let mut scene = common::empty_scene();
    let rec = compose(&mut scene, &spec, 7, dir.path()).unwrap();
    assert_eq!(rec.objects.len(), 3);
    let mut worst = 0.0f64;
    for o in &rec.objects {
        let shapes: Vec<_> = scene
            .shapes
            .iter()
            .filter(|s| s.name.as_deref() == Some(o.name.as_str()))
            .collect();
        assert!(!shapes.is_empty(), "{}: no shapes", o.name);
        let [w, x, y, z] = o.rotation_wxyz;
        // The rotation matrix of a unit quaternion (Shoemake 1985).
        let r = [
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
        ];
        for s in shapes {
            let k = s
                .tags
                .keypoints
                .as_ref()
                .expect("a shape without its keypoints");
            assert_eq!(k.names, ["tip", "side"]);
            assert_eq!(k.skeleton, [[0, 1]]);
            for (p, got) in points.iter().zip(&k.points_m) {
                // File units and z up -> metres and y up: (x, y, z) -> (x, z, -y).
                let a = [0.1 * p[0], 0.1 * p[2], -0.1 * p[1]].map(|v| v * o.scale);
                for i in 0..3 {
                    let want = o.translation_m[i] + (0..3).map(|j| r[i][j] * a[j]).sum::<f64>();
                    worst = worst.max((want - got[i]).abs());
                }
            }
        }
    }
    assert!(
        worst < 1e-12,
        "keypoints {worst:e} m from the recorded pose"
    );
}
