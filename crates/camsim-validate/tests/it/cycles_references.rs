//! camsim's renders of Blender's own glTF and OBJ exports agree with Cycles' renders of the same
//! Blender scenes (`../shared/scenes/gltf/`): an independent exporter and an independent
//! renderer. Mean luminance within 1 % after the unit factor (1 for the emissive-lit room, 683
//! for the point-lit textured plane: Blender writes P W as P 683 / (4 pi) cd), at most 3 % of
//! 16 x 12 blocks beyond 4 combined standard errors. Small: 256 x 192 at 24 spp per seed. The
//! whole table: `cargo run --release -p camsim-validate --example cycles_references`.

use camsim_validate::cycles_reference::{compare_scene, CYCLES_SCENES};
use std::path::{Path, PathBuf};

fn gltf_dir() -> PathBuf {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/gltf"
    ))
    .to_path_buf()
}

#[test]
fn room_glb_agrees_with_cycles() {
    let c = compare_scene(&gltf_dir(), &CYCLES_SCENES[0], 24).unwrap();
    assert!(c.pass(), "room.glb against Cycles: {c:?}");
}

#[test]
fn room_obj_agrees_with_cycles() {
    // OBJ has no camera: the glTF export's.
    let c = compare_scene(&gltf_dir(), &CYCLES_SCENES[1], 24).unwrap();
    assert!(c.pass(), "room.obj against Cycles: {c:?}");
}

/// The point-lit textured plane: the unit factor (683) and the mean hold; the blocks do not
/// yet (92 of 192 beyond 4 standard errors: camsim 1-2 % brighter over the textured floor, the
/// grey cube's faces agree, and one block at the cube's shadow edge 0.63x). Open in
/// docs/src/assets.md.
#[test]
fn textured_glb_mean_and_unit_factor_agree_with_cycles() {
    let c = compare_scene(&gltf_dir(), &CYCLES_SCENES[2], 24).unwrap();
    assert!((c.mean_ratio - 1.0).abs() < 0.01, "{c:?}");
}
