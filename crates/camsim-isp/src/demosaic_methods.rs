//! Demosaicking methods beside bilinear, chosen by [`DemosaicMethod`] (ISETCam `ipSet(ip,
//! 'demosaic method', ...)`: `'bilinear'`, `'laplacian'`, `'adaptive laplacian'`).
//!
//! - [`DemosaicMethod::Malvar`]: gradient-corrected linear interpolation, H. S. Malvar, L. He,
//!   R. Cutler, "High-quality linear interpolation for demosaicing of Bayer-patterned color
//!   images", ICASSP 2004, vol. 3, pp. 485-488. Each missing colour is the bilinear estimate plus a
//!   gain times the discrete Laplacian of the colour sampled at the pixel (gains alpha = 1/2,
//!   beta = 5/8, gamma = 3/4: the paper's Figure 2 kernels, 5 x 5, in eighths).
//! - [`DemosaicMethod::AdaptiveLaplacian`]: J. F. Hamilton Jr. and J. E. Adams Jr., "Adaptive color
//!   plan interpolation in single sensor color electronic camera", US Patent 5,629,734 (1997), the
//!   method ISETCam calls `'adaptive laplacian'`. Green at a red/blue site is interpolated along the
//!   direction (horizontal or vertical) with the smaller gradient
//!   `|G_-1 - G_+1| + |2 C_0 - C_-2 - C_+2|`, with a Laplacian correction from the site's own colour;
//!   red/blue then follow the colour differences to the full green plane (along the row/column at a
//!   green site, along the diagonal with the smaller gradient at a blue/red site).
//!
//! Both methods reproduce an image whose every channel is a linear function of (row, col)
//! exactly at least two (Malvar) or three (Hamilton-Adams) pixels from the border (every
//! correction term is a second difference),
//! keep the sampled values, and keep constant images constant everywhere: the image is extended
//! past its border by mirror reflection about the edge pixel (`-k -> k`), which keeps the Bayer
//! phase.

use crate::demosaic::{demosaic_bilinear, RgbImage};
use camsim_core::error::{CoreError, Result};
use camsim_core::names::{NameTable, Named};
use camsim_core::{CfaPattern, RawImage};
use rayon::prelude::*;
use std::fmt;
use std::str::FromStr;

/// A demosaicking method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DemosaicMethod {
    /// Bilinear interpolation (the paper's method; [`demosaic_bilinear`]).
    #[default]
    Bilinear,
    /// Malvar-He-Cutler 2004 gradient-corrected linear interpolation (ISETCam `'laplacian'`).
    Malvar,
    /// Hamilton-Adams 1997 adaptive colour-plane interpolation (ISETCam `'adaptive laplacian'`).
    AdaptiveLaplacian,
}

impl DemosaicMethod {
    /// Every method, in the order of [`DEMOSAIC_METHODS`].
    pub const ALL: [DemosaicMethod; 3] = {
        let e = DEMOSAIC_METHODS.entries;
        [e[0].value, e[1].value, e[2].value]
    };

    /// The method's name in [`DEMOSAIC_METHODS`] (`bilinear`, `malvar`, `adaptive-laplacian`).
    pub fn name(self) -> &'static str {
        DEMOSAIC_METHODS.name_of(self).unwrap_or("bilinear")
    }
}

impl fmt::Display for DemosaicMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for DemosaicMethod {
    type Err = CoreError;
    /// A name of [`DEMOSAIC_METHODS`] (ISETCam's `laplacian` and `adaptive laplacian` too).
    fn from_str(s: &str) -> Result<Self> {
        DEMOSAIC_METHODS.get(s)
    }
}

/// The demosaicking methods by name (`--demosaic`, Python's `method=`).
pub const DEMOSAIC_METHODS: NameTable<DemosaicMethod> = NameTable {
    family: "demosaic method",
    entries: &[
        Named {
            name: "bilinear",
            aliases: &["iebilinear"],
            about: "bilinear interpolation (the paper's method)",
            value: DemosaicMethod::Bilinear,
        },
        Named {
            name: "malvar",
            aliases: &["laplacian", "malvar-he-cutler", "mhc"],
            about: "Malvar-He-Cutler 2004 gradient-corrected linear (ISETCam 'laplacian')",
            value: DemosaicMethod::Malvar,
        },
        Named {
            name: "adaptive-laplacian",
            aliases: &["hamilton-adams", "adaptive"],
            about: "Hamilton-Adams 1997 adaptive colour planes (ISETCam 'adaptive laplacian')",
            value: DemosaicMethod::AdaptiveLaplacian,
        },
    ],
};

/// Demosaic `raw` (black level subtracted) with `method`. Errors when `raw.dn` does not hold
/// `rows * cols` values or the output would not fit in memory.
pub fn demosaic(raw: &RawImage, method: DemosaicMethod) -> Result<RgbImage> {
    raw.require_bayer("demosaic")?;
    if raw.dn.len() != raw.rows * raw.cols {
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
    camsim_core::mem::check_alloc(
        (raw.rows * raw.cols * 12) as u64,
        "the demosaicked RGB image",
    )?;
    // The 5 x 5 methods need 3 pixels on each axis for the mirror extension; smaller images (and
    // the bilinear method) take the bilinear path.
    if method == DemosaicMethod::Bilinear || raw.rows < PAD + 1 || raw.cols < PAD + 1 {
        return Ok(demosaic_bilinear(raw));
    }
    camsim_core::mem::check_alloc(
        ((raw.rows + 2 * PAD) * (raw.cols + 2 * PAD) * 8) as u64,
        "the padded mosaic",
    )?;
    let pad = Padded::from_raw(raw);
    Ok(match method {
        DemosaicMethod::Malvar => malvar(&pad, raw.cfa),
        _ => hamilton_adams(&pad, raw.cfa),
    })
}

/// Border extension on each side, pixels (even, so the Bayer phase is unchanged).
const PAD: usize = 2;

/// A plane extended by `PAD` pixels on each side by reflection about the edge pixel.
struct Padded {
    rows: usize,
    cols: usize,
    /// Row stride, `cols + 2 PAD`.
    stride: usize,
    v: Vec<f32>,
}

/// Mirror index about the edge pixels: `-k -> k`, `n - 1 + k -> n - 1 - k` (needs `n > PAD`).
fn reflect(i: isize, n: usize) -> usize {
    let n = n as isize;
    let j = if i < 0 {
        -i
    } else if i >= n {
        2 * (n - 1) - i
    } else {
        i
    };
    j as usize
}

impl Padded {
    fn from_fn(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f32 + Sync) -> Padded {
        let stride = cols + 2 * PAD;
        let mut v = vec![0.0f32; (rows + 2 * PAD) * stride];
        v.par_chunks_mut(stride).enumerate().for_each(|(py, line)| {
            let y = reflect(py as isize - PAD as isize, rows);
            for (px, o) in line.iter_mut().enumerate() {
                *o = f(y, reflect(px as isize - PAD as isize, cols));
            }
        });
        Padded {
            rows,
            cols,
            stride,
            v,
        }
    }

    fn from_raw(raw: &RawImage) -> Padded {
        let black = raw.black_level_dn as f32;
        let cols = raw.cols;
        Padded::from_fn(raw.rows, raw.cols, |y, x| {
            raw.dn[y * cols + x] as f32 - black
        })
    }

    /// Index of image pixel (y, x) in `v`.
    #[inline]
    fn idx(&self, y: usize, x: usize) -> usize {
        (y + PAD) * self.stride + x + PAD
    }
}

/// Channel indices at row `y`, by column parity: the pixel's own colour, the colour of its row
/// neighbours and of its column neighbours (both green at a red/blue site; red and blue, one
/// each, at a green site).
fn row_channels(cfa: CfaPattern, y: usize) -> ([usize; 2], [usize; 2], [usize; 2]) {
    let own = [cfa.channel_at(y, 0).index(), cfa.channel_at(y, 1).index()];
    let horiz = [own[1], own[0]];
    let vert = [
        cfa.channel_at(y + 1, 0).index(),
        cfa.channel_at(y + 1, 1).index(),
    ];
    (own, horiz, vert)
}

/// Malvar-He-Cutler 2004, Figure 2 kernels (weights in eighths).
#[allow(clippy::needless_range_loop)]
fn malvar(p: &Padded, cfa: CfaPattern) -> RgbImage {
    let (rows, cols) = (p.rows, p.cols);
    let mut out = RgbImage::zeros(rows, cols);
    let s = p.stride;
    let v = &p.v;
    out.r
        .par_chunks_mut(cols)
        .zip(out.g.par_chunks_mut(cols))
        .zip(out.b.par_chunks_mut(cols))
        .enumerate()
        .for_each(|(y, ((rr, gr), br))| {
            let (own_of, horiz_of, vert_of) = row_channels(cfa, y);
            for x in 0..cols {
                let i = p.idx(y, x);
                let c = v[i];
                let (n1, s1, w1, e1) = (v[i - s], v[i + s], v[i - 1], v[i + 1]);
                let (n2, s2, w2, e2) = (v[i - 2 * s], v[i + 2 * s], v[i - 2], v[i + 2]);
                let diag = v[i - s - 1] + v[i - s + 1] + v[i + s - 1] + v[i + s + 1];
                let (own, h, vc) = (own_of[x & 1], horiz_of[x & 1], vert_of[x & 1]);
                let mut px = [0.0f32; 3];
                px[own] = c;
                if h == vc {
                    // Red/blue site: green (alpha = 1/2) and the opposite colour (gamma = 3/4).
                    let far = n2 + s2 + w2 + e2;
                    px[h] = (4.0 * c + 2.0 * (n1 + s1 + w1 + e1) - far) * 0.125;
                    px[3 - own - h] = (6.0 * c + 2.0 * diag - 1.5 * far) * 0.125;
                } else {
                    // Green site (beta = 5/8): the row colour and the column colour.
                    px[h] =
                        (5.0 * c + 4.0 * (w1 + e1) - (w2 + e2) - diag + 0.5 * (n2 + s2)) * 0.125;
                    px[vc] =
                        (5.0 * c + 4.0 * (n1 + s1) - (n2 + s2) - diag + 0.5 * (w2 + e2)) * 0.125;
                }
                rr[x] = px[0];
                gr[x] = px[1];
                br[x] = px[2];
            }
        });
    out
}

/// Hamilton-Adams 1997: directional green with a Laplacian correction, then red/blue from the
/// colour differences to green.
#[allow(clippy::needless_range_loop)]
fn hamilton_adams(p: &Padded, cfa: CfaPattern) -> RgbImage {
    let (rows, cols) = (p.rows, p.cols);
    let s = p.stride;
    let v = &p.v;
    // Pass 1: the full green plane.
    let mut green = vec![0.0f32; rows * cols];
    green
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(y, line)| {
            let (own_of, _, _) = row_channels(cfa, y);
            for (x, o) in line.iter_mut().enumerate() {
                let i = p.idx(y, x);
                let c = v[i];
                if own_of[x & 1] == 1 {
                    *o = c;
                    continue;
                }
                let lap_h = 2.0 * c - v[i - 2] - v[i + 2];
                let lap_v = 2.0 * c - v[i - 2 * s] - v[i + 2 * s];
                let grad_h = (v[i - 1] - v[i + 1]).abs() + lap_h.abs();
                let grad_v = (v[i - s] - v[i + s]).abs() + lap_v.abs();
                let g_h = 0.5 * (v[i - 1] + v[i + 1]) + 0.25 * lap_h;
                let g_v = 0.5 * (v[i - s] + v[i + s]) + 0.25 * lap_v;
                *o = if grad_h < grad_v {
                    g_h
                } else if grad_v < grad_h {
                    g_v
                } else {
                    0.5 * (g_h + g_v)
                };
            }
        });
    let gp = Padded::from_fn(rows, cols, |y, x| green[y * cols + x]);
    let g = &gp.v;
    // Pass 2: red and blue.
    let mut out = RgbImage::zeros(rows, cols);
    out.r
        .par_chunks_mut(cols)
        .zip(out.g.par_chunks_mut(cols))
        .zip(out.b.par_chunks_mut(cols))
        .enumerate()
        .for_each(|(y, ((rr, gr), br))| {
            let (own_of, horiz_of, vert_of) = row_channels(cfa, y);
            for x in 0..cols {
                let i = p.idx(y, x);
                let (c, g0) = (v[i], g[i]);
                let (own, h, vc) = (own_of[x & 1], horiz_of[x & 1], vert_of[x & 1]);
                let mut px = [0.0f32; 3];
                px[1] = g0;
                px[own] = c;
                if own == 1 {
                    // Green site: colour difference to green, averaged along the row / column.
                    px[h] = g0 + 0.5 * ((v[i - 1] - g[i - 1]) + (v[i + 1] - g[i + 1]));
                    px[vc] = g0 + 0.5 * ((v[i - s] - g[i - s]) + (v[i + s] - g[i + s]));
                } else {
                    // Red/blue site: the opposite colour along the diagonal with the smaller gradient.
                    let (a, b, c2, d) = (i - s - 1, i + s + 1, i - s + 1, i + s - 1);
                    let lap_n = 2.0 * g0 - g[a] - g[b];
                    let lap_p = 2.0 * g0 - g[c2] - g[d];
                    let grad_n = (v[a] - v[b]).abs() + lap_n.abs();
                    let grad_p = (v[c2] - v[d]).abs() + lap_p.abs();
                    let est_n = 0.5 * (v[a] + v[b]) + 0.5 * lap_n;
                    let est_p = 0.5 * (v[c2] + v[d]) + 0.5 * lap_p;
                    px[3 - own - 1] = if grad_n < grad_p {
                        est_n
                    } else if grad_p < grad_n {
                        est_p
                    } else {
                        0.5 * (est_n + est_p)
                    };
                }
                rr[x] = px[0];
                gr[x] = px[1];
                br[x] = px[2];
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::demosaic::tests::{mosaic, PATTERNS};

    #[test]
    fn names_parse_and_unknown_is_an_error() {
        for m in DemosaicMethod::ALL {
            assert_eq!(m.name().parse::<DemosaicMethod>().unwrap(), m);
        }
        assert_eq!(
            "adaptive laplacian".parse::<DemosaicMethod>().unwrap(),
            DemosaicMethod::AdaptiveLaplacian
        );
        assert_eq!(
            "Laplacian".parse::<DemosaicMethod>().unwrap(),
            DemosaicMethod::Malvar
        );
        assert!("ahd2"
            .parse::<DemosaicMethod>()
            .unwrap_err()
            .to_string()
            .contains("ahd2"));
    }

    #[test]
    fn constants_stay_constant_everywhere() {
        let levels = [1000.0, 2500.0, 400.0];
        for m in DemosaicMethod::ALL {
            for cfa in PATTERNS {
                for (rows, cols) in [(7, 9), (8, 8), (3, 3), (2, 6)] {
                    let raw = mosaic(rows, cols, cfa, 64.0, |_, _, ch| levels[ch]);
                    let rgb = demosaic(&raw, m).unwrap();
                    for (ch, level) in levels.iter().enumerate() {
                        assert!(
                            rgb.plane(ch).iter().all(|v| *v == *level as f32),
                            "{m} {cfa:?} {rows}x{cols} ch {ch}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn linear_ramps_are_exact_in_the_interior_and_samples_are_kept() {
        // Every correction term is a second difference, zero on f = a + b row + c col per channel.
        let coef = [(100.0, 3.0, 5.0), (200.0, 7.0, 2.0), (50.0, 1.0, 11.0)];
        let f = |y: usize, x: usize, ch: usize| {
            coef[ch].0 + coef[ch].1 * y as f64 + coef[ch].2 * x as f64
        };
        for m in DemosaicMethod::ALL {
            for cfa in PATTERNS {
                let (rows, cols) = (14, 17);
                let raw = mosaic(rows, cols, cfa, 16.0, f);
                let rgb = demosaic(&raw, m).unwrap();
                for y in 0..rows {
                    for x in 0..cols {
                        let px = rgb.at(y, x);
                        let own = cfa.channel_at(y, x).index();
                        assert_eq!(px[own] as f64, f(y, x, own), "{m} keeps the sample");
                        // Malvar reads two pixels out, Hamilton-Adams' red/blue read green that
                        // was itself interpolated from two pixels further: three.
                        let k = if m == DemosaicMethod::AdaptiveLaplacian {
                            3
                        } else {
                            2
                        };
                        if y >= k && x >= k && y + k < rows && x + k < cols {
                            for (ch, p) in px.iter().enumerate() {
                                assert!(
                                    (*p as f64 - f(y, x, ch)).abs() < 1e-3,
                                    "{m} {cfa:?} ({y},{x}) ch {ch}: {p} vs {}",
                                    f(y, x, ch)
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn malvar_kernel_weights_match_the_paper() {
        // An impulse of 800 at a red site of RGGB: the response at each neighbour is the paper's
        // kernel weight (in eighths) times 100, read off the kernel centred on that neighbour.
        let (rows, cols) = (11, 11);
        let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 16).unwrap();
        raw.dn[4 * cols + 4] = 800; // (4,4) red
        let rgb = demosaic(&raw, DemosaicMethod::Malvar).unwrap();
        // Green at the red site itself: centre weight 4/8.
        assert_eq!(rgb.at(4, 4)[1], 400.0);
        // Green at the red site (4,6) sees this red two pixels along the row: weight -1/8.
        assert_eq!(rgb.at(4, 6)[1], -100.0);
        // Blue at the red site: centre weight 6/8; blue at red (4,6): -3/2 / 8.
        assert_eq!(rgb.at(4, 4)[2], 600.0);
        assert_eq!(rgb.at(4, 6)[2], -150.0);
        // Red at green (4,5) (red row): the red neighbour along the row has weight 4/8.
        assert_eq!(rgb.at(4, 5)[0], 400.0);
        // Red at green (3,4) (blue row, red column): red above/below weight 4/8.
        assert_eq!(rgb.at(3, 4)[0], 400.0);
        // Red at blue (5,5): diagonal weight 2/8.
        assert_eq!(rgb.at(5, 5)[0], 200.0);
    }

    #[test]
    fn adaptive_interpolates_along_an_edge_not_across_it() {
        // A vertical step edge in all channels (columns < 6 dark, >= 6 bright). Bilinear and
        // Malvar blur green across it at the red/blue sites next to the edge; Hamilton-Adams picks
        // the vertical direction there (zero vertical gradient) and keeps green exact.
        let (rows, cols) = (12, 12);
        for cfa in PATTERNS {
            let raw = mosaic(
                rows,
                cols,
                cfa,
                0.0,
                |_, x, _| if x < 6 { 100.0 } else { 1000.0 },
            );
            let rgb = demosaic(&raw, DemosaicMethod::AdaptiveLaplacian).unwrap();
            for y in 2..rows - 2 {
                for x in 2..cols - 2 {
                    let truth = if x < 6 { 100.0 } else { 1000.0 };
                    assert_eq!(rgb.at(y, x)[1], truth, "{cfa:?} ({y},{x})");
                }
            }
            let bil = demosaic(&raw, DemosaicMethod::Bilinear).unwrap();
            assert!((0..rows * cols).any(|i| bil.g[i] != 100.0 && bil.g[i] != 1000.0));
        }
    }

    #[test]
    fn malformed_raw_is_an_error() {
        let mut raw = RawImage::new(6, 6, CfaPattern::Rggb, 12).unwrap();
        raw.dn.pop();
        assert!(demosaic(&raw, DemosaicMethod::Malvar)
            .unwrap_err()
            .to_string()
            .contains("35 values"));
    }
}
