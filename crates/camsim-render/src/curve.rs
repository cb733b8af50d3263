//! Curves in the tracer (pbrt-v4 `Curve`, 4th ed. sec. 6.7): cubic Bezier segments of a given
//! width, intersected as a ribbon that faces the ray, by recursive subdivision.
//!
//! Each segment of a [`camsim_scene3d::curves::Curves`] is bounded in the BVH by up to
//! `2^splitdepth` pieces ([`crate::geometry::Prim::Curve`], each a `u` range of its segment; the
//! piece's control points come from blossoming the segment's): as many as keep each piece within
//! a few widths of length (see [`add_prims`]). A ray meets a piece in the ray's own frame (z
//! along the ray, the ray at the origin): the piece is split in halves at `u = 1/2` up to a
//! depth chosen from its curvature and width, halves whose width-grown boxes miss the ray are
//! skipped, and at the last level the curve is tested as the line between its end points: the
//! parameter `w` of the point nearest the ray, the curve point and width there, a hit when the
//! ray passes within half the width of that point, in front of the cuts perpendicular to the
//! curve at both ends. The hit's `u` runs along the segment (0..1) and `v` across it (0..1, 1/2
//! on the centre line; `v > 1/2` when the ray passes on the side of `ray x dp/du`); its point
//! is on the ray at the depth of the curve's centre line.
//!
//! Normals per type: `flat` along the ray's component perpendicular to the curve (the ribbon
//! faces the ray); `ribbon` the segment-end normals interpolated by spherical linear
//! interpolation in `u` (and the width seen by the ray scales with `|n . d|`); `cylinder` as
//! pbrt-v4 (`Curve::InteractionFromIntersection`): the ray-facing `dp/dv` turned about the curve
//! by `-theta`, `theta = (v - 1/2) 180 deg`, so that `n = dp/du x dp/dv` runs over the outward
//! normals of the tube's far half (at the centre it points away from the viewer; at the edges
//! outward). Turned toward the viewer, that field is the near half's mirrored across the plane
//! of the axis and the ray; it decides the side spawned rays leave from (one hit width off),
//! and together with the hair BSDF's offset `h = 2 v - 1` (`bsdf::hair::h_from_v`, pbrt-v4's,
//! mirrored the same way) it reproduces pbrt-v4's fibres: on Bitterli's `hair-curl` over 40
//! pbrt-v4 seeds, camsim's earlier near-half normals with the tube's own offset left 9 of 150
//! blocks beyond 4 standard errors at the references' 160 px and 11 at 320 px.

use crate::geometry::Aabb;
use crate::math::V3;
use camsim_scene3d::curves::{CurveType, Curves};

/// Marks a segment without ribbon normals.
const NO_NORMAL: u32 = u32::MAX;

/// Deepest subdivision of one piece (pbrt-v4's limit).
const MAX_DEPTH: i32 = 10;

/// One cubic Bezier segment in the tracer (20 bytes; its control points live in
/// [`CurveStore::points`]).
#[derive(Debug, Clone, Copy)]
pub struct CurveSeg {
    /// Index of the first of its four control points.
    first: u32,
    /// Width at `u = 0` and `u = 1`, m.
    w: [f32; 2],
    /// Index of its normal at `u = 0` in [`CurveStore::normals`] (the one at `u = 1` follows),
    /// or [`NO_NORMAL`].
    normal: u32,
    kind: CurveType,
    /// The shape's orientation is reversed (pbrt-v4 `reverseOrientation ^
    /// transformSwapsHandedness`): the normal is negated.
    flip: bool,
}

/// Every curve segment of a scene: control points shared between consecutive segments of one
/// curve, and ribbon normals.
#[derive(Debug, Clone, Default)]
pub struct CurveStore {
    points: Vec<V3>,
    segs: Vec<CurveSeg>,
    normals: Vec<V3>,
}

/// What the shading code needs at a curve hit.
#[derive(Debug, Clone, Copy)]
pub struct CurveSurface {
    pub p: V3,
    /// Unit normal (see the module docs per type; negated for a reversed shape).
    pub n: V3,
    /// dp/du: along the curve (the hair fibre's direction), m per unit u.
    pub dpdu: V3,
    /// pbrt-v4's error bound of the hit point per axis, m: the width at the hit (the point is
    /// on the ribbon, not on the tube it stands for). Spawned rays start this far off.
    pub err: f32,
}

#[inline(always)]
fn lerp(t: f32, a: V3, b: V3) -> V3 {
    a * (1.0 - t) + b * t
}

/// The blossom `B(t0, t1, t2)` of a cubic Bezier (de Casteljau with a parameter per level):
/// `B(a, a, a)` is the curve point at `a`; `B(u0, u0, u0), B(u0, u0, u1), B(u0, u1, u1),
/// B(u1, u1, u1)` are the control points of the piece over `[u0, u1]` (Ramshaw 1987).
#[inline]
fn blossom(cp: &[V3; 4], t0: f32, t1: f32, t2: f32) -> V3 {
    let a = [
        lerp(t0, cp[0], cp[1]),
        lerp(t0, cp[1], cp[2]),
        lerp(t0, cp[2], cp[3]),
    ];
    let b = [lerp(t1, a[0], a[1]), lerp(t1, a[1], a[2])];
    lerp(t2, b[0], b[1])
}

/// Control points of the piece `[u0, u1]` of a cubic Bezier.
#[inline]
fn sub_curve(cp: &[V3; 4], u0: f32, u1: f32) -> [V3; 4] {
    if u0 == 0.0 && u1 == 1.0 {
        return *cp;
    }
    [
        blossom(cp, u0, u0, u0),
        blossom(cp, u0, u0, u1),
        blossom(cp, u0, u1, u1),
        blossom(cp, u1, u1, u1),
    ]
}

/// The two halves of a cubic Bezier split at 1/2 (de Casteljau), sharing the middle point.
#[inline]
fn split_half(cp: &[V3; 4]) -> [V3; 7] {
    let m01 = (cp[0] + cp[1]) * 0.5;
    let m12 = (cp[1] + cp[2]) * 0.5;
    let m23 = (cp[2] + cp[3]) * 0.5;
    let a = (m01 + m12) * 0.5;
    let b = (m12 + m23) * 0.5;
    let mid = (a + b) * 0.5;
    [cp[0], m01, a, mid, b, m23, cp[3]]
}

/// Point and derivative (d/dt) of a cubic Bezier at `t`; a vanishing derivative (coincident
/// control points at an end) falls back to the chord.
#[inline]
fn eval(cp: &[V3; 4], t: f32) -> (V3, V3) {
    let a = [
        lerp(t, cp[0], cp[1]),
        lerp(t, cp[1], cp[2]),
        lerp(t, cp[2], cp[3]),
    ];
    let b = [lerp(t, a[0], a[1]), lerp(t, a[1], a[2])];
    let mut d = (b[1] - b[0]) * 3.0;
    if d.length_squared() == 0.0 {
        d = cp[3] - cp[0];
    }
    (lerp(t, b[0], b[1]), d)
}

/// `round(log2 x)` as pbrt-v4's `Log2Int(float)` (rounding at sqrt 2), for `x > 0`.
#[inline]
fn log2_round(x: f32) -> i32 {
    let l = x.log2();
    if l >= 0.0 {
        (l + 0.5).floor() as i32
    } else {
        -((-l + 0.5).floor() as i32)
    }
}

/// Bounds of four points.
#[inline]
fn bounds4(cp: &[V3; 4]) -> Aabb {
    let mut b = Aabb::EMPTY;
    for p in cp {
        b.grow_point(*p);
    }
    b
}

/// The ray-facing test state of one piece.
struct Walk<'a> {
    seg: &'a CurveSeg,
    /// Ribbon: the end normals and the angle between them.
    ribbon: Option<(V3, V3, f32)>,
    /// World direction of the ray (unit).
    d: V3,
    t_max: f32,
    /// Stop at the first hit (shadow rays).
    any: bool,
    best: Option<(f32, f32, f32)>,
}

impl Walk<'_> {
    #[inline]
    fn width(&self, u: f32) -> f32 {
        (1.0 - u) * self.seg.w[0] + u * self.seg.w[1]
    }

    /// Whether the piece's box grown by half its widest width can hold the ray segment
    /// `(0, 0, 0)..(0, 0, t_max)` of the ray frame.
    #[inline]
    fn overlaps(&self, cp: &[V3; 4], u0: f32, u1: f32) -> bool {
        let half = 0.5 * self.width(u0).max(self.width(u1));
        let b = bounds4(cp);
        b.min.x - half <= 0.0
            && b.max.x + half >= 0.0
            && b.min.y - half <= 0.0
            && b.max.y + half >= 0.0
            && b.min.z - half <= self.t_max
            && b.max.z + half >= 0.0
    }

    /// Recursive subdivision; `cp` in the ray frame. Returns true to stop (an any-hit found).
    fn recurse(&mut self, cp: &[V3; 4], u0: f32, u1: f32, depth: i32) -> bool {
        if depth > 0 {
            let s = split_half(cp);
            let um = 0.5 * (u0 + u1);
            for (half, (a, b)) in [(0usize, (u0, um)), (3, (um, u1))] {
                let c = [s[half], s[half + 1], s[half + 2], s[half + 3]];
                if self.overlaps(&c, a, b) && self.recurse(&c, a, b, depth - 1) {
                    return true;
                }
            }
            return false;
        }
        self.leaf(cp, u0, u1)
    }

    /// The last level: the piece as the line between its ends (pbrt-v4 4th ed. sec. 6.7.3).
    fn leaf(&mut self, cp: &[V3; 4], u0: f32, u1: f32) -> bool {
        // The ray (the origin of the xy plane) must lie past the cut perpendicular to the
        // curve at its start and before the one at its end.
        let (p0, p1, p2, p3) = (cp[0], cp[1], cp[2], cp[3]);
        if (p1.y - p0.y) * -p0.y + p0.x * (p0.x - p1.x) < 0.0 {
            return false;
        }
        if (p2.y - p3.y) * -p3.y + p3.x * (p3.x - p2.x) < 0.0 {
            return false;
        }
        let (sx, sy) = (p3.x - p0.x, p3.y - p0.y);
        let denom = sx * sx + sy * sy;
        if denom == 0.0 {
            return false;
        }
        let w = -(p0.x * sx + p0.y * sy) / denom;
        let u = ((1.0 - w) * u0 + w * u1).clamp(u0, u1);
        let mut hit_width = self.width(u);
        if let Some((n0, n1, angle)) = self.ribbon {
            hit_width *= slerp(n0, n1, angle, u).dot(self.d).abs();
        }
        let (pc, dpcdw) = eval(cp, w.clamp(0.0, 1.0));
        let dist2 = pc.x * pc.x + pc.y * pc.y;
        if dist2 > 0.25 * hit_width * hit_width {
            return false;
        }
        if !(pc.z > 0.0 && pc.z < self.t_max) {
            return false;
        }
        // Which side of the centre line the ray passes (the sign of the 2D cross product of
        // the curve point and its tangent).
        let dist = dist2.sqrt();
        let edge = dpcdw.x * -pc.y + pc.x * dpcdw.y;
        let v = if edge > 0.0 {
            0.5 + dist / hit_width
        } else {
            0.5 - dist / hit_width
        };
        self.t_max = pc.z;
        self.best = Some((pc.z, u, v.clamp(0.0, 1.0)));
        self.any
    }
}

/// Spherical linear interpolation between unit vectors `n0` and `n1` that make `angle`.
#[inline]
fn slerp(n0: V3, n1: V3, angle: f32, u: f32) -> V3 {
    if angle == 0.0 {
        return n0;
    }
    let inv = 1.0 / angle.sin();
    n0 * (((1.0 - u) * angle).sin() * inv) + n1 * ((u * angle).sin() * inv)
}

/// The angle between unit vectors (robust near 0 and pi: 2 atan2(|a - b|, |a + b|)).
#[inline]
fn angle_between(a: V3, b: V3) -> f32 {
    2.0 * (a - b).length().atan2((a + b).length())
}

/// An orthonormal pair perpendicular to the unit vector `d`.
#[inline]
fn perpendicular(d: V3) -> V3 {
    crate::math::Frame::from_normal(d).s
}

impl CurveStore {
    /// Add a shape's curve segments (`flip`: its orientation is reversed); returns the index of
    /// its first segment. The curve must have been validated ([`Curves::validate`]).
    pub fn add(&mut self, c: &Curves, flip: bool) -> u32 {
        let first_seg = self.segs.len() as u32;
        let base = self.points.len() as u32;
        self.points
            .extend(c.points.iter().map(|p| V3::new(p[0], p[1], p[2])));
        let nbase = self.normals.len() as u32;
        self.normals
            .extend(c.normals.iter().map(|n| V3::new(n[0], n[1], n[2])));
        for i in 0..c.segments() {
            self.segs.push(CurveSeg {
                first: base + 3 * i as u32,
                w: c.segment_width_m(i),
                normal: if c.normals.is_empty() {
                    NO_NORMAL
                } else {
                    nbase + i as u32
                },
                kind: c.kind,
                flip,
            });
        }
        first_seg
    }

    /// Copy segment `seg` of `from` (its four control points and ribbon normals) into `self`;
    /// returns its index here. A moving group's BVH holds its curves this way (`crate::motion`).
    pub(crate) fn copy_segment(&mut self, from: &CurveStore, seg: u32) -> u32 {
        let s = from.segs[seg as usize];
        let first = self.points.len() as u32;
        self.points.extend_from_slice(&from.control_points(&s));
        let normal = if s.normal == NO_NORMAL {
            NO_NORMAL
        } else {
            let n = self.normals.len() as u32;
            let k = s.normal as usize;
            self.normals.extend_from_slice(&from.normals[k..k + 2]);
            n
        };
        self.segs.push(CurveSeg { first, normal, ..s });
        (self.segs.len() - 1) as u32
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.segs.len()
    }

    /// True when there are no curves.
    pub fn is_empty(&self) -> bool {
        self.segs.is_empty()
    }

    /// Bytes held (diagnostics).
    pub fn bytes(&self) -> usize {
        self.points.len() * std::mem::size_of::<V3>()
            + self.segs.len() * std::mem::size_of::<CurveSeg>()
            + self.normals.len() * std::mem::size_of::<V3>()
    }

    #[inline]
    fn control_points(&self, s: &CurveSeg) -> [V3; 4] {
        let f = s.first as usize;
        [
            self.points[f],
            self.points[f + 1],
            self.points[f + 2],
            self.points[f + 3],
        ]
    }

    #[inline]
    fn ribbon(&self, s: &CurveSeg) -> Option<(V3, V3, f32)> {
        (s.normal != NO_NORMAL).then(|| {
            let (n0, n1) = (
                self.normals[s.normal as usize],
                self.normals[s.normal as usize + 1],
            );
            (n0, n1, angle_between(n0, n1))
        })
    }

    /// World bounds of the piece `[u0, u1]` of segment `seg`: its control points' box grown by
    /// half its widest width (pbrt-v4 `Curve::Bounds`).
    pub fn piece_bounds(&self, seg: u32, u0: f32, u1: f32) -> Aabb {
        let s = &self.segs[seg as usize];
        let cp = sub_curve(&self.control_points(s), u0, u1);
        let mut b = bounds4(&cp);
        let half = 0.5 * ((1.0 - u0) * s.w[0] + u0 * s.w[1]).max((1.0 - u1) * s.w[0] + u1 * s.w[1]);
        b.min = b.min - V3::splat(half);
        b.max += V3::splat(half);
        b
    }

    /// Nearest hit `(t, u, v)` of the ray `o + t d` (`d` unit) with the piece `[u0, u1]` of
    /// segment `seg` in `(0, t_max)`; with `any`, the first hit found.
    pub fn intersect(
        &self,
        seg: u32,
        [u0, u1]: [f32; 2],
        o: V3,
        d: V3,
        t_max: f32,
        any: bool,
    ) -> Option<(f32, f32, f32)> {
        let s = &self.segs[seg as usize];
        let cp_world = sub_curve(&self.control_points(s), u0, u1);
        // The ray's frame (pbrt-v4 `LookAt(o, o + d, d x chord)`): z along the ray, x along the
        // chord's component perpendicular to it.
        let up = d.cross(cp_world[3] - cp_world[0]);
        let up = if up.length_squared() > 0.0 {
            up.normalize()
        } else {
            perpendicular(d)
        };
        let x = up.cross(d).normalize();
        let y = d.cross(x);
        let cp = cp_world.map(|p| {
            let q = p - o;
            V3::new(q.dot(x), q.dot(y), q.dot(d))
        });
        let mut walk = Walk {
            seg: s,
            ribbon: self.ribbon(s),
            d,
            t_max,
            any,
            best: None,
        };
        if !walk.overlaps(&cp, u0, u1) {
            return None;
        }
        // Subdivision depth: enough halvings that the piece's curvature (its control polygon's
        // second differences, L0) deviates from a line by well under a twentieth of the width
        // (pbrt-v4 4th ed. sec. 6.7.3).
        let mut l0 = 0f32;
        for i in 0..2 {
            let sd = cp[i] - cp[i + 1] * 2.0 + cp[i + 2];
            l0 = l0.max(sd.x.abs()).max(sd.y.abs()).max(sd.z.abs());
        }
        let depth = if l0 > 0.0 {
            let eps = s.w[0].max(s.w[1]) * 0.05;
            (log2_round(std::f32::consts::SQRT_2 * 6.0 * l0 / (8.0 * eps)) / 2).clamp(0, MAX_DEPTH)
        } else {
            0
        };
        walk.recurse(&cp, u0, u1, depth);
        walk.best
    }

    /// The surface at a hit `(t, u, v)` of segment `seg` by the ray `o + t d`.
    pub fn surface(&self, seg: u32, o: V3, d: V3, t: f32, u: f32, v: f32) -> CurveSurface {
        let s = &self.segs[seg as usize];
        let (_, mut dpdu) = eval(&self.control_points(s), u);
        if !(dpdu.length_squared() > 0.0) {
            dpdu = perpendicular(d);
        }
        let mut hit_width = (1.0 - u) * s.w[0] + u * s.w[1];
        let dpdv = match (s.kind, self.ribbon(s)) {
            (CurveType::Ribbon, Some((n0, n1, angle))) => {
                let nh = slerp(n0, n1, angle, u);
                hit_width *= nh.dot(d).abs();
                nh.cross(dpdu)
            }
            _ => {
                // In the plane facing the ray, perpendicular to the curve.
                let mut w = d.cross(dpdu);
                if !(w.length_squared() > 0.0) {
                    w = perpendicular(dpdu.normalize());
                }
                let w = w.normalize();
                if s.kind == CurveType::Cylinder {
                    // Turn about the curve by -theta, theta = (v - 1/2) pi (Rodrigues; w is
                    // perpendicular to the axis k), as pbrt-v4: see the module docs.
                    let k = dpdu.normalize();
                    let (sn, cs) = ((v - 0.5) * std::f32::consts::PI).sin_cos();
                    w * cs - k.cross(w) * sn
                } else {
                    w
                }
            }
        };
        let mut n = dpdu.cross(dpdv).normalize();
        if !n.is_finite() {
            n = perpendicular(dpdu.normalize());
        }
        if s.flip {
            n = -n;
        }
        CurveSurface {
            p: o + d * t,
            n,
            dpdu,
            err: hit_width,
        }
    }
}

/// Longest BVH piece of a segment, in widths: a segment is split into halves until its pieces
/// are at most this long (when `splitdepth` allows), so that each box hugs its piece.
const PIECE_WIDTHS: f32 = 4.0;

/// Add a shape's curves to `store` and hand each BVH primitive to `push` with its segment's
/// index in the shape: segment `i` is split into `2^k` pieces of equal `u` range, `k` the
/// smallest level at which a piece's control polygon is at most [`PIECE_WIDTHS`] widths long,
/// capped by `split_depth` (pbrt-v4 `CreateCurve` always takes `2^splitdepth`: for a segment a
/// few widths long the extra boxes overlap and cost memory, about 115 bytes each, without
/// speeding up the trace).
pub(crate) fn add_prims(
    store: &mut CurveStore,
    c: &Curves,
    flip: bool,
    mut push: impl FnMut(u32, crate::geometry::Prim),
) {
    let first = store.add(c, flip);
    for i in 0..c.segments() as u32 {
        let s = &store.segs[(first + i) as usize];
        let cp = store.control_points(s);
        let len: f32 = (0..3).map(|k| (cp[k + 1] - cp[k]).length()).sum();
        let ratio = len / (PIECE_WIDTHS * s.w[0].max(s.w[1]));
        let k = if ratio > 1.0 {
            (ratio.log2().ceil() as u32).min(c.split_depth)
        } else {
            0
        };
        let pieces = 1u32 << k;
        for j in 0..pieces {
            push(
                i,
                crate::geometry::Prim::Curve {
                    seg: first + i,
                    u0: j as f32 / pieces as f32,
                    u1: (j + 1) as f32 / pieces as f32,
                },
            );
        }
    }
}

/// The shading frame of a fibre (pbrt-v4 `Frame::FromXZ(normalize(dpdu), n)`): x along the
/// curve, z the unit normal `n`, y = z x x. `dpdu` is made exactly perpendicular to `n` first.
#[inline]
pub fn fibre_frame(dpdu: V3, n: V3) -> crate::math::Frame {
    let mut x = (dpdu - n * n.dot(dpdu)).normalize();
    if !x.is_finite() {
        x = perpendicular(n);
    }
    crate::math::Frame {
        s: x,
        t: n.cross(x),
        n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(kind: CurveType, w: f32) -> CurveStore {
        let mut st = CurveStore::default();
        st.add(
            &Curves {
                kind,
                points: vec![
                    [-1.0, 0.0, 0.0],
                    [-1.0 / 3.0, 0.0, 0.0],
                    [1.0 / 3.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                ],
                width_m: [w, w],
                normals: if kind == CurveType::Ribbon {
                    vec![[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]
                } else {
                    vec![]
                },
                split_depth: 0,
            },
            false,
        );
        st
    }

    #[test]
    fn blossom_pieces_lie_on_the_curve() {
        let cp = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 2.0, 0.0),
            V3::new(2.0, -1.0, 1.0),
            V3::new(3.0, 0.5, 0.0),
        ];
        let piece = sub_curve(&cp, 0.25, 0.75);
        for t in [0.0f32, 0.3, 1.0] {
            let (a, _) = eval(&piece, t);
            let (b, _) = eval(&cp, 0.25 + 0.5 * t);
            assert!((a - b).length() < 1e-5);
        }
        let s = split_half(&cp);
        let (a, _) = eval(&[s[3], s[4], s[5], s[6]], 0.5);
        let (b, _) = eval(&cp, 0.75);
        assert!((a - b).length() < 1e-5);
    }

    #[test]
    fn straight_curve_hit_u_v_and_normal() {
        let st = straight(CurveType::Flat, 0.2);
        let d = V3::new(0.0, 0.0, 1.0);
        // Through the centre line at x = 0.5: u = 0.75, v = 1/2, t = 5.
        let (t, u, v) = st
            .intersect(
                0,
                [0.0, 1.0],
                V3::new(0.5, 0.0, -5.0),
                d,
                f32::INFINITY,
                false,
            )
            .unwrap();
        assert!((t - 5.0).abs() < 1e-5 && (u - 0.75).abs() < 1e-5 && (v - 0.5).abs() < 1e-5);
        // Off the line by 0.05 on the +y side (= d x dp/du = z x x): v = 0.5 + 0.05 / 0.2.
        let (_, _, v) = st
            .intersect(
                0,
                [0.0, 1.0],
                V3::new(0.5, 0.05, -5.0),
                d,
                f32::INFINITY,
                false,
            )
            .unwrap();
        assert!((v - 0.75).abs() < 1e-5, "{v}");
        // Beyond half the width: a miss; beyond the end cut: a miss.
        assert!(st
            .intersect(
                0,
                [0.0, 1.0],
                V3::new(0.5, 0.11, -5.0),
                d,
                f32::INFINITY,
                false
            )
            .is_none());
        assert!(st
            .intersect(
                0,
                [0.0, 1.0],
                V3::new(1.01, 0.0, -5.0),
                d,
                f32::INFINITY,
                false
            )
            .is_none());
        // Flat: the normal is along the ray's component perpendicular to the curve.
        let s = st.surface(0, V3::new(0.5, 0.05, -5.0), d, 5.0, 0.75, 0.75);
        assert!((s.n.dot(d).abs() - 1.0).abs() < 1e-6 && (s.err - 0.2).abs() < 1e-6);
        // Cylinder (pbrt-v4): n = (0, sin theta, cos theta), theta = (v - 1/2) pi, the far half's
        // outward normals: v = 1 points to the side the ray passes (+y), v = 1/2 away from the
        // viewer (+z, along the ray), v = 0 to the other side.
        let st = straight(CurveType::Cylinder, 0.2);
        let o = V3::new(0.5, 0.0, -5.0);
        for v in [0.05f32, 0.5, 0.75, 0.95] {
            let theta = (v - 0.5) * std::f32::consts::PI;
            let want = V3::new(0.0, theta.sin(), theta.cos());
            let n = st.surface(0, o, d, 5.0, 0.75, v).n;
            assert!((n - want).length() < 1e-5, "v {v}: {n:?}, want {want:?}");
        }
    }

    #[test]
    fn ribbon_normal_is_interpolated_and_narrows_the_width() {
        // Normals z at u = 0 and y at u = 1: at u = 1/2 the normal is (0, 1, 1)/sqrt 2, the
        // width seen along z is w cos 45 deg.
        let st = straight(CurveType::Ribbon, 0.2);
        let d = V3::new(0.0, 0.0, 1.0);
        let s = st.surface(0, V3::new(0.0, 0.0, -5.0), d, 5.0, 0.5, 0.5);
        let s45 = std::f32::consts::FRAC_1_SQRT_2;
        assert!((s.n.face_forward(d) - V3::new(0.0, s45, s45)).length() < 1e-5);
        assert!((s.err - 0.2 * s45).abs() < 1e-5);
        let hit = |y: f32| {
            st.intersect(
                0,
                [0.0, 1.0],
                V3::new(0.0, y, -5.0),
                d,
                f32::INFINITY,
                false,
            )
            .is_some()
        };
        assert!(hit(0.0699) && !hit(0.0716));
    }
}
