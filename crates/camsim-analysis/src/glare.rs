//! Veiling glare on an ISO 18844 target image: a black hole (light trap) in a bright surround.
//!
//! The veiling glare index is the signal in the hole's centre divided by the surround's signal,
//! both above black (ISO 18844:2017 defines flare as the light reaching the image of a black
//! target area, relative to the surround's). Without glare the hole's centre would be dark (a
//! light trap); every light it receives was spread there from the surround. For a glare spread
//! function g of total energy G, a hole of radius R at the centre of a uniform surround gives
//! the index G (fraction of g's energy beyond R that lands on the surround) / (surround level),
//! which `camsim-optics`'s `[glare]` makes G (r0^2 / (R^2 + r0^2))^(p - 1) for an unbounded
//! surround.
//!
//! The hole is found, unless given, as the 4-connected region below half the surround's level
//! (the median of the image: the surround fills most of it) that holds the start point (the
//! image centre by default); its centre is the region's centroid and its diameter that of the
//! disc of the region's area (the half-level contour is the hole's edge for a symmetric blur).
//! Coordinates are continuous pixels, x = column, y = row, pixel centres at +0.5.

use crate::error::{AnalysisError, Result};
use crate::image::Plane;
use serde::{Deserialize, Serialize};

/// What to measure: where the hole is and which regions average the two signals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GlareOptions {
    /// The hole's centre [x, y] in pixels (None: found from the image centre).
    pub centre_px: Option<[f64; 2]>,
    /// The hole's diameter in pixels (None: from the dark region's area).
    pub hole_diameter_px: Option<f64>,
    /// Diameter of the central disc averaged in the hole, as a fraction of the hole diameter,
    /// (0, 1) (default 0.2: the signal at the centre, where the glare is least).
    pub roi_fraction: f64,
    /// The surround annulus's inner and outer radii as multiples of the hole radius (default
    /// 1.5 and 2.5).
    pub surround_radii: [f64; 2],
}

impl Default for GlareOptions {
    fn default() -> Self {
        GlareOptions {
            centre_px: None,
            hole_diameter_px: None,
            roi_fraction: 0.2,
            surround_radii: [1.5, 2.5],
        }
    }
}

/// The measured veiling glare of one plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GlareResult {
    /// The hole's centre [x, y], pixels.
    pub centre_px: [f64; 2],
    /// The hole's diameter, pixels.
    pub hole_diameter_px: f64,
    /// Mean signal over the hole's central disc (above black, the plane's unit).
    pub hole_signal: f64,
    /// Pixels averaged in the hole.
    pub hole_pixels: usize,
    /// Mean signal over the surround annulus.
    pub surround_signal: f64,
    /// Pixels averaged in the surround.
    pub surround_pixels: usize,
    /// hole_signal / surround_signal.
    pub glare_index: f64,
}

/// Median of up to ~65 k evenly strided samples of the plane.
fn median_level(p: &Plane) -> f64 {
    let stride = (p.data.len() / 65_536).max(1);
    let mut v: Vec<f32> = p.data.iter().step_by(stride).copied().collect();
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    v[mid] as f64
}

/// The dark hole holding `start` ([x, y], default the image centre): its centroid [x, y] and
/// equivalent diameter, pixels.
pub fn find_hole(plane: &Plane, start: Option<[f64; 2]>) -> Result<([f64; 2], f64)> {
    if plane.data.iter().any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "glare image",
            "has non-finite values",
        ));
    }
    let level = median_level(plane);
    if !(level > 0.0) {
        return Err(AnalysisError::invalid(
            "glare image",
            format!("the median level is {level}: no bright surround above black"),
        ));
    }
    let threshold = 0.5 * level;
    let [sx, sy] = start.unwrap_or([plane.cols as f64 / 2.0, plane.rows as f64 / 2.0]);
    let (c0, r0) = (sx.floor(), sy.floor());
    if !(c0 >= 0.0 && r0 >= 0.0 && (c0 as usize) < plane.cols && (r0 as usize) < plane.rows) {
        return Err(AnalysisError::invalid(
            "glare centre",
            format!(
                "[{sx}, {sy}] is outside the {} x {} image",
                plane.rows, plane.cols
            ),
        ));
    }
    let (c0, r0) = (c0 as usize, r0 as usize);
    if plane.at(r0, c0) as f64 >= threshold {
        return Err(AnalysisError::invalid(
            "glare hole",
            format!(
                "pixel (row {r0}, col {c0}) is {} >= half the surround's level {level}: no dark hole there (give its centre)",
                plane.at(r0, c0)
            ),
        ));
    }
    let (rows, cols) = (plane.rows, plane.cols);
    let mut seen = vec![false; rows * cols];
    let mut stack = vec![(r0, c0)];
    seen[r0 * cols + c0] = true;
    let (mut n, mut sum_x, mut sum_y) = (0usize, 0.0f64, 0.0f64);
    while let Some((r, c)) = stack.pop() {
        if r == 0 || c == 0 || r + 1 == rows || c + 1 == cols {
            return Err(AnalysisError::invalid(
                "glare hole",
                "the dark region at the start point reaches the image edge: not a hole in a bright surround",
            ));
        }
        n += 1;
        sum_x += c as f64 + 0.5;
        sum_y += r as f64 + 0.5;
        for (rr, cc) in [(r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)] {
            let i = rr * cols + cc;
            if !seen[i] && (plane.data[i] as f64) < threshold {
                seen[i] = true;
                stack.push((rr, cc));
            }
        }
    }
    let d = 2.0 * (n as f64 / std::f64::consts::PI).sqrt();
    Ok(([sum_x / n as f64, sum_y / n as f64], d))
}

/// Mean of the pixels whose centres lie at distance [r_in, r_out) from `centre`, those of the
/// image only, and their number.
fn ring_mean(plane: &Plane, centre: [f64; 2], r_in: f64, r_out: f64) -> (f64, usize) {
    let [cx, cy] = centre;
    let r0 = ((cy - r_out).floor().max(0.0)) as usize;
    let r1 = ((cy + r_out).ceil().max(0.0) as usize).min(plane.rows);
    let c0 = ((cx - r_out).floor().max(0.0)) as usize;
    let c1 = ((cx + r_out).ceil().max(0.0) as usize).min(plane.cols);
    let (mut s, mut n) = (0.0f64, 0usize);
    for r in r0..r1 {
        let dy = r as f64 + 0.5 - cy;
        for c in c0..c1 {
            let dx = c as f64 + 0.5 - cx;
            let d2 = dx * dx + dy * dy;
            if d2 >= r_in * r_in && d2 < r_out * r_out {
                s += plane.at(r, c) as f64;
                n += 1;
            }
        }
    }
    (if n > 0 { s / n as f64 } else { 0.0 }, n)
}

/// The veiling glare index of a plane (values above black) of an ISO 18844 target image.
pub fn veiling_glare(plane: &Plane, opts: &GlareOptions) -> Result<GlareResult> {
    if !(opts.roi_fraction > 0.0 && opts.roi_fraction < 1.0) {
        return Err(AnalysisError::invalid(
            "glare roi_fraction",
            format!(
                "{} is not a fraction of the hole diameter in (0, 1)",
                opts.roi_fraction
            ),
        ));
    }
    let [k_in, k_out] = opts.surround_radii;
    if !(k_in >= 1.0 && k_out > k_in && k_out.is_finite()) {
        return Err(AnalysisError::invalid(
            "glare surround_radii",
            format!("[{k_in}, {k_out}] hole radii: need 1 <= inner < outer"),
        ));
    }
    let (centre, d) = match (opts.centre_px, opts.hole_diameter_px) {
        (Some(c), Some(d)) => (c, d),
        (start, given) => {
            let (c, d) = find_hole(plane, start)?;
            (start.unwrap_or(c), given.unwrap_or(d))
        }
    };
    if !(d > 0.0 && d.is_finite()) {
        return Err(AnalysisError::invalid(
            "glare hole_diameter_px",
            format!("{d} is not a positive diameter"),
        ));
    }
    let r = d / 2.0;
    let (hole_signal, hole_pixels) = ring_mean(plane, centre, 0.0, opts.roi_fraction * r);
    if hole_pixels == 0 {
        return Err(AnalysisError::invalid(
            "glare hole",
            format!(
                "the central disc of diameter {:.2} px at [{:.1}, {:.1}] holds no pixel centre (a larger roi_fraction or hole)",
                opts.roi_fraction * d,
                centre[0],
                centre[1]
            ),
        ));
    }
    let (surround_signal, surround_pixels) = ring_mean(plane, centre, k_in * r, k_out * r);
    if surround_pixels < 8 || !(surround_signal > 0.0) {
        return Err(AnalysisError::invalid(
            "glare surround",
            format!(
                "the annulus {:.1}..{:.1} px around [{:.1}, {:.1}] has {surround_pixels} pixels of mean {surround_signal}: no bright surround",
                k_in * r,
                k_out * r,
                centre[0],
                centre[1]
            ),
        ));
    }
    Ok(GlareResult {
        centre_px: centre,
        hole_diameter_px: d,
        hole_signal,
        hole_pixels,
        surround_signal,
        surround_pixels,
        glare_index: hole_signal / surround_signal,
    })
}
