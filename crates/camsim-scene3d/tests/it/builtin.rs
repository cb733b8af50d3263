//! Built-in scenes: the Cornell data page's geometry and camera, the ColorChecker's placement and
//! visibility, the slanted edge's angle, and the light's absolute level.

use camsim_scene3d::builtin::{self, BuiltinOptions, MccPosition};
use camsim_scene3d::spectra::photometric;
use camsim_scene3d::xform::{cross, dot, normalize, shape_bounds, sub};
use camsim_scene3d::{Geometry, SceneDescription, Shape};

fn shape<'a>(s: &'a SceneDescription, name: &str) -> &'a Shape {
    s.shapes
        .iter()
        .find(|x| x.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no {name}"))
}

fn tris(sh: &Shape) -> Vec<[[f64; 3]; 3]> {
    let Geometry::Triangles {
        positions, indices, ..
    } = &sh.geometry
    else {
        panic!()
    };
    indices
        .iter()
        .map(|t| {
            [
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ]
        })
        .collect()
}

fn normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    normalize(cross(sub(t[1], t[0]), sub(t[2], t[0])))
}

fn centroid(t: &[[f64; 3]; 3]) -> [f64; 3] {
    [
        (t[0][0] + t[1][0] + t[2][0]) / 3.0,
        (t[0][1] + t[1][1] + t[2][1]) / 3.0,
        (t[0][2] + t[1][2] + t[2][2]) / 3.0,
    ]
}

/// Moller-Trumbore ray/triangle distance (independent of the renderer's intersector).
fn hit(o: [f64; 3], d: [f64; 3], t: &[[f64; 3]; 3]) -> Option<f64> {
    let e1 = sub(t[1], t[0]);
    let e2 = sub(t[2], t[0]);
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det.abs() < 1e-14 {
        return None;
    }
    let s = sub(o, t[0]);
    let u = dot(s, p) / det;
    let q = cross(s, e1);
    let v = dot(d, q) / det;
    let dist = dot(e2, q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dist > 1e-9).then_some(dist)
}

/// The first shape hit from `o` toward `p`.
fn first_hit(s: &SceneDescription, o: [f64; 3], p: [f64; 3]) -> Option<String> {
    let d = normalize(sub(p, o));
    let mut best: Option<(f64, String)> = None;
    for sh in &s.shapes {
        for t in tris(sh) {
            if let Some(dist) = hit(o, d, &t) {
                if best.as_ref().is_none_or(|b| dist < b.0) {
                    best = Some((dist, sh.name.clone().unwrap_or_default()));
                }
            }
        }
    }
    best.map(|b| b.1)
}

#[test]
fn names_and_unknown() {
    assert_eq!(
        builtin::names(),
        ["cornell-box", "cornell-box-mcc", "slanted-edge"]
    );
    let e = builtin::scene("cornel-box", &BuiltinOptions::default()).unwrap_err();
    assert!(e.to_string().contains("cornell-box-mcc"), "{e}");
}

#[test]
fn cornell_box_geometry_camera_and_light() {
    let s = builtin::scene("cornell-box", &BuiltinOptions::default()).unwrap();
    let centre = [0.278, 0.2744, 0.2796];
    // Walls, floor and ceiling face the room's interior.
    for n in ["floor", "ceiling", "back_wall", "left_wall", "right_wall"] {
        for t in tris(shape(&s, n)) {
            assert!(dot(normal(&t), sub(centre, centroid(&t))) > 0.0, "{n}");
        }
    }
    // Data page dimensions (m): floor 0.5528 x 0.5592, ceiling at 0.5488.
    let (lo, hi) = shape_bounds(&shape(&s, "floor").geometry);
    assert!((hi[0] - 0.5528).abs() < 1e-12 && lo[0] == 0.0 && (hi[2] - 0.5592).abs() < 1e-12);
    assert!((shape_bounds(&shape(&s, "tall_block").geometry).1[1] - 0.330).abs() < 1e-12);
    assert!((shape_bounds(&shape(&s, "short_block").geometry).1[1] - 0.165).abs() < 1e-12);
    // Light: 130 x 105 mm, emitting downward, 1000 cd/m^2 (683 * sum y_bar L).
    let light = shape(&s, "light");
    let area = camsim_scene3d::xform::shape_area(&light.geometry);
    assert!((area - 0.130 * 0.105).abs() < 1e-12);
    for t in tris(light) {
        assert!((normal(&t)[1] + 1.0).abs() < 1e-12);
    }
    let l = light.area_light.as_ref().unwrap();
    assert!(!l.two_sided);
    assert!((683.0 * photometric(&l.radiance) - 1000.0).abs() < 1e-9);
    // Relative shape: the data page's points.
    assert!((l.radiance.eval(600.0) / l.radiance.eval(500.0) - 15.6 / 8.0).abs() < 1e-12);
    // The ceiling's hole has the light's area: ceiling area = 0.556 * 0.5592 - light.
    let ceil = camsim_scene3d::xform::shape_area(&shape(&s, "ceiling").geometry);
    assert!((ceil - (0.556 * 0.5592 - area)).abs() < 1e-12);
    // Camera: 35 mm lens on 25 mm film.
    assert!((s.camera.fov_deg - 2.0 * (12.5f64 / 35.0).atan().to_degrees()).abs() < 1e-12);
    let eye = s.camera.camera_to_world.apply_point([0.0; 3]);
    assert!((eye[0] - 0.278).abs() < 1e-12 && (eye[2] + 0.8).abs() < 1e-12);
    // Red wall on the image's left, green on the right.
    let px = |n: &str| {
        let (lo, hi) = shape_bounds(&shape(&s, n).geometry);
        builtin::project_to_raster(&s.camera, [(lo[0] + hi[0]) / 2.0, 0.27, 0.3]).unwrap()[0]
    };
    assert!(px("left_wall") < 100.0 && px("right_wall") > 412.0);
    // Materials by name.
    for n in ["white", "red", "green"] {
        assert!(s.named_materials.contains_key(n));
    }
    assert_eq!(shape(&s, "left_wall").material, s.named_materials["red"]);
}

#[test]
fn mcc_scene_pixel4a_and_chart_visibility() {
    for pos in [MccPosition::Left, MccPosition::Center, MccPosition::Right] {
        let opts = BuiltinOptions {
            mcc_position: pos,
            ..Default::default()
        };
        let s = builtin::scene("cornell-box-mcc", &opts).unwrap();
        // Pixel 4a: horizontal fov 2 atan(4032 * 1.4 um / 2 / 4.38 mm) = 65.64 degrees.
        let h = 2.0 * (4032.0 * 1.4e-6 / 2.0 / 4.38e-3f64).atan().to_degrees();
        assert!((s.camera.horizontal_fov_deg() - h).abs() < 1e-9);
        assert_eq!((s.camera.width, s.camera.height), (1008, 756));
        let layout = builtin::mcc_layout(&pos).unwrap();
        let eye = s.camera.camera_to_world.apply_point([0.0; 3]);
        let (centers, patch_px) = builtin::mcc_patch_centers_px(&opts).unwrap();
        assert!(patch_px > 10.0, "{patch_px}");
        for (i, (c, px)) in layout.patch_centers.iter().zip(&centers).enumerate() {
            // Inside the image and not hidden by the blocks.
            assert!(
                px[0] > 0.0 && px[0] < 1008.0 && px[1] > 0.0 && px[1] < 756.0,
                "{pos:?} patch {}",
                i + 1
            );
            // Aim off the patch's diagonal (the triangles' shared edge).
            let aim = [
                c[0] + 0.2 * layout.patch_m,
                c[1] + 0.1 * layout.patch_m,
                c[2],
            ];
            assert_eq!(
                first_hit(&s, eye, aim).as_deref(),
                Some(format!("mcc_patch_{:02}", i + 1).as_str()),
                "{pos:?}"
            );
            assert_eq!(
                shape(&s, &format!("mcc_patch_{:02}", i + 1)).material,
                s.named_materials[&format!("mcc_{:02}", i + 1)]
            );
        }
        // Patch 1 top-left, 6 top-right, 19 bottom-left of the image.
        assert!(centers[0][0] < centers[5][0] && centers[0][1] < centers[18][1]);
        let corners = builtin::mcc_corners_px(&opts).unwrap();
        assert!(corners[0][0] < centers[0][0] && corners[0][1] < centers[0][1]);
        assert!(corners[2][0] > centers[23][0] && corners[2][1] > centers[23][1]);
        // Frame reflectance 0 (the paper's black margins).
        let fm = shape(&s, "mcc_frame").material;
        let camsim_scene3d::Material::Diffuse {
            reflectance: camsim_scene3d::Texture::Constant(k),
        } = &s.materials[fm]
        else {
            panic!()
        };
        assert_eq!(k.eval(550.0), 0.0);
    }
    let px = |p| {
        builtin::mcc_corners_px(&BuiltinOptions {
            mcc_position: p,
            ..Default::default()
        })
        .unwrap()[0][0]
    };
    assert!(
        px(MccPosition::Left) < px(MccPosition::Center)
            && px(MccPosition::Center) < px(MccPosition::Right)
    );
    assert_eq!(
        "0.3, 0.4".parse::<MccPosition>().unwrap(),
        MccPosition::At { x_m: 0.3, y_m: 0.4 }
    );
    assert!("middle".parse::<MccPosition>().is_err());
    assert!(builtin::scene(
        "cornell-box-mcc",
        &BuiltinOptions {
            mcc_position: MccPosition::At {
                x_m: 0.01,
                y_m: 0.3
            },
            ..Default::default()
        }
    )
    .is_err());
}

#[test]
fn slanted_edge_angle_distance_and_centring() {
    for d in [0.5, 0.3, 1.2] {
        let opts = BuiltinOptions {
            target_distance_m: d,
            resolution: Some((800, 600)),
            ..Default::default()
        };
        let s = builtin::scene("slanted-edge", &opts).unwrap();
        assert_eq!(s.focus_distance_m, Some(d));
        assert!(s
            .shapes
            .iter()
            .all(|x| !x.name.as_deref().unwrap_or("").contains("block")));
        // The dark quad's edge vertices (shared with the light quad): p1 (bottom) and p2 (top).
        let Geometry::Triangles { positions, .. } = &shape(&s, "target_black").geometry else {
            panic!()
        };
        let (b, t) = (
            builtin::project_to_raster(&s.camera, positions[1]).unwrap(),
            builtin::project_to_raster(&s.camera, positions[2]).unwrap(),
        );
        // Perspective of a fronto-parallel plane keeps angles: 5 degrees from vertical, top leaning right.
        let angle = ((t[0] - b[0]) / (b[1] - t[1])).atan().to_degrees();
        assert!((angle - 5.0).abs() < 1e-9, "{angle}");
        // Centred: the edge's midpoint projects to the image centre.
        let mid = [(b[0] + t[0]) / 2.0, (b[1] + t[1]) / 2.0];
        assert!(
            (mid[0] - 400.0).abs() < 1e-9 && (mid[1] - 300.0).abs() < 1e-9,
            "{mid:?}"
        );
        // Camera-to-card distance along the view axis.
        let eye = s.camera.camera_to_world.apply_point([0.0; 3]);
        assert!((positions[1][2] - eye[2] - d).abs() < 1e-12);
        // Dark on the image's left, visible from the camera.
        let dark_px = builtin::project_to_raster(&s.camera, positions[0]).unwrap();
        assert!(dark_px[0] < 400.0);
        let c = [0.278 + 0.05, 0.30, 0.45];
        assert_eq!(first_hit(&s, eye, c).as_deref(), Some("target_black"));
    }
    assert!(builtin::scene(
        "slanted-edge",
        &BuiltinOptions {
            target_distance_m: -1.0,
            ..Default::default()
        }
    )
    .is_err());
}

#[test]
fn options_override_light_and_walls() {
    let flat = camsim_core::Spectrum::from_pairs(&[(300.0, 0.5), (900.0, 0.5)]);
    let opts = BuiltinOptions {
        light_luminance_cd_m2: Some(250.0),
        light_spectrum: Some(camsim_core::tables::illuminant("D65").unwrap()),
        wall_spectra: builtin::WallSpectra {
            red: Some(flat.clone()),
            ..Default::default()
        },
        ..Default::default()
    };
    let s = builtin::scene("cornell-box", &opts).unwrap();
    let l = &shape(&s, "light").area_light.as_ref().unwrap().radiance;
    assert!((683.0 * photometric(l) - 250.0).abs() < 1e-9);
    let d65 = camsim_core::tables::illuminant("D65").unwrap();
    assert!((l.eval(450.0) / l.eval(600.0) - d65.eval(450.0) / d65.eval(600.0)).abs() < 1e-12);
    let camsim_scene3d::Material::Diffuse {
        reflectance: camsim_scene3d::Texture::Constant(r),
    } = &s.materials[s.named_materials["red"]]
    else {
        panic!()
    };
    assert_eq!(r.eval(550.0), 0.5);
}
