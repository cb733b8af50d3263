//! Moving curves (hair) against closed forms (issue 28): a curve under an animated transform
//! moves rigidly with it and its width, in object space, scales with a uniform scale (pbrt-v4
//! `Curve` under an `AnimatedTransform`). A black curve in front of a uniform white sky of
//! radiance 1 hides `1 - L` of each pixel, so the image of `1 - L` is the curve's coverage:
//! - a vertical flat curve of width w px translating at v px/s across the view under a global
//!   shutter of T s covers the box convolution of its static profile with a box v T long: the
//!   integral along a row stays w (projected area is conserved) and, for v T > w, the profile is
//!   a trapezoid whose half-maximum points sit at the curve's centre at the window's start and
//!   end, x0 + v t0 and x0 + v (t0 + T) (full width at half maximum v T);
//! - a straight flat curve scaled about its centre from 1 to s1 during the window covers the
//!   time average of `s(t)^2 w L`, `w L (1 + s1 + s1^2) / 3` (pbrt-v4 interpolates the scale
//!   linearly);
//! - the labels of a moving curve (instance map) show it at the window's start, x0 + v t0.

use crate::common;
use camsim_render::{render, render_with, LabelRequest, RenderRequest};
use camsim_scene3d::curves::{CurveType, Curves};
use camsim_scene3d::motion::{Motion, MotionPart, Shutter, TimeSettings};
use camsim_scene3d::{Geometry, Light, SceneDescription, Shape, Transform};
use common::grey;

/// Metres per pixel on the plane z = 1 m (the camera looks down +z from the origin, raster x
/// along world +x, raster y along world -y).
const PX_M: f64 = 1e-3;

/// A straight flat curve of width `w_px` from `a` to `b` (pixels from the image centre, raster
/// orientation) in the plane z = 1 m.
fn curve(a: [f64; 2], b: [f64; 2], w_px: f64) -> Shape {
    let p = |t: f64| {
        let (x, y) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
        [(x * PX_M) as f32, (-y * PX_M) as f32, 1.0]
    };
    Shape {
        name: Some("hair".into()),
        geometry: Geometry::Curves(Curves {
            kind: CurveType::Flat,
            points: vec![p(0.0), p(1.0 / 3.0), p(2.0 / 3.0), p(1.0)],
            width_m: [(w_px * PX_M) as f32; 2],
            normals: vec![],
            split_depth: 3,
        }),
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// The black curve `c` before a white sky, seen by a `w` x `h` camera, with `time`.
fn scene(w: usize, h: usize, c: Shape, spp: u32, time: TimeSettings) -> SceneDescription {
    let short = w.min(h) as f64;
    let fov_deg = 2.0 * (short / 2.0 * PX_M).atan().to_degrees();
    let mut s = common::origin_scene(w, h, fov_deg, vec![c], spp, time);
    s.lights = vec![Light::Infinite {
        radiance: grey(1.0),
    }];
    s.settings.seed = 11;
    s
}

fn window(motion: Option<Motion>, open_s: f64, close_s: f64) -> TimeSettings {
    TimeSettings {
        shutter: Shutter {
            open_s,
            close_s,
            rolling: None,
        },
        shapes: motion.into_iter().map(|m| (0, m)).collect(),
        ..TimeSettings::default()
    }
}

/// The coverage `1 - L` of band 0, row-major.
fn coverage(s: &SceneDescription) -> Vec<f64> {
    let out = render(s, &|_, _| {}).unwrap();
    let n = s.camera.width * s.camera.height;
    out.radiance.data[..n]
        .iter()
        .map(|v| 1.0 - *v as f64)
        .collect()
}

/// The mean over rows of a `w`-wide image: a profile along x.
fn row_mean(img: &[f64], w: usize) -> Vec<f64> {
    let rows = img.len() / w;
    (0..w)
        .map(|x| (0..rows).map(|y| img[y * w + x]).sum::<f64>() / rows as f64)
        .collect()
}

/// The two half-maximum crossings of a single-peaked profile (pixel k's value at k + 0.5,
/// linear between), pixels: the first rising and the last falling crossing of `level`.
fn half_points(p: &[f64], level: f64) -> (f64, f64) {
    let at = |i: usize| i as f64 - 0.5 + (level - p[i - 1]) / (p[i] - p[i - 1]);
    let up = (1..p.len())
        .find(|&i| p[i - 1] < level && p[i] >= level)
        .expect("a rising edge");
    let down = (1..p.len())
        .rev()
        .find(|&i| p[i - 1] >= level && p[i] < level)
        .expect("a falling edge");
    (at(up), at(down))
}

/// A velocity of `v` px/s along raster x.
fn along_x(v: f64) -> Motion {
    Motion::single(MotionPart::Velocity {
        velocity_m_s: [v * PX_M, 0.0, 0.0],
        angular_velocity_deg_s: [0.0; 3],
        pivot_m: [0.0; 3],
    })
}

/// A vertical curve 3 px wide at x0 moving at 500 px/s for 40 ms (a 20 px box), for windows
/// starting at t0 = 0 and 20 ms: row integral 3 px (static and moving, within 1 %), half-maximum
/// points at x0 + v t0 and x0 + v (t0 + T) within 0.3 px; the static curve's full width at half
/// maximum is its width.
#[test]
fn a_translating_curve_blurs_by_v_t_and_keeps_its_area() {
    let (w, h, wpx, x0, v, big_t) = (96, 8, 3.0, -30.2, 500.0, 0.04);
    let c = || curve([x0, -20.0], [x0, 20.0], wpx);
    let centre = w as f64 / 2.0;
    let still = row_mean(
        &coverage(&scene(w, h, c(), 64, window(None, 0.0, big_t))),
        w,
    );
    let area: f64 = still.iter().sum();
    assert!(
        (area / wpx - 1.0).abs() < 0.01,
        "static row integral {area} px"
    );
    let (a, b) = half_points(&still, 0.5);
    assert!((b - a - wpx).abs() < 0.2, "static width {} px", b - a);
    for t0 in [0.0, 0.02] {
        let s = scene(w, h, c(), 256, window(Some(along_x(v)), t0, t0 + big_t));
        let p = row_mean(&coverage(&s), w);
        let area: f64 = p.iter().sum();
        assert!(
            (area / wpx - 1.0).abs() < 0.01,
            "t0 = {t0}: moving row integral {area} px, static {wpx} px"
        );
        // The trapezoid's plateau is w / (v T); its half-maximum points are the ramps' middles.
        let (a, b) = half_points(&p, 0.5 * wpx / (v * big_t));
        let (want_a, want_b) = (centre + x0 + v * t0, centre + x0 + v * (t0 + big_t));
        eprintln!("t0 = {t0}: half maximum at {a:.3}, {b:.3} px; closed form {want_a}, {want_b}");
        assert!(
            (a - want_a).abs() < 0.3 && (b - want_b).abs() < 0.3,
            "t0 = {t0}: half maximum at {a}, {b} px, want {want_a}, {want_b}"
        );
    }
}

/// A horizontal curve 40 px long and 4 px wide scaled about its centre from 1 to 2 during the
/// window: the image integral of its coverage is w L (1 + 2 + 4) / 3 (within 1 %); with the
/// scale ignored it would be w L.
#[test]
fn a_scaling_curve_covers_the_time_average_of_its_scaled_area() {
    let (w, h, wpx, len) = (100, 24, 4.0, 40.0);
    let c = curve([-len / 2.0, 0.0], [len / 2.0, 0.0], wpx);
    let centre = [0.0, 0.0, 1.0];
    let end = Transform::translate(centre)
        .then_apply_to(&Transform::scale([2.0, 2.0, 2.0]))
        .then_apply_to(&Transform::translate([-centre[0], -centre[1], -centre[2]]));
    let m = Motion::between(&Transform::identity(), 0.0, &end, 1.0).unwrap();
    let total = |s: &SceneDescription| -> f64 { coverage(s).iter().sum::<f64>() / (wpx * len) };
    let still = total(&scene(w, h, c.clone(), 64, window(None, 0.0, 1.0)));
    assert!((still - 1.0).abs() < 0.01, "static area / (w L) = {still}");
    let got = total(&scene(w, h, c, 256, window(Some(m), 0.0, 1.0)));
    let want = (1.0 + 2.0 + 4.0) / 3.0;
    eprintln!("scaling curve: area / (w L) = {got:.4}, closed form {want:.4}");
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
}

/// The instance map of a moving curve shows it at the window's start: its left edge (pixel
/// edges, maps sampled at pixel centres) within half a pixel of x0 - w/2 + v t0.
#[test]
fn labels_of_a_moving_curve_are_at_the_window_start() {
    let (w, h, wpx, x0, v) = (64, 8, 4.0, -20.3, 150.0);
    let req = RenderRequest {
        labels: Some(LabelRequest::default()),
        ..Default::default()
    };
    for t0 in [0.0, 0.04, 0.1] {
        let s = scene(
            w,
            h,
            curve([x0, -20.0], [x0, 20.0], wpx),
            1,
            window(Some(along_x(v)), t0, t0 + 0.02),
        );
        let out = render_with(&s, &req, &|_, _| {}).unwrap();
        let l = out.labels.unwrap();
        let want = w as f64 / 2.0 + x0 - wpx / 2.0 + v * t0;
        for y in 0..h {
            let e = (0..w).find(|x| l.instance_id[y * w + x] != 0).unwrap() as f64;
            assert!(
                (e - want).abs() <= 0.5,
                "t0 = {t0}, row {y}: edge at {e}, want {want} +- 0.5"
            );
        }
    }
}
