//! Light groups (issue 29): the radiance split by group of lights in one pass. The groups sum to
//! the total, the total is the plain render's bit for bit, and a weighted sum of the groups is
//! the render of the scene with each group's lights scaled by its weight: exactly for the same
//! seed when the weights are equal (the samples are then the same), within the noise for other
//! weights and another seed.

use camsim_pbrt::parse_str;
use camsim_render::{render, render_with, RenderRequest};
use camsim_scene3d::{Light, SceneDescription};

/// A grey floor lit by a small lamp (group "lamp") and a uniform sky (group "sky").
fn scene(spp: u32, seed: u64) -> SceneDescription {
    scene_with(spp, seed, "")
}

/// [`scene`] with a sphere of fog (scattering and absorbing, radius 2 m, an `interface`
/// boundary) around the lamp and the middle of the floor, the camera outside it: rendered by the
/// volumetric path tracer.
fn foggy(spp: u32, seed: u64) -> SceneDescription {
    scene_with(
        spp,
        seed,
        r#"MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [0.5 0.5 0.5]
  "rgb sigma_s" [0.3 0.3 0.3] "float g" 0.3
AttributeBegin
  MediumInterface "fog" ""
  Material "interface"
  Shape "sphere" "float radius" 2
AttributeEnd
"#,
    )
}

fn scene_with(spp: u32, seed: u64, extra: &str) -> SceneDescription {
    let text = format!(
        r#"LookAt 0 3 -3  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Sampler "zsobol" "integer pixelsamples" {spp}
Film "rgb" "integer xresolution" 32 "integer yresolution" 24
WorldBegin
LightSource "infinite" "rgb L" [0.3 0.4 0.6] "string lightgroup" "sky"
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [8 7 5] "string lightgroup" "lamp"
  Shape "trianglemesh" "point3 P" [-0.3 1.5 -0.3  0.3 1.5 -0.3  0.3 1.5 0.3  -0.3 1.5 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 2 1 0 3 2]
{extra}"#
    );
    let mut s = parse_str(&text, "groups.pbrt").unwrap();
    s.settings.seed = seed;
    s
}

/// `scene` with the sky scaled by `sky` and the lamp by `lamp`.
fn scaled(mut s: SceneDescription, sky: f64, lamp: f64) -> SceneDescription {
    for l in s.lights.iter_mut() {
        if let Light::Infinite { radiance } = l {
            *radiance = radiance.clone().scaled(sky);
        }
    }
    for sh in s.shapes.iter_mut() {
        if let Some(al) = &mut sh.area_light {
            al.radiance = al.radiance.clone().scaled(lamp);
        }
    }
    s
}

fn split(s: &SceneDescription) -> camsim_render::RenderOutput {
    let req = RenderRequest {
        light_groups: true,
        ..Default::default()
    };
    render_with(s, &req, &|_, _| {}).unwrap()
}

fn weighted(out: &camsim_render::RenderOutput, sky: f32, lamp: f32) -> Vec<f32> {
    let g = &out.light_groups;
    assert_eq!(
        g.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(),
        ["lamp", "sky"]
    );
    g[0].1
        .data
        .iter()
        .zip(&g[1].1.data)
        .map(|(l, s)| lamp * l + sky * s)
        .collect()
}

#[test]
fn groups_sum_to_the_plain_render_and_weighted_sums_equal_scaled_lights() {
    check_groups(scene);
}

/// The same in fog (the volumetric path tracer): the lamp's light scattered by the fog and the
/// sky's dimmed by it each go to their group.
#[test]
fn light_groups_split_a_foggy_scene() {
    // The fog is there: it changes the image by far more than the noise.
    let mean = |s: &SceneDescription| {
        let r = render(s, &|_, _| {}).unwrap().radiance;
        r.data.iter().map(|v| *v as f64).sum::<f64>() / r.data.len() as f64
    };
    let (clear, fog) = (mean(&scene(16, 1)), mean(&foggy(16, 1)));
    assert!(
        (fog / clear - 1.0).abs() > 0.1,
        "fog {fog} vs clear {clear}"
    );
    check_groups(foggy);
}

fn check_groups(scene: fn(u32, u64) -> SceneDescription) {
    let base = scene(16, 3);
    let out = split(&base);
    let plain = render(&base, &|_, _| {}).unwrap();
    // The total is the plain render's, bit for bit: the same samples, summed in the same order.
    assert_eq!(out.radiance.data, plain.radiance.data);
    // Each group carries light, and they sum to the total (to float rounding).
    let both = weighted(&out, 1.0, 1.0);
    let (mut lamp_sum, mut sky_sum) = (0f64, 0f64);
    for (i, (w, t)) in both.iter().zip(&out.radiance.data).enumerate() {
        assert!(
            (w - t).abs() <= 1e-5 * t.abs().max(1e-3),
            "sample {i}: {w} vs {t}"
        );
        lamp_sum += out.light_groups[0].1.data[i] as f64;
        sky_sum += out.light_groups[1].1.data[i] as f64;
    }
    assert!(lamp_sum > 0.0 && sky_sum > 0.0);

    // Same seed, both groups scaled by 0.25: the scaled scene draws the same samples (light
    // choice is by relative power), so the weighted sum equals it to float rounding.
    let q = render(&scaled(base.clone(), 0.25, 0.25), &|_, _| {}).unwrap();
    for (w, t) in weighted(&out, 0.25, 0.25).iter().zip(&q.radiance.data) {
        assert!((w - t).abs() <= 2e-5 * t.abs().max(1e-3), "{w} vs {t}");
    }

    // Other seeds and unequal weights (the sky at dusk): the light choice differs, so the two
    // agree within the noise. Mean radiance per band over the image, 6 seeds of each, against
    // 4 standard errors of the difference of the two means.
    let (sky, lamp) = (0.05f32, 1.0f32);
    let band_means = |v: &[f32], pixels: usize| -> Vec<f64> {
        v.chunks_exact(pixels)
            .map(|b| b.iter().map(|x| *x as f64).sum::<f64>() / pixels as f64)
            .collect()
    };
    let groups: Vec<Vec<f64>> = (0..6)
        .map(|k| {
            let out = split(&scene(64, 11 + k));
            band_means(&weighted(&out, sky, lamp), out.radiance.pixels())
        })
        .collect();
    let scaled_runs: Vec<Vec<f64>> = (0..6)
        .map(|k| {
            let s = scaled(scene(64, 100 + k), sky as f64, lamp as f64);
            let r = render(&s, &|_, _| {}).unwrap().radiance;
            band_means(&r.data, r.pixels())
        })
        .collect();
    let stats = |runs: &[Vec<f64>], b: usize| {
        let xs: Vec<f64> = runs.iter().map(|r| r[b]).collect();
        let n = xs.len() as f64;
        let m = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, var / n)
    };
    for b in 0..groups[0].len() {
        let ((mg, vg), (ms, vs)) = (stats(&groups, b), stats(&scaled_runs, b));
        let tol = 4.0 * (vg + vs).sqrt() + 1e-4 * ms.abs();
        assert!(
            (mg - ms).abs() <= tol,
            "band {b}: weighted groups {mg} against scaled lights {ms} (tolerance {tol})"
        );
    }
}

/// A glowing medium lights the scene by itself, belonging to no light group: refused, naming
/// why, rather than splitting groups that would not sum to the image.
#[test]
fn an_emissive_medium_refuses_light_groups() {
    let s = scene_with(
        4,
        1,
        r#"MakeNamedMedium "glow" "string type" "homogeneous" "rgb sigma_a" [0.5 0.5 0.5]
  "rgb sigma_s" [0 0 0] "rgb Le" [1 1 1]
AttributeBegin
  MediumInterface "glow" ""
  Material "interface"
  Shape "sphere" "float radius" 2
AttributeEnd
"#,
    );
    assert!(render(&s, &|_, _| {}).is_ok());
    let req = RenderRequest {
        light_groups: true,
        ..Default::default()
    };
    let e = render_with(&s, &req, &|_, _| {}).unwrap_err().to_string();
    assert!(e.contains("emissive medium"), "{e}");
}
