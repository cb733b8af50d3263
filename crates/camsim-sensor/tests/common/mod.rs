//! Helpers shared by the integration tests (independent of the crate's own integration code).
#![allow(dead_code)]

use camsim_core::{Quantity, RawImage, SpectralImage, WavelengthGrid};
use camsim_sensor::{NoiseSwitches, Sensor, SensorConfig};

/// Path of a file under the shared reference data folder.
pub fn shared(path: &str) -> String {
    format!(
        "{}/../../../shared/data/{}",
        env!("CARGO_MANIFEST_DIR"),
        path
    )
}

/// Read the numeric rows of a CSV file (lines starting with a digit).
pub fn read_csv(path: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(shared(path)).unwrap_or_else(|e| panic!("{path}: {e}"));
    text.lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().unwrap())
                .collect()
        })
        .collect()
}

/// A config derived from a preset with changes applied.
pub fn config(preset: &str, f: impl FnOnce(&mut SensorConfig)) -> Sensor {
    let mut c = Sensor::preset(preset).unwrap().config().clone();
    f(&mut c);
    Sensor::from_config(c).unwrap()
}

/// A uniform irradiance image (W/(m^2 nm)) of rows x cols at `spacing_m`.
pub fn uniform_image(
    rows: usize,
    cols: usize,
    grid: WavelengthGrid,
    spacing_m: f64,
    spectrum: &[f64],
) -> SpectralImage {
    let mut img = SpectralImage::zeros(rows, cols, grid, spacing_m, Quantity::Irradiance).unwrap();
    for (b, plane) in img.bands_mut().enumerate() {
        plane.iter_mut().for_each(|v| *v = spectrum[b] as f32);
    }
    img
}

/// Noise switches with everything off (quantization kept unless `analog`).
pub fn quiet(analog: bool) -> NoiseSwitches {
    let mut n = NoiseSwitches::none();
    n.quantization = !analog;
    n
}

/// Indices of the pixels of channel `c` in a raw frame.
pub fn channel_pixels(raw: &RawImage, c: usize) -> Vec<usize> {
    (0..raw.rows)
        .flat_map(|r| (0..raw.cols).map(move |col| (r, col)))
        .filter(|(r, col)| raw.cfa.channel_at(*r, *col).index() == c)
        .map(|(r, col)| r * raw.cols + col)
        .collect()
}

/// Per-pixel temporal mean and unbiased variance over a stack of frames.
pub fn stack_stats(frames: &[RawImage]) -> (Vec<f64>, Vec<f64>) {
    let n = frames.len() as f64;
    let p = frames[0].dn.len();
    let mut mean = vec![0.0; p];
    let mut var = vec![0.0; p];
    for f in frames {
        for (m, v) in mean.iter_mut().zip(&f.dn) {
            *m += *v as f64 / n;
        }
    }
    for f in frames {
        for ((s, m), v) in var.iter_mut().zip(&mean).zip(&f.dn) {
            let d = *v as f64 - m;
            *s += d * d / (n - 1.0);
        }
    }
    (mean, var)
}

/// Mean and (unbiased) variance of the values at `idx`.
pub fn mean_var(values: &[f64], idx: &[usize]) -> (f64, f64) {
    let n = idx.len() as f64;
    let m = idx.iter().map(|i| values[*i]).sum::<f64>() / n;
    let v = idx.iter().map(|i| (values[*i] - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, v)
}
