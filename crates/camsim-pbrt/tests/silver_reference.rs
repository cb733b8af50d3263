//! pbrt-v4's named metal spectra are pbrt-v4's data (issue 27): Bitterli's `coffee` names
//! `metal-Ag-eta` / `metal-Ag-k` for its smooth silver parts, and camsim's render of them must
//! match pbrt-v4's own render of the file (`../shared/scenes/references/coffee.seed{1,2}.exr`,
//! 320 x 400 at 32 spp, box filter, 31 10-nm bands, stored 2 x 2 block-averaged at 160 x 200).
//!
//! camsim renders the same view at 80 x 100 pixels (each pixel the area of 2 x 2 stored
//! pixels, box filter, so both integrate the same solid angle) and the luminance summed over
//! the pixels whose centre sees the `Metal` material is compared with pbrt-v4's over the same
//! pixels, in pbrt-v4's units (camsim's W/(sr m^2 nm) times 683 x 106.857). Measured: pbrt-v4 /
//! camsim = 0.992, 1.001, 0.999, 0.993 for camsim's seeds 1-4 (166 pixels; pbrt-v4's two seeds
//! alone differ by 0.5 %), so the bound is 1.5 %. With Johnson and Christy's silver (1972;
//! normal-incidence reflectance 0.96 at 400 nm, 0.98 at 500 nm, against pbrt-v4's table's 0.87
//! and 0.95), which camsim used before, the ratio is 0.967 and the test fails.
//!
//! Skipped, with a message, when `../shared/scenes` is not beside the checkout.

use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use camsim_io::exr::{read_spectral_exr_as, SourceUnits, PBRT_V4_RADIANCE_UNIT};
use camsim_scene3d::scene::PixelFilter;
use std::path::PathBuf;

fn shared() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    p.join("bitterli/coffee/scene-v4.pbrt")
        .exists()
        .then_some(p)
}

/// Per-pixel luminance (unscaled CIE Y) of `img`, times `scale`.
fn luminance(img: &SpectralImage, cmfs: &Cmfs, scale: f64) -> Vec<f64> {
    let mut px = vec![0f32; img.bands()];
    (0..img.pixels())
        .map(|i| {
            for (b, v) in px.iter_mut().enumerate() {
                *v = img.band(b)[i];
            }
            cmfs.xyz_f32(&px)[1] as f64 * scale
        })
        .collect()
}

#[test]
fn coffee_silver_matches_pbrt_v4() {
    let Some(root) = shared() else {
        eprintln!("skipped: ../shared/scenes is not beside the checkout");
        return;
    };
    let refs: Vec<SpectralImage> = [1, 2]
        .iter()
        .map(|s| {
            let p = root.join(format!("references/coffee.seed{s}.exr"));
            read_spectral_exr_as(&p, SourceUnits::Absolute).unwrap().0
        })
        .collect();
    let (w, h) = (refs[0].cols / 2, refs[0].rows / 2);
    let mut scene = camsim_pbrt::parse_file(root.join("bitterli/coffee/scene-v4.pbrt")).unwrap();
    scene.camera.width = w;
    scene.camera.height = h;
    scene.settings.samples_per_pixel = 64;
    scene.settings.seed = 1;
    scene.settings.filter = PixelFilter::Box { radius: [0.5, 0.5] };
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let cmfs = Cmfs::on(&refs[0].grid);
    let ours = luminance(&out.radiance, &cmfs, PBRT_V4_RADIANCE_UNIT);
    let theirs: Vec<Vec<f64>> = refs.iter().map(|r| luminance(r, &cmfs, 1.0)).collect();
    let metal = 1 + out.ids.materials.iter().position(|m| m == "Metal").unwrap() as u32;
    let (mut sum_ours, mut sum_theirs, mut n) = (0.0, 0.0, 0);
    for y in 0..h {
        for x in 0..w {
            if out.ids.material_id[y * w + x] != metal {
                continue;
            }
            sum_ours += ours[y * w + x];
            // The 2 x 2 stored pixels of this pixel, both seeds.
            for r in &theirs {
                for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    sum_theirs += r[(2 * y + dy) * 2 * w + 2 * x + dx] / 8.0;
                }
            }
            n += 1;
        }
    }
    let ratio = sum_theirs / sum_ours;
    eprintln!("coffee silver: {n} pixels, pbrt-v4 / camsim luminance {ratio:.4}");
    assert!(n > 100, "{n} silver pixels");
    assert!(
        (ratio - 1.0).abs() < 0.015,
        "pbrt-v4 / camsim on silver {ratio:.4}"
    );
}
