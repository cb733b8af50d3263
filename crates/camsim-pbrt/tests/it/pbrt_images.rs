//! Image textures in every format pbrt-v4 reads, decoded with pbrt-v4's rules (pbrt-v4
//! `Image::Read`, src/pbrt/util/image.cpp): PNG honours `encoding` (default sRGB), TGA / JPEG /
//! BMP are always sRGB (pbrt-v4 reads them with stb_image), QOI follows its own colour-space
//! flag, EXR / PFM / HDR are linear floats. Expected values are the sRGB transfer function (IEC
//! 61966-2-1) of the code values written, not camsim's decoder.

use camsim_pbrt as pbrt;
use camsim_scene3d::scene::{FloatTexture, Material, TexelFilter, Texture, WrapMode};
use std::path::Path;

/// IEC 61966-2-1 sRGB decoding of a code value in [0, 1].
fn srgb(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The texels of spectrum texture `tex` (the reflectance of named material `tex`) and of float
/// texture `tex`, from a scene with `lines` (Texture directives) and named materials using them.
fn texels(dir: &Path, lines: &str, names: &[&str]) -> (Vec<Vec<[f32; 3]>>, Vec<String>) {
    let mut text = String::from("Camera \"perspective\"\nWorldBegin\n");
    text.push_str(lines);
    for n in names {
        text.push_str(&format!(
            "MakeNamedMaterial \"{n}\" \"string type\" \"diffuse\" \"texture reflectance\" \"{n}\"\n"
        ));
    }
    text.push_str("Shape \"sphere\"\n");
    let path = dir.join("scene.pbrt");
    std::fs::write(&path, text).unwrap();
    let s = pbrt::parse_file(&path).unwrap();
    let out = names
        .iter()
        .map(|n| match &s.materials[s.named_materials[*n]] {
            Material::Diffuse {
                reflectance: Texture::Image { rgb, .. },
            } => rgb.to_vec(),
            m => panic!("{n}: {m:?}"),
        })
        .collect();
    (out, s.notes)
}

#[test]
fn every_image_format_decodes_as_pbrt_v4_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two texels: codes 188 and 64 (grey), 8 bit.
    let codes = [188u8, 64u8];
    let rgb8: Vec<u8> = codes.iter().flat_map(|&c| [c, c, c]).collect();
    let img8 = image::RgbImage::from_raw(2, 1, rgb8.clone()).unwrap();
    img8.save(d.join("t.png")).unwrap();
    img8.save(d.join("t.tga")).unwrap();
    img8.save(d.join("t.bmp")).unwrap();
    // JPEG: flat 8 x 8 blocks decode to their value within one or two codes.
    let flat = image::RgbImage::from_pixel(16, 8, image::Rgb([188, 188, 188]));
    flat.save(d.join("t.jpg")).unwrap();
    // 16-bit PNG: codes 48316 and 16448 of 65535.
    let img16 = image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(
        2,
        1,
        vec![48316, 48316, 48316, 16448, 16448, 16448],
    )
    .unwrap();
    img16.save(d.join("t16.png")).unwrap();
    // QOI with the sRGB and the linear colour-space flag.
    for (name, cs) in [
        ("srgb.qoi", qoi::ColorSpace::Srgb),
        ("lin.qoi", qoi::ColorSpace::Linear),
    ] {
        let bytes = qoi::Encoder::new(&rgb8, 2, 1)
            .unwrap()
            .with_colorspace(cs)
            .encode_to_vec()
            .unwrap();
        std::fs::write(d.join(name), bytes).unwrap();
    }
    // Radiance HDR (RGBE): 0.5 and 0.25 are exact in its 8-bit mantissa.
    let hdr = std::fs::File::create(d.join("t.hdr")).unwrap();
    image::codecs::hdr::HdrEncoder::new(hdr)
        .encode(
            &[
                image::Rgb([0.5f32, 0.5, 0.5]),
                image::Rgb([0.25, 0.25, 0.25]),
            ],
            2,
            1,
        )
        .unwrap();
    // PFM (little-endian, bottom row first) and EXR: linear floats.
    let mut pfm = b"PF\n2 1\n-1.0\n".to_vec();
    for v in [0.5f32, 0.5, 0.5, 0.25, 0.25, 0.25] {
        pfm.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(d.join("t.pfm"), pfm).unwrap();
    exr::prelude::write_rgb_file(d.join("t.exr"), 2, 1, |x, _| {
        let v = if x == 0 { 0.5f32 } else { 0.25 };
        (v, v, v)
    })
    .unwrap();

    let tex = |name: &str, file: &str, extra: &str| {
        format!(
            "Texture \"{name}\" \"spectrum\" \"imagemap\" \"string filename\" \"{file}\" {extra}\n"
        )
    };
    let lines = [
        tex("png", "t.png", ""),
        tex("pnglin", "t.png", "\"string encoding\" \"linear\""),
        tex("pnggamma", "t.png", "\"string encoding\" \"gamma 2.2\""),
        tex("png16", "t16.png", ""),
        tex("tga", "t.tga", ""),
        tex("tgalin", "t.tga", "\"string encoding\" \"linear\""),
        tex("bmp", "t.bmp", ""),
        tex("jpg", "t.jpg", ""),
        tex("qs", "srgb.qoi", ""),
        tex("ql", "lin.qoi", ""),
        tex("hdr", "t.hdr", ""),
        tex("pfm", "t.pfm", ""),
        tex("exr", "t.exr", ""),
    ]
    .concat();
    let names = [
        "png", "pnglin", "pnggamma", "png16", "tga", "tgalin", "bmp", "jpg", "qs", "ql", "hdr",
        "pfm", "exr",
    ];
    let (t, notes) = texels(d, &lines, &names);
    let c = |k: f64| k / 255.0;
    let want: [(f64, f64, f64); 13] = [
        (srgb(c(188.0)), srgb(c(64.0)), 1e-6),
        (c(188.0), c(64.0), 1e-6),
        (c(188.0).powf(2.2), c(64.0).powf(2.2), 1e-6),
        (srgb(48316.0 / 65535.0), srgb(16448.0 / 65535.0), 1e-6),
        (srgb(c(188.0)), srgb(c(64.0)), 1e-6),
        // TGA ignores "encoding": pbrt-v4 reads it as sRGB (with a note here).
        (srgb(c(188.0)), srgb(c(64.0)), 1e-6),
        (srgb(c(188.0)), srgb(c(64.0)), 1e-6),
        // JPEG: a flat image, one value (within the codec's rounding: 2 codes).
        (
            srgb(c(188.0)),
            srgb(c(188.0)),
            srgb(c(190.0)) - srgb(c(188.0)),
        ),
        (srgb(c(188.0)), srgb(c(64.0)), 1e-6),
        (c(188.0), c(64.0), 1e-6),
        (0.5, 0.25, 1e-6),
        (0.5, 0.25, 1e-6),
        (0.5, 0.25, 1e-6),
    ];
    for ((n, texels), (a, b, tol)) in names.iter().zip(&t).zip(want) {
        let (x, y) = (texels[0][0] as f64, texels[1][1] as f64);
        eprintln!("{n}: {x:.6} {y:.6} (want {a:.6} {b:.6})");
        assert!(
            (x - a).abs() <= tol && (y - b).abs() <= tol,
            "{n}: {texels:?}, want {a} {b}"
        );
        assert!(texels.iter().all(|c| c[0] == c[1] && c[1] == c[2]), "{n}");
    }
    assert!(
        notes
            .iter()
            .any(|n| n.contains("encoding \"linear\" ignored for t.tga")),
        "{notes:?}"
    );
}

#[test]
fn texture_wrap_scale_invert_and_float_channels_follow_pbrt_v4() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // R, G, B differ: a float texture filtered "point" reads R (pbrt-v4 `MIPMap::Texel<Float>`:
    // channel 0), one filtered "bilinear" (or "trilinear") their mean (`MIPMap::Bilerp<Float>`:
    // `RGB::Average`).
    let img = image::RgbImage::from_raw(2, 1, vec![255, 0, 0, 51, 102, 153]).unwrap();
    img.save(d.join("c.png")).unwrap();
    let text = "Camera \"perspective\"\nWorldBegin\n\
        Texture \"f\" \"float\" \"imagemap\" \"string filename\" \"c.png\" \"string encoding\" \"linear\" \"float scale\" 0.5 \"string wrap\" \"clamp\" \"string filter\" \"point\"\n\
        Texture \"fi\" \"float\" \"imagemap\" \"string filename\" \"c.png\" \"string encoding\" \"linear\" \"float scale\" 2 \"bool invert\" true\n\
        Texture \"s\" \"spectrum\" \"imagemap\" \"string filename\" \"c.png\" \"string encoding\" \"linear\" \"string wrap\" \"octahedralsphere\" \"string filter\" \"trilinear\"\n\
        Texture \"b\" \"spectrum\" \"imagemap\" \"string filename\" \"c.png\" \"string wrap\" \"black\"\n\
        Material \"diffuse\" \"texture reflectance\" \"s\"\n\
        Shape \"sphere\" \"texture alpha\" \"f\"\n\
        Material \"diffuse\" \"texture reflectance\" \"b\"\n\
        Shape \"sphere\" \"texture alpha\" \"fi\"\n\
        Texture \"e\" \"spectrum\" \"imagemap\" \"string filename\" \"c.png\" \"string filter\" \"ewa\" \"float maxanisotropy\" 4\n\
        Material \"diffuse\" \"texture reflectance\" \"e\"\n\
        Shape \"sphere\" \"texture alpha\" \"f\"\n";
    let path = d.join("scene.pbrt");
    std::fs::write(&path, text).unwrap();
    let s = pbrt::parse_file(&path).unwrap();
    let mut floats = Vec::new();
    let mut wraps = Vec::new();
    for m in &s.materials {
        if let Material::AlphaMasked {
            alpha:
                FloatTexture::Image {
                    values,
                    wrap: w,
                    filter: f,
                    ..
                },
            material,
        } = m
        {
            floats.push((values.clone(), *w, *f));
            if let Material::Diffuse {
                reflectance: Texture::Image { wrap, filter, .. },
            } = &s.materials[*material]
            {
                wraps.push((*wrap, *filter));
            }
        }
    }
    assert_eq!(floats.len(), 3, "{:?}", s.materials);
    // R scaled by 0.5: 0.5 and 0.1; clamp wrap.
    assert!((floats[0].0[0] - 0.5).abs() < 1e-6 && (floats[0].0[1] - 0.1).abs() < 1e-6);
    assert_eq!(floats[0].1, WrapMode::Clamp);
    // "point" is the nearest texel; no filter given is bilinear; both of a MIP level, as
    // pbrt-v4 reads them (not glTF's full-resolution filters).
    assert_eq!(
        (floats[0].2, floats[1].2),
        (TexelFilter::MipPoint, TexelFilter::MipBilinear)
    );
    // Bilinear, inverted after a scale of 2: max(0, 1 - 2 (R + G + B) / 3) = 1/3 and 0.2 (the
    // first channel alone would give 0 and 0.6).
    assert!(
        (floats[1].0[0] - 1.0 / 3.0).abs() < 1e-6 && (floats[1].0[1] - 0.2).abs() < 1e-6,
        "{floats:?}"
    );
    // "trilinear" is MIP-mapped over the pixel footprint; no filter given is bilinear; "ewa"
    // keeps its "maxanisotropy" (pbrt-v4's elliptical filter, no note).
    assert_eq!(
        wraps,
        [
            (WrapMode::OctahedralSphere, TexelFilter::Trilinear),
            (WrapMode::Black, TexelFilter::MipBilinear),
            (
                WrapMode::Repeat,
                TexelFilter::Ewa {
                    max_anisotropy: 4.0
                }
            )
        ]
    );
    assert!(!s.notes.iter().any(|n| n.contains("ewa")), "{:?}", s.notes);
}

#[test]
fn image_errors_name_the_file_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::RgbImage::new(2, 2).save(d.join("ok.png")).unwrap();
    std::fs::write(d.join("bad.tga"), b"not an image").unwrap();
    let cases = [
        ("\"string filename\" \"missing.tga\"", "missing.tga"),
        ("\"string filename\" \"bad.tga\"", "bad.tga"),
        (
            "\"string filename\" \"ok.png\" \"string filter\" \"nearest\"",
            "filter \"nearest\"",
        ),
        (
            "\"string filename\" \"ok.png\" \"string wrap\" \"mirror\"",
            "wrap \"mirror\"",
        ),
        (
            "\"string filename\" \"ok.png\" \"string filter\" \"ewa\" \"float maxanisotropy\" 0.5",
            "\"maxanisotropy\" 0.5 must be a number >= 1",
        ),
        (
            "\"string filename\" \"ok.png\" \"string encoding\" \"gamma -1\"",
            "unknown encoding",
        ),
    ];
    for (params, what) in cases {
        let text = format!(
            "Camera \"perspective\"\nWorldBegin\n\nTexture \"t\" \"spectrum\" \"imagemap\" {params}\n"
        );
        let path = d.join("scene.pbrt");
        std::fs::write(&path, text).unwrap();
        let e = pbrt::parse_file(&path).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("scene.pbrt:4:") && msg.contains(what),
            "{params}: {msg}"
        );
    }
}

/// Bitterli's interiors with TGA textures (`../shared/scenes/bitterli`) load: every imagemap
/// texture is read (pbrt-v4 decodes TGA as sRGB), none is missing.
#[test]
fn bitterli_scenes_with_tga_textures_load() {
    let root = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/bitterli"
    );
    for scene in ["living-room", "veach-ajar"] {
        let path = format!("{root}/{scene}/scene-v4.pbrt");
        let s = pbrt::parse_file(&path).unwrap_or_else(|e| panic!("{scene}: {e}"));
        let images = s
            .materials
            .iter()
            .filter(|m| {
                matches!(
                    m,
                    Material::Diffuse {
                        reflectance: Texture::Image { .. }
                    } | Material::CoatedDiffuse {
                        reflectance: Texture::Image { .. },
                        ..
                    }
                )
            })
            .count();
        eprintln!(
            "{scene}: {} materials, {images} with image textures",
            s.materials.len()
        );
        assert!(images > 0, "{scene}");
    }
}
