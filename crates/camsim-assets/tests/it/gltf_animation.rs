//! A glTF animation drives camsim's time machinery as pbrt-v4's `ActiveTransform` does: a quad
//! translated by a LINEAR channel from x = 0 at t = 0 to x = 1 m at t = 1 s, seen through a
//! 0-1 s shutter, blurs exactly as the same motion written as a pbrt-v4 `ActiveTransform`
//! StartTime / EndTime pair (the images agree pixel by pixel, normalised to their means, within
//! the Monte Carlo noise); a STEP channel holds the first pose until the step, and the still
//! at t = 0 (the default shutter) is the unmoved quad.

use base64::Engine;
use camsim_assets::{read_scene, ReadOptions};

/// A lit 0.4 m square quad facing +z, animated by `interp` over [0, 1] s along x by 1 m; a
/// camera 3 m away on +z; a directional light along -z of 1000 lux.
fn animated_gltf(interp: &str) -> String {
    let pos: [[f32; 3]; 4] = [
        [-0.2, -0.2, 0.0],
        [0.2, -0.2, 0.0],
        [0.2, 0.2, 0.0],
        [-0.2, 0.2, 0.0],
    ];
    let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let times: [f32; 2] = [0.0, 1.0];
    let trans: [[f32; 3]; 2] = [[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]];
    let mut b = Vec::new();
    for p in pos {
        for v in p {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in idx {
        b.extend_from_slice(&i.to_le_bytes());
    }
    for t in times {
        b.extend_from_slice(&t.to_le_bytes());
    }
    for p in trans {
        for v in p {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let uri = base64::engine::general_purpose::STANDARD.encode(&b);
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "directional", "intensity": 1000}}]}}}},
  "scene": 0, "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [{{"mesh": 0, "name": "quad", "translation": [-0.5, 0, 0]}},
            {{"camera": 0, "translation": [0, 0, 3]}},
            {{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.5, "aspectRatio": 1.0, "znear": 0.01}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}}}],
  "animations": [{{"channels": [{{"sampler": 0, "target": {{"node": 0, "path": "translation"}}}}],
                  "samplers": [{{"input": 2, "output": 3, "interpolation": "{interp}"}}]}}],
  "buffers": [{{"byteLength": {n}, "uri": "data:application/octet-stream;base64,{uri}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}},
                  {{"buffer": 0, "byteOffset": 60, "byteLength": 8}}, {{"buffer": 0, "byteOffset": 68, "byteLength": 24}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.2, -0.2, 0], "max": [0.2, 0.2, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]}},
    {{"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"}}]}}"#,
        n = b.len()
    )
}

/// The same scene as pbrt-v4: the quad's motion as ActiveTransform, the camera seen as the glTF
/// camera sees (a right-handed view: `Scale -1 1 1` before `LookAt`).
const PBRT: &str = r#"Scale -1 1 1
LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" 28.64788975654116 "float shutteropen" 0 "float shutterclose" 1
Film "rgb" "integer xresolution" 48 "integer yresolution" 48
PixelFilter "box"
WorldBegin
LightSource "distant" "point3 from" [0 0 1] "point3 to" [0 0 0] "rgb L" [1 1 1]
AttributeBegin
ActiveTransform StartTime
Translate -0.5 0 0
ActiveTransform EndTime
Translate 0.5 0 0
ActiveTransform All
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-0.2 -0.2 0  0.2 -0.2 0  0.2 0.2 0  -0.2 0.2 0] "integer indices" [0 1 2 0 2 3]
AttributeEnd
"#;

fn luminance(scene: &camsim_scene3d::SceneDescription) -> Vec<f64> {
    let out = camsim_render::render(scene, &|_, _| {}).unwrap();
    let r = &out.radiance;
    let cmfs = camsim_core::colorimetry::Cmfs::on(&r.grid);
    (0..r.pixels())
        .map(|p| {
            let v: Vec<f64> = (0..r.bands()).map(|b| r.band(b)[p] as f64).collect();
            cmfs.luminance_cd_m2(&v)
        })
        .collect()
}

fn gltf_scene(interp: &str, shutter: (f64, f64)) -> camsim_scene3d::SceneDescription {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("anim.gltf");
    std::fs::write(&p, animated_gltf(interp)).unwrap();
    let mut s = read_scene(&p, &ReadOptions::default()).unwrap();
    s.camera.width = 48;
    s.camera.height = 48;
    s.settings.samples_per_pixel = 64;
    s.settings.max_depth = 1;
    s.settings.time.shutter.open_s = shutter.0;
    s.settings.time.shutter.close_s = shutter.1;
    s
}

fn normalised(v: &[f64]) -> Vec<f64> {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| x / m).collect()
}

#[test]
fn linear_channel_blurs_as_pbrt_active_transform() {
    let g = gltf_scene("LINEAR", (0.0, 1.0));
    assert_eq!(g.settings.time.shapes.len(), 1, "the quad moves");
    let mut p = camsim_pbrt::parse_str(PBRT, "anim.pbrt").unwrap();
    p.settings.samples_per_pixel = 64;
    p.settings.max_depth = 1;
    let (a, b) = (normalised(&luminance(&g)), normalised(&luminance(&p)));
    // Column sums over the quad's 12 middle rows (the smear runs along x; summing beats the
    // time and wavelength noise of single pixels down to about 1.5 %).
    let n = 48;
    let row = |v: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|x| (18..30).map(|y| v[y * n + x]).sum::<f64>() / 12.0)
            .collect()
    };
    let (ra, rb) = (row(&a), row(&b));
    for x in 0..n {
        assert!(
            (ra[x] - rb[x]).abs() < 0.04 * rb[x].max(0.5),
            "column {x}: glTF {} vs pbrt-v4 {}\n{ra:?}\n{rb:?}",
            ra[x],
            rb[x]
        );
    }
    // Lit columns: 1.4 m at 3 m over a 0.5 rad field 2 * 3 * tan(0.25) = 1.532 m wide.
    let lit = ra.iter().filter(|v| **v > 0.05).count() as f64;
    let want = 1.4 / (6.0 * 0.25f64.tan()) * n as f64;
    assert!((lit - want).abs() <= 2.0, "{lit} lit columns, want {want}");
}

#[test]
fn the_default_still_and_step_channels_hold_poses() {
    // The default shutter is the still at t = 0: the quad at x = -0.5 m only.
    let still = gltf_scene("LINEAR", (0.0, 0.0));
    let s = luminance(&still);
    let n = 48;
    let lit: Vec<usize> = (0..n).filter(|&x| s[24 * n + x] > 0.0).collect();
    // -0.7..-0.3 m -> columns (x / 1.532 + 0.5) * 48.
    let col = |x_m: f64| (x_m / (6.0 * 0.25f64.tan()) + 0.5) * n as f64;
    assert!(
        (lit[0] as f64 - col(-0.7)).abs() <= 1.0
            && (*lit.last().unwrap() as f64 - col(-0.3)).abs() <= 1.0,
        "{lit:?}"
    );
    // STEP: the first pose until t = 1, so a 0-0.9 s shutter sees the unmoved quad.
    let step = luminance(&gltf_scene("STEP", (0.0, 0.9)));
    let lit_step: Vec<usize> = (0..n).filter(|&x| step[24 * n + x] > 0.0).collect();
    assert_eq!(lit, lit_step);
}
