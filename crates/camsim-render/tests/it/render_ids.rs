//! Object and material id maps (issue 14: segmentation ground truth beside each raw image).
//! Two spheres with named materials in front of a uniform environment: the id maps must agree
//! with the geometry (projected area, depth) and with the rendered colour of each material, and
//! look through alpha cut-outs.

use camsim_pbrt::parse_str;
use camsim_render::render;

const SCENE: &str = r#"
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Sampler "zsobol" "integer pixelsamples" 4
Film "rgb" "integer xresolution" 64 "integer yresolution" 32
PixelFilter "box"
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
MakeNamedMaterial "red" "string type" "diffuse" "rgb reflectance" [0.7 0.05 0.05]
MakeNamedMaterial "blue" "string type" "diffuse" "rgb reflectance" [0.05 0.05 0.7]
AttributeBegin
  NamedMaterial "red"
  Translate -1 0 0
  Shape "sphere" "float radius" 0.5
AttributeEnd
# A fully cut-out quad in front of everything: an alpha texture that is 0 everywhere (pbrt-v4)
# makes it invisible to the id rays as to every other ray.
Texture "cut" "float" "checkerboard" "float tex1" 0 "float tex2" 0
AttributeBegin
  NamedMaterial "blue"
  Shape "trianglemesh" "texture alpha" "cut" "integer indices" [0 1 2 0 2 3]
    "point3 P" [-3 -2 2  3 -2 2  3 2 2  -3 2 2]
AttributeEnd
AttributeBegin
  NamedMaterial "blue"
  Translate 1 0 0
  Shape "sphere" "float radius" 0.5
AttributeEnd
"#;

#[test]
fn id_maps_match_geometry_depth_and_rendered_colour() {
    let scene = parse_str(SCENE, "ids.pbrt").unwrap();
    let out = render(&scene, &|_, _| {}).unwrap();
    let ids = &out.ids;
    let (w, h) = (64usize, 32usize);
    assert_eq!(
        (
            ids.width,
            ids.height,
            ids.object_id.len(),
            ids.material_id.len()
        ),
        (w, h, w * h, w * h)
    );
    // Background: corners see only the environment, depth infinite.
    for p in [0, w - 1, (h - 1) * w, h * w - 1] {
        assert_eq!((ids.object_id[p], ids.material_id[p]), (0, 0));
        assert!(out.depth_m[p].is_infinite());
    }
    // Two objects, each mapped to its own named material.
    let legend = serde_json::to_value(ids.legend()).unwrap();
    let objects = legend["objects"].as_object().unwrap();
    let materials = legend["materials"].as_object().unwrap();
    assert_eq!(objects.len(), 2, "{legend}");
    let mut names: Vec<&str> = materials.values().map(|v| v.as_str().unwrap()).collect();
    names.sort();
    assert_eq!(names, ["blue", "red"], "{legend}");

    // Projected area of each sphere against the closed form: a sphere of radius r whose centre
    // is at distance d, seen at off-axis angle a, covers a disc of angular radius asin(r/d); on the
    // film (focal length f px, f = (h/2) / tan(fov/2), pbrt's fov spans the shorter axis) that is
    // an ellipse of area pi (f tan(asin(r/d)))^2 / cos^3(a) (radial stretch 1/cos^2 a, tangential
    // 1/cos a, to first order).
    let f_px = (h as f64 / 2.0) / 20f64.to_radians().tan();
    let d = 26f64.sqrt();
    let a = (1.0f64 / 5.0).atan();
    let expected = std::f64::consts::PI * (f_px * (0.5 / d).asin().tan()).powi(2) / a.cos().powi(3);
    let band_of = |nm: f64| out.radiance.grid.band_of(nm).unwrap();
    let (b_red, b_blue) = (band_of(650.0), band_of(450.0));
    for (id, name) in materials {
        let id: u32 = id.parse().unwrap();
        let pixels: Vec<usize> = (0..w * h).filter(|&p| ids.material_id[p] == id).collect();
        let area = pixels.len() as f64;
        assert!(
            (area / expected - 1.0).abs() < 0.12,
            "{name}: {area} px against {expected:.1} px"
        );
        // The nearest point of each sphere is 4.5 m along the optical axis.
        let near = pixels
            .iter()
            .map(|&p| out.depth_m[p])
            .fold(f32::INFINITY, f32::min);
        assert!((near - 4.5).abs() < 0.02, "{name}: nearest depth {near} m");
        // Where the id map says "red", the render is red; where "blue", blue.
        let mean = |b: usize| {
            pixels
                .iter()
                .map(|&p| out.radiance.band(b)[p] as f64)
                .sum::<f64>()
                / area
        };
        let (r, b) = (mean(b_red), mean(b_blue));
        match name.as_str().unwrap() {
            "red" => assert!(r > 4.0 * b, "red sphere: 650 nm {r}, 450 nm {b}"),
            _ => assert!(b > 4.0 * r, "blue sphere: 650 nm {r}, 450 nm {b}"),
        }
    }
}
