//! camsim against pbrt-v4 on the same pbrt-v4 file: the comparison of issue 27.
//!
//! `../shared/scenes/references/` holds pbrt-v4's own spectral renders of real scenes
//! (mmp/pbrt-v4 5f7a606): two seeds each, 32 spp, `Film "spectral"` with 31 buckets of 10 nm
//! centred on 400..700 nm, `PixelFilter "box"` of radius 0.5, the file's integrator and
//! `maxdepth`, stored averaged over 2 x 2 pixel blocks (160 px wide for a 320 px render), in
//! pbrt-v4's photometrically normalised units: pbrt-v4's radiance is camsim's W/(sr m^2 nm)
//! times [`PBRT_UNIT_FACTOR`] = 683 x 106.857 (see `camsim_pbrt`'s unit notes).
//!
//! [`render_like_reference`] renders a file as the references were made (at the reference's
//! size times the block factor, the same bands, the file's depth and sampler, a given seed and
//! sample count) and averages it down to the stored size; [`compare`] then judges camsim's two
//! seeds against pbrt-v4's two seeds by the criteria ([`Criteria`]):
//! 1. the ratio of pbrt-v4's to camsim's mean radiance (all bands, all pixels) equals
//!    [`PBRT_UNIT_FACTOR`] within 1 %;
//! 2. after scaling camsim by that factor, at most 3 % of the luminance blocks (16 x 9 for 16:9,
//!    12 x 12 for a square image, about 144 roughly square blocks otherwise) differ by more
//!    than 4 combined standard errors;
//! 3. each band's image mean agrees within 2 %.
//!
//! Pixels that one sample far brighter than the image made bright (an emitter smaller than a
//! pixel seen directly, or through glass) are left out of all three and counted
//! ([`Criteria::emitter_pixel_factor`]).
//!
//! Standard errors come from the seeds of each renderer (two for the stored references, any
//! number `k >= 2` given), pixel by pixel: for independent renders `a`, `b` of one pixel,
//! `E[(a - b)^2] / 2` is the variance of one render, so the variance of a block's two-seed mean
//! is `sum_p (a_p - b_p)^2 / (4 n^2)` over its `n` pixels (pixels are independent Monte Carlo
//! estimates); with `k` seeds, each pixel's sample variance over them divided by `k`. Pooling
//! over the block's pixels gives the estimate `n` degrees of freedom; the single difference of
//! the two block means would give one,
//! and a 4-sigma test with a one-degree-of-freedom error (a Student t with two) fails 5.7 % of
//! blocks of two identical renderers.
//!
//! [`Comparison`] also carries each renderer's variance per sample (the pixel-mean luminance
//! variance of one seed times its samples per pixel, relative to the squared mean luminance),
//! from which, with the CPU time of each, the time to equal error follows.

use crate::{Result, ValidateError};
use camsim_core::colorimetry::Cmfs;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::SpectralImage;
use camsim_scene3d::builtin::BuiltinOptions;
use camsim_scene3d::SceneDescription;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// pbrt-v4's spectral film values per camsim W/(sr m^2 nm): 683 lm/W (camsim reads pbrt's
/// normalised radiance as photometric, `camsim_pbrt`) times pbrt-v4's `CIE_Y_integral`
/// (106.856895, the y-bar integral its `SpectrumToPhotometric` normalisation divides by).
pub const PBRT_UNIT_FACTOR: f64 = 683.0 * 106.856895;

/// Pixel blocks the references were averaged over (2 x 2).
pub const REFERENCE_BLOCK: usize = 2;

/// Pass limits of [`compare`] (the "Done means").
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Criteria {
    /// Largest relative difference of the mean-radiance ratio from [`PBRT_UNIT_FACTOR`].
    pub mean_tolerance: f64,
    /// A block differs when |difference| exceeds this many combined standard errors.
    pub block_sigmas: f64,
    /// Largest fraction of differing blocks.
    pub block_fraction: f64,
    /// Largest relative difference of one band's image mean...
    pub band_tolerance: f64,
    /// ... unless the difference is within this many standard errors of the two renderers'
    /// band means (their Monte Carlo noise; 4, as the blocks).
    pub band_sigmas: f64,
    /// Pixels whose luminance times their samples per pixel (the value one sample would need
    /// to make them that bright) exceeds this many times the image's mean luminance in any of
    /// the four renders are left out of every criterion and counted
    /// (`Comparison::masked_pixels`). 128,000: 1000x the mean at the references' 128 samples
    /// per stored pixel. Only a camera sample on an emitter smaller than a pixel, seen directly
    /// or through glass, is that bright: such a pixel's value is the emitter's radiance times
    /// the fraction of the pixel it covers, which both renderers estimate from the one or two
    /// samples that hit it (`volumetric-caustic`'s 5 x 4 mm light, about 1 % of a pixel,
    /// holding a quarter to a third of the image's mean). Scaling by the sample count leaves the
    /// same single-sample events out of renders of different sample counts.
    pub emitter_pixel_factor: f64,
}

impl Default for Criteria {
    fn default() -> Self {
        Criteria {
            mean_tolerance: 0.01,
            block_sigmas: 4.0,
            block_fraction: 0.03,
            band_tolerance: 0.02,
            band_sigmas: 4.0,
            emitter_pixel_factor: 1000.0 * 128.0,
        }
    }
}

/// Which of pbrt-v4's outputs the luminance criteria (mean and blocks) use.
#[derive(Debug, Clone, Copy)]
pub enum PbrtLuminance<'a> {
    /// The spectral channels (y-bar weighted band sum), the setup.
    Spectral,
    /// The luminance of pbrt-v4's own `R`, `G`, `B` channels of both seeds
    /// ([`load_reference_rgb_luminance`]). Needed for files whose integrator splats
    /// (`bdpt`, `lightpath`, `mlt`): pbrt-v4 (5f7a606) `SpectralFilm::AddSplat` adds a
    /// splatted sample's radiance divided by its wavelength density and the sample count, where
    /// `AddSample` multiplies by `CIE_Y_integral` and averages per bucket, so the light-tracing
    /// part of a `bdpt` image is `bucket width / CIE_Y_integral` = 10 / 106.857 = 0.094 of its
    /// weight in the spectral channels, while its RGB channels are consistent.
    Rgb(&'a [Vec<f64>]),
}

/// The outcome of [`compare`]: every figure of the three criteria and the noise of each renderer.
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// pbrt-v4's mean over camsim's (both two-seed means), divided by the unit factor: 1 when
    /// they agree. Mean radiance over all bands and pixels ([`PbrtLuminance::Spectral`]) or mean
    /// luminance ([`PbrtLuminance::Rgb`]).
    pub mean_ratio: f64,
    /// Standard error of `mean_ratio` from the pixels' seed differences (both renderers).
    pub mean_ratio_se: f64,
    /// The luminance criteria used pbrt-v4's RGB channels ([`PbrtLuminance::Rgb`]); the band
    /// criterion is then reported but not judged (the spectral channels are biased).
    pub luminance_from_rgb: bool,
    /// Blocks across and down.
    pub blocks: (usize, usize),
    /// Blocks whose luminance differs by more than `block_sigmas` standard errors.
    pub blocks_off: usize,
    /// The largest |difference| / standard error over the blocks.
    pub worst_block_sigmas: f64,
    /// Mean of (pbrt / camsim - 1) luminance over the blocks off (signed: > 0 where pbrt-v4 is
    /// brighter), 0 when none.
    pub blocks_off_mean_rel: f64,
    /// Per band: (wavelength nm, pbrt-v4's image mean over camsim's, scaled to 1).
    pub band_ratios: Vec<(f64, f64)>,
    /// Per band: the standard error of that ratio (both renderers' seed differences).
    pub band_ratio_se: Vec<f64>,
    /// The band ratio farthest from 1 in units of the criterion (relative difference over
    /// `max(band_tolerance, band_sigmas x its standard error)`).
    pub worst_band: (f64, f64),
    /// camsim's relative luminance variance per sample: mean over pixels of the variance of one
    /// seed's pixel luminance times its samples per pixel, over the squared mean luminance.
    pub camsim_rel_variance_per_sample: f64,
    /// The same for pbrt-v4 (its samples per pixel given to [`compare`]).
    pub pbrt_rel_variance_per_sample: f64,
    /// Pass or fail of each criterion: mean, blocks, bands (bands always pass when
    /// `luminance_from_rgb`).
    pub passes: [bool; 3],
    /// Pixels left out as a sub-pixel emitter's ([`Criteria::emitter_pixel_factor`]).
    pub masked_pixels: usize,
}

impl Comparison {
    /// All three criteria met.
    pub fn pass(&self) -> bool {
        self.passes.iter().all(|&p| p)
    }
}

/// Average `factor` x `factor` pixel blocks (the references' storage). Rows and columns that
/// do not fill a block are dropped.
pub fn block_average(img: &SpectralImage, factor: usize) -> Result<SpectralImage> {
    let (rows, cols) = (img.rows / factor, img.cols / factor);
    let mut out = SpectralImage::zeros(
        rows,
        cols,
        img.grid,
        img.sample_spacing_m * factor as f64,
        img.quantity,
    )?;
    let k = 1.0 / (factor * factor) as f64;
    for b in 0..img.bands() {
        let src = img.band(b);
        let dst = out.band_mut(b);
        for r in 0..rows {
            for c in 0..cols {
                let mut s = 0.0f64;
                for dr in 0..factor {
                    let row = &src[(r * factor + dr) * img.cols + c * factor..];
                    s += row[..factor].iter().map(|&v| v as f64).sum::<f64>();
                }
                dst[r * cols + c] = (s * k) as f32;
            }
        }
    }
    Ok(out)
}

/// The reference renders of `scene` in `references_dir` for seeds 1 to `seeds`
/// (`<scene>.seed1.exr`, `<scene>.seed2.exr`, ...; the stored references have two), in
/// pbrt-v4's units.
pub fn load_reference(
    references_dir: &Path,
    scene: &str,
    seeds: usize,
) -> Result<Vec<SpectralImage>> {
    (1..=seeds)
        .map(|seed| {
            let p = references_dir.join(format!("{scene}.seed{seed}.exr"));
            // In pbrt-v4's own units: `read_spectral_exr` would recognise the file and convert.
            Ok(camsim_io::exr::read_spectral_exr_as(&p, camsim_io::exr::SourceUnits::Absolute)?.0)
        })
        .collect()
}

/// pbrt-v4's own luminance of each pixel of a reference, from its `R`, `G`, `B` channels (the
/// film's linear sRGB through its default `cie1931` sensor): `0.2126 R + 0.7152 G + 0.0722 B`
/// (ITU-R BT.709). This is camsim's luminance in cd/m^2 (pbrt-v4's `cie1931` sensor gives
/// `Y = integral y-bar L_pbrt dlambda` of its normalised radiance, which camsim reads as
/// `L / 683`): measured on `veach-mis`, the RGB and spectral channels agree within 0.1 %.
pub fn load_reference_rgb_luminance(
    references_dir: &Path,
    scene: &str,
    seeds: usize,
) -> Result<Vec<Vec<f64>>> {
    let read = |seed: usize| -> Result<Vec<f64>> {
        let p = references_dir.join(format!("{scene}.seed{seed}.exr"));
        Ok(exr_rgb_luminance(&p)?.2)
    };
    (1..=seeds).map(read).collect()
}

/// The Rec. 709 luminance `0.2126 R + 0.7152 G + 0.0722 B` of an RGB OpenEXR file's first layer
/// with R, G, B channels (a layer prefix such as `ViewLayer.Combined.` allowed), row-major, with
/// its width and height.
pub fn exr_rgb_luminance(path: &Path) -> Result<(usize, usize, Vec<f64>)> {
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .map_err(|e| ValidateError::file(path, e.to_string()))?;
    for layer in &image.layer_data {
        let find = |name: &str| {
            layer.channel_data.list.iter().find(|c| {
                let n = c.name.to_string();
                n == name || n.ends_with(&format!(".{name}"))
            })
        };
        if let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) {
            let n = layer.size.area();
            let lum = (0..n)
                .map(|i| {
                    0.2126 * r.sample_data.value_by_flat_index(i).to_f32() as f64
                        + 0.7152 * g.sample_data.value_by_flat_index(i).to_f32() as f64
                        + 0.0722 * b.sample_data.value_by_flat_index(i).to_f32() as f64
                })
                .collect();
            return Ok((layer.size.width(), layer.size.height(), lum));
        }
    }
    Err(ValidateError::file(path, "no R, G, B channels"))
}

/// The scene file of a Bitterli scene name: `<scenes_dir>/<scene>/scene-v4.pbrt`.
pub fn scene_file(scenes_dir: &Path, scene: &str) -> PathBuf {
    scenes_dir.join(scene).join("scene-v4.pbrt")
}

/// Load a pbrt-v4 file for a comparison with a reference of `ref_cols` x `ref_rows` pixels:
/// camsim's default bands (31 x 10 nm, 400-700 nm, the references' buckets), the file's
/// sampler and maximum depth, `spp` samples per pixel, `seed`, and a film `render_block` times
/// the reference's size (2 reproduces the references' 320 px render; 1 renders straight at the
/// stored size, the same box-filtered pixel with a quarter of the samples per unit area).
/// camsim's film is a box filter of radius 0.5 (one uniform sample per pixel sample), as the
/// references'. Refused (with the reader's message) when camsim cannot read the file.
pub fn load_like_reference(
    file: &Path,
    ref_cols: usize,
    ref_rows: usize,
    render_block: usize,
    spp: u32,
    seed: u64,
) -> Result<SceneDescription> {
    load_at_render_size(
        file,
        (ref_cols * render_block, ref_rows * render_block),
        spp,
        seed,
    )
}

/// The render size that reproduces a reference of `cols` x `rows` stored pixels at
/// `render_block` times its size: pbrt-v4's own render size from `INDEX.md` when the block
/// reproduces it (an odd height such as `hair-curl`'s 213 rows: the stored image dropped the
/// last row, and a 212-row render would scale the field of view's pixels by 213 / 212), else
/// the stored size times the block.
pub fn render_size(
    row: Option<&IndexRow>,
    cols: usize,
    rows: usize,
    render_block: usize,
) -> (usize, usize) {
    match row.and_then(|r| r.render_width.zip(r.render_height)) {
        Some((w, h)) if w == cols * render_block && h / render_block == rows => (w, h),
        _ => (cols * render_block, rows * render_block),
    }
}

/// [`load_like_reference`] at a given render size `(cols, rows)`.
pub fn load_at_render_size(
    file: &Path,
    render: (usize, usize),
    spp: u32,
    seed: u64,
) -> Result<SceneDescription> {
    let opts = BuiltinOptions {
        resolution: Some(render),
        seed,
        ..BuiltinOptions::default()
    };
    let mut scene = camsim_pipeline::render::load_scene(None, Some(file), None, &opts)?;
    scene.settings.samples_per_pixel = spp;
    scene.settings.time_budget_s = None;
    // The references' film: a box filter of radius 0.5, whatever `PixelFilter` the file asks for.
    scene.settings.filter = camsim_scene3d::scene::PixelFilter::Box { radius: [0.5, 0.5] };
    Ok(scene)
}

/// Render a scene from [`load_like_reference`] and average it down by `render_block`; returns
/// the image (camsim's W/(sr m^2 nm)) and the process CPU time of the render, s (user +
/// system, all threads).
pub fn render_like_reference(
    scene: &SceneDescription,
    render_block: usize,
) -> Result<(SpectralImage, f64)> {
    render_like_reference_with(scene, render_block, None)
}

/// [`render_like_reference`] with the given light sampler (to compare samplers' variance;
/// `None`: the file's `lightsampler`, as pbrt-v4 renders it).
pub fn render_like_reference_with(
    scene: &SceneDescription,
    render_block: usize,
    light_sampler: Option<camsim_render::LightSampler>,
) -> Result<(SpectralImage, f64)> {
    let cpu = || {
        let (u, s) = camsim_core::mem::process_cpu_s();
        u + s
    };
    let request = camsim_render::RenderRequest {
        light_sampler,
        ..Default::default()
    };
    let t0 = cpu();
    let out = camsim_render::render_with(scene, &request, &|_, _| {})?;
    let cpu_s = cpu() - t0;
    let img = if render_block > 1 {
        block_average(&out.radiance, render_block)?
    } else {
        out.radiance
    };
    Ok((img, cpu_s))
}

/// `k sum_b w_b L_b` of every pixel (with `w` = y-bar: luminance up to a constant).
pub(crate) fn luminance_of(img: &SpectralImage, w: &[f64], k: f64) -> Vec<f64> {
    let mut y = vec![0.0f64; img.pixels()];
    for (b, &wb) in w.iter().enumerate() {
        for (acc, &v) in y.iter_mut().zip(img.band(b)) {
            *acc += k * wb * v as f64;
        }
    }
    y
}

/// Blocks across and down for an image of `cols` x `rows`: 16 x 9 for 16:9, 12 x 12 for a
/// square, otherwise about 144 roughly square blocks.
pub fn block_grid(cols: usize, rows: usize) -> (usize, usize) {
    let aspect = cols as f64 / rows as f64;
    let nx = ((144.0 * aspect).sqrt().round() as usize).clamp(1, cols);
    let ny = ((144.0 / nx as f64).round() as usize).clamp(1, rows);
    (nx, ny)
}

/// Per pixel over `k >= 2` seeds `v[0..k][p]`: the seeds' mean, the variance of that mean
/// (`sum (x - mean)^2 / (k (k - 1))`) and one render's variance (`sum (x - mean)^2 / (k - 1)`);
/// for two seeds `(a + b) / 2`, `(a - b)^2 / 4` and `(a - b)^2 / 2`.
#[inline]
fn seed_stats(v: &[Vec<f64>], p: usize) -> (f64, f64, f64) {
    let k = v.len() as f64;
    let mean = v.iter().map(|s| s[p]).sum::<f64>() / k;
    let ss = v.iter().map(|s| (s[p] - mean) * (s[p] - mean)).sum::<f64>();
    (mean, ss / (k * (k - 1.0)), ss / (k - 1.0))
}

/// Compare camsim's seeds (W/(sr m^2 nm), `camsim_spp` samples per pixel at the compared size)
/// with pbrt-v4's seeds (its units, `pbrt_spp`), at least two of each, all of the same size and
/// bands; `luminance` chooses pbrt-v4's output for the mean and block criteria. Standard errors
/// pool each pixel's variance over the seeds (module docs); more seeds estimate a heavy-tailed
/// scene's noise better (`volumetric-caustic`).
pub fn compare(
    camsim: &[&SpectralImage],
    camsim_spp: f64,
    pbrt: &[&SpectralImage],
    pbrt_spp: f64,
    luminance: PbrtLuminance<'_>,
    criteria: &Criteria,
) -> Result<Comparison> {
    if camsim.len() < 2 || pbrt.len() < 2 {
        return Err(ValidateError::invalid(
            "images to compare",
            format!(
                "{} camsim and {} pbrt-v4 renders: at least two seeds of each are needed for \
                 their noise",
                camsim.len(),
                pbrt.len()
            ),
        ));
    }
    let (rows, cols, nb) = (pbrt[0].rows, pbrt[0].cols, pbrt[0].bands());
    for im in camsim.iter().chain(pbrt.iter()) {
        if im.rows != rows || im.cols != cols || im.bands() != nb {
            return Err(ValidateError::invalid(
                "images to compare",
                format!(
                    "{} x {} x {} bands against {cols} x {rows} x {nb}",
                    im.cols,
                    im.rows,
                    im.bands()
                ),
            ));
        }
    }
    let npx = rows * cols;
    let n = npx as f64;
    let cmfs = Cmfs::on(&pbrt[0].grid);
    let lum = |ims: &[&SpectralImage], w: &[f64], k: f64| -> Vec<Vec<f64>> {
        ims.iter().map(|im| luminance_of(im, w, k)).collect()
    };
    // Per-pixel values both criteria 1 and 2 compare, camsim's already in pbrt-v4's units.
    let (yc, yp, mean_c, mean_p, from_rgb) = match luminance {
        PbrtLuminance::Spectral => {
            let k = PBRT_UNIT_FACTOR;
            let yc = lum(camsim, &cmfs.y, k);
            let yp = lum(pbrt, &cmfs.y, 1.0);
            // Criterion 1 on the plain band sum (radiance), as the issue states it.
            let ones = vec![1.0; nb];
            let mc = lum(camsim, &ones, k);
            let mp = lum(pbrt, &ones, 1.0);
            (yc, yp, mc, mp, false)
        }
        PbrtLuminance::Rgb(rgb) => {
            if rgb.len() != pbrt.len() || rgb.iter().any(|v| v.len() != npx) {
                return Err(ValidateError::invalid(
                    "pbrt-v4 RGB luminance",
                    format!("not {} seeds of {cols} x {rows} pixels", pbrt.len()),
                ));
            }
            // camsim's luminance in cd/m^2 (683 sum y-bar L dlambda) is pbrt-v4's RGB luminance.
            let k = LUMINOUS_EFFICACY_LM_PER_W * pbrt[0].grid.step_nm;
            let yc = lum(camsim, &cmfs.y, k);
            let yp = rgb.to_vec();
            (yc.clone(), yp.clone(), yc, yp, true)
        }
    };
    // Sub-pixel emitters' pixels: one sample as bright as the pixel times its samples per
    // pixel would exceed `emitter_pixel_factor` times the mean luminance, in any of the renders.
    let keep: Vec<bool> = {
        let all: Vec<(&Vec<f64>, f64)> = yc
            .iter()
            .map(|v| (v, camsim_spp))
            .chain(yp.iter().map(|v| (v, pbrt_spp)))
            .collect();
        let limits: Vec<f64> = all
            .iter()
            .map(|(v, k)| criteria.emitter_pixel_factor * v.iter().sum::<f64>() / n / k)
            .collect();
        (0..npx)
            .map(|p| all.iter().zip(&limits).all(|((v, _), lim)| !(v[p] > *lim)))
            .collect()
    };
    let masked_pixels = keep.iter().filter(|k| !**k).count();
    let n = (npx - masked_pixels) as f64;
    if n == 0.0 {
        return Err(ValidateError::invalid(
            "images to compare",
            "every pixel is brighter than the emitter threshold".to_string(),
        ));
    }
    let kept = || (0..npx).filter(|&p| keep[p]);
    // The image mean over the seeds and the variance of that mean: the pixels' variances of
    // their means, / n^2 (pixels are independent estimates).
    let mean_and_var = |v: &[Vec<f64>]| {
        let (mut s, mut var) = (0.0f64, 0.0f64);
        for p in kept() {
            let (m, vm, _) = seed_stats(v, p);
            s += m;
            var += vm;
        }
        (s / n, var / (n * n))
    };
    let (mc, vc) = mean_and_var(&mean_c);
    let (mp, vp) = mean_and_var(&mean_p);
    let mean_ratio = mp / mc;
    let mean_ratio_se = mean_ratio * (vc / (mc * mc) + vp / (mp * mp)).sqrt();

    let (nx, ny) = block_grid(cols, rows);
    let mut blocks_off = 0;
    let mut worst = 0.0f64;
    let mut off_rel = 0.0f64;
    for by in 0..ny {
        for bx in 0..nx {
            let (r0, r1) = (by * rows / ny, (by + 1) * rows / ny);
            let (c0, c1) = (bx * cols / nx, (bx + 1) * cols / nx);
            let (mut m, mut sc, mut sp, mut var) = (0.0, 0.0, 0.0, 0.0);
            for r in r0..r1 {
                for c in c0..c1 {
                    let p = r * cols + c;
                    if !keep[p] {
                        continue;
                    }
                    m += 1.0;
                    let (a, va, _) = seed_stats(&yc, p);
                    let (e, ve, _) = seed_stats(&yp, p);
                    sc += a;
                    sp += e;
                    var += va + ve;
                }
            }
            if m == 0.0 {
                continue;
            }
            let (mcb, mpb) = (sc / m, sp / m);
            let se = var.sqrt() / m;
            let diff = mpb - mcb;
            let z = if se > 0.0 {
                diff.abs() / se
            } else if diff == 0.0 {
                0.0
            } else {
                f64::INFINITY
            };
            worst = worst.max(z);
            if z > criteria.block_sigmas {
                blocks_off += 1;
                if mcb > 0.0 {
                    off_rel += mpb / mcb - 1.0;
                }
            }
        }
    }
    // Band means over the seeds and the variance of each (same estimator per band).
    let band_mean = |ims: &[&SpectralImage], band: usize, k: f64| {
        let v: Vec<Vec<f64>> = ims
            .iter()
            .map(|im| im.band(band).iter().map(|&x| k * x as f64).collect())
            .collect();
        mean_and_var(&v)
    };
    let mut band_ratio_se = Vec::with_capacity(nb);
    let mut band_ok = true;
    let mut worst_band = (pbrt[0].grid.wavelength_nm(0), 1.0);
    let mut worst_score = -1.0;
    let band_ratios: Vec<(f64, f64)> = (0..nb)
        .map(|b| {
            let (c, vc) = band_mean(camsim, b, PBRT_UNIT_FACTOR);
            let (p, vp) = band_mean(pbrt, b, 1.0);
            let (ratio, se) = if c > 0.0 && p > 0.0 {
                let r = p / c;
                (r, r * (vc / (c * c) + vp / (p * p)).sqrt())
            } else if c == p {
                (1.0, 0.0)
            } else {
                (f64::INFINITY, 0.0)
            };
            band_ratio_se.push(se);
            let lambda = pbrt[0].grid.wavelength_nm(b);
            let allowed = criteria.band_tolerance.max(criteria.band_sigmas * se);
            let score = (ratio - 1.0).abs() / allowed;
            band_ok &= score <= 1.0;
            if score > worst_score {
                worst_score = score;
                worst_band = (lambda, ratio);
            }
            (lambda, ratio)
        })
        .collect();
    // Relative variance per sample: mean over pixels of one render's variance times spp, over
    // the squared mean luminance.
    let rel_var = |y: &[Vec<f64>], spp: f64| {
        let (m, _) = mean_and_var(y);
        let v: f64 = kept().map(|p| seed_stats(y, p).2).sum();
        if m > 0.0 {
            v / n * spp / (m * m)
        } else {
            0.0
        }
    };
    let nblocks = nx * ny;
    let passes = [
        (mean_ratio - 1.0).abs() <= criteria.mean_tolerance,
        blocks_off as f64 <= criteria.block_fraction * nblocks as f64,
        from_rgb || band_ok,
    ];
    Ok(Comparison {
        mean_ratio,
        mean_ratio_se,
        luminance_from_rgb: from_rgb,
        blocks: (nx, ny),
        blocks_off,
        worst_block_sigmas: worst,
        blocks_off_mean_rel: if blocks_off > 0 {
            off_rel / blocks_off as f64
        } else {
            0.0
        },
        band_ratios,
        band_ratio_se,
        worst_band,
        camsim_rel_variance_per_sample: rel_var(&yc, camsim_spp),
        pbrt_rel_variance_per_sample: rel_var(&yp, pbrt_spp),
        passes,
        masked_pixels,
    })
}

/// How [`compare_scene`] renders and judges.
#[derive(Debug, Clone, Copy)]
pub struct SceneOptions {
    /// camsim's samples per render pixel (32, the references').
    pub spp: u32,
    /// Seeds of each renderer, 1 to `seeds` (at least 2; the stored references have 2).
    pub seeds: usize,
    /// The render's size as a multiple of the stored size: [`REFERENCE_BLOCK`] reproduces the
    /// references' render; 1 renders at the stored size with a quarter of the samples per unit
    /// area.
    pub block: usize,
    /// camsim's light sampler; `None`: the file's `lightsampler`, as pbrt-v4 renders it.
    pub light_sampler: Option<camsim_render::LightSampler>,
    /// How camsim's layered BSDFs weigh their exits: its unbiased weights (default), or
    /// pbrt-v4 5f7a606's biased ones to reproduce pbrt-v4's `coateddiffuse` and
    /// `coatedconductor` (`camsim_scene3d::scene::LayeredExitWeight`).
    pub layered_exit_weight: camsim_scene3d::scene::LayeredExitWeight,
    /// The pass limits.
    pub criteria: Criteria,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            spp: 32,
            seeds: 2,
            block: REFERENCE_BLOCK,
            light_sampler: None,
            layered_exit_weight: Default::default(),
            criteria: Criteria::default(),
        }
    }
}

/// One scene rendered twice by camsim and compared with pbrt-v4's two seeds ([`compare_scene`]).
#[derive(Debug, Clone)]
pub struct SceneComparison {
    /// The criteria's figures.
    pub comparison: Comparison,
    /// camsim's renders (seeds 1 to `seeds`) at the stored size, W/(sr m^2 nm).
    pub camsim: Vec<SpectralImage>,
    /// pbrt-v4's references (the same seeds), in its units.
    pub pbrt: Vec<SpectralImage>,
    /// camsim's samples per stored pixel.
    pub camsim_spp: f64,
    /// pbrt-v4's samples per stored pixel.
    pub pbrt_spp: f64,
    /// camsim's render CPU time per seed (process user + system, all threads), s.
    pub camsim_cpu_s: f64,
    /// pbrt-v4's CPU time per seed from `INDEX.md`, s, when listed.
    pub pbrt_cpu_s: Option<f64>,
}

impl SceneComparison {
    /// camsim's CPU time to reach pbrt-v4's error over pbrt-v4's: `(V_c T_c) / (V_p T_p)` with
    /// `V` the relative variance per sample and `T` the CPU time per sample (below 1: camsim is
    /// faster); `None` without pbrt-v4's time.
    pub fn equal_error_time(&self) -> Option<f64> {
        let c = &self.comparison;
        self.pbrt_cpu_s.map(|pc| {
            (c.camsim_rel_variance_per_sample / self.camsim_spp * self.camsim_cpu_s)
                / (c.pbrt_rel_variance_per_sample / self.pbrt_spp * pc)
        })
    }
}

/// Whether pbrt-v4's `integrator` splats light-traced samples onto its film, so that its
/// spectral channels are biased and the luminance criteria read its RGB channels
/// ([`PbrtLuminance::Rgb`]).
pub fn integrator_splats(integrator: &str) -> bool {
    matches!(integrator, "bdpt" | "lightpath" | "mlt")
}

/// The comparison of issue 27 for one scene, as the `pbrt_references` example prints it and the
/// CI test checks it: pbrt-v4's references of `scene` (`references_dir`, seeds 1 to
/// `opts.seeds`, its
/// samples per stored pixel from `index`), camsim's renders of `scenes_dir/<scene>/scene-v4.pbrt`
/// with the same seeds ([`load_like_reference`], [`render_like_reference_with`]), and
/// [`compare`] on pbrt-v4's spectral channels, or its RGB luminance for files whose integrator
/// splats ([`integrator_splats`], the integrator from [`file_integrator`], else `index`).
/// Errors name what is missing: the references, or the reader's message when camsim cannot
/// read the file.
pub fn compare_scene(
    scenes_dir: &Path,
    references_dir: &Path,
    index: &[IndexRow],
    scene: &str,
    opts: &SceneOptions,
) -> Result<SceneComparison> {
    let row = index.iter().find(|r| r.scene == scene);
    let file = scene_file(scenes_dir, scene);
    let integrator = scene_integrator(scenes_dir, index, scene);
    let pbrt = load_reference(references_dir, scene, opts.seeds)?;
    let (cols, rows) = (pbrt[0].cols, pbrt[0].rows);
    let mut cpu_s = 0.0;
    let size = render_size(row, cols, rows, opts.block);
    let mut render = |seed: u64| -> Result<SpectralImage> {
        let mut sc = load_at_render_size(&file, size, opts.spp, seed)?;
        sc.settings.layered_exit_weight = opts.layered_exit_weight;
        let (img, c) = render_like_reference_with(&sc, opts.block, opts.light_sampler)?;
        cpu_s += c;
        Ok(img)
    };
    let camsim = (1..=opts.seeds as u64)
        .map(&mut render)
        .collect::<Result<Vec<_>>>()?;
    let camsim_spp = (opts.spp as usize * opts.block * opts.block) as f64;
    // pbrt-v4's samples per stored pixel: the references are 2 x 2 averages of its render; a
    // set stored at the render's size (as INDEX.md's render size says) has its samples per pixel.
    let pbrt_spp = row.map_or(32.0 * (REFERENCE_BLOCK * REFERENCE_BLOCK) as f64, |r| {
        r.samples_per_stored_pixel(cols)
    });
    let rgb = match integrator.as_deref() {
        Some(i) if integrator_splats(i) => Some(load_reference_rgb_luminance(
            references_dir,
            scene,
            opts.seeds,
        )?),
        _ => None,
    };
    let comparison = compare(
        &camsim.iter().collect::<Vec<_>>(),
        camsim_spp,
        &pbrt.iter().collect::<Vec<_>>(),
        pbrt_spp,
        rgb.as_deref()
            .map_or(PbrtLuminance::Spectral, PbrtLuminance::Rgb),
        &opts.criteria,
    )?;
    Ok(SceneComparison {
        comparison,
        camsim,
        pbrt,
        camsim_spp,
        pbrt_spp,
        camsim_cpu_s: cpu_s / opts.seeds as f64,
        pbrt_cpu_s: row.map(|r| r.pbrt_cpu_s),
    })
}

/// The integrator pbrt-v4 ran for `scene`: its file's ([`file_integrator`]), else the one
/// `INDEX.md` lists.
pub fn scene_integrator(scenes_dir: &Path, index: &[IndexRow], scene: &str) -> Option<String> {
    file_integrator(&scene_file(scenes_dir, scene)).or_else(|| {
        index
            .iter()
            .find(|r| r.scene == scene)
            .map(|r| r.integrator.clone())
    })
}

/// The integrator a pbrt-v4 scene file asks for: the name on its first `Integrator` line that is
/// not commented out, in the file or a file it includes (`None` when there is none, or the file
/// cannot be read). INDEX.md's column can be wrong: `volumetric-caustic`'s says bdpt, whose line
/// is commented out.
pub fn file_integrator(file: &Path) -> Option<String> {
    file_integrator_at(file, file.parent().unwrap_or(Path::new(".")), 0)
}

/// [`file_integrator`] through `Include` and `Import` (relative names resolved against the main
/// file's folder, pbrt-v4's search directory; in order, as pbrt-v4 reads them), at most 16
/// files deep.
fn file_integrator_at(file: &Path, dir: &Path, depth: usize) -> Option<String> {
    if depth > 16 {
        return None;
    }
    let text = std::fs::read_to_string(file).ok()?;
    let quoted = |rest: &str| {
        Some(
            rest.trim()
                .strip_prefix('"')?
                .split('"')
                .next()?
                .to_string(),
        )
    };
    text.lines().find_map(|line| {
        let code = line.split('#').next()?.trim();
        if let Some(rest) = code.strip_prefix("Integrator") {
            return quoted(rest);
        }
        let inc = code
            .strip_prefix("Include")
            .or_else(|| code.strip_prefix("Import"))?;
        file_integrator_at(&dir.join(quoted(inc)?), dir, depth + 1)
    })
}

/// One row of `references/INDEX.md`: the scene and pbrt-v4's CPU seconds for one seed.
#[derive(Debug, Clone, Serialize)]
pub struct IndexRow {
    /// Scene name (folder under `bitterli/`).
    pub scene: String,
    /// The file's integrator.
    pub integrator: String,
    /// pbrt-v4's samples per pixel.
    pub spp: u32,
    /// Width of pbrt-v4's render, pixels (its `render size` column, `WxH`), when given: with
    /// the stored image's width it tells how many render pixels each stored pixel averages.
    pub render_width: Option<usize>,
    /// Height of pbrt-v4's render, pixels, when given ([`render_size`]).
    pub render_height: Option<usize>,
    /// pbrt-v4's CPU time for one seed, s.
    pub pbrt_cpu_s: f64,
}

impl IndexRow {
    /// pbrt-v4's samples per stored pixel of `stored_cols` columns: its samples per pixel times
    /// the render pixels each stored pixel averages ([`REFERENCE_BLOCK`] squared when the index
    /// gives no render size).
    pub fn samples_per_stored_pixel(&self, stored_cols: usize) -> f64 {
        let block = match self.render_width {
            Some(w) if stored_cols > 0 => w as f64 / stored_cols as f64,
            _ => REFERENCE_BLOCK as f64,
        };
        self.spp as f64 * block * block
    }
}

/// The scenes listed in `references/INDEX.md` (its markdown table).
pub fn read_index(references_dir: &Path) -> Result<Vec<IndexRow>> {
    let path = references_dir.join("INDEX.md");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| ValidateError::file(&path, format!("cannot read: {e}")))?;
    let mut rows = Vec::new();
    for line in text.lines() {
        let cells: Vec<&str> = line
            .trim()
            .trim_matches('|')
            .split('|')
            .map(str::trim)
            .collect();
        if cells.len() != 6 {
            continue;
        }
        let (Ok(spp), Ok(cpu)) = (cells[4].parse::<u32>(), cells[5].parse::<f64>()) else {
            continue;
        };
        rows.push(IndexRow {
            scene: cells[0].to_string(),
            integrator: cells[1].to_string(),
            spp,
            render_width: cells[3]
                .split('x')
                .next()
                .and_then(|w| w.trim().parse().ok()),
            render_height: cells[3]
                .split('x')
                .nth(1)
                .and_then(|h| h.trim().parse().ok()),
            pbrt_cpu_s: cpu,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::{Quantity, WavelengthGrid};

    /// `2 k` renders of a uniform grey image with independent noise in every pixel and band,
    /// uniform over +-0.025 (hashed indices): `k` camsim seeds in its units, then `k` pbrt-v4
    /// seeds; `hit` puts one camera sample on a sub-pixel emitter into pbrt-v4's first seed at
    /// pixel (5, 3).
    fn renders_k(hit: f32, k: usize) -> Vec<SpectralImage> {
        let mut i = 0u64;
        let mut noise = move || {
            i += 1;
            (camsim_core::rng::mix64(i) >> 11) as f32 / (1u64 << 53) as f32
        };
        (0..2 * k)
            .map(|s| {
                let mut im = SpectralImage::zeros(
                    45,
                    80,
                    WavelengthGrid::default(),
                    1e-3,
                    Quantity::Radiance,
                )
                .unwrap();
                let scale = if s < k { 1.0 / PBRT_UNIT_FACTOR } else { 1.0 } as f32;
                for b in 0..im.bands() {
                    for v in im.band_mut(b) {
                        *v = scale * (1.0 + 0.05 * (noise() - 0.5));
                    }
                }
                if s == k {
                    for b in 0..im.bands() {
                        im.band_mut(b)[3 * 80 + 5] += hit;
                    }
                }
                im
            })
            .collect()
    }

    fn renders(hit: f32) -> Vec<SpectralImage> {
        renders_k(hit, 2)
    }

    fn compare_k(r: &[SpectralImage], criteria: &Criteria) -> Comparison {
        let k = r.len() / 2;
        let (c, p): (Vec<&SpectralImage>, Vec<&SpectralImage>) =
            (r[..k].iter().collect(), r[k..].iter().collect());
        compare(&c, 128.0, &p, 128.0, PbrtLuminance::Spectral, criteria).unwrap()
    }

    /// The mean ratio's standard error from `k` seeds of each renderer is the closed form for
    /// independent pixels: per band value variance `s^2 = 0.05^2 / 12`, the band sum's `31 s^2`
    /// over its mean 31 squared, over `n k` pixel renders, for both renderers:
    /// `sqrt(2 s^2 / (31 n k))`; two seeds and eight agree with it (the estimate's own error
    /// is about 1 % here), and one seed is refused.
    #[test]
    fn standard_errors_pool_any_number_of_seeds() {
        let s2 = 0.05f64 * 0.05 / 12.0;
        for k in [2usize, 8] {
            let c = compare_k(&renders_k(0.0, k), &Criteria::default());
            let want = (2.0 * s2 / (31.0 * 3600.0 * k as f64)).sqrt();
            assert!(
                (c.mean_ratio_se / want - 1.0).abs() < 0.05,
                "{k} seeds: {} against {want}",
                c.mean_ratio_se
            );
            assert!(c.pass(), "{c:?}");
        }
        let r = renders_k(0.0, 1);
        assert!(compare(
            &[&r[0]],
            1.0,
            &[&r[1]],
            1.0,
            PbrtLuminance::Spectral,
            &Criteria::default()
        )
        .is_err());
    }

    /// One sample on a sub-pixel emitter (a quarter of the image's mean by itself) fails the
    /// mean criterion with every pixel counted, and passes with the emitter's pixel
    /// left out, which is counted; an image without one loses no pixel.
    #[test]
    fn a_sub_pixel_emitters_pixel_is_left_out() {
        let run = |r: &[SpectralImage], factor: f64| {
            let criteria = Criteria {
                emitter_pixel_factor: factor,
                ..Criteria::default()
            };
            compare_k(r, &criteria)
        };
        let clean = run(&renders(0.0), 1000.0);
        assert_eq!(clean.masked_pixels, 0);
        assert!(clean.pass(), "{clean:?}");
        let hit = renders(0.25 * 2.0 * 3600.0);
        let all = run(&hit, f64::INFINITY);
        assert!(!all.passes[0], "{all:?}");
        assert!((all.mean_ratio - 1.25).abs() < 1e-2, "{}", all.mean_ratio);
        let masked = run(&hit, Criteria::default().emitter_pixel_factor);
        assert_eq!(masked.masked_pixels, 1);
        assert!(masked.pass(), "{masked:?}");
        assert!(
            (masked.mean_ratio - 1.0).abs() < 1e-3,
            "{}",
            masked.mean_ratio
        );
    }

    /// The stored references average 2 x 2 render pixels (128 samples from 32 spp); a set stored
    /// at the render's size has 32; an index without a render size means the references'.
    #[test]
    fn samples_and_render_size_follow_the_index() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("INDEX.md"),
            "| scene | integrator (file) | max depth | render size | spp | pbrt-v4 CPU s |\n\
             |---|---|---|---|---|---|\n\
             | lamp | path | 65 | 320x180 | 32 | 17.4 |\n",
        )
        .unwrap();
        let rows = read_index(dir.path()).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!(
            (rows[0].render_width, rows[0].render_height),
            (Some(320), Some(180))
        );
        // An odd render height is rendered as such and cropped by the 2 x 2 average (hair-curl:
        // 320 x 213 stored at 160 x 106); a block that does not reproduce the render, or no
        // size in the index, renders the stored size times the block.
        let odd = IndexRow {
            render_height: Some(213),
            ..rows[0].clone()
        };
        assert_eq!(render_size(Some(&odd), 160, 106, 2), (320, 213));
        assert_eq!(render_size(Some(&odd), 160, 106, 1), (160, 106));
        assert_eq!(render_size(None, 160, 106, 2), (320, 212));
        assert_eq!(rows[0].samples_per_stored_pixel(160), 128.0);
        assert_eq!(rows[0].samples_per_stored_pixel(320), 32.0);
        let no_size = IndexRow {
            render_width: None,
            ..rows[0].clone()
        };
        assert_eq!(no_size.samples_per_stored_pixel(320), 128.0);
    }
}
