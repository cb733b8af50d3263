//! The sensor stage at full IMX363 resolution (4032 x 3024) from a 31-band irradiance image, all
//! noise on, auto-exposed; prints the time of `Sensor::compute` and the irradiance size, so that
//! `/usr/bin/time -v` gives the peak memory relative to the irradiance image:
//!
//!     cargo run --release -p camsim-sensor --example full_frame
//!     /usr/bin/time -v target/release/examples/full_frame
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_sensor::{Capture, Sensor};
use rayon::prelude::*;
use std::time::Instant;

/// A smooth, spatially varying irradiance (W/(m^2 nm)) at the pixel pitch: a colour ramp with a
/// fine ripple, so that every band and pixel differ.
pub fn test_irradiance(sensor: &Sensor, grid: WavelengthGrid) -> SpectralImage {
    let (rows, cols) = (sensor.rows(), sensor.cols());
    // SPACING=0.9 samples the irradiance at 0.9 x the pitch (the general area-integration path).
    let ratio: f64 = std::env::var("SPACING")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let mut img = SpectralImage::zeros(
        rows,
        cols,
        grid,
        sensor.pixel_pitch_m() * ratio,
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

/// CPU time (user + system) of this process so far, s.
fn cpu_s() -> f64 {
    let (user, system) = camsim_core::mem::process_cpu_s();
    user + system
}

fn main() {
    let sensor = Sensor::preset("imx363").unwrap();
    let grid = WavelengthGrid::default();
    let img = test_irradiance(&sensor, grid);
    let bytes = img.data.len() * 4;
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let mut best = f64::INFINITY;
    let mut best_cpu = f64::INFINITY;
    for i in 0..reps {
        let (t0, c0) = (Instant::now(), cpu_s());
        let frame = sensor
            .compute(&img, &Capture::auto().with_seed(i as u64))
            .unwrap();
        let dt = t0.elapsed().as_secs_f64();
        best = best.min(dt);
        let mean =
            frame.raw[0].dn.iter().map(|v| *v as f64).sum::<f64>() / frame.raw[0].dn.len() as f64;
        let cpu = cpu_s() - c0;
        best_cpu = best_cpu.min(cpu);
        println!(
            "run {i}: {dt:.3} s wall, {cpu:.2} s CPU (exposure {:.4} s, mean {mean:.1} DN)",
            frame.exposure_s
        );
    }
    let (t0, c0) = (Instant::now(), cpu_s());
    let rate = sensor.electron_rate_image(&img).unwrap();
    println!(
        "of which irradiance -> electron rate: {:.3} s wall, {:.2} s CPU ({} pixels)",
        t0.elapsed().as_secs_f64(),
        cpu_s() - c0,
        rate.len()
    );
    println!(
        "irradiance {} x {} x {} bands = {:.1} MiB; best {:.3} s wall, best {:.2} s CPU on {} threads",
        img.rows,
        img.cols,
        grid.len(),
        bytes as f64 / (1 << 20) as f64,
        best,
        best_cpu,
        rayon::current_num_threads()
    );
}
