//! Curves (pbrt-v4 `Shape "curve"`, 4th ed. sec. 6.7): thin swept surfaces for hair, fur and
//! grass, stored as cubic Bezier segments.
//!
//! pbrt-v4 semantics: a curve is given by control points `P` in a `basis` (`bezier` or uniform
//! `bspline`) of `degree` 2 or 3; every piece of it becomes a cubic Bezier segment (quadratics
//! degree-elevated, B-splines converted). The width varies linearly from `width0` at the curve's
//! start to `width1` at its end, segment by segment (segment `i` of `n` spans
//! `lerp(i / n, w0, w1)` to `lerp((i + 1) / n, w0, w1)`). Each segment has its own parameter
//! `u` in [0, 1] along it and `v` in [0, 1] across it (pbrt-v4's `Curve` shapes are per
//! segment). Ribbons carry a normal at every segment end (`n + 1` of them) and are rendered
//! with the normal interpolated between them by spherical linear interpolation.
//!
//! Storage is compact for hair with millions of segments: the control points are `f32` (the
//! renderer traces in `f32`) and consecutive segments share their end point, so `n` segments
//! hold `3 n + 1` points (12 bytes each) instead of pbrt-v4's four points per segment.

/// How a curve's surface is shaded (pbrt-v4 `CurveType`). All three are intersected as a
/// ribbon facing the ray (pbrt-v4 4th ed. sec. 6.7.3); they differ in width and normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveType {
    /// A flat ribbon always facing the ray; the normal points along the ray's projection.
    Flat,
    /// A flat ribbon shaded as a cylinder: the normal turns across the width.
    Cylinder,
    /// A ribbon with a fixed orientation: the normal is interpolated between the segment-end
    /// normals, and the width seen by a ray shrinks with the cosine between them.
    Ribbon,
}

impl CurveType {
    /// pbrt-v4's name (`"flat"`, `"cylinder"`, `"ribbon"`).
    pub fn from_name(name: &str) -> Option<CurveType> {
        match name {
            "flat" => Some(CurveType::Flat),
            "cylinder" => Some(CurveType::Cylinder),
            "ribbon" => Some(CurveType::Ribbon),
            _ => None,
        }
    }
}

/// One pbrt-v4 `curve` shape in world space: `3 n + 1` cubic Bezier control points for `n`
/// segments (segment `i` uses `points[3 i ..= 3 i + 3]`), metres.
#[derive(Debug, Clone, PartialEq)]
pub struct Curves {
    pub kind: CurveType,
    /// Control points, world space, m (f32: compact; the renderer traces in f32).
    pub points: Vec<[f32; 3]>,
    /// Width at the curve's start and end, m (linear in the segment index and `u`).
    pub width_m: [f32; 2],
    /// Ribbons: unit normals at the segment ends (`n + 1`), world space; empty otherwise.
    pub normals: Vec<[f32; 3]>,
    /// pbrt-v4 `splitdepth`: each segment is bounded by `2^split_depth` boxes in the renderer's
    /// BVH (tighter bounds around a bent segment; pbrt-v4 default 3).
    pub split_depth: u32,
}

impl Curves {
    /// Number of cubic Bezier segments.
    pub fn segments(&self) -> usize {
        self.points.len().saturating_sub(1) / 3
    }

    /// Width at the start and end of segment `i`, m.
    pub fn segment_width_m(&self, i: usize) -> [f32; 2] {
        let n = self.segments().max(1) as f32;
        let lerp = |t: f32| (1.0 - t) * self.width_m[0] + t * self.width_m[1];
        [lerp(i as f32 / n), lerp((i + 1) as f32 / n)]
    }

    /// Check the layout (point and normal counts, finite values, widths > 0, split depth).
    pub fn validate(&self) -> Result<(), String> {
        let n = self.segments();
        if n == 0 || self.points.len() != 3 * n + 1 {
            return Err(format!(
                "{} control points do not form cubic Bezier segments (3 n + 1 needed)",
                self.points.len()
            ));
        }
        if let Some(i) = self
            .points
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(format!("control point {i} has a non-finite coordinate"));
        }
        if !self.width_m.iter().all(|w| *w > 0.0 && w.is_finite()) {
            return Err(format!(
                "widths {} and {} m must be positive and finite",
                self.width_m[0], self.width_m[1]
            ));
        }
        match self.kind {
            CurveType::Ribbon if self.normals.len() != n + 1 => {
                return Err(format!(
                    "a ribbon of {n} segments needs {} normals, got {}",
                    n + 1,
                    self.normals.len()
                ))
            }
            CurveType::Ribbon => {
                if let Some(i) = self.normals.iter().position(|v| {
                    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    !(l.is_finite() && (l - 1.0).abs() < 1e-3)
                }) {
                    return Err(format!("ribbon normal {i} is not a unit vector"));
                }
            }
            _ if !self.normals.is_empty() => {
                return Err("only ribbon curves take normals".into());
            }
            _ => {}
        }
        if self.split_depth > MAX_SPLIT_DEPTH {
            return Err(format!(
                "splitdepth {} is above {MAX_SPLIT_DEPTH}",
                self.split_depth
            ));
        }
        Ok(())
    }

    /// pbrt-v4's approximate area (`Curve::Area`): per segment the control polygon's length times
    /// the mean width, m^2.
    pub fn area_m2(&self) -> f64 {
        (0..self.segments())
            .map(|i| {
                let p = &self.points[3 * i..3 * i + 4];
                let len: f64 = (0..3)
                    .map(|k| {
                        (0..3)
                            .map(|a| (p[k + 1][a] as f64 - p[k][a] as f64).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    })
                    .sum();
                let w = self.segment_width_m(i);
                len * 0.5 * (w[0] as f64 + w[1] as f64)
            })
            .sum()
    }

    /// Axis-aligned bounds of the control points grown by half the largest width, m (a Bezier
    /// segment lies in the convex hull of its control points).
    pub fn bounds_m(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
        let r = 0.5 * self.width_m[0].max(self.width_m[1]) as f64;
        (lo.map(|v| v - r), hi.map(|v| v + r))
    }
}

/// Largest `splitdepth` accepted (2^12 BVH boxes per segment is far past any benefit).
pub const MAX_SPLIT_DEPTH: u32 = 12;

/// The basis control points are given in (pbrt-v4 `basis`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveBasis {
    Bezier,
    /// Uniform B-spline.
    BSpline,
}

/// Cubic Bezier control points (shared-end layout, `3 n + 1`) of a curve given by `cp` in
/// `basis` of `degree` 2 or 3, with pbrt-v4's segment counts: Bezier needs `degree + 1 + k
/// degree` points (`1 + k` segments), a B-spline at least `degree + 1` (`len - degree`
/// segments). Conversions (standard spline algebra, e.g. Farin, "Curves and Surfaces for CAGD",
/// ch. 5 and 7): a quadratic is degree-elevated to `(q0, (q0 + 2 q1) / 3, (2 q1 + q2) / 3, q2)`;
/// a uniform cubic B-spline's span `p0..p3` is the Bezier segment `((p0 + 4 p1 + p2) / 6,
/// (2 p1 + p2) / 3, (p1 + 2 p2) / 3, (p1 + 4 p2 + p3) / 6)`; a uniform quadratic B-spline's
/// span `p0..p2` the quadratic Bezier `((p0 + p1) / 2, p1, (p1 + p2) / 2)`. Consecutive
/// segments meet in one point in every case, which the layout stores once.
pub fn bezier_control_points(
    cp: &[[f64; 3]],
    basis: CurveBasis,
    degree: u32,
) -> Result<Vec<[f64; 3]>, String> {
    if degree != 2 && degree != 3 {
        return Err(format!(
            "degree {degree}: only degree 2 and 3 curves are supported"
        ));
    }
    let d = degree as usize;
    let lin = |a: [f64; 3], wa: f64, b: [f64; 3], wb: f64| {
        [
            a[0] * wa + b[0] * wb,
            a[1] * wa + b[1] * wb,
            a[2] * wa + b[2] * wb,
        ]
    };
    let elevate = |q: [[f64; 3]; 3]| -> [[f64; 3]; 4] {
        [
            q[0],
            lin(q[0], 1.0 / 3.0, q[1], 2.0 / 3.0),
            lin(q[1], 2.0 / 3.0, q[2], 1.0 / 3.0),
            q[2],
        ]
    };
    let segments: Vec<[[f64; 3]; 4]> = match basis {
        CurveBasis::Bezier => {
            if cp.len() < d + 1 || !(cp.len() - 1 - d).is_multiple_of(d) {
                return Err(format!(
                    "{} control points: a degree {degree} Bezier curve needs {} + n * {degree} (n >= 0)",
                    cp.len(),
                    d + 1
                ));
            }
            (0..(cp.len() - 1) / d)
                .map(|s| {
                    let c = &cp[s * d..s * d + d + 1];
                    if d == 2 {
                        elevate([c[0], c[1], c[2]])
                    } else {
                        [c[0], c[1], c[2], c[3]]
                    }
                })
                .collect()
        }
        CurveBasis::BSpline => {
            if cp.len() < d + 1 {
                return Err(format!(
                    "{} control points: a degree {degree} B-spline needs at least {}",
                    cp.len(),
                    d + 1
                ));
            }
            (0..cp.len() - d)
                .map(|s| {
                    let c = &cp[s..s + d + 1];
                    if d == 2 {
                        elevate([lin(c[0], 0.5, c[1], 0.5), c[1], lin(c[1], 0.5, c[2], 0.5)])
                    } else {
                        let six = 1.0 / 6.0;
                        let a = lin(lin(c[0], six, c[1], 4.0 * six), 1.0, c[2], six);
                        let b = lin(c[1], 2.0 / 3.0, c[2], 1.0 / 3.0);
                        let e = lin(c[1], 1.0 / 3.0, c[2], 2.0 / 3.0);
                        let f = lin(lin(c[1], six, c[2], 4.0 * six), 1.0, c[3], six);
                        [a, b, e, f]
                    }
                })
                .collect()
        }
    };
    let mut out = Vec::with_capacity(3 * segments.len() + 1);
    for (i, s) in segments.iter().enumerate() {
        if i == 0 {
            out.push(s[0]);
        }
        out.extend_from_slice(&s[1..]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cubic Bezier point (Bernstein form).
    fn bezier(p: &[[f64; 3]], t: f64) -> [f64; 3] {
        let s = 1.0 - t;
        let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
        let mut o = [0.0; 3];
        for k in 0..4 {
            for a in 0..3 {
                o[a] += w[k] * p[k][a];
            }
        }
        o
    }

    /// The uniform cubic B-spline through its basis functions (de Boor; 1/6 (1-t)^3, ...).
    fn bspline3(c: &[[f64; 3]], t: f64) -> [f64; 3] {
        let s = 1.0 - t;
        let w = [
            s * s * s / 6.0,
            (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
            (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
            t * t * t / 6.0,
        ];
        let mut o = [0.0; 3];
        for k in 0..4 {
            for a in 0..3 {
                o[a] += w[k] * c[k][a];
            }
        }
        o
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    #[test]
    fn bspline_segments_trace_the_spline_and_share_ends() {
        let cp: Vec<[f64; 3]> = (0..7)
            .map(|i| {
                let x = i as f64;
                [x, (x * 1.3).sin(), 0.2 * x * x]
            })
            .collect();
        let b = bezier_control_points(&cp, CurveBasis::BSpline, 3).unwrap();
        assert_eq!(b.len(), 3 * 4 + 1);
        for s in 0..4 {
            for t in [0.0, 0.3, 0.71, 1.0] {
                assert!(close(
                    bezier(&b[3 * s..3 * s + 4], t),
                    bspline3(&cp[s..s + 4], t)
                ));
            }
        }
    }

    #[test]
    fn quadratics_are_elevated_exactly() {
        // Quadratic Bezier q(t) = (1-t)^2 q0 + 2 t (1-t) q1 + t^2 q2.
        let q = [
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 0.5],
            [3.0, 0.0, -1.0],
            [4.0, 1.0, 0.0],
            [5.0, 5.0, 5.0],
        ];
        let b = bezier_control_points(&q, CurveBasis::Bezier, 2).unwrap();
        assert_eq!(b.len(), 7);
        for s in 0..2 {
            for t in [0.0, 0.25, 0.6, 1.0] {
                let u = 1.0 - t;
                let c = &q[2 * s..2 * s + 3];
                let want =
                    [0, 1, 2].map(|a| u * u * c[0][a] + 2.0 * t * u * c[1][a] + t * t * c[2][a]);
                assert!(close(bezier(&b[3 * s..3 * s + 4], t), want));
            }
        }
        // Quadratic B-spline: the span's midpoints and the middle point as the Bezier hull.
        let b = bezier_control_points(&q[..4], CurveBasis::BSpline, 2).unwrap();
        assert_eq!(b.len(), 7);
        assert!(close(b[0], [0.5, 1.0, 0.25]) && close(b[3], [2.0, 1.0, -0.25]));
        assert!(bezier_control_points(&q[..4], CurveBasis::Bezier, 2).is_err());
        assert!(bezier_control_points(&q[..3], CurveBasis::Bezier, 3).is_err());
        assert!(bezier_control_points(&q, CurveBasis::Bezier, 4).is_err());
    }
}
