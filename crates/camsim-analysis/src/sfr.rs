//! ISO 12233 edge spatial frequency response (e-SFR), following ISO 12233:2017 annex D and
//! P. D. Burns' `sfrmat3`/`sfrmat4` description (Burns, "Slanted-edge MTF for digital camera and
//! scanner analysis", PICS 2000; Burns, "Refined slanted-edge measurement", IS&T EI 2022).
//!
//! Steps (all in the ROI, with the edge made near-vertical by transposing when needed):
//! 1. per row, the derivative `a[m+1] - a[m]` (the [-1/2, 1/2] kernel up to scale) and its
//!    centroid, weighted by a Hamming window centred first on the ROI, then on the fitted edge;
//! 2. a least-squares polynomial (1st or 2nd order) `x_edge(row)` through the centroids;
//! 3. the rows kept are the largest number holding an integer number of phase cycles
//!    (`round(floor(n |slope|) / |slope|)`, as sfrmat);
//! 4. every pixel is projected onto the edge normal (`(x - x_edge(row)) cos(atan(slope))`) and
//!    binned at 1/oversample pixel into the edge-spread function (ESF);
//! 5. the line-spread function (LSF) is the ESF's first difference, multiplied by a Hamming window
//!    centred on the LSF centroid;
//! 6. the magnitude of its DFT, normalised to 1 at zero frequency, divided by the frequency
//!    response of the difference (`sinc(f / oversample)`, the discrete-derivative correction).
//!
//! Units: every result is given in cycles per *sensor pixel* (`_cyc_per_sensor_px`, the unit to
//! report and compare) and, given the pitch, cycles/mm on the sensor. For a CFA channel measured
//! on its own sub-grid (samples 2 sensor pixels apart) the per-sample values
//! (`_cyc_per_sample`, twice as large) are kept only as the analysed grid's own axis.

use crate::error::{AnalysisError, Result};
use crate::image::{cfa_channel_offset, cfa_channel_plane, luminance, sub_grid_rect, Plane, Rect};
use camsim_core::{CfaChannel, RawImage};
use serde::{Deserialize, Serialize};

/// Options of the SFR measurement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SfrOptions {
    /// ESF bins per pixel (ISO 12233 and sfrmat use 4).
    pub oversample: usize,
    /// Order of the polynomial fitted to the edge locations: 1 (straight edge) or 2 (curved edge,
    /// sfrmat4 option for lens distortion).
    pub poly_order: usize,
    /// Pixel pitch of the *sensor*, mm (for cycles/mm); `None` leaves cycles/mm out (raw frames
    /// fall back to their own `pixel_pitch_m`).
    pub pixel_pitch_mm: Option<f64>,
}

impl Default for SfrOptions {
    fn default() -> Self {
        SfrOptions {
            oversample: 4,
            poly_order: 1,
            pixel_pitch_mm: None,
        }
    }
}

/// Which way the edge runs in the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeOrientation {
    /// Near-vertical edge (intensity changes along rows): the SFR is horizontal.
    Vertical,
    /// Near-horizontal edge (intensity changes along columns): analysed transposed.
    Horizontal,
}

/// The measured SFR and what it was measured on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SfrResult {
    /// Frequencies, cycles per sample of the analysed grid (0 to oversample / 2): equal to
    /// `freq_cyc_per_sensor_px` for a full plane, twice it for a CFA channel sub-grid.
    pub freq_cyc_per_sample: Vec<f64>,
    /// The same frequencies in cycles per sensor pixel (the unit to report).
    pub freq_cyc_per_sensor_px: Vec<f64>,
    /// The same frequencies in cycles/mm, when the pixel pitch is known.
    pub freq_cyc_per_mm: Option<Vec<f64>>,
    /// SFR (MTF) at each frequency, 1 at zero frequency.
    pub mtf: Vec<f64>,
    /// Angle of the edge from the column axis (vertical edge) or row axis (horizontal edge), degrees.
    pub edge_angle_deg: f64,
    /// Edge orientation.
    pub orientation: EdgeOrientation,
    /// Coefficients of the fitted edge `x = c0 + c1 t + c2 t^2`, t = row - `edge_fit_row0` (ROI
    /// coordinates of the analysed, possibly transposed, grid; pixel centres at integers).
    pub edge_fit: Vec<f64>,
    /// Row about which `edge_fit` is expanded.
    pub edge_fit_row0: f64,
    /// Rows used (an integer number of phase cycles).
    pub rows_used: usize,
    /// ESF bins that received no pixel and were filled by interpolation.
    pub empty_bins: usize,
    /// Frequency where the SFR first falls to 0.5, cycles per sample of the analysed grid (None
    /// if it never does).
    pub mtf50_cyc_per_sample: Option<f64>,
    /// MTF50 in cycles per sensor pixel.
    pub mtf50_cyc_per_sensor_px: Option<f64>,
    /// MTF50 in cycles/mm, when the pitch is known.
    pub mtf50_cyc_per_mm: Option<f64>,
    /// SFR at the Nyquist frequency of the analysed grid (0.5 cycles per sample, that is
    /// `nyquist_cyc_per_sensor_px`).
    pub mtf_at_nyquist: f64,
    /// The analysed grid's Nyquist frequency in cycles per sensor pixel (0.5 for a full plane,
    /// 0.25 for a CFA channel sub-grid).
    pub nyquist_cyc_per_sensor_px: f64,
    /// Distance between ESF/LSF samples along the edge normal, pixels of the analysed grid.
    pub esf_spacing_px: f64,
    /// Edge-spread function (mean value per bin, in the input's unit, original sign).
    pub esf: Vec<f64>,
    /// Line-spread function after windowing (first difference of the ESF, dark-to-light sign).
    pub lsf: Vec<f64>,
    /// Region analysed, in the coordinates of the plane it was taken from.
    pub roi: Rect,
    /// Sample pitch of the analysed grid, sensor pixels (1 for a plane, 2 for a CFA sub-grid).
    pub sample_pitch_sensor_px: f64,
}

/// Hamming window of length n centred at `mid` (sfrmat `ahamming`): 0.54 + 0.46 cos(pi (i - mid) / w),
/// w the larger distance from `mid` to an end.
fn hamming_at(i: f64, mid: f64, n: usize) -> f64 {
    let wid = mid.max((n as f64 - 1.0) - mid).max(1.0);
    let arg = ((i - mid) / wid).clamp(-1.0, 1.0);
    0.54 + 0.46 * (std::f64::consts::PI * arg).cos()
}

/// Least-squares polynomial `y = sum c_k (x - x0)^k`, k = 0..=order, by the normal equations
/// in centred coordinates (order <= 2 keeps them well conditioned).
fn polyfit(xs: &[f64], ys: &[f64], order: usize, x0: f64) -> Option<Vec<f64>> {
    let m = order + 1;
    let mut a = [[0.0f64; 4]; 3];
    for (x, y) in xs.iter().zip(ys) {
        let t = x - x0;
        let p = [1.0, t, t * t, t * t * t, t * t * t * t];
        for i in 0..m {
            for j in 0..m {
                a[i][j] += p[i + j];
            }
            a[i][3] += p[i] * y;
        }
    }
    // Gaussian elimination with partial pivoting.
    for col in 0..m {
        let piv = (col..m).max_by(|i, j| a[*i][col].abs().total_cmp(&a[*j][col].abs()))?;
        if a[piv][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, piv);
        for r in 0..m {
            if r != col {
                let f = a[r][col] / a[col][col];
                for k in col..4 {
                    a[r][k] -= f * a[col][k];
                }
            }
        }
    }
    let c: Vec<f64> = (0..m).map(|i| a[i][3] / a[i][i]).collect();
    c.iter().all(|v| v.is_finite()).then_some(c)
}

fn poly_eval(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, k| acc * t + k)
}

fn poly_slope(c: &[f64], t: f64) -> f64 {
    match c.len() {
        0 | 1 => 0.0,
        2 => c[1],
        _ => c[1] + 2.0 * c[2] * t,
    }
}

use camsim_core::math::sinc;

/// Is the edge in `a` (rows x cols, row-major) closer to horizontal than vertical? Compares the
/// left-right with the top-bottom contrast of the border strips (sfrmat `rotatev2`).
fn is_horizontal(a: &[f64], rows: usize, cols: usize) -> bool {
    let k_c = (cols / 8).clamp(1, 5);
    let k_r = (rows / 8).clamp(1, 5);
    let mean = |rs: std::ops::Range<usize>, cs: std::ops::Range<usize>| {
        let mut s = 0.0;
        let mut n = 0.0;
        for r in rs {
            for c in cs.clone() {
                s += a[r * cols + c];
                n += 1.0;
            }
        }
        s / n
    };
    let lr = (mean(0..rows, 0..k_c) - mean(0..rows, cols - k_c..cols)).abs();
    let tb = (mean(0..k_r, 0..cols) - mean(rows - k_r..rows, 0..cols)).abs();
    tb > lr
}

/// The e-SFR of the edge in `plane` (inside `roi`, or the whole plane when `None`).
///
/// The ROI must contain one straight (or, with `poly_order` 2, gently curved) edge between two
/// flat regions, slanted by 1 to 45 degrees from the vertical or horizontal; ISO 12233 suggests
/// about 5 degrees. Either side may be the bright one.
pub fn sfr(plane: &Plane, roi: Option<Rect>, opts: &SfrOptions) -> Result<SfrResult> {
    sfr_with_pitch(plane, roi, opts, 1.0)
}

/// [`sfr`] on a grid whose samples are `pitch_sensor_px` sensor pixels apart: sfrmat's steps
/// (check, orient, edge fit, binned ESF, windowed LSF, DFT), one function each.
fn sfr_with_pitch(
    plane: &Plane,
    roi: Option<Rect>,
    opts: &SfrOptions,
    pitch_sensor_px: f64,
) -> Result<SfrResult> {
    check_options(opts)?;
    let roi = roi.unwrap_or_else(|| plane.full_rect());
    let mut g = oriented_roi(plane, &roi)?;
    let polarity = make_dark_to_light(&mut g, &roi)?;
    let edge = fit_edge(&g, opts.poly_order, &roi)?;
    let ovs = opts.oversample;
    let (esf, empty_bins) = binned_esf(&g, &edge, ovs, &roi)?;
    let lsf = windowed_lsf(&esf);
    let (freq, mtf) = lsf_mtf(&lsf, ovs, &roi)?;
    let mtf50 = crossing(&freq, &mtf, 0.5);
    let mtf_at_nyquist = interp(&freq, &mtf, 0.5);
    let pitch_mm = opts.pixel_pitch_mm.map(|p| p * pitch_sensor_px);
    Ok(SfrResult {
        freq_cyc_per_sensor_px: freq.iter().map(|f| f / pitch_sensor_px).collect(),
        freq_cyc_per_mm: pitch_mm.map(|p| freq.iter().map(|f| f / p).collect()),
        freq_cyc_per_sample: freq,
        mtf,
        edge_angle_deg: poly_slope(&edge.fit, 0.0).atan().to_degrees(),
        orientation: g.orientation,
        edge_fit: edge.fit,
        edge_fit_row0: edge.row0,
        rows_used: edge.nlin1,
        empty_bins,
        mtf50_cyc_per_sample: mtf50,
        mtf50_cyc_per_sensor_px: mtf50.map(|f| f / pitch_sensor_px),
        mtf50_cyc_per_mm: mtf50.and_then(|f| pitch_mm.map(|p| f / p)),
        mtf_at_nyquist,
        nyquist_cyc_per_sensor_px: 0.5 / pitch_sensor_px,
        esf_spacing_px: 1.0 / ovs as f64,
        esf: esf.iter().map(|v| v * polarity).collect(),
        lsf,
        roi,
        sample_pitch_sensor_px: pitch_sensor_px,
    })
}

fn check_options(opts: &SfrOptions) -> Result<()> {
    if opts.oversample == 0 || opts.oversample > 64 {
        return Err(AnalysisError::invalid(
            "sfr oversample",
            format!("{} is not in 1..=64", opts.oversample),
        ));
    }
    if opts.poly_order != 1 && opts.poly_order != 2 {
        return Err(AnalysisError::invalid(
            "sfr poly_order",
            format!("{} is not 1 or 2", opts.poly_order),
        ));
    }
    if let Some(p) = opts.pixel_pitch_mm {
        if !(p > 0.0 && p.is_finite()) {
            return Err(AnalysisError::invalid(
                "sfr pixel_pitch_mm",
                format!("{p} is not a positive number"),
            ));
        }
    }
    Ok(())
}

/// The ROI's values, transposed when the edge runs horizontally, so the edge always runs down
/// the rows: `a[r * npix + m]`, `nlin` rows along the edge, `npix` samples across it.
struct EdgeGrid {
    a: Vec<f64>,
    nlin: usize,
    npix: usize,
    orientation: EdgeOrientation,
}

fn oriented_roi(plane: &Plane, roi: &Rect) -> Result<EdgeGrid> {
    let crop = plane.crop(roi)?;
    if crop.data.iter().any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("ROI {roi} holds values that are not finite"),
        ));
    }
    let mut a: Vec<f64> = crop.data.iter().map(|v| *v as f64).collect();
    let (mut nlin, mut npix) = (crop.rows, crop.cols);
    if nlin.min(npix) < 4 {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("ROI {roi} is smaller than 4 x 4 pixels"),
        ));
    }
    let orientation = if is_horizontal(&a, nlin, npix) {
        let t = crop.transpose();
        a = t.data.iter().map(|v| *v as f64).collect();
        std::mem::swap(&mut nlin, &mut npix);
        EdgeOrientation::Horizontal
    } else {
        EdgeOrientation::Vertical
    };
    if npix < 8 || nlin < 4 {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("ROI {roi} needs at least 8 pixels across the edge and 4 along it"),
        ));
    }
    Ok(EdgeGrid {
        a,
        nlin,
        npix,
        orientation,
    })
}

/// Make the edge dark-to-light from left to right (ISO 12233 allows either polarity); returns the
/// sign applied (1 or -1). Errors when the two sides do not differ.
fn make_dark_to_light(g: &mut EdgeGrid, roi: &Rect) -> Result<f64> {
    let (nlin, npix) = (g.nlin, g.npix);
    let k = (npix / 8).clamp(1, 5);
    let side = |a: &[f64], cs: std::ops::Range<usize>| -> f64 {
        (0..nlin)
            .map(|r| cs.clone().map(|c| a[r * npix + c]).sum::<f64>())
            .sum::<f64>()
    };
    let (left, right) = (side(&g.a, 0..k), side(&g.a, npix - k..npix));
    let polarity = if right >= left { 1.0 } else { -1.0 };
    if polarity < 0.0 {
        g.a.iter_mut().for_each(|v| *v = -*v);
    }
    let contrast = (right - left).abs() / (nlin * k) as f64;
    let level = g.a.iter().map(|v| v.abs()).fold(0.0, f64::max);
    if !(contrast > 1e-9 * level.max(1e-30)) {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("ROI {roi} shows no edge (no contrast between its sides)"),
        ));
    }
    Ok(polarity)
}

/// The fitted edge: `x = poly(t)`, t = row - `row0`, over rows `first..first + nlin1` (an integer
/// number of phase cycles).
struct EdgeFit {
    fit: Vec<f64>,
    row0: f64,
    first: usize,
    nlin1: usize,
}

/// sfrmat steps 1-3: the edge location per row (centroid of the windowed derivative, two passes),
/// a polynomial fit, and the rows kept for an integer number of phase cycles.
fn fit_edge(g: &EdgeGrid, poly_order: usize, roi: &Rect) -> Result<EdgeFit> {
    let (a, nlin, npix) = (&g.a, g.nlin, g.npix);
    let nd = npix - 1; // derivative samples, sample m at x = m + 0.5
    let centroid_row = |r: usize, mid: f64| -> Option<f64> {
        let row = &a[r * npix..(r + 1) * npix];
        let (mut s, mut sx) = (0.0, 0.0);
        for m in 0..nd {
            let d = (row[m + 1] - row[m]) * hamming_at(m as f64, mid, nd);
            s += d;
            sx += d * (m as f64 + 0.5);
        }
        (s > 0.0).then(|| sx / s)
    };
    let row0 = (nlin as f64 - 1.0) / 2.0;
    let fit_rows = |rows: &[usize], locs: &[f64]| -> Result<Vec<f64>> {
        let xs: Vec<f64> = rows.iter().map(|r| *r as f64).collect();
        polyfit(&xs, locs, poly_order, row0).ok_or_else(|| {
            AnalysisError::invalid("sfr", format!("cannot fit a line to the edge in ROI {roi}"))
        })
    };
    let located = |place: &dyn Fn(usize) -> f64| -> Result<(Vec<usize>, Vec<f64>)> {
        let (mut rows_ok, mut locs) = (Vec::with_capacity(nlin), Vec::with_capacity(nlin));
        for r in 0..nlin {
            if let Some(c) = centroid_row(r, place(r)) {
                rows_ok.push(r);
                locs.push(c);
            }
        }
        if rows_ok.len() < nlin.div_ceil(2).max(3) {
            return Err(AnalysisError::invalid(
                "sfr",
                format!("no edge found in most rows of ROI {roi}"),
            ));
        }
        Ok((rows_ok, locs))
    };
    let (rows1, locs1) = located(&|_| (nd as f64 - 1.0) / 2.0)?;
    let fit1 = fit_rows(&rows1, &locs1)?;
    // Second pass: the window centred on the first fit's edge (its derivative index).
    let (rows_ok, locs) =
        located(&|r| (poly_eval(&fit1, r as f64 - row0) - 0.5).clamp(0.0, nd as f64 - 1.0))?;
    let fit2 = fit_rows(&rows_ok, &locs)?;
    let slope = poly_slope(&fit2, 0.0);

    // 3. Keep an integer number of phase cycles (sfrmat: nlin1 = round(floor(nlin |s|) / |s|)).
    let cycles = (nlin as f64 * slope.abs()).floor();
    if cycles < 1.0 {
        return Err(AnalysisError::invalid(
            "sfr",
            format!(
                "the edge in ROI {roi} is too close to vertical/horizontal ({:.2} degrees): fewer than one phase cycle in {nlin} rows; slant it by 2 to 10 degrees or use a taller ROI",
                slope.atan().to_degrees()
            ),
        ));
    }
    let nlin1 = ((cycles / slope.abs()).round() as usize).clamp(1, nlin);
    let first = (nlin - nlin1) / 2;
    let keep: Vec<usize> = (0..rows_ok.len())
        .filter(|i| rows_ok[*i] >= first && rows_ok[*i] < first + nlin1)
        .collect();
    let fit = if keep.len() >= 3 && nlin1 < nlin {
        let rs: Vec<usize> = keep.iter().map(|i| rows_ok[*i]).collect();
        let ls: Vec<f64> = keep.iter().map(|i| locs[*i]).collect();
        fit_rows(&rs, &ls)?
    } else {
        fit2
    };
    let mid_loc = poly_eval(&fit, 0.0);
    if !(mid_loc > 0.0 && mid_loc < npix as f64 - 1.0) {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("the fitted edge leaves ROI {roi}"),
        ));
    }
    Ok(EdgeFit {
        fit,
        row0,
        first,
        nlin1,
    })
}

/// sfrmat step 4: every sample projected onto the edge normal and binned at 1/`ovs` pixel; empty
/// bins filled by linear interpolation between the nearest filled ones (held at the ends).
/// Returns the ESF and the number of empty bins.
fn binned_esf(g: &EdgeGrid, e: &EdgeFit, ovs: usize, roi: &Rect) -> Result<(Vec<f64>, usize)> {
    let npix = g.npix;
    let nn = npix * ovs;
    let half = (nn / 2) as f64;
    let mut sum = vec![0.0f64; nn];
    let mut count = vec![0u32; nn];
    for r in e.first..e.first + e.nlin1 {
        let t = r as f64 - e.row0;
        let xe = poly_eval(&e.fit, t);
        let cosang = poly_slope(&e.fit, t).atan().cos();
        let row = &g.a[r * npix..(r + 1) * npix];
        for (m, v) in row.iter().enumerate() {
            let d = (m as f64 - xe) * cosang;
            let b = (d * ovs as f64 + half).floor();
            if b >= 0.0 && b < nn as f64 {
                sum[b as usize] += v;
                count[b as usize] += 1;
            }
        }
    }
    let filled: Vec<usize> = (0..nn).filter(|b| count[*b] > 0).collect();
    if filled.len() < 2 {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("too few pixels in ROI {roi} to build the edge profile"),
        ));
    }
    let mut esf = vec![0.0f64; nn];
    for b in &filled {
        esf[*b] = sum[*b] / count[*b] as f64;
    }
    let mut empty_bins = 0;
    for b in 0..nn {
        if count[b] > 0 {
            continue;
        }
        empty_bins += 1;
        let i = filled.partition_point(|f| *f < b);
        esf[b] = if i == 0 {
            esf[filled[0]]
        } else if i == filled.len() {
            esf[filled[filled.len() - 1]]
        } else {
            let (b0, b1) = (filled[i - 1], filled[i]);
            let w = (b - b0) as f64 / (b1 - b0) as f64;
            esf[b0] * (1.0 - w) + esf[b1] * w
        };
    }
    Ok((esf, empty_bins))
}

/// sfrmat step 5: the LSF, first difference of the ESF (the [-1/2, 1/2] kernel; the scale does
/// not matter after normalisation), Hamming-windowed about its centroid.
fn windowed_lsf(esf: &[f64]) -> Vec<f64> {
    let nn = esf.len();
    let half = (nn / 2) as f64;
    let mut lsf = vec![0.0f64; nn];
    for b in 0..nn - 1 {
        lsf[b] = esf[b + 1] - esf[b];
    }
    let s: f64 = lsf.iter().sum();
    let sx: f64 = lsf.iter().enumerate().map(|(i, v)| i as f64 * v).sum();
    let centre = if s > 0.0 {
        (sx / s).clamp(0.0, nn as f64 - 2.0)
    } else {
        half
    };
    for (i, v) in lsf.iter_mut().enumerate().take(nn - 1) {
        *v *= hamming_at(i as f64, centre, nn - 1);
    }
    lsf
}

/// sfrmat step 6: |DFT| of the LSF normalised at DC, divided by the difference filter's response
/// sinc(f / oversample) (fir2fix, capped at 10). Returns (frequency, cycles per sample; MTF).
fn lsf_mtf(lsf: &[f64], ovs: usize, roi: &Rect) -> Result<(Vec<f64>, Vec<f64>)> {
    let nn = lsf.len();
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nn);
    let mut input = lsf.to_vec();
    let mut spectrum = fft.make_output_vec();
    fft.process(&mut input, &mut spectrum)
        .map_err(|e| AnalysisError::invalid("sfr", format!("FFT failed: {e}")))?;
    let dc = spectrum[0].norm();
    if !(dc > 0.0) {
        return Err(AnalysisError::invalid(
            "sfr",
            format!("the edge in ROI {roi} has no net contrast"),
        ));
    }
    let nf = nn / 2 + 1;
    let spacing = 1.0 / ovs as f64;
    let mut freq = Vec::with_capacity(nf);
    let mut mtf = Vec::with_capacity(nf);
    for (k, c) in spectrum.iter().enumerate().take(nf) {
        let f = k as f64 / (nn as f64 * spacing);
        let corr = (1.0 / sinc(f * spacing)).min(10.0);
        freq.push(f);
        mtf.push(c.norm() / dc * corr);
    }
    Ok((freq, mtf))
}

/// First frequency where `y` falls to `level` (linear interpolation), if it does.
pub fn crossing(x: &[f64], y: &[f64], level: f64) -> Option<f64> {
    for i in 1..y.len().min(x.len()) {
        if y[i - 1] >= level && y[i] < level {
            let w = (y[i - 1] - level) / (y[i - 1] - y[i]);
            return Some(x[i - 1] + w * (x[i] - x[i - 1]));
        }
    }
    None
}

/// Linear interpolation of `y(x)` at `x0` (x increasing), held at the ends.
pub fn interp(x: &[f64], y: &[f64], x0: f64) -> f64 {
    let i = x.partition_point(|v| *v < x0);
    if i == 0 {
        y[0]
    } else if i >= x.len() {
        y[y.len() - 1]
    } else {
        let w = (x0 - x[i - 1]) / (x[i] - x[i - 1]);
        y[i - 1] * (1.0 - w) + y[i] * w
    }
}

/// SFR of one CFA channel of a raw mosaic, measured on the channel's own sub-grid (no
/// demosaicking). `roi` is in sensor pixels (None: found automatically on the sub-grid). For
/// green the first green of the 2x2 block is used (see [`sfr_raw_sub_grid`] for the other).
/// `opts.pixel_pitch_mm` is the sensor pitch; if `None`, the frame's `pixel_pitch_m` is used
/// when set. Frequencies: `freq_cyc_per_sensor_px` per sensor pixel (`freq_cyc_per_sample` per
/// sub-grid sample, twice as large); `mtf_at_nyquist` is at the sub-grid's Nyquist (0.25 cycles per sensor pixel).
pub fn sfr_raw_channel(
    raw: &RawImage,
    ch: CfaChannel,
    roi: Option<Rect>,
    opts: &SfrOptions,
) -> Result<SfrResult> {
    sfr_raw_sub_grid(raw, ch, None, roi, opts)
}

/// [`sfr_raw_channel`] choosing which green (0 or 1) for `ch` = G.
pub fn sfr_raw_sub_grid(
    raw: &RawImage,
    ch: CfaChannel,
    which_green: Option<usize>,
    roi: Option<Rect>,
    opts: &SfrOptions,
) -> Result<SfrResult> {
    let plane = cfa_channel_plane(raw, ch, which_green)?;
    let off = cfa_channel_offset(raw.cfa, ch, which_green)?;
    let sub_roi = match roi {
        Some(r) => {
            r.check_inside(raw.rows, raw.cols, "sfr ROI")?;
            Some(sub_grid_rect(&r, off))
        }
        None => Some(find_edge_roi(&plane)?),
    };
    let mut o = *opts;
    if o.pixel_pitch_mm.is_none() && raw.pixel_pitch_m > 0.0 && raw.pixel_pitch_m.is_finite() {
        o.pixel_pitch_mm = Some(raw.pixel_pitch_m * 1e3);
    }
    sfr_with_pitch(&plane, sub_roi, &o, 2.0)
}

/// SFR of the luminance of a demosaicked RGB image (camsim's one luminance of RGB planes,
/// [`crate::image::luminance`]: Rec. 709 weights).
pub fn sfr_luminance(
    planes: &[Plane; 3],
    roi: Option<Rect>,
    opts: &SfrOptions,
) -> Result<SfrResult> {
    let y = luminance(planes)?;
    sfr(&y, roi, opts)
}

/// Find a region of interest around the best slanted edge of `plane`.
///
/// Per row (or column, for near-horizontal edges) the local maxima of the smoothed derivative are
/// linked from row to row into straight-edge tracks (a track continues while its position moves
/// by at most 3 pixels per row). A track is a *slanted edge* when its fitted slope gives at least
/// one phase cycle over its length (`rows |slope| >= 1`, what [`sfr`] needs) and it leans by
/// 0.5 to 45 degrees; the frame of a scene smaller than the image (a perfectly vertical or
/// horizontal border) is not. Among the slanted edges at least half as long as the longest, the
/// one with the largest contrast (median step across the edge) wins; if no edge is slanted, the
/// longest one is returned (and [`sfr`] then explains why it cannot be measured). The window is
/// wide enough for the transition and flat regions on both sides (at least 12 pixels or 3
/// transition widths each side), but stops short of any other strong edge beside it.
pub fn find_edge_roi(plane: &Plane) -> Result<Rect> {
    if plane.rows < 8 || plane.cols < 8 || plane.data.len() != plane.rows * plane.cols {
        return Err(AnalysisError::invalid(
            "edge search",
            format!("a {} x {} plane is too small", plane.rows, plane.cols),
        ));
    }
    if plane.data.iter().any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "edge search",
            "the plane holds values that are not finite",
        ));
    }
    // Both orientations; the horizontal candidates' rectangles are transposed back.
    // (A plane flat in one direction has no candidates in it.)
    let mut cands = edge_candidates(plane);
    let transposed = edge_candidates(&plane.transpose());
    cands.extend(transposed.into_iter().map(|c| EdgeCandidate {
        rect: Rect::new(c.rect.col, c.rect.row, c.rect.cols, c.rect.rows),
        ..c
    }));
    let longest_slanted = cands
        .iter()
        .filter(|c| c.slanted)
        .map(|c| c.len)
        .max()
        .unwrap_or(0);
    let best = if longest_slanted > 0 {
        cands
            .iter()
            .filter(|c| c.slanted && 2 * c.len >= longest_slanted)
            .max_by(|a, b| a.contrast.total_cmp(&b.contrast).then(a.len.cmp(&b.len)))
    } else {
        cands
            .iter()
            .max_by(|a, b| a.len.cmp(&b.len).then(a.contrast.total_cmp(&b.contrast)))
    };
    match best {
        Some(c) => Ok(c.rect),
        None => Err(AnalysisError::invalid(
            "edge search",
            "no straight edge of 8 pixels or longer found (is the image flat?)",
        )),
    }
}

/// A straight edge found by [`edge_candidates`].
#[derive(Debug, Clone, Copy)]
struct EdgeCandidate {
    /// The ROI around it.
    rect: Rect,
    /// Its length in rows.
    len: usize,
    /// Median peak of the smoothed derivative along it (the step across the edge, input units).
    contrast: f64,
    /// Whether it is slanted enough for the e-SFR (at least one phase cycle, 0.5 to 45 degrees).
    slanted: bool,
}

/// One row's derivative peak on a track: row, column, peak value, transition width.
type TrackPoint = (usize, usize, f64, usize);

/// The near-vertical straight edges of `p` (at least 8 rows long), with an ROI around each.
// Row and column loops index several arrays at once.
#[allow(clippy::needless_range_loop)]
fn edge_candidates(p: &Plane) -> Vec<EdgeCandidate> {
    let (rows, cols) = (p.rows, p.cols);
    // Derivative [1, 0, -1] of the 3-row average, per row; local maxima are the edge points.
    let mut d = vec![0.0f64; cols];
    let mut peaks: Vec<Vec<(usize, f64, usize)>> = Vec::with_capacity(rows);
    let mut row_max = vec![0.0f64; rows];
    for r in 0..rows {
        let rs = r.saturating_sub(1)..(r + 2).min(rows);
        let nr = rs.len() as f64;
        let avg = |c: usize| rs.clone().map(|k| p.at(k, c) as f64).sum::<f64>() / nr;
        for c in 1..cols - 1 {
            d[c] = (avg(c + 1) - avg(c - 1)).abs();
        }
        row_max[r] = d.iter().cloned().fold(0.0, f64::max);
        // Local maxima: the largest value within 2 columns (one peak per edge).
        let mut pk = Vec::new();
        for c in 1..cols - 1 {
            let lo = c.saturating_sub(2).max(1);
            let hi = (c + 3).min(cols - 1);
            let v = d[c];
            if v > 0.0 && (lo..hi).all(|k| d[k] < v || (d[k] == v && k >= c)) {
                // Width of the transition: contiguous samples above 10 % of the peak.
                let (mut a, mut b) = (c, c);
                while a > 1 && d[a - 1] > 0.1 * v {
                    a -= 1;
                }
                while b + 2 < cols && d[b + 1] > 0.1 * v {
                    b += 1;
                }
                pk.push((c, v, b - a + 1));
            }
        }
        peaks.push(pk);
    }
    let mut sorted = row_max.clone();
    sorted.sort_by(f64::total_cmp);
    let p90 = sorted[(rows * 9) / 10];
    if !(p90 > 0.0) {
        return Vec::new();
    }
    // Strong peaks only (a quarter of the typical row maximum), the 8 strongest per row.
    for pk in &mut peaks {
        pk.retain(|(_, v, _)| *v > 0.25 * p90);
        pk.sort_by(|a, b| b.1.total_cmp(&a.1));
        pk.truncate(8);
    }
    // Link peaks of consecutive rows into tracks, strongest peaks first.
    let mut open: Vec<Vec<TrackPoint>> = Vec::new();
    let mut done: Vec<Vec<TrackPoint>> = Vec::new();
    for (r, pk) in peaks.iter().enumerate() {
        let mut next: Vec<Vec<TrackPoint>> = Vec::new();
        let mut taken = vec![false; open.len()];
        for &(c, v, w) in pk {
            let near = (0..open.len())
                .filter(|i| !taken[*i])
                .map(|i| {
                    (
                        i,
                        (open[i].last().map_or(0, |q| q.1) as i64 - c as i64).abs(),
                    )
                })
                .filter(|(_, dc)| *dc <= 3)
                .min_by_key(|(_, dc)| *dc);
            match near {
                Some((i, _)) => {
                    taken[i] = true;
                    let mut t = std::mem::take(&mut open[i]);
                    t.push((r, c, v, w));
                    next.push(t);
                }
                None => next.push(vec![(r, c, v, w)]),
            }
        }
        for (i, t) in open.into_iter().enumerate() {
            if !taken[i] {
                done.push(t);
            }
        }
        open = next;
    }
    done.extend(open);
    done.retain(|t| t.len() >= 8);
    // Trim two rows at each end (the 3-row average blurs an edge's ends).
    let tracks: Vec<&[TrackPoint]> = done
        .iter()
        .map(|t| &t[2.min(t.len() / 4)..t.len() - 2.min(t.len() / 4)])
        .collect();
    let stats: Vec<(f64, f64)> = tracks
        .iter()
        .map(|t| {
            // Least-squares line c = c0 + s r through the peaks; the median peak value.
            let n = t.len() as f64;
            let (mr, mc) = (
                t.iter().map(|q| q.0 as f64).sum::<f64>() / n,
                t.iter().map(|q| q.1 as f64).sum::<f64>() / n,
            );
            let sxy: f64 = t
                .iter()
                .map(|q| (q.0 as f64 - mr) * (q.1 as f64 - mc))
                .sum();
            let sxx: f64 = t.iter().map(|q| (q.0 as f64 - mr).powi(2)).sum();
            let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
            let mut vs: Vec<f64> = t.iter().map(|q| q.2).collect();
            vs.sort_by(f64::total_cmp);
            (slope, vs[vs.len() / 2])
        })
        .collect();
    let mut out = Vec::with_capacity(tracks.len());
    for (k, t) in tracks.iter().enumerate() {
        let (slope, contrast) = stats[k];
        let (r0, r1) = (t[0].0, t[t.len() - 1].0 + 1);
        let cmin = t.iter().map(|q| q.1).min().unwrap_or(0);
        let cmax = t.iter().map(|q| q.1).max().unwrap_or(cols - 1);
        let mut ws: Vec<usize> = t.iter().map(|q| q.3).collect();
        ws.sort_unstable();
        let w = ws[ws.len() / 2];
        let margin = (3 * w).max(12);
        let mut c0 = cmin.saturating_sub(margin);
        let mut c1 = (cmax + margin + 1).min(cols);
        // Stop short of other strong edges in the same rows (half of this one's contrast or more).
        for (j, o) in tracks.iter().enumerate() {
            if j == k || stats[j].1 < 0.5 * contrast {
                continue;
            }
            let cs: Vec<usize> = o
                .iter()
                .filter(|q| q.0 >= r0 && q.0 < r1)
                .map(|q| q.1)
                .collect();
            let (Some(omin), Some(omax)) = (cs.iter().min().copied(), cs.iter().max().copied())
            else {
                continue;
            };
            let ow = o[o.len() / 2].3;
            if omin > cmax {
                c1 = c1.min(omin.saturating_sub(ow).max(cmax + 2));
            } else if omax < cmin {
                c0 = c0.max((omax + ow + 1).min(cmin.saturating_sub(1)));
            }
        }
        let len = t.len();
        let angle_deg = slope.atan().to_degrees().abs();
        let slanted = len as f64 * slope.abs() >= 1.0 && (0.5..=45.0).contains(&angle_deg);
        out.push(EdgeCandidate {
            rect: Rect::new(r0, c0, r1 - r0, c1 - c0),
            len,
            contrast,
            slanted,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polyfit_recovers_a_parabola_and_hamming_is_one_at_centre() {
        let xs: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let ys: Vec<f64> = xs
            .iter()
            .map(|x| 1.5 - 0.25 * (x - 9.5) + 0.01 * (x - 9.5) * (x - 9.5))
            .collect();
        let c = polyfit(&xs, &ys, 2, 9.5).unwrap();
        assert!(
            (c[0] - 1.5).abs() < 1e-10
                && (c[1] + 0.25).abs() < 1e-10
                && (c[2] - 0.01).abs() < 1e-10
        );
        assert!((hamming_at(7.0, 7.0, 20) - 1.0).abs() < 1e-15);
        assert!((hamming_at(19.0, 7.0, 20) - 0.08).abs() < 1e-12);
        assert_eq!(
            crossing(&[0.0, 1.0, 2.0], &[1.0, 0.6, 0.2], 0.5),
            Some(1.25)
        );
    }

    #[test]
    fn rejects_flat_tiny_and_unslanted_regions() {
        let flat = Plane::from_fn(32, 32, |_, _| 5.0).unwrap();
        assert!(sfr(&flat, None, &SfrOptions::default()).is_err());
        let tiny = Plane::from_fn(3, 32, |_, c| if c > 16 { 1.0 } else { 0.0 }).unwrap();
        assert!(sfr(&tiny, None, &SfrOptions::default()).is_err());
        // A perfectly vertical edge has no phase diversity: an error, not a wrong answer.
        let vertical = Plane::from_fn(32, 32, |_, c| if c > 16 { 1.0 } else { 0.0 }).unwrap();
        let e = sfr(&vertical, None, &SfrOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("phase cycle"), "{e}");
        let bad = SfrOptions {
            poly_order: 3,
            ..Default::default()
        };
        let slanted = Plane::from_fn(32, 32, |r, c| {
            if c as f64 > 16.0 + 0.1 * r as f64 {
                1.0
            } else {
                0.0
            }
        })
        .unwrap();
        assert!(sfr(&slanted, None, &bad).is_err());
        assert!(sfr(
            &slanted,
            Some(Rect::new(30, 0, 8, 8)),
            &SfrOptions::default()
        )
        .is_err());
        let mut nan = slanted.clone();
        nan.data[5] = f32::NAN;
        assert!(sfr(&nan, None, &SfrOptions::default()).is_err());
        assert!(find_edge_roi(&flat).is_err());
    }
}
