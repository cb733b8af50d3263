//! Physics checks of the path tracer against closed forms: furnace enclosures, the
//! point-to-rectangle form factor, emitter radiance and the distance invariance of radiance.
//! Tolerances: the stated 1 % bound, and in addition |error| < 4.5 standard errors where the
//! standard error comes from the scatter of independent pixel estimates (each test also checks
//! that this standard error is small enough for the 1 % bound to mean something).

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;

fn spec(w: &[f64], v: &[f64]) -> Spectrum {
    Spectrum::new(w.to_vec(), v.to_vec(), "test").unwrap()
}

fn flat(v: f64) -> Spectrum {
    spec(&[300.0, 900.0], &[v, v])
}

fn settings(grid: WavelengthGrid, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        grid,
        samples_per_pixel: spp,
        max_depth,
        wavelengths_per_path: 4,
        seed: 7,
        time_budget_s: None,
        direct_only: false,
        ..RenderSettings::default()
    }
}

fn camera(from: [f64; 3], to: [f64; 3], up: [f64; 3], fov_deg: f64, w: usize, h: usize) -> Camera {
    Camera {
        camera_to_world: look_at_camera_to_world(from, to, up, true).unwrap(),
        fov_deg,
        width: w,
        height: h,
        lens: None,
    }
}

fn scene(
    camera: Camera,
    shapes: Vec<Shape>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    settings: RenderSettings,
) -> SceneDescription {
    SceneDescription {
        camera,
        shapes,
        materials,
        named_materials: HashMap::new(),
        lights,
        settings,
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    }
}

fn diffuse(s: Spectrum) -> Material {
    Material::Diffuse {
        reflectance: Texture::Constant(s),
    }
}

/// Mean and standard error (over pixels) of band `b`.
fn band_stats(img: &camsim_core::SpectralImage, b: usize) -> (f64, f64) {
    let v: Vec<f64> = img.band(b).iter().map(|x| *x as f64).collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Mean over all bands and pixels with its standard error (pixel-wise band means are the
/// independent estimates).
fn all_band_stats(img: &camsim_core::SpectralImage) -> (f64, f64) {
    let nb = img.bands();
    let per_pixel: Vec<f64> = (0..img.pixels())
        .map(|p| (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64)
        .collect();
    let n = per_pixel.len() as f64;
    let m = per_pixel.iter().sum::<f64>() / n;
    let var = per_pixel.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

fn check(what: &str, got: f64, se: f64, want: f64, rel_tol: f64) {
    let err = (got - want) / want;
    eprintln!(
        "{what}: got {got:.6}, want {want:.6}, rel. error {:+.3} %, standard error {:.3} %",
        err * 100.0,
        se / want * 100.0
    );
    assert!(
        se / want < rel_tol / 3.0,
        "{what}: standard error {:.3} % too large for a {:.1} % test",
        se / want * 100.0,
        rel_tol * 100.0
    );
    assert!(
        err.abs() < rel_tol,
        "{what}: relative error {:.3} % exceeds {:.1} %",
        err * 100.0,
        rel_tol * 100.0
    );
    assert!(
        (got - want).abs() < 4.5 * se + 1e-4 * want,
        "{what}: error {:.3e} is more than 4.5 standard errors ({se:.3e})",
        got - want
    );
}

/// Band average of `f` over band `b` of `grid` (Simpson's rule, 400 intervals).
fn band_average(grid: &WavelengthGrid, b: usize, f: impl Fn(f64) -> f64) -> f64 {
    let (lo, hi) = (
        grid.wavelength_nm(b) - grid.step_nm / 2.0,
        grid.wavelength_nm(b) + grid.step_nm / 2.0,
    );
    let n = 400;
    let h = (hi - lo) / n as f64;
    let mut s = f(lo) + f(hi);
    for i in 1..n {
        s += f(lo + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0 / (hi - lo)
}

/// A closed cube [-1, 1]^3 of 12 triangles; `inward` winds them so (p1-p0)x(p2-p0) points inside.
fn cube(inward: bool) -> Geometry {
    let mut positions = vec![];
    for i in 0..8 {
        positions.push([
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        ]);
    }
    // Faces as quads with outward-facing counter-clockwise winding.
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut indices = vec![];
    for q in quads {
        let (a, b) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
        if inward {
            indices.push([a[0], a[2], a[1]]);
            indices.push([b[0], b[2], b[1]]);
        } else {
            indices.push(a);
            indices.push(b);
        }
    }
    Geometry::mesh(positions, indices, None, None)
}

#[test]
fn cube_winding_helper_is_outward() {
    // Guard for the helper itself: the outward cube's face normals point away from the centre.
    if let Geometry::Triangles {
        positions, indices, ..
    } = cube(false)
    {
        for t in indices {
            let p: Vec<[f64; 3]> = t.iter().map(|i| positions[*i as usize]).collect();
            let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let c = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
                (p[0][2] + p[1][2] + p[2][2]) / 3.0,
            ];
            assert!(n[0] * c[0] + n[1] * c[1] + n[2] * c[2] > 0.0);
        }
    }
}

/// Furnace (closed enclosure, every surface emits Le and reflects rho): L = Le / (1 - rho).
/// Spectrally varying Le and rho; expected band values are the band averages of Le/(1-rho).
fn furnace(
    shape: Geometry,
    two_sided: bool,
    reverse: bool,
    spp: u32,
) -> (WavelengthGrid, camsim_core::SpectralImage) {
    let grid = WavelengthGrid::new(400.0, 700.0, 50.0).unwrap();
    let le = spec(&[350.0, 750.0], &[1.0, 2.0]);
    let rho = spec(&[350.0, 750.0], &[0.5, 0.75]);
    let cam = camera(
        [0.0, 0.0, 0.0],
        [0.3, 0.2, 1.0],
        [0.0, 1.0, 0.0],
        100.0,
        24,
        24,
    );
    let shapes = vec![Shape {
        name: Some("enclosure".into()),
        geometry: shape,
        material: 0,
        area_light: Some(AreaLight {
            radiance: le,
            two_sided,
            image: None,
        }),
        reverse_orientation: reverse,
        tags: Default::default(),
    }];
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(rho)],
        vec![],
        settings(grid, spp, 1000),
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    (grid, out.radiance)
}

fn check_furnace(name: &str, grid: &WavelengthGrid, img: &camsim_core::SpectralImage) {
    for b in 0..grid.len() {
        let want = band_average(grid, b, |w| {
            let t = (w - 350.0) / 400.0;
            (1.0 + t) / (1.0 - (0.5 + 0.25 * t))
        });
        let (m, se) = band_stats(img, b);
        check(
            &format!("{name} band {} nm", grid.wavelength_nm(b)),
            m,
            se,
            want,
            0.01,
        );
    }
}

#[test]
fn furnace_inside_a_sphere() {
    let (grid, img) = furnace(
        Geometry::Sphere {
            center: [0.1, -0.2, 0.05],
            radius: 1.0,
        },
        true,
        false,
        512,
    );
    check_furnace("sphere furnace", &grid, &img);
}

#[test]
fn furnace_inside_a_one_sided_triangle_box() {
    // One-sided emitters whose normals point into the box: (a) by winding, (b) by
    // ReverseOrientation of an outward-wound box.
    let (grid, img) = furnace(cube(true), false, false, 480);
    check_furnace("box furnace (inward winding)", &grid, &img);
    let (grid, img) = furnace(cube(false), false, true, 480);
    check_furnace("box furnace (reverse orientation)", &grid, &img);
}

#[test]
fn one_sided_emitter_facing_away_gives_no_light() {
    // Outward-wound, one-sided: nothing inside is lit, so the radiance is exactly zero.
    let (_, img) = furnace(cube(false), false, false, 4);
    assert!(
        img.data.iter().all(|v| *v == 0.0),
        "light leaked from the back of one-sided emitters"
    );
}

#[test]
fn white_furnace_convex_sphere_under_uniform_sky() {
    // A convex diffuse object under a uniform infinite light L reflects exactly rho L (every
    // reflected ray escapes to the sky); seen against the sky the background reads L.
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let (rho, l) = (0.7, 2.5);
    let cam = camera(
        [0.0, 0.0, -3.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        8.0,
        16,
        16,
    );
    let shapes = vec![Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }];
    let sc = scene(
        cam.clone(),
        shapes,
        vec![diffuse(flat(rho))],
        vec![Light::Infinite { radiance: flat(l) }],
        settings(grid, 128, 10),
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    let (m, se) = all_band_stats(&out.radiance);
    check("white furnace sphere", m, se, rho * l, 0.01);
    // Background only (sphere out of view).
    let cam2 = camera(
        [0.0, 0.0, -3.0],
        [0.0, 5.0, 0.0],
        [0.0, 0.0, 1.0],
        8.0,
        8,
        8,
    );
    let sc2 = SceneDescription { camera: cam2, ..sc };
    let out = render(&sc2, &|_, _| {}).unwrap();
    let (m, _) = all_band_stats(&out.radiance);
    assert!((m - l).abs() < 1e-4 * l, "sky reads {m}, want {l}");
    assert!(out.depth_m.iter().all(|d| d.is_infinite()));
}

/// Form factor from a differential area to a parallel rectangle a x b at height h whose corner
/// lies above the point (Howell, "A Catalog of Radiation Heat Transfer Configuration Factors",
/// B-3; the formula of issue 4).
fn form_factor_corner(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

#[test]
fn direct_light_under_a_rectangle_corner() {
    let grid = WavelengthGrid::new(420.0, 680.0, 20.0).unwrap();
    let (a, b, h, rho, le) = (1.0, 2.0, 1.0, 0.6, 3.0);
    // Ground plane z = 0 (large), emitter z = h over [0, a] x [0, b], facing down (-z).
    let ground = Geometry::Triangles {
        positions: vec![
            [-20.0, -20.0, 0.0],
            [20.0, -20.0, 0.0],
            [20.0, 20.0, 0.0],
            [-20.0, 20.0, 0.0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let emitter = Geometry::Triangles {
        positions: vec![[0.0, 0.0, h], [a, 0.0, h], [a, b, h], [0.0, b, h]],
        // (p1-p0)x(p2-p0) = +z here; ReverseOrientation turns the emitting side down.
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let shapes = vec![
        Shape {
            name: Some("ground".into()),
            geometry: ground,
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        },
        Shape {
            name: Some("light".into()),
            geometry: emitter,
            material: 1,
            area_light: Some(AreaLight {
                radiance: flat(le),
                two_sided: false,
                image: None,
            }),
            reverse_orientation: true,
            tags: Default::default(),
        },
    ];
    // Camera off to the side (x, y < 0) so its view of the point does not pass the emitter;
    // a 0.05 degree field of view keeps the footprint ~1 mm.
    let cam = camera(
        [-1.0, -1.0, 0.5],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        0.05,
        8,
        8,
    );
    let mut st = settings(grid, 2048, 5);
    st.direct_only = true;
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(flat(rho)), diffuse(flat(0.0))],
        vec![],
        st,
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    let want = rho * le * form_factor_corner(a, b, h);
    let (m, se) = all_band_stats(&out.radiance);
    check(
        "direct light (rectangle corner form factor)",
        m,
        se,
        want,
        0.01,
    );
    // Depth: distance along the optical axis to the point = |from - to| = 1.5 m.
    let d = out.depth_m[4 * 8 + 4];
    assert!((d - 1.5).abs() < 1e-3, "depth {d}");
}

#[test]
fn visible_emitter_reads_its_band_averaged_radiance() {
    // A linear spectrum: its band averages equal its values at the band centres.
    let le = spec(&[350.0, 750.0], &[0.5, 4.0]);
    let grid = WavelengthGrid::new(400.0, 700.0, 50.0).unwrap();
    let shapes = vec![Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [0.0, 0.0, 5.0],
            radius: 1.0,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: le.clone(),
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }];
    let cam = camera([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 5.0, 16, 16);
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(flat(0.0))],
        vec![],
        settings(grid, 1024, 5),
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    for b in 0..grid.len() {
        let (m, se) = band_stats(&out.radiance, b);
        check(
            &format!("emitter band {} nm", grid.wavelength_nm(b)),
            m,
            se,
            le.eval(grid.wavelength_nm(b)),
            0.01,
        );
    }
    // ISETCam's 31-band grid: the mean over bands equals the mean of Le over the grid.
    let grid = WavelengthGrid::default();
    let sc = SceneDescription {
        settings: settings(grid, 256, 5),
        ..sc
    };
    let out = render(&sc, &|_, _| {}).unwrap();
    let (m, se) = all_band_stats(&out.radiance);
    let want = (0..grid.len())
        .map(|b| le.eval(grid.wavelength_nm(b)))
        .sum::<f64>()
        / grid.len() as f64;
    check("emitter all bands", m, se, want, 0.005);
}

#[test]
fn radiance_of_a_white_surface_does_not_depend_on_viewing_distance() {
    // White Lambertian plane z = 0 lit by a spherical emitter of radius r at height d above the
    // viewed point: E = pi Le (r/d)^2, so L = rho Le (r/d)^2 from any distance.
    let grid = WavelengthGrid::new(450.0, 650.0, 50.0).unwrap();
    let (rho, le, r, d) = (0.9, 5.0, 0.5, 10.0);
    let plane = Geometry::Triangles {
        positions: vec![
            [-50.0, -50.0, 0.0],
            [50.0, -50.0, 0.0],
            [50.0, 50.0, 0.0],
            [-50.0, 50.0, 0.0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let shapes = vec![
        Shape {
            name: None,
            geometry: plane,
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        },
        Shape {
            name: None,
            geometry: Geometry::Sphere {
                center: [0.0, 0.0, d],
                radius: r,
            },
            material: 1,
            area_light: Some(AreaLight {
                radiance: flat(le),
                two_sided: false,
                image: None,
            }),
            reverse_orientation: false,
            tags: Default::default(),
        },
    ];
    let want = rho * le * (r / d) * (r / d);
    let mut means = vec![];
    for dist in [1.0, 3.0] {
        let from = [0.0, -dist * 0.6, dist * 0.8];
        let cam = camera(from, [0.0; 3], [0.0, 0.0, 1.0], 1.0, 8, 8);
        let sc = scene(
            cam,
            shapes.clone(),
            vec![diffuse(flat(rho)), diffuse(flat(0.0))],
            vec![],
            settings(grid, 256, 1),
        );
        let out = render(&sc, &|_, _| {}).unwrap();
        let (m, se) = all_band_stats(&out.radiance);
        check(
            &format!("white plane seen from {dist} m"),
            m,
            se,
            want,
            0.01,
        );
        means.push((m, se));
    }
    let (a, b) = (means[0], means[1]);
    assert!(
        (a.0 - b.0).abs() < 4.5 * (a.1 * a.1 + b.1 * b.1).sqrt(),
        "radiance changed with distance: {a:?} vs {b:?}"
    );
}

#[test]
fn same_seed_is_bit_identical_for_one_and_two_threads() {
    let (grid, _) = (WavelengthGrid::default(), ());
    let cam = camera(
        [0.0, 0.0, 0.0],
        [0.3, 0.2, 1.0],
        [0.0, 1.0, 0.0],
        90.0,
        40,
        24,
    );
    let shapes = vec![
        Shape {
            name: None,
            geometry: cube(true),
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        },
        Shape {
            name: None,
            geometry: Geometry::Sphere {
                center: [0.0, 0.7, 0.3],
                radius: 0.2,
            },
            material: 1,
            area_light: Some(AreaLight {
                radiance: flat(10.0),
                two_sided: false,
                image: None,
            }),
            reverse_orientation: false,
            tags: Default::default(),
        },
    ];
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(flat(0.6)), diffuse(flat(0.2))],
        vec![],
        settings(grid, 12, 6),
    );
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(&sc, &|_, _| {}).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert!(a
        .radiance
        .data
        .iter()
        .zip(&b.radiance.data)
        .all(|(x, y)| x.to_bits() == y.to_bits()));
    assert!(a
        .variance
        .iter()
        .zip(&b.variance)
        .all(|(x, y)| x.to_bits() == y.to_bits()));
    assert_eq!(a.depth_m, b.depth_m);
    // The comparison means something: inside the closed box every pixel sees a wall within the
    // cube's diagonal (depth along the axis <= 2 sqrt(3) m), and every pixel got light (each
    // wall sees the emitter).
    let (w, h) = (40, 24);
    assert!(
        a.depth_m
            .iter()
            .all(|d| *d > 0.0 && *d <= 2.0 * 3f32.sqrt()),
        "a pixel escaped the closed box"
    );
    let nb = a.radiance.bands();
    for p in 0..w * h {
        let sum: f32 = (0..nb).map(|b| a.radiance.band(b)[p]).sum();
        assert!(
            sum > 0.0 && sum.is_finite(),
            "pixel {p}: radiance summed over bands {sum}"
        );
    }
    assert_eq!(a.samples_per_pixel, vec![12; w * h]);
    // One camera ray per sample plus one depth ray per pixel.
    assert_eq!(a.stats.camera_rays, (w * h * (12 + 1)) as u64);
    assert_eq!(
        a.stats,
        RenderStats {
            seconds: a.stats.seconds,
            samples_per_second: a.stats.samples_per_second,
            rays_per_second: a.stats.rays_per_second,
            ..b.stats
        }
    );
    // A different seed gives a different image.
    let mut sc2 = sc.clone();
    sc2.settings.seed = 8;
    let c = render(&sc2, &|_, _| {}).unwrap();
    assert_ne!(a.radiance.data, c.radiance.data);
}

#[test]
fn bad_scenes_are_errors_not_panics() {
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let cam = camera([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 40.0, 4, 4);
    let sphere = Shape {
        name: Some("s".into()),
        geometry: Geometry::Sphere {
            center: [0.0, 0.0, 3.0],
            radius: 1.0,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    };
    let empty = scene(cam.clone(), vec![], vec![], vec![], settings(grid, 1, 1));
    assert!(matches!(
        render(&empty, &|_, _| {}),
        Err(RenderError::EmptyScene)
    ));
    let dark = scene(
        cam.clone(),
        vec![sphere.clone()],
        vec![diffuse(flat(0.5))],
        vec![],
        settings(grid, 1, 1),
    );
    assert!(matches!(
        render(&dark, &|_, _| {}),
        Err(RenderError::NoLights)
    ));
    let sky = vec![Light::Infinite {
        radiance: flat(1.0),
    }];
    let bad_mat = scene(
        cam.clone(),
        vec![Shape {
            material: 3,
            ..sphere.clone()
        }],
        vec![diffuse(flat(0.5))],
        sky.clone(),
        settings(grid, 1, 1),
    );
    let e = render(&bad_mat, &|_, _| {}).unwrap_err();
    assert!(e.to_string().contains("material index 3"), "{e}");
    let mut bad_cam = cam.clone();
    bad_cam.fov_deg = 0.0;
    let s = scene(
        bad_cam,
        vec![sphere.clone()],
        vec![diffuse(flat(0.5))],
        sky.clone(),
        settings(grid, 1, 1),
    );
    assert!(matches!(
        render(&s, &|_, _| {}),
        Err(RenderError::Camera(_))
    ));
    let degenerate = camera_from_focal_length(
        4.38e-3,
        5.6e-3,
        4.2e-3,
        [0.0; 3],
        [0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        4,
        4,
    );
    let s = scene(
        degenerate,
        vec![sphere.clone()],
        vec![diffuse(flat(0.5))],
        sky.clone(),
        settings(grid, 1, 1),
    );
    assert!(matches!(
        render(&s, &|_, _| {}),
        Err(RenderError::Camera(_))
    ));
    let tri = Shape {
        name: Some("mesh".into()),
        geometry: Geometry::Triangles {
            positions: vec![[0.0; 3]; 3],
            indices: vec![[0, 1, 5]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        ..sphere.clone()
    };
    let e = render(
        &scene(
            cam.clone(),
            vec![tri],
            vec![diffuse(flat(0.5))],
            sky.clone(),
            settings(grid, 1, 1),
        ),
        &|_, _| {},
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("mesh") && e.to_string().contains("vertex 5"),
        "{e}"
    );
    let mut st = settings(grid, 1, 1);
    st.wavelengths_per_path = 5;
    assert!(matches!(
        render(
            &scene(cam, vec![sphere], vec![diffuse(flat(0.5))], sky, st),
            &|_, _| {}
        ),
        Err(RenderError::Settings(_))
    ));
}

#[test]
fn time_budget_stops_between_passes_and_reports_samples() {
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let cam = camera([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 40.0, 8, 8);
    let sphere = Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [0.0, 0.0, 3.0],
            radius: 1.0,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    };
    let mut st = settings(grid, 1_000_000, 3);
    st.time_budget_s = Some(1e-9);
    let sc = scene(
        cam,
        vec![sphere],
        vec![diffuse(flat(0.5))],
        vec![Light::Infinite {
            radiance: flat(1.0),
        }],
        st,
    );
    let calls = std::sync::atomic::AtomicU64::new(0);
    let out = render(&sc, &|_, _| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    // One pass only (the budget is checked after each pass), one progress call per tile.
    assert_eq!(out.samples_per_pixel[0], render::SAMPLES_PER_PASS);
    assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 1);
    // Deterministic for a given number of passes: equals a render asked for that many samples.
    let mut sc2 = sc.clone();
    sc2.settings.time_budget_s = None;
    sc2.settings.samples_per_pixel = render::SAMPLES_PER_PASS;
    let out2 = render(&sc2, &|_, _| {}).unwrap();
    assert_eq!(out.radiance.data, out2.radiance.data);
    // Statistics of the samples actually taken: 8 x 8 pixels, one camera ray per sample plus one
    // depth ray per pixel; throughputs are counts over the reported time.
    let pixels = 64u64;
    let spp = render::SAMPLES_PER_PASS as u64;
    assert_eq!(out.stats.camera_rays, pixels * (spp + 1));
    assert_eq!(
        (
            out.stats.camera_rays,
            out.stats.bounce_rays,
            out.stats.shadow_rays
        ),
        (
            out2.stats.camera_rays,
            out2.stats.bounce_rays,
            out2.stats.shadow_rays
        )
    );
    let rays = (out.stats.camera_rays + out.stats.bounce_rays + out.stats.shadow_rays) as f64;
    assert!((out.stats.rays_per_second * out.stats.seconds / rays - 1.0).abs() < 1e-9);
    assert!(
        (out.stats.samples_per_second * out.stats.seconds / (pixels * spp) as f64 - 1.0).abs()
            < 1e-9
    );
}

#[test]
fn image_texture_is_looked_up_by_uv() {
    // A flat quad under a uniform sky L reflects rho(uv) L. The 8 x 1 texture is grey 0.2 in its
    // left half and 0.8 in its right half (greys uplift to constant spectra); bilinear filtering
    // gives the pure values for s in [1/16, 7/16] and [9/16, 15/16].
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let l_sky = 1.5;
    let rgb: Vec<[f32; 3]> = (0..8)
        .map(|i| if i < 4 { [0.2; 3] } else { [0.8; 3] })
        .collect();
    let tex = Texture::Image {
        width: 8,
        height: 1,
        rgb: rgb.into(),
        uscale: 1.0,
        vscale: 1.0,
        udelta: 0.0,
        vdelta: 0.0,
        kind: MappingKind::Uv,
        wrap: Default::default(),
        filter: Default::default(),
    };
    let quad = Geometry::Triangles {
        positions: vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    for (x, rho) in [(-0.5, 0.2), (0.5, 0.8)] {
        let cam = camera([x, 0.0, 2.0], [x, 0.0, 0.0], [0.0, 1.0, 0.0], 5.0, 8, 8);
        let shapes = vec![Shape {
            name: None,
            geometry: quad.clone(),
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        }];
        let sc = scene(
            cam,
            shapes,
            vec![Material::Diffuse {
                reflectance: tex.clone(),
            }],
            vec![Light::Infinite {
                radiance: flat(l_sky),
            }],
            settings(grid, 256, 3),
        );
        let out = render(&sc, &|_, _| {}).unwrap();
        let (m, se) = all_band_stats(&out.radiance);
        check(
            &format!("image texture at x = {x}"),
            m,
            se,
            rho * l_sky,
            0.01,
        );
    }
}

/// A large diffuse plane `z = z0` (facing +z) centred under `(cx, cy)`.
fn floor_plane(cx: f64, cy: f64, z0: f64, half: f64) -> Geometry {
    Geometry::Triangles {
        positions: vec![
            [cx - half, cy - half, z0],
            [cx + half, cy - half, z0],
            [cx + half, cy + half, z0],
            [cx - half, cy + half, z0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    }
}

/// Direct irradiance from a uniform Lambertian sphere light of radius R and radiance L at a point
/// a distance d >= R from its centre, on a surface whose normal points at the centre:
/// E = pi L (R/d)^2 (the sphere subtends a cone of half-angle asin(R/d); the cosine-weighted
/// solid angle of that cone is pi sin^2; e.g. Howell's catalogue, configuration B-43).
/// The receiver is the plane z = z0 under the sphere's centre, seen at 10 degrees elevation so
/// the view passes under the sphere (the gap's view angle is atan(sqrt(2 (d - R)/R)) > 17 degrees
/// for d >= 1.05 R). Box-sized coordinates (the ceiling of the Cornell box is at 0.55 m), where
/// the spawn offsets are the renderer's real ones.
#[test]
fn irradiance_from_a_sphere_light_close_up() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    let (rho, le, r) = (0.8, 4.0, 0.06);
    let (cx, cy, z0) = (0.278, 0.28, 0.5488);
    for d_over_r in [1.05, 1.2, 2.0, 5.0] {
        let d = d_over_r * r;
        let shapes = vec![
            Shape {
                name: Some("receiver".into()),
                geometry: floor_plane(cx, cy, z0, 5.0),
                material: 0,
                area_light: None,
                reverse_orientation: false,
                tags: Default::default(),
            },
            Shape {
                name: Some("sphere light".into()),
                geometry: Geometry::Sphere {
                    center: [cx, cy, z0 + d],
                    radius: r,
                },
                material: 1,
                area_light: Some(AreaLight {
                    radiance: flat(le),
                    two_sided: false,
                    image: None,
                }),
                reverse_orientation: false,
                tags: Default::default(),
            },
        ];
        let el = 10f64.to_radians();
        let from = [cx - 0.5 * el.cos(), cy, z0 + 0.5 * el.sin()];
        let cam = camera(from, [cx, cy, z0], [0.0, 0.0, 1.0], 0.02, 8, 8);
        let mut st = settings(grid, 1024, 1);
        st.direct_only = true;
        let sc = scene(
            cam,
            shapes,
            vec![diffuse(flat(rho)), diffuse(flat(0.0))],
            vec![],
            st,
        );
        let out = render(&sc, &|_, _| {}).unwrap();
        // L_out = rho / pi * E = rho L (R/d)^2.
        let want = rho * le / (d_over_r * d_over_r);
        let (m, se) = all_band_stats(&out.radiance);
        check(
            &format!("sphere light, receiver at {d_over_r} radii"),
            m,
            se,
            want,
            0.01,
        );
    }
}

/// Irradiance at `p` (surface normal `n`) from a uniform Lambertian polygon of radiance `l`:
/// E = (L/2) |sum_i gamma_i n . (R_i x R_{i+1}) / |R_i x R_{i+1}||, with R_i the vectors from `p`
/// to the vertices and gamma_i the angle between R_i and R_{i+1} (Lambert 1760; the contour
/// integral of the point-to-polygon form factor, e.g. Howell's catalogue or Baum et al. 1989).
fn polygon_irradiance(p: [f64; 3], n: [f64; 3], verts: &[[f64; 3]], l: f64) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let mut s = 0.0;
    for i in 0..verts.len() {
        let (a, b) = (sub(verts[i], p), sub(verts[(i + 1) % verts.len()], p));
        let c = cross(a, b);
        let cl = dot(c, c).sqrt();
        let gamma = (dot(a, b) / (dot(a, a).sqrt() * dot(b, b).sqrt()))
            .clamp(-1.0, 1.0)
            .acos();
        s += gamma * dot(n, c) / cl;
    }
    0.5 * l * s.abs()
}

#[test]
fn polygon_irradiance_helper_matches_the_corner_form_factor() {
    // Guard for the helper: under the corner of an a x b rectangle at height h, E = pi L F.
    let (a, b, h, l) = (1.0, 2.0, 1.0, 3.0);
    let e = polygon_irradiance(
        [0.0; 3],
        [0.0, 0.0, 1.0],
        &[[0.0, 0.0, h], [a, 0.0, h], [a, b, h], [0.0, b, h]],
        l,
    );
    let want = std::f64::consts::PI * l * form_factor_corner(a, b, h);
    assert!((e / want - 1.0).abs() < 1e-12, "{e} vs {want}");
}

/// Direct light on a large floor from a square light 0.25 m wide, 0.55 m up (the Cornell box's
/// light height), from right under it out to 10 light widths, where the light is seen at
/// 12 degrees above the horizon: the polygon form factor in closed form.
#[test]
fn irradiance_from_a_quad_light_out_to_grazing_angles() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    let (rho, le, a, h) = (0.7, 5.0, 0.25, 0.55);
    let light_verts = [
        [-a / 2.0, -a / 2.0, h],
        [a / 2.0, -a / 2.0, h],
        [a / 2.0, a / 2.0, h],
        [-a / 2.0, a / 2.0, h],
    ];
    let light = Geometry::Triangles {
        positions: light_verts.to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let shapes = vec![
        Shape {
            name: Some("floor".into()),
            geometry: floor_plane(0.0, 0.0, 0.0, 20.0),
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        },
        // (p1-p0)x(p2-p0) = +z; ReverseOrientation turns the emitting side down.
        Shape {
            name: Some("light".into()),
            geometry: light,
            material: 1,
            area_light: Some(AreaLight {
                radiance: flat(le),
                two_sided: false,
                image: None,
            }),
            reverse_orientation: true,
            tags: Default::default(),
        },
    ];
    for x in [0.0, 0.5, 1.0, 1.5, 2.0, 2.5] {
        // The camera looks from beyond the point, below the light's plane, so it never sees the light.
        let cam = camera(
            [x + 0.8, 0.3, 0.5],
            [x, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            0.05,
            8,
            8,
        );
        let mut st = settings(grid, 512, 1);
        st.direct_only = true;
        let sc = scene(
            cam,
            shapes.clone(),
            vec![diffuse(flat(rho)), diffuse(flat(0.0))],
            vec![],
            st,
        );
        let out = render(&sc, &|_, _| {}).unwrap();
        let want = rho / std::f64::consts::PI
            * polygon_irradiance([x, 0.0, 0.0], [0.0, 0.0, 1.0], &light_verts, le);
        let (m, se) = all_band_stats(&out.radiance);
        check(
            &format!("quad light, floor point {x} m out"),
            m,
            se,
            want,
            0.01,
        );
    }
}

/// A spectrum given on 400-700 nm is zero outside that range (pbrt-v4
/// `PiecewiseLinearSpectrum`): on the 31-band grid the 400 nm band (395-405 nm) and the 700 nm
/// band (695-705 nm) hold data over half their width, so an emitter of constant radiance L there
/// reads L/2 in those bands and L in the bands between.
#[test]
fn spectrum_ends_at_its_last_sample() {
    let grid = WavelengthGrid::default();
    let le = 2.0;
    let shapes = vec![Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [0.0, 0.0, 5.0],
            radius: 1.0,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: spec(&[400.0, 700.0], &[le, le]),
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }];
    let cam = camera([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 5.0, 32, 32);
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(flat(0.0))],
        vec![],
        settings(grid, 1024, 0),
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    let last = grid.len() - 1;
    for (b, want) in [
        (0, le / 2.0),
        (1, le),
        (15, le),
        (last - 1, le),
        (last, le / 2.0),
    ] {
        let (m, se) = band_stats(&out.radiance, b);
        check(
            &format!("band {} nm of a 400-700 nm spectrum", grid.wavelength_nm(b)),
            m,
            se,
            want,
            0.03,
        );
    }
}
