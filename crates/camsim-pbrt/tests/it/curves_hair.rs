//! `Shape "curve"` and `Material "hair"` in the scene reader: pbrt-v4's parameters, defaults and
//! segment counts, world-space transformation, the melanin absorption table, and errors naming
//! file, line and column.

use camsim_pbrt::{self as pbrt, PbrtError};
use camsim_scene3d::curves::CurveType;
use camsim_scene3d::{Geometry, HairAbsorption, Material, SceneDescription, Texture};

fn parse(text: &str) -> Result<SceneDescription, PbrtError> {
    pbrt::parse_str(text, "/tmp/virtual/hair.pbrt")
}

const HEAD: &str = "Camera \"perspective\" \"float fov\" 45\nWorldBegin\n";

fn curves(s: &SceneDescription, i: usize) -> &camsim_scene3d::curves::Curves {
    match &s.shapes[i].geometry {
        Geometry::Curves(c) => c,
        g => panic!("shape {i} is {g:?}"),
    }
}

#[test]
fn curves_read_with_pbrt_v4_bases_widths_and_defaults() {
    let text = format!(
        "{HEAD}\
Shape \"curve\" \"point3 P\" [0 0 0  1 0 0  2 1 0  3 1 0]\n\
Shape \"curve\" \"string basis\" \"bspline\" \"string type\" \"cylinder\" \"point3 P\" [0 0 0  1 0 0  2 1 0  3 1 0  4 0 0  5 0 0] \"float width0\" 0.2 \"float width1\" 0.1 \"integer splitdepth\" 1\n\
Shape \"curve\" \"integer degree\" 2 \"point3 P\" [0 0 0  1 1 0  2 0 0  3 1 0  4 0 0] \"float width\" 0.05\n\
AttributeBegin\n\
Translate 10 0 0\n\
Scale 2 2 2\n\
Shape \"curve\" \"string type\" \"ribbon\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0] \"normal N\" [0 0 2  0 1 0]\n\
AttributeEnd\n"
    );
    let s = parse(&text).unwrap();
    // Defaults: Bezier, degree 3, flat, width 1, splitdepth 3; one segment from four points.
    let c = curves(&s, 0);
    assert_eq!(
        (c.kind, c.segments(), c.width_m, c.split_depth),
        (CurveType::Flat, 1, [1.0, 1.0], 3)
    );
    // A cubic B-spline of six points has three segments whose ends lie at (p0 + 4 p1 + p2) / 6.
    let c = curves(&s, 1);
    assert_eq!(
        (c.kind, c.segments(), c.points.len(), c.split_depth),
        (CurveType::Cylinder, 3, 10, 1)
    );
    let b0 = c.points[0];
    assert!((b0[0] - 1.0).abs() < 1e-6 && (b0[1] - 1.0 / 6.0).abs() < 1e-6);
    // Widths per segment: linear in the segment index from width0 to width1.
    let w = c.segment_width_m(1);
    assert!((w[0] - (0.2 - 0.1 / 3.0)).abs() < 1e-6 && (w[1] - (0.2 - 0.2 / 3.0)).abs() < 1e-6);
    // Degree 2 Bezier, 2 + 1 + 2 points: two quadratic segments elevated to cubics.
    let c = curves(&s, 2);
    assert_eq!((c.segments(), c.width_m), (2, [0.05, 0.05]));
    assert!((c.points[1][1] - 2.0 / 3.0).abs() < 1e-6);
    // Ribbon under Translate and a uniform Scale 2: points and width move to world space,
    // normals are normalised.
    let c = curves(&s, 3);
    assert_eq!(c.kind, CurveType::Ribbon);
    assert!((c.points[3][0] - 16.0).abs() < 1e-5 && (c.width_m[0] - 2.0).abs() < 1e-6);
    assert_eq!(c.normals, vec![[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]);
}

#[test]
fn curve_errors_name_the_line() {
    let cases = [
        (
            "Shape \"curve\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0  4 0 0]\n",
            "a degree 3 Bezier curve needs 4 + n * 3",
        ),
        (
            "Shape \"curve\" \"string type\" \"ribbon\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0]\n",
            "ribbon curves need normals",
        ),
        (
            "Shape \"curve\" \"string type\" \"ribbon\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0] \"normal N\" [0 0 1]\n",
            "ribbons need one per segment end (2)",
        ),
        (
            "Shape \"curve\" \"string basis\" \"hermite\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0]\n",
            "basis \"hermite\" is not supported",
        ),
        (
            "Shape \"curve\" \"integer degree\" 4 \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0  4 0 0]\n",
            "only degree 2 and 3",
        ),
        (
            "Shape \"curve\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0] \"float width\" -1\n",
            "must be positive",
        ),
        (
            "AreaLightSource \"diffuse\"\nShape \"curve\" \"point3 P\" [0 0 0  1 0 0  2 0 0  3 0 0]\n",
            "area light on a curve",
        ),
    ];
    for (body, want) in cases {
        let e = parse(&format!("{HEAD}{body}")).unwrap_err().to_string();
        assert!(e.contains(want), "{body}: {e}");
        assert!(e.contains("hair.pbrt:"), "{e}");
    }
}

/// The absorption of a hair material, as read.
fn absorption(s: &SceneDescription, name: &str) -> HairAbsorption {
    match &s.materials[s.named_materials[name]] {
        Material::Hair { absorption, .. } => absorption.clone(),
        m => panic!("{name}: {m:?}"),
    }
}

#[test]
fn hair_reads_sigma_a_color_and_melanin_as_pbrt_v4() {
    let text = format!(
        "{HEAD}\
MakeNamedMaterial \"default\" \"string type\" \"hair\"\n\
MakeNamedMaterial \"black\" \"string type\" \"hair\" \"float eumelanin\" 8 \"float beta_m\" 0.2 \"float alpha\" 3\n\
MakeNamedMaterial \"red\" \"string type\" \"hair\" \"float pheomelanin\" 2\n\
MakeNamedMaterial \"dyed\" \"string type\" \"hair\" \"rgb color\" [0.8 0.3 0.2] \"float eumelanin\" 1\n\
MakeNamedMaterial \"given\" \"string type\" \"hair\" \"rgb sigma_a\" [0.5 1.5 3] \"rgb reflectance\" [0.5 0.5 0.5] \"float eta\" 1.6\n\
Shape \"sphere\"\n"
    );
    let s = parse(&text).unwrap();
    // pbrt-v4 defaults: eumelanin 1.3, eta 1.55, beta_m 0.3, beta_n 0.3, alpha 2 deg.
    match &s.materials[s.named_materials["default"]] {
        Material::Hair {
            eta,
            beta_m,
            beta_n,
            alpha_deg,
            ..
        } => assert_eq!((*eta, *beta_m, *beta_n, *alpha_deg), (1.55, 0.3, 0.3, 2.0)),
        m => panic!("{m:?}"),
    }
    // Melanin: sigma_a = c_e (0.419, 0.697, 1.37) + c_p (0.187, 0.4, 1.05) in linear sRGB, as
    // an unbounded spectrum; its colour under the uplift's white reproduces that RGB.
    let sigma = |n: &str| match absorption(&s, n) {
        HairAbsorption::SigmaA(Texture::Constant(sp)) => sp,
        a => panic!("{n}: {a:?}"),
    };
    for (name, rgb) in [
        ("default", [1.3f64 * 0.419, 1.3 * 0.697, 1.3 * 1.37]),
        ("black", [8.0 * 0.419, 8.0 * 0.697, 8.0 * 1.37]),
        ("red", [2.0 * 0.187, 2.0 * 0.4, 2.0 * 1.05]),
    ] {
        let sp = sigma(name);
        let m = rgb[0].max(rgb[1]).max(rgb[2]);
        let back = camsim_scene3d::uplift::reflectance_to_rgb(&sp.scaled(1.0 / (2.0 * m)));
        for k in 0..3 {
            assert!(
                (back[k] * 2.0 * m - rgb[k]).abs() < 0.01 * m,
                "{name}: channel {k} {} vs {}",
                back[k] * 2.0 * m,
                rgb[k]
            );
        }
    }
    // Blue is absorbed most: blonde to black hair is yellow to brown.
    let b = sigma("black");
    assert!(b.eval(450.0) > b.eval(550.0) && b.eval(550.0) > b.eval(650.0));
    // Colour wins over melanin (with a note), sigma_a over colour.
    assert!(matches!(absorption(&s, "dyed"), HairAbsorption::Color(_)));
    assert!(s
        .notes
        .iter()
        .any(|n| n.contains("\"eumelanin\" ignored since \"color\"")));
    match absorption(&s, "given") {
        HairAbsorption::SigmaA(Texture::Constant(sp)) => {
            assert!(sp.eval(450.0) > sp.eval(650.0));
        }
        a => panic!("{a:?}"),
    }
    let e = parse(&format!(
        "{HEAD}MakeNamedMaterial \"x\" \"string type\" \"hair\" \"float beta_n\" 1.5\n"
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("beta_n 1.5 must lie in [0, 1]") && e.contains("hair.pbrt:3"),
        "{e}"
    );
}
