//! Overlays: moves, removals, replacements, reflectances and light spectra/levels, camera, and
//! the example overlays (against the files and tables they name).

use camsim_pbrt::overlay;
use camsim_scene3d::builtin::{self, BuiltinOptions};
use camsim_scene3d::spectra::photometric;
use camsim_scene3d::xform::shape_bounds;
use camsim_scene3d::{Material, SceneDescription, Texture};
use std::path::Path;

fn mcc() -> SceneDescription {
    builtin::scene("cornell-box-mcc", &BuiltinOptions::default()).unwrap()
}

fn bounds(s: &SceneDescription, name: &str) -> ([f64; 3], [f64; 3]) {
    let sh = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some(name))
        .unwrap();
    shape_bounds(&sh.geometry)
}

fn refl(s: &SceneDescription, name: &str) -> camsim_core::Spectrum {
    match &s.materials[s.named_materials[name]] {
        Material::Diffuse {
            reflectance: Texture::Constant(k),
        } => k.clone(),
        m => panic!("{m:?}"),
    }
}

fn light(s: &SceneDescription) -> camsim_core::Spectrum {
    s.shapes
        .iter()
        .find(|x| x.name.as_deref() == Some("light"))
        .unwrap()
        .area_light
        .as_ref()
        .unwrap()
        .radiance
        .clone()
}

fn apply(s: &mut SceneDescription, t: &str) -> Result<(), overlay::OverlayError> {
    overlay::apply(s, t, "test.toml", Path::new("/nonexistent"))
}

fn data(p: &str) -> String {
    format!("{}/../../../shared/data/{p}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn moves_rotates_scales_about_the_pivot() {
    let mut s = mcc();
    let (lo, hi) = bounds(&s, "tall_block");
    apply(
        &mut s,
        "[[object]]\nname = \"tall_block\"\ntranslate_m = [0.1, 0.0, -0.02]\n",
    )
    .unwrap();
    let (lo2, hi2) = bounds(&s, "tall_block");
    for k in 0..3 {
        let d = [0.1, 0.0, -0.02][k];
        assert!((lo2[k] - lo[k] - d).abs() < 1e-12 && (hi2[k] - hi[k] - d).abs() < 1e-12);
    }
    // 180 degrees about the vertical through the bbox centre keeps the bounding box.
    let (lo, hi) = bounds(&s, "short_block");
    apply(
        &mut s,
        "[[object]]\nname = \"short_block\"\nrotate = { angle_deg = 180.0, axis = [0, 1, 0] }\n",
    )
    .unwrap();
    let (lo2, hi2) = bounds(&s, "short_block");
    for k in 0..3 {
        assert!((lo2[k] - lo[k]).abs() < 1e-12 && (hi2[k] - hi[k]).abs() < 1e-12);
    }
    // Scale 2 about an explicit pivot on the floor: height doubles, bottom stays.
    apply(
        &mut s,
        "[[object]]\nname = \"short_block\"\nscale = 2\npivot_m = [0.2, 0.0, 0.2]\n",
    )
    .unwrap();
    let (lo3, hi3) = bounds(&s, "short_block");
    assert!(lo3[1].abs() < 1e-12 && (hi3[1] - 0.33).abs() < 1e-12);
    // Wildcards move the whole chart together.
    let before: Vec<_> = (1..=24)
        .map(|i| bounds(&s, &format!("mcc_patch_{i:02}")).0)
        .collect();
    apply(
        &mut s,
        "[[object]]\nname = \"mcc_*\"\ntranslate_m = [0, 0.05, 0]\n",
    )
    .unwrap();
    for (i, b) in before.iter().enumerate() {
        assert!((bounds(&s, &format!("mcc_patch_{:02}", i + 1)).0[1] - b[1] - 0.05).abs() < 1e-12);
    }
}

#[test]
fn removes_and_replaces() {
    let mut s = mcc();
    let n = s.shapes.len();
    apply(&mut s, "[[object]]\nname = \"mcc_*\"\nremove = true\n").unwrap();
    assert_eq!(s.shapes.len(), n - 25);
    // Replace the tall block with a PLY tetrahedron, bottom-aligned, with the red material.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tet.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\n\
         property list uchar int vertex_indices\nend_header\n0 5 0\n1 5 0\n0 6 0\n0 5 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n",
    )
    .unwrap();
    let (lo, hi) = bounds(&s, "tall_block");
    overlay::apply(
        &mut s,
        "[[object]]\nname = \"tall_block\"\nreplace = { file = \"tet.ply\", material = \"red\" }\n",
        "t",
        dir.path(),
    )
    .unwrap();
    let (nlo, nhi) = bounds(&s, "tall_block");
    assert!((nlo[1] - lo[1]).abs() < 1e-12);
    assert!(
        ((nlo[0] + nhi[0]) - (lo[0] + hi[0])).abs() < 1e-12
            && ((nlo[2] + nhi[2]) - (lo[2] + hi[2])).abs() < 1e-12
    );
    assert!((nhi[1] - nlo[1] - 1.0).abs() < 1e-12);
    let sh = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some("tall_block"))
        .unwrap();
    assert_eq!(sh.material, s.named_materials["red"]);
    // Unknown names are errors listing the objects.
    let e = apply(&mut s, "[[object]]\nname = \"teapot\"\nremove = true\n").unwrap_err();
    assert!(
        e.to_string().contains("teapot") && e.to_string().contains("short_block"),
        "{e}"
    );
}

#[test]
fn sets_reflectances_from_tables_constants_and_files() {
    let mut s = mcc();
    apply(
        &mut s,
        &format!(
            "[[material]]\nname = \"white\"\nreflectance = \"macbeth:13\"\n\
             [[material]]\nname = \"green\"\nreflectance = 0.25\n\
             [[material]]\nname = \"red\"\nreflectance = {{ file = \"{}\", column = \"red\" }}\n\
             [[material]]\nname = \"new_grey\"\nreflectance = \"cornell:white\"\n",
            data("isetcornellbox/cboxWalls.csv")
        ),
    )
    .unwrap();
    let m13 = camsim_core::tables::macbeth_patch("13").unwrap();
    assert!((refl(&s, "white").eval(450.0) - m13.eval(450.0)).abs() < 1e-15);
    assert_eq!(refl(&s, "green").eval(620.0), 0.25);
    // cboxWalls.csv, red column: compare with the file's own numbers (read here independently).
    let text = std::fs::read_to_string(data("isetcornellbox/cboxWalls.csv")).unwrap();
    let row = text.lines().find(|l| l.starts_with("500,")).unwrap();
    let red_500: f64 = row.split(',').nth(1).unwrap().parse().unwrap();
    assert!((refl(&s, "red").eval(500.0) - red_500).abs() < 1e-12);
    assert!(s.named_materials.contains_key("new_grey"));
    // The .mat file holds the same numbers (column 1 = red).
    let mut s2 = mcc();
    apply(
        &mut s2,
        &format!(
            "[[material]]\nname = \"red\"\nreflectance = {{ file = \"{}\", column = 1 }}\n",
            data("isetcornellbox/cboxWalls.mat")
        ),
    )
    .unwrap();
    assert!((refl(&s2, "red").eval(500.0) - red_500).abs() < 1e-5);
}

#[test]
fn sets_light_spectrum_and_level() {
    let mut s = mcc();
    let lum = |x: &camsim_core::Spectrum| 683.0 * photometric(x);
    assert!((lum(&light(&s)) - builtin::MCC_LIGHT_LUMINANCE_CD_M2).abs() < 1e-9);
    apply(
        &mut s,
        &format!(
            "[light]\nspectrum = {{ file = \"{}\", column = \"spd\" }}\n",
            data("isetcornellbox/cboxIlluminant.csv")
        ),
    )
    .unwrap();
    // Shape from the file, luminance kept.
    let text = std::fs::read_to_string(data("isetcornellbox/cboxIlluminant.csv")).unwrap();
    let val = |w: &str| -> f64 {
        text.lines()
            .find(|l| l.starts_with(w))
            .unwrap()
            .split(',')
            .nth(1)
            .unwrap()
            .parse()
            .unwrap()
    };
    let l = light(&s);
    assert!((l.eval(450.0) / l.eval(600.0) - val("450,") / val("600,")).abs() < 1e-9);
    assert!((lum(&l) - builtin::MCC_LIGHT_LUMINANCE_CD_M2).abs() < 1e-6);
    apply(
        &mut s,
        "[light]\nname = \"light\"\nluminance_cd_m2 = 21.5\n",
    )
    .unwrap();
    assert!((lum(&light(&s)) - 21.5).abs() < 1e-9);
    apply(
        &mut s,
        "[light]\nradiance_scale = 2.0\nspectrum = { blackbody_k = 3000.0 }\n",
    )
    .unwrap();
    assert!((lum(&light(&s)) - 43.0).abs() < 1e-6);
    assert!(apply(&mut s, "[light]\nname = \"floor\"\nradiance_scale = 2.0\n").is_err());
}

/// `[[light]]` tables apply in order, each to the emitters its `name` matches: the night road's
/// street lamps and headlamps take different CIE lamp spectra and luminances.
#[test]
fn light_tables_apply_in_order_each_to_its_emitters() {
    let mut s = mcc();
    // A second emitter: a copy of the light named "headlamp".
    let mut lamp = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some("light"))
        .unwrap()
        .clone();
    lamp.name = Some("headlamp".into());
    s.shapes.push(lamp);
    apply(
        &mut s,
        "[[light]]\nspectrum = \"HP1\"\nluminance_cd_m2 = 50.0\n\
         [[light]]\nname = \"head*\"\nspectrum = \"LED-B5\"\nluminance_cd_m2 = 2000.0\n",
    )
    .unwrap();
    let of = |name: &str| {
        s.shapes
            .iter()
            .find(|x| x.name.as_deref() == Some(name))
            .unwrap()
            .area_light
            .as_ref()
            .unwrap()
            .radiance
            .clone()
    };
    let lum = |x: &camsim_core::Spectrum| 683.0 * photometric(x);
    let (street, head) = (of("light"), of("headlamp"));
    assert!((lum(&street) - 50.0).abs() < 1e-6 && (lum(&head) - 2000.0).abs() < 1e-6);
    // Sodium is orange (little blue), the 6598 K LED bluish: their 450/600 nm ratios differ.
    let ratio = |l: &camsim_core::Spectrum| l.eval(450.0) / l.eval(600.0);
    assert!(
        ratio(&street) < 0.3 && ratio(&head) > 1.0,
        "{} {}",
        ratio(&street),
        ratio(&head)
    );
    // A bad key inside a [[light]] table keeps its own message.
    let e = apply(&mut s, "[[light]]\nluminance = 3.0\n").unwrap_err();
    assert!(e.to_string().contains("luminance"), "{e}");
}

#[test]
fn camera_render_settings_and_strict_keys() {
    let mut s = mcc();
    apply(
        &mut s,
        "[camera]\nposition_m = [0.278, 0.3, -1.0]\nlook_at_m = [0.278, 0.3, 0.5]\nresolution = [64, 48]\nfov_deg = 30\n\
         [render]\nsamples_per_pixel = 9\nmax_depth = 3\nseed = 5\ngrid = { start_nm = 400, end_nm = 700, step_nm = 20 }\n",
    )
    .unwrap();
    assert_eq!(
        (s.camera.width, s.camera.height, s.camera.fov_deg),
        (64, 48, 30.0)
    );
    assert_eq!(
        (
            s.settings.samples_per_pixel,
            s.settings.max_depth,
            s.settings.seed,
            s.settings.grid.len()
        ),
        (9, 3, 5, 16)
    );
    // An overlay's light sampler overrides the file's (`Integrator` `lightsampler`).
    assert_eq!(
        s.settings.light_sampler,
        camsim_scene3d::scene::LightSampler::Bvh
    );
    apply(&mut s, "[render]\nlight_sampler = \"uniform\"\n").unwrap();
    assert_eq!(
        s.settings.light_sampler,
        camsim_scene3d::scene::LightSampler::Uniform
    );
    let e = apply(&mut s, "[render]\nlight_sampler = \"spatial\"\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("render.light_sampler \"spatial\" is unknown"),
        "{e}"
    );
    // Still a right-handed view: the red wall stays on the left.
    assert!(camsim_scene3d::xform::det3(&s.camera.camera_to_world) < 0.0);
    let eye = s.camera.camera_to_world.apply_point([0.0; 3]);
    assert!((eye[2] + 1.0).abs() < 1e-12);
    // deny_unknown_fields: a misspelt key names itself and its line.
    let e = apply(&mut s, "[camera]\n\npositon_m = [0, 0, 0]\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("positon_m") && e.contains("line 3"), "{e}");
    let e = apply(
        &mut s,
        "[[material]]\nname = \"white\"\nreflectance = \"macbeth:99\"\n",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("macbeth:99") || e.contains("99"), "{e}");
}

#[test]
fn example_overlays_apply() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/overlays");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            let mut s = mcc();
            let text = std::fs::read_to_string(&p).unwrap();
            // Overlays that insert glTF / OBJ assets need the asset reader the pipeline passes
            // (`apply_with`); camsim-pipeline's tests apply them.
            if text.contains(".glb") || text.contains(".gltf") || text.contains(".obj") {
                let e = overlay::apply(&mut s, &text, "x", &dir)
                    .unwrap_err()
                    .to_string();
                assert!(e.contains("asset reader"), "{e}");
                continue;
            }
            overlay::apply(&mut s, &text, &p.display().to_string(), &dir)
                .unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 3);
    // The measured-spectra overlay puts the files' numbers in the scene.
    let mut s = mcc();
    let p = dir.join("isetcornellbox-measured.toml");
    overlay::apply(&mut s, &std::fs::read_to_string(&p).unwrap(), "x", &dir).unwrap();
    let text = std::fs::read_to_string(data("isetcornellbox/cboxWalls.csv")).unwrap();
    let row = text.lines().find(|l| l.starts_with("550,")).unwrap();
    let green: f64 = row.split(',').nth(2).unwrap().parse().unwrap();
    assert!((refl(&s, "green").eval(550.0) - green).abs() < 1e-12);
}
