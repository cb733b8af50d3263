//! Bitterli's `veach-bidir` (../shared/scenes/bitterli), read with pbrt-v4's semantics, against a
//! closed form: the torchiere's bulb (`AreaLightSource "diffuse" "rgb L" [523.2578 ...]` on a
//! quad with `"normal N"` pointing up, one-sided) lights the diffuse ceiling (`rgb reflectance`
//! 0.5) directly above it. Direct lighting only, the other light removed: the ceiling's
//! luminance is `rho / pi * E` with `E` the quad's irradiance by Lambert's polygon formula and
//! the bulb's luminance 523.2578 cd/m^2 (pbrt-v4 divides `scale` by the photometric value of
//! the colour space's illuminant only, so `rgb L` = (v, v, v) is a luminance of v; camsim
//! reads pbrt's "nit" as cd/m^2). This pins the light's scale, its emitting side and the
//! camera (the file's `Transform`, `fov` on the shorter axis), computed here independently.
//!
//! It also settles the issue-27 disagreement: pbrt-v4's spectral reference of this scene is
//! 7.5x darker there than this direct light alone (the light-tracing part of its `bdpt` image
//! is scaled by 10 / 106.857 in its spectral film; its RGB channels agree with camsim within
//! 0.5 %, `camsim_validate::pbrt_reference`).

use camsim_core::colorimetry::Cmfs;
use std::path::PathBuf;

type V = [f64; 3];
fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V) -> V {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Irradiance at `q` (surface normal `n`) from a Lambertian polygon of unit radiance:
/// `E = 1/2 sum_i angle(r_i, r_i+1) n . unit(r_i x r_i+1)` (Lambert 1760; e.g. Arvo 1995,
/// "Applications of irradiance tensors", eq. 3), `r_i` from `q` to the vertices.
fn polygon_irradiance(q: V, n: V, poly: &[V]) -> f64 {
    let mut e = 0.0;
    for i in 0..poly.len() {
        let a = norm(sub(poly[i], q));
        let b = norm(sub(poly[(i + 1) % poly.len()], q));
        let theta = dot(a, b).clamp(-1.0, 1.0).acos();
        e += theta * dot(n, norm(cross(a, b)));
    }
    (0.5 * e).abs()
}

#[test]
fn torchiere_bulb_lights_the_ceiling_as_lamberts_formula_says() {
    let file = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/bitterli/veach-bidir/scene-v4.pbrt"
    ));
    let mut scene = camsim_pbrt::parse_file(&file).unwrap();
    // Keep the bulb (the emitter at y = 6), drop the desk lamp's light.
    let bulb_y = |s: &camsim_scene3d::Shape| match &s.geometry {
        camsim_scene3d::Geometry::Triangles { positions, .. } => positions[0][1],
        _ => f64::NAN,
    };
    scene
        .shapes
        .retain(|s| s.area_light.is_none() || (bulb_y(s) - 6.0).abs() < 1e-9);
    assert_eq!(
        scene
            .shapes
            .iter()
            .filter(|s| s.area_light.is_some())
            .count(),
        1
    );
    let (w, h) = (64usize, 64usize);
    scene.camera.width = w;
    scene.camera.height = h;
    scene.settings.samples_per_pixel = 256;
    scene.settings.direct_only = true;
    // The closed form averages each pixel's square (a box filter); the file asks for a
    // triangle filter of radius 1, which would mix in the neighbours.
    scene.settings.filter = camsim_scene3d::scene::PixelFilter::Box { radius: [0.5, 0.5] };
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let img = &out.radiance;
    scene.settings.seed = scene.settings.seed.wrapping_add(1);
    let out_b = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let img_b = &out_b.radiance;
    let cmfs = Cmfs::on(&img.grid);

    // The file's camera: `Transform` is world-to-camera, given column by column; pbrt-v4's
    // perspective camera spans tan(fov / 2) on the shorter image axis, raster y down.
    let m = [
        0.00502469,
        -0.00467005,
        -0.999977,
        -0.0,
        -0.0,
        0.999989,
        -0.00467011,
        -0.0,
        -0.999987,
        -0.0000233837,
        -0.00500703,
        -0.0,
        -0.0699916,
        -3.9759,
        16.2341,
        1.0,
    ];
    let r = |i: usize, j: usize| m[j * 4 + i];
    let t = [r(0, 3), r(1, 3), r(2, 3)];
    let eye: V = std::array::from_fn(|j| -(0..3).map(|i| r(i, j) * t[i]).sum::<f64>());
    let tan = (35.0f64 / 2.0).to_radians().tan();
    let quad: [V; 4] = [
        [-2.75736, 6.0, 2.31365],
        [-2.75736, 6.0, 2.86515],
        [-2.20586, 6.0, 2.86515],
        [-2.20586, 6.0, 2.31365],
    ];
    let (rho, l_bulb) = (0.5, 523.2578);
    // Ceiling pixels just above the bulb. The room (Mesh010.ply) is the box [-4, 4]^2 x [0, 8]
    // (x, z; y up): the ceiling is the plane y = 8 (normal down), the back wall the plane x = -4
    // (normal +x). Row 11's pixels reach past the ceiling's far edge (x = -4 at raster y ~ 11.7)
    // onto the wall, so each sub-pixel ray takes the nearer of the two planes.
    let want_at = |px: usize, py: usize| {
        let k = 12;
        let mut want = 0.0;
        for sy in 0..k {
            for sx in 0..k {
                let fx = px as f64 + (sx as f64 + 0.5) / k as f64;
                let fy = py as f64 + (sy as f64 + 0.5) / k as f64;
                let dc = [
                    (2.0 * fx / w as f64 - 1.0) * tan,
                    (1.0 - 2.0 * fy / h as f64) * tan,
                    1.0,
                ];
                let d: V = std::array::from_fn(|j| (0..3).map(|i| r(i, j) * dc[i]).sum::<f64>());
                let (s_ceiling, s_wall) = ((8.0 - eye[1]) / d[1], (-4.0 - eye[0]) / d[0]);
                let (s, n) = if s_wall > 0.0 && s_wall < s_ceiling {
                    (s_wall, [1.0, 0.0, 0.0])
                } else {
                    (s_ceiling, [0.0, -1.0, 0.0])
                };
                let q = std::array::from_fn(|j| eye[j] + s * d[j]);
                want += rho / std::f64::consts::PI * polygon_irradiance(q, n, &quad);
            }
        }
        want * l_bulb / (k * k) as f64
    };
    let pixels = [
        (17usize, 9usize),
        (18, 9),
        (17, 10),
        (18, 10),
        (16, 11),
        (19, 11),
    ];
    let luminance = |img: &camsim_core::SpectralImage, px: usize, py: usize| {
        let spectrum: Vec<f64> = (0..img.bands())
            .map(|b| img.band(b)[py * w + px] as f64)
            .collect();
        cmfs.luminance_cd_m2(&spectrum)
    };
    // Monte Carlo noise from a second render with another seed: per pixel the two renders'
    // relative difference has variance 2 s^2 (s the relative standard deviation of one render),
    // pooled over the pixels; the mean of the two renders has s / sqrt(2).
    let mut var_sum = 0.0;
    let mut rels = Vec::new();
    for &(px, py) in &pixels {
        let want = want_at(px, py);
        let (a, b) = (luminance(img, px, py), luminance(img_b, px, py));
        let got = 0.5 * (a + b);
        var_sum += ((a - b) / got).powi(2) / 2.0;
        rels.push(got / want - 1.0);
        eprintln!(
            "pixel ({px}, {py}): {got:.4} cd/m^2 (seeds {a:.4}, {b:.4}), Lambert {want:.4} ({:+.2} %)",
            100.0 * (got / want - 1.0)
        );
    }
    let se = (var_sum / pixels.len() as f64 / 2.0).sqrt();
    eprintln!("standard error of a pixel's mean: {:.2} %", 100.0 * se);
    // The noise estimate itself must be small, or the tolerance below would mean nothing.
    assert!(se < 0.01, "noise {se}");
    // 4 standard errors of the noise, plus 0.5 % for the closed form's 12 x 12 sub-pixel rule
    // and the f32 film.
    for (&(px, py), rel) in pixels.iter().zip(&rels) {
        assert!(rel.abs() < 4.0 * se + 0.005, "pixel ({px}, {py}): {rel}");
    }
}
