//! sRGB previews of spectral images (scene radiance, sensor irradiance): what a person would see.

use camsim_core::colorimetry::{srgb_encode_u8, Cmfs, XYZ_TO_LINEAR_SRGB};
use camsim_core::SpectralImage;
use rayon::prelude::*;

/// An 8-bit sRGB rendering (interleaved RGB, row-major) of a spectral image: CIE 1931 XYZ from
/// the colour-matching functions (energy weighting, as for radiance), XYZ -> linear sRGB
/// (IEC 61966-2-1, D65 white, so an equal-energy-ish scene keeps its colour cast), scaled so the
/// 99th percentile of Y maps to 0.9, then the sRGB transfer function.
pub fn radiance_srgb8(img: &SpectralImage) -> Vec<u8> {
    let cmfs = Cmfs::on(&img.grid);
    let n = img.pixels();
    let mut xyz = vec![[0f32; 3]; n];
    for b in 0..img.bands() {
        let w = [cmfs.x[b] as f32, cmfs.y[b] as f32, cmfs.z[b] as f32];
        xyz.par_iter_mut()
            .zip(img.band(b).par_iter())
            .for_each(|(o, v)| {
                o[0] += w[0] * v;
                o[1] += w[1] * v;
                o[2] += w[2] * v;
            });
    }
    let mut ys: Vec<f32> = xyz.iter().map(|p| p[1]).filter(|y| y.is_finite()).collect();
    let scale = if ys.is_empty() {
        1.0
    } else {
        let k = ((ys.len() - 1) as f64 * 0.99) as usize;
        let (_, p99, _) = ys.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        if *p99 > 0.0 {
            0.9 / *p99 as f64
        } else {
            1.0
        }
    };
    let m = XYZ_TO_LINEAR_SRGB;
    let mut out = vec![0u8; n * 3];
    out.par_chunks_exact_mut(3)
        .zip(xyz.par_iter())
        .for_each(|(o, p)| {
            let v = [
                p[0] as f64 * scale,
                p[1] as f64 * scale,
                p[2] as f64 * scale,
            ];
            for (c, oc) in o.iter_mut().enumerate() {
                let lin = m[c][0] * v[0] + m[c][1] * v[1] + m[c][2] * v[2];
                *oc = srgb_encode_u8(lin);
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::{tables, Quantity, WavelengthGrid};

    #[test]
    fn d65_white_is_neutral_and_a_is_warm() {
        // A D65 radiance renders R = G = B (the sRGB white point is D65); illuminant A renders R > B.
        let grid = WavelengthGrid::default();
        for (name, neutral) in [("D65", true), ("A", false)] {
            let s = tables::illuminant(name).unwrap().sample(&grid);
            let mut img = SpectralImage::zeros(4, 4, grid, 1e-3, Quantity::Radiance).unwrap();
            for (b, v) in s.iter().enumerate() {
                img.band_mut(b).iter_mut().for_each(|x| *x = *v as f32);
            }
            let px = radiance_srgb8(&img);
            let (r, g, b) = (px[0] as i32, px[1] as i32, px[2] as i32);
            if neutral {
                assert!(
                    (r - g).abs() <= 2 && (b - g).abs() <= 2,
                    "D65 -> {r} {g} {b}"
                );
            } else {
                assert!(r > g && g > b, "A -> {r} {g} {b}");
            }
        }
    }
}
