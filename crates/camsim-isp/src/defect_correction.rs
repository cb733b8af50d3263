//! Defect correction on the raw mosaic: hot, dead and stuck pixels replaced by the median of
//! their same-filter neighbours in the 5 x 5 window around them (the usual ISP defect-pixel
//! correction; e.g. Chan, "Dead pixel correction techniques for digital still cameras", ICIP
//! 2004 [median of same-colour neighbours]). The pixels come from a defect list (the sensor's
//! calibration map, `camsim_sensor::Sensor::defect_list`) or from a detection: a pixel whose
//! value deviates from that median by more than k robust sigmas, sigma = 1.4826 x the median
//! absolute deviation of those residuals over all pixels of its filter (the MAD's consistency
//! factor for a normal, Hampel 1974).
//!
//! Any CFA tile works: "same filter" is the tile's filter index at each site. For a Bayer R or B
//! site the 5 x 5 window holds 8 same-filter neighbours, for G 12; flagged neighbours (another
//! defect, the other pixel of a pair) are left out of the median.

use camsim_core::error::{CoreError, Result};
use camsim_core::RawImage;
use rayon::prelude::*;

/// Where the ISP's defect correction takes its pixels from.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum DefectCorrection {
    /// No defect correction (the default).
    #[default]
    Off,
    /// The sensor's defect list (its calibration map of hot, dead and stuck pixels).
    Sensor,
    /// Detected in the frame: deviating from the same-filter median by more than the threshold.
    Detect,
}

impl DefectCorrection {
    /// The name the configs take.
    pub fn name(self) -> &'static str {
        match self {
            DefectCorrection::Off => "off",
            DefectCorrection::Sensor => "sensor",
            DefectCorrection::Detect => "detect",
        }
    }
}

/// Default detection threshold, robust sigmas of the same-filter median residual: at 6 a
/// normal residual is flagged with probability 2e-9 (about none in a 12 Mpx frame), while a hot
/// pixel 10 sigma above the floor is caught.
pub const DEFECT_DETECTION_SIGMAS: f64 = 6.0;

/// Consistency factor of the median absolute deviation for a normal: sigma = 1.4826 MAD
/// (1 / Phi^-1(3/4)).
const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Half-width of the neighbourhood window, pixels (5 x 5).
const WINDOW_RADIUS_PX: usize = 2;

/// Median of the same-filter neighbours of (r, c) in the 5 x 5 window, leaving out the pixels
/// `skip` flags (`None`: none). `None` when no neighbour is left.
fn neighbour_median(
    raw: &RawImage,
    filter: &impl Fn(usize, usize) -> usize,
    skip: Option<&[bool]>,
    r: usize,
    c: usize,
    buf: &mut Vec<u16>,
) -> Option<f64> {
    buf.clear();
    let f = filter(r, c);
    let (r0, r1) = (
        r.saturating_sub(WINDOW_RADIUS_PX),
        (r + WINDOW_RADIUS_PX + 1).min(raw.rows),
    );
    let (c0, c1) = (
        c.saturating_sub(WINDOW_RADIUS_PX),
        (c + WINDOW_RADIUS_PX + 1).min(raw.cols),
    );
    for rr in r0..r1 {
        for cc in c0..c1 {
            if (rr, cc) == (r, c) || filter(rr, cc) != f {
                continue;
            }
            let i = rr * raw.cols + cc;
            if skip.is_some_and(|s| s[i]) {
                continue;
            }
            buf.push(raw.dn[i]);
        }
    }
    if buf.is_empty() {
        return None;
    }
    buf.sort_unstable();
    let n = buf.len();
    Some(if n % 2 == 1 {
        buf[n / 2] as f64
    } else {
        0.5 * (buf[n / 2 - 1] as f64 + buf[n / 2] as f64)
    })
}

/// The filter index at each site of `raw`'s CFA tile.
fn filter_fn(raw: &RawImage) -> impl Fn(usize, usize) -> usize {
    let layout = raw.cfa_layout();
    move |r, c| layout.filter_at(r, c)
}

fn check(raw: &RawImage, what: &str) -> Result<()> {
    if raw.dn.len() != raw.rows * raw.cols || raw.rows == 0 || raw.cols == 0 {
        return Err(CoreError::invalid(
            what,
            format!(
                "{} values for {} x {} pixels",
                raw.dn.len(),
                raw.rows,
                raw.cols
            ),
        ));
    }
    Ok(())
}

/// `raw` with each pixel of `pixels` ((row, column), stored orientation) replaced by the
/// median of its same-filter neighbours in the 5 x 5 window, other listed pixels left out of
/// the medians (rounded to the nearest DN). Errors on a pixel outside the frame.
pub fn correct_defects(raw: &RawImage, pixels: &[(usize, usize)]) -> Result<RawImage> {
    check(raw, "defect correction")?;
    let mut flagged = vec![false; raw.dn.len()];
    for &(r, c) in pixels {
        if r >= raw.rows || c >= raw.cols {
            return Err(CoreError::invalid(
                "defect correction",
                format!(
                    "defect at row {r}, column {c} lies outside the {} x {} frame",
                    raw.rows, raw.cols
                ),
            ));
        }
        flagged[r * raw.cols + c] = true;
    }
    Ok(replace_flagged(raw, &flagged))
}

/// Replace each flagged pixel by its neighbours' median (left as it is where it has no
/// unflagged same-filter neighbour).
fn replace_flagged(raw: &RawImage, flagged: &[bool]) -> RawImage {
    let filter = filter_fn(raw);
    let mut out = raw.clone();
    let cols = raw.cols;
    out.dn
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(r, line)| {
            let mut buf = Vec::with_capacity(24);
            for (c, v) in line.iter_mut().enumerate() {
                if !flagged[r * cols + c] {
                    continue;
                }
                if let Some(m) = neighbour_median(raw, &filter, Some(flagged), r, c, &mut buf) {
                    *v = m.round() as u16;
                }
            }
        });
    out
}

/// The pixels of `raw` whose value deviates from the median of their same-filter 5 x 5
/// neighbours by more than `k_sigmas` robust sigmas of that residual (per filter: 1.4826 x the
/// median absolute residual over the filter's pixels), sorted by row then column. A filter
/// whose robust sigma is 0 (a noise-free frame) takes 0.5 DN (half a code), so only pixels off by
/// more than k / 2 DN are flagged. Errors on `k_sigmas` not positive.
pub fn detect_defects(raw: &RawImage, k_sigmas: f64) -> Result<Vec<(usize, usize)>> {
    check(raw, "defect detection")?;
    if !(k_sigmas > 0.0) || !k_sigmas.is_finite() {
        return Err(CoreError::invalid(
            "defect detection",
            format!("threshold {k_sigmas} sigmas: must be positive"),
        ));
    }
    let filter = filter_fn(raw);
    let cols = raw.cols;
    let mut residual = vec![0f32; raw.dn.len()];
    residual
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(r, line)| {
            let mut buf = Vec::with_capacity(24);
            for (c, o) in line.iter_mut().enumerate() {
                *o = neighbour_median(raw, &filter, None, r, c, &mut buf)
                    .map_or(0.0, |m| (raw.dn[r * cols + c] as f64 - m) as f32);
            }
        });
    let n_filters = raw.cfa_layout().filters().len().max(1);
    let sigma: Vec<f64> = (0..n_filters)
        .map(|f| {
            let mut a: Vec<f32> = residual
                .iter()
                .enumerate()
                .filter(|(i, _)| filter(i / cols, i % cols) == f)
                .map(|(_, v)| v.abs())
                .collect();
            if a.is_empty() {
                return 0.5;
            }
            let k = a.len() / 2;
            let (_, mad, _) = a.select_nth_unstable_by(k, |x, y| x.total_cmp(y));
            let s = MAD_TO_SIGMA * *mad as f64;
            if s > 0.0 {
                s
            } else {
                0.5
            }
        })
        .collect();
    Ok(residual
        .iter()
        .enumerate()
        .filter(|(i, v)| (v.abs() as f64) > k_sigmas * sigma[filter(i / cols, i % cols)])
        .map(|(i, _)| (i / cols, i % cols))
        .collect())
}

/// Detect ([`detect_defects`]) and correct ([`correct_defects`]) in one pass; returns the
/// corrected frame and the pixels it replaced.
pub fn detect_and_correct(
    raw: &RawImage,
    k_sigmas: f64,
) -> Result<(RawImage, Vec<(usize, usize)>)> {
    let found = detect_defects(raw, k_sigmas)?;
    Ok((correct_defects(raw, &found)?, found))
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::rng::{keyed, stage};
    use camsim_core::CfaPattern;
    use rand_distr::{Distribution, StandardNormal};

    /// A flat Bayer field at `level_dn` with read noise `sigma_dn` (seeded).
    fn flat(rows: usize, cols: usize, level_dn: f64, sigma_dn: f64) -> RawImage {
        let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 12).unwrap();
        for r in 0..rows {
            let mut rng = keyed(7, stage::ANALYSIS, 0, r as u64);
            for c in 0..cols {
                let z: f64 = StandardNormal.sample(&mut rng);
                raw.dn[r * cols + c] = (level_dn + sigma_dn * z).round() as u16;
            }
        }
        raw
    }

    /// Hot (+800 DN), dead (0) and stuck (4095) pixels, with a hot pair (two horizontal
    /// neighbours, different filters) and a same-filter pair two columns apart.
    fn inject(raw: &mut RawImage) -> Vec<(usize, usize)> {
        let bad = vec![
            (5, 5),
            (10, 20),
            (10, 21),
            (17, 30),
            (17, 32),
            (25, 8),
            (30, 40),
            (0, 0),
            (47, 63),
        ];
        for (k, &(r, c)) in bad.iter().enumerate() {
            let v = &mut raw.dn[r * raw.cols + c];
            *v = match k % 3 {
                0 => *v + 800,
                1 => 0,
                _ => 4095,
            };
        }
        bad
    }

    #[test]
    fn listed_and_detected_defects_come_back_within_noise() {
        let (level, sigma) = (1000.0, 10.0);
        let clean = flat(48, 64, level, sigma);
        let mut raw = clean.clone();
        let bad = inject(&mut raw);
        // The median of n >= 8 normal neighbours has sigma about 1.2533 sigma / sqrt(n) (the
        // median's asymptotic efficiency, pi / 2 in variance): 4 sigma of one pixel bounds it
        // with margin even at the corner (3 neighbours).
        let bound = 4.0 * sigma;
        let fixed = correct_defects(&raw, &bad).unwrap();
        for &(r, c) in &bad {
            let v = fixed.dn[r * 64 + c] as f64;
            assert!((v - level).abs() < bound, "listed ({r}, {c}): {v}");
        }
        // Pixels not listed are untouched.
        let changed = (0..raw.dn.len())
            .filter(|&i| fixed.dn[i] != raw.dn[i])
            .count();
        assert!(changed <= bad.len());
        let (found_fixed, found) = detect_and_correct(&raw, DEFECT_DETECTION_SIGMAS).unwrap();
        let mut want = bad.clone();
        want.sort();
        assert_eq!(found, want, "detection at {DEFECT_DETECTION_SIGMAS} sigma");
        for &(r, c) in &bad {
            let v = found_fixed.dn[r * 64 + c] as f64;
            assert!((v - level).abs() < bound, "detected ({r}, {c}): {v}");
        }
        // The clean field has no detections at 6 sigma (P = 2e-9 per pixel).
        assert!(detect_defects(&clean, DEFECT_DETECTION_SIGMAS)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn bad_input_is_an_error() {
        let raw = flat(8, 8, 100.0, 1.0);
        assert!(correct_defects(&raw, &[(8, 0)]).is_err());
        assert!(detect_defects(&raw, 0.0).is_err());
        assert!(detect_defects(&raw, f64::NAN).is_err());
    }
}
