//! Motion in the tracer (pbrt-v4 4th ed. sec. 3.9 and 7.1.4, `AnimatedPrimitive`): every camera
//! ray carries a time, and intersections, light samples, depth, ids and flow see the scene at
//! that time.
//!
//! Shapes that move (`camsim_scene3d::motion::TimeSettings::shapes`) are taken out of the static
//! BVH and grouped by their motion; each group has its own BVH over its primitives in their
//! stored (reference) pose and a world box that holds them over the whole shutter span. A ray
//! at time `t` is tested against the static BVH, then against every group whose box it enters,
//! moved into the group's reference pose by the inverse of the group's pose at `t` (the same
//! test pbrt-v4's `AnimatedPrimitive` makes). Hits on moving primitives get slots after the
//! static ones (`Tracer::info` holds both), so the integrator reads them as it reads any hit;
//! their surface is computed in the reference pose and moved to the world. A scene without
//! motion builds none of this and renders exactly as before (tested bit for bit).
//!
//! The poses of one path's time are computed when first needed and kept for the rest of the
//! path ([`TimeCache`]): a camera ray, its bounces and its shadow rays share one time.
//!
//! Moving emitters and moving point, spot, distant, goniometric and projection lights are
//! sampled in their reference pose from the reference point moved there, which is exact for a
//! rigid motion with uniform scale (a similarity keeps solid angles; a point light's `I / r^2`
//! is divided by the scale squared); a moving emitter whose motion stretches is refused.

use crate::bvh::{Bvh, Hit};
use crate::curve::CurveStore;
use crate::error::RenderError;
use crate::geometry::{ray_box, Aabb, Prim, Ray, RayInv, SphereClip};
use crate::geometry::{PrimInfo, NO_LIGHT};
use crate::math::V3;
use crate::scene::{Light, SceneDescription, Transform};
use camsim_scene3d::motion::Motion;
use std::cell::Cell;

/// Uniform time steps per shutter span when bounding a moving group (plus every key inside).
const BOUND_STEPS: usize = 64;

/// A 3 x 4 affine map in f32 (rows of `[linear | translation]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Affine {
    r: [[f32; 4]; 3],
}

impl Affine {
    fn from_rows(m: &[[f64; 4]; 3]) -> Affine {
        Affine {
            r: m.map(|row| row.map(|v| v as f32)),
        }
    }

    /// `m p + t`.
    #[inline(always)]
    pub(crate) fn point(&self, p: V3) -> V3 {
        let r = &self.r;
        V3::new(
            r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z + r[0][3],
            r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z + r[1][3],
            r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z + r[2][3],
        )
    }

    /// `m v`.
    #[inline(always)]
    pub(crate) fn vector(&self, v: V3) -> V3 {
        let r = &self.r;
        V3::new(
            r[0][0] * v.x + r[0][1] * v.y + r[0][2] * v.z,
            r[1][0] * v.x + r[1][1] * v.y + r[1][2] * v.z,
            r[2][0] * v.x + r[2][1] * v.y + r[2][2] * v.z,
        )
    }

    /// The error bound of `point(p)` for a point `p` known to within `err` per axis: the
    /// rounding of the product plus the propagated error (pbrt-v4 4th ed. sec. 6.8.6,
    /// `Transform` applied to a `Point3fi`: `g (|m| |p| + |t|) + (1 + g) |m| err`), with
    /// camsim's [`crate::geometry::POINT_ERR_SCALE`] for pbrt-v4's `gamma(3)`.
    #[inline(always)]
    pub(crate) fn point_error(&self, p: V3, err: V3) -> V3 {
        let g3 = crate::geometry::POINT_ERR_SCALE;
        let r = &self.r;
        let row = |i: usize| {
            let a = r[i][0].abs() * p.x.abs()
                + r[i][1].abs() * p.y.abs()
                + r[i][2].abs() * p.z.abs()
                + r[i][3].abs();
            let e = r[i][0].abs() * err.x + r[i][1].abs() * err.y + r[i][2].abs() * err.z;
            g3 * a + (1.0 + g3) * e
        };
        V3::new(row(0), row(1), row(2))
    }

    /// `m^T n`, normalized: with `self` the inverse of a point map, the normal map (inverse
    /// transpose).
    #[inline(always)]
    pub(crate) fn normal_from_inverse(&self, n: V3) -> V3 {
        let r = &self.r;
        V3::new(
            r[0][0] * n.x + r[1][0] * n.y + r[2][0] * n.z,
            r[0][1] * n.x + r[1][1] * n.y + r[2][1] * n.z,
            r[0][2] * n.x + r[1][2] * n.y + r[2][2] * n.z,
        )
        .normalize()
    }
}

/// A mover's pose at one time: from its reference pose to the world, back, and the uniform
/// scale (the cube root of the determinant's magnitude).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pose {
    pub to_world: Affine,
    pub to_ref: Affine,
    pub scale: f32,
}

impl Pose {
    /// The pose of the world-space move `d` (affine); identity if it is singular.
    fn of(d: &Transform) -> Pose {
        let a: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| d.m[i][j]));
        let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
        let fwd: [[f64; 4]; 3] = std::array::from_fn(|i| d.m[i]);
        if !(det.abs() > 1e-300 && det.is_finite()) {
            let id = Affine::from_rows(&Transform::identity().m[..3].try_into().expect("3 rows"));
            return Pose {
                to_world: id,
                to_ref: id,
                scale: 1.0,
            };
        }
        // Inverse of [A | t]: [A^-1 | -A^-1 t], A^-1 = adjugate / det.
        let cof = |i: usize, j: usize| {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]
        };
        let inv3: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| cof(j, i) / det));
        let t = [d.m[0][3], d.m[1][3], d.m[2][3]];
        let back: [[f64; 4]; 3] = std::array::from_fn(|i| {
            let ti = -(inv3[i][0] * t[0] + inv3[i][1] * t[1] + inv3[i][2] * t[2]);
            [inv3[i][0], inv3[i][1], inv3[i][2], ti]
        });
        Pose {
            to_world: Affine::from_rows(&fwd),
            to_ref: Affine::from_rows(&back),
            scale: det.abs().cbrt() as f32,
        }
    }
}

/// Something that moves: its motion and the inverse of its reference pose.
#[derive(Debug, Clone)]
struct Mover {
    motion: Motion,
    ref_inv: Transform,
}

impl Mover {
    fn new(motion: &Motion, span_end_s: f64) -> Mover {
        let motion = motion.compiled(span_end_s);
        let ref_inv = camsim_scene3d::xform::inverse(&motion.reference()).unwrap_or_default();
        Mover { motion, ref_inv }
    }

    /// The world-space move from the reference pose to the pose at `t_s` (f64).
    fn delta(&self, t_s: f64) -> Transform {
        self.motion.at(t_s).then_apply_to(&self.ref_inv)
    }

    fn pose(&self, t_s: f64) -> Pose {
        Pose::of(&self.delta(t_s))
    }
}

/// The primitives of the shapes that share one motion.
#[derive(Debug, Clone)]
pub(crate) struct Group {
    /// Primitives in their reference pose, with their clips.
    pub(crate) bvh: Bvh,
    /// Unit geometric normal of each triangle in the reference pose, BVH order.
    pub(crate) tri_normals: Vec<V3>,
    /// Global slot (index into `Tracer::info`) of `bvh.prims[0]`.
    pub(crate) slot0: u32,
    /// World box over the shutter span.
    bounds: Aabb,
}

/// The moving part of a scene, compiled for tracing.
#[derive(Debug, Clone)]
pub(crate) struct MotionTracer {
    /// Groups' movers first (mover `i` moves group `i`), then the camera's, then the lights'.
    movers: Vec<Mover>,
    pub(crate) groups: Vec<Group>,
    /// The camera's mover.
    camera: Option<u32>,
    /// Per light entry (`Lights::list`): its mover, or `NO_MOVER`.
    pub(crate) light_mover: Vec<u32>,
    /// Per shape of the scene: its group's mover, or `NO_MOVER`.
    shape_mover: Vec<u32>,
    /// First slot of a moving primitive (the static BVH's primitive count).
    first_moving_slot: u32,
    /// Every ray's time lies in this span, s (the shutter's windows over all rows).
    span_s: (f64, f64),
}

pub(crate) const NO_MOVER: u32 = u32::MAX;

/// The moving shapes' primitives, taken out of the static lists ([`take_moving`]).
pub(crate) struct MovingPrims {
    groups: Vec<MovingGroupPrims>,
}

/// The primitives of the shapes that share one motion, before their BVH is built.
struct MovingGroupPrims {
    motion: Motion,
    prims: Vec<Prim>,
    info: Vec<PrimInfo>,
    /// Clips of its partial spheres (their `clip` indexes this).
    clips: Vec<SphereClip>,
    /// Segments of its curves (their pieces' `seg` indexes this).
    curves: CurveStore,
}

/// Take the primitives of moving shapes out of `prims`/`info` (the order of the rest is kept),
/// grouped by motion. `None`, touching nothing, when no shape moves.
pub(crate) fn take_moving(
    scene: &SceneDescription,
    prims: &mut Vec<Prim>,
    info: &mut Vec<PrimInfo>,
    clips: &[SphereClip],
    curves: &CurveStore,
) -> Result<Option<MovingPrims>, RenderError> {
    let time = &scene.settings.time;
    let moving: Vec<(usize, &Motion)> = time
        .shapes
        .iter()
        .filter(|(i, m)| *i < scene.shapes.len() && !m.is_static())
        .map(|(i, m)| (*i, m))
        .collect();
    if moving.is_empty() {
        return Ok(None);
    }
    // Group index of each shape (shapes with equal motions share a group).
    let mut motions: Vec<Motion> = Vec::new();
    let mut group_of_shape = vec![u32::MAX; scene.shapes.len()];
    for (i, m) in moving {
        let g = match motions.iter().position(|x| x == m) {
            Some(g) => g,
            None => {
                motions.push(m.clone());
                motions.len() - 1
            }
        };
        group_of_shape[i] = g as u32;
    }
    let mut groups: Vec<MovingGroupPrims> = motions
        .into_iter()
        .map(|motion| MovingGroupPrims {
            motion,
            prims: Vec::new(),
            info: Vec::new(),
            clips: Vec::new(),
            curves: CurveStore::default(),
        })
        .collect();
    let (mut kept_p, mut kept_i) = (Vec::with_capacity(prims.len()), Vec::new());
    // Each curve segment's index in its group's store (a segment belongs to one shape).
    let mut local_seg: Vec<u32> = Vec::new();
    for (p, pi) in prims.drain(..).zip(info.drain(..)) {
        let g = group_of_shape[pi.shape as usize];
        if g == u32::MAX {
            kept_p.push(p);
            kept_i.push(pi);
            continue;
        }
        let grp = &mut groups[g as usize];
        let p = match p {
            // Curve pieces: their segment copied into the group's own store (once per segment),
            // in the reference pose like every other moving primitive.
            Prim::Curve { seg, u0, u1 } => {
                if local_seg.is_empty() {
                    local_seg = vec![u32::MAX; curves.len()];
                }
                let l = &mut local_seg[seg as usize];
                if *l == u32::MAX {
                    *l = grp.curves.copy_segment(curves, seg);
                }
                Prim::Curve { seg: *l, u0, u1 }
            }
            Prim::PartialSphere {
                center,
                radius,
                clip,
            } => {
                grp.clips.push(clips[clip as usize]);
                Prim::PartialSphere {
                    center,
                    radius,
                    clip: (grp.clips.len() - 1) as u32,
                }
            }
            p => p,
        };
        grp.prims.push(p);
        grp.info.push(pi);
    }
    *prims = kept_p;
    *info = kept_i;
    Ok(Some(MovingPrims { groups }))
}

impl MotionTracer {
    /// Compile the scene's motion. `moving`: the moving shapes' primitives ([`take_moving`]);
    /// `info`: the static primitives' info in BVH order, to which the moving ones are appended;
    /// `lights`: the light entries (moving emitters and lights get their movers). `None` when
    /// nothing moves.
    pub(crate) fn build(
        scene: &SceneDescription,
        moving: Option<MovingPrims>,
        info: &mut Vec<PrimInfo>,
        light_count: usize,
    ) -> Result<Option<MotionTracer>, RenderError> {
        let time = &scene.settings.time;
        if !time.has_motion() {
            return Ok(None);
        }
        let sh = &time.shutter;
        if !(sh.open_s.is_finite() && sh.close_s.is_finite() && sh.close_s >= sh.open_s) {
            return Err(RenderError::Settings(format!(
                "shutter window [{}, {}] s is not a finite interval",
                sh.open_s, sh.close_s
            )));
        }
        let span_s = sh.span_s(scene.camera.height);
        if !(span_s.0.is_finite() && span_s.1.is_finite()) {
            return Err(RenderError::Settings(
                "the rolling shutter's row delays are not finite".into(),
            ));
        }
        // Motions are evaluated up to the span's end, and flow that much later again.
        let t_end = span_s.1
            + time
                .flow_intervals_s
                .iter()
                .copied()
                .filter(|d| d.is_finite())
                .fold(0.0, f64::max);
        let mut movers = Vec::new();
        let mut groups = Vec::new();
        let mut light_mover = vec![NO_MOVER; light_count];
        let mut shape_mover = vec![NO_MOVER; scene.shapes.len()];
        let first_moving_slot = info.len() as u32;
        for MovingGroupPrims {
            motion,
            prims,
            info: pinfo,
            clips,
            curves,
        } in moving.map(|m| m.groups).unwrap_or_default()
        {
            let mover = Mover::new(&motion, t_end);
            let gi = movers.len() as u32;
            let mut bvh = Bvh::build_with_curves(prims, curves);
            bvh.clips = clips;
            let slot0 = info.len() as u32;
            info.extend(bvh.ids.iter().map(|&i| pinfo[i as usize]));
            let tri_normals = bvh
                .prims
                .iter()
                .map(|p| match *p {
                    Prim::Tri { e1, e2, .. } => e1.cross(e2).normalize(),
                    _ => V3::splat(0.0),
                })
                .collect();
            let bounds = motion_bounds(&mover, bvh.bounds(), span_s);
            // Emitters on the group: sampled in the reference pose, which needs a similarity.
            let emitters: Vec<u32> = pinfo
                .iter()
                .filter(|p| p.light != NO_LIGHT)
                .map(|p| p.light)
                .collect();
            if let Some(first) = pinfo.iter().find(|p| p.light != NO_LIGHT) {
                check_similarity(&mover, span_s).map_err(|message| RenderError::Shape {
                    index: first.shape as usize,
                    name: scene.shapes[first.shape as usize]
                        .name
                        .clone()
                        .unwrap_or_default(),
                    message: format!("a moving area light {message}"),
                })?;
            }
            for l in emitters {
                light_mover[l as usize] = gi;
            }
            for p in &pinfo {
                if let Some(m) = shape_mover.get_mut(p.shape as usize) {
                    *m = gi;
                }
            }
            movers.push(mover);
            groups.push(Group {
                bvh,
                tri_normals,
                slot0,
                bounds,
            });
        }
        let camera = match &time.camera {
            Some(m) if !m.is_static() => {
                movers.push(Mover::new(m, t_end));
                Some((movers.len() - 1) as u32)
            }
            _ => None,
        };
        // Scene lights follow the shape lights in `Lights::list`, one entry each, in order.
        let first_scene_light = light_count.saturating_sub(scene.lights.len());
        for (k, m) in &time.lights {
            if m.is_static() {
                continue;
            }
            let err = |message: String| RenderError::Light { index: *k, message };
            match scene.lights.get(*k) {
                None => return Err(err("moves, but the scene has no such light".into())),
                Some(Light::Infinite { .. } | Light::Environment(_)) => {
                    return Err(err(
                        "an infinite or environment light cannot move (pbrt-v4 uses its start transform)"
                            .into(),
                    ))
                }
                Some(_) => {}
            }
            let mover = Mover::new(m, t_end);
            check_similarity(&mover, span_s).map_err(|e| err(format!("a moving light {e}")))?;
            movers.push(mover);
            light_mover[first_scene_light + k] = (movers.len() - 1) as u32;
        }
        Ok(Some(MotionTracer {
            movers,
            groups,
            camera,
            light_mover,
            shape_mover,
            first_moving_slot,
            span_s,
        }))
    }

    /// The group of a moving slot.
    #[inline]
    pub(crate) fn group_of(&self, slot: u32) -> usize {
        self.groups.partition_point(|g| g.slot0 <= slot) - 1
    }

    /// Whether `slot` is a moving primitive's, and then its group.
    #[inline]
    pub(crate) fn moving_group(&self, slot: u32) -> Option<usize> {
        (slot >= self.first_moving_slot).then(|| self.group_of(slot))
    }

    /// A path's time clamped to the span the bounds hold.
    #[inline]
    fn clamp_time(&self, t_s: f64) -> f64 {
        t_s.clamp(self.span_s.0, self.span_s.1)
    }
}

/// A world box holding `b` (reference pose) moved by `mover` over `span`: the box's corners at
/// [`BOUND_STEPS`] times and every key inside, grown by the longest move of a corner between
/// two consecutive times (a path bends away from its chord by less than its length).
fn motion_bounds(mover: &Mover, b: Aabb, span: (f64, f64)) -> Aabb {
    if b.min.x > b.max.x {
        return b;
    }
    let corners: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            [
                if k & 1 == 0 { b.min.x } else { b.max.x } as f64,
                if k & 2 == 0 { b.min.y } else { b.max.y } as f64,
                if k & 4 == 0 { b.min.z } else { b.max.z } as f64,
            ]
        })
        .collect();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut pad = 0f64;
    let mut prev: Option<Vec<[f64; 3]>> = None;
    for t in mover.motion.sample_times(span.0, span.1, BOUND_STEPS) {
        let d = mover.delta(t);
        let now: Vec<[f64; 3]> = corners.iter().map(|c| d.apply_point(*c)).collect();
        for p in &now {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if let Some(prev) = &prev {
            for (a, b) in prev.iter().zip(&now) {
                pad = pad.max(
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt(),
                );
            }
        }
        prev = Some(now);
    }
    // f32 rounding of the box and of the moved rays: a relative margin on top.
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let pad = pad + 1e-5 * (extent + lo.iter().chain(&hi).map(|v| v.abs()).fold(0.0, f64::max));
    Aabb {
        min: V3::from_f64([lo[0] - pad, lo[1] - pad, lo[2] - pad]),
        max: V3::from_f64([hi[0] + pad, hi[1] + pad, hi[2] + pad]),
    }
}

/// `Ok` when the mover's moves over `span` are similarities (rotation, translation, uniform
/// scale), what light sampling in the reference pose needs; else what is wrong.
fn check_similarity(mover: &Mover, span: (f64, f64)) -> Result<(), String> {
    for t in mover.motion.sample_times(span.0, span.1, BOUND_STEPS) {
        let d = mover.delta(t);
        let cols: Vec<[f64; 3]> = (0..3).map(|c| [d.m[0][c], d.m[1][c], d.m[2][c]]).collect();
        let len: Vec<f64> = cols
            .iter()
            .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
            .collect();
        let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let s = len[0];
        let tol = 1e-6 * s;
        if (len[1] - s).abs() > tol
            || (len[2] - s).abs() > tol
            || dot(&cols[0], &cols[1]).abs() > tol * s
            || dot(&cols[0], &cols[2]).abs() > tol * s
            || dot(&cols[1], &cols[2]).abs() > tol * s
        {
            return Err(format!(
                "must move rigidly (rotation, translation and uniform scale): at t = {t} s its move scales the axes by {:.6}, {:.6}, {:.6}",
                len[0], len[1], len[2]
            ));
        }
    }
    Ok(())
}

/// The poses of one path's time, computed when first used (per tile: one allocation).
pub(crate) struct TimeCache {
    generation: Cell<u32>,
    /// Per mover: (generation it was computed for, pose).
    poses: Vec<Cell<(u32, Pose)>>,
}

impl TimeCache {
    /// A cache for the movers of a tracer's `motion` (empty for a static scene).
    pub(crate) fn new(motion: Option<&MotionTracer>) -> TimeCache {
        let n = motion.map_or(0, |m| m.movers.len());
        let id = Pose::of(&Transform::identity());
        TimeCache {
            generation: Cell::new(0),
            poses: (0..n).map(|_| Cell::new((0, id))).collect(),
        }
    }

    /// Start a path at time `t_s` (its poses are computed anew as they are needed).
    pub(crate) fn at(&self, t_s: f64) -> PathTime<'_> {
        let g = self.generation.get().wrapping_add(1).max(1);
        self.generation.set(g);
        PathTime {
            time_s: t_s,
            generation: g,
            cache: Some(self),
        }
    }
}

/// One path's time: every ray of the path sees the scene at `time_s`.
#[derive(Clone, Copy)]
pub(crate) struct PathTime<'a> {
    pub time_s: f64,
    generation: u32,
    cache: Option<&'a TimeCache>,
}

impl PathTime<'_> {
    /// The time of a static scene (nothing is evaluated).
    pub(crate) const STATIC: PathTime<'static> = PathTime {
        time_s: 0.0,
        generation: 0,
        cache: None,
    };

    /// Mover `i`'s pose at this time.
    #[inline]
    pub(crate) fn pose(&self, m: &MotionTracer, i: usize) -> Pose {
        let t = m.clamp_time(self.time_s);
        match self.cache {
            Some(c) => {
                let cell = &c.poses[i];
                let (g, p) = cell.get();
                if g == self.generation {
                    return p;
                }
                let p = m.movers[i].pose(t);
                cell.set((self.generation, p));
                p
            }
            None => m.movers[i].pose(t),
        }
    }
}

/// A ray moved into a group's reference pose: origin, unit direction and the factor from world
/// distances to reference-pose distances.
#[inline(always)]
pub(crate) fn to_ref(pose: &Pose, r: &Ray) -> (Ray, f32) {
    let d = pose.to_ref.vector(r.d);
    let len = d.length();
    (
        Ray {
            o: pose.to_ref.point(r.o),
            d: d / len,
        },
        len,
    )
}

#[inline(always)]
fn box_arrays(b: &Aabb) -> ([f32; 3], [f32; 3]) {
    ([b.min.x, b.min.y, b.min.z], [b.max.x, b.max.y, b.max.z])
}

impl MotionTracer {
    /// True when any light moves.
    pub(crate) fn any_light_moves(&self) -> bool {
        self.light_mover.iter().any(|&m| m != NO_MOVER)
    }

    /// The closest hit along `r` at `pt` among the moving groups nearer than `best` (the static
    /// BVH's hit), or `best`.
    #[inline]
    pub(crate) fn intersect(
        &self,
        r: &Ray,
        t_max: f32,
        pt: &PathTime,
        mut best: Option<Hit>,
    ) -> Option<Hit> {
        let mut t_max = best.map_or(t_max, |h| h.t);
        let ri = RayInv::new(r);
        for (gi, g) in self.groups.iter().enumerate() {
            let (lo, hi) = box_arrays(&g.bounds);
            if ray_box(&ri, &lo, &hi, t_max) == f32::INFINITY {
                continue;
            }
            let pose = pt.pose(self, gi);
            let (rr, len) = to_ref(&pose, r);
            if let Some(h) = g.bvh.intersect(&RayInv::new(&rr), t_max * len) {
                t_max = h.t / len;
                best = Some(Hit {
                    t: t_max,
                    u: h.u,
                    v: h.v,
                    slot: g.slot0 + h.slot,
                });
            }
        }
        best
    }

    /// Whether a moving primitive blocks `r` within `(0, t_max)` at `pt`.
    #[inline]
    pub(crate) fn occluded(&self, r: &Ray, t_max: f32, pt: &PathTime) -> bool {
        let ri = RayInv::new(r);
        self.groups.iter().enumerate().any(|(gi, g)| {
            let (lo, hi) = box_arrays(&g.bounds);
            if ray_box(&ri, &lo, &hi, t_max) == f32::INFINITY {
                return false;
            }
            let (rr, len) = to_ref(&pt.pose(self, gi), r);
            g.bvh.occluded(&RayInv::new(&rr), t_max * len)
        })
    }

    /// The camera's pose at `pt`, if the camera moves.
    #[inline]
    pub(crate) fn camera_pose(&self, pt: &PathTime) -> Option<Pose> {
        self.camera.map(|i| pt.pose(self, i as usize))
    }

    /// Mover `i`'s pose at an exact time (flow: times outside the shutter span too).
    pub(crate) fn pose_at(&self, i: usize, t_s: f64) -> Pose {
        self.movers[i].pose(t_s)
    }

    /// The camera's mover.
    pub(crate) fn camera_mover(&self) -> Option<usize> {
        self.camera.map(|i| i as usize)
    }

    /// The world-space move (f64) of shape `shape` from its stored pose to its pose at `t_s`,
    /// if it moves.
    pub(crate) fn shape_delta_at(&self, shape: usize, t_s: f64) -> Option<Transform> {
        let i = *self.shape_mover.get(shape)?;
        (i != NO_MOVER).then(|| self.movers[i as usize].delta(t_s))
    }

    /// The world-space move (f64) of the camera from its stored pose to its pose at `t_s`, if
    /// it moves.
    pub(crate) fn camera_delta_at(&self, t_s: f64) -> Option<Transform> {
        self.camera.map(|i| self.movers[i as usize].delta(t_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_inverts_and_scales() {
        let d = Transform::translate([1.0, 2.0, -3.0])
            .then_apply_to(&Transform::rotate(40.0, [1.0, 2.0, 0.5]))
            .then_apply_to(&Transform::scale([2.0, 2.0, 2.0]));
        let p = Pose::of(&d);
        let x = V3::new(0.3, -0.2, 1.7);
        let y = p.to_ref.point(p.to_world.point(x));
        assert!((y - x).length() < 1e-5);
        assert!((p.scale - 2.0).abs() < 1e-6);
        // Normals stay perpendicular to moved tangents.
        let (t, n) = (V3::new(1.0, 0.0, 0.0), V3::new(0.0, 0.0, 1.0));
        let (tw, nw) = (p.to_world.vector(t), p.to_ref.normal_from_inverse(n));
        assert!(tw.dot(nw).abs() < 1e-5);
    }
}
