//! Sphere texture coordinates as pbrt-v4 (4th ed. §6.2.3): u = phi / phi_max, v = (theta -
//! theta_zmin) / (theta_zmax - theta_zmin) in the sphere's object frame, so a full sphere has
//! v = 1 - theta / pi and its texture turns with the sphere. A full sphere and the same sphere cut
//! a hair below its pole (a partial sphere, whose uv code is separate) must render alike, rotated
//! or not.

use camsim_pbrt::parse_str;
use camsim_render::render;

fn image(transform: &str, cut: &str) -> Vec<f64> {
    let text = format!(
        r#"
LookAt 0 -4 1.5  0 0 0  0 0 1
Camera "perspective" "float fov" 30
Sampler "zsobol" "integer pixelsamples" 16
Film "rgb" "integer xresolution" 48 "integer yresolution" 48
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Texture "checks" "spectrum" "checkerboard" "float uscale" 8 "float vscale" 4
    "rgb tex1" [0.8 0.8 0.8] "rgb tex2" [0.05 0.05 0.05]
Material "diffuse" "texture reflectance" "checks"
AttributeBegin
  {transform}
  Shape "sphere" "float radius" 1 {cut}
AttributeEnd
"#
    );
    let scene = parse_str(&text, "sphere-uv.pbrt").unwrap();
    let out = render(&scene, &|_, _| {}).unwrap();
    let img = &out.radiance;
    (0..img.rows * img.cols)
        .map(|p| (0..img.bands()).map(|b| img.band(b)[p] as f64).sum())
        .collect()
}

fn mean_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>() / a.iter().sum::<f64>()
}

#[test]
fn full_and_partial_spheres_share_pbrt_uv_rotated_or_not() {
    for transform in ["", "Rotate 90 1 0 0", "Rotate 40 0 1 1"] {
        let full = image(transform, "");
        let cut = image(transform, "\"float zmax\" 0.99999");
        let d = mean_abs_difference(&full, &cut);
        // A texture flipped in v (4 check rows) or left unrotated differs by tens of percent.
        let flipped = image(transform, "\"float zmax\" 0.99999 \"float phimax\" 180");
        let d_ref = mean_abs_difference(&full, &flipped);
        eprintln!("{transform:?}: full vs cut {d:.5}, vs a half sphere {d_ref:.3}");
        assert!(
            d < 0.01,
            "{transform:?}: full and partial sphere differ by {d}"
        );
        assert!(
            d_ref > 0.1,
            "{transform:?}: the test cannot see a different texture ({d_ref})"
        );
    }
}
