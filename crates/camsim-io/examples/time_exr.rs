//! Spectral EXR write speed: a 4032 x 3024 x 31 f32 image (1.51 GB of samples) written with each
//! compression and precision; MB/s of f32 sample data (bands x pixels x 4 bytes) per second.
//!
//! cargo run --release -p camsim-io --example time_exr -- [DIR]   (DIR on the disk to measure)
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_io::exr::{write_spectral_exr_with, ExrCompression, ExrOptions, ExrPrecision};
use std::time::Instant;

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| std::env::temp_dir().display().to_string());
    let (rows, cols) = (3024usize, 4032usize);
    let grid = WavelengthGrid::default();
    // A smooth irradiance-like image with a little pseudo-random texture (as rendered scenes have).
    let mut data = vec![0.0f32; rows * cols * grid.len()];
    data.chunks_mut(rows * cols)
        .enumerate()
        .for_each(|(b, band)| {
            for (i, v) in band.iter_mut().enumerate() {
                let (r, c) = (i / cols, i % cols);
                let h = ((i as u64).wrapping_mul(0x9E3779B97F4A7C15) >> 40) as f32
                    / (1u64 << 24) as f32;
                *v = 1e-3
                    * (0.2 + 0.5 * ((r / 500 + c / 600) % 4) as f32 / 4.0 + 0.02 * h)
                    * (1.0 + b as f32 / 31.0);
            }
        });
    let img =
        SpectralImage::from_data(rows, cols, grid, 1.4e-6, Quantity::Irradiance, data).unwrap();
    let mb = (rows * cols * grid.len() * 4) as f64 / 1e6;
    let threads = rayon::current_num_threads();
    for (precision, compression) in [
        (ExrPrecision::F32, ExrCompression::None),
        (ExrPrecision::F16, ExrCompression::None),
        (ExrPrecision::F32, ExrCompression::Rle),
        (ExrPrecision::F32, ExrCompression::Zip),
        (ExrPrecision::F16, ExrCompression::Zip),
        (ExrPrecision::F32, ExrCompression::Piz),
    ] {
        let path = std::path::Path::new(&dir).join("camsim-time-exr.exr");
        let t = Instant::now();
        write_spectral_exr_with(
            &path,
            &img,
            "optics",
            ExrOptions {
                precision,
                compression,
            },
        )
        .unwrap();
        let s = t.elapsed().as_secs_f64();
        let size = std::fs::metadata(&path).unwrap().len() as f64 / 1e6;
        std::fs::remove_file(&path).unwrap();
        println!("{precision:?} {compression:?}: {s:.2} s, {:.0} MB/s of f32 samples ({mb:.0} MB), file {size:.0} MB, {threads} threads", mb / s);
    }
}
