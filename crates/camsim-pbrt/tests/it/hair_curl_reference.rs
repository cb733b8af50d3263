//! Bitterli's `hair-curl` (one B-spline cylinder curve of blonde `hair`, eumelanin 0.2, under a
//! distant light and a sky map), read and rendered by camsim, against pbrt-v4's own spectral
//! render of the same file (`../shared/scenes/references/hair-curl.seed{1,2}.exr`: 320 x 213, 32
//! spp, box filter, 31 10-nm bands, stored 2 x 2 block-averaged at 160 x 106; see that folder's
//! README and INDEX.md). camsim renders the same size at 16 spp with two seeds, averaged the same
//! way, in pbrt-v4's units (camsim's W/(sr m^2 nm) times 683 x 106.857).
//!
//! Checked (the method): the luminance of 16 x 9 blocks agrees within 4 standard errors
//! of the two renders' combined noise for at least 97 % of the blocks (each renderer's noise from
//! its two seeds: the pixel differences pooled over the block, floored by the image-wide relative
//! noise, since a block crossed by the fibre in one or two pixels has a one-degree-of-freedom
//! estimate of its own). The image means are compared at the resolution these references allow:
//! pbrt-v4's two seeds differ by about 3 % in their image means and 5 % in a band's, so the mean
//! luminance must agree within 3 % and each group of five bands within 8 %; the figures are
//! printed.
//!
//! camsim takes pbrt-v4's offset across the fibre (`h = 2 v - 1`) and cylinder normals (see
//! `camsim_render::bsdf::hair::h_from_v` and `camsim_render::curve`); with the tube's own offset
//! and normals instead the lobes leave from the mirrored side, which 40 pbrt-v4 seeds resolve as
//! 9 of 150 blocks beyond 4 standard errors at 160 px (`docs/src/validation.md`).
//!
//! Skipped, with a message, when `../shared/scenes` is not beside the checkout.

use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use camsim_io::exr::{read_spectral_exr_as, SourceUnits, PBRT_V4_RADIANCE_UNIT};
use camsim_scene3d::scene::PixelFilter;
use std::path::PathBuf;
const BLOCKS: (usize, usize) = (16, 9);

fn shared() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    p.join("bitterli/hair-curl/scene-v4.pbrt")
        .exists()
        .then_some(p)
}

/// camsim's render of hair-curl at 320 x 213, `spp` samples, averaged over 2 x 2 pixel blocks
/// (the last odd row dropped, as the references), in pbrt-v4's units.
fn render(root: &std::path::Path, spp: u32, seed: u64) -> SpectralImage {
    let mut scene = camsim_pbrt::parse_file(root.join("bitterli/hair-curl/scene-v4.pbrt")).unwrap();
    scene.camera.width = 320;
    scene.camera.height = 213;
    scene.settings.samples_per_pixel = spp;
    scene.settings.seed = seed;
    // The references were rendered with `PixelFilter "box"` of radius 0.5 in place of the file's
    // triangle of radius 1 (see the module docs): camsim now honours the file's filter, so the
    // references' own filter is set here.
    scene.settings.filter = PixelFilter::Box { radius: [0.5, 0.5] };
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let img = out.radiance;
    let (w, h) = (img.cols / 2, img.rows / 2);
    let mut data = Vec::with_capacity(w * h * img.bands());
    for b in 0..img.bands() {
        let p = img.band(b);
        for y in 0..h {
            for x in 0..w {
                let s = p[2 * y * img.cols + 2 * x]
                    + p[2 * y * img.cols + 2 * x + 1]
                    + p[(2 * y + 1) * img.cols + 2 * x]
                    + p[(2 * y + 1) * img.cols + 2 * x + 1];
                data.push((s as f64 * 0.25 * PBRT_V4_RADIANCE_UNIT) as f32);
            }
        }
    }
    SpectralImage::from_data(h, w, img.grid, 1.0, img.quantity, data).unwrap()
}

/// Per-pixel luminance (unscaled CIE Y).
fn luminance(img: &SpectralImage, cmfs: &Cmfs) -> Vec<f64> {
    let mut px = vec![0f32; img.bands()];
    (0..img.pixels())
        .map(|i| {
            for (b, v) in px.iter_mut().enumerate() {
                *v = img.band(b)[i];
            }
            cmfs.xyz_f32(&px)[1]
        })
        .collect()
}

/// Block `(bx, by)`'s pixel indices in a `w x h` image split into `BLOCKS`.
fn block(w: usize, h: usize, bx: usize, by: usize) -> impl Iterator<Item = usize> {
    let (x0, x1) = (bx * w / BLOCKS.0, (bx + 1) * w / BLOCKS.0);
    let (y0, y1) = (by * h / BLOCKS.1, (by + 1) * h / BLOCKS.1);
    (y0..y1).flat_map(move |y| (x0..x1).map(move |x| y * w + x))
}

/// The image-wide relative noise of one render: `k` with var(pixel) ~ k mean(pixel)^2, from
/// the two seeds' differences pooled over every pixel (`sum (a - b)^2 / 2 / sum ((a + b) / 2)^2`).
fn relative_variance(a: &[f64], b: &[f64]) -> f64 {
    let (mut d2, mut m2) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        d2 += 0.5 * (x - y) * (x - y);
        m2 += 0.25 * (x + y) * (x + y);
    }
    if m2 > 0.0 {
        d2 / m2
    } else {
        0.0
    }
}

/// Mean of a block over two seeds and the variance of that mean: the seeds' pixel differences
/// pooled over the block (var of one pixel ~ (a - b)^2 / 2, of the two-seed mean of n pixels
/// sum (a - b)^2 / (4 n^2)), floored by the image-wide relative noise `k`.
fn block_stats(a: &[f64], b: &[f64], k: f64, idx: impl Iterator<Item = usize>) -> (f64, f64) {
    let (mut s, mut d2, mut m2, mut n) = (0.0, 0.0, 0.0, 0usize);
    for i in idx {
        s += a[i] + b[i];
        d2 += (a[i] - b[i]) * (a[i] - b[i]);
        m2 += 0.25 * (a[i] + b[i]) * (a[i] + b[i]);
        n += 1;
    }
    let n = n as f64;
    (s / (2.0 * n), (d2 / 4.0).max(0.5 * k * m2) / (n * n))
}

/// Image mean of band `band` over two renders.
fn band_mean(a: &SpectralImage, b: &SpectralImage, band: usize) -> f64 {
    let s: f64 = a
        .band(band)
        .iter()
        .chain(b.band(band))
        .map(|v| *v as f64)
        .sum();
    s / (2 * a.pixels()) as f64
}

#[test]
fn hair_curl_agrees_with_pbrt_v4() {
    let Some(root) = shared() else {
        eprintln!("skipped: ../shared/scenes is not beside the checkout");
        return;
    };
    let refs: Vec<SpectralImage> = [1, 2]
        .iter()
        .map(|s| {
            // In pbrt-v4's own units, as written: `read_spectral_exr` would recognise pbrt-v4's
            // header and divide by `PBRT_V4_RADIANCE_UNIT`, while camsim's render is scaled up.
            let p = root.join(format!("references/hair-curl.seed{s}.exr"));
            read_spectral_exr_as(&p, SourceUnits::Absolute).unwrap().0
        })
        .collect();
    let ours = [render(&root, 16, 1), render(&root, 16, 2)];
    let (w, h) = (refs[0].cols, refs[0].rows);
    assert_eq!((ours[0].cols, ours[0].rows), (w, h));
    assert_eq!(ours[0].grid.wavelengths_nm(), refs[0].grid.wavelengths_nm());
    let cmfs = Cmfs::on(&refs[0].grid);
    let (r1, r2) = (luminance(&refs[0], &cmfs), luminance(&refs[1], &cmfs));
    let (c1, c2) = (luminance(&ours[0], &cmfs), luminance(&ours[1], &cmfs));
    let (kr, kc) = (relative_variance(&r1, &r2), relative_variance(&c1, &c2));
    let (mr, _) = block_stats(&r1, &r2, 0.0, 0..w * h);
    let (mc, _) = block_stats(&c1, &c2, 0.0, 0..w * h);
    let (mut outliers, mut worst) = (0, 0f64);
    for by in 0..BLOCKS.1 {
        for bx in 0..BLOCKS.0 {
            let (br, vr) = block_stats(&r1, &r2, kr, block(w, h, bx, by));
            let (bc, vc) = block_stats(&c1, &c2, kc, block(w, h, bx, by));
            let z = if vr + vc > 0.0 {
                (bc - br) / (vr + vc).sqrt()
            } else if bc == br {
                0.0
            } else {
                f64::INFINITY
            };
            worst = worst.max(z.abs());
            if z.abs() > 4.0 {
                outliers += 1;
                eprintln!("  block ({bx}, {by}): pbrt-v4 {br:.4}, camsim {bc:.4}: {z:+.1} sigma");
            }
        }
    }
    let n_blocks = BLOCKS.0 * BLOCKS.1;
    eprintln!(
        "hair-curl: mean luminance pbrt-v4 / camsim {:.4}; {outliers} of {n_blocks} blocks \
         beyond 4 standard errors (worst {worst:.2}); per-pixel relative noise pbrt-v4 (32 spp) \
         {:.3}, camsim (16 spp) {:.3}",
        mr / mc,
        kr.sqrt(),
        kc.sqrt()
    );
    // Bands in groups of five (the last takes six): one band's mean is too noisy (above).
    let nb = refs[0].bands();
    let mut worst_group = (0.0f64, 0.0f64);
    for g in 0..nb / 5 {
        let bands = 5 * g..if g + 1 == nb / 5 { nb } else { 5 * g + 5 };
        let (mut sr, mut sc) = (0.0, 0.0);
        for b in bands.clone() {
            sr += band_mean(&refs[0], &refs[1], b);
            sc += band_mean(&ours[0], &ours[1], b);
        }
        let r = sr / sc - 1.0;
        eprintln!(
            "  {:.0}-{:.0} nm: pbrt-v4 / camsim - 1 = {:+.1} %",
            refs[0].grid.wavelength_nm(bands.start),
            refs[0].grid.wavelength_nm(bands.end - 1),
            100.0 * r
        );
        if r.abs() > worst_group.1.abs() {
            worst_group = (refs[0].grid.wavelength_nm(bands.start), r);
        }
    }
    assert!(
        (mr / mc - 1.0).abs() < 0.03,
        "mean luminance ratio {}",
        mr / mc
    );
    assert!(
        outliers * 100 <= 3 * n_blocks,
        "{outliers} of {n_blocks} blocks beyond 4 standard errors"
    );
    assert!(
        worst_group.1.abs() < 0.08,
        "bands from {} nm off by {:+.1} %",
        worst_group.0,
        100.0 * worst_group.1
    );
}
