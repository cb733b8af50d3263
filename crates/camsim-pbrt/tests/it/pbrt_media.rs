//! Participating media in pbrt-v4 files (issue 27): `MakeNamedMedium` types, parameters,
//! defaults and units as pbrt-v4 reads them, `MediumInterface` on shapes (scoped, forward
//! references), the camera's medium, the measured presets, the integrator notes, the errors;
//! and the `[render] medium` overlay key with the Cornell-box fog example.

use camsim_core::Spectrum;
use camsim_pbrt::spectra::{photometric, rgb_spectrum, SpectrumUse};
use camsim_scene3d::media::{MediumKind, JENSEN_2001};
use camsim_scene3d::{Material, SceneDescription};

fn parse(world: &str) -> SceneDescription {
    camsim_pbrt::parse_str(
        &format!("Camera \"perspective\"\nWorldBegin\n{world}"),
        "/tmp/virtual/media.pbrt",
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn parse_err(text: &str) -> String {
    camsim_pbrt::parse_str(text, "/tmp/virtual/bad.pbrt")
        .unwrap_err()
        .to_string()
}

fn coefficients(s: &SceneDescription, i: usize) -> &camsim_scene3d::media::Coefficients {
    match &s.media.list[i].kind {
        MediumKind::Homogeneous(c) => c,
        k => panic!("{k:?}"),
    }
}

fn close(a: &Spectrum, b: &Spectrum, what: &str) {
    for l in [400.0, 480.0, 550.0, 620.0, 700.0] {
        let (x, y) = (a.eval(l), b.eval(l));
        assert!(
            (x - y).abs() <= 1e-9 * y.abs().max(1.0),
            "{what} at {l} nm: {x} vs {y}"
        );
    }
}

/// pbrt-v4 `HomogeneousMedium::Create`: RGB coefficients are unbounded spectra
/// (`2m S(rgb / 2m)`), `scale` multiplies them, the defaults are 1 per unit length and g 0;
/// `Le` is an illuminant normalised to luminance 1 times `Lescale` (camsim: / 683 lm/W).
#[test]
fn homogeneous_parameters_defaults_and_units() {
    let s = parse(
        "MakeNamedMedium \"tea\" \"string type\" \"homogeneous\" \"float scale\" 2\n\
         \x20 \"rgb sigma_a\" [0.1486 0.321 0.736] \"rgb sigma_s\" [0 0 0] \"float g\" 0.4\n\
         MakeNamedMedium \"glow\" \"string type\" \"homogeneous\" \"blackbody Le\" 3000 \"float Lescale\" 5\n\
         MediumInterface \"tea\" \"\"\n\
         Shape \"sphere\"\n",
    );
    assert_eq!(s.media.list.len(), 2);
    assert_eq!(s.media.list[0].g, 0.4);
    let tea = coefficients(&s, 0);
    let want = rgb_spectrum([0.1486, 0.321, 0.736], SpectrumUse::Unbounded)
        .unwrap()
        .spectrum
        .scaled(2.0);
    close(&tea.sigma_a_per_m, &want, "sigma_a");
    assert_eq!(tea.sigma_s_per_m.max_value(), 0.0);
    assert!(tea.le.is_none());
    // The unbounded uplift keeps the colour's ordering: blue absorbs most.
    assert!(tea.sigma_a_per_m.eval(450.0) > tea.sigma_a_per_m.eval(650.0));
    let glow = coefficients(&s, 1);
    assert_eq!(s.media.list[1].g, 0.0);
    for c in [&glow.sigma_a_per_m, &glow.sigma_s_per_m] {
        assert_eq!(
            (c.eval(400.0), c.eval(700.0)),
            (1.0, 1.0),
            "default 1 per unit"
        );
    }
    let le = glow.le.as_ref().unwrap();
    let luminance = photometric(le) * camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
    assert!((luminance - 5.0).abs() < 1e-9, "Le luminance {luminance}");
}

/// `MediumInterface` is graphics state (scoped by `AttributeBegin`), may name a medium defined
/// later, wraps the shapes whose two sides differ in a shared boundary material, leaves the
/// others alone, nests inside an alpha mask's wrapper, and the outside medium at `Camera` is
/// the camera's (and stays selected after `WorldBegin`, as in pbrt-v4).
#[test]
fn medium_interfaces_on_shapes_and_the_camera() {
    let s = camsim_pbrt::parse_str(
        "MediumInterface \"\" \"fog\"\n\
         Camera \"perspective\"\n\
         WorldBegin\n\
         AttributeBegin\n\
         \x20 MediumInterface \"water\" \"fog\"\n\
         \x20 Material \"dielectric\"\n\
         \x20 Shape \"sphere\" \"float radius\" 1\n\
         \x20 Shape \"sphere\" \"float radius\" 2\n\
         \x20 Shape \"sphere\" \"float radius\" 3 \"float alpha\" 0.5\n\
         AttributeEnd\n\
         Shape \"sphere\" \"float radius\" 4\n\
         MediumInterface \"fog\"\n\
         Shape \"sphere\" \"float radius\" 5\n\
         MakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\n\
         MakeNamedMedium \"water\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0.4 0.05 0.01]\n",
        "/tmp/virtual/mi.pbrt",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let fog = s.media.list.iter().position(|m| m.name == "fog").unwrap();
    let water = s.media.list.iter().position(|m| m.name == "water").unwrap();
    assert_eq!(s.media.camera, Some(fog));
    let m: Vec<&Material> = s
        .shapes
        .iter()
        .map(|sh| &s.materials[sh.material])
        .collect();
    let Material::MediumInterface {
        material,
        inside,
        outside,
    } = m[0]
    else {
        panic!("{:?}", m[0]);
    };
    assert_eq!((*inside, *outside), (Some(water), Some(fog)));
    assert!(matches!(
        s.materials[*material],
        Material::Dielectric { .. }
    ));
    assert_eq!(
        s.shapes[0].material, s.shapes[1].material,
        "one shared wrapper"
    );
    let Material::AlphaMasked {
        material: inner, ..
    } = m[2]
    else {
        panic!("{:?}", m[2]);
    };
    assert_eq!(*inner, s.shapes[0].material, "alpha wraps the boundary");
    // After the block the selection before `Camera` is back (pbrt-v4 keeps it through
    // `WorldBegin`): vacuum inside, fog outside, a boundary; then fog on both sides, which is
    // no transition.
    assert!(
        matches!(m[3], Material::MediumInterface { inside: None, outside: Some(f), .. } if *f == fog),
        "{:?}",
        m[3]
    );
    assert!(matches!(m[4], Material::Diffuse { .. }), "{:?}", m[4]);
}

/// The measured presets: Jensen et al. 2001's values (mm^-1 read per scene unit, sigma_s = the
/// reduced scattering, as pbrt-v4), RGB uplifted as unbounded spectra; pbrt-v4's Narasimhan et
/// al. 2006 names are refused with the reason, unknown names list the known ones, and a preset
/// with explicit coefficients is an unused-parameter error as in pbrt-v4.
#[test]
fn measured_presets() {
    let s = parse("MakeNamedMedium \"skin\" \"string type\" \"homogeneous\" \"string preset\" \"Skin1\"\nMediumInterface \"skin\" \"\"\nShape \"sphere\"\n");
    let p = JENSEN_2001.iter().find(|p| p.name == "Skin1").unwrap();
    assert_eq!(p.sigma_s_prime_per_mm, [0.74, 0.88, 1.01]);
    assert_eq!(p.sigma_a_per_mm, [0.032, 0.17, 0.48]);
    let c = coefficients(&s, 0);
    let up = |v: [f64; 3]| rgb_spectrum(v, SpectrumUse::Unbounded).unwrap().spectrum;
    close(&c.sigma_a_per_m, &up(p.sigma_a_per_mm), "Skin1 sigma_a");
    close(
        &c.sigma_s_per_m,
        &up(p.sigma_s_prime_per_mm),
        "Skin1 sigma_s",
    );

    let head = "Camera \"perspective\"\nWorldBegin\n";
    let e = parse_err(&format!("{head}MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"string preset\" \"Espresso\"\n"));
    assert!(
        e.contains("bad.pbrt:3:1") && e.contains("Narasimhan"),
        "{e}"
    );
    let e = parse_err(&format!(
        "{head}MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"string preset\" \"Tea\"\n"
    ));
    assert!(
        e.contains("unknown preset \"Tea\"") && e.contains("Wholemilk"),
        "{e}"
    );
    let e = parse_err(&format!("{head}MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"string preset\" \"Apple\" \"rgb sigma_a\" [1 1 1]\n"));
    assert!(e.contains("sigma_a"), "{e}");
}

/// Bounded media: `uniformgrid` (density, optional Lescale grid or temperature), `rgbgrid`
/// and `cloud` keep their box `p0`..`p1` in the frame of the CTM at their definition.
#[test]
fn grid_and_cloud_media() {
    let s = parse(
        "Translate 1 2 3\n\
         MakeNamedMedium \"smoke\" \"string type\" \"uniformgrid\" \"integer nx\" 2 \"integer ny\" 1 \"integer nz\" 1\n\
         \x20 \"float density\" [0.5 1] \"point3 p0\" [0 0 0] \"point3 p1\" [2 1 1] \"rgb sigma_s\" [1 1 1]\n\
         MakeNamedMedium \"paint\" \"string type\" \"rgbgrid\" \"rgb sigma_a\" [0.1 0.2 0.3  0.3 0.2 0.1] \"integer nz\" 2\n\
         MakeNamedMedium \"sky\" \"string type\" \"cloud\" \"float wispiness\" 0.5\n\
         MediumInterface \"smoke\" \"paint\"\n\
         Shape \"sphere\"\n\
         MediumInterface \"sky\" \"\"\n\
         Shape \"sphere\"\n",
    );
    let MediumKind::UniformGrid(g) = &s.media.list[0].kind else {
        panic!()
    };
    assert_eq!((g.size.nx, g.size.ny, g.size.nz), (2, 1, 1));
    assert_eq!(g.density, vec![0.5, 1.0]);
    assert_eq!(g.le_scale, vec![1.0]);
    assert_eq!(g.bounds.p1, [2.0, 1.0, 1.0]);
    let p = g.bounds.medium_from_world.apply_point([1.0, 2.0, 3.0]);
    assert!(
        p.iter().all(|v| v.abs() < 1e-12),
        "medium frame = inverse CTM: {p:?}"
    );
    let MediumKind::RgbGrid(r) = &s.media.list[1].kind else {
        panic!()
    };
    assert_eq!(r.sigma_a.as_ref().unwrap().len(), 2);
    assert!(r.sigma_s.is_none());
    let MediumKind::Cloud(c) = &s.media.list[2].kind else {
        panic!()
    };
    assert_eq!((c.density, c.wispiness, c.frequency), (1.0, 0.5, 5.0));

    let head = "Camera \"perspective\"\nWorldBegin\n";
    let e = parse_err(&format!("{head}MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"float density\" [1 1 1] \"integer nx\" 2\n"));
    assert!(e.contains("bad.pbrt:3:1") && e.contains("3 values"), "{e}");
    let e = parse_err(&format!(
        "{head}MakeNamedMedium \"g\" \"string type\" \"uniformgrid\"\n"
    ));
    assert!(e.contains("no \"density\""), "{e}");
    let e = parse_err(&format!(
        "{head}MakeNamedMedium \"n\" \"string type\" \"nanovdb\" \"string filename\" \"x.nvdb\"\n"
    ));
    assert!(e.contains("NanoVDB"), "{e}");
}

/// Errors name the file and line: an undefined medium (at the `MediumInterface`), a
/// redefinition, a missing or unknown type, a phase asymmetry outside (-1, 1), an unused
/// parameter (pbrt-v4 refuses them too).
#[test]
fn media_errors_name_file_and_line() {
    let head = "Camera \"perspective\"\nWorldBegin\n";
    for (body, line, needle) in [
        ("MediumInterface \"tea\" \"\"\nShape \"sphere\"\n", 3, "medium \"tea\" is not defined"),
        ("MakeNamedMedium \"a\" \"string type\" \"homogeneous\"\nMakeNamedMedium \"a\" \"string type\" \"homogeneous\"\n", 4, "redefined"),
        ("MakeNamedMedium \"a\"\n", 3, "no \"string type\""),
        ("MakeNamedMedium \"a\" \"string type\" \"fog\"\n", 3, "unknown type \"fog\""),
        ("MakeNamedMedium \"a\" \"string type\" \"homogeneous\" \"float g\" 1\n", 3, "(-1, 1)"),
        ("MakeNamedMedium \"a\" \"string type\" \"homogeneous\" \"float density\" 2\n", 3, "density"),
    ] {
        let e = parse_err(&format!("{head}{body}"));
        assert!(
            e.contains(&format!("bad.pbrt:{line}:")) && e.contains(needle),
            "{body}: {e}"
        );
    }
}

/// How the integrator is rendered is noted: `volpath` with media by the volumetric path
/// tracer, `path`/`bdpt` with media too (with a note), `volpath` without media by the path
/// tracer.
#[test]
fn integrator_notes() {
    let run = |integrator: &str, media: bool| {
        let world = if media {
            "MakeNamedMedium \"m\" \"string type\" \"homogeneous\"\nMediumInterface \"m\" \"\"\nShape \"sphere\"\n"
        } else {
            "Shape \"sphere\"\n"
        };
        camsim_pbrt::parse_str(
            &format!("Integrator \"{integrator}\"\nCamera \"perspective\"\nWorldBegin\n{world}"),
            "/tmp/virtual/i.pbrt",
        )
        .unwrap()
        .notes
        .join("\n")
    };
    assert!(run("volpath", true).contains("volumetric path tracer"));
    assert!(run("path", true).contains("has participating media"));
    assert!(run("bdpt", true).contains("has participating media"));
    let n = run("volpath", false);
    assert!(
        n.contains("no participating medium") && n.contains("path tracer"),
        "{n}"
    );
}

/// `[render] medium` fills the scene: the camera's medium, homogeneous, coefficients per
/// metre from overlay spectra or a Jensen et al. 2001 preset (mm^-1 -> 1/m, times `scale`);
/// the example fog overlay loads on the built-in Cornell box as written.
#[test]
fn render_medium_overlay_and_the_fog_example() {
    use camsim_scene3d::builtin::{self, BuiltinOptions};
    let base = || builtin::scene("cornell-box-mcc", &BuiltinOptions::default()).unwrap();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/overlays");
    let mut s = base();
    let text = std::fs::read_to_string(dir.join("cornell-fog.toml")).unwrap();
    camsim_pbrt::overlay::apply(&mut s, &text, "cornell-fog.toml", &dir).unwrap();
    let cam = s.media.camera.expect("the fog is the camera's medium");
    assert_eq!(s.media.list[cam].g, 0.3);
    let MediumKind::Homogeneous(c) = &s.media.list[cam].kind else {
        panic!()
    };
    assert_eq!(
        (c.sigma_a_per_m.eval(550.0), c.sigma_s_per_m.eval(550.0)),
        (0.05, 1.5)
    );

    let mut s = base();
    camsim_pbrt::overlay::apply(
        &mut s,
        "[render]\nmedium = { preset = \"Marble\", scale = 0.01 }\n",
        "inline",
        &dir,
    )
    .unwrap();
    let MediumKind::Homogeneous(c) = &s.media.list[0].kind else {
        panic!()
    };
    let want = rgb_spectrum([2.19e3, 2.62e3, 3.00e3], SpectrumUse::Unbounded)
        .unwrap()
        .spectrum
        .scaled(0.01);
    close(&c.sigma_s_per_m, &want, "Marble sigma_s per m");

    for (toml, needle) in [
        ("medium = { g = 1.0, sigma_s_per_m = 1.0 }", "(-1, 1)"),
        ("medium = { preset = \"Espresso\" }", "Narasimhan"),
        (
            "medium = { preset = \"Apple\", sigma_a_per_m = 1.0 }",
            "not both",
        ),
        ("medium = { sigma_a_per_m = 0.0 }", "both zero"),
        ("medium = { sigma_a_per_m = -1.0 }", "non-negative"),
        ("medium = { sigma = 1.0 }", "unknown field"),
    ] {
        let mut s = base();
        let e = camsim_pbrt::overlay::apply(&mut s, &format!("[render]\n{toml}\n"), "inline", &dir)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{toml}: {e}");
    }
}
