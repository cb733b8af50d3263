//! ISP for general colour filter arrays (RGBW, Quad Bayer, any N x M tile of named filters).
//!
//! - [`demosaic_layout_bilinear`]: per-filter bilinear interpolation for any tile. Each missing
//!   filter at a pixel is the normalized tent-weighted mean of that filter's samples in the
//!   (2N-1) x (2M-1) window around it, weight (1 - |dy|/N)(1 - |dx|/M) (normalized convolution,
//!   Knutsson & Westin 1993, with a bilinear kernel spanning one tile); a pixel keeps its own
//!   sample. On a 2x2 Bayer tile this is exactly [`crate::demosaic_bilinear`]: green from the four
//!   edge neighbours, red/blue from the two row or column neighbours or the four diagonals, border
//!   pixels from the neighbours inside the image.
//! - [`bin_2x2`]: Quad Bayer (or any tile of 2x2 same-filter blocks) to the tile of half the size:
//!   each output pixel is the sum of the four pixels' signals above black (digital binning, as
//!   ISETCam's `binning` of same-colour pixels): half the rows and columns, 4x the signal, the
//!   noise variances of the four add.
//! - [`rgbw_to_rgb`]: RGBW to RGB. R, G, B are interpolated as above, then scaled at every pixel
//!   by W / (a R + b G + c B), where a R + b G + c B is the W signal predicted from the colour
//!   channels (a, b, c fitted to the QE curves, `Sensor::filter_from_rgb_weights`): the colour
//!   ratios come from R, G, B and the brightness from W (the "W-guided" fusion of RGBW sensors,
//!   e.g. Kodak's 2007 panchromatic CFA).
//! - [`demosaic_any`]: an [`RgbImage`] from any frame (Bayer: [`crate::demosaic_bilinear`]; Quad Bayer: per-filter
//!   bilinear; other tiles with r, g, b filters: their interpolated planes).

use crate::demosaic::RgbImage;
use camsim_core::error::{CoreError, Result};
use camsim_core::RawImage;
use rayon::prelude::*;

/// One interpolated plane per filter of a CFA: black-level-subtracted DN, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterPlanes {
    /// Image height, pixels.
    pub rows: usize,
    /// Image width, pixels.
    pub cols: usize,
    /// Filter names, in the layout's order (r, g, b, then e.g. w).
    pub names: Vec<String>,
    /// One plane per filter, row-major, `rows * cols` each.
    pub planes: Vec<Vec<f32>>,
}

impl FilterPlanes {
    /// The plane of filter `name` (any alias: `red`, `white`...).
    pub fn plane(&self, name: &str) -> Option<&[f32]> {
        let n = camsim_core::cfa::canonical_filter_name(name);
        self.names
            .iter()
            .position(|f| *f == n)
            .map(|i| self.planes[i].as_slice())
    }
}

/// The raw's values fill its `rows x cols` grid, of at least one pixel.
pub(crate) fn check(raw: &RawImage) -> Result<()> {
    if raw.dn.len() != raw.rows * raw.cols || raw.rows == 0 || raw.cols == 0 {
        return Err(CoreError::invalid(
            "raw image",
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

/// Per-filter bilinear interpolation of any CFA (see the module docs), black level subtracted.
pub fn demosaic_layout_bilinear(raw: &RawImage) -> Result<FilterPlanes> {
    check(raw)?;
    let layout = raw.cfa_layout();
    let nf = layout.filters().len();
    let (rows, cols) = (raw.rows, raw.cols);
    camsim_core::mem::check_alloc(
        (rows * cols * 4 * nf) as u64,
        "the demosaicked filter planes",
    )?;
    let (tn, tm) = (layout.rows() as isize, layout.cols() as isize);
    let black = raw.black_level_dn as f32;
    // Interleaved output (pixel-major, nf values per pixel), split into planes after.
    let mut inter = vec![0.0f32; rows * cols * nf];
    inter
        .par_chunks_mut(cols * nf)
        .enumerate()
        .for_each(|(y, out)| {
            let mut sum = [0.0f32; 64];
            let mut wsum = [0.0f32; 64];
            for x in 0..cols {
                sum[..nf].fill(0.0);
                wsum[..nf].fill(0.0);
                for dy in -(tn - 1)..tn {
                    let yy = y as isize + dy;
                    if yy < 0 || yy >= rows as isize {
                        continue;
                    }
                    let wy = 1.0 - dy.abs() as f32 / tn as f32;
                    for dx in -(tm - 1)..tm {
                        let xx = x as isize + dx;
                        if xx < 0 || xx >= cols as isize {
                            continue;
                        }
                        let w = wy * (1.0 - dx.abs() as f32 / tm as f32);
                        let f = layout.filter_at(yy as usize, xx as usize);
                        sum[f] += w * (raw.dn[yy as usize * cols + xx as usize] as f32 - black);
                        wsum[f] += w;
                    }
                }
                let own = layout.filter_at(y, x);
                let px = &mut out[x * nf..(x + 1) * nf];
                for f in 0..nf {
                    px[f] = if f == own {
                        raw.dn[y * cols + x] as f32 - black
                    } else if wsum[f] > 0.0 {
                        sum[f] / wsum[f]
                    } else {
                        0.0
                    };
                }
            }
        });
    let planes = (0..nf)
        .map(|f| inter.iter().skip(f).step_by(nf).copied().collect())
        .collect();
    Ok(FilterPlanes {
        rows,
        cols,
        names: layout.filters().to_vec(),
        planes,
    })
}

/// Digital 2x2 binning of same-filter blocks (Quad Bayer -> Bayer): output pixel (i, j) is the sum
/// of the four input pixels (2i..2i+2, 2j..2j+2) above black, plus black (an odd last row or
/// column is dropped). White level 4 (white - black) + black and two more bits (both capped at 16
/// bits). Errors when the tile does not consist of 2x2 blocks of one filter.
pub fn bin_2x2(raw: &RawImage) -> Result<RawImage> {
    check(raw)?;
    let half = raw.cfa_layout().binned(2)?;
    let (rows, cols) = (raw.rows / 2, raw.cols / 2);
    if rows == 0 || cols == 0 {
        return Err(CoreError::invalid(
            "binning",
            format!("a {} x {} frame has no 2x2 block", raw.rows, raw.cols),
        ));
    }
    let bits = (raw.bits + 2).min(16);
    let mut out = RawImage::new(rows, cols, half.as_bayer().unwrap_or_default(), bits)?;
    out.layout = if half.as_bayer().is_some() {
        None
    } else {
        Some(half)
    };
    let black = raw.black_level_dn;
    out.black_level_dn = black;
    out.white_level_dn = (4.0 * (raw.white_level_dn - black) + black).min(65535.0);
    out.exposure_s = raw.exposure_s;
    out.pixel_pitch_m = raw.pixel_pitch_m * 2.0;
    let src_cols = raw.cols;
    out.dn
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(i, orow)| {
            let (a, b) = (
                &raw.dn[2 * i * src_cols..][..src_cols],
                &raw.dn[(2 * i + 1) * src_cols..][..src_cols],
            );
            for (j, o) in orow.iter_mut().enumerate() {
                let s =
                    a[2 * j] as f64 + a[2 * j + 1] as f64 + b[2 * j] as f64 + b[2 * j + 1] as f64;
                *o = (s - 3.0 * black).round().clamp(0.0, 65535.0) as u16;
            }
        });
    Ok(out)
}

/// RGBW (or any tile with r, g, b and w filters) to RGB by W-guided fusion (module docs):
/// interpolated R, G, B times W / (a R + b G + c B), with `w_from_rgb` = (a, b, c). Where the
/// predicted W is not positive the interpolated R, G, B are kept.
pub fn rgbw_to_rgb(raw: &RawImage, w_from_rgb: [f64; 3]) -> Result<RgbImage> {
    let p = demosaic_layout_bilinear(raw)?;
    let get = |n: &str| {
        p.plane(n).ok_or_else(|| {
            CoreError::invalid(
                "RGBW to RGB",
                format!("the CFA {} has no '{n}' filter", raw.cfa_layout().name()),
            )
        })
    };
    let (r, g, b, w) = (get("r")?, get("g")?, get("b")?, get("w")?);
    let [wa, wb, wc] = w_from_rgb.map(|v| v as f32);
    let mut out = RgbImage::zeros(p.rows, p.cols);
    for i in 0..p.rows * p.cols {
        let predicted = wa * r[i] + wb * g[i] + wc * b[i];
        let k = if predicted > 0.0 && w[i].is_finite() {
            w[i] / predicted
        } else {
            1.0
        };
        out.r[i] = r[i] * k;
        out.g[i] = g[i] * k;
        out.b[i] = b[i] * k;
    }
    Ok(out)
}

/// An RGB image from any raw frame: Bayer -> [`crate::demosaic_bilinear`]; any other CFA with r, g, b
/// filters -> their planes from [`demosaic_layout_bilinear`] (other filters, e.g. w, unused).
pub fn demosaic_any(raw: &RawImage) -> Result<RgbImage> {
    if raw.layout.as_ref().is_none_or(|l| l.as_bayer().is_some()) {
        let mut bayer = raw.clone();
        if let Some(p) = raw.layout.as_ref().and_then(|l| l.as_bayer()) {
            bayer.cfa = p;
            bayer.layout = None;
        }
        return crate::demosaic::try_demosaic_bilinear(&bayer);
    }
    let p = demosaic_layout_bilinear(raw)?;
    let mut out = RgbImage::zeros(p.rows, p.cols);
    for (name, dst) in [("r", &mut out.r), ("g", &mut out.g), ("b", &mut out.b)] {
        let plane = p.plane(name).ok_or_else(|| {
            CoreError::invalid(
                "demosaic",
                format!(
                    "the CFA {} has no '{name}' filter, so it gives no RGB image",
                    raw.cfa_layout().name()
                ),
            )
        })?;
        dst.copy_from_slice(plane);
    }
    Ok(out)
}
