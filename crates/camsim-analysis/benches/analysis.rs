//! Speed of the SFR and EMVA statistics. Run: `cargo bench -p camsim-analysis`.

use camsim_analysis::emva::{emva, EmvaInput, EmvaOptions};
use camsim_analysis::sfr::{sfr, SfrOptions};
use camsim_analysis::Plane;
use criterion::{criterion_group, criterion_main, Criterion};

fn edge(rows: usize, cols: usize) -> Plane {
    let t = 5f64.to_radians().tan();
    Plane::from_fn(rows, cols, |r, c| {
        let d = c as f64 + 0.5 - cols as f64 / 2.0 - t * (r as f64 - rows as f64 / 2.0);
        (0.5 + 0.5 * (d / 1.2).tanh()) as f32
    })
    .unwrap()
}

fn bench(c: &mut Criterion) {
    let img = edge(256, 128);
    c.bench_function("sfr 256x128 roi", |b| {
        b.iter(|| sfr(&img, None, &SfrOptions::default()).unwrap())
    });
    // EMVA: 12 levels of 2 bright + 2 dark 512 x 512 frames (a deterministic pseudo-noise pattern).
    let frames: Vec<Plane> = (0..48)
        .map(|k| {
            Plane::from_fn(512, 512, |r, c| {
                (100 + (k / 4) * 50) as f32 * if k % 4 < 2 { 1.0 } else { 0.0 }
                    + ((r * 31 + c * 17 + k * 7) % 13) as f32
            })
            .unwrap()
        })
        .collect();
    let levels: Vec<EmvaInput> = (0..12)
        .map(|l| EmvaInput {
            exposure_s: 1e-3 * (l + 1) as f64,
            photons_per_pixel: None,
            exposure_lux_s: None,
            bright: vec![&frames[4 * l], &frames[4 * l + 1]],
            dark: vec![&frames[4 * l + 2], &frames[4 * l + 3]],
        })
        .collect();
    c.bench_function("emva 12 levels 512x512", |b| {
        b.iter(|| emva(&levels, &EmvaOptions::default()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
