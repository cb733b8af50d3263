//! pbrt-v4's named metal spectra are pbrt-v4's data (issue 27): Bitterli's `coffee` names
//! `metal-Ag-eta` / `metal-Ag-k` for its smooth silver parts, and camsim's render of them must
//! match pbrt-v4's own render of the file (`../shared/scenes/references/coffee.seed{1,2}.exr`,
//! 320 x 400 at 32 spp, box filter, 31 10-nm bands, stored 2 x 2 block-averaged at 160 x 200).
//!
//! camsim renders the stored size (160 x 200, box filter, so each pixel integrates the same
//! solid angle as a stored pixel) at 64 spp, and the luminance summed over the pixels whose
//! centre sees the `Metal` material is compared with pbrt-v4's over the same pixels, in pbrt-v4's
//! units (camsim's W/(sr m^2 nm) times 683 x 106.857). Measured over 686 pixels: pbrt-v4 /
//! camsim = 0.9931, 0.9997, 0.9969 for camsim's seeds 1-3 (pbrt-v4's two seeds alone differ by
//! about 0.5 % there), so the bound is 1.5 %. With Johnson and Christy's silver (1972;
//! normal-incidence reflectance 0.96 at 400 nm, 0.98 at 500 nm, against pbrt-v4's table's 0.87
//! and 0.95), which camsim used before, the ratio is 0.9671 and the test fails.
//!
//! Skipped, with a message, when `../shared/scenes` is not beside the checkout.

use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use camsim_validate::pbrt_reference::{load_like_reference, load_reference, scene_file};
use camsim_validate::pbrt_reference::{PBRT_UNIT_FACTOR, REFERENCE_BLOCK};
use std::path::PathBuf;

fn shared() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    p.join("bitterli/coffee/scene-v4.pbrt")
        .exists()
        .then_some(p)
}

/// Per-pixel luminance (unscaled CIE Y) of `img`, times `scale`.
fn luminance(img: &SpectralImage, cmfs: &Cmfs, scale: f64) -> Vec<f64> {
    let mut y = vec![0.0; img.pixels()];
    for (b, w) in cmfs.y.iter().enumerate() {
        for (acc, v) in y.iter_mut().zip(img.band(b)) {
            *acc += w * *v as f64 * scale;
        }
    }
    y
}

#[test]
fn coffee_silver_matches_pbrt_v4() {
    let Some(root) = shared() else {
        eprintln!("skipped: ../shared/scenes is not beside the checkout");
        return;
    };
    let refs = load_reference(&root.join("references"), "coffee", 2).unwrap();
    let (w, h) = (refs[0].cols, refs[0].rows);
    let file = scene_file(&root.join("bitterli"), "coffee");
    // The references' samples per stored pixel: 32 spp on 2 x 2 pixels; half of them here.
    let spp = 32 * (REFERENCE_BLOCK * REFERENCE_BLOCK) as u32 / 2;
    let scene = load_like_reference(&file, w, h, 1, spp, 1).unwrap();
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let cmfs = Cmfs::on(&refs[0].grid);
    let ours = luminance(&out.radiance, &cmfs, PBRT_UNIT_FACTOR);
    let theirs = [0, 1].map(|k| luminance(&refs[k], &cmfs, 1.0));
    let metal = 1 + out.ids.materials.iter().position(|m| m == "Metal").unwrap() as u32;
    let on: Vec<usize> = (0..w * h)
        .filter(|&i| out.ids.material_id[i] == metal)
        .collect();
    let sum = |y: &[f64]| on.iter().map(|&i| y[i]).sum::<f64>();
    let ratio = (sum(&theirs[0]) + sum(&theirs[1])) / 2.0 / sum(&ours);
    eprintln!(
        "coffee silver: {} pixels, pbrt-v4 / camsim luminance {ratio:.4}",
        on.len()
    );
    assert!(on.len() > 400, "{} silver pixels", on.len());
    assert!(
        (ratio - 1.0).abs() < 0.015,
        "pbrt-v4 / camsim on silver {ratio:.4}"
    );
}
