//! Every real scene in `../shared/scenes/bitterli` (Bitterli's collection in pbrt-v4 form, made by
//! other people; see that folder's README) loads without edits and renders (issue 27's "done
//! means"): each file is read with pbrt-v4's semantics and rendered at 48 px wide, 1 sample per
//! pixel, 4 bounces, and its image must be finite, non-negative and lit somewhere. Mean
//! radiance against pbrt-v4's own renders is checked on a fast subset by
//! `crates/camsim-validate/tests/pbrt_references.rs` and `hair_curl_reference.rs`, and for every
//! scene by the report `cargo run --release -p camsim-validate --example pbrt_references`.
//!
//! Skipped, with a message, when `../shared/scenes` is not beside the checkout.

use std::path::PathBuf;

fn scenes_dir() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/bitterli");
    p.is_dir().then_some(p)
}

#[test]
fn every_bitterli_scene_loads_and_renders() {
    let Some(dir) = scenes_dir() else {
        eprintln!("skipped: ../shared/scenes/bitterli is not beside the checkout");
        return;
    };
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("scene-v4.pbrt").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(names.len() >= 18, "found only {names:?}");
    let mut failures = Vec::new();
    for name in &names {
        let file = dir.join(name).join("scene-v4.pbrt");
        let start = std::time::Instant::now();
        let mut scene = match camsim_pbrt::parse_file(&file) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        let aspect = scene.camera.height as f64 / scene.camera.width.max(1) as f64;
        scene.camera.width = 48;
        scene.camera.height = ((48.0 * aspect).round() as usize).max(1);
        scene.settings.samples_per_pixel = 1;
        scene.settings.max_depth = scene.settings.max_depth.min(4);
        scene.settings.time_budget_s = None;
        let out = match camsim_render::render(&scene, &|_, _| {}) {
            Ok(o) => o,
            Err(e) => {
                failures.push(format!("{name}: does not render: {e}"));
                continue;
            }
        };
        let data = &out.radiance.data;
        let bad = data.iter().filter(|v| !v.is_finite() || **v < 0.0).count();
        let lit = data.iter().filter(|v| **v > 0.0).count();
        eprintln!(
            "{name}: {} x {}, {} lit values, {:.1} s",
            scene.camera.width,
            scene.camera.height,
            lit,
            start.elapsed().as_secs_f64()
        );
        if bad > 0 {
            failures.push(format!("{name}: {bad} values not finite or negative"));
        }
        if lit == 0 {
            failures.push(format!("{name}: the image is black"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
