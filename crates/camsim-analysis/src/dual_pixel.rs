//! Dual-pixel disparity on an edge: how far a dual-pixel sensor's left-photodiode image of a
//! near-vertical edge lies from its right-photodiode image, the quantity a phase-detection
//! autofocus turns into a focus error.
//!
//! Each photodiode sees one half of the pupil, so a defocused edge's line spread function in each
//! image is the defocus blur of a half disc projected on x, displaced from the whole pupil's by
//! the half disc's centroid, 4 r / (3 pi) for a blur circle of radius r (thin lens, the PSF
//! centroid is the mean ray intercept over the open pupil). The two images are therefore
//! `d = 8 r / (3 pi) = 4 c / (3 pi)` apart (c the circle of confusion's diameter), with opposite
//! signs on either side of focus.
//!
//! Method: rows are taken in blocks (8 by default); in each block the mean row profile of each
//! image is differentiated into a line spread function along x, oriented by the edge's step, and
//! its centroid taken over a window around the edge (where the two images' summed line spread
//! function is above 2 % of its peak, widened by half its width on each side, the same window for
//! both). The disparity is the mean over the blocks of the left centroid minus the right one, its
//! standard error their spread over sqrt(blocks). Within a block a slanted edge moves little;
//! an edge more than 45 degrees from vertical is refused (the halves split along x, so a
//! horizontal edge has no disparity to measure).

use crate::error::{AnalysisError, Result};
use crate::image::{Plane, Rect};
use serde::Serialize;

/// Options of [`edge_disparity`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisparityOptions {
    /// The region holding the edge (default: the whole plane).
    pub roi: Option<Rect>,
    /// Rows per block (>= 1; default 8).
    pub block_rows: usize,
}

impl Default for DisparityOptions {
    fn default() -> Self {
        DisparityOptions {
            roi: None,
            block_rows: 8,
        }
    }
}

/// The disparity between a dual-pixel sensor's two images of an edge.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EdgeDisparity {
    /// The left image's edge position minus the right one's, pixels of the plane (positive: the
    /// left image lies further right).
    pub disparity_px: f64,
    /// Standard error of the disparity over the blocks, pixels (0 with one block).
    pub standard_error_px: f64,
    /// The edge's mean position (the summed images' line spread centroid), plane column in pixel
    /// edges (column c covers [c, c + 1)).
    pub edge_col: f64,
    /// Blocks of rows measured.
    pub blocks: usize,
    /// The centroid window, plane columns `[first, last]` in pixel edges.
    pub window: [usize; 2],
    /// The edge's slope, columns per row (0 for a vertical edge).
    pub slope_px_per_row: f64,
}

/// The disparity between `left` and `right` (a dual-pixel sensor's photodiode planes, signal
/// above black) of a near-vertical edge in `opts.roi` (see the module docs).
pub fn edge_disparity(
    left: &Plane,
    right: &Plane,
    opts: &DisparityOptions,
) -> Result<EdgeDisparity> {
    if (left.rows, left.cols) != (right.rows, right.cols) {
        return Err(AnalysisError::invalid(
            "dual-pixel planes",
            format!(
                "left is {} x {}, right {} x {}",
                left.cols, left.rows, right.cols, right.rows
            ),
        ));
    }
    let roi = opts.roi.unwrap_or(Rect {
        row: 0,
        col: 0,
        rows: left.rows,
        cols: left.cols,
    });
    if roi.rows == 0
        || roi.cols < 8
        || roi.row + roi.rows > left.rows
        || roi.col + roi.cols > left.cols
    {
        return Err(AnalysisError::invalid(
            "roi",
            format!(
                "{} x {} at ({}, {}) does not fit the {} x {} plane with at least 8 columns",
                roi.cols, roi.rows, roi.col, roi.row, left.cols, left.rows
            ),
        ));
    }
    if opts.block_rows == 0 {
        return Err(AnalysisError::invalid("block_rows", "must be at least 1"));
    }
    let n = roi.cols;
    // The mean row profile of rows [r0, r1) of a plane, and its derivative along x (n - 1 values;
    // value j sits on the edge between columns j and j + 1).
    let profile = |p: &Plane, r0: usize, r1: usize| -> Vec<f64> {
        let mut m = vec![0.0f64; n];
        for r in r0..r1 {
            let row = &p.data[(roi.row + r) * p.cols + roi.col..][..n];
            m.iter_mut().zip(row).for_each(|(a, &v)| *a += v as f64);
        }
        let k = (r1 - r0) as f64;
        m.windows(2).map(|w| (w[1] - w[0]) / k).collect()
    };
    let sum_lsf = |r0: usize, r1: usize| -> Vec<f64> {
        let (a, b) = (profile(left, r0, r1), profile(right, r0, r1));
        a.iter().zip(&b).map(|(x, y)| x + y).collect()
    };
    // The edge's direction (dark to bright or back) from the summed images' total step.
    let whole = sum_lsf(0, roi.rows);
    let step: f64 = whole.iter().sum();
    let sign = if step >= 0.0 { 1.0 } else { -1.0 };
    let lsf: Vec<f64> = whole.iter().map(|v| sign * v).collect();
    let (peak_j, peak) =
        lsf.iter().enumerate().fold(
            (0, f64::MIN),
            |(bj, bv), (j, &v)| if v > bv { (j, v) } else { (bj, bv) },
        );
    let mut abs_sorted: Vec<f64> = lsf.iter().map(|v| v.abs()).collect();
    abs_sorted.sort_by(|a, b| a.total_cmp(b));
    let median = abs_sorted[abs_sorted.len() / 2];
    if !(peak > 0.0 && peak > 5.0 * median) {
        return Err(AnalysisError::invalid(
            "dual-pixel edge",
            "no edge across the region: its mean row profile has no step that stands out of the noise (give --roi around a near-vertical edge)",
        ));
    }
    // The window: where the summed LSF stays above 2 % of its peak, widened by half its width.
    let floor = 0.02 * peak;
    let mut a = peak_j;
    while a > 0 && lsf[a - 1] > floor {
        a -= 1;
    }
    let mut b = peak_j;
    while b + 1 < lsf.len() && lsf[b + 1] > floor {
        b += 1;
    }
    let pad = (b - a) / 2 + 2;
    let (a, b) = (a.saturating_sub(pad), (b + pad).min(lsf.len() - 1));
    let centroid = |l: &[f64]| -> Option<f64> {
        let (mut s, mut sx) = (0.0, 0.0);
        for (j, v) in l.iter().enumerate().take(b + 1).skip(a) {
            let v = sign * v;
            s += v;
            // The derivative value j lies on the edge between columns j and j + 1 (pixel edge
            // coordinate j + 1).
            sx += v * (j as f64 + 1.0);
        }
        (s > 0.0).then(|| sx / s)
    };
    let mut d = Vec::new();
    let mut pos = Vec::new();
    let blocks = (roi.rows / opts.block_rows).max(1);
    for k in 0..blocks {
        let r0 = k * opts.block_rows;
        let r1 = if k + 1 == blocks {
            roi.rows
        } else {
            r0 + opts.block_rows
        };
        let (cl, cr, cs) = (
            centroid(&profile(left, r0, r1)),
            centroid(&profile(right, r0, r1)),
            centroid(&sum_lsf(r0, r1)),
        );
        if let (Some(cl), Some(cr), Some(cs)) = (cl, cr, cs) {
            d.push(cl - cr);
            pos.push((0.5 * (r0 + r1) as f64, cs));
        }
    }
    if d.is_empty() {
        return Err(AnalysisError::invalid(
            "dual-pixel edge",
            "no block of rows has the edge in both images",
        ));
    }
    let m = d.len() as f64;
    let mean = d.iter().sum::<f64>() / m;
    let se = if d.len() > 1 {
        (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1.0) / m).sqrt()
    } else {
        0.0
    };
    // The edge's slope: least squares of the blocks' positions on their rows.
    let (my, mx) = (
        pos.iter().map(|p| p.0).sum::<f64>() / m,
        pos.iter().map(|p| p.1).sum::<f64>() / m,
    );
    let syy: f64 = pos.iter().map(|p| (p.0 - my).powi(2)).sum();
    let sxy: f64 = pos.iter().map(|p| (p.0 - my) * (p.1 - mx)).sum();
    let slope = if syy > 0.0 { sxy / syy } else { 0.0 };
    if slope.abs() > 1.0 {
        return Err(AnalysisError::invalid(
            "dual-pixel edge",
            format!(
                "the edge runs {:.0} degrees from vertical; the photodiodes split along x, so measure on an edge within 45 degrees of vertical",
                slope.atan().to_degrees().abs()
            ),
        ));
    }
    Ok(EdgeDisparity {
        disparity_px: mean,
        standard_error_px: se,
        edge_col: roi.col as f64 + mx,
        blocks: d.len(),
        window: [roi.col + a + 1, roi.col + b + 1],
        slope_px_per_row: slope,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertical edge blurred by a box of width `w` px, at column `x0` (pixel edges), as a plane.
    fn edge(rows: usize, cols: usize, x0: f64, w: f64) -> Plane {
        let mut data = vec![0.0f32; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                // The pixel's mean of the blurred step: the box-blurred ramp integrated over the
                // pixel [c, c + 1) (a fine sum).
                let mut v = 0.0;
                for s in 0..64 {
                    let x = c as f64 + (s as f64 + 0.5) / 64.0;
                    v += ((x - x0) / w + 0.5).clamp(0.0, 1.0);
                }
                data[r * cols + c] = (100.0 * v / 64.0) as f32 + 10.0;
            }
        }
        Plane::new(rows, cols, data).unwrap()
    }

    #[test]
    fn two_shifted_edges_give_their_shift() {
        // Left edge at 30.4, right at 27.9: disparity 2.5 px, whatever the blur and direction.
        let (l, r) = (edge(32, 64, 30.4, 6.0), edge(32, 64, 27.9, 6.0));
        let d = edge_disparity(&l, &r, &DisparityOptions::default()).unwrap();
        assert!((d.disparity_px - 2.5).abs() < 1e-3, "{d:?}");
        assert!((d.edge_col - (30.4 + 27.9) / 2.0).abs() < 1e-3, "{d:?}");
        assert!(d.slope_px_per_row.abs() < 1e-9);
        // Bright to dark: the same disparity.
        let flip = |p: &Plane| {
            Plane::new(p.rows, p.cols, p.data.iter().map(|v| 120.0 - v).collect()).unwrap()
        };
        let d2 = edge_disparity(&flip(&l), &flip(&r), &DisparityOptions::default()).unwrap();
        assert!((d2.disparity_px - 2.5).abs() < 1e-3, "{d2:?}");
        // A flat field has no edge.
        let flat = Plane::new(32, 64, vec![5.0; 32 * 64]).unwrap();
        assert!(edge_disparity(&flat, &flat, &DisparityOptions::default()).is_err());
    }
}
