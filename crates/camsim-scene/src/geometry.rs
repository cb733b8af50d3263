//! Chart geometry in pixel coordinates: the ColorChecker layout and the anti-aliased slanted
//! edge. Pixel (row, col) covers the unit square [col, col + 1] x [row, row + 1]; rows grow
//! downwards.

use serde::{Deserialize, Serialize};

/// An axis-aligned rectangle of pixels: rows `row0 .. row0 + rows`, columns `col0 .. col0 + cols`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rect {
    /// First row, pixels.
    pub row0: usize,
    /// First column, pixels.
    pub col0: usize,
    /// Height, pixels.
    pub rows: usize,
    /// Width, pixels.
    pub cols: usize,
}

impl Rect {
    /// True when pixel (row, col) lies inside.
    pub fn contains(&self, row: usize, col: usize) -> bool {
        row >= self.row0
            && row < self.row0 + self.rows
            && col >= self.col0
            && col < self.col0 + self.cols
    }
    /// The rectangle shrunk by `margin` pixels on every side (for measuring a patch away from its
    /// edges, where optics blur mixes in the neighbours); empty sides saturate at zero size.
    pub fn inset(&self, margin: usize) -> Rect {
        let rows = self.rows.saturating_sub(2 * margin);
        let cols = self.cols.saturating_sub(2 * margin);
        Rect {
            row0: self.row0 + margin.min(self.rows / 2),
            col0: self.col0 + margin.min(self.cols / 2),
            rows,
            cols,
        }
    }
}

/// ColorChecker layout: 4 rows x 6 columns of square patches of `patch_px`, separated from each
/// other and from the chart's outer edge by borders `border_px` wide.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MacbethLayout {
    /// Patch side, pixels.
    pub patch_px: usize,
    /// Border width between patches and around the chart, pixels.
    pub border_px: usize,
}

impl MacbethLayout {
    /// Patch rows on the chart.
    pub const PATCH_ROWS: usize = 4;
    /// Patch columns on the chart.
    pub const PATCH_COLS: usize = 6;

    /// Chart height, pixels: 4 patches and 5 borders.
    pub fn rows(&self) -> usize {
        Self::PATCH_ROWS * self.patch_px + (Self::PATCH_ROWS + 1) * self.border_px
    }
    /// Chart width, pixels: 6 patches and 7 borders.
    pub fn cols(&self) -> usize {
        Self::PATCH_COLS * self.patch_px + (Self::PATCH_COLS + 1) * self.border_px
    }
    /// The rectangles of the 24 patches in chart order (row by row from the top left: patch 1
    /// "dark skin" top left, patch 19 "white" bottom left, patch 24 "black" bottom right).
    pub fn patch_rects(&self) -> Vec<Rect> {
        (0..24)
            .map(|i| {
                let (pr, pc) = (i / Self::PATCH_COLS, i % Self::PATCH_COLS);
                Rect {
                    row0: self.border_px + pr * (self.patch_px + self.border_px),
                    col0: self.border_px + pc * (self.patch_px + self.border_px),
                    rows: self.patch_px,
                    cols: self.patch_px,
                }
            })
            .collect()
    }
    /// Patch index (0-23) at pixel (row, col), or `None` on the border.
    #[inline]
    pub fn patch_at(&self, row: usize, col: usize) -> Option<usize> {
        let pitch = self.patch_px + self.border_px;
        let (r, c) = (
            row.checked_sub(self.border_px)?,
            col.checked_sub(self.border_px)?,
        );
        let (pr, pc) = (r / pitch, c / pitch);
        if pr < Self::PATCH_ROWS
            && pc < Self::PATCH_COLS
            && r % pitch < self.patch_px
            && c % pitch < self.patch_px
        {
            Some(pr * Self::PATCH_COLS + pc)
        } else {
            None
        }
    }
}

/// A straight edge through the point (`x0`, `y0`) (pixel coordinates), tilted by `angle_deg` from
/// the vertical: it crosses the horizontal line at height y at x = x0 + (y - y0) tan(angle).
/// The bright side is the one with larger x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// A point on the edge, column coordinate (pixels).
    pub x0: f64,
    /// A point on the edge, row coordinate (pixels).
    pub y0: f64,
    /// Tilt from the vertical, degrees.
    pub angle_deg: f64,
}

impl Edge {
    /// Column at which the edge crosses the horizontal line at row coordinate `y`.
    pub fn x_at(&self, y: f64) -> f64 {
        self.x0 + (y - self.y0) * self.angle_deg.to_radians().tan()
    }

    /// Signed distance of point (x, y) from the edge, pixels, positive on the bright side.
    pub fn signed_distance(&self, x: f64, y: f64) -> f64 {
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        (x - self.x0) * c - (y - self.y0) * s
    }

    /// Fraction of pixel (row, col) on the bright side: the exact area of the unit square clipped
    /// by the half-plane (Sutherland-Hodgman clipping against one plane, shoelace area).
    pub fn coverage(&self, row: usize, col: usize) -> f64 {
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let (x, y) = (col as f64, row as f64);
        // Distance at the pixel centre; corners differ by at most (|c| + |s|) / 2 < 0.71.
        let d_centre = (x + 0.5 - self.x0) * c - (y + 0.5 - self.y0) * s;
        let reach = 0.5 * (c.abs() + s.abs());
        if d_centre >= reach {
            return 1.0;
        }
        if d_centre <= -reach {
            return 0.0;
        }
        let corners = [(x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)];
        let dist = |p: (f64, f64)| (p.0 - self.x0) * c - (p.1 - self.y0) * s;
        // Clip the square (in local coordinates, for precision) against dist >= 0.
        let mut poly = [(0.0f64, 0.0f64); 8];
        let mut n = 0;
        for i in 0..4 {
            let p = corners[i];
            let q = corners[(i + 1) % 4];
            let (dp, dq) = (dist(p), dist(q));
            if dp >= 0.0 {
                poly[n] = (p.0 - x, p.1 - y);
                n += 1;
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                let t = dp / (dp - dq);
                poly[n] = (p.0 + t * (q.0 - p.0) - x, p.1 + t * (q.1 - p.1) - y);
                n += 1;
            }
        }
        let mut area2 = 0.0;
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            area2 += a.0 * b.1 - b.0 * a.1;
        }
        (0.5 * area2.abs()).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn macbeth_layout_rects_and_lookup_agree() {
        let l = MacbethLayout {
            patch_px: 10,
            border_px: 3,
        };
        assert_eq!((l.rows(), l.cols()), (4 * 10 + 5 * 3, 6 * 10 + 7 * 3));
        let rects = l.patch_rects();
        let mut counts = [0usize; 25];
        for r in 0..l.rows() {
            for c in 0..l.cols() {
                let p = l.patch_at(r, c);
                counts[p.unwrap_or(24)] += 1;
                for (i, rect) in rects.iter().enumerate() {
                    assert_eq!(rect.contains(r, c), p == Some(i));
                }
            }
        }
        assert!(counts[..24].iter().all(|n| *n == 100));
        assert_eq!(counts[24], l.rows() * l.cols() - 2400);
        // Standard order: white (19) bottom left, black (24) bottom right.
        assert_eq!(rects[18].col0, 3);
        assert_eq!(rects[23].row0, 3 + 3 * 13);
        assert_eq!(
            rects[0].inset(2),
            Rect {
                row0: 5,
                col0: 5,
                rows: 6,
                cols: 6
            }
        );
    }

    #[test]
    fn coverage_matches_fine_supersampling() {
        // Independent check: count 400 x 400 sub-pixel centres on the bright side. The count
        // error is at most about one sub-pixel row crossing the edge: < 2 / 400.
        for angle in [0.0, 5.0, -12.0, 30.0, 44.0] {
            let e = Edge {
                x0: 3.3,
                y0: 2.1,
                angle_deg: angle,
            };
            for row in 0..5 {
                for col in 0..7 {
                    let n = 400;
                    let mut k = 0;
                    for i in 0..n {
                        for j in 0..n {
                            let x = col as f64 + (j as f64 + 0.5) / n as f64;
                            let y = row as f64 + (i as f64 + 0.5) / n as f64;
                            if e.signed_distance(x, y) > 0.0 {
                                k += 1;
                            }
                        }
                    }
                    let mc = k as f64 / (n * n) as f64;
                    let a = e.coverage(row, col);
                    assert!(
                        (a - mc).abs() < 2.0 / n as f64,
                        "angle {angle} ({row},{col}): {a} vs {mc}"
                    );
                }
            }
        }
    }
}
