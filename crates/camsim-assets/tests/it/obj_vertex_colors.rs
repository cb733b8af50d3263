//! OBJ vertex colours (`v x y z r g b`) are per-vertex factors of the base colour, as glTF's
//! `COLOR_0` (the renderer interpolates them; `gltf_attributes.rs` tests that path): on trimesh's
//! `nancolor.obj` every colour equals the file's own numbers (read here from its `v` lines), the
//! NaN one reads as white with a note, and the material multiplies them into `Kd`.

use camsim_assets::{read_scene, ReadOptions};
use camsim_scene3d::{Geometry, Material, Texture};

#[test]
fn vertex_colours_are_kept_per_vertex_and_multiply_the_base_colour() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/trimesh/nancolor.obj");
    let text = std::fs::read_to_string(&path).unwrap();
    // (position, colour) of each `v` line.
    let want: Vec<([f64; 3], [f32; 4])> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f32> = l
                .split_whitespace()
                .map(|x| x.parse::<f32>().unwrap())
                .collect();
            let c = if v[3..6].iter().all(|x| x.is_finite()) {
                [v[3], v[4], v[5], 1.0]
            } else {
                [1.0; 4]
            };
            ([v[0] as f64, v[1] as f64, v[2] as f64], c)
        })
        .collect();
    assert_eq!(want.len(), 8);
    let s = read_scene(&path, &ReadOptions::default()).unwrap();
    assert_eq!(s.shapes.len(), 1);
    let Geometry::Triangles {
        colors, positions, ..
    } = &s.shapes[0].geometry
    else {
        panic!("not a mesh")
    };
    assert_eq!(positions.len(), 8, "no vertex split without a normal map");
    // tobj numbers the vertices in the order the faces use them: match by position (the
    // default frame is the file's, Y up, 1 m per unit).
    let colors = colors.as_ref().expect("vertex colours");
    for (p, c) in positions.iter().zip(colors) {
        let (_, w) = want
            .iter()
            .find(|(q, _)| (0..3).all(|k| (q[k] - p[k]).abs() < 1e-6))
            .unwrap_or_else(|| panic!("no vertex at {p:?}"));
        assert_eq!(c, w, "at {p:?}");
    }
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("1 vertex colours are not finite")),
        "{:?}",
        s.notes
    );
    // No MTL: the default Kd 0.8 as a 1 x 1 texel that the vertex colour multiplies.
    let Material::GltfPbr(p) = &s.materials[s.shapes[0].material] else {
        panic!("{:?}", s.materials[s.shapes[0].material])
    };
    let Texture::VertexColored(inner) = &p.base_color else {
        panic!("{:?}", p.base_color)
    };
    let Texture::Image { rgb, .. } = inner.as_ref() else {
        panic!("{inner:?}")
    };
    assert_eq!(rgb[0], [0.8; 3]);
    // A mesh without colours keeps a plain constant base colour.
    let plain = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/trimesh/box.obj");
    let s = read_scene(&plain, &ReadOptions::default()).unwrap();
    assert!(s.shapes.iter().all(|sh| match &s.materials[sh.material] {
        Material::GltfPbr(p) => !matches!(p.base_color, Texture::VertexColored(_)),
        _ => true,
    }));
}
