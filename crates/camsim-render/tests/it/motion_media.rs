//! Participating media in a moving scene (issue 28). Media do not move (pbrt-v4 creates them
//! with the start transform), but the camera, lights and the shapes around them do, and the
//! volumetric path tracer traces, transmits and sees emission at each path's time. Checked
//! against the time average of Beer-Lambert's law, `mean over [t0, t1] of exp(-sigma d(t))`,
//! which for a distance changing at constant speed from `d0` to `d1` is
//! `(exp(-sigma d0) - exp(-sigma d1)) / (sigma (d1 - d0))`:
//! - a camera translating toward or away from an emitting plane through an absorbing medium
//!   that fills the scene;
//! - an emitting sphere receding from a still camera through the medium (its emission is seen
//!   at the path's time: side and density in the sphere's own pose);
//! - and a static scene with media renders byte for byte as before with the time machinery on
//!   (a shutter window, a rolling shutter, and a moving object no ray can reach).

use crate::common;
use camsim_render::render;
use camsim_scene3d::media::{Coefficients, Medium, MediumKind};
use camsim_scene3d::motion::{Motion, MotionPart, RowReadout, Shutter, TimeSettings};
use camsim_scene3d::{AreaLight, Geometry, Material, SceneDescription, Shape, Texture, Transform};
use common::grey;

/// An absorbing (and, with `sigma_s_per_m`, scattering) homogeneous medium.
fn fog(sigma_a_per_m: f64, sigma_s_per_m: f64) -> Medium {
    Medium {
        name: "fog".into(),
        g: 0.0,
        kind: MediumKind::Homogeneous(Coefficients {
            sigma_a_per_m: grey(sigma_a_per_m),
            sigma_s_per_m: grey(sigma_s_per_m),
            le: None,
        }),
    }
}

/// An emitter of radiance 1 with a black surface (one-sided: toward its outside only).
fn emitter(geometry: Geometry, two_sided: bool) -> Shape {
    Shape {
        name: Some("emitter".into()),
        geometry,
        material: 0,
        area_light: Some(AreaLight {
            radiance: grey(1.0),
            two_sided,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// A 16 x 16 camera at the origin looking down +z with a 1 degree field (the rays are within
/// 0.71 degrees of the axis: their paths are longer than the axis's by under 8e-5), the scene
/// filled with a medium absorbing `sigma_per_m`, the shutter open over [0, 1] s.
fn scene(shapes: Vec<Shape>, sigma_per_m: f64, spp: u32, time: TimeSettings) -> SceneDescription {
    let mut s = common::origin_scene(16, 16, 1.0, shapes, spp, time);
    s.media.fill(fog(sigma_per_m, 0.0));
    s
}

fn along_z(v_m_s: f64) -> Motion {
    Motion::single(MotionPart::Velocity {
        velocity_m_s: [0.0, 0.0, v_m_s],
        angular_velocity_deg_s: [0.0; 3],
        pivot_m: [0.0; 3],
    })
}

/// The mean of band 0 over the image.
fn mean(s: &SceneDescription) -> f64 {
    let out = render(s, &|_, _| {}).unwrap();
    let n = s.camera.width * s.camera.height;
    out.radiance.data[..n]
        .iter()
        .map(|v| *v as f64)
        .sum::<f64>()
        / n as f64
}

/// Beer-Lambert averaged over a distance running linearly from `d0` to `d1`.
fn mean_transmittance(sigma: f64, d0: f64, d1: f64) -> f64 {
    if d0 == d1 {
        return (-sigma * d0).exp();
    }
    ((-sigma * d0).exp() - (-sigma * d1).exp()) / (sigma * (d1 - d0))
}

fn check(what: &str, got: f64, want: f64, tol: f64) {
    eprintln!("{what}: {got:.5}, closed form {want:.5}");
    assert!((got / want - 1.0).abs() < tol, "{what}: {got} vs {want}");
}

/// The camera moves at 2 m/s toward (and, in a second render, away from) an emitting plane 3 m
/// ahead at the window's start, through a medium absorbing 1/m: the mean transmittance over the
/// distances 3 -> 1 m and 3 -> 5 m (within 1 %); the still camera sees exp(-3).
#[test]
fn a_camera_moving_through_fog_sees_the_time_averaged_transmittance() {
    let (sigma, d0, v) = (1.0, 3.0, 2.0);
    let plane = || {
        emitter(
            Geometry::Triangles {
                positions: vec![
                    [-1.0, -1.0, d0],
                    [1.0, -1.0, d0],
                    [1.0, 1.0, d0],
                    [-1.0, 1.0, d0],
                ],
                indices: vec![[0, 1, 2], [0, 2, 3]],
                uvs: None,
                normals: None,
                colors: None,
                uvs1: None,
                tangents: None,
            },
            true,
        )
    };
    let window = |camera: Option<Motion>| TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: 1.0,
            rolling: None,
        },
        camera,
        ..TimeSettings::default()
    };
    let still = mean(&scene(vec![plane()], sigma, 256, window(None)));
    check("still camera", still, (-sigma * d0).exp(), 0.01);
    for (what, vz) in [("toward", v), ("away", -v)] {
        let got = mean(&scene(vec![plane()], sigma, 256, window(Some(along_z(vz)))));
        check(what, got, mean_transmittance(sigma, d0, d0 - vz), 0.01);
    }
}

/// A one-sided emitting sphere of radius 0.5 m centred 2 m ahead recedes at 2 m/s through a
/// medium absorbing 1/m: its near side runs from 1.5 m to 3.5 m, and the camera sees the mean
/// transmittance over those distances (within 1 %). Which side emits is decided in the
/// sphere's pose at the path's time (in its stored pose, the near side would face inward once
/// the sphere has moved by its radius, and most of the light would be lost).
#[test]
fn an_emitter_receding_through_fog_is_seen_at_each_paths_time() {
    let (sigma, r, c, v) = (1.0, 0.5, 2.0, 2.0);
    let ball = emitter(
        Geometry::Sphere {
            center: [0.0, 0.0, c],
            radius: r,
        },
        false,
    );
    let time = TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: 1.0,
            rolling: None,
        },
        shapes: vec![(0, along_z(v))],
        ..TimeSettings::default()
    };
    let got = mean(&scene(vec![ball], sigma, 256, time));
    check(
        "receding sphere",
        got,
        mean_transmittance(sigma, c - r, c - r + v),
        0.01,
    );
}

/// A diffuse floor (reflectance 0.5, z = 0) seen from 2 m above through a medium absorbing
/// 0.3/m, lit by a point light of intensity 2 that slides 1 m above it from x = -1 m to +1 m
/// during the window [0, 1] s: the light reaching the floor below the path's middle is the time
/// average of `I h exp(-sigma r) / r^3`, `r = sqrt(x(t)^2 + h^2)` (evaluated here by a fine
/// midpoint sum), and the camera sees rho / pi of it times exp(-2 sigma) (within 1 %): the
/// light is sampled, and its shadow ray attenuated, at the path's time.
#[test]
fn a_light_moving_through_fog_lights_with_the_time_averaged_attenuation() {
    let (sigma, h, i, rho) = (0.3, 1.0, 2.0, 0.5);
    let floor = common::floor(5.0);
    let time = TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: 1.0,
            rolling: None,
        },
        lights: vec![(
            0,
            Motion::single(MotionPart::Velocity {
                velocity_m_s: [2.0, 0.0, 0.0],
                angular_velocity_deg_s: [0.0; 3],
                pivot_m: [0.0; 3],
            }),
        )],
        ..TimeSettings::default()
    };
    let mut s = scene(vec![floor], sigma, 256, time);
    s.camera.camera_to_world =
        camsim_scene3d::look_at_camera_to_world([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], false)
            .unwrap();
    s.materials = vec![Material::Diffuse {
        reflectance: Texture::Constant(grey(rho)),
    }];
    s.lights = vec![camsim_scene3d::Light::Point {
        position_m: [-1.0, 0.0, h],
        intensity: grey(i),
    }];
    let n = 100_000;
    let irradiance = (0..n)
        .map(|k| {
            let x = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (x * x + h * h).sqrt();
            i * h * (-sigma * r).exp() / (r * r * r)
        })
        .sum::<f64>()
        / n as f64;
    let want = rho / std::f64::consts::PI * irradiance * (-2.0 * sigma).exp();
    check("moving light in fog", mean(&s), want, 0.01);
}

/// The Cornell box filled with a scattering fog renders byte for byte as before under a
/// shutter window and a rolling shutter with motions that do not move, and with a triangle
/// moving inside the closed short block (no ray reaches it, but every path draws a time and
/// tests the moving group).
#[test]
fn a_static_scene_with_media_is_bit_identical_with_the_time_machinery_on() {
    use camsim_scene3d::builtin::{scene as builtin, BuiltinOptions};
    let opts = BuiltinOptions {
        resolution: Some((24, 24)),
        samples_per_pixel: 4,
        ..BuiltinOptions::default()
    };
    let mut base = builtin("cornell-box", &opts).unwrap();
    base.media.fill(fog(0.5, 1.5));
    let a = render(&base, &|_, _| {}).unwrap();
    let mut windowed = base.clone();
    windowed.settings.time = TimeSettings {
        shutter: Shutter {
            open_s: 0.3,
            close_s: 0.9,
            rolling: Some(RowReadout {
                row0_delay_s: 0.01,
                per_row_delay_s: 1e-3,
                global_reset: false,
            }),
        },
        shapes: vec![(0, along_z(0.0))],
        camera: Some(Motion::single(MotionPart::Fixed(Transform::identity()))),
        ..TimeSettings::default()
    };
    let b = render(&windowed, &|_, _| {}).unwrap();
    assert!(
        a.radiance.data == b.radiance.data,
        "a shutter window changed the render"
    );
    let mut moved = base.clone();
    moved.shapes.push(common::hidden_in_cornell_block());
    let k = moved.shapes.len() - 1;
    moved.settings.time = TimeSettings {
        shutter: Shutter {
            open_s: 0.0,
            close_s: 1.0,
            rolling: None,
        },
        shapes: vec![(k, along_z(0.01))],
        ..TimeSettings::default()
    };
    let c = render(&moved, &|_, _| {}).unwrap();
    assert!(
        a.radiance.data == c.radiance.data,
        "a hidden moving object changed the render"
    );
}
