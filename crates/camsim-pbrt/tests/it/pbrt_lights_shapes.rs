//! pbrt-v4 reader, issue 12: light parameters and their photometric normalisations, disk,
//! cylinder and loopsubdiv shapes, the checkerboard texture (rendered: colour fractions against
//! the analytic areas) and one-pass error reporting across included files.

use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;
use std::f64::consts::PI;

fn parse(text: &str) -> Result<SceneDescription, camsim_pbrt::PbrtError> {
    camsim_pbrt::parse_str(text, "/tmp/virtual/test.pbrt")
}

/// Luminous quantity (cd, cd/m^2, lx ...) of a spectral one in camsim's absolute units.
fn luminous(s: &Spectrum) -> f64 {
    LUMINOUS_EFFICACY_LM_PER_W * camsim_pbrt::spectra::photometric(s)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn point_spot_distant_parameters_follow_pbrt_v4() {
    let s = parse(
        "WorldBegin\nAttributeBegin\nTranslate 0 0 1\n\
         LightSource \"point\" \"blackbody I\" 3000 \"float power\" 100 \"point3 from\" [1 2 3]\n\
         AttributeEnd\n\
         AttributeBegin\nRotate 90 1 0 0\n\
         LightSource \"spot\" \"rgb I\" [1 0.5 0.25] \"float power\" 50 \"float coneangle\" 40 \"float conedelta\" 10 \"point3 to\" [0 0 1]\n\
         AttributeEnd\n\
         LightSource \"distant\" \"point3 from\" [0 0 10] \"point3 to\" [0 0 0] \"float illuminance\" 2000\n\
         LightSource \"point\" \"float scale\" 7\n",
    )
    .unwrap();
    assert_eq!(s.lights.len(), 4);
    match &s.lights[0] {
        Light::Point {
            position_m,
            intensity,
        } => {
            assert_eq!(*position_m, [1.0, 2.0, 4.0]);
            // power Phi_v: I_v = Phi_v / (4 pi) candela (pbrt-v4 PointLight::Create).
            assert!(
                rel(luminous(intensity), 100.0 / (4.0 * PI)) < 1e-9,
                "{}",
                luminous(intensity)
            );
        }
        l => panic!("{l:?}"),
    }
    match &s.lights[1] {
        Light::Spot {
            position_m,
            direction,
            intensity,
            cone_angle_deg,
            cone_delta_deg,
            ..
        } => {
            assert_eq!(*position_m, [0.0, 0.0, 0.0]);
            // Rotate 90 about x takes +z to -y.
            assert!(
                direction[0].abs() < 1e-12
                    && (direction[1] + 1.0).abs() < 1e-12
                    && direction[2].abs() < 1e-12,
                "{direction:?}"
            );
            assert_eq!((*cone_angle_deg, *cone_delta_deg), (40.0, 10.0));
            let (ce, cs) = (40f64.to_radians().cos(), 30f64.to_radians().cos());
            let want = 50.0 / (2.0 * PI * ((1.0 - cs) + (cs - ce) / 2.0));
            // rgb I: pbrt-v4 normalises by the illuminant's photometric value only, so the
            // luminous intensity is the power's times the colour's luminance Y(rgb) (Rec. 709).
            let y_rgb = 0.2126 * 1.0 + 0.7152 * 0.5 + 0.0722 * 0.25;
            let got = luminous(intensity);
            assert!(
                rel(got, want * y_rgb) < 0.02,
                "spot I_v {got} vs {}",
                want * y_rgb
            );
        }
        l => panic!("{l:?}"),
    }
    match &s.lights[2] {
        Light::Distant {
            direction,
            irradiance,
        } => {
            assert_eq!(*direction, [0.0, 0.0, -1.0]);
            assert!(rel(luminous(irradiance), 2000.0) < 1e-9);
        }
        l => panic!("{l:?}"),
    }
    match &s.lights[3] {
        // Default I: the colour space illuminant normalised to 1 nit, times scale.
        Light::Point { intensity, .. } => assert!(rel(luminous(intensity), 7.0) < 1e-9),
        l => panic!("{l:?}"),
    }
    // Bad parameters are errors at the directive.
    let e =
        parse("WorldBegin\nLightSource \"spot\" \"float coneangle\" 10 \"float conedelta\" 20\n")
            .unwrap_err();
    assert_eq!((e.line, e.column), (2, 1), "{e}");
    let e = parse("WorldBegin\nLightSource \"point\" \"float radius\" 1\n").unwrap_err();
    assert!(e.message.contains("radius"), "{e}");
}

#[test]
fn infinite_light_from_an_image_file() {
    let dir = tempfile::tempdir().unwrap();
    // Constant grey maps: the upper-hemisphere illuminance of radiance c is pi c, so with
    // "illuminance" E every texel's luminance becomes E / pi (pbrt-v4 ImageInfiniteLight).
    for (name, w, h, mapping) in [
        ("sq.exr", 16usize, 16usize, EnvMapping::EqualAreaOctahedral),
        ("ll.exr", 32, 16, EnvMapping::LatLong),
    ] {
        let path = dir.path().join(name);
        exr::prelude::write_rgb_file(&path, w, h, |_, _| (0.5f32, 0.5f32, 0.5f32)).unwrap();
        let text =
            format!("WorldBegin\nRotate 30 0 1 0\nLightSource \"infinite\" \"string filename\" \"{name}\" \"float illuminance\" 1000\n");
        let s = camsim_pbrt::parse_str(&text, dir.path().join("scene.pbrt")).unwrap();
        let Light::Environment(m) = &s.lights[0] else {
            panic!("{:?}", s.lights[0])
        };
        assert_eq!((m.width, m.height, m.mapping), (w, h, mapping));
        assert!((m.light_to_world.m[0][2] - 30f64.to_radians().sin()).abs() < 1e-12);
        let texel_luminance = luminous(&m.illuminant) * 0.5;
        // The map's illuminance is summed at texel centres: within 1 % of pi c at these sizes.
        assert!(
            rel(texel_luminance, 1000.0 / PI) < 0.01,
            "{name}: {texel_luminance} vs {}",
            1000.0 / PI
        );
    }
    exr::prelude::write_rgb_file(dir.path().join("bad.exr"), 30, 20, |_, _| {
        (1f32, 1f32, 1f32)
    })
    .unwrap();
    let e = camsim_pbrt::parse_str(
        "WorldBegin\nLightSource \"infinite\" \"string filename\" \"bad.exr\"\n",
        dir.path().join("s.pbrt"),
    )
    .unwrap_err();
    assert!(e.message.contains("square"), "{e}");
    let e = camsim_pbrt::parse_str(
        "WorldBegin\nLightSource \"infinite\" \"string filename\" \"sq.exr\" \"rgb L\" [1 1 1]\n",
        dir.path().join("s.pbrt"),
    )
    .unwrap_err();
    assert!(e.message.contains("not both"), "{e}");
}

fn tri_normal(p: &[[f64; 3]], t: &[u32; 3]) -> [f64; 3] {
    let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
    camsim_scene3d::xform::cross(
        camsim_scene3d::xform::sub(b, a),
        camsim_scene3d::xform::sub(c, a),
    )
}

#[test]
fn disk_and_cylinder_area_power_and_orientation() {
    let s = parse(
        "WorldBegin\n\
         Shape \"disk\" \"float radius\" 2 \"float innerradius\" 0.5 \"float phimax\" 270 \"float height\" 0.3\n\
         AttributeBegin\nScale 2 2 2\nAreaLightSource \"diffuse\" \"float power\" 80\n\
         Shape \"cylinder\" \"float radius\" 0.5 \"float zmin\" -1 \"float zmax\" 2 \"float phimax\" 180\n\
         AttributeEnd\n\
         AreaLightSource \"diffuse\" \"float power\" 30 \"bool twosided\" true\n\
         Shape \"disk\"\n",
    )
    .unwrap();
    assert_eq!(
        s.shapes.len(),
        3,
        "a tessellated disk/cylinder stays one shape, even with power"
    );
    let area = |i: usize| camsim_scene3d::xform::shape_area(&s.shapes[i].geometry);
    let want_disk = 0.75 * PI * (4.0 - 0.25);
    let want_cyl = 4.0 * PI * 0.5 * 3.0; // (phimax r (zmax - zmin)) scaled by 2^2
    eprintln!(
        "disk area {:.9} vs {want_disk:.9}; cylinder {:.9} vs {want_cyl:.9}",
        area(0),
        area(1)
    );
    assert!(
        rel(area(0), want_disk) < 1e-9 && rel(area(1), want_cyl) < 1e-9 && rel(area(2), PI) < 1e-9
    );
    // Emitted luminous flux pi A L_v (one-sided) / 2 pi A L_v (two-sided) equals "power".
    let phi = |i: usize, sides: f64| {
        sides * PI * area(i) * luminous(&s.shapes[i].area_light.as_ref().unwrap().radiance)
    };
    assert!(rel(phi(1, 1.0), 80.0) < 1e-9, "{}", phi(1, 1.0));
    assert!(rel(phi(2, 2.0), 30.0) < 1e-9, "{}", phi(2, 2.0));
    // Orientation: the disk faces +z; the cylinder faces away from its axis; both stay
    // within 0.01 % of the analytic radius (area-preserving polygon).
    let Geometry::Triangles {
        positions, indices, ..
    } = &s.shapes[0].geometry
    else {
        panic!()
    };
    for t in indices {
        let n = tri_normal(positions, t);
        assert!(n[2] > 0.0 && n[0].abs() < 1e-9 && n[1].abs() < 1e-9);
    }
    for p in positions {
        let r = p[0].hypot(p[1]);
        assert!(rel(r, 2.0) < 1e-4 || rel(r, 0.5) < 1e-4 || r == 0.0, "{r}");
        assert!((p[2] - 0.3).abs() < 1e-12);
    }
    let Geometry::Triangles {
        positions, indices, ..
    } = &s.shapes[1].geometry
    else {
        panic!()
    };
    for t in indices {
        let n = tri_normal(positions, t);
        let c = positions[t[0] as usize];
        assert!(
            n[0] * c[0] + n[1] * c[1] > 0.0 && n[2].abs() < 1e-9,
            "inward facet"
        );
        assert!(!s.shapes[1].reverse_orientation);
    }
    // Constant alpha 0 cuts a shape out entirely; alpha 1 is opaque.
    let s = parse(
        "WorldBegin\nShape \"disk\" \"float alpha\" 0\nShape \"cylinder\" \"float alpha\" 1\n",
    )
    .unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert!(s.notes.iter().any(|n| n.contains("alpha 0")));
    // A fraction is a per-hit stochastic test (tests/pbrt_breadth.rs renders it).
    let s = parse("WorldBegin\nShape \"disk\" \"float alpha\" 0.5\n").unwrap();
    assert!(matches!(
        s.materials[s.shapes[0].material],
        Material::AlphaMasked { .. }
    ));
    assert!(
        parse("WorldBegin\nShape \"disk\" \"float radius\" 1 \"float innerradius\" 2\n").is_err()
    );
    assert!(parse("WorldBegin\nShape \"cylinder\" \"float zmin\" 1 \"float zmax\" 1\n").is_err());
}

fn edges_of(tris: &[[u32; 3]]) -> HashMap<(u32, u32), usize> {
    let mut e = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *e.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    e
}

fn mesh_area(p: &[[f64; 3]], tris: &[[u32; 3]]) -> f64 {
    tris.iter()
        .map(|t| {
            let n = tri_normal(p, t);
            0.5 * camsim_scene3d::xform::dot(n, n).sqrt()
        })
        .sum()
}

/// Loop subdivision of a regular tetrahedron: every level stays a closed 2-manifold (each edge
/// in exactly two faces, V - E + F = 2, consistent orientation), the 4 original vertices keep
/// valence 3 and every new vertex has valence 6, the control mesh's area decreases at every
/// level, and the control meshes converge to the limit surface (the distance between control
/// and limit positions shrinks by about 4x per level).
#[test]
fn loop_subdivision_of_a_tetrahedron() {
    let s = 1.0 / 2f64.sqrt();
    let p0 = vec![
        [1.0, 0.0, -s],
        [-1.0, 0.0, -s],
        [0.0, 1.0, s],
        [0.0, -1.0, s],
    ];
    let t0 = vec![[0u32, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
    let mut prev_area = mesh_area(&p0, &t0);
    let mut prev_gap = f64::INFINITY;
    let mut prev_limit_area = 0.0;
    for level in 1..=5u32 {
        let (p, t, n) = shapes::loop_subdivide(&p0, &t0, level, false).unwrap();
        let (pl, tl, _) = shapes::loop_subdivide(&p0, &t0, level, true).unwrap();
        assert_eq!(t, tl);
        assert_eq!(t.len(), 4 * 4usize.pow(level));
        if level == 5 {
            // Level 5: control and limit-projected areas within 0.5 % of each other.
            assert!(rel(mesh_area(&pl, &tl), mesh_area(&p, &t)) < 0.005);
        }
        let e = edges_of(&t);
        assert!(
            e.values().all(|c| *c == 2),
            "level {level}: an edge is not shared by exactly two faces"
        );
        assert_eq!(
            p.len() as i64 - e.len() as i64 + t.len() as i64,
            2,
            "Euler characteristic"
        );
        let mut valence = vec![0; p.len()];
        for (a, b) in e.keys() {
            valence[*a as usize] += 1;
            valence[*b as usize] += 1;
        }
        assert!(
            valence[..4].iter().all(|v| *v == 3) && valence[4..].iter().all(|v| *v == 6),
            "level {level}: valences"
        );
        // Consistent orientation: every directed edge appears once.
        let mut directed = std::collections::HashSet::new();
        for tri in &t {
            for k in 0..3 {
                assert!(
                    directed.insert((tri[k], tri[(k + 1) % 3])),
                    "level {level}: inconsistent winding"
                );
            }
        }
        // Outward normals (the tetrahedron's centre is the origin).
        for (i, v) in p.iter().enumerate() {
            assert!(camsim_scene3d::xform::dot(n[i], *v) > 0.0);
        }
        let area = mesh_area(&p, &t);
        let gap = p
            .iter()
            .zip(&pl)
            .map(|(a, b)| {
                camsim_scene3d::xform::dot(
                    camsim_scene3d::xform::sub(*a, *b),
                    camsim_scene3d::xform::sub(*a, *b),
                )
                .sqrt()
            })
            .fold(0.0, f64::max);
        eprintln!(
            "level {level}: {} faces, control area {area:.6}, limit-projected area {:.6}, max control-limit gap {gap:.2e}",
            t.len(),
            mesh_area(&pl, &tl)
        );
        assert!(
            area < prev_area,
            "level {level}: area {area} did not decrease from {prev_area}"
        );
        assert!(
            gap < 0.5 * prev_gap,
            "level {level}: gap {gap} vs {prev_gap}"
        );
        // The limit-projected mesh is inscribed in the limit surface and the control mesh
        // encloses it: their areas bracket the limit area and close in.
        let limit_area = mesh_area(&pl, &tl);
        assert!(
            limit_area < area && limit_area > prev_limit_area,
            "level {level}: limit-projected area {limit_area}"
        );
        prev_limit_area = limit_area;
        prev_area = area;
        prev_gap = gap;
    }
    // Through the reader: pbrt-v4 defaults (levels 3) and a non-manifold input is an error.
    let text = "WorldBegin\nShape \"loopsubdiv\" \"integer levels\" 2 \"point3 P\" [1 0 -0.7071 -1 0 -0.7071 0 1 0.7071 0 -1 0.7071] \"integer indices\" [0 1 2 0 3 1 0 2 3 1 3 2]\n";
    let sc = parse(text).unwrap();
    let Geometry::Triangles {
        indices, normals, ..
    } = &sc.shapes[0].geometry
    else {
        panic!()
    };
    assert_eq!(indices.len(), 64);
    assert!(normals.is_some());
    let e =
        parse("WorldBegin\nShape \"loopsubdiv\" \"point3 P\" [0 0 0 1 0 0 0 1 0 0 0 1 1 1 1] \"integer indices\" [0 1 2 0 1 3 0 1 4]\n")
            .unwrap_err();
    assert!(e.message.contains("non-manifold"), "{e}");
}

/// Measure of {x in [0, b]: floor(x) even}, b >= 0.
fn even_measure(b: f64) -> f64 {
    let q = (b / 2.0).floor();
    q + (b - 2.0 * q).min(1.0)
}

/// A checkerboard (uscale 2.5, vscale 1.5) seen face-on: the image's mean is the analytic mix
/// of the two reflectances by area, computed from the visible (s, t) window in closed form.
#[test]
fn checkerboard_colour_fractions_match_the_analytic_areas() {
    // The reader builds the texture as pbrt-v4 defines it.
    let s = parse(
        "WorldBegin\nTexture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 2.5 \"float vscale\" 1.5 \"rgb tex1\" [0.2 0.2 0.2] \"rgb tex2\" [0.8 0.8 0.8]\n\
         Material \"diffuse\" \"texture reflectance\" \"c\"\nShape \"sphere\"\n",
    )
    .unwrap();
    let Material::Diffuse {
        reflectance:
            Texture::Checkerboard {
                tex1,
                tex2,
                mapping,
            },
    } = &s.materials[s.shapes[0].material]
    else {
        panic!("{:?}", s.materials)
    };
    assert_eq!((mapping.uscale, mapping.vscale), (2.5, 1.5));
    let Texture::Constant(k1) = &**tex1 else {
        panic!()
    };
    let Texture::Constant(k2) = &**tex2 else {
        panic!()
    };
    assert!((k1.eval(550.0) - 0.2).abs() < 1e-6 && (k2.eval(550.0) - 0.8).abs() < 1e-6);

    let (rho1, rho2) = (0.2, 0.8);
    let flat = |v: f64| Spectrum::new(vec![300.0, 900.0], vec![v, v], "t").unwrap();
    let tex = Texture::Checkerboard {
        tex1: Box::new(Texture::Constant(flat(rho1))),
        tex2: Box::new(Texture::Constant(flat(rho2))),
        mapping: UvMapping {
            uscale: 2.5,
            vscale: 1.5,
            ..Default::default()
        },
    };
    // Quad [-1, 1]^2 at z = 0 with uv = ((x + 1) / 2, (y + 1) / 2); camera 2 m above, fov 40.
    let quad = Shape {
        name: None,
        geometry: Geometry::Triangles {
            positions: vec![
                [-1.0, -1.0, 0.0],
                [1.0, -1.0, 0.0],
                [1.0, 1.0, 0.0],
                [-1.0, 1.0, 0.0],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    };
    let (d, fov) = (2.0, 40.0f64);
    let cam = Camera {
        camera_to_world: look_at_camera_to_world([0.0, 0.0, d], [0.0; 3], [0.0, 1.0, 0.0], true)
            .unwrap(),
        fov_deg: fov,
        width: 64,
        height: 64,
        lens: None,
    };
    let sc = SceneDescription {
        camera: cam,
        shapes: vec![quad],
        materials: vec![Material::Diffuse { reflectance: tex }],
        named_materials: HashMap::new(),
        lights: vec![Light::Infinite {
            radiance: flat(1.0),
        }],
        settings: RenderSettings {
            grid: WavelengthGrid::new(400.0, 700.0, 100.0).unwrap(),
            samples_per_pixel: 32,
            max_depth: 1,
            wavelengths_per_path: 4,
            seed: 5,
            time_budget_s: None,
            direct_only: false,
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    };
    let out = render(&sc, &|_, _| {}).unwrap();
    let img = &out.radiance;
    let nb = img.bands();
    let mean = (0..img.pixels())
        .map(|p| (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64)
        .sum::<f64>()
        / img.pixels() as f64;
    // Visible window: |x|, |y| <= d tan(fov / 2) (perspective of a parallel plane is a uniform
    // scaling, so image-area fractions are (s, t)-area fractions).
    let w = d * (fov.to_radians() / 2.0).tan();
    let (u0, u1) = ((1.0 - w) / 2.0, (1.0 + w) / 2.0);
    let (sa, sb, ta, tb) = (2.5 * u0, 2.5 * u1, 1.5 * u0, 1.5 * u1);
    let (es, et) = (
        even_measure(sb) - even_measure(sa),
        even_measure(tb) - even_measure(ta),
    );
    let (os, ot) = ((sb - sa) - es, (tb - ta) - et);
    let frac1 = (es * et + os * ot) / ((sb - sa) * (tb - ta));
    // Under a uniform sky of radiance 1, a Lambertian plane reads its reflectance.
    let got_frac1 = (mean - rho2) / (rho1 - rho2);
    eprintln!("checkerboard: tex1 fraction {got_frac1:.5}, analytic {frac1:.5}");
    assert!((got_frac1 - frac1).abs() < 0.005, "{got_frac1} vs {frac1}");
    assert!(
        (frac1 - 0.5).abs() > 0.02,
        "the test window must not give one half by symmetry"
    );
}

#[test]
fn one_pass_report_lists_every_problem_across_includes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("main.pbrt"),
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
         Camera \"perspective\" \"float fov\" 40\n\
         WorldBegin\n\
         LightSource \"infinite\"\n\
         \x20   MediumInterface \"fog\" \"\"\n\
         Include \"inc.pbrt\"\n\
         Shape \"sphere\" \"float radius\" 1\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("inc.pbrt"),
        "# included\nLightSource \"goniometric\" \"string filename\" \"x.exr\"\n\
         Shape \"sphere\"\n\
         \x20 Shape \"curve\" \"point3 P\" [0 0 0 1 1 1]\n",
    )
    .unwrap();
    let e = camsim_pbrt::parse_file(dir.path().join("main.pbrt")).unwrap_err();
    let all: Vec<(String, usize, usize)> = e
        .problems()
        .map(|p| {
            (
                p.file.file_name().unwrap().to_string_lossy().into_owned(),
                p.line,
                p.column,
            )
        })
        .collect();
    assert_eq!(
        all,
        // An undefined medium is found when the scene is finished (media may be defined
        // after they are selected, as in pbrt-v4): reported last.
        vec![
            ("inc.pbrt".into(), 2, 1),
            ("inc.pbrt".into(), 4, 17),
            ("main.pbrt".into(), 5, 5)
        ],
        "{e}"
    );
    let text = e.to_string();
    eprintln!("{text}");
    assert!(text.starts_with("3 problems"), "{text}");
    assert!(
        text.contains("MediumInterface") && text.contains("goniometric") && text.contains("curve"),
        "{text}"
    );
    assert!(
        text.contains("main.pbrt:5:5:")
            && text.contains("inc.pbrt:2:1:")
            && text.contains("inc.pbrt:4:17:"),
        "{text}"
    );

    // Harmless unknowns are warnings (notes), and the scene still loads.
    let s = parse(
        "Option \"bool wavefront\" true\nColorSpace \"aces2065-1\"\nPixelFilter \"mitchell\" \"float B\" 0.3\nSampler \"fancy\"\n\
         WorldBegin\nLightSource \"infinite\"\nShape \"sphere\"\n",
    )
    .unwrap();
    for needle in ["Option", "ColorSpace", "Sampler \"fancy\""] {
        assert!(
            s.notes.iter().any(|n| n.contains(needle)),
            "no note for {needle}: {:?}",
            s.notes
        );
    }
    // PixelFilter is read (pbrt-v4's defaults for what it does not give).
    assert_eq!(
        s.settings.filter,
        camsim_scene3d::scene::PixelFilter::Mitchell {
            radius: [2.0, 2.0],
            b: 0.3,
            c: 1.0 / 3.0
        }
    );
}
