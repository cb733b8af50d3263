//! The camera sampler: views on a spherical shell around the target, looking at it, validated
//! by ray casts. Each accepted view is checked here against an independent brute-force ray
//! cast (every triangle for every ray, no hierarchy) of the same visibility definition.

use camsim_compose::camera::{apply, CameraSamplerSpec};
use camsim_compose::environment::Draw;
use camsim_scene3d::*;
use std::collections::HashMap;

fn cube(name: &str, centre: [f64; 3], half: f64, category: Option<&str>) -> Shape {
    let mut positions = Vec::new();
    for k in 0..8 {
        positions.push([
            centre[0] + if k & 1 == 0 { -half } else { half },
            centre[1] + if k & 2 == 0 { -half } else { half },
            centre[2] + if k & 4 == 0 { -half } else { half },
        ]);
    }
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let indices = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Shape {
        name: Some(name.into()),
        geometry: Geometry::mesh(positions, indices, None, None),
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: ShapeTags {
            category: category.map(String::from),
            ..Default::default()
        },
    }
}

/// Four cubes on a floor (y up); the cubes have categories, the floor has none.
fn scene() -> SceneDescription {
    let floor = Shape {
        name: Some("floor".into()),
        geometry: Geometry::Triangles {
            positions: vec![
                [-3.0, 0.0, -3.0],
                [3.0, 0.0, -3.0],
                [3.0, 0.0, 3.0],
                [-3.0, 0.0, 3.0],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    };
    SceneDescription {
        camera: Camera {
            camera_to_world: look_at_camera_to_world(
                [0.0, 1.0, 5.0],
                [0.0; 3],
                [0.0, 1.0, 0.0],
                true,
            )
            .unwrap(),
            fov_deg: 40.0,
            width: 64,
            height: 48,
            lens: None,
        },
        shapes: vec![
            floor,
            cube("a", [0.3, 0.1, 0.0], 0.1, Some("box")),
            cube("b", [-0.3, 0.1, 0.1], 0.1, Some("box")),
            cube("c", [0.0, 0.15, -0.35], 0.15, Some("box")),
            cube("d", [0.05, 0.05, 0.35], 0.05, Some("box")),
        ],
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(camsim_core::Spectrum::from_pairs(&[
                (300.0, 0.5),
                (900.0, 0.5),
            ])),
        }],
        named_materials: HashMap::new(),
        lights: vec![],
        settings: RenderSettings::default(),
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: vec![],
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Brute force: nearest hit distance of the ray with each shape (infinite where missed), by a
/// barycentric point-in-triangle test on the ray's plane hit.
fn hits(scene: &SceneDescription, o: [f64; 3], d: [f64; 3]) -> Vec<f64> {
    scene
        .shapes
        .iter()
        .map(|s| {
            let Geometry::Triangles {
                positions, indices, ..
            } = &s.geometry
            else {
                unreachable!()
            };
            let mut best = f64::INFINITY;
            for t in indices {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                let n = cross(sub(b, a), sub(c, a));
                let den = dot(n, d);
                if den.abs() < 1e-15 {
                    continue;
                }
                let tt = dot(n, sub(a, o)) / den;
                if tt <= 1e-9 {
                    continue;
                }
                let p = [o[0] + tt * d[0], o[1] + tt * d[1], o[2] + tt * d[2]];
                let inside = [(a, b), (b, c), (c, a)]
                    .iter()
                    .all(|(u, v)| dot(cross(sub(*v, *u), sub(p, *u)), n) >= 0.0);
                if inside {
                    best = best.min(tt);
                }
            }
            best
        })
        .collect()
}

/// The module's visibility definition by brute force: (per counted shape its visible
/// fraction, background fraction), for the scene's camera and a `nx` x `ny` in-frame grid
/// extended 1.5 times.
fn brute_force_view(scene: &SceneDescription, nx: i64, ny: i64) -> (Vec<f64>, f64) {
    let c = &scene.camera;
    let t = (c.fov_deg.to_radians() / 2.0).tan();
    let a = c.width as f64 / c.height as f64;
    let (hx, hy) = if a >= 1.0 { (t * a, t) } else { (t, t / a) };
    let o = c.camera_to_world.apply_point([0.0; 3]);
    let ns = scene.shapes.len();
    let (mut vis, mut total, mut bg, mut n_in) = (vec![0.0; ns], vec![0.0; ns], 0.0, 0.0);
    let (ex, ey) = (
        (0.25 * nx as f64).ceil() as i64,
        (0.25 * ny as f64).ceil() as i64,
    );
    for j in -ey..ny + ey {
        for i in -ex..nx + ex {
            let sx = (2.0 * (i as f64 + 0.5) / nx as f64 - 1.0) * hx;
            let sy = (1.0 - 2.0 * (j as f64 + 0.5) / ny as f64) * hy;
            let d = c.camera_to_world.apply_vector([sx, sy, 1.0]);
            let l = dot(d, d).sqrt();
            let h = hits(scene, o, d.map(|v| v / l));
            let first = (0..ns)
                .filter(|k| h[*k].is_finite())
                .min_by(|x, y| h[*x].total_cmp(&h[*y]));
            for k in 0..ns {
                if h[k].is_finite() {
                    total[k] += 1.0;
                }
            }
            if (0..nx).contains(&i) && (0..ny).contains(&j) {
                n_in += 1.0;
                match first {
                    Some(k) if scene.shapes[k].tags.category.is_some() => vis[k] += 1.0,
                    _ => bg += 1.0,
                }
            }
        }
    }
    let fr = (0..ns)
        .filter(|k| scene.shapes[*k].tags.category.is_some())
        .map(|k| {
            if total[k] > 0.0 {
                vis[k] / total[k]
            } else {
                0.0
            }
        })
        .collect();
    (fr, bg / n_in)
}

fn spec() -> CameraSamplerSpec {
    CameraSamplerSpec {
        distance_m: Draw::Range([1.0, 2.5]),
        elevation_deg: Draw::Range([15.0, 70.0]),
        roll_deg: Draw::Range([-20.0, 20.0]),
        fov_deg: Some(Draw::Range([30.0, 50.0])),
        min_visible_objects: 3,
        min_visible_fraction: 0.6,
        max_background_fraction: 0.9,
        validation_rays: [24, 18],
        ..CameraSamplerSpec::default()
    }
}

/// Every accepted view meets the constraints by an independent brute-force cast; the optical
/// axis passes within 1 mm of the target; distance and elevation lie in their ranges.
#[test]
fn accepted_views_satisfy_the_validation_and_look_at_the_target() {
    let target = [0.0, 0.1, 0.0];
    let spec = spec();
    let mut total_tries = 0;
    for seed in 0..12u64 {
        let mut s = scene();
        let rec = apply(&mut s, &spec, seed, Some(target)).unwrap();
        total_tries += rec.tries;
        let (fr, bg) = brute_force_view(&s, 24, 18);
        let n_ok = fr
            .iter()
            .filter(|f| **f >= spec.min_visible_fraction)
            .count();
        assert_eq!(
            Some(n_ok),
            rec.visible_objects,
            "seed {seed}: {fr:?} vs {:?}",
            rec.objects
        );
        assert!(
            n_ok >= 3 && bg <= 0.9,
            "seed {seed}: {n_ok} objects, background {bg}"
        );
        assert!((bg - rec.background_fraction.unwrap()).abs() < 1e-12);
        for (a, b) in fr.iter().zip(&rec.objects) {
            assert!(
                (a - b.fraction).abs() < 1e-12,
                "seed {seed}: {fr:?} vs {:?}",
                rec.objects
            );
        }
        let c2w = &s.camera.camera_to_world;
        let o = c2w.apply_point([0.0; 3]);
        let z = c2w.apply_vector([0.0, 0.0, 1.0]);
        let z = z.map(|v| v / dot(z, z).sqrt());
        let to_t = sub(target, o);
        let along = dot(to_t, z);
        let miss = (dot(to_t, to_t) - along * along).max(0.0).sqrt();
        assert!(
            along > 0.0 && miss < 1e-3,
            "seed {seed}: the axis misses the target by {miss} m"
        );
        let dist = dot(to_t, to_t).sqrt();
        assert!((1.0..=2.5).contains(&dist) && (dist - rec.distance_m).abs() < 1e-9);
        let elev = ((o[1] - target[1]) / dist).asin().to_degrees();
        assert!(
            (15.0 - 1e-9..=70.0 + 1e-9).contains(&elev) && (elev - rec.elevation_deg).abs() < 1e-6
        );
        assert!((30.0..=50.0).contains(&s.camera.fov_deg));
        assert_eq!(s.focus_distance_m, Some(rec.distance_m));
    }
    eprintln!("12 samples took {total_tries} tries");
}

/// The same seed gives the same view; another seed another.
#[test]
fn views_are_deterministic_per_seed() {
    let spec = spec();
    let (mut a, mut b, mut c) = (scene(), scene(), scene());
    let ra = apply(&mut a, &spec, 7, Some([0.0, 0.1, 0.0])).unwrap();
    let rb = apply(&mut b, &spec, 7, Some([0.0, 0.1, 0.0])).unwrap();
    let rc = apply(&mut c, &spec, 8, Some([0.0, 0.1, 0.0])).unwrap();
    assert_eq!(ra, rb);
    assert_eq!(a.camera, b.camera);
    assert_ne!(ra.position_m, rc.position_m);
}

/// Roll 0 keeps the image's up in the plane of the world's up and the optical axis; the
/// target can be an object by name; an impossible constraint fails naming it.
#[test]
fn roll_target_object_and_impossible_constraints() {
    let mut s = scene();
    let spec0 = CameraSamplerSpec {
        target_object: Some("c".into()),
        ..CameraSamplerSpec::default()
    };
    let rec = apply(&mut s, &spec0, 1, None).unwrap();
    assert!(
        dot(
            sub(rec.target_m, [0.0, 0.15, -0.35]),
            sub(rec.target_m, [0.0, 0.15, -0.35])
        ) < 1e-20
    );
    let c2w = &s.camera.camera_to_world;
    let (y, z) = (
        c2w.apply_vector([0.0, 1.0, 0.0]),
        c2w.apply_vector([0.0, 0.0, 1.0]),
    );
    assert!(
        dot(cross(z, [0.0, 1.0, 0.0]), y).abs() < 1e-9,
        "roll 0 tilts the image"
    );
    assert!(y[1] > 0.0);
    let impossible = CameraSamplerSpec {
        min_visible_objects: 4,
        min_visible_fraction: 1.0,
        distance_m: Draw::Fixed(0.3),
        max_tries: 5,
        ..CameraSamplerSpec::default()
    };
    let err = apply(&mut scene(), &impossible, 0, Some([0.0; 3])).unwrap_err();
    assert!(
        err.message.contains("min_visible_objects = 4") && err.message.contains("max_tries = 5"),
        "{err}"
    );
    let bad = CameraSamplerSpec {
        distance_m: Draw::Range([2.0, 1.0]),
        ..CameraSamplerSpec::default()
    };
    assert_eq!(
        apply(&mut scene(), &bad, 0, None).unwrap_err().key,
        "compose.camera.distance_m"
    );
}
