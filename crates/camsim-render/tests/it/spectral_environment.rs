//! Environment maps whose texels are coefficients of a spectral basis (`EnvironmentMap::basis`,
//! the CIE daylight basis S0, S1, S2 of `camsim_scene3d::daylight`): the spectral sky of
//! `camsim-compose`. Closed forms: a uniform environment of radiance L(lambda) gives an upward
//! plane the irradiance E = pi L, so a Lambertian plane of reflectance rho has radiance
//! rho E / pi = rho L at every wavelength; and camera rays that escape see each texel's
//! spectrum, whose chromaticity is the one its coefficients were solved for.

use camsim_core::{colorimetry, Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;
use std::sync::Arc;

use crate::common;
use common::floor;

fn settings(grid: WavelengthGrid, spp: u32) -> RenderSettings {
    RenderSettings {
        grid,
        samples_per_pixel: spp,
        max_depth: 1,
        seed: 3,
        ..RenderSettings::default()
    }
}

fn scene(
    camera: Camera,
    shapes: Vec<Shape>,
    rho: f64,
    map: EnvironmentMap,
    grid: WavelengthGrid,
    spp: u32,
) -> SceneDescription {
    SceneDescription {
        camera,
        shapes,
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(common::grey(rho)),
        }],
        named_materials: HashMap::new(),
        lights: vec![Light::Environment(map)],
        settings: settings(grid, spp),
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: vec![],
    }
}

fn camera(from: [f64; 3], to: [f64; 3], up: [f64; 3], fov_deg: f64) -> Camera {
    Camera {
        camera_to_world: look_at_camera_to_world(from, to, up, true).unwrap(),
        fov_deg,
        width: 8,
        height: 8,
        lens: None,
    }
}

/// A lat-long daylight-basis map: `upper` coefficients above the horizon, `lower` below.
fn basis_map(upper: [f32; 3], lower: [f32; 3]) -> EnvironmentMap {
    let (w, h) = (32, 16);
    EnvironmentMap {
        width: w,
        height: h,
        rgb: (0..w * h)
            .map(|i| if i / w < h / 2 { upper } else { lower })
            .collect(),
        mapping: EnvMapping::LatLong,
        illuminant: Spectrum::from_pairs(&[(300.0, 1.0), (830.0, 1.0)]),
        basis: Some(Arc::new(daylight::basis().clone())),
        light_to_world: Transform::identity(),
    }
}

/// Mean over the pixels of each band.
fn band_means(img: &camsim_core::SpectralImage) -> Vec<f64> {
    (0..img.bands())
        .map(|b| img.band(b).iter().map(|v| *v as f64).sum::<f64>() / img.pixels() as f64)
        .collect()
}

/// The basis spectrum `c0 S0 + c1 S1 + c2 S2` averaged over each band of `grid` (1 nm steps).
fn basis_band_means(c: [f32; 3], grid: &WavelengthGrid) -> Vec<f64> {
    let b = daylight::basis();
    (0..grid.len())
        .map(|i| {
            let lo = grid.wavelength_nm(i) - grid.step_nm / 2.0;
            let n = grid.step_nm as usize;
            (0..n)
                .map(|k| {
                    let l = lo + k as f64 + 0.5;
                    (c[0] as f64 * b[0].eval(l)
                        + c[1] as f64 * b[1].eval(l)
                        + c[2] as f64 * b[2].eval(l))
                    .max(0.0)
                })
                .sum::<f64>()
                / n as f64
        })
        .collect()
}

/// A white-ish Lambertian floor (rho 0.5) under a uniform basis environment (the D65-like
/// coefficients with negative M1) has radiance rho L(lambda) in every 20 nm band: E = pi L.
/// The lower hemisphere is black, so nothing reaches the floor from below.
#[test]
fn uniform_basis_environment_gives_a_lambertian_plane_rho_l() {
    let c = [0.01f32, -0.003, -0.0007];
    let grid = WavelengthGrid::new(400.0, 700.0, 20.0).unwrap();
    let rho = 0.5;
    let cam = camera([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 20.0);
    let out = render(
        &scene(
            cam,
            vec![floor(0.2)],
            rho,
            basis_map(c, [0.0; 3]),
            grid,
            256,
        ),
        &|_, _| {},
    )
    .unwrap();
    let got = band_means(&out.radiance);
    let want = basis_band_means(c, &grid);
    for (b, (g, w)) in got.iter().zip(&want).enumerate() {
        let err = (g - rho * w) / (rho * w);
        eprintln!(
            "band {} nm: floor {g:.5e}, rho L {:.5e}, rel. error {:+.3} %",
            grid.wavelength_nm(b),
            rho * w,
            100.0 * err
        );
        assert!(err.abs() < 0.015, "band {b}: {g} vs {}", rho * w);
    }
}

/// Camera rays that escape into a basis map see the texel's spectrum: the chromaticity of the
/// rendered spectrum (5 nm bands, CIE 1931) is the one the coefficients were solved for by
/// `daylight::m1_m2`, within 0.005, looking up (a bluish sky, x 0.27) and down (a warm ground,
/// x 0.36). A broken basis evaluation (a coefficient dropped, the RGB uplift used instead)
/// moves the chromaticity by far more.
#[test]
fn rendered_basis_spectrum_has_the_solved_chromaticity() {
    let up_xy = [0.27, 0.285];
    let down_xy = [0.36, 0.365];
    let coeffs = |xy: [f64; 2], k: f64| {
        let m = daylight::m1_m2(xy[0], xy[1]).unwrap();
        [k as f32, (k * m[0]) as f32, (k * m[1]) as f32]
    };
    let map = basis_map(coeffs(up_xy, 0.01), coeffs(down_xy, 0.004));
    let grid = WavelengthGrid::new(380.0, 780.0, 5.0).unwrap();
    for (to, up, want) in [
        ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], up_xy),
        ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0], down_xy),
    ] {
        let cam = camera([0.0; 3], to, up, 30.0);
        let out = render(&scene(cam, vec![], 0.5, map.clone(), grid, 64), &|_, _| {}).unwrap();
        let spectrum = band_means(&out.radiance);
        let xy = colorimetry::chromaticity_xy(colorimetry::xyz(&spectrum, &grid));
        eprintln!(
            "looking at {to:?}: rendered xy ({:.4}, {:.4}), solved for ({:.4}, {:.4})",
            xy[0], xy[1], want[0], want[1]
        );
        assert!((xy[0] - want[0]).abs() < 0.005 && (xy[1] - want[1]).abs() < 0.005);
    }
}

/// End to end: the spectral sky of `camsim-compose` (Preetham, Shirley and Smits 1999 through
/// the CIE daylight basis) rendered. Camera rays into a narrow (2 degree) field at the zenith
/// and at 60 degrees from it, away from the sun, return spectra whose CIE 1931 chromaticity is
/// the model's x, y there within 0.005 and whose luminance is the model's within 2 %.
#[test]
fn rendered_preetham_sky_has_the_models_chromaticity() {
    use camsim_compose::environment::{apply, Draw, EnvironmentKind, EnvironmentSpec, PreethamSky};
    let spec = EnvironmentSpec {
        kind: EnvironmentKind::Sky,
        sun_elevation_deg: Draw::Fixed(40.0),
        sun_azimuth_deg: Draw::Fixed(0.0),
        turbidity: Draw::Fixed(3.0),
        up: [0.0, 0.0, 1.0],
        ..EnvironmentSpec::default()
    };
    let grid = WavelengthGrid::new(380.0, 780.0, 5.0).unwrap();
    let model = PreethamSky::new(3.0, 50f64.to_radians());
    let cam0 = camera([0.0; 3], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], 2.0);
    let mut sc = scene(cam0, vec![], 0.5, basis_map([0.0; 3], [0.0; 3]), grid, 32);
    sc.lights.clear();
    let rec = apply(&mut sc, &spec, 0, std::path::Path::new(".")).unwrap();
    // The sun (reference axis world +x): view directions at theta 60 deg, azimuth 180 deg.
    let away = [-(60f64.to_radians().sin()), 0.0, 60f64.to_radians().cos()];
    let sun = rec.sun_direction.unwrap();
    let gamma = (away[0] * sun[0] + away[1] * sun[1] + away[2] * sun[2]).acos();
    for (to, up, want) in [
        (
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            model.xyy(0.0, 50f64.to_radians()),
        ),
        (away, [0.0, 0.0, 1.0], model.xyy(60f64.to_radians(), gamma)),
    ] {
        sc.camera = camera([0.0; 3], to, up, 2.0);
        let out = render(&sc, &|_, _| {}).unwrap();
        let spectrum = band_means(&out.radiance);
        let xyz = colorimetry::xyz(&spectrum, &grid);
        let xy = colorimetry::chromaticity_xy(xyz);
        let lum = camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * xyz[1];
        eprintln!(
            "sky toward {to:?}: rendered xy ({:.4}, {:.4}), {lum:.0} cd/m^2; model ({:.4}, {:.4}), {:.0} cd/m^2",
            xy[0], xy[1], want[1], want[2], want[0]
        );
        assert!((xy[0] - want[1]).abs() < 0.005 && (xy[1] - want[2]).abs() < 0.005);
        assert!((lum / want[0] - 1.0).abs() < 0.02);
    }
}
