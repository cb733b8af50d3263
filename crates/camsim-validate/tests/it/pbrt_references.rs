//! camsim against pbrt-v4's own renders of Bitterli's scenes (issue 27), on a fast subset in CI,
//! through the same [`compare_scene`] that `examples/pbrt_references.rs` runs on every scene for
//! the table in `docs/src/validation.md`: the same unedited file rendered by camsim with seeds 1
//! and 2 at the references' setup (320 px wide, 32 spp, box filter, 31 x 10 nm bands, averaged
//! to the stored 160 px) and judged by the three criteria ([`Criteria::default`]): mean
//! radiance over the unit factor within 1 %, at most 3 % of the luminance blocks beyond 4
//! combined standard errors, each band's mean within 2 % (or its noise).
//!
//! - `dragon` (path tracer, a mesh light);
//! - `veach-mis` (path; its smallest sphere light is a sub-pixel emitter whose pixel is left out);
//! - `glass-of-water` (the file asks for `bdpt`: camsim's path tracer against pbrt-v4's RGB
//!   luminance, since its spectral channels are biased for splatting integrators);
//! - `teapot-full` (volumetric path tracer: a homogeneous medium in a glass teapot).
//!
//! `teapot-full`'s 490 nm band is held to 3 % instead of 2 %: pbrt-v4's seed-1 reference misses
//! the 485-495 nm bucket in about 4 % of its pixels and writes 0 there (see "The 490 nm band"
//! in `docs/src/validation.md`: pbrt-v4 renders of seeds 3 and 4 agree with camsim within
//! 0.5 % in every band of this scene).
//!
//! Skipped, with a message, when `../shared/scenes` is not beside the checkout.

use camsim_validate::pbrt_reference::{compare_scene, read_index, SceneComparison, SceneOptions};
use std::path::PathBuf;

fn shared() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    p.join("references/INDEX.md").exists().then_some(p)
}

fn run(scene: &str) -> Option<SceneComparison> {
    let Some(root) = shared() else {
        eprintln!("skipped: ../shared/scenes is not beside the checkout");
        return None;
    };
    let refs = root.join("references");
    let index = read_index(&refs).unwrap();
    let r = compare_scene(
        &root.join("bitterli"),
        &refs,
        &index,
        scene,
        &SceneOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{scene}: {e}"));
    let c = &r.comparison;
    eprintln!(
        "{scene}: mean ratio {:.4} +- {:.4}; {}/{} blocks beyond 4 SE (worst {:.1}); worst band {} nm {:+.2} %; {} pixel(s) left out; passes {:?}",
        c.mean_ratio,
        c.mean_ratio_se,
        c.blocks_off,
        c.blocks.0 * c.blocks.1,
        c.worst_block_sigmas,
        c.worst_band.0,
        100.0 * (c.worst_band.1 - 1.0),
        c.masked_pixels,
        c.passes
    );
    Some(r)
}

#[test]
fn dragon_matches_pbrt_v4() {
    if let Some(r) = run("dragon") {
        assert!(r.comparison.pass(), "{:?}", r.comparison);
    }
}

#[test]
fn veach_mis_matches_pbrt_v4_without_its_sub_pixel_light() {
    if let Some(r) = run("veach-mis") {
        assert!(r.comparison.pass(), "{:?}", r.comparison);
        assert_eq!(
            r.comparison.masked_pixels, 1,
            "the smallest sphere light's pixel"
        );
    }
}

#[test]
fn glass_of_water_path_traced_matches_pbrt_v4_bdpt() {
    if let Some(r) = run("glass-of-water") {
        assert!(
            r.comparison.luminance_from_rgb,
            "a bdpt file is judged on RGB luminance"
        );
        assert!(r.comparison.pass(), "{:?}", r.comparison);
    }
}

#[test]
fn teapot_full_with_its_medium_matches_pbrt_v4() {
    let Some(r) = run("teapot-full") else {
        return;
    };
    let c = &r.comparison;
    assert!(c.passes[0] && c.passes[1], "{c:?}");
    for ((lambda_nm, ratio), se) in c.band_ratios.iter().zip(&c.band_ratio_se) {
        // The reference's empty 490 nm bucket (module docs).
        let tolerance: f64 = if *lambda_nm == 490.0 { 0.03 } else { 0.02 };
        assert!(
            (ratio - 1.0).abs() <= tolerance.max(4.0 * se),
            "{lambda_nm} nm: pbrt-v4 / camsim {ratio:.4} +- {se:.4}"
        );
    }
}
