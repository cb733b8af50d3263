//! Every colour filter array to a display image: which ISP path a CFA takes, and the paths that
//! are not the RGB one (monochrome, RCCC, multichannel).
//!
//! [`CfaFamily::of`] sorts a tile by its filters:
//! - **rgb**: filters r, g, b only (Bayer, Quad Bayer, any r/g/b tile): demosaic, white balance and
//!   the 3x3 QE colour matrix ([`crate::ColorPipeline`]).
//! - **rgbw**: r, g, b and w: R, G, B interpolated per channel and W used as the luminance
//!   ([`crate::cfa_general::rgbw_to_rgb`], the W-guided fusion), then the RGB path.
//! - **monochrome**: one filter (`[["w"]]`, a bare sensor): no demosaic; the preview is grey, its
//!   linear value the pixel's DN above black times the exposure scale ([`mono_rgb`]).
//! - **rccc**: a 2x2 tile of one r and three w (clear) cells, the automotive sensor. ISETCam's
//!   'analog rccc' idea (its `demosaicRCCC`, after Analog Devices EE-358): the clear channel is the
//!   luminance, its value at the R sites interpolated ([`rccc_clear`], [`RcccClear::Analog`]: the
//!   EE-358 cross kernel; [`RcccClear::EdgeAware`]: Hamilton-Adams directional interpolation), the
//!   red channel interpolated from the R sites (per-filter bilinear) and scaled by the white
//!   balance so that a neutral surface has red = clear. The preview shows (red, clear, clear):
//!   grey where the surface is neutral, red where it reflects more red than a neutral, cyan-grey
//!   where less: the one colour difference an RCCC sensor measures ([`rccc_rgb`]).
//! - **multichannel**: anything else (CMY, CMYG, RGB-IR, RGBC, N-channel multispectral tiles):
//!   every channel interpolated by the per-filter bilinear ([`crate::cfa_general::demosaic_layout_bilinear`]),
//!   then a 3 x N matrix to linear sRGB fitted by least squares on the ColorChecker under the
//!   scene illuminant from the sensor's own spectral QE ([`ChannelTransform::fit`]).
//!
//! The linear images of the three non-RGB paths are rendered by [`render_linear_srgb8`]:
//! exposure scale (automatic: the 99th percentile of the luminance at
//! [`crate::color::AUTO_EXPOSURE_P99_Y`]), then the sRGB transfer function (IEC 61966-2-1).

use crate::cfa_general::demosaic_layout_bilinear;
use crate::color::{bradford_adaptation, Mat3};
use crate::coring::{render_display8, SRGB_LUMINANCE_WEIGHTS};
use crate::demosaic::RgbImage;
use camsim_analysis::color_difference::{ciede2000, xyz_to_lab};
use camsim_core::colorimetry::{self, Cmfs};
use camsim_core::error::{CoreError, Result};
use camsim_core::{tables, CfaLayout, RawImage, Spectrum, WavelengthGrid};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Which ISP path a CFA takes (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CfaFamily {
    /// Filters r, g, b only.
    Rgb,
    /// Filters r, g, b and w.
    Rgbw,
    /// One filter.
    Monochrome,
    /// A 2x2 tile of one r and three w (clear) cells.
    Rccc,
    /// Any other set of filters.
    Multichannel,
}

impl CfaFamily {
    /// The family of `layout` (module docs).
    pub fn of(layout: &CfaLayout) -> CfaFamily {
        let f = layout.filters();
        let has = |n: &str| f.iter().any(|x| x == n);
        let rgb = has("r") && has("g") && has("b");
        if f.len() == 1 {
            CfaFamily::Monochrome
        } else if rgb && f.len() == 3 {
            CfaFamily::Rgb
        } else if rgb && f.len() == 4 && has("w") {
            CfaFamily::Rgbw
        } else if f.len() == 2 && has("r") && has("w") && layout.rows() == 2 && layout.cols() == 2 {
            let r = layout.filter_index("r").unwrap_or(0);
            let reds = (0..2)
                .flat_map(|y| (0..2).map(move |x| (y, x)))
                .filter(|&(y, x)| layout.filter_at(y, x) == r)
                .count();
            if reds == 1 {
                CfaFamily::Rccc
            } else {
                CfaFamily::Multichannel
            }
        } else {
            CfaFamily::Multichannel
        }
    }

    /// Short name (`rgb`, `rgbw`, `monochrome`, `rccc`, `multichannel`).
    pub fn name(self) -> &'static str {
        match self {
            CfaFamily::Rgb => "rgb",
            CfaFamily::Rgbw => "rgbw",
            CfaFamily::Monochrome => "monochrome",
            CfaFamily::Rccc => "rccc",
            CfaFamily::Multichannel => "multichannel",
        }
    }
}

/// The raw's grid is whole ([`crate::cfa_general::check`]) and its three demosaicked planes fit.
fn check(raw: &RawImage) -> Result<()> {
    crate::cfa_general::check(raw)?;
    camsim_core::mem::check_alloc((raw.rows * raw.cols * 12) as u64, "the demosaicked planes")
}

/// A monochrome frame as a grey image: every channel the pixel's DN above black (no demosaic).
/// Any frame can be shown so (a mosaic then shows its filter pattern).
pub fn mono_rgb(raw: &RawImage) -> Result<RgbImage> {
    check(raw)?;
    let black = raw.black_level_dn as f32;
    let v: Vec<f32> = raw.dn.iter().map(|&d| d as f32 - black).collect();
    Ok(RgbImage {
        rows: raw.rows,
        cols: raw.cols,
        r: v.clone(),
        g: v.clone(),
        b: v,
    })
}

/// How [`rccc_clear`] fills the clear channel at the R sites.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RcccClear {
    /// ISETCam's `demosaicRCCC` idea (Analog Devices EE-358): the cross kernel
    /// [-1 2 4 2 -1] / 8 along rows and columns of the mosaic, i.e. the mean of the four clear
    /// neighbours plus an eighth of the red Laplacian (here of the white-balanced red).
    Analog,
    /// Hamilton-Adams (US 5,629,734, 1997) with clear as the dense channel: along the row or the
    /// column, whichever has the smaller gradient |C- - C+| + |2R - R-- - R++|, the mean of the two
    /// clear neighbours plus a quarter of the red second difference (both when equal). A step edge
    /// along a row or a column is kept exact where the cross kernel blurs it.
    #[default]
    EdgeAware,
}

impl RcccClear {
    /// `analog` or `edge-aware`.
    pub fn name(self) -> &'static str {
        match self {
            RcccClear::Analog => "analog",
            RcccClear::EdgeAware => "edge-aware",
        }
    }
}

impl std::str::FromStr for RcccClear {
    type Err = CoreError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "analog" => Ok(RcccClear::Analog),
            "edge-aware" | "edge_aware" | "edgeaware" => Ok(RcccClear::EdgeAware),
            other => Err(CoreError::UnknownName {
                family: "RCCC clear interpolation".into(),
                name: other.to_string(),
                known: "analog, edge-aware".into(),
            }),
        }
    }
}

/// Mirror index `i` into 0..n (n >= 3): -1 -> 1, -2 -> 2, n -> n - 2, n + 1 -> n - 3. Keeps the
/// parity, so a mirrored pixel of a 2-periodic tile has the same filter.
#[inline]
fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let j = if i < 0 {
        -i
    } else if i >= n {
        2 * (n - 1) - i
    } else {
        i
    };
    j.clamp(0, n - 1) as usize
}

fn rccc_layout(raw: &RawImage) -> Result<CfaLayout> {
    let layout = raw.cfa_layout();
    if CfaFamily::of(&layout) != CfaFamily::Rccc {
        return Err(CoreError::invalid(
            "RCCC demosaic",
            format!(
                "the CFA {} is not a 2x2 tile of one r and three w (clear) cells",
                layout.name()
            ),
        ));
    }
    if raw.rows < 3 || raw.cols < 3 {
        return Err(CoreError::invalid(
            "RCCC demosaic",
            format!(
                "a {} x {} frame is too small (at least 3 x 3 pixels)",
                raw.rows, raw.cols
            ),
        ));
    }
    Ok(layout)
}

/// The clear channel of an RCCC frame at full resolution, DN above black: clear sites keep
/// their value, R sites get it by `method` ([`RcccClear`]), the red values there multiplied by
/// `red_gain` (the white balance that makes a neutral's red equal its clear) so that red and
/// clear differences are comparable. Borders mirror the image.
pub fn rccc_clear(raw: &RawImage, red_gain: f64, method: RcccClear) -> Result<Vec<f32>> {
    check(raw)?;
    let layout = rccc_layout(raw)?;
    let r_index = layout.filter_index("r").unwrap_or(0);
    let (rows, cols) = (raw.rows, raw.cols);
    let black = raw.black_level_dn as f32;
    let k = red_gain as f32;
    let mut out = vec![0.0f32; rows * cols];
    out.par_chunks_mut(cols).enumerate().for_each(|(y, line)| {
        let v = |yy: isize, xx: isize| {
            raw.dn[mirror(yy, rows) * cols + mirror(xx, cols)] as f32 - black
        };
        for (x, o) in line.iter_mut().enumerate() {
            let (yi, xi) = (y as isize, x as isize);
            if layout.filter_at(y, x) != r_index {
                *o = v(yi, xi);
                continue;
            }
            let r0 = k * v(yi, xi);
            let (cl, cr, cu, cd) = (v(yi, xi - 1), v(yi, xi + 1), v(yi - 1, xi), v(yi + 1, xi));
            let lap_h = 2.0 * r0 - k * (v(yi, xi - 2) + v(yi, xi + 2));
            let lap_v = 2.0 * r0 - k * (v(yi - 2, xi) + v(yi + 2, xi));
            *o = match method {
                // (2 (cl + cr + cu + cd) + 4 r0 - (r--, r++ of both axes)) / 8.
                RcccClear::Analog => (cl + cr + cu + cd) / 4.0 + (lap_h + lap_v) / 8.0,
                RcccClear::EdgeAware => {
                    let dh = (cl - cr).abs() + lap_h.abs();
                    let dv = (cu - cd).abs() + lap_v.abs();
                    let eh = (cl + cr) / 2.0 + lap_h / 4.0;
                    let ev = (cu + cd) / 2.0 + lap_v / 4.0;
                    if dh < dv {
                        eh
                    } else if dv < dh {
                        ev
                    } else {
                        (eh + ev) / 2.0
                    }
                }
            };
        }
    });
    Ok(out)
}

/// An RCCC frame as (red, clear, clear), DN above black: red interpolated from the R sites
/// (per-filter bilinear) times `red_gain`, clear from [`rccc_clear`]. A neutral surface has
/// red = clear (grey); see the module docs.
pub fn rccc_rgb(raw: &RawImage, red_gain: f64, method: RcccClear) -> Result<RgbImage> {
    let clear = rccc_clear(raw, red_gain, method)?;
    let planes = demosaic_layout_bilinear(raw)?;
    let red = planes
        .plane("r")
        .ok_or_else(|| CoreError::invalid("RCCC demosaic", "no r plane"))?;
    let k = red_gain as f32;
    Ok(RgbImage {
        rows: raw.rows,
        cols: raw.cols,
        r: red.iter().map(|v| v * k).collect(),
        g: clear.clone(),
        b: clear,
    })
}

/// Relative response of a filter with QE `qe` (on `grid`) to a perfect white under `illuminant`
/// (on `grid`): sum QE E lambda d lambda (photon counts, as [`crate::camera_response`]).
pub fn white_response(qe: &[f64], illuminant: &[f64], grid: &WavelengthGrid) -> f64 {
    (0..grid.len().min(qe.len()).min(illuminant.len()))
        .map(|b| qe[b] * illuminant[b] * grid.wavelength_nm(b))
        .sum::<f64>()
        * grid.step_nm
}

/// The RCCC white balance: clear's over red's response to a perfect white under `illuminant`
/// (so that a neutral surface has red x gain = clear). Errors when either sees no light.
pub fn rccc_red_gain(
    qe_red: &[f64],
    qe_clear: &[f64],
    grid: &WavelengthGrid,
    illuminant: &Spectrum,
) -> Result<f64> {
    let e = illuminant.sample(grid);
    let (r, c) = (
        white_response(qe_red, &e, grid),
        white_response(qe_clear, &e, grid),
    );
    if !(r > 0.0 && c > 0.0 && (c / r).is_finite()) {
        return Err(CoreError::invalid(
            "RCCC white balance",
            format!("a white surface under this illuminant gives red {r:e}, clear {c:e}: both must see light"),
        ));
    }
    Ok(c / r)
}

/// A 3 x N matrix from the N channels of a multichannel CFA to linear sRGB (D65 white), fitted
/// on the ColorChecker (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelTransform {
    /// The channels (filter names), in the order of the matrix's columns.
    pub names: Vec<String>,
    /// Rows R, G, B of linear sRGB; one column per channel: sRGB = M c for camera values c
    /// normalised so that a perfect white's largest channel is 1 (any common scale of c only
    /// scales the image: the exposure scale takes it).
    pub to_linear_srgb: [Vec<f64>; 3],
    /// The camera values of a perfect white under the illuminant, largest = 1 (`M white` is the
    /// D65 white, R = G = B = 1: the white balance is in M).
    pub white_camera: Vec<f64>,
    /// CIEDE2000 of each ColorChecker patch between `M c` and its XYZ under the illuminant
    /// adapted to D65 (Bradford), both relative to the D65 white, patches 1-24.
    pub patch_delta_e2000: Vec<f64>,
}

impl ChannelTransform {
    /// Fit: `filter_qe[k]` is channel k's spectral QE on `grid`. Camera values of patch i are
    /// c_ik = sum QE_k E rho_i lambda d lambda (photon counts; ColorChecker reflectances
    /// N. Ohta 1997), scaled so the white's largest channel is 1. Targets: the patches' CIE 1931
    /// XYZ under E (white Y = 1), Bradford-adapted to D65 and taken to linear sRGB
    /// (IEC 61966-2-1). Each row of M minimises sum_i (M c_i - t_i)^2 subject to M mapping the
    /// white exactly onto the D65 white (white-point preserving least squares, Finlayson & Drew
    /// 1996; the KKT system, as [`crate::ColorPipeline::fit`] for three channels). Channels that
    /// are linear combinations of x_bar/lambda, y_bar/lambda, z_bar/lambda (the Luther condition)
    /// give an exact fit. Errors name a channel that sees no light or a degenerate set.
    pub fn fit(
        names: &[String],
        filter_qe: &[Vec<f64>],
        grid: &WavelengthGrid,
        illuminant: &Spectrum,
    ) -> Result<ChannelTransform> {
        let bad = |m: String| CoreError::invalid("multichannel colour fit", m);
        let n = filter_qe.len();
        if n == 0 || n != names.len() {
            return Err(bad(format!("{n} QE curves for {} channels", names.len())));
        }
        if let Some(k) = filter_qe
            .iter()
            .position(|q| q.len() != grid.len() || q.iter().any(|v| !v.is_finite()))
        {
            return Err(bad(format!(
                "channel '{}': its QE has {} values (finite ones) for a {}-band grid",
                names[k],
                filter_qe[k].len(),
                grid.len()
            )));
        }
        let illum = illuminant.sample(grid);
        let response = |rho: &[f64]| -> Vec<f64> {
            filter_qe
                .iter()
                .map(|qe| {
                    (0..grid.len())
                        .map(|b| qe[b] * illum[b] * rho[b] * grid.wavelength_nm(b))
                        .sum::<f64>()
                        * grid.step_nm
                })
                .collect()
        };
        let white = response(&vec![1.0; grid.len()]);
        if let Some(k) = white.iter().position(|v| !(*v > 0.0)) {
            return Err(bad(format!(
                "channel '{}' sees no light from a white surface under this illuminant",
                names[k]
            )));
        }
        let norm = white.iter().cloned().fold(0.0, f64::max);
        let white: Vec<f64> = white.iter().map(|v| v / norm).collect();
        let cmfs = Cmfs::on(grid);
        let white_xyz = cmfs.xyz(&illum);
        if !(white_xyz[1] > 0.0) {
            return Err(bad(
                "the illuminant has no luminance on this wavelength grid".into(),
            ));
        }
        let illum_white = white_xyz.map(|v| v / white_xyz[1]);
        let d65 = colorimetry::xyy_to_xyz(
            colorimetry::SRGB_WHITE_XY[0],
            colorimetry::SRGB_WHITE_XY[1],
            1.0,
        );
        let adapt = bradford_adaptation(illum_white, d65);
        let to_srgb =
            |xyz: [f64; 3]| colorimetry::xyz_to_linear_srgb(colorimetry::mat3_mul_vec(&adapt, xyz));
        let patches = tables::macbeth_reflectances();
        let mut cam = Vec::with_capacity(patches.len());
        let mut target = Vec::with_capacity(patches.len());
        for p in &patches {
            let rho = p.sample(grid);
            cam.push(response(&rho).iter().map(|v| v / norm).collect::<Vec<_>>());
            let rad: Vec<f64> = illum.iter().zip(&rho).map(|(e, r)| e * r).collect();
            target.push(to_srgb(cmfs.xyz(&rad).map(|v| v / white_xyz[1])));
        }
        let target_white = to_srgb(illum_white);
        // KKT: [C^T C  w; w^T 0] [m; mu] = [C^T t; t_w], one row of M at a time.
        let mut kkt = DMatrix::<f64>::zeros(n + 1, n + 1);
        for c in &cam {
            for p in 0..n {
                for q in 0..n {
                    kkt[(p, q)] += c[p] * c[q];
                }
            }
        }
        for p in 0..n {
            kkt[(p, n)] = white[p];
            kkt[(n, p)] = white[p];
        }
        let lu = kkt.lu();
        let mut m: [Vec<f64>; 3] = Default::default();
        for (row, m_row) in m.iter_mut().enumerate() {
            let mut rhs = DVector::<f64>::zeros(n + 1);
            for (c, t) in cam.iter().zip(&target) {
                for p in 0..n {
                    rhs[p] += c[p] * t[row];
                }
            }
            rhs[n] = target_white[row];
            let sol = lu
                .solve(&rhs)
                .filter(|s| s.iter().all(|v| v.is_finite()))
                .ok_or_else(|| {
                    bad(format!(
                        "the ColorChecker responses of the channels {} do not determine a 3 x {n} matrix (channels linearly dependent?)",
                        names.join(", ")
                    ))
                })?;
            *m_row = sol.iter().take(n).copied().collect();
        }
        let apply = |c: &[f64]| -> [f64; 3] {
            [0, 1, 2].map(|r| m[r].iter().zip(c).map(|(a, b)| a * b).sum())
        };
        let patch_delta_e2000 = cam
            .iter()
            .zip(&target)
            .map(|(c, t)| {
                let fit = colorimetry::linear_srgb_to_xyz(apply(c));
                let want = colorimetry::linear_srgb_to_xyz(*t);
                ciede2000(xyz_to_lab(fit, d65), xyz_to_lab(want, d65))
            })
            .collect();
        Ok(ChannelTransform {
            names: names.to_vec(),
            to_linear_srgb: m,
            white_camera: white,
            patch_delta_e2000,
        })
    }

    /// Mean CIEDE2000 over the 24 patches.
    pub fn delta_e2000_mean(&self) -> f64 {
        self.patch_delta_e2000.iter().sum::<f64>() / self.patch_delta_e2000.len().max(1) as f64
    }

    /// Largest CIEDE2000 over the 24 patches.
    pub fn delta_e2000_max(&self) -> f64 {
        self.patch_delta_e2000.iter().cloned().fold(0.0, f64::max)
    }

    /// Linear sRGB (in the frame's DN scale) of a multichannel frame: every channel by the
    /// per-filter bilinear, then `M c` per pixel. With `saturation_dn` (DN above black at which
    /// the raw clips), channel k is first clipped at `saturation_dn x white_camera[k]`, so that
    /// a clipped highlight renders as the white does, neutral (the RGB path clips at the
    /// AsShotNeutral alike). The frame's filters must be the transform's.
    pub fn apply(&self, raw: &RawImage, saturation_dn: Option<f64>) -> Result<RgbImage> {
        check(raw)?;
        let planes = demosaic_layout_bilinear(raw)?;
        let cols: Vec<&[f32]> = self
            .names
            .iter()
            .map(|n| {
                planes.plane(n).ok_or_else(|| {
                    CoreError::invalid(
                        "multichannel colour transform",
                        format!(
                            "fitted for channel '{n}', which the frame's CFA {} lacks",
                            raw.cfa_layout().name()
                        ),
                    )
                })
            })
            .collect::<Result<_>>()?;
        let m = self
            .to_linear_srgb
            .clone()
            .map(|r| r.iter().map(|v| *v as f32).collect::<Vec<f32>>());
        let clip: Vec<f32> = self
            .white_camera
            .iter()
            .map(|w| {
                saturation_dn
                    .filter(|s| *s > 0.0)
                    .map_or(f32::INFINITY, |s| (s * w) as f32)
            })
            .collect();
        let mut out = RgbImage::zeros(raw.rows, raw.cols);
        let px = |i: usize, row: &[f32]| -> f32 {
            row.iter()
                .zip(&cols)
                .zip(&clip)
                .map(|((a, p), c)| a * p[i].min(*c))
                .sum()
        };
        out.r
            .par_iter_mut()
            .zip(out.g.par_iter_mut())
            .zip(out.b.par_iter_mut())
            .enumerate()
            .for_each(|(i, ((r, g), b))| {
                *r = px(i, &m[0]);
                *g = px(i, &m[1]);
                *b = px(i, &m[2]);
            });
        Ok(out)
    }
}

/// The exposure scale that puts the 99th percentile of the luminance (sRGB weights) of a linear
/// sRGB image at [`crate::color::AUTO_EXPOSURE_P99_Y`] (1 for an image with no positive luminance); as
/// [`crate::ColorPipeline::auto_exposure_scale`], at most 2^20 pixels sampled.
pub fn auto_exposure_linear_srgb(img: &RgbImage) -> f64 {
    crate::color::p99_exposure_scale(img, SRGB_LUMINANCE_WEIGHTS)
}

/// Interleaved 8-bit sRGB of a linear sRGB image: each value clipped at `clip` (the saturation,
/// in the image's units; None: no clip) so clipped highlights stay neutral, times
/// `exposure_scale`, then the sRGB transfer function.
pub fn render_linear_srgb8(img: &RgbImage, exposure_scale: f64, clip: Option<f64>) -> Vec<u8> {
    let s = exposure_scale;
    let m: Mat3 = [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
    let c = clip.filter(|c| *c > 0.0).unwrap_or(f64::INFINITY);
    let encoder = crate::color::Srgb8Encoder::new();
    render_display8(
        img,
        &m,
        [c; 3],
        SRGB_LUMINANCE_WEIGHTS,
        None,
        crate::tone::ToneCurve::Clip,
        |v| encoder.encode(v),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(p: &[&[&str]]) -> CfaLayout {
        CfaLayout::from_names(
            &p.iter()
                .map(|r| r.iter().map(|c| c.to_string()).collect())
                .collect::<Vec<Vec<String>>>(),
        )
        .unwrap()
    }

    #[test]
    fn families() {
        assert_eq!(
            CfaFamily::of(&CfaLayout::parse("RGGB").unwrap()),
            CfaFamily::Rgb
        );
        assert_eq!(
            CfaFamily::of(&CfaLayout::parse("quad-bayer").unwrap()),
            CfaFamily::Rgb
        );
        assert_eq!(
            CfaFamily::of(&CfaLayout::parse("RGBW").unwrap()),
            CfaFamily::Rgbw
        );
        assert_eq!(CfaFamily::of(&names(&[&["w"]])), CfaFamily::Monochrome);
        assert_eq!(
            CfaFamily::of(&names(&[&["r", "clear"], &["clear", "clear"]])),
            CfaFamily::Rccc
        );
        assert_eq!(
            CfaFamily::of(&names(&[&["c", "y"], &["m", "g"]])),
            CfaFamily::Multichannel
        );
        assert_eq!(
            CfaFamily::of(&names(&[&["r", "g"], &["ir", "b"]])),
            CfaFamily::Multichannel
        );
        // Two reds in a 2x2 r/w tile is not RCCC.
        assert_eq!(
            CfaFamily::of(&names(&[&["r", "w"], &["w", "r"]])),
            CfaFamily::Multichannel
        );
    }

    #[test]
    fn mirror_keeps_parity() {
        for n in 3..7 {
            for i in -2..(n as isize + 2) {
                let j = mirror(i, n);
                assert!(j < n);
                assert_eq!((j as isize - i).rem_euclid(2), 0, "{i} -> {j} of {n}");
            }
        }
    }
}
