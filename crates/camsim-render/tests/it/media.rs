//! Participating media (issue 27, pbrt-v4 4th ed. ch. 11 and sec. 14.1) against closed forms:
//! Beer-Lambert transmittance through an absorbing slab at several optical depths and
//! wavelengths (homogeneous, grid and RGB-grid media, and a camera inside a medium), single
//! scattering from a slab lit by a distant light, a white furnace filled with a non-absorbing
//! medium, the emission of an absorbing, emitting slab, the Henyey-Greenstein phase function's
//! normalisation and sampling (chi-square), and that a medium nothing selects changes no bit.
//!
//! Statistical checks: |error| below 4.5 standard errors of the image mean, where the standard
//! error comes from the scatter of the per-pixel estimates, plus a relative bound.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::math::V3;
use camsim_render::phase::{hg_p, hg_sample};
use camsim_render::*;
use camsim_scene3d::media::{
    Coefficients, GridMedium, GridSize, Media, Medium, MediumBox, MediumKind, RgbGridMedium,
};
use camsim_scene3d::*;
use std::collections::HashMap;

fn pairs(p: &[(f64, f64)]) -> Spectrum {
    Spectrum::from_pairs(p)
}

fn flat(v: f64) -> Spectrum {
    pairs(&[(300.0, v), (900.0, v)])
}

/// A spectrum linear in wavelength: `v400` at 400 nm, `v700` at 700 nm.
fn ramp(v400: f64, v700: f64) -> Spectrum {
    let at = |l: f64| v400 + (v700 - v400) * (l - 400.0) / 300.0;
    pairs(&[(300.0, at(300.0).max(0.0)), (900.0, at(900.0))])
}

/// A camera at `from` looking at `to` with a narrow field (every ray within 0.35 degrees of
/// the axis), `n x n` pixels.
fn narrow_camera(from: [f64; 3], to: [f64; 3], n: usize) -> Camera {
    Camera {
        camera_to_world: look_at_camera_to_world(from, to, [0.0, 1.0, 0.0], true).unwrap(),
        fov_deg: 0.5,
        width: n,
        height: n,
        lens: None,
    }
}

/// The axis-aligned box `[lo, hi]` as 12 triangles wound so that their normals point out.
fn cuboid(name: &str, lo: [f64; 3], hi: [f64; 3], material: usize) -> Shape {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let positions: Vec<[f64; 3]> = (0..8).map(c).collect();
    // Each face counter-clockwise seen from outside.
    let faces = [
        [0, 2, 3, 1], // z = lo
        [4, 5, 7, 6], // z = hi
        [0, 1, 5, 4], // y = lo
        [2, 6, 7, 3], // y = hi
        [0, 4, 6, 2], // x = lo
        [1, 3, 7, 5], // x = hi
    ];
    let indices = faces
        .iter()
        .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    Shape {
        name: Some(name.into()),
        geometry: Geometry::mesh(positions, indices, None, None),
        material,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// The square `[-s, s]^2` in the plane z = `z`, facing +z, emitting `le` (material 0).
fn emitter(s: f64, z: f64, le: Spectrum) -> Shape {
    Shape {
        name: Some("emitter".into()),
        geometry: Geometry::Triangles {
            positions: vec![[-s, -s, z], [s, -s, z], [s, s, z], [-s, s, z]],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: le,
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// Materials: 0 black diffuse, 1 `interface`, 2 the boundary of medium 0 (inside) with
/// vacuum outside.
fn materials() -> Vec<Material> {
    vec![
        Material::Diffuse {
            reflectance: Texture::Constant(flat(0.0)),
        },
        Material::Interface,
        Material::MediumInterface {
            material: 1,
            inside: Some(0),
            outside: None,
        },
    ]
}

fn homogeneous(sigma_a: Spectrum, sigma_s: Spectrum, le: Option<Spectrum>, g: f64) -> Medium {
    Medium {
        name: "test".into(),
        g,
        kind: MediumKind::Homogeneous(Coefficients {
            sigma_a_per_m: sigma_a,
            sigma_s_per_m: sigma_s,
            le,
        }),
    }
}

fn scene(
    camera: Camera,
    shapes: Vec<Shape>,
    lights: Vec<Light>,
    media: Media,
    spp: u32,
    max_depth: u32,
) -> SceneDescription {
    SceneDescription {
        camera,
        shapes,
        materials: materials(),
        named_materials: HashMap::new(),
        lights,
        settings: RenderSettings {
            grid: WavelengthGrid::default(),
            samples_per_pixel: spp,
            max_depth,
            seed: 11,
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: vec![],
        media,
        light_groups: Vec::new(),
    }
}

/// Mean and standard error over pixels of the mean of bands `bands`.
fn stats(img: &camsim_core::SpectralImage, bands: std::ops::Range<usize>) -> (f64, f64) {
    let nb = bands.len() as f64;
    let px: Vec<f64> = (0..img.pixels())
        .map(|p| bands.clone().map(|b| img.band(b)[p] as f64).sum::<f64>() / nb)
        .collect();
    let n = px.len() as f64;
    let m = px.iter().sum::<f64>() / n;
    let var = px.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// `got` (standard error `se`) agrees with `want`: within 4.5 standard errors and `rel`.
fn agrees(what: &str, got: f64, se: f64, want: f64, rel: f64) {
    eprintln!(
        "{what}: {got:.6e} vs closed form {want:.6e} ({:+.2} %, {:.1} standard errors; s.e. {:.2} %)",
        (got / want - 1.0) * 100.0,
        (got - want) / se,
        se / want * 100.0
    );
    assert!(
        se < rel * want,
        "{what}: standard error too large for the test"
    );
    assert!(
        (got - want).abs() < 4.5 * se && (got - want).abs() < rel * want,
        "{what}: {got} vs {want} (standard error {se})"
    );
}

/// The average of `f` over the band of `grid` index `b` (midpoint rule, 200 steps).
fn band_mean(grid: &WavelengthGrid, b: usize, f: impl Fn(f64) -> f64) -> f64 {
    let lo = grid.wavelength_nm(b) - grid.step_nm / 2.0;
    (0..200)
        .map(|i| f(lo + (i as f64 + 0.5) * grid.step_nm / 200.0))
        .sum::<f64>()
        / 200.0
}

/// Beer-Lambert (4th ed. eq. 11.6): a camera looks through an absorbing slab of thickness `d`
/// at an emitter of radiance `L0`: `L(lambda) = L0 exp(-sigma_a(lambda) d)`. sigma_a varies
/// 3:1 over the spectrum, so the bands see different optical depths and the spectral MIS
/// (distances sampled at one wavelength, carried to the others by ratios) is checked band by
/// band; optical depths at 550 nm 0.25, 1 and 3.
#[test]
fn beer_lambert_through_an_absorbing_slab() {
    let grid = WavelengthGrid::default();
    let l0 = 2.0;
    for tau550 in [0.25, 1.0, 3.0] {
        let d = 0.5;
        // sigma_a(550 nm) = tau550 / d; 0.5x at 400 nm, 1.5x at 700 nm.
        let s550 = tau550 / d;
        let sigma_a = ramp(0.5 * s550, 1.5 * s550);
        let media = Media {
            list: vec![homogeneous(sigma_a.clone(), flat(0.0), None, 0.0)],
            camera: None,
        };
        let sc = scene(
            narrow_camera([0.0, 0.0, 5.0], [0.0; 3], 24),
            vec![
                emitter(20.0, -1.0, flat(l0)),
                cuboid("slab", [-10.0, -10.0, 0.0], [10.0, 10.0, d], 2),
            ],
            vec![],
            media,
            64,
            5,
        );
        let img = render(&sc, &|_, _| {}).unwrap().radiance;
        let want = |b: usize| band_mean(&grid, b, |l| l0 * (-sigma_a.eval(l) * d).exp());
        for (what, bands) in [
            ("400-450 nm", 0..6),
            ("520-580 nm", 12..19),
            ("650-700 nm", 25..31),
        ] {
            let w = bands.clone().map(want).sum::<f64>() / bands.len() as f64;
            let (m, se) = stats(&img, bands);
            agrees(&format!("tau(550) {tau550}, {what}"), m, se, w, 0.05);
        }
    }
}

/// The camera itself inside an absorbing medium (the `[render] medium` case): the emitter at
/// distance D reads `L0 exp(-sigma_a D)`; surfaces without a boundary keep the medium.
#[test]
fn camera_inside_a_medium_sees_beer_lambert() {
    let grid = WavelengthGrid::default();
    let (l0, sigma, dist) = (1.5, 0.4, 3.0);
    let mut media = Media::default();
    media.fill(homogeneous(flat(sigma), flat(0.0), None, 0.0));
    let sc = scene(
        narrow_camera([0.0, 0.0, dist - 1.0], [0.0, 0.0, -1.0], 24),
        vec![emitter(20.0, -1.0, flat(l0))],
        vec![],
        media,
        32,
        5,
    );
    let img = render(&sc, &|_, _| {}).unwrap().radiance;
    let (m, se) = stats(&img, 0..grid.len());
    agrees("camera in medium", m, se, l0 * (-sigma * dist).exp(), 0.03);
}

/// pbrt-v4 `SampledGrid` lookups fall off to zero within half a sample of the box faces, so
/// a constant density `rho` on an `n`-sample axis gives a ray along that axis (far from the
/// other faces) the optical depth `sigma rho (L - h / 4)`, `h = L / n` (two linear ramps from
/// rho / 2 to rho over h / 2). Checked for a `uniformgrid` and for an `rgbgrid` of grey RGB
/// (uplifted as `2m S(rgb / 2m)` = the grey value), both tracked through their 16^3 majorant
/// grids with null collisions near the faces.
#[test]
fn grid_media_transmit_as_their_interpolated_density() {
    let grid = WavelengthGrid::default();
    let (l0, sigma, rho, len, n) = (1.0, 1.2, 0.75, 1.0, 4usize);
    let bounds = MediumBox {
        p0: [-5.0, -5.0, 0.0],
        p1: [5.0, 5.0, len],
        medium_from_world: Transform::identity(),
    };
    let size = GridSize {
        nx: n,
        ny: n,
        nz: n,
    };
    let h = len / n as f64;
    let want = l0 * (-sigma * rho * (len - h / 4.0)).exp();
    let kinds = [
        MediumKind::UniformGrid(Box::new(GridMedium {
            bounds: bounds.clone(),
            size: size.clone(),
            coefficients: Coefficients {
                sigma_a_per_m: flat(sigma),
                sigma_s_per_m: flat(0.0),
                le: None,
            },
            density: vec![rho as f32; n * n * n],
            le_scale: vec![1.0],
            temperature: None,
        })),
        MediumKind::RgbGrid(Box::new(RgbGridMedium {
            bounds,
            size,
            sigma_a: Some(vec![[rho as f32; 3]; n * n * n]),
            sigma_s: Some(vec![[0.0; 3]; n * n * n]),
            sigma_scale_per_m: sigma,
            le: None,
            illuminant: flat(0.0),
        })),
    ];
    for kind in kinds {
        let what = match kind {
            MediumKind::UniformGrid(_) => "uniformgrid",
            _ => "rgbgrid",
        };
        let mut media = Media::default();
        // Filled everywhere: the grid's box bounds it.
        media.fill(Medium {
            name: what.into(),
            g: 0.0,
            kind,
        });
        let sc = scene(
            narrow_camera([0.0, 0.0, 4.0], [0.0; 3], 24),
            vec![emitter(20.0, -1.0, flat(l0))],
            vec![],
            media,
            64,
            5,
        );
        let img = render(&sc, &|_, _| {}).unwrap().radiance;
        let (m, se) = stats(&img, 0..grid.len());
        agrees(what, m, se, want, 0.03);
    }
}

/// Single scattering from a slab (4th ed. sec. 11.1 and 14.1; exact for one scattering
/// event, which `max_depth` 1 keeps alone): a distant light of irradiance E shining straight
/// down on a slab of thickness d, seen at angle theta from the normal (mu = cos theta), gives
/// `L = E p sigma_s / (sigma_t (1 + mu)) (1 - exp(-sigma_t d (1 + mu) / mu))` with `p` the
/// Henyey-Greenstein value between the directions to the camera and to the light. Optically
/// thin (tau 0.1) and thick (tau 1), g = 0.6 and albedo 0.8.
#[test]
fn single_scattering_from_a_slab() {
    let grid = WavelengthGrid::default();
    let (e, g, albedo) = (3.0, 0.6f64, 0.8);
    let theta = 35f64.to_radians();
    let mu = theta.cos();
    for tau in [0.1, 1.0] {
        let d = 0.2;
        let sigma_t = tau / d;
        let media = Media {
            list: vec![homogeneous(
                flat(sigma_t * (1.0 - albedo)),
                flat(sigma_t * albedo),
                None,
                g,
            )],
            camera: None,
        };
        let cam_dir = [0.0, -theta.sin(), mu];
        let sc = scene(
            narrow_camera(cam_dir.map(|v| 6.0 * v), [0.0, 0.0, 0.0], 24),
            vec![cuboid("slab", [-40.0, -40.0, -d], [40.0, 40.0, 0.0], 2)],
            vec![Light::Distant {
                direction: [0.0, 0.0, -1.0],
                irradiance: flat(e),
            }],
            media,
            128,
            1,
        );
        let img = render(&sc, &|_, _| {}).unwrap().radiance;
        let p = hg_p(
            g as f32,
            V3::new(cam_dir[0] as f32, cam_dir[1] as f32, cam_dir[2] as f32),
            V3::new(0.0, 0.0, 1.0),
        ) as f64;
        let want = e * p * albedo / (1.0 + mu) * (1.0 - (-sigma_t * d * (1.0 + mu) / mu).exp());
        let (m, se) = stats(&img, 0..grid.len());
        agrees(&format!("single scattering, tau {tau}"), m, se, want, 0.04);
    }
}

/// A white furnace: a sphere of non-absorbing medium (sigma_s varying 3:1 over the spectrum,
/// g = 0.3) under a uniform sky of radiance L0. Scattering only redistributes light, so every
/// pixel reads L0 in every band (radiance is conserved), however many times a path scatters.
#[test]
fn non_absorbing_medium_in_a_white_furnace_conserves_radiance() {
    let grid = WavelengthGrid::default();
    let l0 = 0.8;
    let media = Media {
        list: vec![homogeneous(flat(0.0), ramp(1.0, 3.0), None, 0.3)],
        camera: None,
    };
    let sphere = Shape {
        name: Some("ball".into()),
        geometry: Geometry::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        },
        material: 2,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    };
    let mut cam = narrow_camera([0.0, 0.0, 4.0], [0.0; 3], 24);
    cam.fov_deg = 20.0;
    let sc = scene(
        cam,
        vec![sphere],
        vec![Light::Infinite { radiance: flat(l0) }],
        media,
        32,
        10_000,
    );
    let img = render(&sc, &|_, _| {}).unwrap().radiance;
    for (what, bands) in [
        ("400-450 nm", 0..6),
        ("650-700 nm", 25..31),
        ("all bands", 0..31),
    ] {
        let (m, se) = stats(&img, bands);
        agrees(&format!("furnace {what}"), m, se, l0, 0.02);
    }
    let _ = grid;
}

/// An absorbing, emitting slab (no scattering) seen through its thickness d: `dL/ds = -sigma_a
/// (L - Le)` gives `L = Le (1 - exp(-sigma_a d))`, which tends to `Le sigma_a d` (Le times the
/// optical path length) when the slab is optically thin. Checked at tau 0.1, 1 and 3; the
/// medium is the scene's only light.
#[test]
fn emissive_slab_radiance_and_its_thin_limit() {
    let grid = WavelengthGrid::default();
    let le = 5.0;
    for tau in [0.1, 1.0, 3.0] {
        let d = 0.3;
        let sigma_a = tau / d;
        let media = Media {
            list: vec![homogeneous(flat(sigma_a), flat(0.0), Some(flat(le)), 0.0)],
            camera: None,
        };
        let sc = scene(
            narrow_camera([0.0, 0.0, 5.0], [0.0; 3], 32),
            vec![cuboid("slab", [-10.0, -10.0, -d], [10.0, 10.0, 0.0], 2)],
            vec![],
            media,
            256,
            5,
        );
        let img = render(&sc, &|_, _| {}).unwrap().radiance;
        let (m, se) = stats(&img, 0..grid.len());
        let want = le * (1.0 - (-tau).exp());
        agrees(&format!("emissive slab, tau {tau}"), m, se, want, 0.03);
        if tau <= 0.1 {
            // Optically thin: Le sigma_a d to first order in tau.
            let thin = le * sigma_a * d;
            assert!(
                ((m - thin) / thin).abs() < tau / 2.0 + 4.5 * se / thin,
                "thin limit: {m} vs Le sigma_a d = {thin}"
            );
        }
    }
}

/// The Henyey-Greenstein phase function integrates to 1 over the sphere, and its sampling
/// (the inverted cumulative distribution in `hg_sample`) produces directions with density
/// `hg_p` and returns that density: a chi-square test over 20 x 8 bins in (cos, azimuth) of the
/// angle to the propagation direction, with the expected counts integrated from `hg_p` alone.
#[test]
fn henyey_greenstein_normalisation_and_sampling_chi_square() {
    let wo = V3::new(0.3, -0.5, 0.81).normalize();
    let fwd = -wo;
    // A frame around the propagation direction for binning.
    let a = if fwd.x.abs() > 0.5 {
        V3::new(0.0, 1.0, 0.0)
    } else {
        V3::new(1.0, 0.0, 0.0)
    };
    let t = a.cross(fwd).normalize();
    let b = fwd.cross(t);
    let dir = |c: f64, phi: f64| {
        let s = (1.0 - c * c).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        (t * (s * cp) as f32) + (b * (s * sp) as f32) + (fwd * c as f32)
    };
    for g in [-0.7f32, 0.0, 0.3, 0.9] {
        // Normalisation: Simpson in cos (4000 intervals); the azimuth is uniform.
        let n_int = 4000;
        let integral = (0..=n_int)
            .map(|i| {
                let c = -1.0 + 2.0 * i as f64 / n_int as f64;
                let w = if i == 0 || i == n_int {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * hg_p(g, wo, dir(c, 0.7)) as f64
            })
            .sum::<f64>()
            * (2.0 / n_int as f64)
            / 3.0
            * 2.0
            * std::f64::consts::PI;
        assert!((integral - 1.0).abs() < 1e-4, "g {g}: integral {integral}");

        let (nc, nphi, samples) = (20usize, 8usize, 200_000usize);
        let mut counts = vec![0f64; nc * nphi];
        let mut rng = camsim_core::rng::seeded(42 + (g * 100.0) as u64);
        use rand::Rng as _;
        for _ in 0..samples {
            let (wi, pdf) = hg_sample(g, wo, rng.gen(), rng.gen());
            assert!(
                (pdf - hg_p(g, wo, wi)).abs() <= 1e-4 * pdf,
                "g {g}: pdf mismatch"
            );
            let c = (wi.dot(fwd) as f64).clamp(-1.0, 1.0);
            let phi = (wi.dot(b) as f64)
                .atan2(wi.dot(t) as f64)
                .rem_euclid(2.0 * std::f64::consts::PI);
            let ic = (((c + 1.0) / 2.0 * nc as f64) as usize).min(nc - 1);
            let ip = ((phi / (2.0 * std::f64::consts::PI) * nphi as f64) as usize).min(nphi - 1);
            counts[ic * nphi + ip] += 1.0;
        }
        let mut chi2 = 0.0;
        for ic in 0..nc {
            // Probability of the cos bin from hg_p (Simpson, 200 intervals), split evenly
            // over the azimuth bins.
            let (c0, c1) = (
                -1.0 + 2.0 * ic as f64 / nc as f64,
                -1.0 + 2.0 * (ic + 1) as f64 / nc as f64,
            );
            let m = 200;
            let p_bin = (0..=m)
                .map(|i| {
                    let c = c0 + (c1 - c0) * i as f64 / m as f64;
                    let w = if i == 0 || i == m {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * hg_p(g, wo, dir(c, 1.3)) as f64
                })
                .sum::<f64>()
                * (c1 - c0)
                / m as f64
                / 3.0
                * 2.0
                * std::f64::consts::PI;
            let expected = p_bin * samples as f64 / nphi as f64;
            assert!(expected > 5.0, "g {g}: bin {ic} expects {expected}");
            for ip in 0..nphi {
                let o = counts[ic * nphi + ip];
                chi2 += (o - expected).powi(2) / expected;
            }
        }
        let dof = (nc * nphi - 1) as f64;
        // p ~ 1e-5 for a chi-square with ~159 degrees of freedom.
        let limit = dof + 6.0 * (2.0 * dof).sqrt();
        eprintln!("g {g}: chi-square {chi2:.1} for {dof} degrees of freedom (limit {limit:.1})");
        assert!(chi2 < limit, "g {g}: chi-square {chi2} > {limit}");
    }
}

/// A medium that is defined but that no camera or shape selects leaves the render bit for bit
/// the path tracer's (the volumetric path tracer runs only where a ray can be in a medium).
#[test]
fn unselected_medium_changes_no_bit() {
    let base = scene(
        narrow_camera([0.0, 0.0, 5.0], [0.0; 3], 8),
        vec![
            emitter(20.0, -1.0, flat(1.0)),
            cuboid("glass", [-1.0, -1.0, 0.0], [1.0, 1.0, 0.5], 1),
        ],
        vec![],
        Media::default(),
        8,
        5,
    );
    let mut base = base;
    base.materials.truncate(2);
    let mut with = base.clone();
    with.media
        .list
        .push(homogeneous(flat(1.0), flat(1.0), None, 0.0));
    let a = render(&base, &|_, _| {}).unwrap().radiance;
    let b = render(&with, &|_, _| {}).unwrap().radiance;
    assert!(
        a.data
            .iter()
            .zip(&b.data)
            .all(|(x, y)| x.to_bits() == y.to_bits()),
        "an unselected medium changed the render"
    );
}
