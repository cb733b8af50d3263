//! Spatially aware light selection: a bounding volume hierarchy over the bounded lights whose
//! nodes carry light bounds (box, power, cone of emission directions), after pbrt-v4's
//! `BVHLightSampler` (4th ed. sec. 12.6.3). At a shading point the sampler walks from the root,
//! choosing each child with probability proportional to its importance there (power over squared
//! distance, times the cosine bounds of the emitter's orientation and of the receiving surface),
//! so a small emitter inside a lamp fixture is not chosen for points it cannot light. Infinite
//! and distant lights are outside the tree and chosen with probability `n_inf / (n_inf + 1)`
//! (pbrt-v4's split), uniformly among themselves.
//!
//! The probability of a light at a point ([`LightBvh::pmf`]) follows the same path down the
//! tree (each light's branch bits), with the same arithmetic as [`LightBvh::sample`], so light
//! sampling and the MIS weight of a BSDF sample that hits the light agree exactly. Lights whose
//! importance is zero at a point (behind a one-sided emitter's whole cone, for example) have
//! probability zero there; they cannot light that point, so the estimate stays unbiased.

use crate::math::V3;
use std::f32::consts::PI;

/// Bounds of one light or of a group (pbrt-v4 `LightBounds`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LightBounds {
    pub min: V3,
    pub max: V3,
    /// Axis of the cone of surface normals (unit).
    pub w: V3,
    /// Emitted power (any consistent unit: only ratios matter).
    pub phi: f32,
    /// Cosine of the half-angle of the normal cone.
    pub cos_theta_o: f32,
    /// Cosine of the angle beyond the normal cone over which light is emitted (pi / 2 for
    /// diffuse emitters).
    pub cos_theta_e: f32,
    pub two_sided: bool,
}

/// `cos(max(0, theta_a - theta_b))` from sines and cosines (pbrt-v4 `cosSubClamped`).
#[inline(always)]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// `sin(max(0, theta_a - theta_b))` (pbrt-v4 `sinSubClamped`).
#[inline(always)]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

#[inline(always)]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

impl LightBounds {
    /// Union of two bounds (pbrt-v4 `Union(LightBounds, LightBounds)`): boxes and powers add up,
    /// the normal cones merge into the smallest cone holding both.
    fn union(a: &LightBounds, b: &LightBounds) -> LightBounds {
        if a.phi == 0.0 {
            return *b;
        }
        if b.phi == 0.0 {
            return *a;
        }
        let (w, cos_theta_o) = cone_union(a.w, a.cos_theta_o, b.w, b.cos_theta_o);
        LightBounds {
            min: a.min.min(b.min),
            max: a.max.max(b.max),
            w,
            phi: a.phi + b.phi,
            cos_theta_o,
            cos_theta_e: a.cos_theta_e.min(b.cos_theta_e),
            two_sided: a.two_sided || b.two_sided,
        }
    }

    fn centroid(&self) -> V3 {
        (self.min + self.max) * 0.5
    }

    /// Importance of these lights for a point `p` with surface normal `n` (see
    /// [`NodeBounds::importance`]).
    #[cfg(test)]
    pub(crate) fn importance(&self, p: V3, n: V3) -> f32 {
        NodeBounds::from(self).importance(p, n)
    }
}

/// [`LightBounds`] as the sampler reads them at every shading point: centre, squared
/// half-diagonal and the cone's sine precomputed.
#[derive(Debug, Clone, Copy)]
struct NodeBounds {
    centre: V3,
    half_diag2: f32,
    w: V3,
    phi: f32,
    cos_theta_o: f32,
    sin_theta_o: f32,
    cos_theta_e: f32,
    two_sided: bool,
}

impl NodeBounds {
    fn from(b: &LightBounds) -> NodeBounds {
        NodeBounds {
            centre: b.centroid(),
            half_diag2: ((b.max - b.min) * 0.5).length_squared(),
            w: b.w,
            phi: b.phi,
            cos_theta_o: b.cos_theta_o,
            sin_theta_o: safe_sqrt(1.0 - b.cos_theta_o * b.cos_theta_o),
            cos_theta_e: b.cos_theta_e,
            two_sided: b.two_sided,
        }
    }

    /// Importance of these lights for a point `p` with surface normal `n` (zero vector inside a
    /// medium): pbrt-v4 `LightBounds::Importance`. An upper bound of what any light inside can
    /// deliver, up to a common factor: `phi cos(theta') / d^2`, with `theta'` the smallest
    /// angle between the cone of emission and the direction to `p` over the box, and, at a
    /// surface, the cosine bound of the incident angle. The squared distance is clamped below
    /// by the squared half-diagonal of the box (pbrt-v4 clamps by the half-diagonal itself;
    /// the square keeps both terms in m^2: any positive bound is unbiased, this one only
    /// changes how close points weigh large groups).
    #[inline]
    fn importance(&self, p: V3, n: V3) -> f32 {
        let half_diag2 = self.half_diag2;
        let d = p - self.centre;
        let dist2 = d.length_squared();
        // Directions the box subtends from p (pbrt-v4 `BoundSubtendedDirections`): the
        // bounding sphere's cone, or every direction from inside it.
        if dist2 <= half_diag2 {
            // p inside the bounding sphere: every orientation term is bounded by 1.
            return self.phi / dist2.max(half_diag2).max(1e-12);
        }
        let sin2 = half_diag2 / dist2;
        let (sin_b, cos_b) = (sin2.sqrt(), safe_sqrt(1.0 - sin2));
        let wi = d / dist2.sqrt();
        let mut cos_w = self.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        let (sin_o, cos_o) = (self.sin_theta_o, self.cos_theta_o);
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut imp = self.phi * cos_p / dist2;
        if n != V3::splat(0.0) {
            let cos_i = wi.dot(n).abs();
            let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
            imp *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
        }
        imp.max(0.0)
    }
}

/// The smallest cone (axis, cosine of half-angle) holding two cones (pbrt-v4
/// `Union(DirectionCone, DirectionCone)`).
fn cone_union(wa: V3, cos_a: f32, wb: V3, cos_b: f32) -> (V3, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = wa.dot(wb).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (wa, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (wb, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= PI {
        return (wa, -1.0);
    }
    // Rotate wa toward wb by theta_o - theta_a about wa x wb (Rodrigues, axis orthogonal to wa).
    let theta_r = theta_o - theta_a;
    let axis = wa.cross(wb);
    if axis.length_squared() == 0.0 {
        return (wa, -1.0);
    }
    let k = axis.normalize();
    let w = wa * theta_r.cos() + k.cross(wa) * theta_r.sin();
    (w.normalize(), theta_o.cos())
}

/// pbrt-v4's orientation measure of a cone (`EvaluateCost`'s `M_omega`): the solid angle the
/// emission directions sweep, cosine weighted.
fn orientation_measure(b: &LightBounds) -> f32 {
    let theta_o = b.cos_theta_o.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let (sin_o, cos_o) = theta_o.sin_cos();
    2.0 * PI * (1.0 - cos_o)
        + PI / 2.0
            * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                + cos_o)
}

#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: NodeBounds,
    /// Interior: index of the second child (the first is the next node). Leaf: the light.
    index: u32,
    leaf: bool,
}

/// The tree, and each light's way down it.
#[derive(Debug, Clone, Default)]
pub(crate) struct LightBvh {
    nodes: Vec<Node>,
    /// Infinite and distant lights (chosen outside the tree).
    infinite: Vec<u32>,
    /// Per light: branch bits from the root (bit k: second child at depth k) and depth, or
    /// `None` for lights outside the tree (infinite, or zero power).
    trail: Vec<Option<(u64, u32)>>,
}

/// Deepest tree a branch trail can describe.
const MAX_DEPTH: u32 = 63;

impl LightBvh {
    /// Build over `bounded` (light index, bounds; lights of zero power are left out: they are
    /// never chosen) with `infinite` chosen outside the tree; `n_lights` lights in all.
    pub(crate) fn build(
        bounded: Vec<(u32, LightBounds)>,
        infinite: Vec<u32>,
        n_lights: usize,
    ) -> LightBvh {
        let mut items: Vec<(u32, LightBounds)> = bounded
            .into_iter()
            .filter(|(_, b)| b.phi > 0.0 && b.phi.is_finite())
            .collect();
        let mut bvh = LightBvh {
            nodes: Vec::with_capacity(2 * items.len()),
            infinite,
            trail: vec![None; n_lights],
        };
        if !items.is_empty() {
            bvh.build_node(&mut items, 0, 0);
        }
        bvh
    }

    fn build_node(
        &mut self,
        items: &mut [(u32, LightBounds)],
        bits: u64,
        depth: u32,
    ) -> LightBounds {
        if items.len() == 1 {
            let (light, b) = items[0];
            self.nodes.push(Node {
                bounds: NodeBounds::from(&b),
                index: light,
                leaf: true,
            });
            self.trail[light as usize] = Some((bits, depth));
            return b;
        }
        let mid = split(items, depth);
        let node = self.nodes.len();
        self.nodes.push(Node {
            bounds: NodeBounds::from(&items[0].1),
            index: 0,
            leaf: false,
        });
        let (left, right) = items.split_at_mut(mid);
        let b0 = self.build_node(left, bits, depth + 1);
        self.nodes[node].index = self.nodes.len() as u32;
        let b1 = self.build_node(right, bits | (1u64 << depth), depth + 1);
        let b = LightBounds::union(&b0, &b1);
        self.nodes[node].bounds = NodeBounds::from(&b);
        b
    }

    /// Probability of choosing the infinite lights as a group.
    #[inline]
    fn p_infinite(&self) -> f32 {
        let n = self.infinite.len() as f32;
        n / (n + if self.nodes.is_empty() { 0.0 } else { 1.0 })
    }

    /// Choose a light for point `p` (surface normal `n`, zero in a medium) from the uniform
    /// number `u`: (light, probability), or `None` when no light can reach `p`.
    #[inline]
    pub(crate) fn sample(&self, p: V3, n: V3, u: f32) -> Option<(u32, f32)> {
        let p_inf = self.p_infinite();
        if u < p_inf {
            let k = self.infinite.len();
            let i = ((u / p_inf * k as f32) as usize).min(k - 1);
            return Some((self.infinite[i], p_inf / k as f32));
        }
        if self.nodes.is_empty() {
            return None;
        }
        const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;
        let mut u = ((u - p_inf) / (1.0 - p_inf)).min(ONE_MINUS_EPS);
        let mut pmf = 1.0 - p_inf;
        let mut i = 0usize;
        loop {
            let node = &self.nodes[i];
            if node.leaf {
                return (i > 0 || node.bounds.importance(p, n) > 0.0).then_some((node.index, pmf));
            }
            let (c0, c1) = (i + 1, node.index as usize);
            let i0 = self.nodes[c0].bounds.importance(p, n);
            let i1 = self.nodes[c1].bounds.importance(p, n);
            if i0 == 0.0 && i1 == 0.0 {
                return None;
            }
            let p0 = i0 / (i0 + i1);
            if u < p0 {
                i = c0;
                u = (u / p0).min(ONE_MINUS_EPS);
                pmf *= p0;
            } else {
                i = c1;
                u = ((u - p0) / (1.0 - p0)).min(ONE_MINUS_EPS);
                pmf *= 1.0 - p0;
            }
        }
    }

    /// Probability that [`LightBvh::sample`] at `p`, `n` chooses `light`.
    #[inline]
    pub(crate) fn pmf(&self, light: u32, p: V3, n: V3) -> f32 {
        let Some((bits, depth)) = self.trail.get(light as usize).copied().flatten() else {
            return if self.infinite.contains(&light) {
                self.p_infinite() / self.infinite.len() as f32
            } else {
                0.0
            };
        };
        let mut pmf = 1.0 - self.p_infinite();
        let mut i = 0usize;
        for k in 0..depth {
            let node = &self.nodes[i];
            let (c0, c1) = (i + 1, node.index as usize);
            let i0 = self.nodes[c0].bounds.importance(p, n);
            let i1 = self.nodes[c1].bounds.importance(p, n);
            if i0 == 0.0 && i1 == 0.0 {
                return 0.0;
            }
            let p0 = i0 / (i0 + i1);
            if bits & (1u64 << k) == 0 {
                i = c0;
                pmf *= p0;
            } else {
                i = c1;
                pmf *= 1.0 - p0;
            }
        }
        if depth == 0 && self.nodes[0].bounds.importance(p, n) <= 0.0 {
            return 0.0;
        }
        pmf
    }
}

/// Partition `items` (at least two) for a tree node and return the split index: pbrt-v4's
/// cost over 12 buckets of centroids along each axis (power x orientation measure x box
/// surface area, the box's aspect penalised); halves by count along the longest axis when no
/// bucket split separates the lights or the tree is too deep for the branch bits.
fn split(items: &mut [(u32, LightBounds)], depth: u32) -> usize {
    let (mut cmin, mut cmax) = (V3::splat(f32::INFINITY), V3::splat(f32::NEG_INFINITY));
    let (mut bmin, mut bmax) = (V3::splat(f32::INFINITY), V3::splat(f32::NEG_INFINITY));
    for (_, b) in items.iter() {
        cmin = cmin.min(b.centroid());
        cmax = cmax.max(b.centroid());
        bmin = bmin.min(b.min);
        bmax = bmax.max(b.max);
    }
    let diag = bmax - bmin;
    let max_extent = diag[0].max(diag[1]).max(diag[2]);
    const BUCKETS: usize = 12;
    let mut best: Option<(f32, usize, f32)> = None; // (cost, axis, split coordinate)
    if depth + (items.len() as f32).log2().ceil() as u32 + 2 < MAX_DEPTH {
        for axis in 0..3 {
            let (lo, hi) = (cmin[axis], cmax[axis]);
            if hi <= lo {
                continue;
            }
            let bucket = |b: &LightBounds| {
                (((b.centroid()[axis] - lo) / (hi - lo) * BUCKETS as f32) as usize).min(BUCKETS - 1)
            };
            let mut groups: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
            for (_, b) in items.iter() {
                let g = &mut groups[bucket(b)];
                *g = Some(match g {
                    Some(a) => LightBounds::union(a, b),
                    None => *b,
                });
            }
            let kr = if diag[axis] > 0.0 {
                max_extent / diag[axis]
            } else {
                1.0
            };
            let cost = |b: &LightBounds| {
                let d = b.max - b.min;
                let area = 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
                b.phi * orientation_measure(b) * kr * area.max(f32::MIN_POSITIVE)
            };
            for s in 1..BUCKETS {
                let merge = |r: std::ops::Range<usize>| {
                    groups[r]
                        .iter()
                        .flatten()
                        .fold(None::<LightBounds>, |acc, b| {
                            Some(acc.map_or(*b, |a| LightBounds::union(&a, b)))
                        })
                };
                let (Some(b0), Some(b1)) = (merge(0..s), merge(s..BUCKETS)) else {
                    continue;
                };
                let c = cost(&b0) + cost(&b1);
                if c.is_finite() && best.is_none_or(|(bc, _, _)| c < bc) {
                    best = Some((c, axis, lo + (hi - lo) * s as f32 / BUCKETS as f32));
                }
            }
        }
    }
    if let Some((_, axis, at)) = best {
        let lo = cmin[axis];
        let hi = cmax[axis];
        // Partition by bucket index (the same arithmetic as the cost's buckets).
        let s = (((at - lo) / (hi - lo) * BUCKETS as f32).round() as usize).clamp(1, BUCKETS - 1);
        let bucket = |b: &LightBounds| {
            (((b.centroid()[axis] - lo) / (hi - lo) * BUCKETS as f32) as usize).min(BUCKETS - 1)
        };
        let mut mid = 0;
        for i in 0..items.len() {
            if bucket(&items[i].1) < s {
                items.swap(i, mid);
                mid += 1;
            }
        }
        if mid > 0 && mid < items.len() {
            return mid;
        }
    }
    // Fallback: halves by count along the axis of the widest centroid spread (stable order).
    let ext = cmax - cmin;
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| {
        a.1.centroid()[axis]
            .total_cmp(&b.1.centroid()[axis])
            .then(a.0.cmp(&b.0))
    });
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn tri_bounds(p: V3, n: V3, size: f32, phi: f32, two_sided: bool) -> LightBounds {
        LightBounds {
            min: p - V3::splat(size),
            max: p + V3::splat(size),
            w: n,
            phi,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided,
        }
    }

    /// At random points and normals the probabilities of all lights sum to at most 1 (less by
    /// the branches whose children both have importance zero: no light there can reach the
    /// point), the infinite lights get n_inf / (n_inf + 1) between them, a zero-power light
    /// nothing; sampling returns each light with the probability `pmf` reports and nothing with
    /// the rest (frequencies within 5 standard errors).
    #[test]
    fn probabilities_sum_to_one_and_match_sampling() {
        let mut rng = camsim_core::rng::seeded(11);
        let mut bounded = Vec::new();
        for i in 0..40u32 {
            let p = V3::new(
                rng.gen::<f32>() * 4.0 - 2.0,
                rng.gen::<f32>() * 2.0,
                rng.gen(),
            );
            let n = V3::new(
                rng.gen::<f32>() - 0.5,
                rng.gen::<f32>() - 0.5,
                rng.gen::<f32>() - 0.5,
            )
            .normalize();
            let phi = 0.1 + rng.gen::<f32>() * 3.0;
            bounded.push((
                i,
                tri_bounds(p, n, 0.05 + 0.1 * rng.gen::<f32>(), phi, i % 3 == 0),
            ));
        }
        // A point light (full sphere) and a zero-power light (left out).
        bounded.push((
            40,
            LightBounds {
                min: V3::new(0.0, 3.0, 0.0),
                max: V3::new(0.0, 3.0, 0.0),
                w: V3::new(0.0, 0.0, 1.0),
                phi: 5.0,
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            },
        ));
        bounded.push((
            41,
            tri_bounds(V3::splat(0.0), V3::new(0.0, 1.0, 0.0), 0.1, 0.0, false),
        ));
        let bvh = LightBvh::build(bounded, vec![42, 43], 44);
        for _ in 0..200 {
            let p = V3::new(
                rng.gen::<f32>() * 6.0 - 3.0,
                rng.gen::<f32>() * 4.0 - 1.0,
                rng.gen::<f32>() * 2.0 - 0.5,
            );
            let n = if rng.gen::<f32>() < 0.2 {
                V3::splat(0.0)
            } else {
                V3::new(
                    rng.gen::<f32>() - 0.5,
                    rng.gen::<f32>() - 0.5,
                    rng.gen::<f32>() - 0.5,
                )
                .normalize()
            };
            let total: f64 = (0..44).map(|l| bvh.pmf(l, p, n) as f64).sum();
            assert!(
                total <= 1.0 + 1e-5 && total > 2.0 / 3.0,
                "sum {total} at {p:?}"
            );
            assert_eq!(bvh.pmf(41, p, n), 0.0);
            assert!((bvh.pmf(42, p, n) - 1.0 / 3.0).abs() < 1e-6);
        }
        // Frequencies at one point.
        let (p, n) = (V3::new(0.3, 0.5, 0.4), V3::new(0.0, 1.0, 0.0));
        let draws = 200_000;
        let mut count = [0u32; 44];
        let mut none = 0u32;
        for k in 0..draws {
            let u = (k as f32 + 0.5) / draws as f32;
            let Some((l, pmf)) = bvh.sample(p, n, u) else {
                none += 1;
                continue;
            };
            assert_eq!(pmf, bvh.pmf(l, p, n), "light {l}");
            count[l as usize] += 1;
        }
        let total: f64 = (0..44).map(|l| bvh.pmf(l, p, n) as f64).sum();
        let expect_none = (1.0 - total) * draws as f64;
        assert!(
            (none as f64 - expect_none).abs() < 5.0 * expect_none.max(1.0).sqrt() + 1.0,
            "{none} draws without a light, expected {expect_none}"
        );
        for l in 0..44u32 {
            let expect = bvh.pmf(l, p, n) as f64 * draws as f64;
            let sd = expect.max(1.0).sqrt();
            assert!(
                (count[l as usize] as f64 - expect).abs() < 5.0 * sd + 1.0,
                "light {l}: {} draws, expected {expect}",
                count[l as usize]
            );
        }
    }

    /// A one-sided emitter facing away from a point (its whole box behind it) has importance
    /// zero there; facing it, the importance falls off as 1 / d^2.
    #[test]
    fn importance_orientation_and_distance() {
        let b = tri_bounds(V3::splat(0.0), V3::new(0.0, 1.0, 0.0), 0.01, 1.0, false);
        let up = V3::new(0.0, 1.0, 0.0);
        assert_eq!(b.importance(V3::new(0.0, -2.0, 0.0), V3::splat(0.0)), 0.0);
        let i1 = b.importance(V3::new(0.0, 1.0, 0.0), -up);
        let i2 = b.importance(V3::new(0.0, 2.0, 0.0), -up);
        assert!((i1 / i2 - 4.0).abs() < 0.01, "{i1} / {i2}");
        let two = LightBounds {
            two_sided: true,
            ..b
        };
        assert!(two.importance(V3::new(0.0, -2.0, 0.0), V3::splat(0.0)) > 0.0);
    }
}
