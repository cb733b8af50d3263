//! Material randomization: spectral reflectances drawn from a set, roughness and metallic from
//! ranges, one draw per object, keyed by (seed, entry, instance), wrappers kept.

use camsim_compose::materials::{apply, MaterialRandomSpec};
use camsim_scene3d::builtin::{scene, BuiltinOptions};
use camsim_scene3d::{FloatTexture, Material, SceneDescription, Texture};
use std::path::Path;

fn cornell() -> SceneDescription {
    scene("cornell-box", &BuiltinOptions::default()).unwrap()
}

fn blocks(reflectances: Option<&str>) -> MaterialRandomSpec {
    MaterialRandomSpec {
        objects: Some("*_block".into()),
        reflectances: reflectances.map(str::to_string),
        roughness: Some([0.2, 0.6]),
        metallic: Some([0.0, 0.0]),
        ..Default::default()
    }
}

fn pbr_of<'a>(s: &'a SceneDescription, name: &str) -> &'a camsim_scene3d::GltfPbr {
    let shape = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some(name))
        .unwrap();
    match &s.materials[shape.material] {
        Material::GltfPbr(g) => g,
        other => panic!("{name}: {other:?}"),
    }
}

#[test]
fn each_block_gets_a_colorchecker_reflectance_and_roughness_in_range_and_walls_keep_theirs() {
    let mut s = cornell();
    let floor_before = {
        let f = s
            .shapes
            .iter()
            .find(|x| x.name.as_deref() == Some("floor"))
            .unwrap();
        s.materials[f.material].clone()
    };
    let draws = apply(&mut s, &[blocks(Some("macbeth"))], 11, Path::new(".")).unwrap();
    assert_eq!(draws.len(), 2, "{draws:?}");
    let macbeth = camsim_core::tables::macbeth_reflectances();
    for (d, name) in draws.iter().zip(["short_block", "tall_block"]) {
        assert_eq!(d.object, name);
        let g = pbr_of(&s, name);
        let Texture::Constant(sp) = &g.base_color else {
            panic!("{name}: base colour {:?}", g.base_color)
        };
        let k = macbeth
            .iter()
            .position(|m| m == sp)
            .expect("a ColorChecker spectrum");
        let patch = camsim_core::tables::MACBETH_PATCH_NAMES[k];
        assert_eq!(
            d.reflectance.as_deref(),
            Some(format!("macbeth: {patch}").as_str())
        );
        let FloatTexture::Constant(r) = g.roughness else {
            panic!()
        };
        assert!(
            (0.2..0.6).contains(&r) && d.roughness == Some(r),
            "{r} {d:?}"
        );
        assert_eq!(g.metallic, FloatTexture::Constant(0.0));
    }
    let f = s
        .shapes
        .iter()
        .find(|x| x.name.as_deref() == Some("floor"))
        .unwrap();
    assert_eq!(
        s.materials[f.material], floor_before,
        "the floor was not asked for"
    );
}

#[test]
fn draws_are_uniform_over_the_set_and_keyed_by_seed_and_object() {
    // 480 draws of 24 patches: each patch is expected 20 times; a patch never drawn has
    // probability 24 (23/24)^480 ~ 3e-8, a count beyond 20 +- 5 sigma (4.4) almost as rare.
    let mut counts = [0usize; 24];
    let macbeth = camsim_core::tables::macbeth_reflectances();
    for seed in 0..240u64 {
        let mut s = cornell();
        apply(&mut s, &[blocks(Some("macbeth"))], seed, Path::new(".")).unwrap();
        for name in ["short_block", "tall_block"] {
            let Texture::Constant(sp) = &pbr_of(&s, name).base_color else {
                panic!()
            };
            counts[macbeth.iter().position(|m| m == sp).unwrap()] += 1;
        }
    }
    for (k, c) in counts.iter().enumerate() {
        assert!(
            (1..=42).contains(c),
            "patch {k} drawn {c} times of 480: {counts:?}"
        );
    }
    // The same seed gives the same draw; another object in the entry does not change it.
    let one = |objects: &str| {
        let mut s = cornell();
        let mut spec = blocks(Some("macbeth"));
        spec.objects = Some(objects.into());
        apply(&mut s, &[spec], 5, Path::new(".")).unwrap();
        pbr_of(&s, "tall_block").clone()
    };
    assert_eq!(one("*_block"), one("*_block"));
    assert_eq!(
        one("*_block"),
        one("tall_block"),
        "a draw depends on its own key only"
    );
}

#[test]
fn a_spectra_file_is_drawn_from_and_percent_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("paints.csv"),
        "wavelength_nm,red_paint,grey_paint\n380,0.05,0.4\n550,0.08,0.4\n780,0.9,0.4\n",
    )
    .unwrap();
    let mut s = cornell();
    let draws = apply(&mut s, &[blocks(Some("paints.csv"))], 3, dir.path()).unwrap();
    for (d, name) in draws.iter().zip(["short_block", "tall_block"]) {
        let Texture::Constant(sp) = &pbr_of(&s, name).base_color else {
            panic!()
        };
        let v = sp.eval(780.0);
        assert!(v == 0.9 || v == 0.4, "{v}");
        assert!(
            d.reflectance.as_deref().unwrap().ends_with("_paint"),
            "{d:?}"
        );
    }
    std::fs::write(
        dir.path().join("percent.csv"),
        "wavelength_nm,red\n400,5\n700,90\n",
    )
    .unwrap();
    let e = apply(
        &mut cornell(),
        &[blocks(Some("percent.csv"))],
        3,
        dir.path(),
    )
    .unwrap_err();
    assert!(
        e.key == "compose.materials.0.reflectances" && e.message.contains("\"red\""),
        "{e}"
    );
}

#[test]
fn bad_entries_name_their_key() {
    let mut bad = blocks(None);
    bad.roughness = Some([0.5, 1.5]);
    let e = apply(&mut cornell(), &[bad], 1, Path::new(".")).unwrap_err();
    assert_eq!(e.key, "compose.materials.0.roughness", "{e}");
    let mut both = blocks(Some("macbeth"));
    both.textures = Some("tex".into());
    let e = apply(&mut cornell(), &[both], 1, Path::new(".")).unwrap_err();
    assert!(e.message.contains("not both"), "{e}");
    let mut none = blocks(Some("macbeth"));
    none.objects = Some("teapot*".into());
    let e = apply(&mut cornell(), &[none], 1, Path::new(".")).unwrap_err();
    assert_eq!(e.key, "compose.materials.0.objects", "{e}");
    let mut missing = blocks(Some("no-such.csv"));
    missing.objects = None;
    let e = apply(&mut cornell(), &[missing], 1, Path::new(".")).unwrap_err();
    assert!(e.message.contains("no-such.csv"), "{e}");
}

#[test]
fn wrappers_around_the_material_are_kept_and_textures_are_drawn_from_a_folder() {
    let mut s = cornell();
    let i = s
        .shapes
        .iter()
        .position(|x| x.name.as_deref() == Some("short_block"))
        .unwrap();
    let original = s.shapes[i].material;
    s.materials.push(Material::AlphaMasked {
        material: original,
        alpha: FloatTexture::Constant(0.5),
    });
    s.shapes[i].material = s.materials.len() - 1;
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("tex")).unwrap();
    for (name, rgb) in [("a.png", [255u8, 0, 0]), ("b.png", [0, 0, 255])] {
        image::RgbImage::from_pixel(2, 2, image::Rgb(rgb))
            .save(dir.path().join("tex").join(name))
            .unwrap();
    }
    let spec = MaterialRandomSpec {
        objects: Some("short_block".into()),
        textures: Some("tex".into()),
        ..Default::default()
    };
    let draws = apply(&mut s, &[spec], 2, dir.path()).unwrap();
    let Material::AlphaMasked { material, alpha } = &s.materials[s.shapes[i].material] else {
        panic!(
            "the cut-out was lost: {:?}",
            s.materials[s.shapes[i].material]
        )
    };
    assert_eq!(*alpha, FloatTexture::Constant(0.5));
    let Material::GltfPbr(g) = &s.materials[*material] else {
        panic!()
    };
    let Texture::Image { rgb, .. } = &g.base_color else {
        panic!("{:?}", g.base_color)
    };
    let drawn = draws[0].texture.as_ref().unwrap();
    // sRGB 255 decodes to 1, 0 to 0.
    let expect = if drawn.ends_with("a.png") {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    assert_eq!(rgb[0], expect, "{drawn:?}");
}
