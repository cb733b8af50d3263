//! pbrt-v4 materials in the scene reader: every supported material with pbrt-v4's parameter
//! names and defaults, named metal and glass spectra, and errors with file:line:column.

use camsim_pbrt::{self as pbrt, PbrtError};
use camsim_scene3d::{ConductorOptics, Material, Roughness, SceneDescription, Texture};

fn parse(text: &str) -> Result<SceneDescription, PbrtError> {
    pbrt::parse_str(text, "/tmp/virtual/materials.pbrt")
}

const HEAD: &str = "Camera \"perspective\" \"float fov\" 45\nWorldBegin\n";

fn named<'a>(s: &'a SceneDescription, n: &str) -> &'a Material {
    &s.materials[s.named_materials[n]]
}

#[test]
fn every_material_parses_with_pbrt_v4_parameters() {
    let text = format!(
        "{HEAD}\
MakeNamedMaterial \"copper\" \"string type\" \"conductor\"\n\
MakeNamedMaterial \"gold\" \"string type\" \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"float uroughness\" 0.04 \"float vroughness\" 0.09\n\
MakeNamedMaterial \"tinted\" \"string type\" \"conductor\" \"rgb reflectance\" [0.9 0.6 0.3] \"float roughness\" 0.01 \"bool remaproughness\" false\n\
MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"float eta\" 1.5\n\
MakeNamedMaterial \"bk7\" \"string type\" \"dielectric\" \"spectrum eta\" \"glass-BK7\" \"float roughness\" 0.1\n\
MakeNamedMaterial \"window\" \"string type\" \"thindielectric\"\n\
MakeNamedMaterial \"leaf\" \"string type\" \"diffusetransmission\" \"rgb transmittance\" [0.2 0.5 0.1] \"float scale\" 0.9\n\
MakeNamedMaterial \"paint\" \"string type\" \"coateddiffuse\" \"rgb reflectance\" [0.7 0.1 0.1] \"float roughness\" 0.05 \"float thickness\" 0.02 \"integer maxdepth\" 5\n\
MakeNamedMaterial \"blend\" \"string type\" \"mix\" \"string materials\" [\"copper\" \"paint\"] \"float amount\" 0.3\n\
MakeNamedMaterial \"none\" \"string type\" \"interface\"\n\
Texture \"bumps\" \"float\" \"fbm\"\n\
Material \"diffuse\" \"texture bumpmap\" \"bumps\"\n\
Shape \"sphere\"\n"
    );
    let s = parse(&text).unwrap();
    // Conductor defaults: copper (pbrt-v4 metal-Cu-eta / metal-Cu-k), smooth, remapped.
    match named(&s, "copper") {
        Material::Conductor {
            optics: ConductorOptics::EtaK { eta, k },
            roughness,
        } => {
            // Johnson & Christy 1972 copper at 620 nm: n ~ 0.27, k ~ 3.2 (interpolated).
            assert!(
                (eta.eval(620.0) - 0.27).abs() < 0.05 && (k.eval(620.0) - 3.26).abs() < 0.1,
                "{} {}",
                eta.eval(620.0),
                k.eval(620.0)
            );
            assert_eq!(
                *roughness,
                Roughness {
                    u: 0.0,
                    v: 0.0,
                    remap: true
                }
            );
        }
        m => panic!("copper: {m:?}"),
    }
    match named(&s, "gold") {
        Material::Conductor {
            optics: ConductorOptics::EtaK { eta, .. },
            roughness,
        } => {
            assert!(
                eta.eval(700.0) < 0.2 && eta.eval(450.0) > 1.3,
                "gold's eta drops in the red"
            );
            assert_eq!((roughness.u, roughness.v), (0.04, 0.09));
            assert_eq!(roughness.alphas(), (0.2, 0.3));
        }
        m => panic!("gold: {m:?}"),
    }
    match named(&s, "tinted") {
        Material::Conductor {
            optics: ConductorOptics::Reflectance(Texture::Constant(_)),
            roughness,
        } => {
            assert_eq!(
                roughness.alphas(),
                (0.01, 0.01),
                "remaproughness false keeps alpha = roughness"
            );
        }
        m => panic!("tinted: {m:?}"),
    }
    match named(&s, "glass") {
        Material::Dielectric { eta, roughness } => {
            assert_eq!((eta.eval(400.0), eta.eval(800.0)), (1.5, 1.5));
            assert_eq!(roughness.alphas(), (0.0, 0.0));
        }
        m => panic!("glass: {m:?}"),
    }
    match named(&s, "bk7") {
        Material::Dielectric { eta, roughness } => {
            assert!(
                (eta.eval(587.56) - 1.5168).abs() < 2e-4,
                "BK7 n_d {}",
                eta.eval(587.56)
            );
            assert!(eta.eval(450.0) > eta.eval(650.0), "normal dispersion");
            assert_eq!(roughness.u, 0.1);
        }
        m => panic!("bk7: {m:?}"),
    }
    assert!(
        matches!(named(&s, "window"), Material::ThinDielectric { eta } if eta.eval(550.0) == 1.5)
    );
    match named(&s, "leaf") {
        Material::DiffuseTransmission {
            reflectance: Texture::Constant(r),
            transmittance: Texture::Constant(_),
            scale,
        } => {
            assert_eq!(
                (r.eval(550.0), *scale),
                (0.25, 0.9),
                "pbrt-v4 default reflectance 0.25"
            );
        }
        m => panic!("leaf: {m:?}"),
    }
    match named(&s, "paint") {
        Material::CoatedDiffuse {
            roughness,
            eta,
            thickness,
            walk,
            ..
        } => {
            assert_eq!((roughness.u, *eta, *thickness), (0.05, 1.5, 0.02));
            // pbrt-v4 LayeredBxDF parameters: maxdepth given, nsamples and g defaulted.
            assert_eq!((walk.max_depth, walk.n_samples, walk.g), (5, 1, 0.0));
        }
        m => panic!("paint: {m:?}"),
    }
    match named(&s, "blend") {
        Material::Mix { materials, amount } => {
            assert_eq!(
                *materials,
                [s.named_materials["copper"], s.named_materials["paint"]]
            );
            assert_eq!(*amount, 0.3);
        }
        m => panic!("blend: {m:?}"),
    }
    assert!(matches!(named(&s, "none"), Material::Interface));
    // bumpmap (pbrt-v3's name for displacement): a bump-mapped diffuse material.
    match &s.materials[s.shapes[0].material] {
        Material::Bumped {
            material,
            perturbation: camsim_scene3d::scene::NormalPerturbation::Displacement(_),
        } => assert!(matches!(s.materials[*material], Material::Diffuse { .. })),
        m => panic!("bump-mapped diffuse: {m:?}"),
    }
    assert!(
        !s.notes.iter().any(|n| n.contains("maxdepth")),
        "maxdepth is read, not ignored: {:?}",
        s.notes
    );
}

#[test]
fn the_default_material_scene_renders_with_every_material() {
    // Each material on a sphere under a uniform sky: the scene must compile and render.
    for m in [
        "\"conductor\" \"float roughness\" 0.2",
        "\"conductor\" \"spectrum eta\" \"metal-Ag-eta\" \"spectrum k\" \"metal-Ag-k\"",
        "\"conductor\" \"spectrum eta\" \"metal-Al-eta\" \"spectrum k\" \"metal-Al-k\"",
        "\"dielectric\" \"spectrum eta\" \"glass-BK7\"",
        "\"dielectric\" \"float roughness\" 0.3",
        "\"thindielectric\" \"float eta\" 1.33",
        "\"diffusetransmission\"",
        "\"coateddiffuse\" \"float roughness\" 0.1",
        "\"interface\"",
    ] {
        let text = format!(
            "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nSampler \"independent\" \"integer pixelsamples\" 4\n{HEAD}\
             LightSource \"infinite\" \"rgb L\" [1 1 1]\nMaterial {m}\nTranslate 0 0 5\nShape \"sphere\"\n"
        );
        let s = parse(&text).unwrap_or_else(|e| panic!("{m}: {e}"));
        let out = camsim_render::render(&s, &|_, _| {}).unwrap_or_else(|e| panic!("{m}: {e}"));
        assert!(
            out.radiance.data.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{m}: bad radiance"
        );
    }
}

#[test]
fn material_errors_name_file_line_and_column() {
    let cases: &[(&str, usize, usize, &str)] = &[
        // Unknown parameter: pbrt-v4 reports unused parameters.
        ("Material \"conductor\"\n  \"float roughnes\" 0.1\n", 4, 3, "roughnes"),
        ("Material \"dielectric\" \"float eta\" 1.5 \"rgb reflectance\" [1 1 1]\n", 3, 39, "reflectance"),
        ("Material \"coateddiffuse\" \"integer nsamples\" 0\n", 3, 26, "nsamples"),
        ("Material \"coatedconductor\" \"float g\" 1\n", 3, 28, "\"g\""),
        ("Material \"conductor\" \"rgb reflectance\" [0.5 0.5 0.5] \"spectrum eta\" \"metal-Au-eta\"\n", 3, 22, "either"),
        ("Material \"dielectric\" \"float eta\" -1\n", 3, 23, "positive"),
        ("Material \"conductor\" \"spectrum eta\" \"metal-Zn-eta\"\n", 3, 22, "metal-Zn-eta"),
        ("Material \"mix\" \"string materials\" [\"a\" \"b\"]\n", 3, 16, "no named material \"a\""),
        ("Material \"measured\"\n", 3, 1, "not supported"),
        (
            "MakeNamedMaterial \"i\" \"string type\" \"interface\"\nMaterial \"mix\" \"string materials\" [\"i\" \"i\"]\n",
            4,
            16,
            "interface",
        ),
        ("Material \"dielectric\" \"texture roughness\" \"r\"\n", 3, 23, "float texture"),
    ];
    for (body, line, col, needle) in cases {
        let e = parse(&format!("{HEAD}{body}")).unwrap_err();
        eprintln!("{e}");
        assert!(e.message.contains(needle), "{body:?}: {e}");
        assert_eq!((e.line, e.column), (*line, *col), "{body:?}: {e}");
        assert!(
            e.to_string()
                .starts_with(&format!("/tmp/virtual/materials.pbrt:{line}:{col}:")),
            "{e}"
        );
    }
}

#[test]
fn mix_cycles_and_bad_values_are_render_errors_not_panics() {
    use camsim_render::{render, RenderError};
    let mut s = parse(&format!(
        "{HEAD}LightSource \"infinite\"\nShape \"sphere\"\n"
    ))
    .unwrap();
    s.settings.samples_per_pixel = 1;
    s.camera.width = 4;
    s.camera.height = 4;
    let m = s.materials.len();
    s.materials.push(Material::Mix {
        materials: [m + 1, 0],
        amount: 0.5,
    });
    s.materials.push(Material::Mix {
        materials: [m, 0],
        amount: 0.5,
    });
    s.shapes[0].material = m;
    assert!(
        matches!(render(&s, &|_, _| {}), Err(RenderError::Material { .. })),
        "mix cycle"
    );
    s.materials[m] = Material::Mix {
        materials: [99, 0],
        amount: 0.5,
    };
    assert!(
        matches!(render(&s, &|_, _| {}), Err(RenderError::Material { .. })),
        "mix index"
    );
    s.materials[m] = Material::Dielectric {
        eta: camsim_core::Spectrum::from_pairs(&[(400.0, 0.0), (700.0, 1.5)]),
        roughness: Roughness::SMOOTH,
    };
    assert!(
        matches!(render(&s, &|_, _| {}), Err(RenderError::Material { .. })),
        "eta 0"
    );
    s.materials[m] = Material::Conductor {
        optics: ConductorOptics::Reflectance(Texture::Constant(camsim_core::Spectrum::from_pairs(
            &[(400.0, 1.0)],
        ))),
        roughness: Roughness {
            u: f64::NAN,
            v: 0.0,
            remap: true,
        },
    };
    assert!(
        matches!(render(&s, &|_, _| {}), Err(RenderError::Material { .. })),
        "NaN roughness"
    );
}

#[test]
fn overlay_replacement_keeps_mix_references_inside_the_inserted_scene() {
    use camsim_scene3d::builtin::{self, BuiltinOptions};
    let mut s = builtin::scene("cornell-box-mcc", &BuiltinOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("obj.pbrt"),
        "WorldBegin\nMakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n\
         MakeNamedMaterial \"b\" \"string type\" \"conductor\"\n\
         MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\" \"b\"]\n\
         NamedMaterial \"m\"\nShape \"sphere\" \"float radius\" 0.1\n",
    )
    .unwrap();
    camsim_pbrt::overlay::apply(
        &mut s,
        "[[object]]\nname = \"tall_block\"\nreplace = { file = \"obj.pbrt\" }\n",
        "t",
        dir.path(),
    )
    .unwrap();
    let sh = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some("tall_block"))
        .unwrap();
    let Material::Mix { materials, .. } = &s.materials[sh.material] else {
        panic!("{:?}", s.materials[sh.material]);
    };
    assert!(matches!(
        s.materials[materials[0]],
        Material::Diffuse { .. }
    ));
    assert!(matches!(
        s.materials[materials[1]],
        Material::Conductor { .. }
    ));
}
