//! glTF's physical units through camsim's renderer, against closed forms: an emissive quad's
//! luminance is its `emissiveStrength` (cd/m^2); a point light of I cd gives I cos / d^2 lux
//! (inverse square), seen on a Lambertian plane of albedo rho as rho E / pi cd/m^2; a
//! directional light of E lux gives rho E / pi; a spot light's cone falls off as
//! `KHR_lights_punctual` defines it. The files are written here as glTF JSON with a data-URI
//! buffer, so the reader's whole path (JSON, buffer, accessors, nodes, materials, lights,
//! camera) is under test.

use base64::Engine;
use camsim_assets::{read_scene, ReadOptions};
use camsim_core::colorimetry::Cmfs;

/// A glTF with one mesh (a 20 m square in the xz plane at y = 0, normal +y, or a quad facing
/// +z for `emissive`), one material and optional extras (lights, nodes).
fn gltf(
    material: &str,
    lights: &str,
    light_node: &str,
    camera_y: f64,
    emissive_quad: bool,
) -> String {
    let pos: [[f32; 3]; 4] = if emissive_quad {
        [
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ]
    } else {
        [
            [-10.0, 0.0, 10.0],
            [10.0, 0.0, 10.0],
            [10.0, 0.0, -10.0],
            [-10.0, 0.0, -10.0],
        ]
    };
    let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bytes = Vec::new();
    for p in pos {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in idx {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    // Camera: above the plane looking down (-y), or in front of the quad looking along -z.
    let cam_node = if emissive_quad {
        format!(r#"{{"camera": 0, "translation": [0, 0, {camera_y}]}}"#)
    } else {
        format!(
            r#"{{"camera": 0, "translation": [0, {camera_y}, 0], "rotation": [-0.7071067811865476, 0, 0, 0.7071067811865476]}}"#
        )
    };
    let (ext_used, exts) = if lights.is_empty() {
        (String::new(), String::new())
    } else {
        (
            r#""extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_specular"],"#.to_string(),
            format!(r#""extensions": {{"KHR_lights_punctual": {{"lights": [{lights}]}}}},"#),
        )
    };
    let light_nodes = if light_node.is_empty() {
        String::new()
    } else {
        format!(", {light_node}")
    };
    let scene_nodes = if light_node.is_empty() {
        "[0, 1]"
    } else {
        "[0, 1, 2]"
    };
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {ext_used} {exts}
  "scene": 0, "scenes": [{{"nodes": {scene_nodes}}}],
  "nodes": [{{"mesh": 0, "name": "plane"}}, {cam_node}{light_nodes}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.5, "aspectRatio": 1.0, "znear": 0.01}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{material}],
  "buffers": [{{"byteLength": {len}, "uri": "{uri}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-10, -10, -10], "max": [10, 10, 10]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#,
        len = bytes.len()
    )
}

const GREY: &str = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}, "extensions": {"KHR_materials_specular": {"specularFactor": 0}}}"#;

/// Render the file and return the luminance image (cd/m^2), `n` x `n`.
fn render(text: &str, n: usize, spp: u32) -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scene.gltf");
    std::fs::write(&p, text).unwrap();
    let mut s = read_scene(&p, &ReadOptions::default()).unwrap();
    s.camera.width = n;
    s.camera.height = n;
    s.settings.samples_per_pixel = spp;
    s.settings.max_depth = 1;
    let out = camsim_render::render(&s, &|_, _| {}).unwrap();
    let cmfs = Cmfs::on(&out.radiance.grid);
    let b = out.radiance.bands();
    (0..n * n)
        .map(|p| {
            let v: Vec<f64> = (0..b).map(|k| out.radiance.band(k)[p] as f64).collect();
            cmfs.luminance_cd_m2(&v)
        })
        .collect()
}

/// The mean of `f(dx, dz)` over the ground footprint of pixel (x, y) of an n x n camera at
/// height h looking down with a vertical field of 0.5 rad (`dx`, `dz` the offsets from the
/// nadir, m; 8 x 8 points per pixel, the box filter's average).
fn footprint_mean(x: usize, y: usize, n: usize, h: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
    let t = (0.25f64).tan();
    let mut sum = 0.0;
    for j in 0..8 {
        for i in 0..8 {
            let sx = ((x as f64 + (i as f64 + 0.5) / 8.0) / n as f64 * 2.0 - 1.0) * t;
            let sy = ((y as f64 + (j as f64 + 0.5) / 8.0) / n as f64 * 2.0 - 1.0) * t;
            sum += f(sx * h, sy * h);
        }
    }
    sum / 64.0
}

/// The luminance the render's grid (31 bands of 10 nm, 400-700 nm, each the mean over its
/// band) shows of a white (D65) light per cd/m^2 of its 360-830 nm luminance: the grid leaves
/// out the ends of y-bar and averages D65's lines over each band (0.8 % in all).
fn grid_fraction() -> f64 {
    let s = camsim_assets::units::photometric_spectrum([1.0; 3], 1.0).unwrap();
    let grid = camsim_core::WavelengthGrid::default();
    let v: Vec<f64> = (0..grid.len())
        .map(|k| {
            let c = grid.wavelength_nm(k);
            (0..100)
                .map(|i| s.eval(c - 5.0 + (i as f64 + 0.5) * 0.1))
                .sum::<f64>()
                / 100.0
        })
        .collect();
    Cmfs::on(&grid).luminance_cd_m2(&v)
}

#[test]
fn emissive_strength_is_luminance_in_cd_m2() {
    let m = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 100}}}"#;
    let text = gltf(m, "", "", 3.0, true).replace(r#""extensionsUsed""#, r#""unused""#);
    let text = text.replacen(
        r#"{"asset": {"version": "2.0"},"#,
        r#"{"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_materials_emissive_strength"],"#,
        1,
    );
    let y = render(&text, 8, 64);
    // The quad fills the frame (1 m half-width at 3 m: 0.32 rad > 0.25 half field). Each
    // pixel's value carries the noise of its sampled wavelengths; the image mean averages it.
    let want = 100.0 * grid_fraction();
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    assert!(
        (mean / want - 1.0).abs() < 3e-3,
        "{mean} cd/m^2, want {want}"
    );
    for v in &y {
        assert!((v / want - 1.0).abs() < 0.03, "{v} cd/m^2, want {want}");
    }
}

#[test]
fn point_light_follows_the_inverse_square_law() {
    let h = 2.0;
    let i_cd = 1000.0;
    let text = gltf(
        GREY,
        &format!(r#"{{"type": "point", "intensity": {i_cd}, "color": [1, 1, 1]}}"#),
        r#"{"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 1.0, 0]}"#,
        h,
        false,
    );
    let n = 16;
    let y = render(&text, n, 64);
    // Light 1 m above the plane: E = I cos / d^2 = I / (1 + r^2)^1.5; L = rho E / pi.
    let k = grid_fraction();
    for &(px, py) in &[(7usize, 7usize), (0, 0), (15, 3), (4, 12)] {
        let e_lux = footprint_mean(px, py, n, h, |dx, dz| {
            i_cd / (1.0 + dx * dx + dz * dz).powf(1.5)
        });
        let want = k * 0.5 * e_lux / std::f64::consts::PI;
        let got = y[py * n + px];
        assert!(
            (got / want - 1.0).abs() < 0.03,
            "pixel ({px}, {py}): {got} vs {want} cd/m^2"
        );
    }
    // Over the whole image (the wavelength noise averaged out).
    let want: f64 = (0..n * n)
        .map(|p| {
            k * 0.5 / std::f64::consts::PI
                * footprint_mean(p % n, p / n, n, h, |dx, dz| {
                    i_cd / (1.0 + dx * dx + dz * dz).powf(1.5)
                })
        })
        .sum();
    let got: f64 = y.iter().sum();
    assert!((got / want - 1.0).abs() < 3e-3, "image sum {got} vs {want}");
}

#[test]
fn directional_light_gives_its_lux() {
    let e_lux = 20_000.0;
    // Straight down (-z of the node turned by -90 degrees about x).
    let text = gltf(
        GREY,
        &format!(r#"{{"type": "directional", "intensity": {e_lux}}}"#),
        r#"{"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-0.7071067811865476, 0, 0, 0.7071067811865476]}"#,
        2.0,
        false,
    );
    let y = render(&text, 8, 64);
    let want = grid_fraction() * 0.5 * e_lux / std::f64::consts::PI;
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    assert!((mean / want - 1.0).abs() < 3e-3, "{mean} vs {want}");
}

#[test]
fn spot_cone_falls_off_as_khr_lights_punctual_says() {
    let h = 2.0;
    let (inner, outer) = (0.15f64, 0.45f64);
    let i_cd = 1000.0;
    let text = gltf(
        GREY,
        &format!(
            r#"{{"type": "spot", "intensity": {i_cd}, "spot": {{"innerConeAngle": {inner}, "outerConeAngle": {outer}}}}}"#
        ),
        r#"{"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 1.0, 0], "rotation": [-0.7071067811865476, 0, 0, 0.7071067811865476]}"#,
        h,
        false,
    );
    let n = 32;
    let y = render(&text, n, 64);
    let (ci, co) = (inner.cos(), outer.cos());
    let k = grid_fraction();
    let mut checked = 0;
    let mut sums = (0.0f64, 0.0f64);
    for py in 0..n {
        for px in 0..n {
            // E = I t^2 cos^3 / h'^2 with t = clamp((cos - cos_outer) / (cos_inner - cos_outer)).
            let falloff = |dx: f64, dz: f64| {
                let cos_t = 1.0 / (1.0 + dx * dx + dz * dz).sqrt();
                let t = ((cos_t - co) / (ci - co)).clamp(0.0, 1.0);
                i_cd * t * t * cos_t.powi(3)
            };
            let want = k * 0.5 * footprint_mean(px, py, n, h, falloff) / std::f64::consts::PI;
            let got = y[py * n + px];
            if want > 1.0 {
                sums.0 += got;
                sums.1 += want;
                // pbrt-v4's smoothstep 3t^2 - 2t^3 is 1.5-2x t^2 over most of the band.
                assert!(
                    (got / want - 1.0).abs() < 0.05,
                    "({px}, {py}): {got} vs {want}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "{checked} lit pixels");
    assert!((sums.0 / sums.1 - 1.0).abs() < 5e-3, "{sums:?}");
}

/// `KHR_materials_transmission` + `KHR_materials_volume`: a 1 m glass cube (ior 1.5) whose
/// attenuation colour 0.5 at 1 m halves the light per metre (Beer-Lambert), in front of a
/// 100 cd/m^2 emitter: seen through its middle, `100 (1 - R)^2 t / (1 - R^2 t^2)` with `t = 0.5`
/// and `R = 0.04` (normal-incidence Fresnel, the internal reflections summed).
#[test]
fn a_volume_absorbs_by_beer_lambert() {
    // Quad (4 vertices) at z = 0 facing +z, then a cube of side 1 centred at (0, 0, 1).
    let mut pos: Vec<[f32; 3]> = vec![
        [-2.0, -2.0, 0.0],
        [2.0, -2.0, 0.0],
        [2.0, 2.0, 0.0],
        [-2.0, 2.0, 0.0],
    ];
    for k in 0..8 {
        let c = |b: usize| if k & b != 0 { 0.5 } else { -0.5 };
        pos.push([c(1), c(2), 1.0 + c(4)]);
    }
    let quad: [u16; 6] = [0, 1, 2, 0, 2, 3];
    // Cube faces, outward (counter-clockwise seen from outside), vertex 4 + bits (x=1, y=2, z=4).
    let faces: [[u16; 4]; 6] = [
        [0, 2, 3, 1], // z-
        [4, 5, 7, 6], // z+
        [0, 1, 5, 4], // y-
        [2, 6, 7, 3], // y+
        [0, 4, 6, 2], // x-
        [1, 3, 7, 5], // x+
    ];
    let mut cube: Vec<u16> = Vec::new();
    for f in faces {
        let f = f.map(|v| v + 4);
        cube.extend_from_slice(&[f[0], f[1], f[2], f[0], f[2], f[3]]);
    }
    let mut bytes = Vec::new();
    for p in &pos {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in quad.iter().chain(&cube) {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let uri = base64::engine::general_purpose::STANDARD.encode(&bytes);
    let text = format!(
        r#"{{"asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior"],
  "scene": 0, "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [{{"mesh": 0, "name": "lamp"}}, {{"mesh": 1, "name": "glass"}}, {{"camera": 0, "translation": [0, 0, 4]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.1, "aspectRatio": 1.0, "znear": 0.01}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}},
             {{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 2, "material": 1}}]}}],
  "materials": [
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1]}}, "emissiveFactor": [1, 1, 1],
      "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 100}}}}}},
    {{"pbrMetallicRoughness": {{"roughnessFactor": 0}},
      "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}, "KHR_materials_ior": {{"ior": 1.5}},
                      "KHR_materials_volume": {{"thicknessFactor": 1, "attenuationDistance": 1, "attenuationColor": [0.5, 0.5, 0.5]}}}}}}],
  "buffers": [{{"byteLength": {n}, "uri": "data:application/octet-stream;base64,{uri}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 144}}, {{"buffer": 0, "byteOffset": 144, "byteLength": 12}},
                  {{"buffer": 0, "byteOffset": 156, "byteLength": 72}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 12, "type": "VEC3", "min": [-2, -2, 0], "max": [2, 2, 1.5]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5123, "count": 36, "type": "SCALAR"}}]}}"#,
        n = bytes.len()
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("glass.gltf");
    std::fs::write(&p, text).unwrap();
    let mut s = read_scene(&p, &ReadOptions::default()).unwrap();
    assert_eq!(s.media.list.len(), 1, "the volume's medium");
    s.camera.width = 8;
    s.camera.height = 8;
    s.settings.samples_per_pixel = 64;
    s.settings.max_depth = 12;
    let out = camsim_render::render(&s, &|_, _| {}).unwrap();
    let cmfs = Cmfs::on(&out.radiance.grid);
    let b = out.radiance.bands();
    let y: Vec<f64> = (0..64)
        .map(|p| {
            let v: Vec<f64> = (0..b).map(|k| out.radiance.band(k)[p] as f64).collect();
            cmfs.luminance_cd_m2(&v)
        })
        .collect();
    let (r, t) = (0.04f64, 0.5f64);
    let want = 100.0 * grid_fraction() * (1.0 - r).powi(2) * t / (1.0 - r * r * t * t);
    let mean = y.iter().sum::<f64>() / 64.0;
    assert!((mean / want - 1.0).abs() < 5e-3, "{mean} vs {want} cd/m^2");
}
