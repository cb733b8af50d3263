//! Assets in scenes: a glTF file inserted into the built-in Cornell box by an overlay's
//! `[[object]] add` renders, is one instance of its own with its name, category and 3D box
//! (the box's extent the asset's bounds as trimesh reads them, times the overlay's scale); an
//! OBJ replaces a named object; `camsim render`'s loader reads a GLB by its content.

use camsim_pipeline::render::{load_scene, read_scene_file};
use camsim_render::{render_with, LabelRequest, RenderRequest};
use camsim_scene3d::builtin::BuiltinOptions;
use std::path::Path;

fn shared() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"))
}

fn opts() -> BuiltinOptions {
    BuiltinOptions {
        resolution: Some((96, 96)),
        samples_per_pixel: 4,
        ..BuiltinOptions::default()
    }
}

#[test]
fn a_gltf_asset_added_to_the_cornell_box_is_its_own_labelled_instance() {
    let dir = tempfile::tempdir().unwrap();
    let duck = shared().join("assets/trimesh/Duck.glb");
    let overlay = dir.path().join("duck.toml");
    std::fs::write(
        &overlay,
        format!(
            "[[object]]\nname = \"duck\"\nadd = {{ file = {:?}, at_m = [0.28, 0.0, 0.28] }}\ncategory = \"rubber duck\"\nscale = 0.1\n",
            duck.display().to_string()
        ),
    )
    .unwrap();
    let scene = load_scene(Some("cornell-box"), None, Some(&overlay), &opts()).unwrap();
    let ducks: Vec<_> = scene
        .shapes
        .iter()
        .filter(|s| s.name.as_deref() == Some("duck"))
        .collect();
    assert!(!ducks.is_empty());
    assert!(ducks
        .iter()
        .all(|s| s.tags.category.as_deref() == Some("rubber duck")));
    let req = RenderRequest {
        labels: Some(LabelRequest {
            normals: false,
            albedo: false,
            amodal: false,
        }),
        ..Default::default()
    };
    let out = render_with(&scene, &req, &|_, _| {}).unwrap();
    let labels = out.labels.unwrap();
    let inst: Vec<_> = labels
        .instances
        .iter()
        .filter(|i| i.name == "duck")
        .collect();
    assert_eq!(inst.len(), 1, "one duck instance");
    let d = inst[0];
    assert_eq!(d.category.as_deref(), Some("rubber duck"));
    assert!(d.visible_px > 20, "the duck is seen: {} px", d.visible_px);
    // trimesh's bounds of Duck.glb: 1.65478 x 1.54041 x 1.15253 (file units), scaled by 0.1.
    let mut got = d.box_3d.as_ref().unwrap().size_m;
    got.sort_by(|a, b| b.total_cmp(a));
    let want = [0.165478, 0.154041, 0.115253];
    for k in 0..3 {
        assert!((got[k] - want[k]).abs() < 2e-3, "box {got:?} vs {want:?}");
    }
    // The ids and the instance map agree: the duck's pixels carry its id.
    let n = labels.instance_id.iter().filter(|&&v| v == d.id).count() as u64;
    assert_eq!(n, d.visible_px);
}

#[test]
fn an_obj_replaces_a_named_object() {
    let dir = tempfile::tempdir().unwrap();
    let overlay = dir.path().join("o.toml");
    std::fs::write(
        &overlay,
        format!(
            "[[object]]\nname = \"short_block\"\nreplace = {{ file = {:?} }}\ncategory = \"cube\"\nscale = 0.08\n",
            shared().join("assets/trimesh/cube.OBJ").display().to_string()
        ),
    )
    .unwrap();
    let scene = load_scene(Some("cornell-box"), None, Some(&overlay), &opts()).unwrap();
    let blocks: Vec<_> = scene
        .shapes
        .iter()
        .filter(|s| s.name.as_deref() == Some("short_block"))
        .collect();
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].tags.category.as_deref(), Some("cube"));
    let (lo, hi) = camsim_scene3d::xform::shape_bounds(&blocks[0].geometry);
    for k in 0..3 {
        // cube.OBJ is a unit cube: 0.08 m after the scale.
        assert!((hi[k] - lo[k] - 0.08).abs() < 1e-9, "{lo:?} {hi:?}");
    }
}

#[test]
fn scene_files_are_told_apart_by_content() {
    // A GLB under a misleading name is still read as glTF.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("room.pbrt");
    std::fs::copy(shared().join("scenes/gltf/room.glb"), &p).unwrap();
    let s = read_scene_file(&p, &opts()).unwrap();
    assert!(s.shapes.iter().any(|s| s.name.as_deref() == Some("lamp")));
    // A bad accessor names the file, the mesh and the accessor.
    let mut bytes = std::fs::read(shared().join("assets/trimesh/BoxTextured.glb")).unwrap();
    let bad = dir.path().join("bad.glb");
    // Cut the binary chunk short: the accessors run past their buffer.
    let len = bytes.len();
    bytes.truncate(len - 200);
    std::fs::write(&bad, &bytes).unwrap();
    let e = read_scene_file(&bad, &opts()).unwrap_err().to_string();
    assert!(e.contains("bad.glb"), "{e}");
}

#[test]
fn the_example_duck_overlay_applies() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/overlays/cornell-duck.toml");
    let scene = load_scene(Some("cornell-box"), None, Some(&p), &opts()).unwrap();
    let duck: Vec<_> = scene
        .shapes
        .iter()
        .filter(|s| s.name.as_deref() == Some("duck"))
        .collect();
    assert!(
        !duck.is_empty()
            && duck
                .iter()
                .all(|s| s.tags.category.as_deref() == Some("duck"))
    );
    // It stands on the floor (y = 0) after its scale and turn about its bottom centre.
    let lo = duck
        .iter()
        .map(|s| camsim_scene3d::xform::shape_bounds(&s.geometry).0[1])
        .fold(f64::INFINITY, f64::min);
    assert!(lo.abs() < 1e-9, "{lo}");
}

/// `[render.asset]` / `camsim render --obj-scale-m --obj-up`: trimesh reads wallhole.obj's
/// bounds as (0, 0, -10)..(10, 15, 0); in centimetres they are a hundredth, and a Z-up file
/// turned to camsim's Y-up frame (-90 degrees about x: (x, y, z) -> (x, z, -y)) spans
/// (0, -10, -15)..(10, 0, 0) file units. A glTF camera that is not there, a bad key and asset
/// keys on a pbrt-v4 file or a built-in are refused by name.
#[test]
fn render_asset_keys_scale_and_turn_an_obj_and_choose_the_gltf_camera() {
    use camsim_pipeline::render::{load_scene_with, read_scene_file_with};
    use camsim_pipeline::AssetReadSection;
    let wall = shared().join("assets/trimesh/wallhole.obj");
    let bounds = |a: &AssetReadSection| {
        camsim_assets::scene_bounds(&read_scene_file_with(&wall, &opts(), a).unwrap())
    };
    let close = |got: ([f64; 3], [f64; 3]), want: ([f64; 3], [f64; 3])| {
        for k in 0..3 {
            assert!(
                (got.0[k] - want.0[k]).abs() < 1e-9 && (got.1[k] - want.1[k]).abs() < 1e-9,
                "{got:?} vs {want:?}"
            );
        }
    };
    close(
        bounds(&AssetReadSection::default()),
        ([0.0, 0.0, -10.0], [10.0, 15.0, 0.0]),
    );
    let cm = AssetReadSection {
        obj_scale_m: Some(0.01),
        ..Default::default()
    };
    close(bounds(&cm), ([0.0, 0.0, -0.1], [0.1, 0.15, 0.0]));
    let z_up = AssetReadSection {
        obj_up_axis: Some("z".into()),
        ..cm.clone()
    };
    close(bounds(&z_up), ([0.0, -0.1, -0.15], [0.1, 0.0, 0.0]));
    // Refusals, each naming what is wrong.
    let err = |a: AssetReadSection, file: &Path| {
        read_scene_file_with(file, &opts(), &a)
            .unwrap_err()
            .to_string()
    };
    let duck = shared().join("assets/trimesh/Duck.glb");
    let e = err(
        AssetReadSection {
            camera: Some("no-such-camera".into()),
            ..Default::default()
        },
        &duck,
    );
    assert!(e.contains("no-such-camera"), "{e}");
    let e = err(
        AssetReadSection {
            obj_up_axis: Some("x".into()),
            ..Default::default()
        },
        &wall,
    );
    assert!(e.contains("render.asset.obj_up_axis"), "{e}");
    let pbrt = shared().join("scenes/bitterli/cornell-box/scene-v4.pbrt");
    let e = err(cm.clone(), &pbrt);
    assert!(e.contains("render.asset") && e.contains("pbrt-v4"), "{e}");
    let e = load_scene_with(Some("cornell-box"), None, None, &opts(), &cm)
        .unwrap_err()
        .to_string();
    assert!(e.contains("built-in"), "{e}");
    let e = toml::from_str::<camsim_pipeline::RenderSection>("[asset]\nunits = 2\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("units"), "{e}");
}
