//! The optional denoiser (issue 44, `camsim_render::denoise`) with Intel Open Image Denoise:
//! on the Cornell box at 8 samples per pixel, the denoised film's luminance on its lit surfaces
//! is far nearer the converged image than the noisy one, its mean stays within 3 % of it, the
//! lamp keeps its own radiance (no halo), and its bytes are the same for 1 and 3 render threads.
//!
//! OIDN is a C++ library camsim opens at run time, never needed to build or to test camsim:
//! these tests run where `CAMSIM_OIDN_LIBRARY` names it (`pip install oidn`; the file is
//! `oidn/lib.linux.x64/libOpenImageDenoise.so.1.4.3` in the wheel) and say so and pass where it
//! does not. The missing-library message is tested in the module's unit tests.

use crate::common;
use camsim_render::render;
use camsim_scene3d::scene::DenoiseSettings;
use camsim_scene3d::{builtin, SceneDescription};
use common::luminance;

const W: usize = 96;
const H: usize = 96;

fn library() -> Option<std::path::PathBuf> {
    match std::env::var_os(camsim_render::denoise::LIBRARY_ENV) {
        Some(p) => Some(p.into()),
        None => {
            eprintln!(
                "skipped: set {} to an OIDN library to test the denoiser",
                camsim_render::denoise::LIBRARY_ENV
            );
            None
        }
    }
}

fn scene(spp: u32, denoise: bool) -> SceneDescription {
    let mut s = builtin::scene("cornell-box", &Default::default()).unwrap();
    s.camera.width = W;
    s.camera.height = H;
    s.settings.samples_per_pixel = spp;
    s.settings.denoise = denoise.then(DenoiseSettings::default);
    s
}

/// RMS of (L / L_ref - 1) over the pixels of the surfaces light reaches (reference above 30 %
/// of its mean: the walls, the blocks' lit faces, the floor; the lamp and its edge left out).
fn errors(l: &[f64], reference: &[f64], lamp: &[bool]) -> f64 {
    let m = mean(reference);
    let lit: Vec<(f64, f64)> = l
        .iter()
        .zip(reference)
        .zip(lamp)
        .filter(|((_, r), lamp)| **r > 0.3 * m && !**lamp)
        .map(|((a, r), _)| (*a, *r))
        .collect();
    (lit.iter().map(|(a, r)| (a / r - 1.0).powi(2)).sum::<f64>() / lit.len() as f64).sqrt()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn the_denoised_film_is_nearer_the_converged_one_and_keeps_its_mean() {
    if library().is_none() {
        return;
    }
    let converged = render(&scene(512, false), &|_, _| {}).unwrap();
    let reference = luminance(&converged);
    // The lamp's pixels and their neighbours (partly covered by it).
    let light = 1 + converged
        .ids
        .objects
        .iter()
        .position(|n| n == "light")
        .expect("the lamp") as u32;
    let lamp: Vec<bool> = (0..W * H)
        .map(|p| {
            let (x, y) = ((p % W) as i64, (p / W) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    (0..W as i64).contains(&xx)
                        && (0..H as i64).contains(&yy)
                        && converged.ids.object_id[(yy * W as i64 + xx) as usize] == light
                })
            })
        })
        .collect();
    assert!(lamp.iter().filter(|l| **l).count() > 20);
    let noisy = render(&scene(8, false), &|_, _| {}).unwrap();
    let denoised = render(&scene(8, true), &|_, _| {}).unwrap();
    let (ln, ld) = (luminance(&noisy), luminance(&denoised));
    let (en, ed) = (
        errors(&ln, &reference, &lamp),
        errors(&ld, &reference, &lamp),
    );
    eprintln!("lit surfaces: noisy {en:.4}, denoised {ed:.4}");
    assert!(
        ed < 0.6 * en,
        "denoised RMS relative error on lit surfaces {ed:.4} against the noisy film's {en:.4}"
    );
    let bias = mean(&ld) / mean(&reference) - 1.0;
    assert!(bias.abs() < 0.03, "mean luminance off by {bias:+.4}");
    // The lamp and its edge keep the film's own values (the same seed renders the same film).
    let px = W * H;
    for p in (0..px).filter(|p| lamp[*p]) {
        for b in 0..noisy.radiance.bands() {
            assert_eq!(
                noisy.radiance.data[b * px + p],
                denoised.radiance.data[b * px + p]
            );
        }
    }
    // Every band is denoised, and stays a spectrum (no negative radiance).
    assert!(denoised.radiance.data.iter().all(|v| *v >= 0.0));
    let bands = noisy.radiance.bands();
    for b in [0, bands / 2, bands - 1] {
        assert_ne!(
            noisy.radiance.band(b),
            denoised.radiance.band(b),
            "band {b}"
        );
    }
}

#[test]
fn the_denoised_film_is_the_same_bytes_for_any_thread_count() {
    if library().is_none() {
        return;
    }
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&scene(8, true), &|_, _| {}).unwrap())
    };
    assert_eq!(run(1).radiance.data, run(3).radiance.data);
}
