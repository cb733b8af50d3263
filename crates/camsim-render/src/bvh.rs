//! Bounding volume hierarchy: binned surface-area-heuristic build (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"; SAH: MacDonald & Booth 1990),
//! flattened depth-first into 32-byte nodes with f32 boxes, iterative closest-hit traversal that
//! visits the nearer child first, and an any-hit traversal for shadow rays.
//!
//! Memory is linear in the number of primitives: at most `2 n - 1` nodes of 32 bytes plus the
//! reordered primitives. The top of the tree is built in parallel with `rayon::join`; the result
//! does not depend on the number of threads (every split decision is a function of the input only).

use crate::geometry::{ray_box, Aabb, Prim, RayInv};
use crate::math::V3;

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
/// Traversal stack size.
const STACK: usize = 128;

/// A flattened BVH node (32 bytes). Interior: `count == 0`, left child is the next node, right
/// child is `index`. Leaf: `count > 0` primitives starting at `index` in [`Bvh::prims`].
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub struct Node {
    pub min: [f32; 3],
    pub index: u32,
    pub max: [f32; 3],
    pub count: u32,
}

impl Node {
    fn new(b: &Aabb, index: u32, count: u32) -> Node {
        Node { min: [b.min.x, b.min.y, b.min.z], index, max: [b.max.x, b.max.y, b.max.z], count }
    }
}

/// A BVH over primitives; `prims` are reordered so every leaf's primitives are contiguous and
/// `ids[i]` is the caller's index of `prims[i]`.
#[derive(Debug, Clone)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    pub prims: Vec<Prim>,
    pub ids: Vec<u32>,
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
    Flat(Vec<Node>),
    Split { bounds: Aabb, left: Box<Sub>, right: Box<Sub> },
}

impl Bvh {
    /// Build over `prims` (their ids are their positions in the input).
    pub fn build(prims: Vec<Prim>) -> Bvh {
        use rayon::prelude::*;
        let n = prims.len();
        if n == 0 {
            return Bvh { nodes: Vec::new(), prims, ids: Vec::new() };
        }
        let bounds: Vec<Aabb> = prims.par_iter().map(|p| p.bounds()).collect();
        let centroids: Vec<V3> = bounds.par_iter().map(|b| b.center()).collect();
        let mut idx: Vec<u32> = (0..n as u32).collect();
        let ctx = BuildCtx { bounds: &bounds, centroids: &centroids };
        let (b, cb) = range_bounds(&ctx, &idx);
        let sub = build_par(&ctx, &mut idx, 0, 0, b, cb);
        let mut nodes = Vec::with_capacity(2 * n);
        flatten(sub, &mut nodes);
        nodes.shrink_to_fit();
        let ordered: Vec<Prim> = idx.iter().map(|&i| prims[i as usize]).collect();
        Bvh { nodes, prims: ordered, ids: idx }
    }

    /// Bounds of the whole scene (empty box for an empty BVH).
    pub fn bounds(&self) -> Aabb {
        match self.nodes.first() {
            Some(n) => Aabb { min: V3::new(n.min[0], n.min[1], n.min[2]), max: V3::new(n.max[0], n.max[1], n.max[2]) },
            None => Aabb::EMPTY,
        }
    }

    /// Closest intersection with `t` in `(0, t_max)`.
    #[inline]
    pub fn intersect(&self, r: &RayInv, mut t_max: f32) -> Option<Hit> {
        let nodes = &self.nodes[..];
        if nodes.is_empty() || ray_box(r, &nodes[0].min, &nodes[0].max, t_max) == f32::INFINITY {
            return None;
        }
        let mut best: Option<(f32, f32, u32)> = None;
        // Uninitialised: zeroing 1 KiB per ray costs as much as a traversal step.
        let mut stack: [std::mem::MaybeUninit<(u32, f32)>; STACK] = [std::mem::MaybeUninit::uninit(); STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let nd = &nodes[node];
            if nd.count > 0 {
                let start = nd.index as usize;
                for i in start..start + nd.count as usize {
                    if let Some((t, u, v)) = self.prims[i].intersect(r, t_max) {
                        t_max = t;
                        best = Some((u, v, i as u32));
                    }
                }
            } else {
                let (l, rr) = (node + 1, nd.index as usize);
                let tl = ray_box(r, &nodes[l].min, &nodes[l].max, t_max);
                let tr = ray_box(r, &nodes[rr].min, &nodes[rr].max, t_max);
                if tl < f32::INFINITY {
                    if tr < f32::INFINITY {
                        let (near, far, tf) = if tl <= tr { (l, rr, tr) } else { (rr, l, tl) };
                        stack[sp] = std::mem::MaybeUninit::new((far as u32, tf));
                        sp += 1;
                        node = near;
                    } else {
                        node = l;
                    }
                    continue;
                } else if tr < f32::INFINITY {
                    node = rr;
                    continue;
                }
            }
            // Pop the next subtree that can still hold a closer hit.
            loop {
                if sp == 0 {
                    return best.map(|(u, v, i)| Hit { t: t_max, u, v, slot: i });
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written before being popped.
                let (n, t) = unsafe { stack[sp].assume_init() };
                if t < t_max {
                    node = n as usize;
                    break;
                }
            }
        }
    }

    /// True when anything blocks the ray within `(0, t_max)` (shadow rays; stops at the first hit).
    #[inline]
    pub fn occluded(&self, r: &RayInv, t_max: f32) -> bool {
        let nodes = &self.nodes[..];
        if nodes.is_empty() || ray_box(r, &nodes[0].min, &nodes[0].max, t_max) == f32::INFINITY {
            return false;
        }
        let mut stack: [std::mem::MaybeUninit<u32>; STACK] = [std::mem::MaybeUninit::uninit(); STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let nd = &nodes[node];
            if nd.count > 0 {
                let start = nd.index as usize;
                for i in start..start + nd.count as usize {
                    if self.prims[i].intersect(r, t_max).is_some() {
                        return true;
                    }
                }
            } else {
                let (l, rr) = (node + 1, nd.index as usize);
                let hl = ray_box(r, &nodes[l].min, &nodes[l].max, t_max) < f32::INFINITY;
                let hr = ray_box(r, &nodes[rr].min, &nodes[rr].max, t_max) < f32::INFINITY;
                if hl {
                    if hr {
                        stack[sp] = std::mem::MaybeUninit::new(rr as u32);
                        sp += 1;
                    }
                    node = l;
                    continue;
                } else if hr {
                    node = rr;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            // SAFETY: entries below `sp` were written before being popped.
            node = unsafe { stack[sp].assume_init() } as usize;
        }
    }

    /// Depth of the tree (tests, diagnostics).
    pub fn depth(&self) -> usize {
        fn rec(nodes: &[Node], i: usize) -> usize {
            let n = &nodes[i];
            if n.count > 0 {
                1
            } else {
                1 + rec(nodes, i + 1).max(rec(nodes, n.index as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            rec(&self.nodes, 0)
        }
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
    (mid, range_bounds(ctx, &idx[..mid]), range_bounds(ctx, &idx[mid..]))
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
        return if n <= MAX_LEAF { None } else { Some(split_at(ctx, idx, n / 2)) };
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
    let mut bins = [Bin { b: Aabb::EMPTY, cb: Aabb::EMPTY, n: 0 }; BINS];
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
        return if n <= MAX_LEAF { None } else { Some(split_at(ctx, idx, n / 2)) };
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
fn build_serial(ctx: &BuildCtx, idx: &mut [u32], offset: usize, depth: usize, b: Aabb, cb: Aabb, out: &mut Vec<Node>) {
    match split(ctx, idx, &b, &cb, depth) {
        None => out.push(Node::new(&b, offset as u32, idx.len() as u32)),
        Some((mid, (lb, lcb), (rb, rcb))) => {
            let me = out.len();
            out.push(Node::new(&b, 0, 0));
            let (l, r) = idx.split_at_mut(mid);
            build_serial(ctx, l, offset, depth + 1, lb, lcb, out);
            out[me].index = out.len() as u32;
            build_serial(ctx, r, offset + mid, depth + 1, rb, rcb, out);
        }
    }
}

fn build_par(ctx: &BuildCtx, idx: &mut [u32], offset: usize, depth: usize, b: Aabb, cb: Aabb) -> Sub {
    if idx.len() < PARALLEL_THRESHOLD {
        let mut v = Vec::with_capacity(idx.len() * 2 / MAX_LEAF.max(1) + 1);
        build_serial(ctx, idx, offset, depth, b, cb, &mut v);
        return Sub::Flat(v);
    }
    match split(ctx, idx, &b, &cb, depth) {
        None => Sub::Flat(vec![Node::new(&b, offset as u32, idx.len() as u32)]),
        Some((mid, (lb, lcb), (rb, rcb))) => {
            let (l, r) = idx.split_at_mut(mid);
            let (left, right) = rayon::join(
                || build_par(ctx, l, offset, depth + 1, lb, lcb),
                || build_par(ctx, r, offset + mid, depth + 1, rb, rcb),
            );
            Sub::Split { bounds: b, left: Box::new(left), right: Box::new(right) }
        }
    }
}

fn flatten(sub: Sub, out: &mut Vec<Node>) {
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
        Sub::Split { bounds, left, right } => {
            let me = out.len();
            out.push(Node::new(&bounds, 0, 0));
            flatten(*left, out);
            out[me].index = out.len() as u32;
            flatten(*right, out);
        }
    }
}
