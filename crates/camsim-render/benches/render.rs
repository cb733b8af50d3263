//! Renderer benchmarks (issue 4): the classic Cornell box at 512 x 512 with 4 wavelengths per
//! path and maximum depth 8 (samples/s and rays/s, camera + bounce + shadow rays), the same box
//! with both blocks moving during the exposure (issue 28: motion blur, against the static box
//! at equal samples), and the BVH build of a 1-million-triangle mesh.
//!
//! Run: `cargo bench -p camsim-render --bench render`
//! (`-- --measurement-time 5` for a shorter run). The Cornell box render also prints the
//! `RenderStats` of one 16-spp render, which is the rays/s figure to quote.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::bvh::Bvh;
use camsim_render::geometry::Prim;
use camsim_render::math::V3;
use camsim_render::*;
use camsim_scene3d::*;
use criterion::{criterion_group, criterion_main, Criterion};
use rand::Rng;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// The Cornell box geometry as published by the Cornell Program of Computer Graphics ("Cornell
/// Box Data", https://www.graphics.cornell.edu/online/box/data.html), millimetres converted to
/// metres. The light is lowered 0.1 mm below the ceiling so the two do not coincide.
fn cornell_box(width: usize, height: usize, spp: u32) -> SceneDescription {
    let quads: Vec<(&str, usize, [[f64; 3]; 4])> = vec![
        (
            "floor",
            0,
            [
                [552.8, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 559.2],
                [549.6, 0.0, 559.2],
            ],
        ),
        (
            "ceiling",
            0,
            [
                [556.0, 548.8, 0.0],
                [556.0, 548.8, 559.2],
                [0.0, 548.8, 559.2],
                [0.0, 548.8, 0.0],
            ],
        ),
        (
            "back_wall",
            0,
            [
                [549.6, 0.0, 559.2],
                [0.0, 0.0, 559.2],
                [0.0, 548.8, 559.2],
                [556.0, 548.8, 559.2],
            ],
        ),
        (
            "right_wall",
            2,
            [
                [0.0, 0.0, 559.2],
                [0.0, 0.0, 0.0],
                [0.0, 548.8, 0.0],
                [0.0, 548.8, 559.2],
            ],
        ),
        (
            "left_wall",
            1,
            [
                [552.8, 0.0, 0.0],
                [549.6, 0.0, 559.2],
                [556.0, 548.8, 559.2],
                [556.0, 548.8, 0.0],
            ],
        ),
        (
            "short_block",
            0,
            [
                [130.0, 165.0, 65.0],
                [82.0, 165.0, 225.0],
                [240.0, 165.0, 272.0],
                [290.0, 165.0, 114.0],
            ],
        ),
        (
            "short_block",
            0,
            [
                [290.0, 0.0, 114.0],
                [290.0, 165.0, 114.0],
                [240.0, 165.0, 272.0],
                [240.0, 0.0, 272.0],
            ],
        ),
        (
            "short_block",
            0,
            [
                [130.0, 0.0, 65.0],
                [130.0, 165.0, 65.0],
                [290.0, 165.0, 114.0],
                [290.0, 0.0, 114.0],
            ],
        ),
        (
            "short_block",
            0,
            [
                [82.0, 0.0, 225.0],
                [82.0, 165.0, 225.0],
                [130.0, 165.0, 65.0],
                [130.0, 0.0, 65.0],
            ],
        ),
        (
            "short_block",
            0,
            [
                [240.0, 0.0, 272.0],
                [240.0, 165.0, 272.0],
                [82.0, 165.0, 225.0],
                [82.0, 0.0, 225.0],
            ],
        ),
        (
            "tall_block",
            0,
            [
                [423.0, 330.0, 247.0],
                [265.0, 330.0, 296.0],
                [314.0, 330.0, 456.0],
                [472.0, 330.0, 406.0],
            ],
        ),
        (
            "tall_block",
            0,
            [
                [423.0, 0.0, 247.0],
                [423.0, 330.0, 247.0],
                [472.0, 330.0, 406.0],
                [472.0, 0.0, 406.0],
            ],
        ),
        (
            "tall_block",
            0,
            [
                [472.0, 0.0, 406.0],
                [472.0, 330.0, 406.0],
                [314.0, 330.0, 456.0],
                [314.0, 0.0, 456.0],
            ],
        ),
        (
            "tall_block",
            0,
            [
                [314.0, 0.0, 456.0],
                [314.0, 330.0, 456.0],
                [265.0, 330.0, 296.0],
                [265.0, 0.0, 296.0],
            ],
        ),
        (
            "tall_block",
            0,
            [
                [265.0, 0.0, 296.0],
                [265.0, 330.0, 296.0],
                [423.0, 330.0, 247.0],
                [423.0, 0.0, 247.0],
            ],
        ),
    ];
    let mm = |p: [f64; 3]| [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3];
    let quad = |q: [[f64; 3]; 4]| Geometry::Triangles {
        positions: q.iter().map(|p| mm(*p)).collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let mut shapes: Vec<Shape> = quads
        .into_iter()
        .map(|(name, m, q)| Shape {
            name: Some(name.into()),
            geometry: quad(q),
            material: m,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        })
        .collect();
    // The light faces down: (p1 - p0) x (p2 - p0) = -y for this winding.
    shapes.push(Shape {
        name: Some("light".into()),
        geometry: quad([
            [343.0, 548.7, 227.0],
            [343.0, 548.7, 332.0],
            [213.0, 548.7, 332.0],
            [213.0, 548.7, 227.0],
        ]),
        material: 3,
        area_light: Some(AreaLight {
            radiance: flat(10.0),
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    });
    // Grey-ish walls; red and green as smooth ramps (speed does not depend on the values).
    let white = flat(0.75);
    let red = Spectrum::new(
        vec![400.0, 580.0, 620.0, 700.0],
        vec![0.05, 0.06, 0.5, 0.6],
        "red",
    )
    .unwrap();
    let green = Spectrum::new(
        vec![400.0, 500.0, 550.0, 600.0, 700.0],
        vec![0.08, 0.3, 0.45, 0.15, 0.1],
        "green",
    )
    .unwrap();
    let materials = [white, red, green, flat(0.78)]
        .into_iter()
        .map(|s| Material::Diffuse {
            reflectance: Texture::Constant(s),
        })
        .collect();
    // Camera of the Cornell data: (278, 273, -800) mm looking +z, 35 mm lens on a 25 mm sensor.
    let camera = camera_from_focal_length(
        0.035,
        0.025,
        0.025,
        mm([278.0, 273.0, -800.0]),
        mm([278.0, 273.0, 0.0]),
        [0.0, 1.0, 0.0],
        width,
        height,
    );
    SceneDescription {
        camera,
        shapes,
        materials,
        named_materials: HashMap::new(),
        lights: vec![],
        settings: RenderSettings {
            grid: WavelengthGrid::default(),
            samples_per_pixel: spp,
            max_depth: 8,
            wavelengths_per_path: 4,
            seed: 1,
            time_budget_s: None,
            direct_only: false,
            ..RenderSettings::default()
        },
        focus_distance_m: Some(1.08),
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    }
}

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![380.0, 720.0], vec![v, v], "flat").unwrap()
}

/// A jittered latitude-longitude sphere of about `n` triangles.
fn big_mesh(n: usize) -> Vec<Prim> {
    let rows = ((n / 4) as f64).sqrt() as usize;
    let cols = 2 * rows;
    let mut rng = camsim_core::rng::seeded(3);
    let mut pts = Vec::with_capacity((rows + 1) * (cols + 1));
    for i in 0..=rows {
        let th = std::f32::consts::PI * i as f32 / rows as f32;
        for j in 0..=cols {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / cols as f32;
            let r = 1.0 + 0.02 * rng.gen::<f32>();
            pts.push(V3::new(
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ));
        }
    }
    let mut prims = Vec::with_capacity(2 * rows * cols);
    let at = |i: usize, j: usize| pts[i * (cols + 1) + j];
    for i in 0..rows {
        for j in 0..cols {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            prims.push(Prim::Tri {
                p0: a,
                e1: b - a,
                e2: c - a,
            });
            prims.push(Prim::Tri {
                p0: a,
                e1: c - a,
                e2: d - a,
            });
        }
    }
    prims
}

fn bench_cornell(c: &mut Criterion) {
    // One longer render, reported from RenderStats.
    let scene = cornell_box(512, 512, 16);
    let out = render(&scene, &|_, _| {}).unwrap();
    let s = out.stats;
    let threads = rayon::current_num_threads();
    eprintln!(
        "Cornell box 512x512, 16 spp, 4 wavelengths/path, max depth 8, {threads} threads: {:.2} s, {:.3} M samples/s, {:.3} M rays/s \
         ({:.3} M rays/s per thread; camera {}, bounce {}, shadow {})",
        s.seconds,
        s.samples_per_second / 1e6,
        s.rays_per_second / 1e6,
        s.rays_per_second / 1e6 / threads as f64,
        s.camera_rays,
        s.bounce_rays,
        s.shadow_rays
    );
    let mut g = c.benchmark_group("cornell_box_512");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));
    let scene = cornell_box(512, 512, 4);
    g.throughput(criterion::Throughput::Elements(512 * 512 * 4));
    g.bench_function("render_4spp", |b| {
        b.iter(|| render(&scene, &|_, _| {}).unwrap())
    });
    let moving = moving_blocks(scene.clone());
    g.bench_function("render_4spp_moving_blocks", |b| {
        b.iter(|| render(&moving, &|_, _| {}).unwrap())
    });
    g.finish();
}

/// The box with its two blocks moving over the shutter (0-1 s): the short block slides 5 cm
/// and turns 20 degrees about its vertical axis, the tall block slides 3 cm the other way; the
/// camera is still. Every path draws a time, and every ray also tests the two moving groups.
fn moving_blocks(mut scene: SceneDescription) -> SceneDescription {
    use camsim_scene3d::motion::{Motion, MotionPart, TimeSettings};
    let mut time = TimeSettings::default();
    for (i, s) in scene.shapes.iter().enumerate() {
        let part = match s.name.as_deref() {
            Some("short_block") => MotionPart::Velocity {
                velocity_m_s: [0.05, 0.0, 0.0],
                angular_velocity_deg_s: [0.0, 20.0, 0.0],
                pivot_m: [0.186, 0.0, 0.169],
            },
            Some("tall_block") => MotionPart::Velocity {
                velocity_m_s: [-0.03, 0.0, 0.0],
                angular_velocity_deg_s: [0.0; 3],
                pivot_m: [0.0; 3],
            },
            _ => continue,
        };
        time.shapes.push((i, Motion::single(part)));
    }
    scene.settings.time = time;
    scene
}

fn bench_bvh(c: &mut Criterion) {
    let prims = big_mesh(1_000_000);
    let t = Instant::now();
    let bvh = Bvh::build(prims.clone());
    eprintln!(
        "BVH build of {} triangles: {:.3} s, {} nodes, depth {}",
        prims.len(),
        t.elapsed().as_secs_f64(),
        bvh.node_count(),
        bvh.depth()
    );
    drop(bvh);
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(15));
    g.bench_function("build_1M_triangles", |b| {
        b.iter(|| Bvh::build(prims.clone()))
    });
    g.finish();
}

criterion_group!(benches, bench_cornell, bench_bvh);
criterion_main!(benches);
