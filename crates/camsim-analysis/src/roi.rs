//! Mean and standard deviation per colour channel in rectangles, on raw mosaics (each CFA
//! channel's own pixels) and on demosaicked RGB planes, and the region-by-region comparison of a
//! simulated and a measured image with the noise a sensor model predicts (paper, Figure 6).

use crate::error::{AnalysisError, Result};
use crate::image::{check_rgb, Moments, Plane, Rect};
use camsim_core::RawImage;
use serde::{Deserialize, Serialize};

/// Statistics of one rectangle, per channel (index 0, 1, 2 = R, G, B).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionStats {
    /// The rectangle, pixels.
    pub rect: Rect,
    /// Mean per channel, DN above black (raw) or the planes' unit.
    pub mean_dn: [f64; 3],
    /// Sample standard deviation (n - 1) per channel, same unit.
    pub std_dn: [f64; 3],
    /// Number of pixels per channel.
    pub n: [usize; 3],
}

impl RegionStats {
    fn from_moments(rect: Rect, m: &[Moments; 3]) -> RegionStats {
        RegionStats {
            rect,
            mean_dn: m.map(|v| v.mean()),
            std_dn: m.map(|v| v.std()),
            n: m.map(|v| v.n),
        }
    }
}

/// Moments of each CFA channel's pixels (black subtracted) inside `rect` (both greens pooled).
pub fn raw_rect_moments(raw: &RawImage, rect: &Rect) -> Result<[Moments; 3]> {
    crate::image::check_bayer_raw(raw)?;
    rect.check_inside(raw.rows, raw.cols, "raw region")?;
    let mut m = [Moments::default(); 3];
    for r in rect.row..rect.row_end() {
        let line = &raw.dn[r * raw.cols..(r + 1) * raw.cols];
        for (c, v) in line.iter().enumerate().take(rect.col_end()).skip(rect.col) {
            m[raw.cfa.channel_at(r, c).index()].push(*v as f64 - raw.black_level_dn);
        }
    }
    Ok(m)
}

/// Moments of three planes inside `rect`.
pub fn rgb_rect_moments(planes: &[Plane; 3], rect: &Rect) -> Result<[Moments; 3]> {
    check_rgb(planes)?;
    rect.check_inside(planes[0].rows, planes[0].cols, "rgb region")?;
    let mut m = [Moments::default(); 3];
    for (k, p) in planes.iter().enumerate() {
        for r in rect.row..rect.row_end() {
            for v in &p.row(r)[rect.col..rect.col_end()] {
                m[k].push(*v as f64);
            }
        }
    }
    Ok(m)
}

/// Mean and standard deviation per CFA channel of a raw mosaic in each rectangle.
pub fn roi_stats_raw(raw: &RawImage, rects: &[Rect]) -> Result<Vec<RegionStats>> {
    rects
        .iter()
        .map(|r| Ok(RegionStats::from_moments(*r, &raw_rect_moments(raw, r)?)))
        .collect()
}

/// Mean and standard deviation per plane of a demosaicked RGB image in each rectangle.
pub fn roi_stats_rgb(planes: &[Plane; 3], rects: &[Rect]) -> Result<Vec<RegionStats>> {
    rects
        .iter()
        .map(|r| Ok(RegionStats::from_moments(*r, &rgb_rect_moments(planes, r)?)))
        .collect()
}

/// One region measured in two images (a: simulated, b: measured), with the standard deviation
/// a noise model predicts at each image's mean level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionPair {
    /// Statistics in image a.
    pub a: RegionStats,
    /// Statistics in image b.
    pub b: RegionStats,
    /// b's mean minus a's mean, per channel.
    pub mean_difference_dn: [f64; 3],
    /// b's std minus a's std, per channel.
    pub std_difference_dn: [f64; 3],
    /// The model's standard deviation at a's mean levels (after [`add_predicted_std`]).
    pub predicted_std_dn_a: Option<[f64; 3]>,
    /// The model's standard deviation at b's mean levels.
    pub predicted_std_dn_b: Option<[f64; 3]>,
}

fn pair(a: RegionStats, b: RegionStats) -> RegionPair {
    let md = [0, 1, 2].map(|c| b.mean_dn[c] - a.mean_dn[c]);
    let sd = [0, 1, 2].map(|c| b.std_dn[c] - a.std_dn[c]);
    RegionPair {
        a,
        b,
        mean_difference_dn: md,
        std_difference_dn: sd,
        predicted_std_dn_a: None,
        predicted_std_dn_b: None,
    }
}

/// Compare two raw mosaics region by region: `regions[k] = (rect in a, rect in b)` (the regions
/// may differ between the images, as the paper picks corresponding regions by hand).
pub fn compare_regions_raw(
    a: &RawImage,
    b: &RawImage,
    regions: &[(Rect, Rect)],
) -> Result<Vec<RegionPair>> {
    regions
        .iter()
        .map(|(ra, rb)| {
            Ok(pair(
                RegionStats::from_moments(*ra, &raw_rect_moments(a, ra)?),
                RegionStats::from_moments(*rb, &raw_rect_moments(b, rb)?),
            ))
        })
        .collect()
}

/// [`compare_regions_raw`] for demosaicked RGB planes.
pub fn compare_regions_rgb(
    a: &[Plane; 3],
    b: &[Plane; 3],
    regions: &[(Rect, Rect)],
) -> Result<Vec<RegionPair>> {
    regions
        .iter()
        .map(|(ra, rb)| {
            Ok(pair(
                RegionStats::from_moments(*ra, &rgb_rect_moments(a, ra)?),
                RegionStats::from_moments(*rb, &rgb_rect_moments(b, rb)?),
            ))
        })
        .collect()
}

/// Fill in the noise a sensor model predicts, `model(mean_dn) -> std_dn`, at each region's mean
/// in each image. Errors if the model returns a negative or non-finite value.
pub fn add_predicted_std(pairs: &mut [RegionPair], model: impl Fn(f64) -> f64) -> Result<()> {
    let eval = |m: &[f64; 3]| -> Result<[f64; 3]> {
        let mut o = [0.0; 3];
        for c in 0..3 {
            o[c] = model(m[c]);
            if !(o[c] >= 0.0 && o[c].is_finite()) {
                return Err(AnalysisError::invalid(
                    "noise model",
                    format!("predicted std {} at mean {} DN", o[c], m[c]),
                ));
            }
        }
        Ok(o)
    };
    for p in pairs.iter_mut() {
        p.predicted_std_dn_a = Some(eval(&p.a.mean_dn)?);
        p.predicted_std_dn_b = Some(eval(&p.b.mean_dn)?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::rng::{keyed, stage};
    use camsim_core::CfaPattern;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn a_non_bayer_frame_is_refused_by_the_region_statistics() {
        let mut raw = RawImage::new(4, 4, CfaPattern::Rggb, 12).unwrap();
        raw.layout = Some(camsim_core::cfa::CfaLayout::parse("RGBW").unwrap());
        let e = raw_rect_moments(&raw, &Rect::new(0, 0, 2, 2))
            .unwrap_err()
            .to_string();
        assert!(e.contains("Bayer"), "{e}");
    }

    fn noisy_raw(seed: u64, level: [f64; 3], sigma: [f64; 3]) -> RawImage {
        let (rows, cols) = (64, 80);
        let mut raw = RawImage::new(rows, cols, CfaPattern::Grbg, 12).unwrap();
        raw.black_level_dn = 64.0;
        for r in 0..rows {
            let mut rng = keyed(seed, stage::ANALYSIS, 0, r as u64);
            for c in 0..cols {
                let ch = raw.channel_at(r, c).index();
                let v = 64.0 + level[ch] + Normal::new(0.0, sigma[ch]).unwrap().sample(&mut rng);
                raw.dn[r * cols + c] = v.round().clamp(0.0, 4095.0) as u16;
            }
        }
        raw
    }

    #[test]
    fn channel_statistics_match_the_generating_noise_within_sampling_error() {
        // Gaussian noise of known sigma (rounded to integers: + 1/12 DN^2 of quantisation noise).
        let level = [500.0, 1200.0, 300.0];
        let sigma = [10.0, 20.0, 6.0];
        let a = noisy_raw(1, level, sigma);
        let b = noisy_raw(2, level, sigma);
        let rect = Rect::new(4, 6, 50, 60); // 3000 pixels: 750 R, 1500 G, 750 B
        let mut pairs = compare_regions_raw(&a, &b, &[(rect, rect)]).unwrap();
        let s = &pairs[0].a;
        assert_eq!(s.n, [750, 1500, 750]);
        for c in 0..3 {
            let sd = (sigma[c] * sigma[c] + 1.0 / 12.0).sqrt();
            let n = s.n[c] as f64;
            // 4 standard errors: mean sd/sqrt(n), std sd/sqrt(2 n).
            assert!(
                (s.mean_dn[c] - level[c]).abs() < 4.0 * sd / n.sqrt(),
                "mean {c}: {}",
                s.mean_dn[c]
            );
            assert!(
                (s.std_dn[c] - sd).abs() < 4.0 * sd / (2.0 * n).sqrt(),
                "std {c}: {}",
                s.std_dn[c]
            );
        }
        // A model that returns the generating sigma for each level.
        add_predicted_std(&mut pairs, |m| {
            if m > 1000.0 {
                20.0
            } else if m > 400.0 {
                10.0
            } else {
                6.0
            }
        })
        .unwrap();
        assert_eq!(pairs[0].predicted_std_dn_a, Some(sigma));
        assert!(add_predicted_std(&mut pairs, |_| f64::NAN).is_err());
        assert!(roi_stats_raw(&a, &[Rect::new(60, 0, 10, 10)]).is_err());
    }

    #[test]
    fn constant_regions_have_exact_means_and_zero_std() {
        let p = [
            Plane::from_fn(10, 10, |_, _| 3.0).unwrap(),
            Plane::from_fn(10, 10, |_, _| 4.5).unwrap(),
            Plane::from_fn(10, 10, |r, _| r as f32).unwrap(),
        ];
        let s = roi_stats_rgb(&p, &[Rect::new(2, 2, 4, 3)]).unwrap();
        assert_eq!(s[0].mean_dn, [3.0, 4.5, 3.5]);
        assert_eq!(s[0].std_dn[0], 0.0);
        // Rows 2..6: values 2,3,4,5 each 3 times: sample variance = 15/11.
        assert!((s[0].std_dn[2] - (15.0f64 / 11.0).sqrt()).abs() < 1e-12);
        let q =
            compare_regions_rgb(&p, &p, &[(Rect::new(0, 0, 2, 2), Rect::new(5, 5, 2, 2))]).unwrap();
        assert_eq!(q[0].mean_difference_dn[0], 0.0);
        assert_eq!(q[0].mean_difference_dn[2], 5.0);
    }
}
