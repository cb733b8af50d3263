//! Curves (pbrt-v4 `Shape "curve"`) rendered against closed forms of their projected area: a
//! black curve in front of a uniform sky removes exactly its coverage, and a pinhole maps the
//! plane the curve lies in (fronto-parallel, distance D) onto the pixels by one scale, so
//! `sum_pixels (1 - L / L_sky) * (pixel footprint)^2` is the curve's area seen from the camera
//! (a distant camera: the rays are nearly parallel, so a width seen along them is the width).
//! Closed forms (width w, length L): a straight flat or cylinder curve covers `w L` (tapered:
//! `L (w0 + w1) / 2`); a ribbon whose normal makes angle `a` with the view covers `w L cos a`,
//! and one whose normal turns by 90 degrees along it (spherical interpolation) `w L 2 / pi`; a
//! bent flat curve covers `w` times its arc length (the tube formula: the inner side's loss
//! `kappa w / 2` cancels the outer side's gain), which tests the recursive subdivision.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::curves::{CurveType, Curves};
use camsim_scene3d::*;
use std::collections::HashMap;

/// The camera is far away with a narrow field (the curves span +-2.6 m at 100 m), so the rays
/// are parallel to 1.5 degrees: perspective changes the widths seen by < 0.05 %.
const D: f64 = 100.0;
const FOV_DEG: f64 = 3.0;
const PX: usize = 160;

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![300.0, 900.0], vec![v, v], "test").unwrap()
}

/// Side of a pixel's footprint in the plane z = D, m.
fn pixel_m() -> f64 {
    2.0 * D * (FOV_DEG.to_radians() / 2.0).tan() / PX as f64
}

/// The area (m^2, in the plane z = D) that `curves` hide from a camera at the origin looking
/// along +z, from a render of the black curves against a uniform sky of radiance 1.
fn covered_area_m2(curves: Curves, spp: u32) -> f64 {
    let scene = SceneDescription {
        camera: Camera {
            camera_to_world: look_at_camera_to_world(
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0],
                true,
            )
            .unwrap(),
            fov_deg: FOV_DEG,
            width: PX,
            height: PX,
            lens: None,
        },
        shapes: vec![Shape {
            name: Some("curve".into()),
            geometry: Geometry::Curves(curves),
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        }],
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(flat(0.0)),
        }],
        named_materials: HashMap::new(),
        lights: vec![Light::Infinite {
            radiance: flat(1.0),
        }],
        settings: RenderSettings {
            grid: WavelengthGrid::new(500.0, 600.0, 50.0).unwrap(),
            samples_per_pixel: spp,
            max_depth: 1,
            seed: 5,
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    };
    let out = render(&scene, &|_, _| {}).unwrap();
    let img = &out.radiance;
    let mut hidden = 0.0;
    for b in 0..img.bands() {
        hidden += img.band(b).iter().map(|v| 1.0 - *v as f64).sum::<f64>();
    }
    hidden / img.bands() as f64 * pixel_m() * pixel_m()
}

/// A straight curve from `a` to `b` (evenly spaced control points: u is proportional to
/// length) in the plane z = D.
fn straight(
    kind: CurveType,
    a: [f32; 2],
    b: [f32; 2],
    w: [f32; 2],
    normals: Vec<[f32; 3]>,
) -> Curves {
    let p = |t: f32| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), D as f32];
    Curves {
        kind,
        points: vec![p(0.0), p(1.0 / 3.0), p(2.0 / 3.0), p(1.0)],
        width_m: w,
        normals,
        split_depth: 3,
    }
}

/// Ends of a 4 m long curve through the image centre, turned 7 degrees off the pixel rows.
fn ends() -> ([f32; 2], [f32; 2], f64) {
    let (s, c) = 7f32.to_radians().sin_cos();
    ([-2.0 * c, -2.0 * s + 0.1], [2.0 * c, 2.0 * s + 0.1], 4.0)
}

fn check(what: &str, got: f64, want: f64, tol: f64) {
    eprintln!(
        "{what}: covered {got:.5} m^2, closed form {want:.5} m^2 ({:+.3} %)",
        100.0 * (got / want - 1.0)
    );
    assert!(
        (got / want - 1.0).abs() < tol,
        "{what}: {got} m^2 against {want} m^2"
    );
}

#[test]
fn straight_flat_and_cylinder_curves_cover_width_times_length() {
    let (a, b, len) = ends();
    for kind in [CurveType::Flat, CurveType::Cylinder] {
        let got = covered_area_m2(straight(kind, a, b, [0.1, 0.1], vec![]), 16);
        check(&format!("{kind:?} w 0.1"), got, 0.1 * len, 0.005);
    }
    // Tapered: the width runs linearly from width0 to width1.
    let got = covered_area_m2(straight(CurveType::Flat, a, b, [0.16, 0.04], vec![]), 16);
    check(
        "tapered 0.16 -> 0.04",
        got,
        0.5 * (0.16 + 0.04) * len,
        0.005,
    );
}

#[test]
fn ribbon_width_follows_its_interpolated_normal() {
    let (a, b, len) = ends();
    // The ribbon's plane holds the curve; its normal is tilted 60 degrees from the view axis
    // about the curve.
    let t = [b[0] - a[0], b[1] - a[1]];
    let tl = (t[0] * t[0] + t[1] * t[1]).sqrt();
    let side = [-t[1] / tl, t[0] / tl, 0.0];
    let (s60, c60) = 60f32.to_radians().sin_cos();
    let n60 = [side[0] * s60, side[1] * s60, -c60];
    let got = covered_area_m2(
        straight(CurveType::Ribbon, a, b, [0.2, 0.2], vec![n60, n60]),
        16,
    );
    check("ribbon at 60 deg", got, 0.2 * len * 0.5, 0.005);
    // Facing the camera at the start, edge-on at the end: width w cos(u pi / 2), area 2 w L / pi.
    let got = covered_area_m2(
        straight(
            CurveType::Ribbon,
            a,
            b,
            [0.2, 0.2],
            vec![[0.0, 0.0, -1.0], side],
        ),
        16,
    );
    check(
        "ribbon turning 90 deg",
        got,
        0.2 * len * 2.0 / std::f64::consts::PI,
        0.005,
    );
}

#[test]
fn bent_curve_covers_width_times_arc_length() {
    // One cubic segment bent through a half turn (no BVH split: only the intersector's
    // subdivision follows the bend), width 0.08 m; its arc length by a fine midpoint sum of
    // |B'(t)|.
    let cp = [[-2.0f32, -1.0], [-2.0, 2.2], [2.0, 2.2], [2.0, -1.0]];
    let curves = Curves {
        kind: CurveType::Flat,
        points: cp.iter().map(|p| [p[0], p[1], D as f32]).collect(),
        width_m: [0.08, 0.08],
        normals: vec![],
        split_depth: 0,
    };
    let n = 100_000;
    let mut len = 0.0;
    for k in 0..n {
        let t = (k as f64 + 0.5) / n as f64;
        let s = 1.0 - t;
        // B'(t) = 3 [s^2 (p1 - p0) + 2 s t (p2 - p1) + t^2 (p3 - p2)]
        let d = |a: usize| {
            3.0 * (s * s * (cp[1][a] - cp[0][a]) as f64
                + 2.0 * s * t * (cp[2][a] - cp[1][a]) as f64
                + t * t * (cp[3][a] - cp[2][a]) as f64)
        };
        len += (d(0) * d(0) + d(1) * d(1)).sqrt() / n as f64;
    }
    let got = covered_area_m2(curves, 16);
    check("bent flat curve", got, 0.08 * len, 0.005);
}
