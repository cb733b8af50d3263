//! Where rays leave a surface (pbrt-v4 `OffsetRayOrigin`, 4th ed. §6.8.6): far enough off the
//! hit point that they cannot hit the surface again, near enough to meet a surface a hair's
//! breadth away, at any distance from the origin. Real scenes model parts that touch (the coffee
//! scene's plastic collar sits on the carafe's glass within microns); pbrt-v4 offsets by the hit
//! point's floating-point error bound, and so does camsim.
//! * a light 10 um behind a glass slab is seen through it: radiance `T L` with the slab's
//!   transmittance `T = (1 - F)^2 / (1 - F^2)` (incoherent internal reflections, normal
//!   incidence), against the same light seen directly;
//! * no self-intersection: a diffuse square under a uniform sky has radiance `rho L` exactly,
//!   1 mm across at the origin and 2 m across 10 km away (where f32 positions are coarse).

fn render(text: &str) -> Vec<f64> {
    let scene = camsim_pbrt::parse_str(text, "/tmp/virtual/offsets.pbrt").unwrap();
    let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
    let img = &out.radiance;
    (0..img.bands())
        .map(|b| img.band(b).iter().map(|&v| v as f64).sum::<f64>() / img.pixels() as f64)
        .collect()
}

/// Mean over bands and its standard error from the per-band means' scatter around a smooth
/// reference ratio (the ratio of two spectra with the same shape is flat).
fn ratio_and_se(a: &[f64], b: &[f64]) -> (f64, f64) {
    let r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    let n = r.len() as f64;
    let m = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

const CAMERA: &str = r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" [ 2 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
Sampler "independent" "integer pixelsamples" [ 256 ]
Integrator "path" "integer maxdepth" [ 12 ]
WorldBegin
"#;

/// A light facing the camera (-z) at distance `z`, 10 m across.
fn light(z: f64) -> String {
    format!(
        r#"AttributeBegin
AreaLightSource "diffuse" "rgb L" [ 1 1 1 ]
Shape "trianglemesh" "point3 P" [ -5 -5 {z} -5 5 {z} 5 5 {z} 5 -5 {z} ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
"#
    )
}

#[test]
fn light_microns_behind_glass_is_seen_through_it() {
    // Glass slab from z = 1 to 1.01 m (front face toward the camera, back face toward the
    // light), the light 10 um behind its back face. The previous offset, 3e-5 (1 + |p|) = 61 um
    // at 1 m, put every ray leaving the back face behind the light: the pixel was black.
    let slab = r#"Material "dielectric" "float eta" [ 1.5 ]
Shape "trianglemesh" "point3 P" [ -4 -4 1  4 -4 1  4 4 1  -4 4 1 ] "integer indices" [ 0 1 2 0 2 3 ]
Shape "trianglemesh" "point3 P" [ -4 -4 1.01  -4 4 1.01  4 4 1.01  4 -4 1.01 ] "integer indices" [ 0 1 2 0 2 3 ]
"#;
    let through = render(&format!("{CAMERA}{slab}{}", light(1.01001)));
    let direct = render(&format!("{CAMERA}{}", light(1.01001)));
    let f = ((1.5f64 - 1.0) / (1.5 + 1.0)).powi(2);
    let want = (1.0 - f) * (1.0 - f) / (1.0 - f * f);
    let (got, se) = ratio_and_se(&through, &direct);
    eprintln!("light 10 um behind glass: T = {got:.5} +- {se:.5}, closed form {want:.5}");
    assert!((got - want).abs() < 4.0 * se + 2e-3, "{got} vs {want}");
}

#[test]
fn no_self_intersection_near_or_far_from_the_origin() {
    // A diffuse square of reflectance 0.5 under a uniform sky of radiance L: every direction
    // above it sees the sky, so its radiance is 0.5 L (NEE and BSDF samples alike). A shadow or
    // bounce ray that hit the square itself would darken it. The square is tilted off every
    // axis (rotated 37 degrees about (1, 1, 0)): in an axis-aligned plane the intersection
    // test's `t` is exact and even a zero offset would pass. The camera, 2 h above the square
    // along its normal and 0.5 h aside, looking at its centre with a 20 degree field of view,
    // sees the square alone: its rays meet the plane within 0.39 h of the centre.
    let axis = [0.5f64.sqrt(), 0.5f64.sqrt(), 0.0];
    let (sin, cos) = 37f64.to_radians().sin_cos();
    // Rodrigues' rotation formula.
    let rot = |v: [f64; 3]| -> [f64; 3] {
        let k = axis;
        let kxv = [
            k[1] * v[2] - k[2] * v[1],
            k[2] * v[0] - k[0] * v[2],
            k[0] * v[1] - k[1] * v[0],
        ];
        let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        std::array::from_fn(|i| v[i] * cos + kxv[i] * sin + k[i] * kv * (1.0 - cos))
    };
    for (centre, half) in [(0.0f64, 5e-4f64), (1e4, 1.0)] {
        let (c, h) = (centre, half);
        let at = |v: [f64; 3]| {
            let r = rot(v);
            format!("{} {} {}", c + r[0], c + r[1], c + r[2])
        };
        let corners = [[-h, 0.0, -h], [-h, 0.0, h], [h, 0.0, h], [h, 0.0, -h]].map(at);
        let up = rot([0.0, 1.0, 0.0]);
        let text = format!(
            r#"LookAt {}  {c} {c} {c}  {} {} {}
Camera "perspective" "float fov" [ 20 ]
Film "rgb" "integer xresolution" [ 8 ] "integer yresolution" [ 8 ]
Sampler "independent" "integer pixelsamples" [ 64 ]
Integrator "path" "integer maxdepth" [ 5 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ {} {} {} {} ] "integer indices" [ 0 1 2 0 2 3 ]
"#,
            at([0.0, 2.0 * h, 0.5 * h]),
            up[0],
            up[1],
            up[2],
            corners[0],
            corners[1],
            corners[2],
            corners[3],
        );
        let plane = render(&text);
        // The sky seen directly (the same camera, no square).
        let sky_text = text.split("Material").next().unwrap().to_string();
        let sky = render(&sky_text);
        let (got, se) = ratio_and_se(&plane, &sky);
        eprintln!(
            "square {:.0e} m wide at {c:.0e} m: radiance / sky = {got:.5} +- {se:.5}",
            2.0 * h
        );
        assert!((got - 0.5).abs() < 4.0 * se + 2e-3, "{got} at {c}");
    }
}
