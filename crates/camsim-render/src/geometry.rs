//! Rays, bounding boxes and the primitive kinds (triangles, spheres, curve pieces) with their
//! ray tests.

use crate::math::{fmax, fmin, V3};

/// A ray `o + t d` with a unit direction `d`, so `t` is a distance in metres.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    pub o: V3,
    pub d: V3,
}

/// A ray with the reciprocal direction precomputed for box tests.
#[derive(Debug, Clone, Copy)]
pub struct RayInv {
    pub o: V3,
    pub d: V3,
    pub inv_d: V3,
    /// Per axis, 1 when the direction is negative (the box's max plane is entered first), else 0.
    pub neg: [usize; 3],
}

impl RayInv {
    /// Precompute `1 / d`. Zero components are replaced by +-1e-30 so the reciprocal is finite
    /// and the slab test never forms `0 * inf` (NaN).
    #[inline(always)]
    pub fn new(r: &Ray) -> RayInv {
        #[inline(always)]
        fn safe(x: f32) -> f32 {
            if x.abs() < 1e-30 {
                1e-30f32.copysign(x)
            } else {
                x
            }
        }
        let inv_d = V3::new(1.0 / safe(r.d.x), 1.0 / safe(r.d.y), 1.0 / safe(r.d.z));
        let neg = [
            (inv_d.x < 0.0) as usize,
            (inv_d.y < 0.0) as usize,
            (inv_d.z < 0.0) as usize,
        ];
        RayInv {
            o: r.o,
            d: r.d,
            inv_d,
            neg,
        }
    }
}

/// An axis-aligned bounding box (f32).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: V3,
    pub max: V3,
}

impl Aabb {
    /// The empty box (min = +inf, max = -inf).
    pub const EMPTY: Aabb = Aabb {
        min: V3::splat(f32::INFINITY),
        max: V3::splat(f32::NEG_INFINITY),
    };

    /// Grow to include a point.
    #[inline(always)]
    pub fn grow_point(&mut self, p: V3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    /// Grow to include a box.
    #[inline(always)]
    pub fn grow(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }
    /// Half the surface area (the SAH only needs ratios); 0 for the empty box.
    #[inline(always)]
    pub fn half_area(&self) -> f32 {
        let d = self.max - self.min;
        if d.x < 0.0 || d.y < 0.0 || d.z < 0.0 {
            0.0
        } else {
            d.x * d.y + d.y * d.z + d.z * d.x
        }
    }
    /// Centre point.
    #[inline(always)]
    pub fn center(&self) -> V3 {
        (self.min + self.max) * 0.5
    }
}

/// Slab test (Kay & Kajiya 1986): entry distance of the ray into the box if it enters within
/// `(0, t_max)`, else `f32::INFINITY`.
#[inline(always)]
pub fn ray_box(r: &RayInv, min: &[f32; 3], max: &[f32; 3], t_max: f32) -> f32 {
    let tx0 = (min[0] - r.o.x) * r.inv_d.x;
    let tx1 = (max[0] - r.o.x) * r.inv_d.x;
    let ty0 = (min[1] - r.o.y) * r.inv_d.y;
    let ty1 = (max[1] - r.o.y) * r.inv_d.y;
    let tz0 = (min[2] - r.o.z) * r.inv_d.z;
    let tz1 = (max[2] - r.o.z) * r.inv_d.z;
    // inv_d is finite (RayInv::new), so no NaN arises and one-instruction min/max suffice.
    let t_near = fmax(
        fmax(fmin(tx0, tx1), fmin(ty0, ty1)),
        fmax(fmin(tz0, tz1), 0.0),
    );
    let t_far = fmin(
        fmin(fmax(tx0, tx1), fmax(ty0, ty1)),
        fmin(fmax(tz0, tz1), t_max),
    );
    // Robust traversal slack (Ize 2013): widen t_far by 2 ulp-ish so grazing boxes are not lost.
    if t_near <= t_far * 1.000_000_2 {
        t_near
    } else {
        f32::INFINITY
    }
}

/// A primitive as stored in BVH order: its intersection data and the index of its
/// [`PrimInfo`] record.
#[derive(Debug, Clone, Copy)]
pub enum Prim {
    /// Triangle `p0, p0 + e1, p0 + e2`.
    Tri { p0: V3, e1: V3, e2: V3 },
    /// Sphere.
    Sphere { center: V3, radius: f32 },
    /// Partial sphere: the sphere clipped by `Bvh::clips[clip]` (see [`SphereClip`]).
    PartialSphere { center: V3, radius: f32, clip: u32 },
    /// The piece `[u0, u1]` of curve segment `seg` of `Bvh::curves` ([`crate::curve`]).
    Curve { seg: u32, u0: f32, u1: f32 },
}

/// Marks a primitive without an emitter.
pub(crate) const NO_LIGHT: u32 = u32::MAX;

/// Per-primitive data needed after a hit, in BVH order.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PrimInfo {
    /// Index of the shape in `SceneDescription::shapes`.
    pub shape: u32,
    /// Triangle index within its mesh (0 for spheres).
    pub tri: u32,
    /// Compiled material index.
    pub material: u32,
    /// Light index, or [`NO_LIGHT`].
    pub light: u32,
}

/// Shading data of a triangle mesh that has uv or normals.
#[derive(Debug, Clone, Default)]
pub(crate) struct MeshShading {
    pub indices: Vec<[u32; 3]>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub normals: Option<Vec<V3>>,
    /// Linear RGBA vertex colours (glTF `COLOR_0`).
    pub colors: Option<Vec<[f32; 4]>>,
    /// The second uv set (glTF `TEXCOORD_n` of a slot whose set is not the first's).
    pub uvs1: Option<Vec<[f32; 2]>>,
    /// Unit tangents and handedness `w` (glTF `TANGENT` or MikkTSpace), render space.
    pub tangents: Option<Vec<(V3, f32)>>,
}

/// Surface data at a hit.
pub(crate) struct SurfaceHit {
    pub(crate) p: V3,
    /// Geometric normal (unit, as the shape defines it: not flipped toward the ray).
    pub(crate) ng: V3,
    /// Shading normal (unit; equals `ng` without vertex normals).
    pub(crate) ns: V3,
    pub(crate) uv: [f32; 2],
    /// The second uv set at the hit (`MeshShading::uvs1`; equals `uv` on shapes without one).
    pub(crate) uv1: [f32; 2],
    /// The interpolated vertex colour, RGBA (`MeshShading::colors`; white, opaque on shapes
    /// without).
    pub(crate) color: [f32; 4],
    /// Curves: dp/du, the direction along the curve (the shading frame's x axis, which the
    /// hair BSDF needs); zero for other shapes (any frame about the normal).
    pub(crate) dpdu: V3,
    /// Per-axis bound on the floating-point error of `p`, m (`geometry::tri_point_err`,
    /// `geometry::sphere_point_err`; a curve's the width at the hit, as pbrt-v4's `pError`).
    /// Rays leave the surface `|ng| . err` along the geometric normal (pbrt-v4
    /// `OffsetRayOrigin`, `geometry::offset_ray_origin`).
    pub(crate) err: V3,
}

/// The clipping of a partial sphere (pbrt-v4 `sphere` with `zmin`, `zmax`, `phimax`, 4th ed.
/// §6.2): its object frame's unit axes in world space, the kept z range (m, along `ez` from the
/// centre) and azimuth range `[0, phi_max]` (rad, from `ex` toward `ey`).
#[derive(Debug, Clone, Copy)]
pub struct SphereClip {
    pub ex: V3,
    pub ey: V3,
    pub ez: V3,
    pub z_min: f32,
    pub z_max: f32,
    pub phi_max: f32,
}

impl SphereClip {
    /// Object-frame coordinates of the offset `q = p - center`.
    #[inline(always)]
    pub fn local(&self, q: V3) -> V3 {
        V3::new(q.dot(self.ex), q.dot(self.ey), q.dot(self.ez))
    }

    /// Azimuth of object-frame point `l` in `[0, 2 pi)` (pbrt-v4 Sphere: `phi = atan2(y, x)`,
    /// plus 2 pi when negative).
    #[inline(always)]
    pub fn phi(l: V3) -> f32 {
        let phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi + 2.0 * std::f32::consts::PI
        } else {
            phi
        }
    }

    /// Whether the sphere point at offset `q` from the centre is kept (pbrt-v4
    /// `Sphere::BasicIntersect`: `z < zMin || z > zMax || phi > phiMax` is cut away).
    #[inline(always)]
    pub fn keeps(&self, q: V3) -> bool {
        let l = self.local(q);
        if l.z < self.z_min || l.z > self.z_max {
            return false;
        }
        self.phi_max >= 2.0 * std::f32::consts::PI || Self::phi(l) <= self.phi_max
    }
}

impl Prim {
    /// World-space bounds (curve pieces: see [`Prim::bounds_with`] in `bvh.rs`; here empty).
    pub fn bounds(&self) -> Aabb {
        match *self {
            Prim::Curve { .. } => Aabb::EMPTY,
            Prim::Tri { p0, e1, e2 } => {
                let mut b = Aabb::EMPTY;
                b.grow_point(p0);
                b.grow_point(p0 + e1);
                b.grow_point(p0 + e2);
                b
            }
            Prim::Sphere { center, radius } | Prim::PartialSphere { center, radius, .. } => Aabb {
                min: center - V3::splat(radius),
                max: center + V3::splat(radius),
            },
        }
    }

    /// Nearest intersection in `(0, t_max)`: `(t, u, v)` with barycentrics `u, v` for triangles
    /// (point = (1-u-v) p0 + u p1 + v p2) and zeros for spheres.
    #[inline(always)]
    pub fn intersect(&self, r: &RayInv, t_max: f32) -> Option<(f32, f32, f32)> {
        match *self {
            Prim::Tri { p0, e1, e2 } => intersect_triangle(r.o, r.d, p0, e1, e2, t_max),
            Prim::Sphere { center, radius } => {
                intersect_sphere(r.o, r.d, center, radius, t_max).map(|t| (t, 0.0, 0.0))
            }
            // Without its clip a partial sphere is tested whole ([`Prim::intersect_with`] clips).
            Prim::PartialSphere { center, radius, .. } => {
                intersect_sphere(r.o, r.d, center, radius, t_max).map(|t| (t, 0.0, 0.0))
            }
            // Curve pieces need their control points ([`Prim::intersect_with`]).
            Prim::Curve { .. } => None,
        }
    }
}

/// Scale of the floating-point error bounds of surface points (`tri_point_err`,
/// `sphere_point_err`): 32 unit roundoffs of f32 (`16 f32::EPSILON`, about 1.9e-6 relative).
/// pbrt-v4 bounds its barycentric reconstruction `b0 p0 + b1 p1 + b2 p2` by `gamma(7)` (7 unit
/// roundoffs, 4th ed. sec. 6.8.3) and re-intersects with its watertight test, which discards
/// `t` below that test's own error bound. camsim intersects with Moller-Trumbore and `t > 0`
/// alone, so the bound has to cover the intersection test's rounding of `t` too (a few more
/// roundoffs of the same magnitudes, `o - p0` being of the order of `p0` and the edges): about
/// 4x pbrt-v4's constant. It stays microns at metres from the origin: a surface 10 um behind the
/// one a ray leaves is still reached (tests/it/ray_offsets.rs).
pub const POINT_ERR_SCALE: f32 = 16.0 * f32::EPSILON;

/// Per-axis bound on the floating-point error of the point `p0 + b1 e1 + b2 e2` of a triangle,
/// m (as pbrt-v4's `gamma(7) (|b0 p0| + |b1 p1| + |b2 p2|)`, 4th ed. sec. 6.8.5, for camsim's
/// stored vertex and edges).
#[inline(always)]
pub fn tri_point_err(p0: V3, e1: V3, e2: V3, b1: f32, b2: f32) -> V3 {
    (p0.abs() + e1.abs() * b1.abs() + e2.abs() * b2.abs()) * POINT_ERR_SCALE
}

/// Per-axis bound on the floating-point error of the point `center + radius n` of a sphere
/// (`n` the unit normal), m: the sum's operands' magnitudes, as pbrt-v4 bounds its re-projected
/// sphere point by `gamma(5) |p|` (4th ed. sec. 6.8.5) in object space.
#[inline(always)]
pub fn sphere_point_err(center: V3, radius: f32, n: V3) -> V3 {
    (center.abs() + n.abs() * radius) * POINT_ERR_SCALE
}

/// A ray origin off the surface point `p` with per-axis error bound `err`, on the side of the
/// unit normal `n` (pbrt-v4 `OffsetRayOrigin`, 4th ed. sec. 6.8.6): moved `|n| . err` along `n`,
/// the distance of the farthest corner of the error box from the tangent plane, then each
/// component rounded away from `p` so that rounding cannot bring it back inside the box.
#[inline(always)]
pub fn offset_ray_origin(p: V3, err: V3, n: V3) -> V3 {
    let off = n * n.abs().dot(err);
    let away = |x: f32, o: f32| {
        let y = x + o;
        if o > 0.0 {
            y.next_up()
        } else if o < 0.0 {
            y.next_down()
        } else {
            y
        }
    };
    V3::new(away(p.x, off.x), away(p.y, off.y), away(p.z, off.z))
}

/// Moller & Trumbore (1997), "Fast, minimum storage ray-triangle intersection".
#[inline(always)]
pub fn intersect_triangle(
    o: V3,
    d: V3,
    p0: V3,
    e1: V3,
    e2: V3,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = o - p0;
    let u = tvec.dot(pvec) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = d.dot(qvec) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qvec) * inv_det;
    if t > 0.0 && t < t_max {
        Some((t, u, v))
    } else {
        None
    }
}

/// The roots `t0 <= t1` of the ray-sphere quadratic with `oc = o - center` (`None` when the ray
/// misses), computed stably: the discriminant from the perpendicular distance and the roots as
/// c/q and q (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing
/// Gems 2019, ch. 7). `d` must be a unit vector.
#[inline(always)]
fn sphere_roots(o: V3, d: V3, center: V3, radius: f32) -> Option<(V3, f32, f32)> {
    let oc = o - center;
    let b = oc.dot(d);
    let perp = oc - d * b;
    let disc = radius * radius - perp.length_squared();
    if disc < 0.0 {
        return None;
    }
    let c = oc.length_squared() - radius * radius;
    let sq = disc.sqrt();
    // q = -(b + sign(b) sqrt(disc)); roots c/q and q.
    let q = if b > 0.0 { -b - sq } else { -b + sq };
    let (mut t0, mut t1) = if q != 0.0 { (c / q, q) } else { (0.0, 0.0) };
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    Some((oc, t0, t1))
}

/// Ray-sphere intersection with the numerically robust discriminant
/// `r^2 - |oc - (oc.d) d|^2` (Haines et al., "Precision Improvements for Ray/Sphere
/// Intersection", Ray Tracing Gems 2019, ch. 7). `d` must be a unit vector.
#[inline(always)]
pub fn intersect_sphere(o: V3, d: V3, center: V3, radius: f32, t_max: f32) -> Option<f32> {
    let (_, t0, t1) = sphere_roots(o, d, center, radius)?;
    if t0 > 0.0 && t0 < t_max {
        Some(t0)
    } else if t1 > 0.0 && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// Ray-partial-sphere intersection (pbrt-v4 `Sphere::BasicIntersect`, 4th ed. §6.2.2): the
/// roots of [`intersect_sphere`]'s quadratic in order, the first in `(0, t_max)` whose point the
/// clip keeps (a near hit cut away falls through to the far one).
#[inline(always)]
pub fn intersect_partial_sphere(
    o: V3,
    d: V3,
    center: V3,
    radius: f32,
    clip: &SphereClip,
    t_max: f32,
) -> Option<f32> {
    let (oc, t0, t1) = sphere_roots(o, d, center, radius)?;
    [t0, t1]
        .into_iter()
        .find(|&t| t > 0.0 && t < t_max && clip.keeps(oc + d * t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_origin_clears_the_error_box_by_no_more_than_it() {
        // Points up to 1e4 m from the origin, random unit normals, their triangle error
        // bounds: in f64, every corner of the error box lies behind the offset origin's plane
        // (no self-intersection), and the origin is no farther along n than the box's farthest
        // corner plus the final rounding (surfaces a hair's breadth away stay reachable).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for i in 0..2000 {
            let scale = [1e-3f64, 1.0, 1e4][i % 3];
            let mut v = || V3::new(next() as f32, next() as f32, next() as f32);
            let (p0, e1, e2) = (v() * scale as f32, v(), v());
            let (b1, b2) = (0.3f32, 0.4f32);
            let p = p0 + e1 * b1 + e2 * b2;
            let n = v().normalize();
            let err = tri_point_err(p0, e1, e2, b1, b2);
            let q = offset_ray_origin(p, err, n);
            let f = |a: V3| [a.x as f64, a.y as f64, a.z as f64];
            let (p, q, n, err) = (f(p), f(q), f(n), f(err));
            let along = (0..3).map(|k| (q[k] - p[k]) * n[k]).sum::<f64>();
            let reach = (0..3).map(|k| n[k].abs() * err[k]).sum::<f64>();
            assert!(along > reach * (1.0 - 1e-6), "{i}: {along} <= {reach}");
            let ulp = (0..3).map(|k| q[k].abs()).fold(0.0, f64::max) * f32::EPSILON as f64;
            assert!(along < reach + 4.0 * ulp, "{i}: {along} vs {reach}");
        }
    }

    #[test]
    fn triangle_hit_and_miss() {
        let (p0, e1, e2) = (
            V3::new(0.0, 0.0, 1.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        );
        let o = V3::new(0.25, 0.25, 0.0);
        let d = V3::new(0.0, 0.0, 1.0);
        let (t, u, v) = intersect_triangle(o, d, p0, e1, e2, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (u - 0.25).abs() < 1e-6 && (v - 0.25).abs() < 1e-6);
        assert!(intersect_triangle(V3::new(0.8, 0.8, 0.0), d, p0, e1, e2, f32::INFINITY).is_none());
        assert!(intersect_triangle(o, d, p0, e1, e2, 0.5).is_none());
    }

    #[test]
    fn sphere_from_outside_and_inside() {
        let c = V3::new(0.0, 0.0, 5.0);
        let t = intersect_sphere(
            V3::splat(0.0),
            V3::new(0.0, 0.0, 1.0),
            c,
            1.0,
            f32::INFINITY,
        )
        .unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let t = intersect_sphere(c, V3::new(0.0, 1.0, 0.0), c, 1.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        assert!(intersect_sphere(
            V3::splat(0.0),
            V3::new(0.0, 1.0, 0.0),
            c,
            1.0,
            f32::INFINITY
        )
        .is_none());
    }
}
