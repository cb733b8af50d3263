//! Bounding volume hierarchy: binned surface-area-heuristic build (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"; SAH: MacDonald & Booth 1990) of a
//! binary tree, collapsed into a 4-wide tree (Wald, Benthin & Boulos 2008, "Getting rid of
//! packets: efficient SIMD single-ray traversal using multi-branching BVHs"; Dammertz et al.
//! 2008, "Shallow Bounding Volume Hierarchies for Fast SIMD Ray Tracing of Incoherent Rays"):
//! every node holds its four children's boxes side by side, so one ray meets all four in one
//! 4-lane slab test, and every leaf of at most four triangles is stored as one 4-lane packet,
//! tested in one 4-lane Moller-Trumbore test. The lane arithmetic is written on `[f32; 4]`
//! arrays, which the compiler turns into SSE/NEON instructions on every target; the
//! arithmetic per lane is the scalar test's, operation for operation, so hits and distances
//! are bit-identical to [`Prim::intersect`]. Closest-hit traversal visits children nearest
//! first; the any-hit traversal (shadow rays) stops at the first hit.
//!
//! Memory is linear in the number of primitives: about `n / 3` nodes of 128 bytes, one
//! 192-byte packet per leaf (at most `n`), and the reordered primitives. The top of the binary
//! tree is built in parallel with `rayon::join`; the result does not depend on the number of
//! threads (every split decision is a function of the input only).

use crate::geometry::{intersect_partial_sphere, Aabb, Prim, RayInv, SphereClip};
use crate::math::V3;
use wide::{f32x4, CmpGe, CmpGt, CmpLe, CmpLt, CmpNe};

/// Number of SAH bins per axis.
const BINS: usize = 16;
/// Leaves hold at most this many primitives (unless all centroids coincide).
const MAX_LEAF: usize = 4;
/// SAH cost of a traversal step relative to one primitive test.
const TRAVERSAL_COST: f32 = 1.0;
/// Subtrees with fewer primitives than this are built on one thread.
const PARALLEL_THRESHOLD: usize = 16 * 1024;
/// Beyond this depth the builder splits at the median, so the tree depth stays below
/// `FORCE_MEDIAN_DEPTH + log2(n)` and fits the traversal stack.
const FORCE_MEDIAN_DEPTH: usize = 64;
/// Traversal stack size: a 4-wide node pushes at most 3 entries and the tree is at most
/// `FORCE_MEDIAN_DEPTH + log2(n)` binary levels deep.
const STACK: usize = 3 * 128;
/// Largest number of primitives a BVH can index (child references keep 30 bits of index).
pub const MAX_PRIMS: usize = 1 << 30;

/// Child references: an empty lane; a leaf (bit 31), which is a triangle packet (bit 30) or a
/// range of primitives tested one by one; else an interior node's index.
const EMPTY: u32 = u32::MAX;
const LEAF: u32 = 1 << 31;
const PACKET: u32 = 1 << 30;
const INDEX: u32 = PACKET - 1;

/// A node of the binary build tree (32 bytes). Interior: `count == 0`, left child is the next
/// node, right child is `index`. Leaf: `count > 0` primitives starting at `index`.
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct BinNode {
    min: [f32; 3],
    index: u32,
    max: [f32; 3],
    count: u32,
}

impl BinNode {
    fn new(b: &Aabb, index: u32, count: u32) -> BinNode {
        BinNode {
            min: [b.min.x, b.min.y, b.min.z],
            index,
            max: [b.max.x, b.max.y, b.max.z],
            count,
        }
    }
    fn half_area(&self) -> f32 {
        let d = [
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        ];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// A 4-wide node: `b[side][axis][lane]` is the min (side 0) or max (side 1) plane of child
/// `lane`'s box along `axis`. Empty lanes have every plane at +inf, which no ray enters.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub struct Node4 {
    b: [[[f32; 4]; 3]; 2],
    child: [u32; 4],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        b: [[[f32::INFINITY; 4]; 3]; 2],
        child: [EMPTY; 4],
    };

    /// Entry distances of the ray into the four child boxes within `(0, t_max)`, `f32::INFINITY`
    /// for a miss: the slab test of [`crate::geometry::ray_box`], four lanes at once, with the
    /// entry plane per axis chosen once per ray from the direction's sign. `fast_max(a, b)` is
    /// `a > b ? a : b` and `fast_min(a, b)` is `a < b ? a : b`, the scalar test's selections.
    #[inline(always)]
    fn hit(&self, r: &Ray4, t_max: f32) -> f32x4 {
        let mut t_near = f32x4::ZERO;
        let mut t_far = f32x4::splat(t_max);
        for axis in 0..3 {
            let near = f32x4::new(self.b[r.neg[axis]][axis]);
            let far = f32x4::new(self.b[1 - r.neg[axis]][axis]);
            let tn = (near - r.o[axis]) * r.inv_d[axis];
            let tf = (far - r.o[axis]) * r.inv_d[axis];
            t_near = tn.fast_max(t_near);
            t_far = tf.fast_min(t_far);
        }
        // Robust traversal slack (Ize 2013), as in the scalar test.
        t_near
            .cmp_le(t_far * f32x4::splat(1.000_000_2))
            .blend(t_near, f32x4::splat(f32::INFINITY))
    }
}

/// A ray with every component broadcast to four lanes, made once per traversal.
struct Ray4 {
    o: [f32x4; 3],
    d: [f32x4; 3],
    inv_d: [f32x4; 3],
    neg: [usize; 3],
}

impl Ray4 {
    #[inline(always)]
    fn new(r: &RayInv) -> Ray4 {
        let s = f32x4::splat;
        Ray4 {
            o: [s(r.o.x), s(r.o.y), s(r.o.z)],
            d: [s(r.d.x), s(r.d.y), s(r.d.z)],
            inv_d: [s(r.inv_d.x), s(r.inv_d.y), s(r.inv_d.z)],
            neg: r.neg,
        }
    }
}

/// Up to four triangles in structure-of-arrays form (`[axis][lane]`); unused lanes have zero
/// edges, so their determinant is 0 and they never report a hit. `start` is the slot of lane 0
/// in [`Bvh::prims`].
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub struct Tri4 {
    p0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
    start: u32,
}

impl Tri4 {
    /// The Moller & Trumbore (1997) test of [`crate::geometry::intersect_triangle`] in four
    /// lanes, operation for operation: per lane `(t, u, v)` with `t = f32::INFINITY` where the
    /// lane misses.
    #[inline(always)]
    fn hit(&self, r: &Ray4, t_max: f32) -> (f32x4, f32x4, f32x4) {
        let ld = |a: &[[f32; 4]; 3]| [f32x4::new(a[0]), f32x4::new(a[1]), f32x4::new(a[2])];
        let (p0, e1, e2) = (ld(&self.p0), ld(&self.e1), ld(&self.e2));
        let (o, d) = (&r.o, &r.d);
        // pvec = d x e2; det = e1 . pvec
        let px = d[1] * e2[2] - d[2] * e2[1];
        let py = d[2] * e2[0] - d[0] * e2[2];
        let pz = d[0] * e2[1] - d[1] * e2[0];
        let det = e1[0] * px + e1[1] * py + e1[2] * pz;
        let inv_det = f32x4::ONE / det;
        // tvec = o - p0; u = tvec . pvec / det
        let (tx, ty, tz) = (o[0] - p0[0], o[1] - p0[1], o[2] - p0[2]);
        let u = (tx * px + ty * py + tz * pz) * inv_det;
        // qvec = tvec x e1; v = d . qvec / det; t = e2 . qvec / det
        let qx = ty * e1[2] - tz * e1[1];
        let qy = tz * e1[0] - tx * e1[2];
        let qz = tx * e1[1] - ty * e1[0];
        let v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv_det;
        let t = (e2[0] * qx + e2[1] * qy + e2[2] * qz) * inv_det;
        let (zero, one, inf) = (f32x4::ZERO, f32x4::ONE, f32x4::splat(f32::INFINITY));
        let ok = det.cmp_ne(zero)
            & det.abs().cmp_lt(inf)
            & u.cmp_ge(zero)
            & u.cmp_le(one)
            & v.cmp_ge(zero)
            & (u + v).cmp_le(one)
            & t.cmp_gt(zero)
            & t.cmp_lt(f32x4::splat(t_max));
        (ok.blend(t, inf), u, v)
    }
}

/// A leaf whose primitives are tested one by one (spheres, or more than four primitives).
#[derive(Debug, Clone, Copy)]
struct Leaf {
    start: u32,
    count: u32,
}

/// A BVH over primitives; `prims` are reordered so every leaf's primitives are contiguous and
/// `ids[i]` is the caller's index of `prims[i]`.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node4>,
    packets: Vec<Tri4>,
    leaves: Vec<Leaf>,
    root: u32,
    bounds: Aabb,
    pub prims: Vec<Prim>,
    pub ids: Vec<u32>,
    /// Clips of the partial spheres among `prims` (empty by default; set by the caller).
    pub clips: Vec<crate::geometry::SphereClip>,
    /// The curve segments the curve pieces among `prims` refer to ([`Bvh::build_with_curves`]).
    pub curves: crate::curve::CurveStore,
}

/// A closest hit: distance, barycentrics and the primitive's position in [`Bvh::prims`]
/// (`Bvh::ids[slot]` is the caller's index).
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub slot: u32,
}

struct BuildCtx<'a> {
    bounds: &'a [Aabb],
    centroids: &'a [V3],
}

enum Sub {
    Flat(Vec<BinNode>),
    Split {
        bounds: Aabb,
        left: Box<Sub>,
        right: Box<Sub>,
    },
}

impl Bvh {
    /// Build over `prims` (their ids are their positions in the input). At most [`MAX_PRIMS`]
    /// primitives (callers check; a scene that large does not fit in memory anyway).
    pub fn build(prims: Vec<Prim>) -> Bvh {
        Self::build_with_curves(prims, crate::curve::CurveStore::default())
    }

    /// [`Bvh::build`] over primitives that include pieces of the curve segments in `curves`.
    pub fn build_with_curves(prims: Vec<Prim>, curves: crate::curve::CurveStore) -> Bvh {
        use rayon::prelude::*;
        let n = prims.len();
        assert!(n <= MAX_PRIMS, "a BVH holds at most {MAX_PRIMS} primitives");
        if n == 0 {
            return Bvh {
                nodes: Vec::new(),
                packets: Vec::new(),
                leaves: Vec::new(),
                root: EMPTY,
                bounds: Aabb::EMPTY,
                prims,
                ids: Vec::new(),
                clips: Vec::new(),
                curves,
            };
        }
        let bounds: Vec<Aabb> = prims.par_iter().map(|p| p.bounds_with(&curves)).collect();
        let centroids: Vec<V3> = bounds.par_iter().map(|b| b.center()).collect();
        let mut idx: Vec<u32> = (0..n as u32).collect();
        let ctx = BuildCtx {
            bounds: &bounds,
            centroids: &centroids,
        };
        let (b, cb) = range_bounds(&ctx, &idx);
        let sub = build_par(&ctx, &mut idx, 0, 0, b, cb);
        drop(bounds);
        drop(centroids);
        let mut bin = Vec::with_capacity(2 * n / MAX_LEAF + 2);
        flatten(sub, &mut bin);
        let ordered: Vec<Prim> = idx.iter().map(|&i| prims[i as usize]).collect();
        drop(prims);
        // The packet and leaf arrays at their exact sizes (`collapse` makes one of either per
        // binary leaf): grown by doubling, the 64-byte-aligned packets were reallocated by
        // copying, holding the old and the new array at once (49 MB more at the peak of
        // veach-ajar's render, measured with massif).
        let (mut n_packets, mut n_leaves) = (0, 0);
        for nd in bin.iter().filter(|nd| nd.count > 0) {
            let start = nd.index as usize;
            if is_packet(&ordered[start..start + nd.count as usize]) {
                n_packets += 1;
            } else {
                n_leaves += 1;
            }
        }
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(bin.len() / 3 + 1),
            packets: Vec::with_capacity(n_packets),
            leaves: Vec::with_capacity(n_leaves),
            root: EMPTY,
            bounds: b,
            prims: ordered,
            ids: idx,
            clips: Vec::new(),
            curves,
        };
        bvh.root = bvh.collapse(&bin, 0);
        bvh.nodes.shrink_to_fit();
        debug_assert_eq!((bvh.packets.len(), bvh.leaves.len()), (n_packets, n_leaves));
        bvh
    }

    /// Turn binary node `i` into a child reference of the wide tree: a leaf becomes a packet
    /// (at most four triangles) or a range; an interior node takes up to four descendants,
    /// opening the interior one of largest surface area first (the SAH's choice).
    fn collapse(&mut self, bin: &[BinNode], i: usize) -> u32 {
        let nd = &bin[i];
        if nd.count > 0 {
            let (start, count) = (nd.index as usize, nd.count as usize);
            let tris = &self.prims[start..start + count];
            if is_packet(tris) {
                let mut pk = Tri4 {
                    p0: [[0.0; 4]; 3],
                    e1: [[0.0; 4]; 3],
                    e2: [[0.0; 4]; 3],
                    start: start as u32,
                };
                for (lane, p) in tris.iter().enumerate() {
                    if let Prim::Tri { p0, e1, e2 } = *p {
                        for a in 0..3 {
                            pk.p0[a][lane] = p0[a];
                            pk.e1[a][lane] = e1[a];
                            pk.e2[a][lane] = e2[a];
                        }
                    }
                }
                self.packets.push(pk);
                return LEAF | PACKET | (self.packets.len() - 1) as u32;
            }
            self.leaves.push(Leaf {
                start: start as u32,
                count: count as u32,
            });
            return LEAF | (self.leaves.len() - 1) as u32;
        }
        let mut kids = [i + 1, nd.index as usize, 0, 0];
        let mut n = 2;
        while n < 4 {
            let open = (0..n)
                .filter(|&k| bin[kids[k]].count == 0)
                .max_by(|&a, &b| {
                    bin[kids[a]]
                        .half_area()
                        .total_cmp(&bin[kids[b]].half_area())
                });
            let Some(k) = open else { break };
            let c = kids[k];
            kids[k] = c + 1;
            kids[n] = bin[c].index as usize;
            n += 1;
        }
        let me = self.nodes.len();
        self.nodes.push(Node4::EMPTY);
        for (lane, &c) in kids[..n].iter().enumerate() {
            let r = self.collapse(bin, c);
            let node = &mut self.nodes[me];
            for a in 0..3 {
                node.b[0][a][lane] = bin[c].min[a];
                node.b[1][a][lane] = bin[c].max[a];
            }
            node.child[lane] = r;
        }
        me as u32
    }

    /// Bounds of the whole scene (empty box for an empty BVH).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Number of 4-wide nodes (diagnostics).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest intersection with `t` in `(0, t_max)`.
    #[inline]
    pub fn intersect(&self, r: &RayInv, mut t_max: f32) -> Option<Hit> {
        let (mut best, mut bu, mut bv) = (u32::MAX, 0f32, 0f32);
        let r4 = Ray4::new(r);
        // Uninitialised: zeroing the stack per ray costs as much as a traversal step.
        let mut stack: [std::mem::MaybeUninit<(u32, f32)>; STACK] =
            [std::mem::MaybeUninit::uninit(); STACK];
        let mut sp = 0usize;
        let mut cur = self.root;
        if cur == EMPTY {
            return None;
        }
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let t4 = node.hit(&r4, t_max);
                let mut mask = t4.cmp_lt(f32x4::splat(f32::INFINITY)).move_mask();
                let t = t4.to_array();
                // Compact the lanes that were entered, then visit them nearest first.
                let (mut ts, mut cs, mut k) = ([0f32; 4], [0u32; 4], 0usize);
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    ts[k] = t[lane];
                    cs[k] = node.child[lane];
                    k += 1;
                }
                if k > 0 {
                    // Insertion sort, farthest first, so the pushes leave the nearest on top.
                    for a in 1..k {
                        let mut j = a;
                        while j > 0 && ts[j - 1] < ts[j] {
                            ts.swap(j - 1, j);
                            cs.swap(j - 1, j);
                            j -= 1;
                        }
                    }
                    for j in 0..k - 1 {
                        stack[sp] = std::mem::MaybeUninit::new((cs[j], ts[j]));
                        sp += 1;
                    }
                    cur = cs[k - 1];
                    continue;
                }
            } else if cur & PACKET != 0 {
                let pk = &self.packets[(cur & INDEX) as usize];
                let (tt4, uu, vv) = pk.hit(&r4, t_max);
                if tt4.cmp_lt(f32x4::splat(f32::INFINITY)).any() {
                    let tt = tt4.to_array();
                    let mut lane = 4;
                    for (l, &t) in tt.iter().enumerate() {
                        if t < t_max {
                            t_max = t;
                            lane = l;
                        }
                    }
                    if lane < 4 {
                        best = pk.start + lane as u32;
                        bu = uu.to_array()[lane];
                        bv = vv.to_array()[lane];
                    }
                }
            } else {
                let leaf = self.leaves[(cur & INDEX) as usize];
                for i in leaf.start as usize..(leaf.start + leaf.count) as usize {
                    if let Some((t, u, v)) =
                        self.prims[i].intersect_with(r, t_max, &self.clips, &self.curves, false)
                    {
                        t_max = t;
                        (best, bu, bv) = (i as u32, u, v);
                    }
                }
            }
            // Pop the next subtree that can still hold a closer hit.
            loop {
                if sp == 0 {
                    return (best != u32::MAX).then_some(Hit {
                        t: t_max,
                        u: bu,
                        v: bv,
                        slot: best,
                    });
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written before being popped.
                let (c, t) = unsafe { stack[sp].assume_init() };
                if t < t_max {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// True when anything blocks the ray within `(0, t_max)` (shadow rays; stops at the first hit).
    #[inline]
    pub fn occluded(&self, r: &RayInv, t_max: f32) -> bool {
        let r4 = Ray4::new(r);
        let mut stack: [std::mem::MaybeUninit<u32>; STACK] =
            [std::mem::MaybeUninit::uninit(); STACK];
        let mut sp = 0usize;
        let mut cur = self.root;
        if cur == EMPTY {
            return false;
        }
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let mut mask = node
                    .hit(&r4, t_max)
                    .cmp_lt(f32x4::splat(f32::INFINITY))
                    .move_mask();
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack[sp] = std::mem::MaybeUninit::new(node.child[lane]);
                    sp += 1;
                }
            } else if cur & PACKET != 0 {
                let (tt, _, _) = self.packets[(cur & INDEX) as usize].hit(&r4, t_max);
                if tt.cmp_lt(f32x4::splat(f32::INFINITY)).any() {
                    return true;
                }
            } else {
                let leaf = self.leaves[(cur & INDEX) as usize];
                for i in leaf.start as usize..(leaf.start + leaf.count) as usize {
                    if self.prims[i]
                        .intersect_with(r, t_max, &self.clips, &self.curves, true)
                        .is_some()
                    {
                        return true;
                    }
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            // SAFETY: entries below `sp` were written before being popped.
            cur = unsafe { stack[sp].assume_init() };
        }
    }

    /// Depth of the 4-wide tree, leaves counted (tests, diagnostics).
    pub fn depth(&self) -> usize {
        fn rec(b: &Bvh, c: u32) -> usize {
            if c == EMPTY {
                0
            } else if c & LEAF != 0 {
                1
            } else {
                1 + b.nodes[c as usize]
                    .child
                    .iter()
                    .map(|&k| rec(b, k))
                    .max()
                    .unwrap_or(0)
            }
        }
        rec(self, self.root)
    }
}

/// Bounds of the primitives and of their centroids.
fn range_bounds(ctx: &BuildCtx, idx: &[u32]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for &i in idx {
        b.grow(&ctx.bounds[i as usize]);
        cb.grow_point(ctx.centroids[i as usize]);
    }
    (b, cb)
}

/// A split: size of the left part and the (bounds, centroid bounds) of both parts.
type Split = (usize, (Aabb, Aabb), (Aabb, Aabb));

/// Split at `mid` after ordering (or not) by the caller; bounds by a pass over both halves.
fn split_at(ctx: &BuildCtx, idx: &[u32], mid: usize) -> Split {
    (
        mid,
        range_bounds(ctx, &idx[..mid]),
        range_bounds(ctx, &idx[mid..]),
    )
}

/// Decide how to split `idx` (bounds `b`, centroid bounds `cb`); partition it and return the
/// split, or `None` for a leaf. Bins along the axis of largest centroid extent (Wald 2007).
fn split(ctx: &BuildCtx, idx: &mut [u32], b: &Aabb, cb: &Aabb, depth: usize) -> Option<Split> {
    let n = idx.len();
    if n <= 1 {
        return None;
    }
    let ext = cb.max - cb.min;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    if ext[axis] <= 0.0 || !ext[axis].is_finite() {
        // All centroids coincide: a leaf, unless too big, then split by count.
        return if n <= MAX_LEAF {
            None
        } else {
            Some(split_at(ctx, idx, n / 2))
        };
    }
    if depth >= FORCE_MEDIAN_DEPTH {
        let mid = n / 2;
        idx.select_nth_unstable_by(mid, |a, c| {
            ctx.centroids[*a as usize][axis].total_cmp(&ctx.centroids[*c as usize][axis])
        });
        return Some(split_at(ctx, idx, mid));
    }
    #[derive(Clone, Copy)]
    struct Bin {
        b: Aabb,
        cb: Aabb,
        n: u32,
    }
    let mut bins = [Bin {
        b: Aabb::EMPTY,
        cb: Aabb::EMPTY,
        n: 0,
    }; BINS];
    let lo = cb.min[axis];
    let scale = BINS as f32 * (1.0 - 1e-6) / ext[axis];
    let bin_of = |c: f32| -> usize { (((c - lo) * scale) as usize).min(BINS - 1) };
    for &i in idx.iter() {
        let c = ctx.centroids[i as usize];
        let bin = &mut bins[bin_of(c[axis])];
        bin.b.grow(&ctx.bounds[i as usize]);
        bin.cb.grow_point(c);
        bin.n += 1;
    }
    // Sweep from the right, then from the left: SAH cost of splitting after bin k.
    let mut right_area = [0f32; BINS];
    let mut right_n = [0u32; BINS];
    let mut acc = Aabb::EMPTY;
    let mut cnt = 0u32;
    for k in (1..BINS).rev() {
        acc.grow(&bins[k].b);
        cnt += bins[k].n;
        right_area[k] = acc.half_area();
        right_n[k] = cnt;
    }
    let mut best = (f32::INFINITY, 0usize);
    let mut acc = Aabb::EMPTY;
    let mut cnt = 0u32;
    for k in 0..BINS - 1 {
        acc.grow(&bins[k].b);
        cnt += bins[k].n;
        if cnt == 0 || right_n[k + 1] == 0 {
            continue;
        }
        let cost = acc.half_area() * cnt as f32 + right_area[k + 1] * right_n[k + 1] as f32;
        if cost < best.0 {
            best = (cost, k);
        }
    }
    let parent_area = b.half_area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + best.0 / parent_area;
    if n <= MAX_LEAF && split_cost >= n as f32 {
        return None;
    }
    if !best.0.is_finite() {
        return if n <= MAX_LEAF {
            None
        } else {
            Some(split_at(ctx, idx, n / 2))
        };
    }
    let k = best.1;
    // In-place partition: bin index <= k goes left.
    let mut i = 0usize;
    let mut j = n;
    while i < j {
        if bin_of(ctx.centroids[idx[i] as usize][axis]) <= k {
            i += 1;
        } else {
            j -= 1;
            idx.swap(i, j);
        }
    }
    if i == 0 || i == n {
        return Some(split_at(ctx, idx, n / 2));
    }
    let (mut l, mut r) = ((Aabb::EMPTY, Aabb::EMPTY), (Aabb::EMPTY, Aabb::EMPTY));
    for (kk, bin) in bins.iter().enumerate() {
        let side = if kk <= k { &mut l } else { &mut r };
        side.0.grow(&bin.b);
        side.1.grow(&bin.cb);
    }
    Some((i, l, r))
}

/// Serial build of a subtree into `out` with node indices relative to `out`'s start.
/// `offset` is the position of `idx[0]` in the global primitive order; `b`, `cb` the bounds
/// and centroid bounds of `idx`.
/// Whether a binary leaf's primitives become a triangle packet ([`Tri4`]): at most four
/// triangles; other leaves are tested one by one.
fn is_packet(prims: &[Prim]) -> bool {
    prims.len() <= 4 && prims.iter().all(|p| matches!(p, Prim::Tri { .. }))
}

fn build_serial(
    ctx: &BuildCtx,
    idx: &mut [u32],
    offset: usize,
    depth: usize,
    b: Aabb,
    cb: Aabb,
    out: &mut Vec<BinNode>,
) {
    match split(ctx, idx, &b, &cb, depth) {
        None => out.push(BinNode::new(&b, offset as u32, idx.len() as u32)),
        Some((mid, (lb, lcb), (rb, rcb))) => {
            let me = out.len();
            out.push(BinNode::new(&b, 0, 0));
            let (l, r) = idx.split_at_mut(mid);
            build_serial(ctx, l, offset, depth + 1, lb, lcb, out);
            out[me].index = out.len() as u32;
            build_serial(ctx, r, offset + mid, depth + 1, rb, rcb, out);
        }
    }
}

fn build_par(
    ctx: &BuildCtx,
    idx: &mut [u32],
    offset: usize,
    depth: usize,
    b: Aabb,
    cb: Aabb,
) -> Sub {
    if idx.len() < PARALLEL_THRESHOLD {
        let mut v = Vec::with_capacity(idx.len() * 2 / MAX_LEAF.max(1) + 1);
        build_serial(ctx, idx, offset, depth, b, cb, &mut v);
        return Sub::Flat(v);
    }
    match split(ctx, idx, &b, &cb, depth) {
        None => Sub::Flat(vec![BinNode::new(&b, offset as u32, idx.len() as u32)]),
        Some((mid, (lb, lcb), (rb, rcb))) => {
            let (l, r) = idx.split_at_mut(mid);
            let (left, right) = rayon::join(
                || build_par(ctx, l, offset, depth + 1, lb, lcb),
                || build_par(ctx, r, offset + mid, depth + 1, rb, rcb),
            );
            Sub::Split {
                bounds: b,
                left: Box::new(left),
                right: Box::new(right),
            }
        }
    }
}

fn flatten(sub: Sub, out: &mut Vec<BinNode>) {
    match sub {
        Sub::Flat(v) => {
            let base = out.len() as u32;
            out.extend(v.into_iter().map(|mut n| {
                if n.count == 0 {
                    n.index += base;
                }
                n
            }));
        }
        Sub::Split {
            bounds,
            left,
            right,
        } => {
            let me = out.len();
            out.push(BinNode::new(&bounds, 0, 0));
            flatten(*left, out);
            out[me].index = out.len() as u32;
            flatten(*right, out);
        }
    }
}

/// The primitive tests that need the BVH's side tables: partial-sphere clips and curve
/// segments ([`crate::curve`]), which the geometry module does not know.
impl Prim {
    /// World-space bounds, curve pieces from `curves`.
    pub fn bounds_with(&self, curves: &crate::curve::CurveStore) -> Aabb {
        match *self {
            Prim::Curve { seg, u0, u1 } => {
                if (seg as usize) < curves.len() {
                    curves.piece_bounds(seg, u0, u1)
                } else {
                    Aabb::EMPTY
                }
            }
            _ => self.bounds(),
        }
    }

    /// [`Prim::intersect`] with partial spheres clipped by `clips` (indexed by their `clip`)
    /// and curve pieces from `curves` (`(t, u, v)` with the curve's `u` and `v`); `any`: a
    /// curve piece may report any hit in range rather than its nearest (shadow rays).
    #[inline(always)]
    pub fn intersect_with(
        &self,
        r: &RayInv,
        t_max: f32,
        clips: &[SphereClip],
        curves: &crate::curve::CurveStore,
        any: bool,
    ) -> Option<(f32, f32, f32)> {
        match *self {
            Prim::Curve { seg, u0, u1 } => curves.intersect(seg, [u0, u1], r.o, r.d, t_max, any),
            Prim::PartialSphere {
                center,
                radius,
                clip,
            } => intersect_partial_sphere(r.o, r.d, center, radius, &clips[clip as usize], t_max)
                .map(|t| (t, 0.0, 0.0)),
            _ => self.intersect(r, t_max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{ray_box, Ray};
    use rand::Rng;

    /// The 4-lane slab test equals the scalar one lane by lane, misses and empty lanes included.
    #[test]
    fn wide_slab_test_equals_the_scalar_test() {
        let mut rng = camsim_core::rng::seeded(7);
        let mut checked = 0;
        for k in 0..20_000 {
            let mut node = Node4::EMPTY;
            let lanes = 1 + k % 4;
            let mut boxes = vec![];
            for lane in 0..lanes {
                let c: [f32; 3] = [
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.0..3.0),
                ];
                let h: [f32; 3] = [
                    rng.gen_range(0.0..1.0),
                    rng.gen_range(0.0..1.0),
                    if k % 7 == 0 {
                        0.0
                    } else {
                        rng.gen_range(0.0..1.0)
                    },
                ];
                let (min, max) = (
                    [c[0] - h[0], c[1] - h[1], c[2] - h[2]],
                    [c[0] + h[0], c[1] + h[1], c[2] + h[2]],
                );
                for a in 0..3 {
                    node.b[0][a][lane] = min[a];
                    node.b[1][a][lane] = max[a];
                }
                boxes.push((min, max));
            }
            let o = V3::new(
                rng.gen_range(-5.0..5.0),
                rng.gen_range(-5.0..5.0),
                rng.gen_range(-5.0..5.0),
            );
            // Aimed near a box (most rays hit it), with some axis-parallel directions.
            let (lo, hi) = boxes[k % lanes];
            let aim = V3::new(
                rng.gen_range(lo[0] - 0.3..hi[0] + 0.3),
                rng.gen_range(lo[1] - 0.3..hi[1] + 0.3),
                rng.gen_range(lo[2] - 0.3..hi[2] + 0.3),
            );
            let mut d = aim - o;
            if k % 5 == 0 {
                d.y = 0.0;
            }
            let r = RayInv::new(&Ray {
                o,
                d: d.normalize(),
            });
            let t_max = if k % 3 == 0 {
                rng.gen_range(0.5..6.0)
            } else {
                f32::INFINITY
            };
            let wide = node.hit(&Ray4::new(&r), t_max).to_array();
            for lane in 0..4 {
                let want = if lane < lanes {
                    ray_box(&r, &boxes[lane].0, &boxes[lane].1, t_max)
                } else {
                    f32::INFINITY
                };
                assert_eq!(wide[lane].to_bits(), want.to_bits(), "case {k} lane {lane}");
                checked += (want < f32::INFINITY) as usize;
            }
        }
        assert!(checked > 4000, "only {checked} hits");
    }
}
