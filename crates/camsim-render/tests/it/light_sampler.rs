//! The spatial light sampler (`LightSampler::Bvh`, pbrt-v4's `BVHLightSampler`) against power
//! selection (`LightSampler::Power`) and uniform selection (`LightSampler::Uniform`): all are
//! unbiased, so the same scene renders the same mean within Monte Carlo error; the spatial one
//! has lower variance where emitters are spread out; its image is the same bytes for any
//! thread count; and the scene's own choice (a pbrt-v4 file's `lightsampler`) is what a render
//! request without one uses.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;

use crate::common;
use common::floor;

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![300.0, 900.0], vec![v, v], "test").unwrap()
}

/// A one-sided emitting square of half-size `s` at `c`, facing down (-z).
fn panel(c: [f64; 3], s: f64, radiance: f64) -> Shape {
    let [x, y, z] = c;
    Shape {
        name: None,
        geometry: Geometry::Triangles {
            positions: vec![
                [x - s, y - s, z],
                [x + s, y - s, z],
                [x + s, y + s, z],
                [x - s, y + s, z],
            ],
            indices: vec![[0, 2, 1], [0, 3, 2]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: Some(AreaLight {
            radiance: flat(radiance),
            two_sided: false,
            image: None,
        }),
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// A floor lit by eight small panels spread over it, facing it, and a ninth under it facing
/// away (it lights nothing: importance zero), a point light, a spot light and a distant light;
/// a camera looking down (at the panels' unlit backs).
fn scene(spp: u32, max_depth: u32) -> SceneDescription {
    let mut shapes = vec![floor(4.0)];
    for (k, (x, y)) in [
        (-3.0, -3.0),
        (0.0, -3.0),
        (3.0, -3.0),
        (-3.0, 0.0),
        (3.0, 0.0),
        (-3.0, 3.0),
        (0.0, 3.0),
        (3.0, 3.0),
        (0.0, 0.0),
    ]
    .into_iter()
    .enumerate()
    {
        let z = if k == 8 { -0.5 } else { 0.4 };
        shapes.push(panel([x, y, z], 0.1, 20.0 + 5.0 * k as f64));
    }
    SceneDescription {
        camera: Camera {
            camera_to_world: look_at_camera_to_world(
                [0.0, 0.0, 6.0],
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                true,
            )
            .unwrap(),
            fov_deg: 70.0,
            width: 24,
            height: 24,
            lens: None,
        },
        shapes,
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(flat(0.5)),
        }],
        named_materials: HashMap::new(),
        lights: vec![
            Light::Point {
                position_m: [1.5, 1.5, 0.5],
                intensity: flat(0.3),
            },
            Light::Spot {
                position_m: [-1.5, 1.5, 1.0],
                direction: [0.0, 0.0, -1.0],
                intensity: flat(2.0),
                cone_angle_deg: 30.0,
                cone_delta_deg: 5.0,
                falloff: Default::default(),
            },
            Light::Distant {
                direction: [0.3, 0.2, -1.0],
                irradiance: flat(0.2),
            },
        ],
        settings: RenderSettings {
            grid: WavelengthGrid::new(400.0, 700.0, 100.0).unwrap(),
            samples_per_pixel: spp,
            max_depth,
            seed: 3,
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    }
}

/// Image-mean luminance and its variance (the render's per-pixel variance of the mean).
fn mean_and_var(out: &RenderOutput) -> (f64, f64) {
    let n = out.variance.len() as f64;
    let cmfs = camsim_core::colorimetry::Cmfs::on(&out.radiance.grid);
    let mut m = 0.0;
    for b in 0..out.radiance.bands() {
        let s: f64 = out.radiance.band(b).iter().map(|&v| v as f64).sum();
        m += 683.0 * cmfs.y[b] * out.radiance.grid.step_nm * s / n;
    }
    let v: f64 = out.variance.iter().map(|&v| v as f64).sum::<f64>() / (n * n);
    (m, v)
}

fn render_by(s: &SceneDescription, light_sampler: LightSampler) -> RenderOutput {
    let req = RenderRequest {
        light_sampler: Some(light_sampler),
        ..Default::default()
    };
    render_with(s, &req, &|_, _| {}).unwrap()
}

/// Same mean with either sampler (direct light, MIS with BSDF samples that hit the panels, and
/// one more bounce), within 4 combined standard errors (about 0.6 % of the mean); the spatial
/// sampler's variance is lower on this spread-out scene.
#[test]
fn spatial_and_power_selection_agree_in_the_mean() {
    {
        let max_depth = 2;
        let s = scene(1024, max_depth);
        let (mb, vb) = mean_and_var(&render_by(&s, LightSampler::Bvh));
        let (mp, vp) = mean_and_var(&render_by(&s, LightSampler::Power));
        let z = (mb - mp) / (vb + vp).sqrt();
        eprintln!(
            "max depth {max_depth}: bvh {mb:.5e} (sd {:.2e}), power {mp:.5e} (sd {:.2e}), z {z:+.2}; \
             variance bvh / power {:.3}",
            vb.sqrt(),
            vp.sqrt(),
            vb / vp
        );
        assert!(z.abs() < 4.0, "means differ by {z:.1} standard errors");
        assert!(
            vb < vp,
            "spatial sampler variance {vb:.3e} not below power's {vp:.3e}"
        );
    }
}

/// The spatial sampler's image is the same bytes on one thread and on three.
#[test]
fn spatial_selection_is_deterministic_across_threads() {
    let s = scene(8, 3);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render_by(&s, LightSampler::Bvh))
    };
    let (a, b) = (run(1), run(3));
    for band in 0..a.radiance.bands() {
        assert_eq!(a.radiance.band(band), b.radiance.band(band), "band {band}");
    }
}

/// Uniform selection (pbrt-v4 `UniformLightSampler`) renders the spatial sampler's mean within
/// 4 combined standard errors (direct light, MIS with BSDF samples that hit the panels, whose
/// weights use the selection pmf, and one more bounce): a wrong uniform pmf (not 1 / n for each
/// of the 12 lights) moves the mean.
#[test]
fn uniform_and_spatial_selection_agree_in_the_mean() {
    let s = scene(2048, 2);
    let (mb, vb) = mean_and_var(&render_by(&s, LightSampler::Bvh));
    let (mu, vu) = mean_and_var(&render_by(&s, LightSampler::Uniform));
    let z = (mb - mu) / (vb + vu).sqrt();
    eprintln!(
        "bvh {mb:.5e} (sd {:.2e}), uniform {mu:.5e} (sd {:.2e}), z {z:+.2}; variance uniform / bvh {:.3}",
        vb.sqrt(),
        vu.sqrt(),
        vu / vb
    );
    assert!(z.abs() < 4.0, "means differ by {z:.1} standard errors");
    // Uniform selection spends samples on the panel that lights nothing and on the dim point
    // light: more variance than the spatial sampler here.
    assert!(
        vu > vb,
        "uniform variance {vu:.3e} not above bvh's {vb:.3e}"
    );
}

/// A request without a light sampler renders with the scene's own (`RenderSettings::
/// light_sampler`, what a pbrt-v4 file's `lightsampler` sets): the same bytes as asking for it,
/// and not the default's.
#[test]
fn the_scenes_light_sampler_is_used_when_the_request_has_none() {
    let mut s = scene(4, 2);
    s.settings.light_sampler = LightSampler::Uniform;
    let from_scene = render_with(&s, &RenderRequest::default(), &|_, _| {}).unwrap();
    let asked = render_by(&s, LightSampler::Uniform);
    let bvh = render_by(&s, LightSampler::Bvh);
    for band in 0..asked.radiance.bands() {
        assert_eq!(from_scene.radiance.band(band), asked.radiance.band(band));
    }
    assert!((0..bvh.radiance.bands()).any(|b| bvh.radiance.band(b) != asked.radiance.band(b)));
}
