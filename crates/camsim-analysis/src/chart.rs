//! The Macbeth ColorChecker: the 24 patch regions from the chart's four outer corners (as
//! ISETCam's `chartRectangles`: patch centres by bilinear interpolation between the corners, a
//! square of a central fraction of the patch around each centre), patch statistics on raw and
//! demosaicked data, and line profiles (paper, Figure 5: a line through the gray series).
//!
//! Patches are numbered in the standard order (McCamy et al. 1976; X-Rite): 0 = dark skin at the
//! top left, row by row, 18 = white at the bottom left, 23 = black at the bottom right.

use crate::error::{AnalysisError, Result};
use crate::image::{cfa_channel_offset, cfa_channel_plane, check_rgb, Plane, Rect};
use crate::roi::{raw_rect_moments, rgb_rect_moments};
use camsim_core::{CfaChannel, RawImage};
use serde::{Deserialize, Serialize};

/// Patch rows of the chart.
pub const PATCH_ROWS: usize = 4;
/// Patch columns of the chart.
pub const PATCH_COLS: usize = 6;

/// Patch names in the standard order (McCamy, Marcus & Davidson 1976): camsim-core's table.
pub use camsim_core::tables::MACBETH_PATCH_NAMES as PATCH_NAMES;

/// The outer corners of the 4 x 6 patch grid in image coordinates `[x, y]` (columns, rows; pixel
/// (r, c) covers [c, c + 1) x [r, r + 1)), with the chart upright: dark skin at the top left,
/// white at the bottom left.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChartCorners {
    /// Outer corner of the dark-skin patch, [x, y] pixels.
    pub top_left: [f64; 2],
    /// Outer corner of the bluish-green patch, [x, y] pixels.
    pub top_right: [f64; 2],
    /// Outer corner of the black patch, [x, y] pixels.
    pub bottom_right: [f64; 2],
    /// Outer corner of the white patch, [x, y] pixels.
    pub bottom_left: [f64; 2],
}

/// As `--corners` takes them: `x,y,x,y,x,y,x,y` (dark skin, bluish green, black, white).
impl std::fmt::Display for ChartCorners {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c, d] = [
            self.top_left,
            self.top_right,
            self.bottom_right,
            self.bottom_left,
        ];
        write!(
            f,
            "{},{},{},{},{},{},{},{}",
            a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]
        )
    }
}

impl ChartCorners {
    /// From ISETCam's `cornerPoints` (rows of [col, row], 1-based MATLAB pixel indices, in the
    /// order lower-left (white), lower-right (black), upper-right, upper-left): pixel index k
    /// has its centre at k - 0.5 in our coordinates.
    pub fn from_isetcam(points: [[f64; 2]; 4]) -> ChartCorners {
        let p = |i: usize| [points[i][0] - 0.5, points[i][1] - 0.5];
        ChartCorners {
            bottom_left: p(0),
            bottom_right: p(1),
            top_right: p(2),
            top_left: p(3),
        }
    }

    /// The image point at chart coordinates (u, v) in [0, 1]^2 (u across, v down), by bilinear
    /// interpolation between the corners.
    pub fn point(&self, u: f64, v: f64) -> [f64; 2] {
        let mut o = [0.0; 2];
        for (k, ok) in o.iter_mut().enumerate() {
            let top = self.top_left[k] * (1.0 - u) + self.top_right[k] * u;
            let bottom = self.bottom_left[k] * (1.0 - u) + self.bottom_right[k] * u;
            *ok = top * (1.0 - v) + bottom * v;
        }
        o
    }

    /// Centre of patch (row, col) in image coordinates.
    pub fn patch_centre(&self, row: usize, col: usize) -> [f64; 2] {
        self.point(
            (col as f64 + 0.5) / PATCH_COLS as f64,
            (row as f64 + 0.5) / PATCH_ROWS as f64,
        )
    }

    /// End points of a line through the centres of patch row `row` (3 = the gray series), from
    /// the left to the right outer edge of the grid.
    pub fn row_line(&self, row: usize) -> ([f64; 2], [f64; 2]) {
        let v = (row as f64 + 0.5) / PATCH_ROWS as f64;
        (self.point(0.0, v), self.point(1.0, v))
    }

    fn check(&self) -> Result<()> {
        let all = [
            self.top_left,
            self.top_right,
            self.bottom_right,
            self.bottom_left,
        ];
        if all.iter().flatten().any(|v| !v.is_finite()) {
            return Err(AnalysisError::invalid(
                "chart corners",
                "a corner coordinate is not a finite number",
            ));
        }
        // Signed area (shoelace) must be clearly non-zero and the corners in clockwise image order.
        let mut area = 0.0;
        for i in 0..4 {
            let (a, b) = (all[i], all[(i + 1) % 4]);
            area += a[0] * b[1] - b[0] * a[1];
        }
        if area <= 0.0 {
            return Err(AnalysisError::invalid(
                "chart corners",
                "the corners do not enclose an upright chart (expected top-left, top-right, bottom-right, bottom-left in image coordinates)",
            ));
        }
        Ok(())
    }
}

/// One patch's region.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatchRegion {
    /// Patch number, 1..=24 in the standard order (X-Rite's and ISETCam's numbering: 1 dark
    /// skin, 19 white, 24 black).
    pub patch: usize,
    /// Patch name.
    pub name: String,
    /// Chart row (0 = top).
    pub row: usize,
    /// Chart column (0 = left).
    pub col: usize,
    /// Patch centre [x, y] in image coordinates.
    pub centre: [f64; 2],
    /// The pixels whose centres lie in the half-open square of side `fraction * patch size` about the centre.
    pub rect: Rect,
}

/// The 24 patch regions: squares of side `fraction` times the smaller patch pitch (mean of
/// opposite chart edges / 6 across, / 4 down) centred on each patch (ISETCam `chartRectangles`,
/// whose default fraction is 0.5). Errors if a region falls outside a `rows x cols` image or
/// holds no pixel.
pub fn chart_patch_rects(
    corners: &ChartCorners,
    fraction: f64,
    rows: usize,
    cols: usize,
) -> Result<Vec<PatchRegion>> {
    corners.check()?;
    if !(fraction > 0.0 && fraction <= 1.0) {
        return Err(AnalysisError::invalid(
            "chart patch fraction",
            format!("{fraction} is not in (0, 1]"),
        ));
    }
    let dist = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let pitch_x = 0.5
        * (dist(corners.top_left, corners.top_right)
            + dist(corners.bottom_left, corners.bottom_right))
        / PATCH_COLS as f64;
    let pitch_y = 0.5
        * (dist(corners.top_left, corners.bottom_left)
            + dist(corners.top_right, corners.bottom_right))
        / PATCH_ROWS as f64;
    let half = 0.5 * fraction * pitch_x.min(pitch_y);
    let mut out = Vec::with_capacity(24);
    for pr in 0..PATCH_ROWS {
        for pc in 0..PATCH_COLS {
            let index = pr * PATCH_COLS + pc;
            let patch = index + 1;
            let centre = corners.patch_centre(pr, pc);
            // Pixels with centre k + 0.5 in [c - half, c + half).
            let lo = |c: f64| (c - half - 0.5).ceil();
            let hi = |c: f64| (c + half - 0.5).ceil() - 1.0;
            let (c0, c1, r0, r1) = (lo(centre[0]), hi(centre[0]), lo(centre[1]), hi(centre[1]));
            if c1 < c0 || r1 < r0 {
                return Err(AnalysisError::invalid(
                    "chart",
                    format!(
                        "patch {patch} ({}) holds no pixel: the chart is too small",
                        PATCH_NAMES[index]
                    ),
                ));
            }
            if c0 < 0.0 || r0 < 0.0 || c1 >= cols as f64 || r1 >= rows as f64 {
                return Err(AnalysisError::invalid(
                    "chart",
                    format!("patch {patch} ({}) at [{:.1}, {:.1}] lies outside the {rows} x {cols} image", PATCH_NAMES[index], centre[0], centre[1]),
                ));
            }
            let rect = Rect::new(
                r0 as usize,
                c0 as usize,
                (r1 - r0) as usize + 1,
                (c1 - c0) as usize + 1,
            );
            out.push(PatchRegion {
                patch,
                name: PATCH_NAMES[index].to_string(),
                row: pr,
                col: pc,
                centre,
                rect,
            });
        }
    }
    Ok(out)
}

/// Per-channel statistics of one patch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatchStats {
    /// Patch number, 1..=24 in the standard order (X-Rite's and ISETCam's numbering: 1 dark
    /// skin, 19 white, 24 black).
    pub patch: usize,
    /// Patch name.
    pub name: String,
    /// The region measured.
    pub rect: Rect,
    /// Mean per channel (R, G, B): DN above black on raw data, the planes' unit otherwise.
    pub mean: [f64; 3],
    /// Sample standard deviation (n - 1) per channel.
    pub std: [f64; 3],
    /// Pixels per channel.
    pub n: [usize; 3],
}

/// Patch statistics on a raw mosaic: each CFA channel's own pixels inside each patch region
/// (both greens pooled), black subtracted.
pub fn chart_patch_stats_raw(
    raw: &RawImage,
    corners: &ChartCorners,
    fraction: f64,
) -> Result<Vec<PatchStats>> {
    chart_patch_rects(corners, fraction, raw.rows, raw.cols)?
        .into_iter()
        .map(|p| {
            let m = raw_rect_moments(raw, &p.rect)?;
            Ok(PatchStats {
                patch: p.patch,
                name: p.name,
                rect: p.rect,
                mean: m.map(|v| v.mean()),
                std: m.map(|v| v.std()),
                n: m.map(|v| v.n),
            })
        })
        .collect()
}

/// Patch statistics on demosaicked RGB planes.
pub fn chart_patch_stats_rgb(
    planes: &[Plane; 3],
    corners: &ChartCorners,
    fraction: f64,
) -> Result<Vec<PatchStats>> {
    check_rgb(planes)?;
    chart_patch_rects(corners, fraction, planes[0].rows, planes[0].cols)?
        .into_iter()
        .map(|p| {
            let m = rgb_rect_moments(planes, &p.rect)?;
            Ok(PatchStats {
                patch: p.patch,
                name: p.name,
                rect: p.rect,
                mean: m.map(|v| v.mean()),
                std: m.map(|v| v.std()),
                n: m.map(|v| v.n),
            })
        })
        .collect()
}

/// One sample of a line profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProfilePoint {
    /// Distance from the first end point, pixels.
    pub distance_px: f64,
    /// Position [x, y], pixels.
    pub position: [f64; 2],
    /// Value per channel (R, G, B), bilinearly interpolated.
    pub rgb: [f64; 3],
}

fn line_points(p0: [f64; 2], p1: [f64; 2], samples: usize) -> Result<Vec<[f64; 2]>> {
    if !(2..=1_000_000).contains(&samples) {
        return Err(AnalysisError::invalid(
            "line profile",
            format!("{samples} samples is not in 2..=1000000"),
        ));
    }
    if p0.iter().chain(p1.iter()).any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "line profile",
            "an end point is not a finite number",
        ));
    }
    Ok((0..samples)
        .map(|i| {
            let t = i as f64 / (samples - 1) as f64;
            [p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])]
        })
        .collect())
}

/// Values of three planes along the line p0 -> p1 (`[x, y]` pixels), `samples` points
/// including both ends, bilinear interpolation. Errors if the line leaves the image.
pub fn line_profile(
    planes: &[Plane; 3],
    p0: [f64; 2],
    p1: [f64; 2],
    samples: usize,
) -> Result<Vec<ProfilePoint>> {
    check_rgb(planes)?;
    let pts = line_points(p0, p1, samples)?;
    pts.iter()
        .map(|p| {
            let mut rgb = [0.0; 3];
            for (k, plane) in planes.iter().enumerate() {
                rgb[k] = plane.sample_bilinear(p[0], p[1]).ok_or_else(|| {
                    AnalysisError::invalid(
                        "line profile",
                        format!("point [{:.1}, {:.1}] lies outside the image", p[0], p[1]),
                    )
                })?;
            }
            Ok(ProfilePoint {
                distance_px: ((p[0] - p0[0]).powi(2) + (p[1] - p0[1]).powi(2)).sqrt(),
                position: *p,
                rgb,
            })
        })
        .collect()
}

/// Line profile on a raw mosaic without demosaicking: each channel is interpolated bilinearly on
/// its own sub-grid (green: the mean of the two green sub-grids), black subtracted.
pub fn line_profile_raw(
    raw: &RawImage,
    p0: [f64; 2],
    p1: [f64; 2],
    samples: usize,
) -> Result<Vec<ProfilePoint>> {
    let pts = line_points(p0, p1, samples)?;
    let grids = [
        (CfaChannel::R, None),
        (CfaChannel::G, Some(0)),
        (CfaChannel::G, Some(1)),
        (CfaChannel::B, None),
    ]
    .into_iter()
    .map(|(ch, g)| {
        Ok((
            ch,
            cfa_channel_plane(raw, ch, g)?,
            cfa_channel_offset(raw.cfa, ch, g)?,
        ))
    })
    .collect::<Result<Vec<_>>>()?;
    pts.iter()
        .map(|p| {
            if !(p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= raw.cols as f64 && p[1] <= raw.rows as f64) {
                return Err(AnalysisError::invalid(
                    "line profile",
                    format!("point [{:.1}, {:.1}] lies outside the image", p[0], p[1]),
                ));
            }
            let mut sum = [0.0f64; 3];
            let mut cnt = [0.0f64; 3];
            for (ch, plane, (dr, dc)) in &grids {
                // Sub-grid sample j is centred at sensor x = 2 j + dc + 0.5, i.e. sub-grid x = j + 0.5.
                let xs = ((p[0] - *dc as f64 - 0.5) / 2.0 + 0.5).clamp(0.0, plane.cols as f64);
                let ys = ((p[1] - *dr as f64 - 0.5) / 2.0 + 0.5).clamp(0.0, plane.rows as f64);
                if let Some(v) = plane.sample_bilinear(xs, ys) {
                    sum[ch.index()] += v;
                    cnt[ch.index()] += 1.0;
                }
            }
            Ok(ProfilePoint {
                distance_px: ((p[0] - p0[0]).powi(2) + (p[1] - p0[1]).powi(2)).sqrt(),
                position: *p,
                rgb: [0, 1, 2].map(|c| sum[c] / cnt[c].max(1.0)),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::CfaPattern;

    /// Analytic channel value of patch p: distinct for every patch and channel.
    fn value(p: usize, c: usize) -> f64 {
        100.0 + 37.0 * p as f64 + 1000.0 * c as f64
    }

    /// An upright chart with its grid from x 10..166, y 8..112 (26-pixel patches), black
    /// (0 above black) borders of 3 pixels around each patch.
    fn chart_corners() -> ChartCorners {
        ChartCorners {
            top_left: [10.0, 8.0],
            top_right: [166.0, 8.0],
            bottom_right: [166.0, 112.0],
            bottom_left: [10.0, 112.0],
        }
    }

    fn patch_at(x: f64, y: f64) -> Option<usize> {
        let (u, v) = ((x - 10.0) / 26.0, (y - 8.0) / 26.0);
        if u < 0.0 || v < 0.0 || u >= 6.0 || v >= 4.0 {
            return None;
        }
        let (fu, fv) = (u - u.floor(), v - v.floor());
        let border = 3.0 / 26.0;
        if fu < border || fu > 1.0 - border || fv < border || fv > 1.0 - border {
            return None;
        }
        Some(v.floor() as usize * 6 + u.floor() as usize)
    }

    #[test]
    fn patch_means_are_exact_with_zero_std_on_raw_and_rgb() {
        let (rows, cols) = (120, 180);
        let mut raw = RawImage::new(rows, cols, CfaPattern::Bggr, 14).unwrap();
        raw.black_level_dn = 256.0;
        let mut planes = [
            Plane::zeros(rows, cols).unwrap(),
            Plane::zeros(rows, cols).unwrap(),
            Plane::zeros(rows, cols).unwrap(),
        ];
        for r in 0..rows {
            for c in 0..cols {
                let p = patch_at(c as f64 + 0.5, r as f64 + 0.5);
                let ch = raw.channel_at(r, c).index();
                raw.dn[r * cols + c] = (256.0 + p.map_or(0.0, |p| value(p, ch))) as u16;
                for k in 0..3 {
                    planes[k].data[r * cols + c] = p.map_or(0.0, |p| value(p, k)) as f32;
                }
            }
        }
        let corners = chart_corners();
        for stats in [
            chart_patch_stats_raw(&raw, &corners, 0.5).unwrap(),
            chart_patch_stats_rgb(&planes, &corners, 0.5).unwrap(),
        ] {
            assert_eq!(stats.len(), 24);
            // Numbered 1..=24 as on the chart: 1 dark skin, 19 white, 24 black.
            assert_eq!((stats[0].patch, stats[0].name.as_str()), (1, "dark skin"));
            assert_eq!((stats[18].patch, stats[23].patch), (19, 24));
            for s in &stats {
                // 13 x 13 pixels: the central half of a 26-pixel patch.
                assert_eq!(s.rect.rows, 13);
                assert_eq!(s.rect.cols, 13);
                for c in 0..3 {
                    assert_eq!(
                        s.mean[c],
                        value(s.patch - 1, c),
                        "patch {} channel {c}",
                        s.patch
                    );
                    assert_eq!(s.std[c], 0.0);
                    assert!(s.n[c] > 0);
                }
            }
            assert_eq!(stats[18].name, "white");
        }
        // Line through the gray series: at the patch centres the profile equals the patch values,
        // between patches it falls to the black border.
        let (p0, p1) = corners.row_line(3);
        let prof = line_profile(&planes, p0, p1, 157).unwrap();
        let prof_raw = line_profile_raw(&raw, p0, p1, 157).unwrap();
        for k in 0..6 {
            let i = 13 + 26 * k; // x = 10 + 13 + 26 k: the centre of patch 18 + k
            for c in 0..3 {
                assert!((prof[i].rgb[c] - value(18 + k, c)).abs() < 1e-9);
                assert!(
                    (prof_raw[i].rgb[c] - value(18 + k, c)).abs() < 1e-9,
                    "raw profile {k} {c}"
                );
            }
        }
        assert_eq!(prof[0].rgb, [0.0; 3]);
        assert!((prof[156].distance_px - 156.0).abs() < 1e-9);
    }

    #[test]
    fn rotated_corners_and_isetcam_order_and_bad_input() {
        // A chart rotated by 10 degrees about its centre: patch centres rotate with it.
        let (cx, cy) = (88.0, 60.0);
        let (s, c) = 10f64.to_radians().sin_cos();
        let rot = |p: [f64; 2]| {
            [
                cx + (p[0] - cx) * c - (p[1] - cy) * s,
                cy + (p[0] - cx) * s + (p[1] - cy) * c,
            ]
        };
        let k = chart_corners();
        let r = ChartCorners {
            top_left: rot(k.top_left),
            top_right: rot(k.top_right),
            bottom_right: rot(k.bottom_right),
            bottom_left: rot(k.bottom_left),
        };
        for (pr, pc) in [(0, 0), (1, 4), (3, 5)] {
            let a = rot(k.patch_centre(pr, pc));
            let b = r.patch_centre(pr, pc);
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
        }
        let i =
            ChartCorners::from_isetcam([[10.5, 112.5], [166.5, 112.5], [166.5, 8.5], [10.5, 8.5]]);
        assert_eq!(i, k);
        assert!(
            chart_patch_rects(&k, 0.5, 100, 180).is_err(),
            "outside the image"
        );
        assert!(chart_patch_rects(&k, 1.5, 120, 180).is_err());
        let flipped = ChartCorners {
            top_left: k.bottom_left,
            bottom_left: k.top_left,
            top_right: k.bottom_right,
            bottom_right: k.top_right,
        };
        assert!(chart_patch_rects(&flipped, 0.5, 120, 180).is_err());
        let p = [
            Plane::zeros(4, 4).unwrap(),
            Plane::zeros(4, 4).unwrap(),
            Plane::zeros(4, 4).unwrap(),
        ];
        assert!(line_profile(&p, [0.0, 0.0], [10.0, 0.0], 5).is_err());
        assert!(line_profile(&p, [0.0, 0.0], [1.0, 0.0], 1).is_err());
    }
}
