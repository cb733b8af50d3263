//! Bitterli's scenes with participating media against pbrt-v4's own renders of them
//! (`../shared/scenes/references/`, see its INDEX.md; issue 27): pbrt-v4's radiance is
//! camsim's times 683 x 106.857. Compared as the issue asks: block means of luminance (16 x 9
//! blocks, 12 x 12 for square images) in units of the combined standard error of both
//! renderers, estimated from two seeds each, and each 10 nm band's image mean.
//!
//! With two seeds per renderer a block's standard error has between one and two degrees of
//! freedom (two when both renderers are equally noisy), so `|z| > 4` happens to 5.7-15.6 % of
//! the blocks of two renderers that agree (Student's t with 2 or 1 degrees of freedom) and the
//! median `|z|` is 0.82-1.0: the test bounds those two rather than asking for the 3 % that a
//! known standard error would give. (camsim's own volumetric and plain path tracers, on
//! teapot-full with a clear medium, give 4.9 % of the blocks beyond 4 this way.)
//!
//! `teapot_full_matches_pbrt_v4_within_noise` runs in CI (small and fast);
//! `media_scenes_against_pbrt_v4` prints the figures for `teapot-full`, `staircase2` and
//! `volumetric-caustic` (run it with `--ignored`, in release mode; `CAMSIM_BITTERLI_DIR`
//! replaces `../shared/scenes/bitterli`, e.g. by a copy whose TGA textures are converted where
//! TGA cannot be read).

use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use std::path::{Path, PathBuf};

/// pbrt-v4's radiance per camsim's W/(sr m^2 nm) (INDEX.md).
const PBRT_UNIT: f64 = 683.0 * 106.857;

fn shared() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")
}

/// camsim's render of `scene` at twice `rows x cols` pixels with `spp` samples and `seed`, in
/// pbrt-v4's units, averaged over 2 x 2 pixels as the references are stored.
fn render_camsim(scene: &str, spp: u32, seed: u64, rows: usize, cols: usize) -> SpectralImage {
    let dir = std::env::var_os("CAMSIM_BITTERLI_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| shared().join("bitterli"));
    let path = dir.join(scene).join("scene-v4.pbrt");
    let mut sc = camsim_pbrt::parse_file(&path).unwrap_or_else(|e| panic!("{e}"));
    sc.camera.width = 2 * cols;
    sc.camera.height = 2 * rows;
    sc.settings.samples_per_pixel = spp;
    sc.settings.seed = seed;
    sc.settings.time_budget_s = None;
    // The references' film: a box filter of radius 0.5 (the file asks for a triangle).
    sc.settings.filter = camsim_scene3d::scene::PixelFilter::Box { radius: [0.5, 0.5] };
    let full = camsim_render::render(&sc, &|_, _| {}).unwrap().radiance;
    let mut img = SpectralImage::zeros(rows, cols, full.grid, 1.0, full.quantity).unwrap();
    for b in 0..full.bands() {
        let src = full.band(b);
        let dst = img.band_mut(b);
        for r in 0..rows {
            for c in 0..cols {
                let s: f64 = [(0, 0), (0, 1), (1, 0), (1, 1)]
                    .iter()
                    .map(|(dr, dc)| src[(2 * r + dr) * 2 * cols + 2 * c + dc] as f64)
                    .sum();
                dst[r * cols + c] = (s / 4.0 * PBRT_UNIT) as f32;
            }
        }
    }
    img
}

fn reference(scene: &str, seed: u32) -> SpectralImage {
    let p = shared()
        .join("references")
        .join(format!("{scene}.seed{seed}.exr"));
    // In pbrt-v4's own units: `read_spectral_exr` would recognise the file and convert.
    camsim_io::exr::read_spectral_exr_as(&p, camsim_io::exr::SourceUnits::Absolute)
        .unwrap_or_else(|e| panic!("{e}"))
        .0
}

/// Block means of luminance (y-bar weighted band sum) over an `nx x ny` grid of blocks.
fn block_luminance(img: &SpectralImage, nx: usize, ny: usize) -> Vec<f64> {
    let y = Cmfs::on(&img.grid).y;
    let mut sum = vec![0f64; nx * ny];
    let mut n = vec![0f64; nx * ny];
    for r in 0..img.rows {
        for c in 0..img.cols {
            let k = (r * ny / img.rows) * nx + c * nx / img.cols;
            let p = r * img.cols + c;
            sum[k] += (0..img.bands())
                .map(|b| y[b] * img.band(b)[p] as f64)
                .sum::<f64>();
            n[k] += 1.0;
        }
    }
    sum.iter().zip(&n).map(|(s, n)| s / n).collect()
}

fn band_means(img: &SpectralImage) -> Vec<f64> {
    (0..img.bands())
        .map(|b| img.band(b).iter().map(|v| *v as f64).sum::<f64>() / img.pixels() as f64)
        .collect()
}

/// What the comparison found.
struct Comparison {
    /// pbrt-v4's mean radiance over camsim's (all bands and pixels).
    ratio: f64,
    /// Per block: (pbrt-v4's mean, camsim's mean, z = difference / combined standard error).
    blocks: Vec<(f64, f64, f64)>,
    /// Per band: pbrt-v4's image mean over camsim's, and the standard error of that ratio
    /// (from the seeds' differences).
    bands: Vec<(f64, f64)>,
}

impl Comparison {
    fn beyond_4_se(&self) -> f64 {
        self.blocks.iter().filter(|b| b.2.abs() > 4.0).count() as f64 / self.blocks.len() as f64
    }
    fn median_abs_z(&self) -> f64 {
        let mut z: Vec<f64> = self.blocks.iter().map(|b| b.2.abs()).collect();
        z.sort_by(f64::total_cmp);
        z[z.len() / 2]
    }
}

fn compare(scene: &str, spp: u32) -> Comparison {
    let (p1, p2) = (reference(scene, 1), reference(scene, 2));
    let (rows, cols) = (p1.rows, p1.cols);
    let (c1, c2) = (
        render_camsim(scene, spp, 1, rows, cols),
        render_camsim(scene, spp, 2, rows, cols),
    );
    let (nx, ny) = if rows == cols { (12, 12) } else { (16, 9) };
    let lum = |i: &SpectralImage| block_luminance(i, nx, ny);
    let (bp1, bp2, bc1, bc2) = (lum(&p1), lum(&p2), lum(&c1), lum(&c2));
    let blocks = (0..nx * ny)
        .map(|k| {
            let (p, c) = ((bp1[k] + bp2[k]) / 2.0, (bc1[k] + bc2[k]) / 2.0);
            // The mean of two seeds has variance (a1 - a2)^2 / 4 (one degree of freedom).
            let se = (((bp1[k] - bp2[k]).powi(2) + (bc1[k] - bc2[k]).powi(2)) / 4.0).sqrt();
            (p, c, if se > 0.0 { (p - c) / se } else { 0.0 })
        })
        .collect();
    let (mp1, mp2, mc1, mc2) = (
        band_means(&p1),
        band_means(&p2),
        band_means(&c1),
        band_means(&c2),
    );
    let bands = (0..p1.bands())
        .map(|b| {
            let (p, c) = ((mp1[b] + mp2[b]) / 2.0, (mc1[b] + mc2[b]) / 2.0);
            let rel_var = ((mp1[b] - mp2[b]) / p).powi(2) + ((mc1[b] - mc2[b]) / c).powi(2);
            (p / c, rel_var.sqrt() / 2.0 * (p / c))
        })
        .collect();
    let total = |a: &[f64], b: &[f64]| a.iter().chain(b).sum::<f64>();
    Comparison {
        ratio: total(&mp1, &mp2) / total(&mc1, &mc2),
        blocks,
        bands,
    }
}

fn report(scene: &str, c: &Comparison) {
    let n = c.blocks.len();
    for (k, (p, m, z)) in c.blocks.iter().enumerate() {
        if z.abs() > 4.0 {
            eprintln!(
                "  block {k} of {n}: pbrt-v4 {p:.4e}, camsim {m:.4e} ({:+.2} %), z {z:.1}",
                (m / p - 1.0) * 100.0
            );
        }
    }
    let (wb, (wr, wse)) = c
        .bands
        .iter()
        .enumerate()
        .max_by(|a, b| (a.1 .0 - 1.0).abs().total_cmp(&(b.1 .0 - 1.0).abs()))
        .unwrap();
    eprintln!(
        "{scene}: pbrt-v4 / camsim mean radiance {:.4}; {:.1} % of {n} blocks beyond 4 standard errors, median |z| {:.2}; worst band {} nm: ratio {wr:.4} +- {wse:.4}",
        c.ratio,
        c.beyond_4_se() * 100.0,
        c.median_abs_z(),
        400 + 10 * wb,
    );
}

/// teapot-full (a `volpath` file: tea, a homogeneous absorbing medium, behind two dielectric
/// interfaces) at 320 x 180 and 32 samples per pixel (as pbrt-v4's, so the two renderers'
/// noise is comparable: about 14 s of CPU in the test profile), two seeds: the mean radiance
/// ratio is the unit factor within 1.5 %, the median block |z| below 1 and at most 10 % of the
/// blocks beyond 4 combined standard errors (2-degree-of-freedom statistics, see the module
/// docs; measured 6.9 %, the teapot's lid among them), and every band's mean within 2 % plus
/// 4 standard errors.
#[test]
fn teapot_full_matches_pbrt_v4_within_noise() {
    let c = compare("teapot-full", 32);
    report("teapot-full", &c);
    assert!((c.ratio - 1.0).abs() < 0.015, "mean ratio {}", c.ratio);
    assert!(c.median_abs_z() < 1.1, "median |z| {}", c.median_abs_z());
    assert!(
        c.beyond_4_se() <= 0.12,
        "{} of blocks beyond 4 s.e.",
        c.beyond_4_se()
    );
    for (b, (r, se)) in c.bands.iter().enumerate() {
        assert!(
            (r - 1.0).abs() < 0.02 + 4.0 * se,
            "band {} nm: ratio {r} +- {se}",
            400 + 10 * b
        );
    }
}

/// The figures for the three media scenes (release mode: `cargo test --release -p
/// camsim-pipeline --test media_reference -- --ignored --nocapture`), 32 spp per seed as
/// pbrt-v4's references (`MEDIA_REF_SPP`; `MEDIA_REF_SCENES` a comma-separated list of other
/// scenes).
#[test]
#[ignore = "slow: renders three scenes twice at 32 spp; prints the comparison"]
fn media_scenes_against_pbrt_v4() {
    let spp = std::env::var("MEDIA_REF_SPP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32);
    let scenes = std::env::var("MEDIA_REF_SCENES")
        .unwrap_or_else(|_| "teapot-full,staircase2,volumetric-caustic".into());
    for scene in scenes.split(',') {
        let c = compare(scene, spp);
        report(scene, &c);
        for (b, (r, se)) in c.bands.iter().enumerate() {
            eprintln!("  {} nm: {r:.4} +- {se:.4}", 400 + 10 * b);
        }
    }
}
