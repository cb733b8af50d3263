//! An OBJ normal map's tangent frame: OBJ carries no tangents, so the reader gives MikkTSpace's,
//! which on a planar quad with affine uvs is `dp/du`'s direction, with the handedness `w` the
//! sign of `(n x t) . dp/dv` (closed forms from the quad's vertices and uvs).

use camsim_assets::{read_scene, ReadOptions};
use camsim_scene3d::Geometry;

#[test]
fn a_normal_mapped_obj_gets_mikktspace_tangents_along_dp_du() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbaImage::from_pixel(1, 1, image::Rgba([128, 128, 255, 255]));
    img.save(dir.path().join("n.png")).unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl bumpy\nKd 0.5 0.5 0.5\nnorm n.png\n",
    )
    .unwrap();
    // The unit square in the xy plane (normal +z), uvs turned by 30 degrees:
    // u = cos x + sin y, v = -sin x + cos y, so dp/du = (cos, sin, 0), dp/dv = (-sin, cos, 0).
    let a = 30f64.to_radians();
    let (c, s) = (a.cos(), a.sin());
    let xy = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let mut obj = String::from("mtllib m.mtl\n");
    for p in xy {
        obj += &format!("v {} {} 0\n", p[0], p[1]);
    }
    for p in xy {
        obj += &format!("vt {} {}\n", c * p[0] + s * p[1], -s * p[0] + c * p[1]);
    }
    obj += "usemtl bumpy\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    std::fs::write(dir.path().join("q.obj"), obj).unwrap();
    // Keep OBJ's axes (z up read as is) so the closed form is in the file's frame.
    let opts = ReadOptions {
        obj_up_axis: camsim_assets::UpAxis::Y,
        ..ReadOptions::default()
    };
    let scene = read_scene(&dir.path().join("q.obj"), &opts).unwrap();
    let Geometry::Triangles {
        positions,
        tangents: Some(t),
        ..
    } = &scene.shapes[0].geometry
    else {
        panic!("no tangents on a normal-mapped OBJ")
    };
    assert_eq!(t.len(), positions.len());
    // n x t = z x (cos, sin, 0) = (-sin, cos, 0) = dp/dv: w = +1.
    for v in t {
        let d = [v[0] as f64 - c, v[1] as f64 - s, v[2] as f64];
        assert!(
            d.iter().all(|e| e.abs() < 1e-5) && v[3] == 1.0,
            "{v:?}, want ({c}, {s}, 0, 1)"
        );
    }
}
