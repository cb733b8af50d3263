//! camsim's renders of Blender's own glTF and OBJ exports agree with Cycles' renders of the same
//! Blender scenes (`../shared/scenes/gltf/`): an independent exporter and an independent
//! renderer. Mean luminance within 1 % after the unit factor (1 for the emissive-lit room, 683
//! for the point-lit textured plane: Blender writes P W as P 683 / (4 pi) cd), at most 3 % of
//! 16 x 12 blocks beyond 4 combined standard errors. Small: 256 x 192 at 24 spp per seed.

use camsim_scene3d::builtin::BuiltinOptions;
use camsim_validate::cycles_reference::{
    compare_luminance, load_cycles_luminance, luminance_cd_m2,
};
use std::path::{Path, PathBuf};

fn gltf_dir() -> PathBuf {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/gltf"
    ))
    .to_path_buf()
}

fn render(file: &str, camera_from: Option<&str>, seed: u64, spp: u32) -> Vec<f64> {
    let opts = BuiltinOptions {
        resolution: Some((256, 192)),
        ..BuiltinOptions::default()
    };
    let mut s = camsim_pipeline::render::read_scene_file(&gltf_dir().join(file), &opts).unwrap();
    if let Some(c) = camera_from {
        let other = camsim_pipeline::render::read_scene_file(&gltf_dir().join(c), &opts).unwrap();
        s.camera = other.camera;
    }
    s.camera.width = 256;
    s.camera.height = 192;
    s.settings.samples_per_pixel = spp;
    s.settings.max_depth = 8;
    s.settings.seed = seed;
    let out = camsim_render::render(&s, &|_, _| {}).unwrap();
    luminance_cd_m2(&out.radiance)
}

fn check(file: &str, camera_from: Option<&str>, reference: &str, unit_factor: f64) {
    let c1 = render(file, camera_from, 1, 24);
    let c2 = render(file, camera_from, 2, 24);
    let (w, h, y1) =
        load_cycles_luminance(&gltf_dir().join(format!("{reference}-cycles-seed1.exr"))).unwrap();
    let (_, _, y2) =
        load_cycles_luminance(&gltf_dir().join(format!("{reference}-cycles-seed2.exr"))).unwrap();
    assert_eq!((w, h), (256, 192));
    let c = compare_luminance([&c1, &c2], [&y1, &y2], w, h, unit_factor).unwrap();
    eprintln!("{file}: {c:?}");
    assert!(c.pass(), "{file} against Cycles: {c:?}");
}

#[test]
fn room_glb_agrees_with_cycles() {
    check("room.glb", None, "room", 1.0);
}

#[test]
fn room_obj_agrees_with_cycles() {
    // OBJ has no camera: the glTF export's.
    check("room.obj", Some("room.glb"), "room", 1.0);
}

/// The point-lit textured plane: the unit factor (683) and the mean hold; the blocks do not
/// yet (92 of 192 beyond 4 standard errors: camsim 1-2 % brighter over the textured floor, the
/// grey cube's faces agree, and one block at the cube's shadow edge 0.63x, where Blender's
/// point light has a radius and camsim's glTF point light none). Open in docs/src/assets.md.
#[test]
fn textured_glb_mean_and_unit_factor_agree_with_cycles() {
    let c1 = render("textured.glb", None, 1, 24);
    let c2 = render("textured.glb", None, 2, 24);
    let (w, h, y1) = load_cycles_luminance(&gltf_dir().join("textured-cycles-seed1.exr")).unwrap();
    let (_, _, y2) = load_cycles_luminance(&gltf_dir().join("textured-cycles-seed2.exr")).unwrap();
    let c = compare_luminance([&c1, &c2], [&y1, &y2], w, h, 683.0).unwrap();
    assert!((c.mean_ratio - 1.0).abs() < 0.01, "{c:?}");
}
