//! Light groups of a moving scene (issue 28): each term of a path's estimate goes to the group
//! of the light it came from, also when the light or the camera moves. Checked: a scene with a
//! moving emitter, a static one, a moving point light, a sky and a moving camera (pbrt-v4
//! `ActiveTransform`) splits into groups whose sum is the beauty film (to f32 rounding: each
//! group is summed on its own) and whose beauty is the plain render's bit for bit; a moving
//! emitter's group shows it blurred by the box of its motion (10-90 % edge 0.8 v T) while a
//! static emitter's group shows it sharp, each group dark where the other's emitter is; and a
//! moving point light's group, sampled in the light's reference pose, holds the time-averaged
//! irradiance it gives, the static light's group its still irradiance.

use crate::common;
use camsim_pbrt::parse_str;
use camsim_render::{render, render_with, RenderOutput, RenderRequest};
use camsim_scene3d::motion::{Motion, MotionPart, Shutter, TimeSettings};
use camsim_scene3d::{AreaLight, Geometry, Light, Material, SceneDescription, Shape, Texture};
use common::grey;

fn with_groups(s: &SceneDescription) -> RenderOutput {
    let req = RenderRequest {
        light_groups: true,
        ..Default::default()
    };
    render_with(s, &req, &|_, _| {}).unwrap()
}

/// The group image called `name`.
fn group<'a>(out: &'a RenderOutput, name: &str) -> &'a [f32] {
    &out.light_groups
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no group {name}"))
        .1
        .data
}

#[test]
fn light_groups_of_a_moving_scene_sum_to_the_beauty() {
    // A floor lit by a sky, a lamp that slides 1 m, a still panel and a point light that slides
    // back; the camera pans 0.3 m.
    let text = r#"LookAt 0 3 -3  0 0 0  0 1 0
ActiveTransform EndTime
Translate 0.3 0 0
ActiveTransform All
Camera "perspective" "float fov" 50 "float shutteropen" 0 "float shutterclose" 1
Sampler "zsobol" "integer pixelsamples" 16
Film "rgb" "integer xresolution" 32 "integer yresolution" 24
WorldBegin
LightSource "infinite" "rgb L" [0.3 0.4 0.6] "string lightgroup" "sky"
AttributeBegin
  ActiveTransform EndTime
  Translate 1 0 0
  ActiveTransform All
  AreaLightSource "diffuse" "rgb L" [8 7 5] "string lightgroup" "lamp" "bool twosided" true
  Shape "trianglemesh" "point3 P" [-0.8 0.6 -0.3  -0.2 0.6 -0.3  -0.2 0.6 0.3  -0.8 0.6 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [2 3 2] "string lightgroup" "panel" "bool twosided" true
  Shape "trianglemesh" "point3 P" [0.8 0.1 1  1.4 0.1 1  1.4 0.9 1  0.8 0.9 1]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
AttributeBegin
  ActiveTransform EndTime
  Translate -1.5 0 0
  ActiveTransform All
  LightSource "point" "point3 from" [0.7 1 0] "rgb I" [3 3 3] "string lightgroup" "bulb"
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 2 1 0 3 2]
"#;
    let s = parse_str(text, "moving-groups.pbrt").unwrap();
    let t = &s.settings.time;
    assert!(t.camera.is_some() && t.shapes.len() == 1 && t.lights.len() == 1);
    let out = with_groups(&s);
    let plain = render(&s, &|_, _| {}).unwrap();
    assert_eq!(out.radiance.data, plain.radiance.data, "beauty changed");
    let names: Vec<&str> = out.light_groups.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["bulb", "lamp", "panel", "sky"]);
    let mut worst = 0f64;
    for (i, total) in out.radiance.data.iter().enumerate() {
        let sum: f64 = out.light_groups.iter().map(|(_, g)| g.data[i] as f64).sum();
        let rel = (sum - *total as f64).abs() / (total.abs() as f64).max(1e-3);
        worst = worst.max(rel);
    }
    eprintln!("largest relative difference of the groups' sum from the beauty: {worst:.2e}");
    assert!(worst <= 1e-5, "groups sum to the beauty within {worst}");
    for (n, g) in &out.light_groups {
        assert!(g.data.iter().sum::<f32>() > 0.0, "group {n} is empty");
    }
}

/// Metres per pixel on the plane z = 1 m (camera at the origin looking down +z, raster x along
/// world +x, raster y along world -y).
const PX_M: f64 = 1e-3;

/// An emitting two-sided rectangle on z = 1 m, x in [x0, x1] px from the centre, 400 px tall,
/// radiance 1, in light group `group`.
fn bar(x0: f64, x1: f64, group: &str) -> Shape {
    let p = |x: f64, y: f64| [x * PX_M, y * PX_M, 1.0];
    let tags = camsim_scene3d::ShapeTags {
        category: None,
        light_group: Some(group.into()),
        ..Default::default()
    };
    Shape {
        name: Some(group.into()),
        geometry: Geometry::Triangles {
            positions: vec![p(x0, -200.0), p(x1, -200.0), p(x1, 200.0), p(x0, 200.0)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: grey(1.0),
            two_sided: true,
            image: None,
        }),
        reverse_orientation: false,
        tags,
    }
}

fn scene(w: usize, h: usize, shapes: Vec<Shape>, spp: u32, time: TimeSettings) -> SceneDescription {
    let short = w.min(h) as f64;
    let fov_deg = 2.0 * (short / 2.0 * PX_M).atan().to_degrees();
    let mut s = common::origin_scene(w, h, fov_deg, shapes, spp, time);
    s.settings.seed = 7;
    s
}

fn velocity(v_m_s: [f64; 3]) -> Motion {
    Motion::single(MotionPart::Velocity {
        velocity_m_s: v_m_s,
        angular_velocity_deg_s: [0.0; 3],
        pivot_m: [0.0; 3],
    })
}

/// Band 0 of `img` averaged over its rows: a profile along x.
fn row_profile(img: &[f32], w: usize, h: usize) -> Vec<f64> {
    (0..w)
        .map(|x| (0..h).map(|y| img[y * w + x] as f64).sum::<f64>() / h as f64)
        .collect()
}

/// Where profile `p` first rises through `level` (pixel k's value at k + 0.5, linear between).
fn rise(p: &[f64], level: f64) -> f64 {
    let i = (1..p.len())
        .find(|&i| p[i - 1] < level && p[i] >= level)
        .expect("a rising edge");
    i as f64 - 0.5 + (level - p[i - 1]) / (p[i] - p[i - 1])
}

/// A still bar (group "still", x in [-56, -36] px) and a bar moving right at 500 px/s for 40 ms
/// (group "moving", x in [-20, 20] px at the start: a 20 px box), seen by a camera sliding
/// along y (which the 400 px tall bars hide): the moving group's rising edge is 0.8 v T = 16 px
/// wide (10-90 %), the still group's under 1.5 px; each group integrates to its bar's width
/// along a row and is dark over the other bar.
#[test]
fn a_moving_emitters_group_is_blurred_and_a_static_ones_is_not() {
    let (w, h, v, big_t) = (128, 16, 500.0, 0.04);
    let time = TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: big_t,
            rolling: None,
        },
        shapes: vec![(1, velocity([v * PX_M, 0.0, 0.0]))],
        camera: Some(velocity([0.0, 300.0 * PX_M, 0.0])),
        ..TimeSettings::default()
    };
    let s = scene(
        w,
        h,
        vec![bar(-56.0, -36.0, "still"), bar(-20.0, 20.0, "moving")],
        64,
        time,
    );
    let out = with_groups(&s);
    let n = w * h;
    let still = row_profile(&group(&out, "still")[..n], w, h);
    let moving = row_profile(&group(&out, "moving")[..n], w, h);
    let c = w / 2;
    // Separation: each group is dark over the other's bar.
    assert!(
        still[c - 20..].iter().all(|v| *v == 0.0),
        "still group lit by the moving bar"
    );
    assert!(
        moving[..c - 22].iter().all(|v| *v == 0.0),
        "moving group lit by the still bar"
    );
    let edge = |p: &[f64]| rise(p, 0.9) - rise(p, 0.1);
    let (e_still, e_moving) = (edge(&still), edge(&moving));
    eprintln!("10-90 % edges: still {e_still:.2} px, moving {e_moving:.2} px (closed form 16)");
    assert!(e_still < 1.5, "still edge {e_still} px");
    assert!(
        (e_moving - 0.8 * v * big_t).abs() < 1.0,
        "moving edge {e_moving} px"
    );
    let (a_still, a_moving): (f64, f64) = (still.iter().sum(), moving.iter().sum());
    assert!(
        (a_still / 20.0 - 1.0).abs() < 0.01,
        "still integral {a_still} px"
    );
    assert!(
        (a_moving / 40.0 - 1.0).abs() < 0.01,
        "moving integral {a_moving} px"
    );
}

/// A diffuse floor (reflectance 0.5, z = 0) seen from 2 m above, the camera descending at
/// 0.5 m/s, lit by a point light 1 m up sliding from x = -1 m to +1 m (group "bulb", intensity 2)
/// and a still one 1 m above the view's centre (group "still", intensity 1) over the window
/// [0, 1] s: the bulb's group is rho / pi times the time-averaged irradiance I / (h sqrt(a^2 +
/// h^2)) = 2 / sqrt 2, the still group rho / pi times I / h^2 = 1 (within 0.5 %).
#[test]
fn a_moving_point_lights_group_holds_its_time_averaged_irradiance() {
    let n = 4;
    let floor = common::floor(5.0);
    let mut s = scene(n, n, vec![floor], 1024, TimeSettings::default());
    s.camera.camera_to_world =
        camsim_scene3d::look_at_camera_to_world([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], false)
            .unwrap();
    s.camera.fov_deg = 0.2;
    s.materials = vec![Material::Diffuse {
        reflectance: Texture::Constant(grey(0.5)),
    }];
    s.lights = vec![
        Light::Point {
            position_m: [-1.0, 0.0, 1.0],
            intensity: grey(2.0),
        },
        Light::Point {
            position_m: [0.0, 0.0, 1.0],
            intensity: grey(1.0),
        },
    ];
    s.light_groups = vec![Some("bulb".into()), Some("still".into())];
    s.settings.time = TimeSettings {
        lights: vec![(0, velocity([2.0, 0.0, 0.0]))],
        camera: Some(velocity([0.0, 0.0, -0.5])),
        ..TimeSettings::default()
    };
    let out = with_groups(&s);
    let mean = |g: &[f32]| g[..n * n].iter().map(|v| *v as f64).sum::<f64>() / (n * n) as f64;
    let k = 0.5 / std::f64::consts::PI;
    for (name, want) in [("bulb", k * 2.0 / 2f64.sqrt()), ("still", k)] {
        let got = mean(group(&out, name));
        eprintln!("group {name}: {got:.5}, closed form {want:.5}");
        assert!(
            (got / want - 1.0).abs() < 0.005,
            "group {name}: {got} vs {want}"
        );
    }
}
