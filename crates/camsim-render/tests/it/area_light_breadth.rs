//! Area-light breadth (issue 12): pbrt-v4 `AreaLightSource "diffuse"` with an emission image
//! (`filename`) on spheres, and alpha-masked area lights (pbrt-v4 `DiffuseAreaLight::AlphaMasked`),
//! against closed forms and independent quadratures.
//!
//! Irradiance is measured with a receiver that transmits diffusely (reflectance 0,
//! transmittance 1): seen from below it has the radiance `E / pi`, with `E` the irradiance on
//! its top side (Lambert). It is lit by next-event estimation and by BSDF samples that hit the
//! light, combined by MIS, so a light whose sampled points and hit points disagree (uv, image,
//! mask) misses the reference. References:
//! - a sphere of uniform radiance `L` fully above the horizon: `E = pi L (R / r)^2 cos(theta)`
//!   (`r` the distance to its centre, `theta` the centre's angle from the normal; Howell's
//!   catalogue of view factors, sphere to a tilted differential area);
//! - a sphere of varying radiance: `E = int L(q) cos_p cos_q / |q - p|^2 dA` by a midpoint
//!   quadrature over the sphere (every point facing `p` is visible: the sphere is convex);
//! - a polygon of uniform radiance: Lambert's contour formula `E = L / 2 |sum_i gamma_i
//!   (v_i x v_{i+1}) / |v_i x v_{i+1}| . n|`, `gamma_i` the angle between the unit vectors to
//!   consecutive vertices (e.g. Arvo 1995, "Applications of irradiance tensors", eq. 7).

use camsim_core::WavelengthGrid;
use camsim_render::*;
use camsim_scene3d::*;
use std::f64::consts::PI;
use std::path::Path;

/// Texels per image row of the sphere images (the bilinear blur at the quadrant borders spans
/// one texel).
const W: usize = 64;
/// Radiance per unit RGB of the four azimuth quadrants of the split image: phi in [0, 90),
/// [90, 180), [180, 270), [270, 360) deg (u = phi / 2 pi). The +y half (u < 0.5) is bright.
const QUAD: [f32; 4] = [4.0, 3.0, 1.0, 0.0];
/// Sphere radius and centre height, m.
const R_M: f64 = 0.3;
const H_M: f64 = 1.0;

/// A linear RGB PFM of `w` x `h` grey texels `f(x, y)` (row 0 at the top), written to `dir`.
fn pfm(dir: &Path, name: &str, w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> String {
    // PFM: "PF", size, negative scale = little endian, rows stored bottom to top.
    let mut bytes = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in (0..h).rev() {
        for x in 0..w {
            for _ in 0..3 {
                bytes.extend_from_slice(&f(x, y).to_le_bytes());
            }
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.to_string_lossy().into_owned()
}

/// The split image's texel at column `x`.
fn quad_texel(x: usize) -> f32 {
    QUAD[x * 4 / W]
}

/// The split image as the renderer reads it at `u` (bilinear, repeat, texel centres at
/// half-integers: pbrt-v4 `Image::Bilerp`).
fn quad_image_at(u: f64) -> f64 {
    let x = u * W as f64 - 0.5;
    let x0 = x.floor();
    let f = x - x0;
    let wrap = |i: f64| (i as i64).rem_euclid(W as i64) as usize;
    (1.0 - f) * quad_texel(wrap(x0)) as f64 + f * quad_texel(wrap(x0 + 1.0)) as f64
}

/// A scene header: a camera at `from` looking at `to`, `n` x `n` pixels, `spp` samples, direct
/// lighting only.
fn header(
    from: [f64; 3],
    to: [f64; 3],
    up: [f64; 3],
    fov_deg: f64,
    n: usize,
    spp: usize,
) -> String {
    format!(
        "LookAt {} {} {}  {} {} {}  {} {} {}\nCamera \"perspective\" \"float fov\" {fov_deg}\n\
         Film \"rgb\" \"integer xresolution\" {n} \"integer yresolution\" {n}\n\
         Sampler \"sobol\" \"integer pixelsamples\" {spp}\nIntegrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n",
        from[0], from[1], from[2], to[0], to[1], to[2], up[0], up[1], up[2]
    )
}

/// A 2 cm diffuse transmitter (reflectance 0, transmittance 1) centred on `(x, y, 0)`, facing
/// up; `receiver_view` is the camera below it that sees only it.
fn receiver(x: f64, y: f64) -> String {
    let s = 0.01;
    format!(
        "AttributeBegin\nMaterial \"diffusetransmission\" \"spectrum reflectance\" [300 0 900 0] \
         \"spectrum transmittance\" [300 1 900 1]\nShape \"trianglemesh\" \"point3 P\" \
         [{} {} 0  {} {} 0  {} {} 0  {} {} 0] \"integer indices\" [0 1 2 0 2 3]\nAttributeEnd\n",
        x - s,
        y - s,
        x + s,
        y - s,
        x + s,
        y + s,
        x - s,
        y + s
    )
}

fn receiver_view(x: f64, y: f64, n: usize, spp: usize) -> String {
    header([x, y, -1.0], [x, y, 0.0], [0.0, 1.0, 0.0], 0.5, n, spp)
}

fn parse(text: &str, dir: &Path) -> SceneDescription {
    let mut s = camsim_pbrt::parse_str(text, dir.join("scene.pbrt"))
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    s.settings.grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    s
}

/// Band average of the spectrum `s` over the 31 bands of the 400..700 nm grid (10 nm each,
/// centred on the grid's wavelengths), averaged over the bands (dense midpoint quadrature):
/// the per-unit value a flat-scaled pixel estimates.
fn band_mean(s: &camsim_core::Spectrum) -> f64 {
    (0..31)
        .map(|k| {
            (0..100)
                .map(|j| s.eval(395.0 + 10.0 * k as f64 + 0.1 * (j as f64 + 0.5)))
                .sum::<f64>()
                / 100.0
        })
        .sum::<f64>()
        / 31.0
}

/// The band-averaged radiance of every pixel.
fn pixels(out: &RenderOutput) -> Vec<f64> {
    let img = &out.radiance;
    (0..img.pixels())
        .map(|p| (0..img.bands()).map(|b| img.band(b)[p] as f64).sum::<f64>() / img.bands() as f64)
        .collect()
}

/// Mean over the pixels and its standard error (the pixels are independent estimates of one
/// value).
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Render `s` and return (mean pixel, standard error), divided by `unit`.
fn measure(s: &SceneDescription, unit: f64) -> (f64, f64) {
    let out = render(s, &|_, _| {}).unwrap();
    let (m, se) = mean_se(&pixels(&out));
    (m / unit, se / unit)
}

/// The illuminant of the first emitting shape (per unit RGB for an image light).
fn emitter_unit(s: &SceneDescription) -> f64 {
    band_mean(
        &s.shapes
            .iter()
            .find_map(|sh| sh.area_light.as_ref())
            .unwrap()
            .radiance,
    )
}

fn check(what: &str, got: (f64, f64), want: f64, systematic: f64) {
    let (m, se) = got;
    eprintln!(
        "{what}: got {m:.5} +- {se:.5}, want {want:.5} ({:+.2} sigma, {:+.3} %)",
        (m - want) / se,
        (m / want - 1.0) * 100.0
    );
    assert!(
        (m - want).abs() <= 3.0 * se + systematic * want.abs(),
        "{what}: {m} +- {se} vs {want}"
    );
}

/// Irradiance at `p` (normal +z) from the sphere of radius `R_M` at `(0, 0, H_M)` with radiance
/// `l(phi_world)` (per unit), by midpoint quadrature over the sphere.
fn sphere_irradiance(p: [f64; 3], l: impl Fn(f64) -> f64) -> f64 {
    let (nt, np) = (400, 800);
    let (dt, dp) = (PI / nt as f64, 2.0 * PI / np as f64);
    let mut e = 0.0;
    for i in 0..nt {
        let th = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let ph = (j as f64 + 0.5) * dp;
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            let w = [
                R_M * n[0] - p[0],
                R_M * n[1] - p[1],
                H_M + R_M * n[2] - p[2],
            ];
            let d2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
            let d = d2.sqrt();
            let cos_q = -(n[0] * w[0] + n[1] * w[1] + n[2] * w[2]) / d;
            let cos_p = w[2] / d;
            if cos_q > 0.0 && cos_p > 0.0 {
                e += l(ph) * cos_q * cos_p / d2 * R_M * R_M * th.sin() * dt * dp;
            }
        }
    }
    e
}

/// Lambert's contour formula: irradiance at `p` (normal +z) from the polygon `poly` of unit
/// radiance.
fn polygon_irradiance(p: [f64; 3], poly: &[[f64; 3]]) -> f64 {
    let unit = |q: [f64; 3]| {
        let v = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    };
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let (a, b) = (unit(poly[i]), unit(poly[(i + 1) % poly.len()]));
        let c = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let cl = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let gamma = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
            .clamp(-1.0, 1.0)
            .acos();
        sum += gamma * c[2] / cl;
    }
    0.5 * sum.abs()
}

fn rect(x0: f64, x1: f64, y0: f64, y1: f64, z: f64) -> [[f64; 3]; 4] {
    [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]
}

/// A sphere light of radius `R_M` at `(0, 0, H_M)`, `extra` transforms inside its attributes.
fn sphere_light(light: &str, extra: &str) -> String {
    partial_sphere_light(light, extra, "")
}

/// As [`sphere_light`] with more sphere parameters (`zmin`, `zmax`, `phimax`).
fn partial_sphere_light(light: &str, extra: &str, shape: &str) -> String {
    format!(
        "AttributeBegin\nTranslate 0 0 {H_M}\n{extra}\nAreaLightSource \"diffuse\" {light}\n\
         Material \"diffuse\" \"rgb reflectance\" [0 0 0]\nShape \"sphere\" \"float radius\" {R_M} {shape}\nAttributeEnd\n"
    )
}

/// A sphere whose image is a constant `c` renders as the sphere with `rgb L [c c c]` (pbrt-v4:
/// texels and `L` are both RGB illuminant spectra of the colour space): seen directly, and as
/// the irradiance it gives a receiver below, which is also the closed form `pi L (R / r)^2`.
#[test]
fn uniform_image_sphere_equals_constant_radiance_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let c = 0.7f32;
    let file = pfm(dir.path(), "flat.pfm", 8, 4, |_, _| c);
    let lights = [
        format!("\"string filename\" \"{file}\""),
        format!("\"rgb L\" [{c} {c} {c}]"),
    ];
    let mut seen = vec![];
    let mut lit = vec![];
    for l in &lights {
        // Directly seen from the side, 5 x 5 pixels inside the disc.
        let s = parse(
            &format!(
                "{}{}",
                header(
                    [0.0, -3.0, H_M],
                    [0.0, 0.0, H_M],
                    [0.0, 0.0, 1.0],
                    3.0,
                    5,
                    16
                ),
                sphere_light(l, "")
            ),
            dir.path(),
        );
        let unit = emitter_unit(&s)
            * if l.contains("filename") {
                c as f64
            } else {
                1.0
            };
        seen.push(measure(&s, unit).0);
        let s = parse(
            &format!(
                "{}{}{}",
                receiver_view(0.0, 0.0, 8, 64),
                sphere_light(l, ""),
                receiver(0.0, 0.0)
            ),
            dir.path(),
        );
        let got = measure(&s, unit);
        // Receiver on the axis: E / pi = L (R / H)^2.
        check(
            &format!("uniform sphere ({l}), E / (pi L)"),
            got,
            (R_M / H_M).powi(2),
            1e-3,
        );
        lit.push(got);
    }
    eprintln!(
        "directly seen / L: image {:.6}, constant {:.6}",
        seen[0], seen[1]
    );
    // Same seed, same wavelengths: equal to f32 rounding; against L within the wavelength
    // sampling noise of 5 x 5 x 16 paths.
    assert!((seen[0] - seen[1]).abs() < 1e-5, "{seen:?}");
    assert!((seen[0] - 1.0).abs() < 0.01, "{seen:?}");
    assert!(
        (lit[0].0 - lit[1].0).abs() < 3.0 * (lit[0].1 + lit[1].1),
        "{lit:?}"
    );
}

/// The split image (the +y half bright) on a sphere: the irradiance below on its axis, at +y
/// and at -y follows the quadrature of the image over the sphere (so the bright side is on +y:
/// u runs with phi = atan2(y, x), not mirrored), and the sphere seen from azimuth phi shows
/// the quadrant of phi. A rotated sphere (Rotate 90 about z) carries its image with it (uv in
/// its object frame).
#[test]
fn split_image_sphere_follows_pbrt_uv_in_the_object_frame() {
    let dir = tempfile::tempdir().unwrap();
    let file = pfm(dir.path(), "split.pfm", W, 1, |x, _| quad_texel(x));
    let light = format!("\"string filename\" \"{file}\"");
    let image_at_phi = |ph: f64| quad_image_at(ph / (2.0 * PI));
    for (x, y, extra, phi0) in [
        (0.0, 0.0, "", 0.0),
        (0.0, 0.4, "", 0.0),
        (0.0, -0.4, "", 0.0),
        // Object +x is world +y: object phi = world phi - 90 deg; object +y (bright) is world -x.
        (-0.4, 0.0, "Rotate 90 0 0 1", 0.5 * PI),
        (0.4, 0.0, "Rotate 90 0 0 1", 0.5 * PI),
    ] {
        let s = parse(
            &format!(
                "{}{}{}",
                receiver_view(x, y, 8, 64),
                sphere_light(&light, extra),
                receiver(x, y)
            ),
            dir.path(),
        );
        let got = measure(&s, emitter_unit(&s));
        let want = sphere_irradiance([x, y, 0.0], |ph| {
            image_at_phi((ph - phi0).rem_euclid(2.0 * PI))
        }) / PI;
        check(
            &format!("split sphere {extra:?}, receiver at ({x}, {y}), E / pi per unit RGB"),
            got,
            want,
            2e-3,
        );
    }
    // The bright side really is brighter: the reference itself differs by far more than noise.
    let (e_plus, e_minus) = (
        sphere_irradiance([0.0, 0.4, 0.0], image_at_phi),
        sphere_irradiance([0.0, -0.4, 0.0], image_at_phi),
    );
    eprintln!(
        "split sphere: reference E(+y) / E(-y) = {:.3}",
        e_plus / e_minus
    );
    assert!(e_plus > 1.3 * e_minus);

    // Seen from azimuth phi (narrow view of the equator point there): the texel of phi's
    // quadrant (centres of the quadrants, away from the bilinear borders).
    for (extra, phi0) in [("", 0.0), ("Rotate 90 0 0 1", 0.5 * PI)] {
        for k in 0..4 {
            let ph = (45.0 + 90.0 * k as f64).to_radians();
            let from = [3.0 * ph.cos(), 3.0 * ph.sin(), H_M];
            let s = parse(
                &format!(
                    "{}{}",
                    header(from, [0.0, 0.0, H_M], [0.0, 0.0, 1.0], 1.0, 3, 16),
                    sphere_light(&light, extra)
                ),
                dir.path(),
            );
            let (got, _) = measure(&s, emitter_unit(&s));
            let want = image_at_phi((ph - phi0).rem_euclid(2.0 * PI));
            eprintln!(
                "split sphere {extra:?} seen from phi = {:.0} deg: {got:.4} (texel {want})",
                ph.to_degrees()
            );
            // Within the wavelength sampling noise of 3 x 3 x 16 paths.
            assert!(
                (got - want).abs() < 0.01 * want.max(1.0),
                "{extra:?} phi {}: {got} vs {want}",
                ph.to_degrees()
            );
        }
    }
    // A half sphere (phimax 180 deg): u = phi / phi_max, so the four quadrants of the image
    // lie at phi = 22.5, 67.5, 112.5, 157.5 deg.
    for (k, want) in QUAD.iter().enumerate() {
        let ph = (22.5 + 45.0 * k as f64).to_radians();
        let from = [3.0 * ph.cos(), 3.0 * ph.sin(), H_M];
        let text = format!(
            "{}{}",
            header(from, [0.0, 0.0, H_M], [0.0, 0.0, 1.0], 1.0, 3, 16),
            partial_sphere_light(&light, "", "\"float phimax\" 180")
        );
        let s = parse(&text, dir.path());
        let (got, _) = measure(&s, emitter_unit(&s));
        let want = *want as f64;
        eprintln!(
            "split half sphere seen from phi = {:.1} deg: {got:.4} (texel {want})",
            ph.to_degrees()
        );
        assert!(
            (got - want).abs() < 0.01 * want.max(1.0),
            "half sphere phi {}: {got} vs {want}",
            ph.to_degrees()
        );
    }
}

/// A 1 m x 1 m two-sided quad light at height 0.5 m, uv (0,0)..(1,1) along x and y, with the
/// shape's `alpha` parameter `alpha`.
fn quad_light(alpha: &str) -> String {
    format!(
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n\
         Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         Shape \"trianglemesh\" \"point3 P\" [-0.5 -0.5 0.5  0.5 -0.5 0.5  0.5 0.5 0.5  -0.5 0.5 0.5] \
         \"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1] {alpha}\nAttributeEnd\n"
    )
}

/// 2 x 2 alpha checkerboard: uv cells (0, 0) and (1, 1) kept (tex1 = 1), the others cut (0).
const CHECKER: &str =
    "Texture \"mask\" \"float\" \"checkerboard\" \"float tex1\" 1 \"float tex2\" 0 \
                       \"float uscale\" 2 \"float vscale\" 2\n";

/// An alpha checkerboard on a quad light: the irradiance below is that of the kept cells
/// (Lambert's polygon formula), and the light seen directly shows the environment through the
/// cut cells.
#[test]
fn alpha_checkerboard_quad_light_emits_only_where_kept() {
    let dir = tempfile::tempdir().unwrap();
    // Under a kept cell and under a cut one: the kept cells give 57 % and 43 % of the full
    // quad's irradiance there, far from the 50 % of a uniform half mask.
    for (x, y) in [(0.2, 0.15), (0.2, -0.15)] {
        let p = [x, y, 0.0];
        let kept = polygon_irradiance(p, &rect(-0.5, 0.0, -0.5, 0.0, 0.5))
            + polygon_irradiance(p, &rect(0.0, 0.5, 0.0, 0.5, 0.5));
        let full = polygon_irradiance(p, &rect(-0.5, 0.5, -0.5, 0.5, 0.5));
        assert!(
            (kept - 0.5 * full).abs() > 0.06 * full,
            "the point must tell the checkerboard from a uniform half"
        );
        let text = format!(
            "{}{CHECKER}{}{}",
            receiver_view(x, y, 8, 64),
            quad_light("\"texture alpha\" \"mask\""),
            receiver(x, y)
        );
        let s = parse(&text, dir.path());
        let got = measure(&s, emitter_unit(&s));
        check(
            &format!(
                "checkerboard-masked quad at ({x}, {y}), E / pi (kept / full = {:.3})",
                kept / full
            ),
            got,
            kept / PI,
            1e-3,
        );
    }

    // Seen from below (narrow views of cell centres): a kept cell shows the light (L = 1),
    // a cut cell the uniform environment behind it (L = 0.25).
    for (cx, cy, want) in [
        (-0.25, -0.25, 1.0),
        (0.25, 0.25, 1.0),
        (0.25, -0.25, 0.25),
        (-0.25, 0.25, 0.25),
    ] {
        let text = format!(
            "{}{CHECKER}LightSource \"infinite\" \"rgb L\" [0.25 0.25 0.25]\n{}",
            header([cx, cy, -0.5], [cx, cy, 0.5], [0.0, 1.0, 0.0], 1.0, 3, 16),
            quad_light("\"texture alpha\" \"mask\"")
        );
        let s = parse(&text, dir.path());
        let (got, _) = measure(&s, emitter_unit(&s));
        eprintln!("checkerboard quad seen at ({cx}, {cy}): {got:.4} (want {want})");
        assert!((got - want).abs() < 0.01, "({cx}, {cy}): {got} vs {want}");
    }
}

/// A constant alpha 0.5 on a quad light: half the unmasked irradiance (pbrt-v4's stochastic
/// alpha test, here the renderer's ray hash, passes half the points on average), and seen
/// directly, the mean of the light and the environment behind it.
#[test]
fn fractional_alpha_quad_light_gives_half_the_irradiance() {
    let dir = tempfile::tempdir().unwrap();
    let p = [0.1, -0.2, 0.0];
    let full = polygon_irradiance(p, &rect(-0.5, 0.5, -0.5, 0.5, 0.5));
    let text = format!(
        "{}{}{}",
        receiver_view(p[0], p[1], 8, 128),
        quad_light("\"float alpha\" 0.5"),
        receiver(p[0], p[1])
    );
    let s = parse(&text, dir.path());
    let got = measure(&s, emitter_unit(&s));
    check("alpha 0.5 quad, E / pi", got, 0.5 * full / PI, 1e-3);
    // Unmasked, the same point gets the full irradiance (the receiver setup itself is right).
    let text = format!(
        "{}{}{}",
        receiver_view(p[0], p[1], 8, 64),
        quad_light(""),
        receiver(p[0], p[1])
    );
    let s = parse(&text, dir.path());
    check(
        "unmasked quad, E / pi",
        measure(&s, emitter_unit(&s)),
        full / PI,
        1e-3,
    );

    let text = format!(
        "{}LightSource \"infinite\" \"rgb L\" [0.25 0.25 0.25]\n{}",
        header(
            [0.0, 0.0, -0.5],
            [0.0, 0.0, 0.5],
            [0.0, 1.0, 0.0],
            1.0,
            8,
            64
        ),
        quad_light("\"float alpha\" 0.5")
    );
    let s = parse(&text, dir.path());
    check(
        "alpha 0.5 quad seen over an environment of 0.25",
        measure(&s, emitter_unit(&s)),
        0.625,
        1e-3,
    );
}

/// A two-sided sphere light with alpha 0.5, seen from a receiver below on its axis: every
/// direction within the sphere's cone meets its near side (kept with probability 1/2) and, where
/// that is cut, its far side's inner face (kept with 1/2 again, emitting since two-sided), so
/// the irradiance is 3/4 of the opaque sphere's `pi L (R / H)^2`. Light sampling must reach the
/// far side through the holes.
#[test]
fn fractional_alpha_two_sided_sphere_shows_its_far_side() {
    let dir = tempfile::tempdir().unwrap();
    let light = "\"rgb L\" [1 1 1] \"bool twosided\" true";
    let text = format!(
        "{}{}{}",
        receiver_view(0.0, 0.0, 8, 128),
        partial_sphere_light(light, "", "\"float alpha\" 0.5"),
        receiver(0.0, 0.0)
    );
    let s = parse(&text, dir.path());
    check(
        "two-sided sphere with alpha 0.5, E / (pi L)",
        measure(&s, emitter_unit(&s)),
        0.75 * (R_M / H_M).powi(2),
        1e-3,
    );
}

/// Bad input stays a clear error: a missing emission image names the file and the line.
#[test]
fn missing_emission_image_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{}AttributeBegin\nAreaLightSource \"diffuse\" \"string filename\" \"missing.pfm\"\nShape \"sphere\"\nAttributeEnd\n",
        header([0.0, -3.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 30.0, 4, 1)
    );
    let e = camsim_pbrt::parse_str(&text, dir.path().join("scene.pbrt"))
        .unwrap_err()
        .to_string();
    eprintln!("{e}");
    assert!(
        e.contains("scene.pbrt:8") && e.contains("missing.pfm"),
        "{e}"
    );
}
