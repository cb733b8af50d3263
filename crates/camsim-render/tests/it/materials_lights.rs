//! Materials (issue 12, `bsdf`) combined with delta lights (issue 12, `lights`), against closed
//! forms. A point light of intensity `I` gives a surface at distance `r`, seen under `cos` from
//! its normal, the irradiance `E = I cos / r^2`; a Lambertian lobe of albedo `a` returns
//! `a / pi * E`. Delta BSDFs get no light sampling (pbrt-v4 `PathIntegrator`), so a point light
//! reaches the camera through a mirror only via a diffuse vertex after it. Each expected pixel
//! value is the closed form averaged over 8 x 8 sub-positions of the pixel's footprint.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;
use std::f64::consts::PI;

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![300.0, 900.0], vec![v, v], "test").unwrap()
}

fn settings(spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        grid: WavelengthGrid::new(400.0, 700.0, 100.0).unwrap(),
        samples_per_pixel: spp,
        max_depth,
        wavelengths_per_path: 4,
        seed: 7,
        time_budget_s: None,
        direct_only: false,
        ..RenderSettings::default()
    }
}

/// `n` x `n` pixels at height `h_m` above the origin looking straight down.
fn camera_down(h_m: f64, fov_deg: f64, n: usize) -> Camera {
    Camera {
        camera_to_world: look_at_camera_to_world(
            [0.0, 0.0, h_m],
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            true,
        )
        .unwrap(),
        fov_deg,
        width: n,
        height: n,
        lens: None,
    }
}

/// The square `[-s, s]^2` in the plane `z = z_m` with material `material`.
fn plane(s: f64, z_m: f64, material: usize) -> Shape {
    Shape {
        name: None,
        geometry: Geometry::Triangles {
            positions: vec![[-s, -s, z_m], [s, -s, z_m], [s, s, z_m], [-s, s, z_m]],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
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

fn point(z_m: f64, intensity: f64) -> Light {
    Light::Point {
        position_m: [0.0, 0.0, z_m],
        intensity: flat(intensity),
    }
}

/// Per-pixel mean over bands.
fn pixel_means(img: &camsim_core::SpectralImage) -> Vec<f64> {
    let nb = img.bands();
    (0..img.pixels())
        .map(|p| (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64)
        .collect()
}

/// `f(tx, ty)` averaged over each pixel of a down-looking camera, `(tx, ty)` the ray's slope
/// (horizontal offset per unit of descent). Every `f` here is symmetric in the sign of `tx` and
/// `ty`, so the image's orientation does not matter.
fn expected(fov_deg: f64, n: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
    let t = (fov_deg.to_radians() / 2.0).tan();
    let k = 8;
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let mut s = 0.0;
            for b in 0..k {
                for a in 0..k {
                    let tx = (2.0 * (i as f64 + (a as f64 + 0.5) / k as f64) / n as f64 - 1.0) * t;
                    let ty = (2.0 * (j as f64 + (b as f64 + 0.5) / k as f64) / n as f64 - 1.0) * t;
                    s += f(tx, ty);
                }
            }
            out.push(s / (k * k) as f64);
        }
    }
    out
}

/// Worst per-pixel relative error and the relative error of the image mean.
fn compare(what: &str, got: &[f64], want: &[f64]) -> (f64, f64) {
    let worst = got
        .iter()
        .zip(want)
        .map(|(g, w)| ((g - w) / w).abs())
        .fold(0.0, f64::max);
    let (sg, sw): (f64, f64) = (got.iter().sum(), want.iter().sum());
    let mean_err = (sg - sw) / sw;
    eprintln!(
        "{what}: worst pixel {:.3} %, image mean {:+.4} %",
        worst * 100.0,
        mean_err * 100.0
    );
    (worst, mean_err)
}

/// Fresnel reflectance of a conductor `eta + i k` in real arithmetic (Born & Wolf, "Principles
/// of Optics", §14.2; the form of pbrt-v3's `FrConductor`), independent of the renderer's
/// complex-arithmetic `fr_complex`.
fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t2 = 2.0 * cos_i * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    0.5 * (rp + rs)
}

/// A point light over a diffuse floor lights it with `rho / pi * I cos / r^2`; over a smooth
/// conductor floor (a delta BSDF: no light sampling, and a reflected ray never hits a point)
/// the image is exactly black; a diffuse ceiling seen in that mirror reads
/// `R(theta) * rho / pi * I cos / r^2` at the reflected point, with `R` the conductor's Fresnel
/// reflectance at the incidence angle (specular bounce, then light sampling of the delta light
/// at the diffuse vertex). As in pbrt-v4, the light reflected by the mirror onto the ceiling (a
/// light-mirror-diffuse caustic through two delta events) is not reachable by a path tracer and
/// is absent from both the render and the closed form; `max_depth` 2 keeps the diffuse
/// interreflections out of both.
#[test]
fn point_light_with_diffuse_and_mirror_floors() {
    let (rho, i_w_sr_nm, fov_deg, n, h_cam_m) = (0.5, 3.0, 60.0, 32, 1.0);
    let diffuse = Material::Diffuse {
        reflectance: Texture::Constant(flat(rho)),
    };
    // An artificial metal, R about 0.91 at normal incidence, falling off with angle.
    let (eta, k) = (1.2, 7.0);
    let mirror = Material::Conductor {
        optics: ConductorOptics::EtaK {
            eta: flat(eta),
            k: flat(k),
        },
        roughness: Roughness::SMOOTH,
    };

    // 1. Diffuse floor at z = 0, light at z = 0.5 m on the axis.
    let z_light_m = 0.5;
    let out = render(
        &scene(
            camera_down(h_cam_m, fov_deg, n),
            vec![plane(50.0, 0.0, 0)],
            vec![diffuse.clone()],
            vec![point(z_light_m, i_w_sr_nm)],
            settings(1024, 1),
        ),
        &|_, _| {},
    )
    .unwrap();
    let want = expected(fov_deg, n, |tx, ty| {
        let (x, y) = (tx * h_cam_m, ty * h_cam_m);
        let r2 = x * x + y * y + z_light_m * z_light_m;
        rho / PI * i_w_sr_nm * (z_light_m / r2.sqrt()) / r2
    });
    let (worst, mean) = compare("diffuse floor", &pixel_means(&out.radiance), &want);
    assert!(worst < 0.01 && mean.abs() < 5e-4);

    // 2. The same light over the mirror floor alone: nothing reaches the camera.
    let out = render(
        &scene(
            camera_down(h_cam_m, fov_deg, n),
            vec![plane(50.0, 0.0, 0)],
            vec![mirror.clone()],
            vec![point(z_light_m, i_w_sr_nm)],
            settings(16, 5),
        ),
        &|_, _| {},
    )
    .unwrap();
    let lit = (0..out.radiance.bands())
        .flat_map(|b| out.radiance.band(b).iter().copied())
        .filter(|v| *v != 0.0)
        .count();
    assert_eq!(lit, 0, "mirror floor under a point light has lit pixels");

    // 3. Mirror floor at z = 0 and a diffuse ceiling at z = 2 m, light at z = 0.5 m: the
    // camera (z = 1 m) sees the ceiling at horizontal offset slope * (h_cam + z_ceiling).
    let z_ceil_m = 2.0;
    let out = render(
        &scene(
            camera_down(h_cam_m, fov_deg, n),
            vec![plane(50.0, 0.0, 0), plane(50.0, z_ceil_m, 1)],
            vec![mirror, diffuse],
            vec![point(z_light_m, i_w_sr_nm)],
            settings(1024, 2),
        ),
        &|_, _| {},
    )
    .unwrap();
    let want = expected(fov_deg, n, |tx, ty| {
        let cos_i = 1.0 / (1.0 + tx * tx + ty * ty).sqrt();
        let (x, y) = (tx * (h_cam_m + z_ceil_m), ty * (h_cam_m + z_ceil_m));
        let d = z_ceil_m - z_light_m;
        let r2 = x * x + y * y + d * d;
        fresnel_conductor(cos_i, eta, k) * rho / PI * i_w_sr_nm * (d / r2.sqrt()) / r2
    });
    let (worst, mean) = compare("ceiling in the mirror", &pixel_means(&out.radiance), &want);
    assert!(worst < 0.01 && mean.abs() < 5e-4);
}

/// A `diffusetransmission` sheet lit from behind by a point light: the camera on the other side
/// reads `t / pi * I cos / r^2` (light sampling through the transmission lobe, shadow ray
/// leaving from the far side), and nothing from the reflectance, which faces no light.
#[test]
fn point_light_behind_a_diffuse_transmitter() {
    let (r, t, i_w_sr_nm, fov_deg, n, h_cam_m) = (0.3, 0.5, 2.0, 60.0, 32, 1.0);
    let sheet = Material::DiffuseTransmission {
        reflectance: Texture::Constant(flat(r)),
        transmittance: Texture::Constant(flat(t)),
        scale: 1.0,
    };
    let d_m = 0.7;
    let out = render(
        &scene(
            camera_down(h_cam_m, fov_deg, n),
            vec![plane(50.0, 0.0, 0)],
            vec![sheet],
            vec![point(-d_m, i_w_sr_nm)],
            settings(1024, 1),
        ),
        &|_, _| {},
    )
    .unwrap();
    let want = expected(fov_deg, n, |tx, ty| {
        let (x, y) = (tx * h_cam_m, ty * h_cam_m);
        let r2 = x * x + y * y + d_m * d_m;
        t / PI * i_w_sr_nm * (d_m / r2.sqrt()) / r2
    });
    let (worst, mean) = compare(
        "transmitted point light",
        &pixel_means(&out.radiance),
        &want,
    );
    assert!(worst < 0.01 && mean.abs() < 5e-4);
}
