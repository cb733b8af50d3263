//! pbrt-v4 reader: directives, parameter types, Include/Import, named spectra, pbrt-v4's light
//! normalisation, errors with positions, and the Cornell box file against the built-in scene.

use camsim_pbrt::{self as pbrt, PbrtError};
use camsim_scene3d::builtin::{self, BuiltinOptions};
use camsim_scene3d::spectra::photometric;
use camsim_scene3d::{Geometry, Light, Material, SceneDescription, Texture};
use std::path::Path;

const LM_PER_W: f64 = 683.0;

fn parse(text: &str) -> Result<SceneDescription, PbrtError> {
    pbrt::parse_str(text, "/tmp/virtual/test.pbrt")
}

/// Luminance (cd/m^2) of a radiance spectrum: 683 * sum y_bar L over 360-830 nm at 1 nm.
fn luminance(s: &camsim_core::Spectrum) -> f64 {
    LM_PER_W * photometric(s)
}

fn sphere(s: &SceneDescription, i: usize) -> ([f64; 3], f64) {
    match &s.shapes[i].geometry {
        Geometry::Sphere { center, radius } => (*center, *radius),
        // A rotated or mirrored sphere keeps its object frame (for its uv): the full range.
        Geometry::PartialSphere {
            center,
            radius,
            z_min,
            z_max,
            phi_max_deg,
            ..
        } if *z_min == -*radius && *z_max == *radius && *phi_max_deg == 360.0 => (*center, *radius),
        g => panic!("not a sphere: {g:?}"),
    }
}

fn close3(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
}

const WORLD_HEAD: &str = "Camera \"perspective\" \"float fov\" 45\nWorldBegin\n";

#[test]
fn transforms_follow_pbrt_v4() {
    let s = parse(&format!(
        "{WORLD_HEAD}\
         AttributeBegin Translate 1 2 3 Scale 2 2 2 Shape \"sphere\" \"float radius\" 0.5 AttributeEnd\n\
         AttributeBegin Rotate 90 0 0 1 Translate 1 0 0 Shape \"sphere\" AttributeEnd\n\
         AttributeBegin Transform [1 0 0 0  0 1 0 0  0 0 1 0  4 5 6 1] Shape \"sphere\" AttributeEnd\n\
         AttributeBegin Translate 1 0 0 ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  0 1 0 1] Shape \"sphere\" AttributeEnd\n\
         AttributeBegin Translate 7 0 0 CoordinateSystem \"here\" Identity CoordSysTransform \"here\" Shape \"sphere\" AttributeEnd\n\
         AttributeBegin ReverseOrientation Shape \"sphere\" AttributeEnd\n\
         AttributeBegin Scale -1 1 1 Shape \"sphere\" AttributeEnd\n\
         TransformBegin Translate 0 0 9 TransformEnd Shape \"sphere\"\n"
    ))
    .unwrap();
    assert_eq!(s.shapes.len(), 8);
    assert_eq!(sphere(&s, 0), ([1.0, 2.0, 3.0], 1.0));
    assert!(
        close3(sphere(&s, 1).0, [0.0, 1.0, 0.0], 1e-12),
        "{:?}",
        sphere(&s, 1)
    );
    assert!(close3(sphere(&s, 2).0, [4.0, 5.0, 6.0], 0.0));
    assert!(close3(sphere(&s, 3).0, [1.0, 1.0, 0.0], 0.0));
    assert!(close3(sphere(&s, 4).0, [7.0, 0.0, 0.0], 0.0));
    assert!(!s.shapes[0].reverse_orientation && s.shapes[5].reverse_orientation);
    // A mirror flips the orientation (pbrt-v4 transformSwapsHandedness).
    assert!(s.shapes[6].reverse_orientation);
    assert!(close3(sphere(&s, 7).0, [0.0; 3], 0.0));
}

#[test]
fn camera_film_sampler_integrator() {
    let s = parse(
        "Scale -1 1 1\nLookAt 0 1 -5  0 1 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ] \"float lensradius\" 0.01 \"float focaldistance\" 5\n\
         Film \"rgb\" \"integer xresolution\" 64 \"integer yresolution\" [ 48 ] \"string filename\" \"a.exr\" \"float iso\" 100\n\
         Sampler \"stratified\" \"integer xsamples\" 3 \"integer ysamples\" 5 \"bool jitter\" false\n\
         Integrator \"bdpt\" \"integer maxdepth\" 7\nWorldBegin\n",
    )
    .unwrap();
    assert_eq!(
        (s.camera.width, s.camera.height, s.camera.fov_deg),
        (64, 48, 30.0)
    );
    assert_eq!(s.settings.samples_per_pixel, 15);
    assert_eq!(s.settings.max_depth, 7);
    assert_eq!(s.focus_distance_m, Some(5.0));
    // camera_to_world maps the camera origin to the eye, +z toward the target, +x to world -x.
    let c = &s.camera.camera_to_world;
    assert!(close3(c.apply_point([0.0; 3]), [0.0, 1.0, -5.0], 1e-12));
    assert!(close3(
        c.apply_vector([0.0, 0.0, 1.0]),
        [0.0, 0.0, 1.0],
        1e-12
    ));
    assert!(close3(
        c.apply_vector([1.0, 0.0, 0.0]),
        [-1.0, 0.0, 0.0],
        1e-12
    ));
    for key in ["lensradius", "filename", "iso", "bdpt"] {
        assert!(
            s.notes.iter().any(|n| n.contains(key)),
            "no note about {key}: {:?}",
            s.notes
        );
    }
    // Defaults of pbrt-v4.
    let d = parse("WorldBegin\n").unwrap();
    assert_eq!(
        (d.camera.width, d.camera.height, d.camera.fov_deg),
        (1280, 720, 90.0)
    );
    assert_eq!(
        (d.settings.samples_per_pixel, d.settings.max_depth),
        (16, 5)
    );
}

#[test]
fn meshes_and_parameter_types() {
    let s = parse(&format!(
        "{WORLD_HEAD}\
         #ObjectName quad:Vector(0,0,0)\n\
         Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 1 1 0 0 1 0] \"integer indices\" [0 1 2 0 2 3]\n\
         \"point2 uv\" [0 0 1 0 1 1 0 1] \"normal N\" [0 0 -1 0 0 -1 0 0 -1 0 0 -1] \"bool dummy\" false\n"
    ));
    // An unknown parameter is an error (pbrt-v4 "unused parameter"), naming it and its position.
    let e = s.unwrap_err();
    assert!(e.message.contains("dummy") && e.line == 5, "{e}");
    let s = parse(&format!(
        "{WORLD_HEAD}\
         #ObjectName quad:Vector(0,0,0)\n\
         Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 1 1 0 0 1 0] \"integer indices\" [0 1 2 0 2 3]\n\
         \"point2 uv\" [0 0 1 0 1 1 0 1] \"normal N\" [0 0 -1 0 0 -1 0 0 -1 0 0 -1]\n\
         Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"point2 uv\" [0 0 1 0 0 1 1 1]\n\
         Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
    ))
    .unwrap();
    assert_eq!(s.shapes[0].name.as_deref(), Some("quad"));
    match &s.shapes[0].geometry {
        Geometry::Triangles {
            positions,
            indices,
            uvs,
            normals,
            ..
        } => {
            assert_eq!(positions.len(), 4);
            assert_eq!(uvs.as_ref().unwrap()[2], [1.0, 1.0]);
            // Winding faces the shading normal (-z): pbrt-v4 faces n toward N.
            for t in indices {
                let (a, b, c) = (
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                );
                let nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                assert!(nz < 0.0);
            }
            assert_eq!(normals.as_ref().unwrap()[0], [0.0, 0.0, -1.0]);
        }
        g => panic!("{g:?}"),
    }
    match &s.shapes[1].geometry {
        // One bilinear patch -> two triangles covering the unit square (area 1).
        Geometry::Triangles { indices, .. } => assert_eq!(indices.len(), 2),
        g => panic!("{g:?}"),
    }
    assert!((camsim_scene3d::xform::shape_area(&s.shapes[1].geometry) - 1.0).abs() < 1e-12);
    assert!((camsim_scene3d::xform::shape_area(&s.shapes[2].geometry) - 0.5).abs() < 1e-12);
}

#[test]
fn materials_textures_and_spectra() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("refl.spd"),
        "# a reflectance\n400 0.2\n700 0.6\n",
    )
    .unwrap();
    // A 2 x 1 PNG: sRGB-encoded 8-bit values 188 (0.5 linear) and 255.
    let img = image::RgbImage::from_raw(2, 1, vec![188, 188, 188, 255, 0, 0]).unwrap();
    img.save(dir.path().join("tex.png")).unwrap();
    let text = format!(
        "{WORLD_HEAD}\
         Texture \"checks\" \"spectrum\" \"imagemap\" \"string filename\" \"tex.png\" \"float uscale\" 2 \"float vdelta\" 0.5\n\
         Texture \"lin\" \"spectrum\" \"imagemap\" \"string filename\" \"tex.png\" \"string encoding\" \"linear\"\n\
         Texture \"k\" \"spectrum\" \"constant\" \"rgb value\" [0.25 0.25 0.25]\n\
         Texture \"f\" \"float\" \"constant\" \"float value\" 0.5\n\
         MakeNamedMaterial \"a\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.8 0.2 0.1]\n\
         MakeNamedMaterial \"b\" \"string type\" \"diffuse\" \"spectrum reflectance\" [400 0.1 500 0.5 700 0.9]\n\
         MakeNamedMaterial \"c\" \"string type\" \"diffuse\" \"spectrum reflectance\" \"refl.spd\"\n\
         MakeNamedMaterial \"d\" \"string type\" \"diffuse\" \"blackbody reflectance\" 5000\n\
         MakeNamedMaterial \"e\" \"string type\" \"diffuse\" \"texture reflectance\" \"checks\"\n\
         MakeNamedMaterial \"g\" \"string type\" \"diffuse\" \"texture reflectance\" \"lin\"\n\
         Material \"diffuse\" \"texture reflectance\" \"k\"\n\
         Shape \"sphere\"\n\
         NamedMaterial \"later\"\n\
         Shape \"sphere\"\n\
         MakeNamedMaterial \"later\" \"string type\" \"diffuse\"\n"
    );
    let path = dir.path().join("scene.pbrt");
    std::fs::write(&path, &text).unwrap();
    let s = pbrt::parse_file(&path).unwrap();
    let refl = |name: &str| match &s.materials[s.named_materials[name]] {
        Material::Diffuse { reflectance } => reflectance.clone(),
        #[allow(unreachable_patterns)]
        m => panic!("{m:?}"),
    };
    let c = |t: Texture| match t {
        Texture::Constant(s) => s,
        t => panic!("{t:?}"),
    };
    // Inline spectrum: linear interpolation between pairs.
    assert!((c(refl("b")).eval(450.0) - 0.3).abs() < 1e-12);
    // Spectrum file relative to the scene file.
    assert!((c(refl("c")).eval(550.0) - 0.4).abs() < 1e-12);
    // Blackbody: pbrt-v4 normalises to 1 at the peak (Wien: 579.6 nm at 5000 K).
    let bb = c(refl("d"));
    assert!((bb.eval(580.0) - 1.0).abs() < 1e-4 && bb.eval(400.0) < 0.8);
    // RGB reflectance: uplifted, reproduces its colour under D65 and stays in [0, 1].
    let a = c(refl("a"));
    let rgb = camsim_scene3d::uplift::reflectance_to_rgb(&a);
    assert!(
        (rgb[0] - 0.8).abs() < 0.01 && (rgb[1] - 0.2).abs() < 0.01 && (rgb[2] - 0.1).abs() < 0.01,
        "{rgb:?}"
    );
    assert!(a.values.iter().all(|v| (0.0..=1.0).contains(v)));
    // Image texture: sRGB decoding for PNG (188 -> 0.5029), "linear" keeps code/255.
    match refl("e") {
        Texture::Image {
            width,
            height,
            rgb,
            uscale,
            vdelta,
            ..
        } => {
            assert_eq!((width, height, uscale, vdelta), (2, 1, 2.0, 0.5));
            assert!(
                (rgb[0][0] - 0.5029).abs() < 1e-3 && rgb[1] == [1.0, 0.0, 0.0],
                "{rgb:?}"
            );
        }
        t => panic!("{t:?}"),
    }
    match refl("g") {
        Texture::Image { rgb, .. } => assert!((rgb[0][0] - 188.0 / 255.0).abs() < 1e-6),
        t => panic!("{t:?}"),
    }
    // The anonymous material with the constant texture, and a forward NamedMaterial reference.
    let m0 = s.shapes[0].material;
    assert!(
        matches!(&s.materials[m0], Material::Diffuse { reflectance: Texture::Constant(k) } if (k.eval(550.0) - 0.25).abs() < 1e-9)
    );
    assert_eq!(s.shapes[1].material, s.named_materials["later"]);
}

#[test]
fn area_light_normalisation_follows_pbrt_v4() {
    // scale / SpectrumToPhotometric(L): the luminance equals `scale` cd/m^2 for any spectrum.
    for (l, scale) in [
        ("\"blackbody L\" 3000", 2.0),
        ("\"spectrum L\" \"stdillum-A\"", 7.0),
        ("\"spectrum L\" [400 1 700 3]", 0.5),
        ("", 3.0),
    ] {
        let s = parse(&format!(
            "{WORLD_HEAD}AttributeBegin AreaLightSource \"diffuse\" {l} \"float scale\" {scale}\nShape \"sphere\" AttributeEnd\n"
        ))
        .unwrap();
        let lum = luminance(&s.shapes[0].area_light.as_ref().unwrap().radiance);
        assert!((lum / scale - 1.0).abs() < 1e-9, "{l}: {lum}");
    }
    // RGB: only the illuminant counts in SpectrumToPhotometric, so the luminance is the rgb's
    // luminance Y = 0.2126 R + 0.7152 G + 0.0722 B (sRGB), to the accuracy of the uplift.
    let s = parse(&format!(
        "{WORLD_HEAD}AreaLightSource \"diffuse\" \"rgb L\" [2 1 0.5]\nShape \"sphere\"\n"
    ))
    .unwrap();
    let lum = luminance(&s.shapes[0].area_light.as_ref().unwrap().radiance);
    let y = 0.2126 * 2.0 + 0.7152 * 1.0 + 0.0722 * 0.5;
    assert!((lum / y - 1.0).abs() < 0.01, "{lum} vs {y}");
    // power: luminous flux (lm) = pi * area * sides * luminance. Sphere r = 0.5: area pi.
    let s = parse(&format!("{WORLD_HEAD}AreaLightSource \"diffuse\" \"float power\" 100 \"bool twosided\" true\nShape \"sphere\" \"float radius\" 0.5\n")).unwrap();
    let a = s.shapes[0].area_light.as_ref().unwrap();
    assert!(a.two_sided);
    let expect = 100.0 / (std::f64::consts::PI * std::f64::consts::PI * 2.0);
    assert!((luminance(&a.radiance) / expect - 1.0).abs() < 1e-9);
    // A two-triangle quad of area 2 with power: pbrt-v4 normalises each triangle (area 1) on its own.
    let s = parse(&format!(
        "{WORLD_HEAD}AreaLightSource \"diffuse\" \"float power\" 10\nShape \"trianglemesh\" \"point3 P\" [0 0 0 2 0 0 2 1 0 0 1 0] \"integer indices\" [0 1 2 0 2 3]\n"
    ))
    .unwrap();
    assert_eq!(s.shapes.len(), 2);
    for sh in &s.shapes {
        let l = luminance(&sh.area_light.as_ref().unwrap().radiance);
        assert!(
            (l / (10.0 / std::f64::consts::PI) - 1.0).abs() < 1e-9,
            "{l}"
        );
    }
    // Infinite light: illuminance E (lux) -> luminance E / pi.
    let s = parse(&format!(
        "{WORLD_HEAD}LightSource \"infinite\" \"rgb L\" [1 1 1] \"float illuminance\" 31.4159265\n"
    ))
    .unwrap();
    match &s.lights[0] {
        Light::Infinite { radiance } => assert!((luminance(radiance) - 10.0).abs() < 1e-3 * 10.0),
        #[allow(unreachable_patterns)]
        l => panic!("{l:?}"),
    }
}

#[test]
fn named_spectra() {
    let s = parse(&format!("{WORLD_HEAD}AreaLightSource \"diffuse\" \"spectrum L\" \"stdillum-D65\"\nShape \"sphere\"\n")).unwrap();
    let r = &s.shapes[0].area_light.as_ref().unwrap().radiance;
    let d65 = camsim_core::tables::illuminant("D65").unwrap();
    // Same shape as CIE D65.
    for l in [420.0, 500.0, 600.0, 680.0] {
        assert!((r.eval(l) / r.eval(560.0) - d65.eval(l) / d65.eval(560.0)).abs() < 1e-9);
    }
    let e = parse(&format!("{WORLD_HEAD}AreaLightSource \"diffuse\" \"spectrum L\" \"canon_eos_100d_r\"\nShape \"sphere\"\n")).unwrap_err();
    assert!(e.message.contains("canon_eos_100d_r") && e.line == 3, "{e}");
    let e = parse(&format!("{WORLD_HEAD}AreaLightSource \"diffuse\" \"spectrum L\" \"nosuchfile.spd\"\nShape \"sphere\"\n")).unwrap_err();
    assert!(e.message.contains("nosuchfile.spd"), "{e}");
}

#[test]
fn include_import_and_cycles() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(sub.join("geo.pbrt"), "Translate 1 0 0\nShape \"sphere\"\n").unwrap();
    std::fs::write(dir.path().join("main.pbrt"), format!("{WORLD_HEAD}Include \"sub/geo.pbrt\"\nShape \"sphere\"\nImport \"sub/geo.pbrt\"\nShape \"sphere\"\n")).unwrap();
    let s = pbrt::parse_file(dir.path().join("main.pbrt")).unwrap();
    // Include shares the graphics state (the Translate persists), Import does not.
    let c: Vec<f64> = (0..4).map(|i| sphere(&s, i).0[0]).collect();
    assert_eq!(c, vec![1.0, 1.0, 2.0, 1.0]);
    std::fs::write(dir.path().join("a.pbrt"), "Include \"b.pbrt\"\n").unwrap();
    std::fs::write(dir.path().join("b.pbrt"), "\n  Include \"a.pbrt\"\n").unwrap();
    let e = pbrt::parse_file(dir.path().join("a.pbrt")).unwrap_err();
    assert!(
        e.message.contains("cycle") && e.file.ends_with("b.pbrt") && (e.line, e.column) == (2, 3),
        "{e}"
    );
    let e = parse("Include \"missing.pbrt\"").unwrap_err();
    assert!(
        e.message.contains("missing.pbrt") && (e.line, e.column) == (1, 1),
        "{e}"
    );
}

#[test]
fn errors_name_file_line_and_column() {
    let cases: &[(&str, usize, usize, &str)] = &[
        ("WorldBegin\n  Frobnicate 1 2\n", 2, 3, "unknown directive"),
        ("WorldBegin\nMaterial \"measured\"\n", 2, 1, "measured"),
        ("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 2 ]\n", 2, 16, "exactly one"),
        ("WorldBegin\nShape \"sphere\" \"float radius\" abc\n", 2, 31, "not a number"),
        ("WorldBegin\nShape \"sphere\" \"string radius\" \"x\"\n", 2, 16, "radius"),
        ("WorldBegin\nShape \"curve\" \"point3 P\" [0 0 0 1 1 1]\n", 2, 15, "control points"),
        ("WorldBegin\nScale 1 2 1 Shape \"sphere\"\n", 2, 13, "non-uniform"),
        ("Shape \"sphere\"\n", 1, 1, "after WorldBegin"),
        ("WorldBegin\nCamera \"perspective\"\n", 2, 1, "before WorldBegin"),
        ("Camera \"orthographic\"\n", 1, 1, "orthographic"),
        ("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 5]\n", 2, 53, "out of range"),
        ("WorldBegin\nNamedMaterial \"nope\"\nShape \"sphere\"\n", 2, 1, "nope"),
        ("WorldBegin\nShape \"sphere\" \"float radius\" [ 1\n", 2, 16, "missing ']'"),
        ("WorldBegin\n\"float radius\" 1\n", 2, 1, "expected a directive"),
        ("Film \"rgb\" \"rgb xresolution\" [1 2 3]", 1, 12, "xresolution"),
        ("WorldBegin\nMaterial \"diffuse\" \"rgb reflectance\" [1.5 0 0]\n", 2, 20, "> 1"),
        ("WorldBegin\nLightSource \"infinite\" \"string filename\" \"sky.exr\"\n", 2, 1, "sky.exr"),
        ("WorldBegin\nLightSource \"goniometric\"\n", 2, 1, "goniometric"),
        ("WorldEnd\n", 1, 1, "pbrt-v3"),
        ("LookAt 0 0 0 0 0 1 0 0 1\n", 1, 1, "parallel"),
        ("WorldBegin\nShape \"sphere\" \"float radius\" 1 \"float zmin\" 2\n", 2, 1, "leave no surface"),
    ];
    for (text, line, col, needle) in cases {
        let e = parse(text).expect_err(text);
        assert_eq!((e.line, e.column), (*line, *col), "{text:?}: {e}");
        assert!(e.message.contains(needle), "{text:?}: {e}");
        assert!(e.to_string().starts_with("/tmp/virtual/test.pbrt:"), "{e}");
    }
}

/// Triangles of a named shape as sorted vertex triples, plus the oriented normal direction.
fn triangles(s: &SceneDescription, name: &str) -> Vec<([[i64; 3]; 3], [i64; 3])> {
    let mut out = Vec::new();
    for sh in s.shapes.iter().filter(|x| x.name.as_deref() == Some(name)) {
        let Geometry::Triangles {
            positions, indices, ..
        } = &sh.geometry
        else {
            panic!()
        };
        for t in indices {
            let p: Vec<[f64; 3]> = t.iter().map(|&i| positions[i as usize]).collect();
            let mut n = camsim_scene3d::xform::cross(
                camsim_scene3d::xform::sub(p[1], p[0]),
                camsim_scene3d::xform::sub(p[2], p[0]),
            );
            if sh.reverse_orientation {
                n = [-n[0], -n[1], -n[2]];
            }
            let q = |v: [f64; 3]| {
                [
                    (v[0] * 1e7).round() as i64,
                    (v[1] * 1e7).round() as i64,
                    (v[2] * 1e7).round() as i64,
                ]
            };
            let mut v = [q(p[0]), q(p[1]), q(p[2])];
            v.sort();
            let nn = camsim_scene3d::xform::normalize(n);
            out.push((
                v,
                [
                    (nn[0] * 1e3).round() as i64,
                    (nn[1] * 1e3).round() as i64,
                    (nn[2] * 1e3).round() as i64,
                ],
            ));
        }
    }
    out.sort();
    out
}

fn cornell_file() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/pbrt/cornell-box.pbrt")
}

#[test]
fn cornell_file_matches_builtin() {
    let file = pbrt::parse_file(cornell_file()).unwrap();
    let built = builtin::scene("cornell-box", &BuiltinOptions::default()).unwrap();
    for name in [
        "floor",
        "back_wall",
        "left_wall",
        "right_wall",
        "ceiling",
        "light",
        "short_block",
        "tall_block",
    ] {
        let a = triangles(&file, name);
        assert!(!a.is_empty(), "{name}");
        assert_eq!(a, triangles(&built, name), "{name}");
    }
    // Camera: same transform and field of view.
    for r in 0..4 {
        for c in 0..4 {
            assert!(
                (file.camera.camera_to_world.m[r][c] - built.camera.camera_to_world.m[r][c]).abs()
                    < 1e-12
            );
        }
    }
    assert!((file.camera.fov_deg - built.camera.fov_deg).abs() < 1e-5);
    assert_eq!((file.camera.width, file.camera.height), (512, 512));
    // Spectra on the grid: reflectances and the light's absolute radiance.
    let grid = camsim_core::WavelengthGrid::default();
    let refl = |s: &SceneDescription, n: &str| match &s.materials[s.named_materials[n]] {
        Material::Diffuse {
            reflectance: Texture::Constant(x),
        } => x.sample(&grid),
        m => panic!("{m:?}"),
    };
    for n in ["white", "red", "green"] {
        let (a, b) = (refl(&file, n), refl(&built, n));
        assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12), "{n}");
    }
    let light = |s: &SceneDescription| {
        s.shapes
            .iter()
            .find(|x| x.name.as_deref() == Some("light"))
            .unwrap()
            .area_light
            .clone()
            .unwrap()
    };
    let (la, lb) = (light(&file), light(&built));
    assert_eq!(la.two_sided, lb.two_sided);
    for (x, y) in la
        .radiance
        .sample(&grid)
        .iter()
        .zip(lb.radiance.sample(&grid))
    {
        assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-6), "{x} vs {y}");
    }
    // The light's luminance is the built-in level.
    assert!((luminance(&la.radiance) - builtin::DEFAULT_LIGHT_LUMINANCE_CD_M2).abs() < 1e-6);
}

/// The pbrt file renders within noise of the built-in scene (same geometry, spectra, camera).
#[test]
fn cornell_file_renders_like_builtin() {
    let opts = BuiltinOptions {
        resolution: Some((24, 24)),
        samples_per_pixel: 32,
        ..Default::default()
    };
    let mut built = builtin::scene("cornell-box", &opts).unwrap();
    let mut file = pbrt::parse_file(cornell_file()).unwrap();
    file.camera.width = 24;
    file.camera.height = 24;
    file.settings = built.settings.clone();
    file.settings.seed = 1; // independent noise
    built.settings.seed = 2;
    let a = camsim_render::render(&built, &|_, _| {}).unwrap();
    let b = camsim_render::render(&file, &|_, _| {}).unwrap();
    let (ra, rb) = (&a.radiance, &b.radiance);
    assert_eq!(ra.data.len(), rb.data.len());
    // Image mean per band: difference within 4 standard errors (from per-pixel variances).
    let npx = 24 * 24;
    let bands = ra.grid.len();
    for band in (0..bands).step_by(5) {
        let pa = &ra.data[band * npx..(band + 1) * npx];
        let pb = &rb.data[band * npx..(band + 1) * npx];
        let ma: f64 = pa.iter().map(|v| *v as f64).sum::<f64>() / npx as f64;
        let mb: f64 = pb.iter().map(|v| *v as f64).sum::<f64>() / npx as f64;
        // Sample standard deviation of the pixel values bounds the per-pixel noise (includes the
        // image's own structure, so this is a conservative tolerance) -> use the variance output.
        let var_a: f64 = a.variance.iter().map(|v| *v as f64).sum::<f64>() / npx as f64;
        let var_b: f64 = b.variance.iter().map(|v| *v as f64).sum::<f64>() / npx as f64;
        let se = ((var_a + var_b) / npx as f64).sqrt();
        assert!(
            (ma - mb).abs() <= 4.0 * se + 1e-3 * ma.abs(),
            "band {band}: {ma} vs {mb} (se {se})"
        );
    }
}

#[test]
fn ply_ascii_and_binary_round_trip() {
    // A mesh written here: 5 vertices with normals and uv, one triangle and one quad.
    let pos = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.5, 2.0, 0.25],
    ];
    let uv = [
        [0.0f32, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
        [0.5, 0.75],
    ];
    let faces: Vec<Vec<u32>> = vec![vec![0, 1, 2, 3], vec![3, 2, 4]];
    let header = |fmt: &str| {
        format!(
            "ply\nformat {fmt} 1.0\ncomment written by the camsim test\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
             element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let mut ascii = header("ascii");
    for (p, t) in pos.iter().zip(&uv) {
        ascii += &format!("{} {} {} 0 0 1 {} {}\n", p[0], p[1], p[2], t[0], t[1]);
    }
    for f in &faces {
        ascii += &format!(
            "{} {}\n",
            f.len(),
            f.iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    let mut bin = header("binary_little_endian").into_bytes();
    for (p, t) in pos.iter().zip(&uv) {
        for v in [
            p[0] as f32,
            p[1] as f32,
            p[2] as f32,
            0.0,
            0.0,
            1.0,
            t[0],
            t[1],
        ] {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    for f in &faces {
        bin.push(f.len() as u8);
        for i in f {
            bin.extend_from_slice(&(*i as i32).to_le_bytes());
        }
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.ply"), ascii).unwrap();
    std::fs::write(dir.path().join("b.ply"), &bin).unwrap();
    let a = pbrt::ply::read_ply(&dir.path().join("a.ply")).unwrap();
    let b = pbrt::ply::read_ply(&dir.path().join("b.ply")).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.positions, pos.to_vec());
    assert_eq!(a.uvs.as_ref().unwrap(), &uv.to_vec());
    assert_eq!(a.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 4]]);
    assert_eq!(a.quads, 1);
    // Through the scene reader, translated: positions move; area = 1 + |(1,0,0) x (0.5,1,0.25)| / 2.
    std::fs::write(
        dir.path().join("s.pbrt"),
        format!("{WORLD_HEAD}Translate 0 0 5\nShape \"plymesh\" \"string filename\" \"b.ply\"\n"),
    )
    .unwrap();
    let s = pbrt::parse_file(dir.path().join("s.pbrt")).unwrap();
    match &s.shapes[0].geometry {
        Geometry::Triangles { positions, .. } => assert_eq!(positions[4], [0.5, 2.0, 5.25]),
        g => panic!("{g:?}"),
    }
    assert!(
        (camsim_scene3d::xform::shape_area(&s.shapes[0].geometry) - (1.0 + 0.5 * 1.0625f64.sqrt()))
            .abs()
            < 1e-12
    );
    // Truncated binary data and bad indices are errors, not panics.
    assert!(pbrt::ply::parse_ply(&bin[..bin.len() - 3]).is_err());
    let mut bad = bin.clone();
    let n = bad.len();
    bad[n - 4..].copy_from_slice(&99i32.to_le_bytes());
    assert!(pbrt::ply::parse_ply(&bad).unwrap_err().contains("beyond"));
}

#[test]
fn exr_texture_is_read_linear() {
    use exr::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.exr");
    // 3 x 2 pixels, linear values (x + 1) / 10 in R, 0.5 in G, y in B.
    write_rgb_file(&path, 3, 2, |x, y| {
        ((x as f32 + 1.0) / 10.0, 0.5f32, y as f32)
    })
    .unwrap();
    let s = parse_in(
        dir.path(),
        "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"t.exr\" \"float scale\" 2\n\
         Material \"diffuse\" \"texture reflectance\" \"t\"\nShape \"sphere\"\n",
    );
    match &s.materials[s.shapes[0].material] {
        Material::Diffuse {
            reflectance: Texture::Image {
                width, height, rgb, ..
            },
        } => {
            assert_eq!((*width, *height), (3, 2));
            // scale 2, clamped to [0, 1] as pbrt-v4 does for reflectances; no sRGB decoding for EXR.
            assert!(
                (rgb[1][0] - 0.4).abs() < 1e-6 && rgb[1][1] == 1.0 && rgb[4][2] == 1.0,
                "{rgb:?}"
            );
        }
        m => panic!("{m:?}"),
    }
}

fn parse_in(dir: &Path, world: &str) -> SceneDescription {
    let p = dir.join("scene.pbrt");
    std::fs::write(&p, format!("{WORLD_HEAD}{world}")).unwrap();
    pbrt::parse_file(&p).unwrap()
}

#[test]
fn an_empty_scene_file_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nothing.pbrt");
    std::fs::write(&path, "# only a comment\nWorldBegin\n").unwrap();
    let e = pbrt::parse_file(&path).unwrap_err().to_string();
    assert!(e.contains("nothing.pbrt") && e.contains("empty"), "{e}");
}

/// A bilinear mesh without "uv" carries pbrt-v4's per-patch parameterization, (0,0), (1,0), (0,1),
/// (1,1) at p00, p10, p01, p11, on both of its triangles and in every patch, also where patches
/// share vertices: two unit squares side by side sharing their middle edge; at every triangle
/// vertex uv = (x - x0, y) of its own square. (A triangle's default uv, (0,0), (1,0), (1,1) per
/// triangle, would put a texture askew on one of the two triangles.)
#[test]
fn bilinear_mesh_default_uv_is_per_patch() {
    let s = parse(&format!(
        "{WORLD_HEAD}\
         Shape \"bilinearmesh\" \"point3 P\" [0 0 0  1 0 0  2 0 0  0 1 0  1 1 0  2 1 0] \"integer indices\" [0 1 3 4  1 2 4 5]\n"
    ))
    .unwrap();
    let Geometry::Triangles {
        positions,
        indices,
        uvs,
        ..
    } = &s.shapes[0].geometry
    else {
        panic!("triangles")
    };
    let uvs = uvs.as_ref().expect("uv from the patches");
    assert_eq!(indices.len(), 4);
    for (k, t) in indices.iter().enumerate() {
        let x0 = if k < 2 { 0.0 } else { 1.0 };
        for &i in t {
            let (p, uv) = (positions[i as usize], uvs[i as usize]);
            assert_eq!(
                [uv[0] as f64, uv[1] as f64],
                [p[0] - x0, p[1]],
                "triangle {k}, vertex {p:?}"
            );
        }
    }
}
