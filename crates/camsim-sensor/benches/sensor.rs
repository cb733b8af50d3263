//! The sensor stage at full IMX363 resolution (4032 x 3024 pixels) from a 31-band irradiance
//! image (1.44 GiB of f32), all noise sources on, auto-exposed. Target (issue 2): <= 0.5 s on a
//! 2-core machine, peak memory <= 1.5 x the irradiance image (measure that with
//! `/usr/bin/time -v target/release/examples/full_frame`).
//!
//!     cargo bench -p camsim-sensor --bench sensor
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_sensor::{Capture, Sensor};
use criterion::{criterion_group, criterion_main, Criterion};
use rayon::prelude::*;
use std::time::Duration;

/// A smooth, spatially varying irradiance (W/(m^2 nm)) at the pixel pitch (same as the example).
fn test_irradiance(sensor: &Sensor, grid: WavelengthGrid) -> SpectralImage {
    let (rows, cols) = (sensor.rows(), sensor.cols());
    let mut img = SpectralImage::zeros(
        rows,
        cols,
        grid,
        sensor.pixel_pitch_m(),
        Quantity::Irradiance,
    )
    .unwrap();
    let bands = grid.len();
    img.bands_mut()
        .enumerate()
        .collect::<Vec<_>>()
        .into_par_iter()
        .for_each(|(b, plane)| {
            let w = b as f32 / (bands - 1) as f32;
            for (r, row) in plane.chunks_mut(cols).enumerate() {
                let y = r as f32 / rows as f32;
                for (c, v) in row.iter_mut().enumerate() {
                    let x = c as f32 / cols as f32;
                    *v = 2e-3
                        * (0.2 + 0.8 * (x * w + y * (1.0 - w)))
                        * (1.0 + 0.1 * ((c ^ r) & 7) as f32 / 7.0);
                }
            }
        });
    img
}

fn bench_sensor(c: &mut Criterion) {
    let sensor = Sensor::preset("imx363").unwrap();
    let grid = WavelengthGrid::default();
    let img = test_irradiance(&sensor, grid);
    let mut g = c.benchmark_group("sensor");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(2));
    g.bench_function("imx363_4032x3024_31_bands_all_noise", |b| {
        let mut seed = 0;
        b.iter(|| {
            seed += 1;
            sensor
                .compute(&img, &Capture::auto().with_seed(seed))
                .unwrap()
        })
    });
    g.bench_function("irradiance_to_electrons_only", |b| {
        b.iter(|| sensor.electron_rate_image(&img).unwrap())
    });
    // The general area-integration path: irradiance sampled at 0.9 x the pitch (each pixel
    // straddles up to 2 x 2 samples), the same data re-labelled.
    let mut img = img;
    img.sample_spacing_m = 0.9 * sensor.pixel_pitch_m();
    g.bench_function("imx363_all_noise_irradiance_at_0.9_pitch", |b| {
        b.iter(|| sensor.compute(&img, &Capture::auto().with_seed(7)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench_sensor);
criterion_main!(benches);
