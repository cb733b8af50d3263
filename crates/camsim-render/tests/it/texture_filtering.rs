//! Texture filtering over the pixel footprint, as pbrt-v4 filters: an image texture reads its
//! MIP pyramid at the level the footprint picks (`trilinear` blending two levels, `bilinear` and
//! `point` reading level `floor(l)`, pbrt-v4 5f7a606 `MIPMap::Filter`), a 2D `checkerboard` is
//! averaged against a triangle filter of the footprint's width. A diffuse square facing the
//! camera at z = 1 under a uniform sky (direct light only) carries checks far finer than a pixel;
//! the ratio of its render to a white square's (the same seed, so the same light samples) is the
//! albedo each pixel sees.
//!
//! Closed forms: a checkerboard of single texels averages to exactly 1/2 at every MIP level above
//! 0, so where the footprint spans two texels or more the square is 1/2 at every pixel (to
//! rounding) with each of pbrt-v4's four filters (`ewa` too), while a full-resolution lookup (glTF's
//! filters, as Cycles reads them) leaves each pixel the mean of its samples' texels (a spread of
//! several per cent at 16 samples); all average 1/2 over the image. The filtered procedural
//! checkerboard is the same: each sample's weight is within a few per cent of 1/2, against 0 or 1
//! unfiltered.

use camsim_core::WavelengthGrid;
use camsim_pbrt::parse_file;
use camsim_render::*;
use camsim_scene3d::{Material, SceneDescription, TexelFilter, Texture};

const N: usize = 40;

const SKY: &str = "LightSource \"infinite\" \"rgb L\" [1 1 1]";

/// Under a uniform sky.
fn band_sums(dir: &std::path::Path, world: &str) -> Vec<f64> {
    band_sums_lit(dir, SKY, world)
}

/// Lit by `light`.
fn band_sums_lit(dir: &std::path::Path, light: &str, world: &str) -> Vec<f64> {
    edited_band_sums(dir, light, world, &|_| {})
}

/// The square at z = 1 filling a 40 x 40 view, with `world` (its texture and material) before
/// it, lit by `light`, the parsed scene changed by `edit`: each pixel's radiance summed over the
/// bands.
fn edited_band_sums(
    dir: &std::path::Path,
    light: &str,
    world: &str,
    edit: &dyn Fn(&mut SceneDescription),
) -> Vec<f64> {
    let text = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         Film \"spectral\" \"integer xresolution\" {N} \"integer yresolution\" {N}\nPixelFilter \"box\"\nWorldBegin\n\
         {light}\n{world}\n\
         Shape \"bilinearmesh\" \"point3 P\" [-1 -1 1  1 -1 1  -1 1 1  1 1 1]\n"
    );
    let path = dir.join("scene.pbrt");
    std::fs::write(&path, text).unwrap();
    let mut s = parse_file(&path).unwrap();
    s.settings.grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    s.settings.samples_per_pixel = 16;
    s.settings.max_depth = 1;
    s.settings.seed = 5;
    edit(&mut s);
    let out = render(&s, &|_, _| {}).unwrap();
    (0..N * N)
        .map(|i| {
            (0..out.radiance.bands())
                .map(|b| out.radiance.band(b)[i] as f64)
                .sum()
        })
        .collect()
}

/// A 256 x 256 checkerboard of single texels (0 and 1), as a PFM (little-endian RGB floats).
fn write_checks(path: &std::path::Path) {
    let n = 256;
    let mut bytes = format!("PF\n{n} {n}\n-1.0\n").into_bytes();
    for y in 0..n {
        for x in 0..n {
            let v = ((x + y) % 2) as f32;
            for _ in 0..3 {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// Mean and relative spread (standard deviation over mean) of the per-pixel albedo.
fn stats(albedo: &[f64]) -> (f64, f64) {
    let n = albedo.len() as f64;
    let mean = albedo.iter().sum::<f64>() / n;
    let var = albedo.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt() / mean)
}

#[test]
fn image_textures_and_checkerboards_average_over_the_pixel_footprint() {
    let dir = tempfile::tempdir().unwrap();
    write_checks(&dir.path().join("checks.pfm"));
    let white = band_sums(
        dir.path(),
        "Material \"diffuse\" \"rgb reflectance\" [1 1 1]",
    );
    let albedo = |world: &str| -> Vec<f64> {
        let t = band_sums(dir.path(), world);
        t.iter().zip(&white).map(|(a, b)| a / b).collect()
    };
    // The square's uv spans 2 m; the view 0.728 m, 40 pixels: with uscale 4 one pixel covers
    // 0.0091 x 4 x 256 = 9.3 texels, times max(1/8, 1/sqrt(16)) = 2.3 texels per sample step:
    // a filter width of 4.7 texels, MIP level 2.2, where every texel is 1/2: trilinear blends
    // levels 2 and 3, bilinear and point read level 2; ewa, its ellipse a circle of 2.3 texels
    // (the square faces the camera), blends levels 1 and 2.
    let image = |filter: &str| {
        format!(
            "Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"checks.pfm\" \
             \"string filter\" \"{filter}\" \"float uscale\" 4 \"float vscale\" 4\n\
             Material \"diffuse\" \"texture reflectance\" \"c\""
        )
    };
    for filter in ["trilinear", "bilinear", "point", "ewa"] {
        let (mean, spread) = stats(&albedo(&image(filter)));
        println!("{filter}: mean {mean:.6}, spread {spread:.2e}");
        assert!((mean - 0.5).abs() < 1e-4, "{filter} mean {mean}");
        assert!(spread < 1e-4, "{filter} spread {spread}");
    }
    // The same image read at full resolution (glTF's `LINEAR`, as Cycles): each pixel the mean
    // of its 16 samples' texels.
    let full_res = edited_band_sums(dir.path(), SKY, &image("bilinear"), &|s| {
        for m in &mut s.materials {
            if let Material::Diffuse {
                reflectance: Texture::Image { filter, .. },
            } = m
            {
                *filter = TexelFilter::Bilinear;
            }
        }
    });
    let full: Vec<f64> = full_res.iter().zip(&white).map(|(a, b)| a / b).collect();
    let (full_mean, full_spread) = stats(&full);
    println!("full resolution: mean {full_mean:.6}, spread {full_spread:.4}");
    assert!(
        (full_mean - 0.5).abs() < 0.01,
        "full-resolution mean {full_mean}"
    );
    assert!(full_spread > 0.02, "full-resolution spread {full_spread}");

    // 1024 checks across the square's uv: 9.3 checks per pixel, 2.3 per sample step, a
    // triangle filter 1.5 x that wide.
    let checker =
        "Texture \"k\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [1 1 1] \"rgb tex2\" [0 0 0] \
                   \"float uscale\" 1024 \"float vscale\" 1024\n\
                   Material \"diffuse\" \"texture reflectance\" \"k\"";
    let (ck_mean, ck_spread) = stats(&albedo(checker));
    println!("checkerboard: mean {ck_mean:.5}, spread {ck_spread:.4}");
    assert!((ck_mean - 0.5).abs() < 0.01, "checkerboard mean {ck_mean}");
    // Unfiltered, 16 samples of 0 or 1 per pixel spread by 1/sqrt(16) = 25 %.
    assert!(ck_spread < 0.03, "checkerboard spread {ck_spread}");
}

/// A bump map reads its displacement texture over the hit's footprint, as pbrt-v4's `BumpMap`
/// does (its shifted texture contexts copy the hit's `dudx` ...). A trilinear displacement of
/// single-texel checks is exactly 1/2 at the MIP level a footprint of several texels picks, so
/// its three lookups agree, the displaced surface is flat and the bumped square renders as the
/// plain one: under a distant light along the view (n . l = 1 on the square, less for any tilted
/// normal), the ratio of the two renders (same seed) is 1 at every pixel. Read at full
/// resolution instead, the lookups straddle 0 and 1 texels and tilt the normal by up to
/// atan(1 / du) (the bathroom floor's local bias against pbrt-v4, issue 43).
#[test]
fn bump_maps_read_the_displacement_over_the_pixel_footprint() {
    let dir = tempfile::tempdir().unwrap();
    write_checks(&dir.path().join("checks.pfm"));
    let light =
        "LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 1] \"rgb L\" [1 1 1]";
    let texture = "Texture \"d\" \"float\" \"imagemap\" \"string filename\" \"checks.pfm\" \
                   \"string filter\" \"trilinear\" \"float uscale\" 4 \"float vscale\" 4";
    let render =
        |material: &str| band_sums_lit(dir.path(), light, &format!("{texture}\n{material}"));
    let plain = render("Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]");
    let bumped = render(
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5] \"texture displacement\" \"d\"",
    );
    let ratios: Vec<f64> = bumped.iter().zip(&plain).map(|(b, p)| b / p).collect();
    let worst = ratios.iter().map(|r| (r - 1.0).abs()).fold(0.0, f64::max);
    println!("bumped / plain: worst |ratio - 1| {worst:.2e}");
    assert!(plain.iter().all(|&p| p > 0.0));
    assert!(
        worst < 1e-4,
        "a flat filtered displacement tilted the normal: {worst}"
    );
}
