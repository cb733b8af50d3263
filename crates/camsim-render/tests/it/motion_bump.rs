//! Bump mapping on a moving shape (issue 28): the shading geometry of a hit on a moving
//! primitive is computed in its group's reference pose and moved to the world at the path's
//! time. A constant displacement perturbs nothing (its finite differences vanish, and a plane's
//! normal does not turn), so a tilting plane with one renders as the same plane without it
//! (to rounding), which holds only if the shading frame is moved with the plane; a wrinkled
//! displacement renders (it used to index the static primitives with a moving hit's slot).

use camsim_pbrt::parse_str;
use camsim_render::render;

/// A grey floor tilting by 30 degrees about x during the exposure, lit by a point light and a
/// sky, with the displacement `displacement` (pbrt-v4 parameter text, or "").
fn image(textures: &str, displacement: &str) -> Vec<f32> {
    let text = format!(
        r#"LookAt 0 3 -3  0 0 0  0 1 0
Camera "perspective" "float fov" 50
Sampler "zsobol" "integer pixelsamples" 16
Film "rgb" "integer xresolution" 24 "integer yresolution" 16
WorldBegin
LightSource "infinite" "rgb L" [0.2 0.2 0.2]
LightSource "point" "point3 from" [0.5 2 -0.5] "rgb I" [4 4 4]
{textures}
AttributeBegin
  ActiveTransform EndTime
  Rotate 30 1 0 0
  ActiveTransform All
  Material "diffuse" "rgb reflectance" [0.5 0.5 0.5] {displacement}
  Shape "trianglemesh" "point3 P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 2 1 0 3 2]
AttributeEnd
"#
    );
    let s = parse_str(&text, "tilt.pbrt").unwrap();
    assert_eq!(s.settings.time.shapes.len(), 1, "the floor moves");
    render(&s, &|_, _| {}).unwrap().radiance.data
}

#[test]
fn a_moving_bump_mapped_plane_shades_as_the_moving_plane() {
    let plain = image("", "");
    let flat = image(
        r#"Texture "flat" "float" "constant" "float value" 0.05"#,
        r#""texture displacement" "flat""#,
    );
    let top = plain.iter().fold(0f32, |a, b| a.max(*b));
    let worst = plain
        .iter()
        .zip(&flat)
        .map(|(a, b)| (a - b).abs() / top)
        .fold(0f32, f32::max);
    eprintln!("largest difference, constant displacement against none: {worst:.2e} of the peak");
    assert!(
        worst < 1e-3,
        "a constant displacement changed the image by {worst} of its peak"
    );
    let wrinkled = image(
        r#"Texture "bumps" "float" "wrinkled""#,
        r#""texture displacement" "bumps""#,
    );
    assert!(wrinkled.iter().all(|v| v.is_finite()) && wrinkled.iter().any(|v| *v > 0.0));
}
