//! Bump and normal mapping through the whole chain (pbrt file -> `displacement` / `normalmap`
//! -> the renderer's shading normal), against closed forms (pbrt-v4 4th ed. sec. 10.5.1):
//! - a flat normal map, (0.5, 0.5, 1) everywhere, changes nothing: the render is bit-identical
//!   to the one without it, on every material that takes one;
//! - a Lambertian plane under a distant light, bump-mapped by a displacement linear in u
//!   (`D = a u`, `|dp/du| = L`): its shading normal is tilted by `atan(a / L)` away from dp/du,
//!   so its radiance is the flat plane's times `(n_s . w_l) / cos(beta)`, `w_l` the direction to
//!   the light at `beta` from the geometric normal; a normal map that encodes the same tilted
//!   normal gives the same radiance.

use camsim_pbrt as pbrt;
use camsim_render::render;
use std::path::Path;

/// A `w` x `h` PFM holding `rgb` everywhere (little-endian floats).
fn write_pfm(path: &Path, w: usize, h: usize, rgb: [f32; 3]) {
    let mut b = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for _ in 0..w * h {
        for v in rgb {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, b).unwrap();
}

fn render_file(dir: &Path, text: &str) -> camsim_render::RenderOutput {
    let path = dir.join("scene.pbrt");
    std::fs::write(&path, text).unwrap();
    let s = pbrt::parse_file(&path).unwrap();
    render(&s, &|_, _| {}).unwrap()
}

#[test]
fn a_flat_normal_map_changes_nothing_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    write_pfm(&dir.path().join("flat.pfm"), 5, 3, [0.5, 0.5, 1.0]);
    let scene = |nm: &str| {
        format!(
            "LookAt 0 -3 1.5  0 0 0.3  0 0 1\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 40 \"integer yresolution\" 30\n\
             Sampler \"sobol\" \"integer pixelsamples\" 8\nIntegrator \"path\" \"integer maxdepth\" 4\n\
             WorldBegin\nLightSource \"infinite\" \"rgb L\" [0.3 0.3 0.3]\n\
             AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\nTranslate 0 0 3\n\
             Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n\
             Material \"diffuse\" \"rgb reflectance\" [0.6 0.5 0.4] {nm}\n\
             Shape \"trianglemesh\" \"point3 P\" [-2 -2 0  2 -2 0  2 2 0  -2 2 0] \"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1]\n\
             Material \"coateddiffuse\" \"float roughness\" 0.1 {nm}\n\
             AttributeBegin\nTranslate -0.6 0 0.4\nShape \"sphere\" \"float radius\" 0.4\nAttributeEnd\n\
             Material \"conductor\" \"float roughness\" 0.2 {nm}\n\
             Shape \"trianglemesh\" \"point3 P\" [0.2 -0.3 0.1  1.2 -0.3 0.1  0.7 0.5 0.9] \"integer indices\" [0 1 2] \
             \"normal N\" [0 -0.6 0.8  0.3 -0.6 0.7  0 -0.2 0.98]\n\
             Material \"dielectric\" {nm}\n\
             AttributeBegin\nTranslate 0.6 -0.8 0.3\nShape \"sphere\" \"float radius\" 0.25\nAttributeEnd\n"
        )
    };
    let plain = render_file(dir.path(), &scene(""));
    let mapped = render_file(dir.path(), &scene("\"string normalmap\" \"flat.pfm\""));
    let s = pbrt::parse_file(dir.path().join("scene.pbrt")).unwrap();
    assert!(
        s.materials
            .iter()
            .filter(|m| matches!(m, camsim_scene3d::scene::Material::Bumped { .. }))
            .count()
            == 4
    );
    assert!(plain.radiance.data.iter().any(|v| *v > 0.0));
    let bits = |o: &camsim_render::RenderOutput| -> Vec<u32> {
        o.radiance.data.iter().map(|v| v.to_bits()).collect()
    };
    assert!(
        bits(&plain) == bits(&mapped),
        "a flat normal map changed the render"
    );
}

/// Radiance of the plane seen from above (mean over the image and bands).
fn plane_radiance(dir: &Path, beta_deg: f64, material_extra: &str, textures: &str) -> f64 {
    let (sb, cb) = beta_deg.to_radians().sin_cos();
    let out = render_file(
        dir,
        &format!(
            "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
             Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n\
             Sampler \"sobol\" \"integer pixelsamples\" 16\nIntegrator \"path\" \"integer maxdepth\" 1\n\
             WorldBegin\nLightSource \"distant\" \"point3 from\" [{sb} 0 {cb}] \"point3 to\" [0 0 0] \"rgb L\" [1 1 1]\n\
             {textures}\
             Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5] {material_extra}\n\
             Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
        ),
    );
    let d = &out.radiance.data;
    d.iter().map(|v| *v as f64).sum::<f64>() / d.len() as f64
}

#[test]
fn a_lit_bump_mapped_plane_matches_the_tilted_normal_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let beta_deg = 30.0f64;
    let flat = plane_radiance(dir.path(), beta_deg, "", "");
    assert!(flat > 0.0);
    // D = a u with a = 1 on a plane with |dp/du| = 2 (u runs over 2 units of x): the shading
    // normal is (-a/2, 0, 1) normalised.
    let a = 1.0f64;
    let bump = "Texture \"d\" \"float\" \"bilerp\" \"float v00\" 0 \"float v10\" 1 \"float v01\" 0 \"float v11\" 1\n";
    let bumped = plane_radiance(dir.path(), beta_deg, "\"texture displacement\" \"d\"", bump);
    let (sb, cb) = beta_deg.to_radians().sin_cos();
    let k = a / 2.0;
    let want = (cb - k * sb) / (1.0 + k * k).sqrt() / cb;
    let got = bumped / flat;
    eprintln!("bumped / flat radiance {got:.6}, closed form {want:.6}");
    assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
    // The same normal from a normal map: (-sin t, 0, cos t) in (dp/du, n x dp/du, n), tan t = k.
    let t = k.atan();
    write_pfm(
        &dir.path().join("tilt.pfm"),
        2,
        2,
        [
            (0.5 - 0.5 * t.sin()) as f32,
            0.5,
            (0.5 + 0.5 * t.cos()) as f32,
        ],
    );
    let mapped = plane_radiance(
        dir.path(),
        beta_deg,
        "\"string normalmap\" \"tilt.pfm\"",
        "",
    );
    let got = mapped / flat;
    eprintln!("normal-mapped / flat radiance {got:.6}, closed form {want:.6}");
    assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
    // Tilting toward the light brightens (a < 0), and bumpmap is pbrt-v3's name for it.
    let toward = plane_radiance(
        dir.path(),
        beta_deg,
        "\"texture bumpmap\" \"d\"",
        &bump
            .replace("\"float v10\" 1", "\"float v10\" -1")
            .replace("\"float v11\" 1", "\"float v11\" -1"),
    );
    let want = (cb + k * sb) / (1.0 + k * k).sqrt() / cb;
    assert!(
        (toward / flat - want).abs() < 1e-4 * want,
        "{} vs {want}",
        toward / flat
    );
}

#[test]
fn bad_bump_parameters_are_errors_naming_the_line() {
    let head = "Camera \"perspective\"\nWorldBegin\n";
    for (line, what) in [
        (
            "Material \"diffuse\" \"string normalmap\" \"nowhere.png\"",
            "nowhere.png",
        ),
        (
            "Material \"diffuse\" \"texture displacement\" \"nope\"",
            "no float texture named \"nope\"",
        ),
        (
            "Material \"interface\" \"float displacement\" 0.1",
            "displacement",
        ),
        (
            "Material \"diffuse\" \"float displacement\" 0.1 \"float bumpmap\" 0.1",
            "not both",
        ),
    ] {
        let e = pbrt::parse_str(&format!("{head}{line}\nShape \"sphere\"\n"), "b.pbrt")
            .unwrap_err()
            .to_string();
        assert!(e.contains("b.pbrt:3:") && e.contains(what), "{line}: {e}");
    }
}
