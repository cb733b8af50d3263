//! glTF 2.0 vertex attributes through the reader and the renderer, against closed forms:
//! `COLOR_0` multiplies the base colour (sec. 3.9.2: a Lambertian of reflectance rho under a
//! directional light of E lux shows `rho E / pi` cd/m^2, rho the colour's luminance
//! 0.2126 R + 0.7152 G + 0.0722 B in linear Rec. 709), interpolated over the triangles; a
//! texture's `texCoord` picks its uv set; normal maps use `TANGENT` (xyz, w) or, without it,
//! MikkTSpace tangents, whose value on a planar quad with affine uvs is `dp/du`'s direction
//! (with `w` the sign that makes `w n x t` point up the image). The files are written here as
//! glTF JSON with data-URI buffers and images.

use base64::Engine;
use camsim_assets::{read_scene, ReadOptions};
use camsim_core::colorimetry::Cmfs;
use camsim_scene3d::{Geometry, SceneDescription};

const PI: f64 = std::f64::consts::PI;

/// The per-vertex extras of the test quad (the 20 m square in the xz plane at y = 0, normal +y,
/// vertices (-10, 10), (10, 10), (10, -10), (-10, -10) in (x, z)).
#[derive(Default)]
struct Quad {
    /// glTF uvs of set 0 and set 1 (else u = (x + 10) / 20, v = (z + 10) / 20 for set 0).
    uv0: Option<[[f32; 2]; 4]>,
    uv1: Option<[[f32; 2]; 4]>,
    /// COLOR_0 as float VEC3.
    color_f32: Option<[[f32; 3]; 4]>,
    /// COLOR_0 as normalized unsigned byte VEC4.
    color_u8: Option<[[u8; 4]; 4]>,
    tangent: Option<[[f32; 4]; 4]>,
    normals: bool,
}

const XZ: [[f32; 2]; 4] = [[-10.0, 10.0], [10.0, 10.0], [10.0, -10.0], [-10.0, -10.0]];

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A PNG of `w` x `h` RGBA8 texels, as a data URI.
fn png(w: u32, h: u32, rgba: &[[u8; 4]]) -> String {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(rgba[(y * w + x) as usize]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    data_uri("image/png", out.get_ref())
}

/// The file: the quad with `q`'s attributes, `material`, `images` (URIs; one texture each,
/// sampler NEAREST, CLAMP_TO_EDGE), an optional directional light travelling along the
/// quaternion `light_q`'s -z, and a camera 2 m above looking down (vertical field 0.5 rad).
fn gltf(q: &Quad, material: &str, images: &[String], light: Option<(f64, [f64; 4])>) -> String {
    let mut bytes: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut attrs = Vec::new();
    let mut push = |name: &str, data: Vec<u8>, ctype: u32, ty: &str, extra: &str| {
        let off = bytes.len();
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {off}, "byteLength": {}}}"#,
            data.len()
        ));
        bytes.extend_from_slice(&data);
        while !bytes.len().is_multiple_of(4) {
            bytes.push(0);
        }
        let count = if name == "indices" { 6 } else { 4 };
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": {ctype}, "count": {count}, "type": "{ty}"{extra}}}"#,
            views.len() - 1
        ));
        if name != "indices" {
            attrs.push(format!(r#""{name}": {}"#, accessors.len() - 1));
        }
        accessors.len() - 1
    };
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let pos: Vec<f32> = XZ.iter().flat_map(|p| [p[0], 0.0, p[1]]).collect();
    push(
        "POSITION",
        f32s(&pos),
        5126,
        "VEC3",
        r#", "min": [-10, 0, -10], "max": [10, 0, 10]"#,
    );
    if q.normals {
        push("NORMAL", f32s(&[0.0, 1.0, 0.0].repeat(4)), 5126, "VEC3", "");
    }
    let uv0 = q
        .uv0
        .unwrap_or(XZ.map(|p| [(p[0] + 10.0) / 20.0, (p[1] + 10.0) / 20.0]));
    push("TEXCOORD_0", f32s(uv0.as_flattened()), 5126, "VEC2", "");
    if let Some(t) = q.uv1 {
        push("TEXCOORD_1", f32s(t.as_flattened()), 5126, "VEC2", "");
    }
    if let Some(c) = q.color_f32 {
        push("COLOR_0", f32s(c.as_flattened()), 5126, "VEC3", "");
    }
    if let Some(c) = q.color_u8 {
        push(
            "COLOR_0",
            c.as_flattened().to_vec(),
            5121,
            "VEC4",
            r#", "normalized": true"#,
        );
    }
    if let Some(t) = q.tangent {
        push("TANGENT", f32s(t.as_flattened()), 5126, "VEC4", "");
    }
    let idx: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let ind = push("indices", idx, 5123, "SCALAR", "");
    let uri = data_uri("application/octet-stream", &bytes);
    let (light_ext, light_node, nodes) = match light {
        Some((e_lux, r)) => (
            format!(
                r#""extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"], "extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "directional", "intensity": {e_lux}}}]}}}},"#
            ),
            format!(
                r#", {{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}, "rotation": [{}, {}, {}, {}]}}"#,
                r[0], r[1], r[2], r[3]
            ),
            "[0, 1, 2]",
        ),
        None => (
            r#""extensionsUsed": ["KHR_materials_specular", "KHR_materials_emissive_strength"],"#
                .to_string(),
            String::new(),
            "[0, 1]",
        ),
    };
    let imgs: Vec<String> = images
        .iter()
        .map(|u| format!(r#"{{"uri": "{u}"}}"#))
        .collect();
    let texs: Vec<String> = (0..images.len())
        .map(|i| format!(r#"{{"source": {i}, "sampler": 0}}"#))
        .collect();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {light_ext}
  "scene": 0, "scenes": [{{"nodes": {nodes}}}],
  "nodes": [{{"mesh": 0, "name": "quad"}}, {{"camera": 0, "translation": [0, 2, 0], "rotation": [-0.7071067811865476, 0, 0, 0.7071067811865476]}}{light_node}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.5, "aspectRatio": 1.0, "znear": 0.01}}}}],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{{attrs}}}, "indices": {ind}, "material": 0}}]}}],
  "materials": [{material}],
  "images": [{imgs}], "textures": [{texs}],
  "samplers": [{{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}}],
  "buffers": [{{"byteLength": {len}, "uri": "{uri}"}}],
  "bufferViews": [{views}],
  "accessors": [{accs}]}}"#,
        attrs = attrs.join(", "),
        imgs = imgs.join(", "),
        texs = texs.join(", "),
        len = bytes.len(),
        views = views.join(", "),
        accs = accessors.join(", "),
    )
}

fn read(text: &str) -> Result<SceneDescription, String> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("quad.gltf");
    std::fs::write(&p, text).unwrap();
    read_scene(&p, &ReadOptions::default()).map_err(|e| e.to_string())
}

/// Render `text` (`n` x `n`, `spp` samples, direct light only) as luminance, cd/m^2.
fn render(text: &str, n: usize, spp: u32) -> Vec<f64> {
    let mut s = read(text).unwrap();
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

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// The luminance the render's 31-band grid shows of a white (D65) light per cd/m^2 (as in
/// `gltf_units.rs`: the grid leaves out the ends of y-bar).
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

/// A Lambertian material (specular 0) of base colour `rgb`, plus `extra` JSON members.
fn lambertian(rgb: [f64; 3], extra: &str) -> String {
    format!(
        r#"{{"name": "mat", "pbrMetallicRoughness": {{"baseColorFactor": [{}, {}, {}, 1], "metallicFactor": 0{extra}}}, "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}}}}}}"#,
        rgb[0], rgb[1], rgb[2]
    )
}

/// Straight down: -z turned by -90 degrees about x.
const DOWN: [f64; 4] = [
    -std::f64::consts::FRAC_1_SQRT_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
];

fn luminance_rgb(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[test]
fn color_0_multiplies_a_white_base_colour() {
    let e_lux = 10_000.0;
    let c = [0.5f32, 0.25, 1.0];
    let q = Quad {
        color_f32: Some([c; 4]),
        ..Default::default()
    };
    let text = gltf(&q, &lambertian([1.0; 3], ""), &[], Some((e_lux, DOWN)));
    let s = read(&text).unwrap();
    let Geometry::Triangles { colors, .. } = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    assert_eq!(colors.as_deref(), Some(&[[c[0], c[1], c[2], 1.0]; 4][..]));
    let got = mean(&render(&text, 4, 64));
    let rho = luminance_rgb(c.map(f64::from));
    let want = grid_fraction() * rho * e_lux / PI;
    assert!((got / want - 1.0).abs() < 0.02, "{got} vs {want} cd/m^2");
    // And a white quad (no COLOR_0) under the same light: the ratio is rho.
    let white = mean(&render(
        &gltf(
            &Quad::default(),
            &lambertian([1.0; 3], ""),
            &[],
            Some((e_lux, DOWN)),
        ),
        4,
        64,
    ));
    assert!(
        (got / white / rho - 1.0).abs() < 0.02,
        "ratio {} vs {rho}",
        got / white
    );
}

#[test]
fn normalized_u8_color_0_is_interpolated_across_the_triangles() {
    // Black at x = -10, white at x = +10 (normalized UNSIGNED_BYTE VEC4): L grows linearly in
    // x, rho(x) = (x + 10) / 20, times a grey factor 0.8.
    let e_lux = 10_000.0;
    let col = XZ.map(|p| {
        if p[0] > 0.0 {
            [255, 255, 255, 255]
        } else {
            [0, 0, 0, 255]
        }
    });
    let q = Quad {
        color_u8: Some(col),
        ..Default::default()
    };
    let text = gltf(&q, &lambertian([0.8; 3], ""), &[], Some((e_lux, DOWN)));
    let n = 8;
    let y = render(&text, n, 64);
    let k = grid_fraction() * 0.8 * e_lux / PI;
    let t = 0.25f64.tan();
    for px in 0..n {
        // The column's mean x on the ground (2 m below the camera); rho is linear in x.
        let x_m = ((px as f64 + 0.5) / n as f64 * 2.0 - 1.0) * t * 2.0;
        let want = k * (x_m + 10.0) / 20.0;
        let got = mean(&(0..n).map(|py| y[py * n + px]).collect::<Vec<_>>());
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "column {px} (x = {x_m:.3} m): {got} vs {want} cd/m^2"
        );
    }
}

/// A 2 x 1 image: black at u < 1/2, white at u > 1/2.
fn black_white() -> String {
    png(2, 1, &[[0, 0, 0, 255], [255, 255, 255, 255]])
}

#[test]
fn base_colour_texture_reads_the_set_its_tex_coord_names() {
    let e_lux = 10_000.0;
    // TEXCOORD_0 on the black texel, TEXCOORD_1 on the white one.
    let q = Quad {
        uv0: Some([[0.25, 0.5]; 4]),
        uv1: Some([[0.75, 0.5]; 4]),
        ..Default::default()
    };
    let m = |set: u32| {
        lambertian(
            [1.0; 3],
            &format!(r#", "baseColorTexture": {{"index": 0, "texCoord": {set}}}"#),
        )
    };
    let want = grid_fraction() * e_lux / PI;
    let on1 = mean(&render(
        &gltf(&q, &m(1), &[black_white()], Some((e_lux, DOWN))),
        4,
        32,
    ));
    assert!((on1 / want - 1.0).abs() < 0.02, "{on1} vs {want} cd/m^2");
    let on0 = mean(&render(
        &gltf(&q, &m(0), &[black_white()], Some((e_lux, DOWN))),
        4,
        32,
    ));
    assert!(on0 < 1e-3 * want, "{on0} cd/m^2 on the black texel");
}

#[test]
fn emissive_texture_on_the_second_set_while_the_base_colour_reads_the_first() {
    // Base colour texture on set 0 (black factor), emissive texture on set 1: TEXCOORD_1 names
    // the white texel, TEXCOORD_0 the black one; the luminance is emissiveStrength (cd/m^2).
    let q = Quad {
        uv0: Some([[0.25, 0.5]; 4]),
        uv1: Some([[0.75, 0.5]; 4]),
        ..Default::default()
    };
    let m = |set: u32| {
        format!(
            r#"{{"name": "glow", "pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "baseColorTexture": {{"index": 0, "texCoord": 0}}}}, "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0, "texCoord": {set}}}, "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 50}}}}}}"#
        )
    };
    let want = 50.0 * grid_fraction();
    let s = read(&gltf(&q, &m(1), &[black_white()], None)).unwrap();
    let Geometry::Triangles { uvs, uvs1, .. } = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    // camsim's v runs up the image: v = 1 - v_glTF.
    assert_eq!(uvs.as_deref(), Some(&[[0.25f32, 0.5]; 4][..]));
    assert_eq!(uvs1.as_deref(), Some(&[[0.75f32, 0.5]; 4][..]));
    let got = mean(&render(&gltf(&q, &m(1), &[black_white()], None), 4, 32));
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want} cd/m^2");
    let same = mean(&render(&gltf(&q, &m(0), &[black_white()], None), 4, 32));
    assert!(same < 1e-3 * want, "{same} cd/m^2 with both on set 0");
}

#[test]
fn a_tex_coord_the_mesh_lacks_is_an_error_naming_material_and_mesh() {
    let m = lambertian(
        [1.0; 3],
        r#", "baseColorTexture": {"index": 0, "texCoord": 3}"#,
    );
    let e = read(&gltf(&Quad::default(), &m, &[black_white()], None)).unwrap_err();
    assert!(
        e.contains("\"mat\"") && e.contains("mesh \"quad\"") && e.contains("TEXCOORD_3"),
        "{e}"
    );
}

/// A 1 x 1 normal map of the unit tangent-space normal `n` (linear, `(n + 1) / 2`).
fn normal_png(n: [f64; 3]) -> String {
    let c = n.map(|v| ((v + 1.0) / 2.0 * 255.0).round() as u8);
    png(1, 1, &[[c[0], c[1], c[2], 255]])
}

fn normal_mapped(extra: &str) -> String {
    lambertian([0.5; 3], "").replacen(
        r#""extensions""#,
        &format!(r#""normalTexture": {{"index": 0}}{extra}, "extensions""#),
        1,
    )
}

/// The tangents the reader gives the quad.
fn tangents_of(q: &Quad) -> Vec<[f32; 4]> {
    let flat = normal_png([0.0, 0.0, 1.0]);
    let s = read(&gltf(q, &normal_mapped(""), &[flat], None)).unwrap();
    let Geometry::Triangles {
        tangents,
        positions,
        ..
    } = &s.shapes[0].geometry
    else {
        panic!("not a mesh")
    };
    let t = tangents.clone().expect("tangents");
    assert_eq!(t.len(), positions.len());
    t
}

fn assert_tangent(got: &[[f32; 4]], want: [f64; 4], what: &str) {
    for t in got {
        let d = (0..3)
            .map(|k| (t[k] as f64 - want[k]).abs())
            .fold(0.0, f64::max);
        assert!(
            d < 1e-5 && t[3] as f64 == want[3],
            "{what}: {t:?}, want {want:?}"
        );
    }
}

#[test]
fn mikktspace_tangents_follow_dp_du() {
    // u along +x, v (glTF, down the image) along +z: t = +x; the image's up is -z = n x t, w = 1.
    for normals in [false, true] {
        let q = Quad {
            normals,
            ..Default::default()
        };
        assert_tangent(&tangents_of(&q), [1.0, 0.0, 0.0, 1.0], "axis-aligned uvs");
    }
    // uvs turned by 30 degrees: u = (cos x + sin z) / 20 + 1/2, v = (-sin x + cos z) / 20 + 1/2
    // gives dp/du = (cos, 0, sin) and the image's up -dp/dv = (sin, 0, -cos) = n x t: w = 1.
    let a = 30f64.to_radians();
    let (c, s) = (a.cos(), a.sin());
    let uv = XZ.map(|p| {
        let (x, z) = (p[0] as f64, p[1] as f64);
        [
            ((c * x + s * z) / 20.0 + 0.5) as f32,
            ((-s * x + c * z) / 20.0 + 0.5) as f32,
        ]
    });
    let q = Quad {
        uv0: Some(uv),
        normals: true,
        ..Default::default()
    };
    assert_tangent(
        &tangents_of(&q),
        [c, 0.0, s, 1.0],
        "uvs turned by 30 degrees",
    );
    // u along +z, v along +x (a mirrored parameterisation): t = +z, the image's up is -x while
    // n x t = +x, so w = -1.
    let q = Quad {
        uv0: Some(XZ.map(|p| [(p[1] + 10.0) / 20.0, (p[0] + 10.0) / 20.0])),
        normals: true,
        ..Default::default()
    };
    assert_tangent(&tangents_of(&q), [0.0, 0.0, 1.0, -1.0], "swapped uvs");
}

#[test]
fn a_tangent_attribute_is_read_as_given() {
    let q = Quad {
        normals: true,
        tangent: Some([[0.6, 0.0, 0.8, -1.0]; 4]),
        ..Default::default()
    };
    assert_tangent(&tangents_of(&q), [0.6, 0.0, 0.8, -1.0], "TANGENT");
}

/// A normal texture's `KHR_texture_transform` moves the uvs it reads (the `gltf` crate gives it
/// no typed accessor: camsim reads the extension's JSON), so MikkTSpace's frame turns with it.
/// These uvs run u along +x and v along -z (tangent +x, w = -1 untransformed); a quarter turn
/// makes u' = v + 1/2, so the tangent dp/du' is -z, and v' = 1/4 - u, so the image's up
/// (-dp/dv') is +x = -(n x t): w = -1. A malformed transform names the material and the key.
#[test]
fn a_normal_textures_transform_turns_its_tangent_frame() {
    let flat = normal_png([0.0, 0.0, 1.0]);
    let with = |xf: &str| {
        lambertian([0.5; 3], "").replacen(
            r#""extensions""#,
            &format!(
                r#""normalTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {xf}}}}}, "extensions""#
            ),
            1,
        )
    };
    let uv: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let q = Quad {
        uv0: Some(uv),
        normals: true,
        ..Default::default()
    };
    let r = std::f64::consts::FRAC_PI_2;
    let s = read(&gltf(
        &q,
        &with(&format!(r#"{{"rotation": {r}, "offset": [0.5, 0.25]}}"#)),
        std::slice::from_ref(&flat),
        None,
    ))
    .unwrap();
    let Geometry::Triangles { uvs, tangents, .. } = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    // u' = v + 1/2, v' = -u + 1/4; camsim stores (u', 1 - v').
    for (got, p) in uvs.as_deref().unwrap().iter().zip(uv) {
        let (u, v) = (p[0] as f64, p[1] as f64);
        let want = [v + 0.5, 1.0 - (-u + 0.25)];
        assert!(
            (got[0] as f64 - want[0]).abs() < 1e-6 && (got[1] as f64 - want[1]).abs() < 1e-6,
            "uv {p:?} -> {got:?}, want {want:?}"
        );
    }
    assert_tangent(
        tangents.as_deref().expect("tangents"),
        [0.0, 0.0, -1.0, -1.0],
        "a quarter-turned normal texture",
    );
    let e = read(&gltf(&q, &with(r#"{"rotation": "x"}"#), &[flat], None)).unwrap_err();
    assert!(
        e.contains("normalTexture's KHR_texture_transform: rotation"),
        "{e}"
    );
}

/// The luminance of the normal-mapped grey quad (rho 0.5) whose map tilts the normal by 45
/// degrees toward +y of the tangent frame (the bitangent `w n x t`), lit by `e_lux` travelling
/// along `light_q`'s -z.
fn tilted_render(q: &Quad, map: [f64; 3], light_q: [f64; 4]) -> f64 {
    let text = gltf(
        q,
        &normal_mapped(""),
        &[normal_png(map)],
        Some((10_000.0, light_q)),
    );
    mean(&render(&text, 4, 32))
}

#[test]
fn normal_maps_turn_in_the_tangent_frame() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let want = grid_fraction() * 0.5 * 10_000.0 / PI;
    // The light travels along (0, -1, -1) / sqrt 2 (from +z, 45 degrees up: -45 degrees about
    // x) or along (0, -1, 1) / sqrt 2 (from -z: -135 degrees about x).
    let (sa, ca) = (22.5f64.to_radians().sin(), 22.5f64.to_radians().cos());
    let from_plus_z = [-sa, 0.0, 0.0, ca];
    let from_minus_z = [-ca, 0.0, 0.0, sa];
    // The map's normal (0, sin 45, cos 45): toward the bitangent.
    let toward_b = [0.0, h, h];
    // MikkTSpace (u along x, v_glTF along z): t = +x, w = 1, bitangent n x t = -z: the normal
    // faces the light from -z (cos 0) and is edge-on to the light from +z (cos 90 degrees).
    let mikk = Quad {
        normals: true,
        ..Default::default()
    };
    let lit = tilted_render(&mikk, toward_b, from_minus_z);
    assert!((lit / want - 1.0).abs() < 0.02, "{lit} vs {want} cd/m^2");
    let edge = tilted_render(&mikk, toward_b, from_plus_z);
    assert!(edge < 0.02 * want, "{edge} cd/m^2 edge-on");
    // TANGENT (1, 0, 0, -1): the bitangent flips to +z, so the light from +z is the one faced.
    let flipped = Quad {
        normals: true,
        tangent: Some([[1.0, 0.0, 0.0, -1.0]; 4]),
        ..Default::default()
    };
    let lit = tilted_render(&flipped, toward_b, from_plus_z);
    assert!(
        (lit / want - 1.0).abs() < 0.02,
        "w = -1: {lit} vs {want} cd/m^2"
    );
    // TANGENT (0, 0, 1, 1), off dp/du (+x): the map's +x tilt, (sin 45, 0, cos 45), turns the
    // normal toward +z, where the frame of dp/du would turn it toward +x (cos 60 degrees).
    let off = Quad {
        normals: true,
        tangent: Some([[0.0, 0.0, 1.0, 1.0]; 4]),
        ..Default::default()
    };
    let lit = tilted_render(&off, [h, 0.0, h], from_plus_z);
    assert!(
        (lit / want - 1.0).abs() < 0.02,
        "TANGENT +z: {lit} vs {want} cd/m^2"
    );
}

/// `../shared/assets/trimesh/cubevc.glb` (a Blender export with NORMAL, TEXCOORD_0, TANGENT
/// and float COLOR_0) rewritten with a normal-mapped material, with or without its TANGENT.
fn cubevc(keep_tangent: bool) -> SceneDescription {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/assets/trimesh/cubevc.glb"
    );
    let glb = std::fs::read(path).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut j: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin = &glb[20 + json_len..];
    j["materials"] = serde_json::json!([{"name": "bumpy", "normalTexture": {"index": 0}}]);
    j["textures"] = serde_json::json!([{"source": 0}]);
    j["images"] = serde_json::json!([{"uri": normal_png([0.0, 0.0, 1.0])}]);
    let prim = &mut j["meshes"][0]["primitives"][0];
    prim["material"] = serde_json::json!(0);
    if !keep_tangent {
        prim["attributes"]
            .as_object_mut()
            .unwrap()
            .remove("TANGENT");
    }
    let mut js = serde_json::to_vec(&j).unwrap();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + js.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(bin);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cubevc.glb");
    std::fs::write(&p, out).unwrap();
    read_scene(&p, &ReadOptions::default()).unwrap()
}

#[test]
fn cubevc_colours_and_tangents_match_trimesh_and_blender() {
    let given = cubevc(true);
    let mikk = cubevc(false);
    let (
        Geometry::Triangles {
            positions,
            indices,
            colors,
            tangents: Some(t_file),
            ..
        },
        Geometry::Triangles {
            positions: p_mikk,
            tangents: Some(t_mikk),
            colors: c_mikk,
            ..
        },
    ) = (&given.shapes[0].geometry, &mikk.shapes[0].geometry)
    else {
        panic!("cubevc: no tangents")
    };
    // trimesh 5.2.0 (expected.csv): 54 vertices, 48 faces; one colour per vertex.
    assert_eq!((positions.len(), indices.len()), (54, 48));
    let colors = colors.as_ref().expect("COLOR_0");
    assert_eq!(colors.len(), 54);
    assert!(colors.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
    // Blender's exporter writes MikkTSpace tangents (it computes them with MikkTSpace too):
    // camsim's MikkTSpace, on the same vertices, agrees with the file's TANGENT.
    assert_eq!(p_mikk.len(), 54, "MikkTSpace split vertices");
    assert_eq!(c_mikk.as_ref().map(Vec::len), Some(54));
    let mut worst = 0f32;
    for (a, b) in t_file.iter().zip(t_mikk) {
        assert_eq!(a[3], b[3], "handedness {a:?} vs {b:?}");
        worst = worst.max((0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f32::max));
    }
    assert!(worst < 1e-3, "worst tangent difference {worst}");
}

#[test]
fn color_0_alpha_multiplies_the_alpha() {
    // BLEND (stochastic): a fraction alpha of the paths stop at the quad, the rest see the black
    // below it, so L = alpha rho E / pi; MASK: all or nothing at the cutoff, after the product.
    let e_lux = 10_000.0;
    let want = grid_fraction() * 0.5 * e_lux / PI;
    let q = |a: u8| Quad {
        color_u8: Some([[255, 255, 255, a]; 4]),
        ..Default::default()
    };
    let mat = |mode: &str| {
        lambertian([0.5; 3], "").replacen(
            r#""extensions""#,
            &format!(r#""alphaMode": "{mode}", "alphaCutoff": 0.5, "extensions""#),
            1,
        )
    };
    let blend = mean(&render(
        &gltf(&q(64), &mat("BLEND"), &[], Some((e_lux, DOWN))),
        8,
        64,
    ));
    let alpha = 64.0 / 255.0;
    assert!(
        (blend / (alpha * want) - 1.0).abs() < 0.05,
        "BLEND: {blend} vs {} cd/m^2",
        alpha * want
    );
    let cut = mean(&render(
        &gltf(&q(64), &mat("MASK"), &[], Some((e_lux, DOWN))),
        4,
        16,
    ));
    assert!(cut < 1e-3 * want, "MASK below the cutoff: {cut} cd/m^2");
    let kept = mean(&render(
        &gltf(&q(192), &mat("MASK"), &[], Some((e_lux, DOWN))),
        4,
        16,
    ));
    assert!(
        (kept / want - 1.0).abs() < 0.02,
        "MASK above: {kept} vs {want} cd/m^2"
    );
}

/// `KHR_texture_transform` (offset, rotation about the origin, scale: uv' = T R S uv) is baked
/// into the uv set its texture reads, on either set: here the base colour's on TEXCOORD_0 and the
/// emissive texture's on TEXCOORD_1, against the closed form; a second texture on a set with
/// another transform is noted.
#[test]
fn texture_transforms_are_baked_into_each_uv_set() {
    let uv: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let q = Quad {
        uv0: Some(uv),
        uv1: Some(uv),
        ..Default::default()
    };
    let xf = |o: [f64; 2], r: f64, s: [f64; 2]| {
        format!(
            r#""extensions": {{"KHR_texture_transform": {{"offset": [{}, {}], "rotation": {r}, "scale": [{}, {}]}}}}"#,
            o[0], o[1], s[0], s[1]
        )
    };
    let (o0, r0, s0) = ([0.5, 0.25], std::f64::consts::FRAC_PI_2, [2.0, 3.0]);
    let (o1, r1, s1) = ([0.0, 0.5], 0.0, [0.5, 0.5]);
    let material = |mr: &str| {
        format!(
            r#"{{"name": "moved", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "texCoord": 0, {}}}{mr}}}, "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0, "texCoord": 1, {}}}}}"#,
            xf(o0, r0, s0),
            xf(o1, r1, s1)
        )
    };
    let s = read(&gltf(&q, &material(""), &[black_white()], None)).unwrap();
    let Geometry::Triangles { uvs, uvs1, .. } = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    // The extension's matrix: u' = cos r s_u u + sin r s_v v + o_u,
    // v' = -sin r s_u u + cos r s_v v + o_v; camsim stores (u', 1 - v').
    let want = |o: [f64; 2], r: f64, s: [f64; 2]| -> Vec<[f32; 2]> {
        uv.iter()
            .map(|p| {
                let (u, v) = (p[0] as f64 * s[0], p[1] as f64 * s[1]);
                let (c, sn) = (r.cos(), r.sin());
                [
                    (c * u + sn * v + o[0]) as f32,
                    (1.0 - (-sn * u + c * v + o[1])) as f32,
                ]
            })
            .collect()
    };
    let close = |got: &[[f32; 2]], want: &[[f32; 2]]| {
        got.len() == want.len()
            && got
                .iter()
                .zip(want)
                .all(|(a, b)| (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6)
    };
    let w0 = want(o0, r0, s0);
    assert!(close(uvs.as_deref().unwrap(), &w0), "{uvs:?} vs {w0:?}");
    let w1 = want(o1, r1, s1);
    assert!(close(uvs1.as_deref().unwrap(), &w1), "{uvs1:?} vs {w1:?}");
    assert!(
        !s.notes.iter().any(|n| n.contains("KHR_texture_transform")),
        "{:?}",
        s.notes
    );
    // A metallic-roughness texture on set 0 without the base colour's transform: noted.
    let s = read(&gltf(
        &q,
        &material(r#", "metallicRoughnessTexture": {"index": 0, "texCoord": 0}"#),
        &[black_white()],
        None,
    ))
    .unwrap();
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("metallicRoughnessTexture and baseColorTexture read TEXCOORD_0")),
        "{:?}",
        s.notes
    );
}

/// The extension's own `texCoord` overrides the texture's (KHR_texture_transform): a base colour
/// texture on `texCoord` 0 whose transform names set 1 reads TEXCOORD_1.
#[test]
fn a_texture_transforms_tex_coord_overrides_the_textures() {
    let q = Quad {
        uv0: Some([[0.25, 0.5]; 4]),
        uv1: Some([[0.75, 0.5]; 4]),
        ..Default::default()
    };
    let m = lambertian(
        [1.0; 3],
        r#", "baseColorTexture": {"index": 0, "texCoord": 0, "extensions": {"KHR_texture_transform": {"texCoord": 1}}}"#,
    );
    let s = read(&gltf(&q, &m, &[black_white()], None)).unwrap();
    let Geometry::Triangles { uvs, .. } = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    assert_eq!(uvs.as_deref(), Some(&[[0.75f32, 0.5]; 4][..]));
}
