//! Optical flow, the ground truth of motion: for each pixel, where the surface it sees first
//! (through its centre, at the start of its row's shutter window: the depth and id maps' ray)
//! lies in the image an interval `dt` later, as a raster offset in pixels (+x right, +y down).
//!
//! The surface point moves with its shape (`crate::motion`: the point is taken to the shape's
//! reference pose at the start time and moved to its pose at the end time) and is seen by the
//! camera in its pose at the end time, through the same pinhole as the depth map (a lens
//! camera's entrance pupil: its distortion is not in the flow). A pixel whose ray escapes
//! follows the direction it looks along (a point at infinity: only the camera's rotation moves
//! it). A point that ends behind the camera has no flow (NaN). Nothing moves in a static scene:
//! its flow is 0 exactly, and is not traced.

use crate::camera::CameraRig;
use crate::integrator::Tracer;
use crate::math::V3;
use crate::motion::{PathTime, Pose};

/// One flow map of a render.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowMap {
    /// The interval the flow spans, s (from each row's window start).
    pub interval_s: f64,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Per pixel, row-major: the offset `[dx, dy]`, pixels.
    pub xy_px: Vec<[f32; 2]>,
}

/// The flow maps of a render from its per-pixel values (`K * pixels`, interval-major; empty when
/// nothing moves: zeros).
pub(crate) fn flow_maps(
    intervals_s: &[f64],
    flat: Vec<[f32; 2]>,
    width: usize,
    height: usize,
) -> Vec<FlowMap> {
    let pixels = width * height;
    intervals_s
        .iter()
        .enumerate()
        .map(|(k, dt)| FlowMap {
            interval_s: *dt,
            width,
            height,
            xy_px: if flat.is_empty() {
                vec![[0.0; 2]; pixels]
            } else {
                flat[k * pixels..(k + 1) * pixels].to_vec()
            },
        })
        .collect()
}

/// Where the camera in pose `cam` (its move from the stored pose; `None`: the stored pose)
/// sees the world point `p` (`dir`: the direction `p`).
fn raster(rig: &CameraRig, cam: Option<Pose>, p: V3, dir: bool) -> Option<[f32; 2]> {
    match (cam, dir) {
        (None, false) => rig.raster_of_point(p),
        (None, true) => rig.raster_of_direction(p),
        (Some(c), false) => rig.raster_of_point(c.to_ref.point(p)),
        (Some(c), true) => rig.raster_of_direction(c.to_ref.vector(p)),
    }
}

/// The flow of pixel (`x`, `y`) from `pt0` (its row's window start) over `dt_s`, pixels.
pub(crate) fn pixel_flow(
    tracer: &Tracer,
    rig: &CameraRig,
    x: usize,
    y: usize,
    pt0: &PathTime,
    dt_s: f64,
) -> [f32; 2] {
    let Some(m) = tracer.motion.as_deref() else {
        return [0.0; 2];
    };
    let (t0, t1) = (pt0.time_s, pt0.time_s + dt_s);
    let cam = |t: f64| m.camera_mover().map(|i| m.pose_at(i, t));
    let r = tracer.camera_ray(rig.ray(x as f32 + 0.5, y as f32 + 0.5), pt0);
    let (a, b) = match tracer.first_kept(&r, pt0) {
        Some((ray, h)) => {
            let p0 = tracer.surface(&ray, &h, pt0).p;
            let p1 = match m.moving_group(h.slot) {
                Some(g) => m
                    .pose_at(g, t1)
                    .to_world
                    .point(m.pose_at(g, t0).to_ref.point(p0)),
                None => p0,
            };
            (
                raster(rig, cam(t0), p0, false),
                raster(rig, cam(t1), p1, false),
            )
        }
        None => (
            raster(rig, cam(t0), r.d, true),
            raster(rig, cam(t1), r.d, true),
        ),
    };
    match (a, b) {
        (Some(a), Some(b)) => [b[0] - a[0], b[1] - a[1]],
        _ => [f32::NAN; 2],
    }
}
