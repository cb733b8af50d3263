//! The samplers and Russian roulette (issue 12): the Sobol sampler's points are stratified
//! (the (0,2)-sequence property, kept by Owen scrambling), a Sobol render is bit-identical for
//! any thread count, both samplers converge to closed forms and the Sobol one with less error
//! at equal sample count, and Russian roulette from any starting depth keeps a truncated
//! furnace at its closed form while it shortens the paths.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::sampler::{dim, SobolSampler};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![300.0, 900.0], vec![v, v], "flat").unwrap()
}

fn camera(from: [f64; 3], to: [f64; 3], fov_deg: f64, w: usize, h: usize) -> Camera {
    Camera {
        camera_to_world: look_at_camera_to_world(from, to, [0.0, 1.0, 0.0], true).unwrap(),
        fov_deg,
        width: w,
        height: h,
        lens: None,
    }
}

fn settings(spp: u32, max_depth: u32, sampler: SamplerKind) -> RenderSettings {
    RenderSettings {
        grid: WavelengthGrid::new(400.0, 700.0, 100.0).unwrap(),
        samples_per_pixel: spp,
        max_depth,
        seed: 3,
        sampler,
        ..RenderSettings::default()
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

/// Per pixel: the radiance averaged over bands, W/(sr m^2 nm).
fn pixel_means(img: &camsim_core::SpectralImage) -> Vec<f64> {
    let nb = img.bands();
    (0..img.pixels())
        .map(|p| (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64)
        .collect()
}

/// Mean over pixels and its standard error from the scatter of the (independent) pixels.
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Root mean square of the pixels' error against `want`.
fn rmse(v: &[f64], want: f64) -> f64 {
    (v.iter().map(|x| (x - want) * (x - want)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Whether the first `n = 2^k` points hit every elementary interval of shape
/// `2^a x 2^(k-a)` exactly once, for every `a` in `0..=k` (the (0,k,2)-net property).
fn is_02_net(points: &[[f32; 2]]) -> Result<(), String> {
    let n = points.len();
    let k = n.trailing_zeros();
    assert!(n.is_power_of_two());
    for a in 0..=k {
        let (nx, ny) = (1usize << a, 1usize << (k - a));
        let mut hits = vec![0u32; n];
        for p in points {
            assert!(
                (0.0..1.0).contains(&p[0]) && (0.0..1.0).contains(&p[1]),
                "point {p:?} outside [0, 1)^2"
            );
            let (i, j) = (
                (p[0] as f64 * nx as f64) as usize,
                (p[1] as f64 * ny as f64) as usize,
            );
            hits[j * nx + i] += 1;
        }
        if let Some(c) = hits.iter().position(|h| *h != 1) {
            return Err(format!(
                "{n} points, {nx} x {ny} cells: cell {c} hit {} times",
                hits[c]
            ));
        }
    }
    Ok(())
}

#[test]
fn sobol_film_samples_of_a_pixel_stratify_every_power_of_two_prefix() {
    for (seed, x, y) in [(0u64, 0u32, 0u32), (3, 17, 5), (12345, 255, 255)] {
        let mut s = SobolSampler::new(seed, x, y);
        let pts: Vec<[f32; 2]> = (0..4096u64)
            .map(|i| {
                s.set_sample(i);
                s.sample_2d(dim::FILM)
            })
            .collect();
        for k in 0..=12u32 {
            let n = 1usize << k;
            // Every 2^(k/2) x 2^(k/2) grid cell once for even k, and every elementary interval.
            is_02_net(&pts[..n]).unwrap_or_else(|e| panic!("pixel ({x}, {y}) seed {seed}: {e}"));
            // Each later aligned block of 2^k points is a net too (progressive stratification).
            if k <= 10 {
                is_02_net(&pts[n..2 * n])
                    .unwrap_or_else(|e| panic!("pixel ({x}, {y}), second block: {e}"));
            }
        }
    }
}

#[test]
fn sobol_stratifies_every_bounce_dimension_and_past_the_sequence_length() {
    let mut s = SobolSampler::new(9, 3, 4);
    let n = 256u64;
    for depth in [1u32, 2, 7, 40] {
        let d0 = dim::bounce(depth);
        for d in [d0 + dim::LIGHT_POSITION, d0 + dim::BSDF_DIRECTION] {
            let pts: Vec<[f32; 2]> = (0..n)
                .map(|i| {
                    s.set_sample(i);
                    s.sample_2d(d)
                })
                .collect();
            is_02_net(&pts).unwrap_or_else(|e| panic!("depth {depth} dimension {d}: {e}"));
        }
        for d in [
            d0 + dim::LIGHT_CHOICE,
            d0 + dim::BSDF_LOBE,
            d0 + dim::RUSSIAN_ROULETTE,
        ] {
            let mut hits = vec![0u32; n as usize];
            for i in 0..n {
                s.set_sample(i);
                hits[(s.sample_1d(d) * n as f32) as usize] += 1;
            }
            assert!(
                hits.iter().all(|h| *h == 1),
                "depth {depth} 1D dimension {d} not stratified"
            );
        }
    }
    // Sample indices past the 2^16 of one scrambled sequence start a new, still stratified one.
    let pts: Vec<[f32; 2]> = (0..n)
        .map(|i| {
            s.set_sample((1 << 16) + i);
            s.sample_2d(dim::FILM)
        })
        .collect();
    is_02_net(&pts).unwrap();
    let first: Vec<[f32; 2]> = (0..n)
        .map(|i| {
            s.set_sample(i);
            s.sample_2d(dim::FILM)
        })
        .collect();
    assert_ne!(
        pts, first,
        "the second block of 2^16 samples repeats the first"
    );
}

#[test]
fn sobol_dimensions_and_pixels_are_decorrelated() {
    // Padding by hashing: two dimensions of one pixel, or one dimension of two pixels, must be
    // independent; sample correlation of n uniform pairs has standard deviation 1/sqrt(n).
    let n = 4096u64;
    let corr = |a: &[f64], b: &[f64]| {
        let (ma, mb) = (
            a.iter().sum::<f64>() / n as f64,
            b.iter().sum::<f64>() / n as f64,
        );
        let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
        let va: f64 = a.iter().map(|x| (x - ma) * (x - ma)).sum();
        let vb: f64 = b.iter().map(|y| (y - mb) * (y - mb)).sum();
        cov / (va * vb).sqrt()
    };
    let draw = |seed: u64, x: u32, d: u32| -> Vec<f64> {
        let mut s = SobolSampler::new(seed, x, 0);
        (0..n)
            .map(|i| {
                s.set_sample(i);
                s.sample_1d(d) as f64
            })
            .collect()
    };
    let film_x = draw(1, 0, dim::FILM);
    let limit = 5.0 / (n as f64).sqrt();
    for (what, other) in [
        ("wavelength", draw(1, 0, dim::WAVELENGTH)),
        (
            "first light choice",
            draw(1, 0, dim::bounce(1) + dim::LIGHT_CHOICE),
        ),
        (
            "second bounce direction",
            draw(1, 0, dim::bounce(2) + dim::BSDF_DIRECTION),
        ),
        ("the neighbouring pixel", draw(1, 1, dim::FILM)),
        ("another seed", draw(2, 0, dim::FILM)),
    ] {
        let r = corr(&film_x, &other);
        assert!(
            r.abs() < limit,
            "film x and {what}: correlation {r:.4} (limit {limit:.4})"
        );
        assert_ne!(film_x, other, "film x and {what} are the same sequence");
    }
}

#[test]
fn sobol_render_is_bit_identical_for_one_and_two_threads() {
    // The built-in Cornell box (diffuse interreflection, area light, depth 8): 11 samples per
    // pixel run as a pass of 8 and one of 3, on 16-pixel tiles that do not divide the 24-pixel image.
    let opts = builtin::BuiltinOptions {
        resolution: Some((24, 24)),
        samples_per_pixel: 11,
        seed: 5,
        ..Default::default()
    };
    let mut sc = builtin::scene("cornell-box", &opts).unwrap();
    assert_eq!(
        sc.settings.sampler,
        SamplerKind::Sobol,
        "Sobol is the default sampler"
    );
    sc.settings.grid = WavelengthGrid::new(400.0, 700.0, 50.0).unwrap();
    let run = |sc: &SceneDescription, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(sc, &|_, _| {}).unwrap())
    };
    let (a, b) = (run(&sc, 1), run(&sc, 2));
    let same = |x: &RenderOutput, y: &RenderOutput| {
        x.radiance
            .data
            .iter()
            .zip(&y.radiance.data)
            .all(|(p, q)| p.to_bits() == q.to_bits())
            && x.variance
                .iter()
                .zip(&y.variance)
                .all(|(p, q)| p.to_bits() == q.to_bits())
    };
    assert!(same(&a, &b), "Sobol render differs between 1 and 2 threads");
    assert_eq!(
        (a.stats.bounce_rays, a.stats.shadow_rays),
        (b.stats.bounce_rays, b.stats.shadow_rays)
    );
    // Most of the image is lit (the frame's edge sees past the open box), so the comparison
    // means something.
    let lit = pixel_means(&a.radiance)
        .iter()
        .filter(|v| **v > 0.0 && v.is_finite())
        .count();
    assert!(
        lit > 24 * 24 * 3 / 4,
        "only {lit} of {} pixels lit",
        24 * 24
    );
    // The independent sampler is still selectable, deterministic, and a different estimator.
    sc.settings.sampler = SamplerKind::Independent;
    let (c, d) = (run(&sc, 1), run(&sc, 2));
    assert!(
        same(&c, &d),
        "independent render differs between 1 and 2 threads"
    );
    assert_ne!(a.radiance.data, c.radiance.data);
}

/// A diffuse plane (reflectance `rho`) facing the camera under a uniform sky of radiance `l`
/// reflects exactly `rho l` (every reflected direction escapes to the sky).
fn plane_under_sky(spp: u32, sampler: SamplerKind, seed: u64) -> Vec<f64> {
    let (rho, l) = (0.6, 2.0);
    let h = 10.0;
    let quad = Geometry::Triangles {
        positions: vec![[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: None,
        normals: None,
        colors: None,
        uvs1: None,
        tangents: None,
    };
    let shapes = vec![Shape {
        name: None,
        geometry: quad,
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }];
    let mut st = settings(spp, 3, sampler);
    st.seed = seed;
    let cam = camera([0.3, 0.2, -3.0], [0.0, 0.0, 0.0], 40.0, 32, 32);
    let sc = scene(
        cam,
        shapes,
        vec![diffuse(rho)],
        vec![Light::Infinite { radiance: flat(l) }],
        st,
    );
    pixel_means(&render(&sc, &|_, _| {}).unwrap().radiance)
}

#[test]
fn sobol_converges_to_the_closed_form_with_less_error_than_independent() {
    let want = 0.6 * 2.0;
    let mut rm = HashMap::new();
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        for spp in [16u32, 64] {
            let v = plane_under_sky(spp, sampler, 11);
            let (m, se) = mean_se(&v);
            let e = rmse(&v, want);
            eprintln!("{} {spp} spp: mean {m:.5} (want {want}), standard error {se:.2e}, pixel RMSE {:.3} %", sampler.name(), e / want * 100.0);
            // Unbiased: the mean of 1024 independent pixels within 4.5 standard errors.
            assert!(
                (m - want).abs() < 4.5 * se + 1e-6,
                "{} {spp} spp: mean {m} vs {want} (se {se})",
                sampler.name()
            );
            rm.insert((sampler.name(), spp), e);
        }
    }
    // Monte Carlo error falls as N^-1/2: 4x the samples halves it (allow scatter of the RMSE
    // over 1024 pixels); stratified Sobol points fall at least as fast.
    let ratio = |s: &str| rm[&(s, 16)] / rm[&(s, 64)];
    assert!(
        (1.7..2.4).contains(&ratio("independent")),
        "independent: RMSE ratio 16/64 spp {:.2}",
        ratio("independent")
    );
    assert!(
        ratio("sobol") > 1.7,
        "sobol: RMSE ratio 16/64 spp {:.2}",
        ratio("sobol")
    );
    for spp in [16, 64] {
        let (i, s) = (rm[&("independent", spp)], rm[&("sobol", spp)]);
        assert!(
            s < 0.8 * i,
            "{spp} spp: Sobol RMSE {s:.3e} is not below 0.8 x the independent {i:.3e}"
        );
    }
}

/// Furnace inside a diffuse sphere that emits `le` and reflects `rho` everywhere, paths cut at
/// `max_depth` bounces: L = le sum_{d=0}^{max_depth} rho^d (emission after d reflections).
fn truncated_furnace(rr_depth: u32, sampler: SamplerKind) -> (Vec<f64>, RenderStats) {
    let (le, rho) = (1.0, 0.8);
    let shapes = vec![Shape {
        name: None,
        geometry: Geometry::Sphere {
            center: [0.0, 0.1, 0.0],
            radius: 1.0,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: flat(le),
            two_sided: true,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }];
    let mut st = settings(128, 9, sampler);
    st.russian_roulette_depth = rr_depth;
    let cam = camera([0.0, 0.0, 0.0], [0.2, 0.1, 1.0], 90.0, 24, 24);
    let out = render(
        &scene(cam, shapes, vec![diffuse(rho)], vec![], st),
        &|_, _| {},
    )
    .unwrap();
    (pixel_means(&out.radiance), out.stats)
}

#[test]
fn russian_roulette_at_any_depth_keeps_a_truncated_furnace_exact() {
    let want: f64 = (0..=9).map(|d| 0.8f64.powi(d)).sum();
    let mut bounces = vec![];
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        for rr in [1u32, 2, 5, u32::MAX] {
            let (v, stats) = truncated_furnace(rr, sampler);
            let (m, se) = mean_se(&v);
            eprintln!(
                "{} RR from depth {rr}: mean {m:.5} (want {want:.5}), standard error {se:.2e}, {} bounce rays",
                sampler.name(),
                stats.bounce_rays
            );
            assert!(
                se / want < 0.004,
                "standard error {se} too large for the test"
            );
            // Besides the statistics, a 3e-4 relative allowance: without roulette the estimate
            // is nearly noise-free and sits 1e-4 below the closed form (f32 arithmetic).
            assert!(
                (m - want).abs() < 4.5 * se + 3e-4 * want && (m - want).abs() < 0.01 * want,
                "{} RR {rr}: {m} vs {want}",
                sampler.name()
            );
            if sampler == SamplerKind::Sobol {
                bounces.push(stats.bounce_rays);
            }
        }
    }
    // Roulette ends paths: the earlier it starts the fewer bounces; without it every path runs
    // all 9 bounces in the closed sphere (24 x 24 pixels x 128 samples x 9).
    assert_eq!(bounces[3], 24 * 24 * 128 * 9);
    assert!(
        bounces[0] < bounces[1] && bounces[1] < bounces[2] && bounces[2] < bounces[3],
        "bounce rays {bounces:?}"
    );
}
