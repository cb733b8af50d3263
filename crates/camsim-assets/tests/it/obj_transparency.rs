//! MTL transparency: `d` is the opacity, `Tr` its complement (the MTL specification), except the
//! lone `Tr 1` exporters such as MeshLab write for opaque materials (trimesh's own `fuze.obj`):
//! read as opaque with a note, so the object is not invisible.

use camsim_assets::{read_scene, ReadOptions};
use camsim_scene3d::{FloatTexture, Material, SceneDescription};

fn read(mtl: &str) -> SceneDescription {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        format!("newmtl paint\nKd 0.5 0.5 0.5\n{mtl}\n"),
    )
    .unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl paint\nf 1 2 3\n";
    std::fs::write(dir.path().join("t.obj"), obj).unwrap();
    read_scene(&dir.path().join("t.obj"), &ReadOptions::default()).unwrap()
}

fn alpha(s: &SceneDescription) -> Option<FloatTexture> {
    match &s.materials[s.shapes[0].material] {
        Material::AlphaMasked { alpha, .. } => Some(alpha.clone()),
        _ => None,
    }
}

#[test]
fn tr_is_the_complement_of_d_but_a_lone_tr_1_is_opaque() {
    assert_eq!(alpha(&read("Tr 0.25")), Some(FloatTexture::Constant(0.75)));
    assert_eq!(alpha(&read("d 0.5")), Some(FloatTexture::Constant(0.5)));
    assert_eq!(
        alpha(&read("d 1\nTr 1")),
        None,
        "d decides when both are given"
    );
    let s = read("Tr 1");
    assert_eq!(alpha(&s), None, "a lone Tr 1 is opaque");
    assert!(s.notes.iter().any(|n| n.contains("Tr 1")), "{:?}", s.notes);
    // The trimesh test model that has it renders visibly.
    let fuze = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/trimesh/fuze.obj");
    let s = read_scene(&fuze, &ReadOptions::default()).unwrap();
    assert!(s
        .shapes
        .iter()
        .all(|sh| !matches!(s.materials[sh.material], Material::AlphaMasked { .. })));
}
