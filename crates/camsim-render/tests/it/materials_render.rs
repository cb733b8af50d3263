//! The path tracer with the pbrt-v4 materials, against closed forms: closed lossless objects in a
//! uniform radiance field read exactly that radiance (glass, with and without dispersion; a white
//! diffuse transmitter; a perfect mirror), a `mix` reflects the amount-weighted albedo, and an
//! index-1 dielectric or an `interface` sphere leaves the image unchanged.

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

fn diffuse(v: f64) -> Material {
    Material::Diffuse {
        reflectance: Texture::Constant(flat(v)),
    }
}

fn sphere(center: [f64; 3], radius: f64, material: usize) -> Shape {
    Shape {
        name: None,
        geometry: Geometry::Sphere { center, radius },
        material,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// Mean over the given pixels (all bands) with its standard error over pixels.
fn stats(img: &camsim_core::SpectralImage, pixels: &[usize], band: Option<usize>) -> (f64, f64) {
    let nb = img.bands();
    let v: Vec<f64> = pixels
        .iter()
        .map(|&p| match band {
            Some(b) => img.band(b)[p] as f64,
            None => (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64,
        })
        .collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
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

/// A sphere of material 0 (the others are for `mix`) filling the whole view (it subtends
/// 14.5 degrees, the image corners are 11.3 degrees off axis) under a uniform sky of radiance
/// `sky`; returns the image and its pixels.
fn sphere_under_sky(
    materials: Vec<Material>,
    sky: Spectrum,
    grid: WavelengthGrid,
    spp: u32,
    max_depth: u32,
) -> (camsim_core::SpectralImage, Vec<usize>) {
    let cam = camera(
        [0.0, 0.0, -4.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        16.0,
        16,
        16,
    );
    let sc = scene(
        cam,
        vec![sphere([0.0; 3], 1.0, 0)],
        materials,
        vec![Light::Infinite { radiance: sky }],
        settings(grid, spp, max_depth),
    );
    let out = render(&sc, &|_, _| {}).unwrap();
    let on: Vec<usize> = (0..out.depth_m.len())
        .filter(|&i| out.depth_m[i].is_finite())
        .collect();
    assert_eq!(on.len(), out.depth_m.len(), "the sphere must fill the view");
    (out.radiance, on)
}

#[test]
fn glass_sphere_under_uniform_sky_reads_the_sky_radiance() {
    // A closed lossless dielectric in a uniform radiance field L: radiance is L everywhere
    // outside (n^2 L inside; Veach 1997 §5.2 radiance scaling at refraction). Every path that
    // leaves the sphere carries weight exactly 1, so only paths cut by max_depth lose energy.
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let l = 1.7;
    for (name, rough) in [
        ("smooth", Roughness::SMOOTH),
        (
            "rough (alpha 0.3)",
            Roughness {
                u: 0.09,
                v: 0.09,
                remap: true,
            },
        ),
    ] {
        let m = Material::Dielectric {
            eta: flat(1.5),
            roughness: rough,
        };
        let (img, on) = sphere_under_sky(vec![m], flat(l), grid, 64, 100);
        let (mean, se) = stats(&img, &on, None);
        if rough == Roughness::SMOOTH {
            // Smooth: every path that escapes has weight 1, so pixels differ only by the rare
            // path cut at max_depth.
            check(
                &format!("{name} glass sphere"),
                mean,
                se.max(1e-5 * l),
                l,
                0.005,
            );
        } else {
            // Rough: the single-scattering microfacet model loses some energy (Heitz et al.
            // 2016); never creates it.
            eprintln!("{name} glass sphere: {mean:.4} +- {se:.4} (sky {l})");
            // Measured: 0.74 L (the interface alone keeps 0.76-0.98 of the energy per crossing,
            // see bsdf_physics), so the bound below is loose; the upper bound is the test.
            assert!(
                mean < l * (1.0 + 1e-3) + 4.5 * se && mean > 0.6 * l,
                "{name}: {mean} vs sky {l}"
            );
        }
    }
}

#[test]
fn dispersive_glass_keeps_the_sky_spectrum() {
    // BK7 (dispersive: paths keep only their hero wavelength, weighted by N) in a spectrally
    // varying uniform field: each band still reads the sky's band average.
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let sky = spec(&[350.0, 750.0], &[1.0, 3.0]);
    let eta = camsim_pbrt::optical_constants::named("glass-BK7").unwrap();
    let (img, on) = sphere_under_sky(
        vec![Material::Dielectric {
            eta,
            roughness: Roughness::SMOOTH,
        }],
        sky.clone(),
        grid,
        2048,
        100,
    );
    for b in 0..grid.len() {
        let lam = grid.wavelength_nm(b);
        // Band average of a linear spectrum: its value at the band centre.
        let want = sky.eval(lam);
        let (m, se) = stats(&img, &on, Some(b));
        check(&format!("BK7 sphere, band {lam} nm"), m, se, want, 0.015);
    }
}

#[test]
fn white_diffuse_transmitter_and_perfect_mirror_under_uniform_sky() {
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let l = 0.8;
    // R + T = 1, Lambertian both ways: a closed lossless scatterer, radiance L everywhere.
    let dt = Material::DiffuseTransmission {
        reflectance: Texture::Constant(flat(0.4)),
        transmittance: Texture::Constant(flat(0.6)),
        scale: 1.0,
    };
    let (img, on) = sphere_under_sky(vec![dt], flat(l), grid, 128, 200);
    let (m, se) = stats(&img, &on, None);
    check("white diffuse transmitter sphere", m, se, l, 0.01);
    // Perfect conductor (Fresnel = 1): a mirror sphere reflects the sky, exactly.
    let mirror = Material::Conductor {
        optics: ConductorOptics::EtaK {
            eta: flat(0.0),
            k: flat(1e4),
        },
        roughness: Roughness::SMOOTH,
    };
    let (img, on) = sphere_under_sky(vec![mirror], flat(l), grid, 4, 5);
    for &p in &on {
        for b in 0..img.bands() {
            let v = img.band(b)[p] as f64;
            assert!(
                (v - l).abs() < 2e-3 * l,
                "mirror pixel {p} band {b}: {v} vs {l}"
            );
        }
    }
}

#[test]
fn conductor_from_reflectance_reflects_it_at_normal_incidence() {
    // pbrt-v4 maps a conductor's `reflectance` r to eta = 1, k = 2 sqrt(r) / sqrt(1 - r), whose
    // normal-incidence Fresnel reflectance ((eta-1)^2 + k^2) / ((eta+1)^2 + k^2) is r exactly.
    // The central 2 x 2 pixels of the mirror sphere filling the view (each pixel 1 degree) see
    // the sky reflected at incidence angles below 5.7 degrees (sin = 4 sin 1.41 deg), where the
    // Fresnel reflectance of this conductor departs from r by less than 0.1 %.
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let (l, r) = (1.5, 0.6);
    let m = Material::Conductor {
        optics: ConductorOptics::Reflectance(Texture::Constant(flat(r))),
        roughness: Roughness::SMOOTH,
    };
    let (img, _) = sphere_under_sky(vec![m], flat(l), grid, 1, 5);
    for p in [7 * 16 + 7, 7 * 16 + 8, 8 * 16 + 7, 8 * 16 + 8] {
        for b in 0..img.bands() {
            let v = img.band(b)[p] as f64;
            assert!(
                (v - r * l).abs() < 2e-3 * r * l,
                "pixel {p} band {b}: {v} vs r L = {}",
                r * l
            );
        }
    }
}

#[test]
fn mix_reflects_the_amount_weighted_albedo() {
    // Convex diffuse sphere under a uniform sky: L_out = rho L. A mix picking rho = 0.8 with
    // probability 0.25 and rho = 0.2 otherwise reads (0.25 * 0.8 + 0.75 * 0.2) L = 0.35 L.
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let l = 2.0;
    let mats = vec![
        Material::Mix {
            materials: [1, 2],
            amount: 0.25,
        },
        diffuse(0.2),
        diffuse(0.8),
    ];
    let (img, on) = sphere_under_sky(mats, flat(l), grid, 512, 10);
    let (m, se) = stats(&img, &on, None);
    check("mix of two diffuse albedos", m, se, 0.35 * l, 0.01);
}

/// A diffuse floor lit by a uniform sky and a small area light, seen through where a sphere of
/// material 2 may float; returns (image with sphere, image without, pixels covered by it).
fn floor_with_and_without_sphere(
    m: Material,
) -> (
    camsim_core::SpectralImage,
    camsim_core::SpectralImage,
    Vec<usize>,
) {
    let grid = WavelengthGrid::new(400.0, 700.0, 150.0).unwrap();
    let floor = Geometry::Triangles {
        positions: vec![
            [-5.0, 0.0, -5.0],
            [5.0, 0.0, -5.0],
            [5.0, 0.0, 5.0],
            [-5.0, 0.0, 5.0],
        ],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let lamp = Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [1.0, 3.0, 0.0],
            radius: 0.5,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: flat(5.0),
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    };
    let cam = camera(
        [0.0, 2.0, -4.0],
        [0.0, 0.4, 0.0],
        [0.0, 1.0, 0.0],
        20.0,
        24,
        24,
    );
    let base = vec![
        Shape {
            name: None,
            geometry: floor,
            material: 0,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        },
        lamp,
    ];
    let mut with = base.clone();
    with.push(sphere([0.0, 0.6, 0.0], 0.5, 1));
    let mats = vec![diffuse(0.5), m];
    let sky = vec![Light::Infinite {
        radiance: flat(0.3),
    }];
    let a = render(
        &scene(
            cam.clone(),
            with,
            mats.clone(),
            sky.clone(),
            settings(grid, 1024, 12),
        ),
        &|_, _| {},
    )
    .unwrap();
    let b = render(
        &scene(cam, base, mats, sky, settings(grid, 1024, 12)),
        &|_, _| {},
    )
    .unwrap();
    let covered: Vec<usize> = (0..a.depth_m.len())
        .filter(|&i| (a.depth_m[i] - b.depth_m[i]).abs() > 1e-3)
        .collect();
    assert!(
        covered.len() > 20,
        "the sphere covers only {} pixels",
        covered.len()
    );
    (a.radiance, b.radiance, covered)
}

fn assert_invisible(name: &str, m: Material) {
    let (a, b, covered) = floor_with_and_without_sphere(m);
    // Pixel-wise differences over the covered pixels: independent estimates with mean 0.
    let nb = a.bands();
    let d: Vec<f64> = covered
        .iter()
        .map(|&p| {
            (0..nb)
                .map(|k| (a.band(k)[p] - b.band(k)[p]) as f64)
                .sum::<f64>()
                / nb as f64
        })
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let se = (d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0) / n).sqrt();
    let (ref_mean, _) = stats(&b, &covered, None);
    eprintln!(
        "{name}: mean difference {mean:.5} +- {se:.5} over {} pixels (mean radiance {ref_mean:.4})",
        covered.len()
    );
    assert!(
        se < 0.01 * ref_mean,
        "{name}: too noisy to test ({se} vs {ref_mean})"
    );
    // Plus f32 rounding (1e-6 of the radiance): an interface sphere leaves every path the same
    // up to the rounding of its ray origins, so its differences are rounding, not noise, and
    // their standard error can be smaller than their mean (5e-9 +- 5e-10 on a mean of 0.19).
    assert!(
        mean.abs() <= 4.5 * se + 1e-6 * ref_mean,
        "{name}: the sphere changes the image by {mean} (+- {se})"
    );
    assert!(
        mean.abs() < 0.02 * ref_mean,
        "{name}: the sphere changes the image by {:.2} %",
        mean / ref_mean * 100.0
    );
}

#[test]
fn index_one_dielectric_sphere_is_invisible() {
    assert_invisible(
        "eta = 1 dielectric sphere",
        Material::Dielectric {
            eta: flat(1.0),
            roughness: Roughness::SMOOTH,
        },
    );
}

#[test]
fn interface_sphere_is_invisible() {
    assert_invisible("interface sphere", Material::Interface);
    // Stronger: the paths are the same (an interface consumes no random numbers and lets
    // shadow rays through), so the images agree pixel by pixel up to float rounding. Passing
    // the interface moves the ray sideways by the spawn offset (microns), so now and then one
    // path of the ~10^5 through the sphere lands on the other side of a discontinuity (the
    // lamp's edge) and changes its pixel by up to ~1e-3 (seen with the Sobol sampler in one
    // pixel for 3 of 5 seeds; all other pixels agree to 2e-6): allow two such pixels, within 1 %.
    let (a, b, covered) = floor_with_and_without_sphere(Material::Interface);
    let nb = a.bands();
    let mut diverged = vec![];
    for &p in &covered {
        for k in 0..nb {
            let (x, y) = (a.band(k)[p], b.band(k)[p]);
            let rel = (x - y).abs() / y.abs().max(1e-3);
            assert!(rel <= 1e-2, "pixel {p} band {k}: {x} vs {y}");
            if rel > 1e-5 && !diverged.contains(&p) {
                diverged.push(p);
            }
        }
    }
    assert!(
        diverged.len() <= 2,
        "pixels {diverged:?} differ by more than float rounding"
    );
}

/// A strongly dispersive glass sphere in front of a wall split into a short-wave and a
/// long-wave emitting half, rendered with `wavelengths` per path and `seed`.
fn dispersive_scene(wavelengths: usize, seed: u64) -> camsim_core::SpectralImage {
    let grid = WavelengthGrid::new(420.0, 680.0, 40.0).unwrap();
    let quad = |x0: f64, x1: f64| Geometry::Triangles {
        positions: vec![
            [x0, -3.0, 3.0],
            [x1, -3.0, 3.0],
            [x1, 3.0, 3.0],
            [x0, 3.0, 3.0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let emitter = |geometry: Geometry, radiance: Spectrum| Shape {
        name: None,
        geometry,
        material: 0,
        area_light: Some(AreaLight {
            radiance,
            two_sided: true,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    };
    let blue = spec(&[400.0, 540.0, 541.0, 700.0], &[1.0, 1.0, 0.0, 0.0]);
    let red = spec(&[400.0, 540.0, 541.0, 700.0], &[0.0, 0.0, 1.0, 1.0]);
    // Artificial strong dispersion: eta from 1.9 (400 nm) to 1.3 (700 nm).
    let eta = spec(&[400.0, 700.0], &[1.9, 1.3]);
    let shapes = vec![
        emitter(quad(-3.0, 0.0), blue),
        emitter(quad(0.0, 3.0), red),
        sphere([0.0, 0.0, 0.0], 1.0, 1),
    ];
    let mats = vec![
        diffuse(0.0),
        Material::Dielectric {
            eta,
            roughness: Roughness::SMOOTH,
        },
    ];
    let cam = camera(
        [0.0, 0.0, -4.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        16.0,
        24,
        24,
    );
    let mut st = settings(grid, 256, 20);
    st.wavelengths_per_path = wavelengths;
    st.seed = seed;
    render(&scene(cam, shapes, mats, vec![], st), &|_, _| {})
        .unwrap()
        .radiance
}

#[test]
fn dispersion_with_hero_wavelength_equals_one_wavelength_per_path() {
    // Four wavelengths per path, secondaries terminated at the dispersive sphere (pbrt-v4
    // `TerminateSecondary`), must converge to the same per-pixel spectra as one wavelength per
    // path (no sharing at all). Were the secondaries to follow the hero's refracted path, the
    // pixels near the image of the blue/red boundary would get the wrong colours.
    // Statistic: S_ab = sum (a - b)^2 over pixels and bands against the noise measured by
    // repeating each render with another seed, S_noise = sum [(a - a')^2 + (b - b')^2] / 2;
    // E[S_ab] = E[S_noise] without bias.
    let (a, a2) = (dispersive_scene(4, 1), dispersive_scene(4, 2));
    let (b, b2) = (dispersive_scene(1, 3), dispersive_scene(1, 4));
    let sq = |x: &camsim_core::SpectralImage, y: &camsim_core::SpectralImage| -> f64 {
        x.data
            .iter()
            .zip(&y.data)
            .map(|(p, q)| ((p - q) as f64).powi(2))
            .sum()
    };
    let s_ab = sq(&a, &b);
    let s_noise = (sq(&a, &a2) + sq(&b, &b2)) / 2.0;
    let n = a.data.len() as f64;
    eprintln!(
        "dispersion: S_ab {s_ab:.4}, S_noise {s_noise:.4}, ratio {:.3} over {n} values",
        s_ab / s_noise
    );
    assert!(s_noise > 0.0);
    // The ratio of two sums of ~n squared noise terms: within a few times sqrt(2/n).
    assert!(
        s_ab / s_noise < 1.0 + 6.0 * (2.0 / n).sqrt(),
        "4-wavelength paths disagree with 1-wavelength paths: {s_ab} vs noise {s_noise}"
    );
}

#[test]
fn materials_render_bit_identically_for_one_and_two_threads() {
    // Mix decisions hash the hit, dispersion terminates by material: nothing depends on the
    // thread that runs a tile.
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| dispersive_scene(4, 9))
    };
    let (a, b) = (run(1), run(2));
    assert!(
        a.data
            .iter()
            .zip(&b.data)
            .all(|(x, y)| x.to_bits() == y.to_bits()),
        "renders differ between 1 and 2 threads"
    );
    let grid = WavelengthGrid::new(400.0, 700.0, 100.0).unwrap();
    let mix = || {
        let glass = Material::Dielectric {
            eta: flat(1.5),
            roughness: Roughness {
                u: 0.1,
                v: 0.1,
                remap: true,
            },
        };
        vec![
            Material::Mix {
                materials: [1, 2],
                amount: 0.4,
            },
            glass,
            diffuse(0.5),
        ]
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| sphere_under_sky(mix(), flat(1.0), grid, 8, 10).0)
    };
    let (a, b) = (run(1), run(2));
    assert!(
        a.data
            .iter()
            .zip(&b.data)
            .all(|(x, y)| x.to_bits() == y.to_bits()),
        "mix renders differ between 1 and 2 threads"
    );
}
