//! pbrt-v4 animated transforms (issue 28): `ActiveTransform`, `TransformTimes`, the camera's
//! `shutteropen`/`shutterclose`, animated shapes, instances, lights and cameras are read with
//! pbrt-v4's semantics, and a moving shape renders as the box convolution of its motion.

use camsim_pbrt::parse_str;
use camsim_render::render;
use camsim_scene3d::Transform;

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9)
}

const HEAD: &str = r#"
LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 30 "float shutteropen" 0.25 "float shutterclose" 0.75
Film "rgb" "integer xresolution" 32 "integer yresolution" 16
"#;

/// A shape under `ActiveTransform EndTime` moves from its start to its end transform over the
/// transform times; the camera's shutter is read; a static shape gets no motion.
#[test]
fn active_transform_gives_shapes_their_motion() {
    let text = format!(
        r#"{HEAD}
WorldBegin
LightSource "point" "rgb I" [1 1 1]
AttributeBegin
  Translate 1 0 0
  ActiveTransform EndTime
  Translate 0 2 0
  Rotate 90 0 0 1
  ActiveTransform All
  Shape "sphere" "float radius" 0.5
AttributeEnd
Shape "sphere" "float radius" 0.1
"#
    );
    let s = parse_str(&text, "m.pbrt").unwrap();
    let t = &s.settings.time;
    assert_eq!((t.shutter.open_s, t.shutter.close_s), (0.25, 0.75));
    assert_eq!(t.shapes.len(), 1, "only the first sphere moves");
    let (i, m) = &t.shapes[0];
    assert_eq!(*i, 0);
    // Stored at the start transform; the move to t = 1 is the end transform's (its centre goes
    // from (1, 0, 0) to (1, 2, 0)), half of it at t = 0.5 (pbrt's default times 0 and 1).
    let c = |t_s: f64| m.delta(t_s).apply_point([1.0, 0.0, 0.0]);
    assert!(close(c(0.0), [1.0, 0.0, 0.0]) && close(c(1.0), [1.0, 2.0, 0.0]));
    assert!(close(c(0.5), [1.0, 1.0, 0.0]), "{:?}", c(0.5));
    // The rotation interpolates along the arc: a point 1 m along +x of the centre is turned by
    // 45 degrees at t = 0.5.
    let p = m.delta(0.5).apply_point([2.0, 0.0, 0.0]);
    let h = 0.5f64.sqrt();
    assert!(close(p, [1.0 + h, 1.0 + h, 0.0]), "{p:?}");
    assert!(s.settings.time.camera.is_none());
}

/// `TransformTimes` (options block) sets the key times; the camera transform animated with
/// `ActiveTransform` gives the camera its motion; instances under an animated CTM move; a point
/// light under one moves; `TransformTimes` in the world block is an error, as in pbrt-v4.
#[test]
fn transform_times_camera_instances_and_lights() {
    let text = r#"
TransformTimes 2 4
LookAt 0 0 -5  0 0 0  0 1 0
ActiveTransform EndTime
Translate 1 0 0
ActiveTransform All
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 32 "integer yresolution" 16
WorldBegin
ObjectBegin "ball"
  Shape "sphere" "float radius" 0.5
ObjectEnd
AttributeBegin
  ActiveTransform EndTime
  Translate 0 0 3
  ActiveTransform All
  ObjectInstance "ball"
  LightSource "point" "rgb I" [1 1 1]
AttributeEnd
ObjectInstance "ball"
"#;
    let s = parse_str(text, "m.pbrt").unwrap();
    let t = &s.settings.time;
    // The camera: world_from_camera moves from LookAt's inverse to (LookAt then Translate)'s
    // inverse, i.e. the eye moves by -1 along the camera's x, between t = 2 and t = 4.
    let cam = t.camera.as_ref().expect("the camera moves");
    let eye = |t_s: f64| {
        cam.delta(t_s)
            .apply_point(s.camera.camera_to_world.apply_point([0.0; 3]))
    };
    assert!(close(eye(1.0), [0.0, 0.0, -5.0]) && close(eye(2.0), [0.0, 0.0, -5.0]));
    // pbrt's LookAt camera space: x = up x dir = (0,1,0) x (0,0,1) = (1,0,0): -1 along x.
    assert!(close(eye(4.0), [-1.0, 0.0, -5.0]), "{:?}", eye(4.0));
    assert!(close(eye(3.0), [-0.5, 0.0, -5.0]));
    // The first instance moves 3 m in z over [2, 4], the second is still.
    assert_eq!(t.shapes.len(), 1);
    let (i, m) = &t.shapes[0];
    assert_eq!(*i, 0);
    assert!(close(m.delta(3.0).apply_point([0.0; 3]), [0.0, 0.0, 1.5]));
    assert_eq!(t.lights.len(), 1);
    assert!(close(
        t.lights[0].1.delta(4.0).apply_point([0.0; 3]),
        [0.0, 0.0, 3.0]
    ));

    let bad = "WorldBegin\nTransformTimes 0 1\n";
    let e = parse_str(bad, "bad.pbrt").unwrap_err().to_string();
    assert!(
        e.contains("bad.pbrt:2") && e.contains("TransformTimes"),
        "{e}"
    );
    let bad = "TransformTimes 1 0\nWorldBegin\n";
    let e = parse_str(bad, "bad.pbrt").unwrap_err().to_string();
    assert!(e.contains("before the start time"), "{e}");
}

/// A static scene read with `ActiveTransform` directives that change nothing is the scene read
/// without them (no motion), and renders the same bytes.
#[test]
fn transforms_equal_at_both_times_are_static() {
    let plain = format!(
        "{HEAD}WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\nShape \"sphere\" \"float radius\" 1\n"
    );
    let active = format!(
        "{HEAD}WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\nActiveTransform StartTime\nTranslate 1 0 0\nActiveTransform EndTime\nTranslate 1 0 0\nActiveTransform All\nTranslate -1 0 0\nShape \"sphere\" \"float radius\" 1\n"
    );
    let a = parse_str(&plain, "a.pbrt").unwrap();
    let b = parse_str(&active, "b.pbrt").unwrap();
    assert!(b.settings.time.shapes.is_empty());
    let ra = render(&a, &|_, _| {}).unwrap();
    let rb = render(&b, &|_, _| {}).unwrap();
    assert!(ra.radiance.data == rb.radiance.data);
    assert_eq!(b.camera.camera_to_world, a.camera.camera_to_world);
    let _ = Transform::identity();
}

/// A bright disk moving across the view during the shutter renders as its motion's box
/// convolution: the image's integral is the still disk's and the blur's extent is the move.
#[test]
fn a_pbrt_animated_emitter_blurs_along_its_path() {
    let scene = |end_translate: &str| {
        format!(
            r#"
LookAt 0 0 -10  0 0 0  0 1 0
Camera "perspective" "float fov" 20 "float shutteropen" 0 "float shutterclose" 1
Sampler "zsobol" "integer pixelsamples" 64
Film "rgb" "integer xresolution" 96 "integer yresolution" 32
WorldBegin
AttributeBegin
  ActiveTransform EndTime
  Translate {end_translate}
  ActiveTransform All
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "disk" "float radius" 0.3
AttributeEnd
"#
        )
    };
    let img = |t: &str| {
        let s = parse_str(&scene(t), "disk.pbrt").unwrap();
        let out = render(&s, &|_, _| {}).unwrap();
        // Summed over the bands (each path carries 4 of the 31 wavelengths).
        let n = 96 * 32;
        (0..n)
            .map(|i| {
                out.radiance.data[i..]
                    .iter()
                    .step_by(n)
                    .map(|v| *v as f64)
                    .sum()
            })
            .collect::<Vec<f64>>()
    };
    let still = img("0 0 0");
    let moving = img("1.5 0 0");
    let (a, b): (f64, f64) = (still.iter().sum(), moving.iter().sum());
    assert!((b / a - 1.0).abs() < 0.01, "integral {b} vs {a}");
    // The image's centroid moves by half the move (the disk spends equal time at every point
    // of its path): 1.5 m at 10 m with a 20-degree field across 32 rows is 1.5 / (2 x 10 tan 10
    // deg / 32) = 13.6 px, so 6.8 px.
    let cx = |img: &[f64]| {
        let s: f64 = img.iter().sum();
        (0..img.len())
            .map(|i| img[i] * ((i % 96) as f64 + 0.5))
            .sum::<f64>()
            / s
    };
    let shift = cx(&moving) - cx(&still);
    let want = 1.5 / (2.0 * 10.0 * 10f64.to_radians().tan() / 32.0) / 2.0;
    assert!(
        (shift - want).abs() < 0.05,
        "centroid moved {shift} px, want {want}"
    );
}
