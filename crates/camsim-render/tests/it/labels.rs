//! Training-data labels of a render (issue 29), against geometry: a box of known size and pose
//! (its 3D box, its 2D box against its corners projected through the pinhole, the intrinsics),
//! projected areas of spheres against the closed form of a cone cut by the film plane, an
//! occluded sphere's visible fraction against the circular-segment area, two instances of one
//! object, a sphere's normals against (p - c) / r, a checkerboard's albedo against its texture.

use camsim_pbrt::parse_str;
use camsim_render::{render_with, LabelRequest, Labels, RenderRequest};
use camsim_scene3d::SceneDescription;

fn labels_of(scene: &SceneDescription, normals: bool, albedo: bool) -> (Labels, Vec<f32>) {
    let req = RenderRequest {
        labels: Some(LabelRequest {
            normals,
            albedo,
            amodal: false,
        }),
        ..Default::default()
    };
    let out = render_with(scene, &req, &|_, _| {}).unwrap();
    (out.labels.unwrap(), out.depth_m)
}

/// Focal length in pixels of pbrt's perspective camera: `fov` spans the shorter image axis.
fn focal_px(fov_deg: f64, w: usize, h: usize) -> f64 {
    (w.min(h) as f64 / 2.0) / (fov_deg.to_radians() / 2.0).tan()
}

const CUBE: &str = r#"Shape "trianglemesh" "point3 P" [-0.5 -0.5 -0.5  0.5 -0.5 -0.5  0.5 0.5 -0.5  -0.5 0.5 -0.5
      -0.5 -0.5 0.5  0.5 -0.5 0.5  0.5 0.5 0.5  -0.5 0.5 0.5]
    "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]"#;

/// A 0.8 x 0.5 x 0.6 m box turned 30 degrees about the vertical, seen by a level camera: its 3D
/// box is its pose, its 2D box the bounding box of its 8 corners projected through the pinhole
/// (within half a pixel: the silhouette's extremes are vertical edges and flat wedges, which the
/// pixel-centre rays find), and K is pbrt's perspective projection.
#[test]
fn a_box_of_known_pose_gives_its_3d_box_and_its_projected_2d_box() {
    let (w, h, fov) = (160usize, 120usize, 30.0);
    let text = format!(
        r#"LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" {fov}
Sampler "zsobol" "integer pixelsamples" 1
Film "rgb" "integer xresolution" {w} "integer yresolution" {h}
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
AttributeBegin
  #ObjectName crate
  Translate 0.3 -0.1 1.0
  Rotate 30 0 1 0
  Scale 0.8 0.5 0.6
  {CUBE}
AttributeEnd
"#
    );
    let scene = parse_str(&text, "box.pbrt").unwrap();
    let (lab, _) = labels_of(&scene, false, false);
    let f = focal_px(fov, w, h);
    let k = lab.camera.k;
    assert!(
        (k[0][0] - f).abs() < 1e-3 * f && (k[1][1] - f).abs() < 1e-3 * f,
        "{k:?}"
    );
    assert!((k[0][2] - (w as f64 / 2.0 - 0.5)).abs() < 1e-9);
    assert!((k[1][2] - (h as f64 / 2.0 - 0.5)).abs() < 1e-9);
    assert_eq!(lab.instances.len(), 1);
    let inst = &lab.instances[0];
    assert_eq!(inst.name, "crate");
    let b = inst.box_3d.as_ref().unwrap();
    // Camera frame (OpenCV): the camera sits at z = -5 looking along +z with +y up, so a world
    // point (x, y, z) is at (x, -y, z + 5).
    let to_cam = |p: [f64; 3]| [p[0], -p[1], p[2] + 5.0];
    let want_c = to_cam([0.3, -0.1, 1.0]);
    for i in 0..3 {
        assert!((b.center_m[i] - want_c[i]).abs() < 1e-6, "{:?}", b.center_m);
    }
    let want_size = [0.8, 0.5, 0.6];
    // pbrt Rotate 30 about y: x axis -> (cos, 0, -sin), z axis -> (sin, 0, cos).
    let (s, c) = 30f64.to_radians().sin_cos();
    let world_axes = [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]];
    for k in 0..3 {
        assert!((b.size_m[k] - want_size[k]).abs() < 1e-6, "{:?}", b.size_m);
        let a = [world_axes[k][0], -world_axes[k][1], world_axes[k][2]];
        let d: f64 = (0..3).map(|i| a[i] * b.axes[k][i]).sum();
        assert!((d.abs() - 1.0).abs() < 1e-9, "axis {k}: {:?}", b.axes[k]);
    }
    // The 2D box against the corners projected independently (pbrt's screen window: raster
    // x = W/2 + f X/Z, y = H/2 - f Y/Z with camera y up).
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for i in 0..8 {
        let l = [
            if i & 1 == 1 { 0.4 } else { -0.4 },
            if i & 2 == 2 { 0.25 } else { -0.25 },
            if i & 4 == 4 { 0.3 } else { -0.3 },
        ];
        // Rotate about y, then translate (pbrt: Translate * Rotate * Scale).
        let p = [
            c * l[0] + s * l[2] + 0.3,
            l[1] - 0.1,
            -s * l[0] + c * l[2] + 1.0,
        ];
        let z = p[2] + 5.0;
        let q = [w as f64 / 2.0 + f * p[0] / z, h as f64 / 2.0 - f * p[1] / z];
        for k in 0..2 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
        // The label's own corners project to the same points (K and the extrinsics).
        let mut best = f64::INFINITY;
        for cc in &b.corners_m {
            let u = lab.camera.project(*cc);
            best = best.min((u[0] + 0.5 - q[0]).hypot(u[1] + 0.5 - q[1]));
        }
        assert!(
            best < 1e-6,
            "corner {i} projects {best} px from its label corner"
        );
    }
    let boxes = camsim_render::labels::boxes_2d(&lab.instance_id, w);
    assert_eq!(boxes.len(), 1);
    let bb = boxes[0].bbox.map(|v| v as f64);
    let want = [lo[0], lo[1], hi[0], hi[1]];
    for k in 0..4 {
        assert!(
            (bb[k] - want[k]).abs() <= 0.5,
            "2D box {bb:?} against the projected corners {want:?}"
        );
    }
    assert_eq!(inst.truncation, 0.0);
    assert_eq!(inst.visible_fraction, 1.0);
}

/// Area (px^2) of the image of a sphere of angular radius `alpha` whose centre is `theta` off the
/// optical axis, on a film at focal length `f` px: the cone of half-angle alpha about that
/// direction cut by the film plane is an ellipse of semi-axes f sin(a) cos(a) / (cos^2 t -
/// sin^2 a) and f sin(a) / sqrt(cos^2 t - sin^2 a), so area = pi f^2 sin^2(a) cos(a) / (cos^2 t -
/// sin^2 a)^(3/2).
fn sphere_image_area_px(f: f64, alpha: f64, theta: f64) -> f64 {
    let (sa, ca, ct) = (alpha.sin(), alpha.cos(), theta.cos());
    std::f64::consts::PI * f * f * sa * sa * ca / (ct * ct - sa * sa).powf(1.5)
}

const SPHERES_HEAD: &str = r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 40
Sampler "zsobol" "integer pixelsamples" 1
Film "rgb" "integer xresolution" 240 "integer yresolution" 240
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
"#;

/// Two spheres (one on the axis, one 0.24 rad off it): each instance's pixel count equals the
/// area of its elliptical image within 1 %.
#[test]
fn sphere_instances_cover_their_projected_areas() {
    let text = format!(
        "{SPHERES_HEAD}AttributeBegin\n Translate 0 0 5\n Shape \"sphere\" \"float radius\" 0.6\nAttributeEnd\n\
         AttributeBegin\n Translate 1.2 0 4.9\n Shape \"sphere\" \"float radius\" 0.4\nAttributeEnd\n"
    );
    let scene = parse_str(&text, "spheres.pbrt").unwrap();
    let (lab, _) = labels_of(&scene, false, false);
    let f = focal_px(40.0, 240, 240);
    let boxes = camsim_render::labels::boxes_2d(&lab.instance_id, 240);
    assert_eq!(boxes.len(), 2);
    for (b, (c, r)) in boxes
        .iter()
        .zip([([0.0f64, 0.0, 5.0], 0.6f64), ([1.2, 0.0, 4.9], 0.4)])
    {
        let d: f64 = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let want = sphere_image_area_px(f, (r / d).asin(), (c[2] / d).acos());
        let got = b.pixels as f64;
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "instance {}: {got} px against {want:.1} px",
            b.id
        );
        let inst = &lab.instances[b.id as usize - 1];
        assert_eq!((inst.visible_px, inst.unoccluded_px), (b.pixels, b.pixels));
    }
}

/// A sphere half hidden behind a wall whose edge passes `h` pixels from the centre of its image:
/// its visible fraction is 1 - (circular segment beyond the edge) / (disc), within 1 %; the wall
/// sees everything it covers.
#[test]
fn an_occluded_sphere_has_the_visible_fraction_of_its_uncovered_segment() {
    // The wall (z = 3, nearer than the sphere at z = 6) covers x >= 0.1 m at z = 3; seen from the
    // origin its edge is at x/z = 1/30, i.e. h = f / 30 px right of the axis, where the sphere's
    // disc is centred.
    let text = format!(
        "{SPHERES_HEAD}AttributeBegin\n Translate 0 0 6\n Shape \"sphere\" \"float radius\" 1\nAttributeEnd\n\
         AttributeBegin\n Shape \"trianglemesh\" \"point3 P\" [0.1 -3 3  5 -3 3  5 3 3  0.1 3 3] \"integer indices\" [0 1 2 0 2 3]\nAttributeEnd\n"
    );
    let scene = parse_str(&text, "occluded.pbrt").unwrap();
    let (lab, _) = labels_of(&scene, false, false);
    let f = focal_px(40.0, 240, 240);
    let sphere = &lab.instances[0];
    let big_r = f * (1.0f64 / 6.0).asin().tan();
    let hh = f / 30.0;
    let segment = big_r * big_r * (hh / big_r).acos() - hh * (big_r * big_r - hh * hh).sqrt();
    let want = 1.0 - segment / (std::f64::consts::PI * big_r * big_r);
    assert!(
        (sphere.visible_fraction / want - 1.0).abs() < 0.01,
        "visible fraction {} against {want:.4}",
        sphere.visible_fraction
    );
    // Unoccluded, the sphere covers its whole disc.
    let disc = std::f64::consts::PI * big_r * big_r;
    assert!((sphere.unoccluded_px as f64 / disc - 1.0).abs() < 0.01);
    assert_eq!(lab.instances[1].visible_fraction, 1.0);
}

/// One object (two shapes) instanced twice: two instance ids, each holding both shapes, each
/// with its own 3D box where the instance put it.
#[test]
fn two_instances_of_one_object_get_two_ids() {
    let text = format!(
        "{SPHERES_HEAD}ObjectBegin \"pair\"\n Shape \"sphere\" \"float radius\" 0.3\n \
         AttributeBegin\n  Translate 0 0.5 0\n  Shape \"sphere\" \"float radius\" 0.2\n AttributeEnd\nObjectEnd\n\
         AttributeBegin\n Translate -0.8 0 5\n ObjectInstance \"pair\"\nAttributeEnd\n\
         AttributeBegin\n Translate 0.8 0 5\n ObjectInstance \"pair\"\nAttributeEnd\n"
    );
    let scene = parse_str(&text, "instances.pbrt").unwrap();
    assert_eq!(scene.shapes.len(), 4);
    let (lab, _) = labels_of(&scene, false, false);
    assert_eq!(lab.instances.len(), 2);
    for (inst, x) in lab.instances.iter().zip([-0.8, 0.8]) {
        assert_eq!(inst.object_ids.len(), 2);
        assert_eq!(inst.name, "pair");
        let b = inst.box_3d.as_ref().unwrap();
        // Union of the spheres: x in +-0.3, y in [-0.3, 0.7], z in +-0.3 about the instance.
        let want_c = [x, -0.2, 5.0];
        for i in 0..3 {
            assert!((b.center_m[i] - want_c[i]).abs() < 1e-6, "{:?}", b.center_m);
        }
        for (s, want) in b.size_m.iter().zip([0.6, 1.0, 0.6]) {
            assert!((s - want).abs() < 1e-6, "{:?}", b.size_m);
        }
    }
    let boxes = camsim_render::labels::boxes_2d(&lab.instance_id, 240);
    assert_eq!(boxes.iter().map(|b| b.id).collect::<Vec<_>>(), [1, 2]);
}

/// The normal label of a sphere equals (p - c) / r at every pixel it covers, p the surface point
/// the depth map places on the pixel's centre ray; in the camera frame it is that vector with y
/// turned down.
#[test]
fn sphere_normals_equal_the_radial_direction() {
    let text = format!(
        "{SPHERES_HEAD}AttributeBegin\n Translate 0.4 -0.2 4\n Shape \"sphere\" \"float radius\" 0.9\nAttributeEnd\n"
    );
    let scene = parse_str(&text, "normals.pbrt").unwrap();
    let (lab, depth) = labels_of(&scene, true, false);
    let (nw, nc) = (
        lab.normal_world.as_ref().unwrap(),
        lab.normal_camera.as_ref().unwrap(),
    );
    let f = focal_px(40.0, 240, 240);
    let (c, r) = ([0.4, -0.2, 4.0], 0.9);
    let mut n = 0;
    for y in 0..240 {
        for x in 0..240 {
            let p = y * 240 + x;
            if lab.instance_id[p] == 0 {
                assert_eq!(nw[p], [0.0; 3]);
                continue;
            }
            // The pixel centre's ray (camera = world here, y up), scaled to the depth along z.
            let z = depth[p] as f64;
            let q = [
                (x as f64 + 0.5 - 120.0) / f * z,
                (120.0 - y as f64 - 0.5) / f * z,
                z,
            ];
            let want: Vec<f64> = (0..3).map(|i| (q[i] - c[i]) / r).collect();
            for i in 0..3 {
                assert!(
                    (nw[p][i] as f64 - want[i]).abs() < 2e-3,
                    "pixel ({x}, {y}): {:?} against {want:?}",
                    nw[p]
                );
            }
            let want_cam = [want[0], -want[1], want[2]];
            for i in 0..3 {
                assert!((nc[p][i] as f64 - want_cam[i]).abs() < 2e-3);
            }
            n += 1;
        }
    }
    assert!(n > 5000, "{n} sphere pixels");
}

/// A square with a 4 x 4 checkerboard of two flat reflectances (0.2, 0.7) seen face on: the
/// albedo at every pixel is the texture at the point the pixel centre sees, at every band, and
/// its sRGB is that grey.
#[test]
fn checkerboard_albedo_equals_the_texture() {
    let text = r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 40
Sampler "zsobol" "integer pixelsamples" 1
Film "rgb" "integer xresolution" 128 "integer yresolution" 128
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Texture "checks" "spectrum" "checkerboard" "float uscale" 4 "float vscale" 4
  "spectrum tex1" [300 0.2 900 0.2] "spectrum tex2" [300 0.7 900 0.7]
Material "diffuse" "texture reflectance" "checks"
Shape "trianglemesh" "point3 P" [-1 -1 2  1 -1 2  1 1 2  -1 1 2] "integer indices" [0 1 2 0 2 3]
  "point2 uv" [0 0  1 0  1 1  0 1]
"#;
    let scene = parse_str(text, "checks.pbrt").unwrap();
    let (lab, _) = labels_of(&scene, false, true);
    let (a, rgb) = (
        lab.albedo.as_ref().unwrap(),
        lab.albedo_srgb.as_ref().unwrap(),
    );
    let f = focal_px(40.0, 128, 128);
    let (pixels, bands) = (128 * 128, lab.grid.len());
    let mut checked = 0;
    for y in 0..128 {
        for x in 0..128 {
            let p = y * 128 + x;
            // The plane z = 2, u = (X + 1) / 2, v = (Y + 1) / 2.
            let (px, py) = (
                (x as f64 + 0.5 - 64.0) / f * 2.0,
                (64.0 - y as f64 - 0.5) / f * 2.0,
            );
            if px.abs() > 0.99 || py.abs() > 0.99 {
                continue;
            }
            let (s, t) = ((px + 1.0) / 2.0 * 4.0, (py + 1.0) / 2.0 * 4.0);
            // Skip samples within 1e-3 of a check's edge (f32 rounding of the hit point).
            let near_edge = |v: f64| (v - v.round()).abs() < 1e-3;
            if near_edge(s) || near_edge(t) {
                continue;
            }
            // pbrt-v4 checkerboard: tex1 where floor(s) + floor(t) is even.
            let want = if (s.floor() + t.floor()) as i64 % 2 == 0 {
                0.2
            } else {
                0.7
            };
            for b in 0..bands {
                assert!(
                    (a[b * pixels + p] as f64 - want).abs() < 1e-5,
                    "pixel ({x}, {y}) band {b}: {} against {want}",
                    a[b * pixels + p]
                );
            }
            for c in 0..3 {
                assert!((rgb[p][c] as f64 - want).abs() < 2e-3, "{:?}", rgb[p]);
            }
            checked += 1;
        }
    }
    assert!(checked > 10_000, "{checked} pixels checked");
}
