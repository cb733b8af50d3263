//! Sampling a triangle light uniformly in the solid angle it subtends from a reference point
//! (Arvo 1995, "Stratified sampling of spherical triangles", SIGGRAPH, sec. 3), the inverse map
//! from a direction back to the unit square, and the bilinear warp of the unit square that
//! pbrt-v4 puts in front of it at surface points so that samples follow the receiver's cosine
//! (Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., sec. 6.5.4 and A.5.2).
//!
//! Area sampling's estimate `L cos_l A / r^2` is unbounded for points near the light, whose
//! variance integrated over a participating medium around a small emitter diverges; the solid
//! angle sampler's is bounded by `L Omega`. As in pbrt-v4, it is used only where the solid angle
//! is neither so small that its computation loses precision nor close to a hemisphere.
//!
//! Computed in f64: the spherical excess of small triangles cancels in f32.

use crate::math::V3;

/// pbrt-v4's range of solid angles (sr) over which triangles are sampled by solid angle
/// (`Triangle::MinSphericalSampleArea`, `MaxSphericalSampleArea`); outside it, by area.
pub(crate) const MIN_SOLID_ANGLE_SR: f64 = 3e-4;
pub(crate) const MAX_SOLID_ANGLE_SR: f64 = 6.22;

/// The floor under each corner's cosine in the bilinear warp (pbrt-v4's 0.01), so that no
/// direction of the triangle gets zero density.
const MIN_CORNER_COS: f32 = 0.01;

type D3 = [f64; 3];

#[inline(always)]
fn d3(v: V3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}
#[inline(always)]
fn dot(a: &D3, b: &D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline(always)]
fn cross(a: &D3, b: &D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline(always)]
fn axpy(s: f64, x: &D3, y: &D3) -> D3 {
    [s * x[0] + y[0], s * x[1] + y[1], s * x[2] + y[2]]
}
#[inline(always)]
fn scale(s: f64, x: &D3) -> D3 {
    [s * x[0], s * x[1], s * x[2]]
}
#[inline(always)]
fn normalized(x: &D3) -> Option<D3> {
    let l = dot(x, x).sqrt();
    (l > 0.0 && l.is_finite()).then(|| scale(1.0 / l, x))
}

/// Solid angle (sr) of the spherical triangle with unit vertices `a`, `b`, `c` (Van Oosterom &
/// Strackee 1983: `tan(Omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a)`; `atan2` keeps
/// triangles beyond a hemisphere's quarter right).
#[inline]
fn solid_angle_sr(a: &D3, b: &D3, c: &D3) -> f64 {
    let num = dot(a, &cross(b, c)).abs();
    let den = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
    2.0 * num.atan2(den)
}

/// The spherical triangle that a triangle `p0 p1 p2` projects to on the unit sphere around a
/// point, with what Arvo's sampler needs.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SphericalTriangle {
    /// Unit directions toward the vertices `p0`, `p1`, `p2` (Arvo's A, B, C).
    a: D3,
    b: D3,
    c: D3,
    /// Solid angle, sr.
    solid_angle_sr: f64,
    /// The sine and cosine of the interior angle at A, and the cosine of the arc AB.
    sin_alpha: f64,
    cos_alpha: f64,
    cos_c: f64,
}

impl SphericalTriangle {
    /// The triangle `p0 p1 p2` seen from `p`, or `None` when it is degenerate from there (`p` in
    /// its plane or on a vertex).
    pub(crate) fn new(p: V3, p0: V3, p1: V3, p2: V3) -> Option<Self> {
        let pp = d3(p);
        let dir = |q: V3| {
            let q = d3(q);
            normalized(&[q[0] - pp[0], q[1] - pp[1], q[2] - pp[2]])
        };
        let (a, b, c) = (dir(p0)?, dir(p1)?, dir(p2)?);
        let solid_angle_sr = solid_angle_sr(&a, &b, &c);
        // The angle at A between the arcs toward B and toward C (their tangents at A).
        let tb = axpy(-dot(&a, &b), &a, &b);
        let tc = axpy(-dot(&a, &c), &a, &c);
        let norms = (dot(&tb, &tb) * dot(&tc, &tc)).sqrt();
        let x = cross(&tb, &tc);
        let (sin_alpha, cos_alpha) = (dot(&x, &x).sqrt() / norms, dot(&tb, &tc) / norms);
        let t = SphericalTriangle {
            a,
            b,
            c,
            solid_angle_sr,
            sin_alpha,
            cos_alpha,
            cos_c: dot(&a, &b),
        };
        (solid_angle_sr > 0.0 && sin_alpha > 0.0 && solid_angle_sr.is_finite()).then_some(t)
    }

    /// The spherical triangle when pbrt-v4 would sample it by solid angle from `p` (its solid
    /// angle within [`MIN_SOLID_ANGLE_SR`, `MAX_SOLID_ANGLE_SR`]), else `None`: sample by area.
    #[inline]
    pub(crate) fn for_sampling(p: V3, p0: V3, p1: V3, p2: V3) -> Option<Self> {
        // A cheap bound first: the triangle lies in the ball of radius R around its centroid,
        // whose cap seen from distance d subtends 2 pi (1 - cos) <= 2 pi R^2 / d^2 sr; below the
        // lower limit, area sampling without computing the triangle (the same decision).
        let c = (p0 + p1 + p2) * (1.0 / 3.0);
        let r2 = (p0 - c)
            .length_squared()
            .max((p1 - c).length_squared())
            .max((p2 - c).length_squared());
        let d2 = (p - c).length_squared();
        if d2 > r2 && 2.0 * std::f64::consts::PI * (r2 as f64) < MIN_SOLID_ANGLE_SR * d2 as f64 {
            return None;
        }
        Self::new(p, p0, p1, p2)
            .filter(|t| (MIN_SOLID_ANGLE_SR..=MAX_SOLID_ANGLE_SR).contains(&t.solid_angle_sr))
    }

    /// Solid angle, sr.
    #[inline]
    pub(crate) fn solid_angle_sr(&self) -> f32 {
        self.solid_angle_sr as f32
    }

    /// The unit direction for `u` in the unit square, uniform in solid angle (Arvo 1995, fig. 2):
    /// `u[0]` chooses the sub-triangle A B C' of area `u[0] Omega`, `u[1]` the point along the arc
    /// from B to C' (by `1 - cos`).
    pub(crate) fn sample(&self, u: [f32; 2]) -> Option<V3> {
        let (a, b, c) = (&self.a, &self.b, &self.c);
        let area = u[0] as f64 * self.solid_angle_sr;
        // sin and cos of (area - alpha).
        let (sin_area, cos_area) = area.sin_cos();
        let (sin_a, cos_a) = (self.sin_alpha, self.cos_alpha);
        let s = sin_area * cos_a - cos_area * sin_a;
        let t = cos_area * cos_a + sin_area * sin_a;
        let uu = t - cos_a;
        let v = s + sin_a * self.cos_c;
        // The cosine of the arc from A to C' (Arvo's q).
        let q = (((v * t - uu * s) * cos_a - v) / ((v * s + uu * t) * sin_a)).clamp(-1.0, 1.0);
        if !q.is_finite() {
            return None;
        }
        let c_perp = normalized(&axpy(-dot(c, a), a, c))?;
        let c2 = axpy(q, a, &scale((1.0 - q * q).max(0.0).sqrt(), &c_perp));
        let z = (1.0 - u[1] as f64 * (1.0 - dot(&c2, b))).clamp(-1.0, 1.0);
        let b_perp = normalized(&axpy(-dot(&c2, b), b, &c2))?;
        let w = axpy(z, b, &scale((1.0 - z * z).max(0.0).sqrt(), &b_perp));
        let w = normalized(&w)?;
        Some(V3::new(w[0] as f32, w[1] as f32, w[2] as f32))
    }

    /// The point of the unit square that [`SphericalTriangle::sample`] maps to the unit
    /// direction `w` inside the triangle (clamped to the square).
    pub(crate) fn invert(&self, w: V3) -> [f32; 2] {
        let (a, b, c) = (&self.a, &self.b, &self.c);
        let w = d3(w);
        // C' is where the great circle through B and w meets the arc AC.
        let n1 = cross(b, &w);
        let n2 = cross(a, c);
        let Some(mut c2) = normalized(&cross(&n1, &n2)) else {
            // w is B: the whole edge u[1] = 0.
            return [0.5, 0.0];
        };
        if dot(&c2, &[a[0] + c[0], a[1] + c[1], a[2] + c[2]]) < 0.0 {
            c2 = scale(-1.0, &c2);
        }
        let u0 = solid_angle_sr(a, b, &c2) / self.solid_angle_sr;
        let den = 1.0 - dot(&c2, b);
        let u1 = if den > 0.0 {
            (1.0 - dot(&w, b)) / den
        } else {
            0.0
        };
        let unit = |x: f64| {
            if x.is_finite() {
                x.clamp(0.0, 1.0) as f32
            } else {
                0.0
            }
        };
        [unit(u0), unit(u1)]
    }

    /// The bilinear warp's corner weights for a receiver with unit shading normal `n`: the
    /// cosines toward the vertices at the corners of the unit square that `sample` maps to
    /// them ((0, 0) and (1, 0) to B, (0, 1) to A, (1, 1) to C), floored at 0.01.
    #[inline]
    pub(crate) fn corner_weights(&self, n: V3) -> [f32; 4] {
        let n = d3(n);
        let k = |v: &D3| (dot(&n, v).abs() as f32).max(MIN_CORNER_COS);
        let (wa, wb, wc) = (k(&self.a), k(&self.b), k(&self.c));
        [wb, wb, wa, wc]
    }
}

/// Sample `x` in [0, 1] with density proportional to `(1 - x) a + x b` (a, b >= 0, not both 0):
/// the CDF's quadratic solved in the form without cancellation.
#[inline]
fn sample_linear(u: f32, a: f32, b: f32) -> f32 {
    if u == 0.0 && a == 0.0 {
        return 0.0;
    }
    let x = u * (a + b) / (a + ((1.0 - u) * a * a + u * b * b).sqrt());
    x.min(1.0 - f32::EPSILON / 2.0)
}

/// Sample the unit square with the bilinear density through corner values `w` at (0, 0),
/// (1, 0), (0, 1), (1, 1): the second coordinate from its marginal, then the first from its
/// conditional. Returns the point and its density.
#[inline]
pub(crate) fn sample_bilinear(u: [f32; 2], w: [f32; 4]) -> ([f32; 2], f32) {
    let y = sample_linear(u[1], w[0] + w[1], w[2] + w[3]);
    let x = sample_linear(
        u[0],
        (1.0 - y) * w[0] + y * w[2],
        (1.0 - y) * w[1] + y * w[3],
    );
    let p = [x, y];
    (p, bilinear_pdf(p, w))
}

/// Density of [`sample_bilinear`] at `p`.
#[inline]
pub(crate) fn bilinear_pdf(p: [f32; 2], w: [f32; 4]) -> f32 {
    let sum = w[0] + w[1] + w[2] + w[3];
    if !(sum > 0.0) {
        return 1.0;
    }
    let [x, y] = p;
    4.0 * ((1.0 - x) * (1.0 - y) * w[0]
        + x * (1.0 - y) * w[1]
        + (1.0 - x) * y * w[2]
        + x * y * w[3])
        / sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::rng::Rng;
    use rand::Rng as _;

    fn tri() -> (V3, V3, V3) {
        (
            V3::new(-0.3, 0.9, 0.2),
            V3::new(0.5, 1.1, -0.1),
            V3::new(0.1, 0.8, 0.6),
        )
    }

    /// Arvo's sampler, inverted, gives back the unit square's point.
    #[test]
    fn invert_undoes_sample() {
        let (p0, p1, p2) = tri();
        let t = SphericalTriangle::new(V3::new(0.0, 0.0, 0.0), p0, p1, p2).unwrap();
        let mut rng = Rng::new(7);
        for _ in 0..2000 {
            let u = [rng.gen::<f32>(), rng.gen::<f32>()];
            let w = t.sample(u).unwrap();
            let back = t.invert(w);
            assert!(
                (back[0] - u[0]).abs() < 2e-4 && (back[1] - u[1]).abs() < 2e-4,
                "{u:?} -> {back:?}"
            );
        }
    }

    /// Uniform in solid angle: the fraction of sampled directions inside each of the four
    /// sub-triangles cut by the edge midpoints equals that sub-triangle's solid angle over the
    /// whole's (binomial error), and every sample lies inside the triangle.
    #[test]
    fn samples_are_uniform_in_solid_angle() {
        let (p0, p1, p2) = tri();
        let o = V3::new(0.0, 0.0, 0.0);
        let t = SphericalTriangle::new(o, p0, p1, p2).unwrap();
        let (m01, m12, m20) = ((p0 + p1) * 0.5, (p1 + p2) * 0.5, (p2 + p0) * 0.5);
        let subs = [
            [p0, m01, m20],
            [m01, p1, m12],
            [m20, m12, p2],
            [m01, m12, m20],
        ];
        let n = 200_000usize;
        let mut counts = [0usize; 4];
        let mut rng = Rng::new(3);
        // Inside the flat triangle q0 q1 q2: the ray o + s w crosses its plane inside it.
        let inside = |w: V3, q: &[V3; 3]| {
            let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
            let pv = w.cross(e2);
            let det = e1.dot(pv);
            let tv = o - q[0];
            let b1 = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let b2 = w.dot(qv) / det;
            let s = e2.dot(qv) / det;
            s > 0.0 && b1 >= -1e-5 && b2 >= -1e-5 && b1 + b2 <= 1.0 + 1e-5
        };
        for _ in 0..n {
            let w = t.sample([rng.gen(), rng.gen()]).unwrap();
            assert!(inside(w, &[p0, p1, p2]));
            for (k, s) in subs.iter().enumerate() {
                if inside(w, s) {
                    counts[k] += 1;
                    break;
                }
            }
        }
        for (k, s) in subs.iter().enumerate() {
            let frac = SphericalTriangle::new(o, s[0], s[1], s[2])
                .unwrap()
                .solid_angle_sr
                / t.solid_angle_sr;
            let got = counts[k] as f64 / n as f64;
            let se = (frac * (1.0 - frac) / n as f64).sqrt();
            assert!((got - frac).abs() < 4.0 * se, "sub {k}: {got} vs {frac}");
        }
    }

    /// The solid angle of one face of a cube seen from its centre is 4 pi / 6, of a half face
    /// (a triangle) 4 pi / 12.
    #[test]
    fn solid_angle_of_a_cube_face_half() {
        let t = SphericalTriangle::new(
            V3::new(0.0, 0.0, 0.0),
            V3::new(-1.0, -1.0, 1.0),
            V3::new(1.0, -1.0, 1.0),
            V3::new(1.0, 1.0, 1.0),
        )
        .unwrap();
        let want = 4.0 * std::f64::consts::PI / 12.0;
        assert!(
            (t.solid_angle_sr - want).abs() < 1e-12,
            "{}",
            t.solid_angle_sr
        );
    }

    /// The bilinear sampler's points follow its density: the mean of a test function under the
    /// samples equals its integral against the density (midpoint rule).
    #[test]
    fn bilinear_samples_follow_their_density() {
        let w = [0.2f32, 1.0, 0.05, 0.7];
        let f = |p: [f32; 2]| (3.0 * p[0]).sin() + p[1] * p[1];
        let m = 400;
        let mut want = 0.0f64;
        for i in 0..m {
            for j in 0..m {
                let p = [(i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32];
                want += (f(p) * bilinear_pdf(p, w)) as f64;
            }
        }
        want /= (m * m) as f64;
        let mut rng = Rng::new(11);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (p, pdf) = sample_bilinear([rng.gen(), rng.gen()], w);
            assert!((pdf - bilinear_pdf(p, w)).abs() < 1e-5);
            let v = f(p) as f64;
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - want).abs() < 4.0 * se, "{mean} vs {want} +- {se}");
    }
}
