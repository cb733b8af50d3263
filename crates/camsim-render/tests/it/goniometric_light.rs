//! pbrt-v4 `goniometric` light (issue 12), read by the pbrt reader and rendered: closed-form
//! checks on a Lambertian floor (reflectance `rho`) lit by the light alone. A delta light adds no
//! Monte Carlo noise to direct lighting, so pixels are compared with `rho / pi * E`, `E = I(w)
//! cos(theta) / d^2` (inverse-square law, pbrt-v4 4th ed. §12.1), averaged over each pixel's
//! footprint by 8 x 8 sub-samples of the same closed form.
//!
//! Image geometry (pbrt-v4 `GoniometricLight`, 4th ed. §12.2.3): the light-frame direction `w`
//! selects texel `EqualAreaSphereToSquare(w)` (u across, v down the image), and the light frame
//! is the CTM with y and z swapped. So in CTM coordinates (X, Y, Z): the left image half (u < 1/2)
//! is X < 0, the top half (v < 1/2) is Z < 0 (below the light), the bottom half Z > 0.

use camsim_core::{Spectrum, WavelengthGrid};
use camsim_render::*;
use camsim_scene3d::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

use crate::common;
const RHO: f64 = 0.5;
/// Light (and camera) height above the floor, m; field of view, deg; image side, pixels.
const H_M: f64 = 1.0;
const FOV_DEG: f64 = 90.0;
const N_PX: usize = 16;

fn flat(v: f64) -> Spectrum {
    Spectrum::new(vec![300.0, 900.0], vec![v, v], "test").unwrap()
}

/// Writes a grey PFM (`Pf`, little-endian, rows stored bottom to top) of `n x m` texels with
/// value `f(column, row)`, row 0 at the top.
fn write_pfm(path: &Path, n: usize, m: usize, f: impl Fn(usize, usize) -> f32) {
    let mut bytes = format!("Pf\n{n} {m}\n-1.0\n").into_bytes();
    for row in (0..m).rev() {
        for col in 0..n {
            bytes.extend_from_slice(&f(col, row).to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// Parses one light: `xform` (transform directives) then `LightSource "<kind>" <params>` inside
/// an attribute block, in a scene file in `dir`.
fn parse_light(
    dir: &Path,
    xform: &str,
    kind: &str,
    params: &str,
) -> Result<Light, camsim_pbrt::PbrtError> {
    let text = format!(
        "WorldBegin\nAttributeBegin\n{xform}\nLightSource \"{kind}\" {params}\nAttributeEnd\n"
    );
    let scene = camsim_pbrt::parse_str(&text, dir.join("scene.pbrt"))?;
    assert_eq!(scene.lights.len(), 1);
    Ok(scene.lights[0].clone())
}

/// Flat `I` so the closed form needs no band averaging.
const FLAT_I: &str = "\"spectrum I\" [300 1 900 1]";

/// The light's flat intensity per unit image value, W/(sr nm).
fn intensity_w_sr_nm(l: &Light) -> f64 {
    let s = match l {
        Light::Point { intensity, .. } => intensity,
        Light::Goniometric(g) => &g.intensity,
        other => panic!("unexpected light {other:?}"),
    };
    let (a, b) = (s.eval(400.0), s.eval(700.0));
    assert!((a - b).abs() <= 1e-12 * a, "intensity not flat: {a} vs {b}");
    a
}

/// Renders the floor z = 0 (a 200 m square) seen straight down from (0, 0, H_M), `up` +y, lit by
/// `light` alone; per-pixel mean over bands.
fn render_floor(light: Light) -> Vec<f64> {
    let camera = Camera {
        camera_to_world: look_at_camera_to_world([0.0, 0.0, H_M], [0.0; 3], [0.0, 1.0, 0.0], true)
            .unwrap(),
        fov_deg: FOV_DEG,
        width: N_PX,
        height: N_PX,
        lens: None,
    };
    let floor = common::floor(100.0);
    let scene = SceneDescription {
        camera,
        shapes: vec![floor],
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(flat(RHO)),
        }],
        named_materials: HashMap::new(),
        lights: vec![light],
        settings: RenderSettings {
            grid: WavelengthGrid::new(400.0, 700.0, 100.0).unwrap(),
            samples_per_pixel: 64,
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
    let out = render(&scene, &|_, _| {}).unwrap();
    let img = &out.radiance;
    let nb = img.bands();
    (0..img.pixels())
        .map(|p| (0..nb).map(|b| img.band(b)[p] as f64).sum::<f64>() / nb as f64)
        .collect()
}

/// Closed-form floor radiance `rho / pi * I(x, y) cos / d^2` for the light at (0, 0, H_M),
/// `i_of(x, y)` the intensity toward floor point (x, y), averaged over each pixel's footprint
/// (column i: x increasing; row j: y decreasing, row 0 at the top as the camera's `up` is +y).
fn expected(i_of: impl Fn(f64, f64) -> f64) -> Vec<f64> {
    let t = (FOV_DEG.to_radians() / 2.0).tan();
    let k = 8;
    let mut out = Vec::with_capacity(N_PX * N_PX);
    for j in 0..N_PX {
        for i in 0..N_PX {
            let mut s = 0.0;
            for b in 0..k {
                for a in 0..k {
                    let x = (2.0 * (i as f64 + (a as f64 + 0.5) / k as f64) / N_PX as f64 - 1.0)
                        * t
                        * H_M;
                    let y = (1.0 - 2.0 * (j as f64 + (b as f64 + 0.5) / k as f64) / N_PX as f64)
                        * t
                        * H_M;
                    let d2 = H_M * H_M + x * x + y * y;
                    s += RHO / PI * i_of(x, y) * (H_M / d2.sqrt()) / d2;
                }
            }
            out.push(s / (k * k) as f64);
        }
    }
    out
}

/// Largest per-pixel error relative to the brightest expected pixel; where the expected value
/// is zero the rendered one must be exactly zero.
fn worst_error(what: &str, got: &[f64], want: &[f64]) -> f64 {
    let peak = want.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.0);
    let mut worst = 0.0f64;
    for (p, (g, w)) in got.iter().zip(want).enumerate() {
        if *w == 0.0 {
            assert_eq!(*g, 0.0, "{what}: pixel {p} should be dark, got {g}");
        } else {
            worst = worst.max(((g - w) / w).abs());
        }
    }
    let lit = want.iter().filter(|w| **w > 0.0).count();
    eprintln!(
        "{what}: {lit} lit pixels of {}, worst rel. error {:.4} % (peak {peak:.4e})",
        want.len(),
        worst * 100.0
    );
    worst
}

/// A uniform image of value c gives exactly c times the `point` light with the same `I`
/// (pbrt-v4: `I(w) = scale I image(w)`), pixel by pixel; and both match the closed form.
#[test]
fn uniform_image_equals_point_light() {
    let dir = tempfile::tempdir().unwrap();
    let tr = format!("Translate 0 0 {H_M}");
    let point = parse_light(dir.path(), &tr, "point", FLAT_I).unwrap();
    let i_pt = intensity_w_sr_nm(&point);
    let reference = render_floor(point);
    let worst = worst_error(
        "point light vs closed form",
        &reference,
        &expected(|_, _| i_pt),
    );
    assert!(worst < 0.01);
    for c in [1.0f32, 2.5] {
        write_pfm(&dir.path().join("u.pfm"), 8, 8, |_, _| c);
        let gonio = parse_light(
            dir.path(),
            &tr,
            "goniometric",
            &format!("{FLAT_I} \"string filename\" \"u.pfm\""),
        )
        .unwrap();
        assert_eq!(
            intensity_w_sr_nm(&gonio),
            i_pt,
            "same I, same normalisation as point"
        );
        let got = render_floor(gonio);
        let worst = got
            .iter()
            .zip(&reference)
            .map(|(g, r)| (g / (c as f64 * r) - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!("uniform image {c}: worst pixel |L_gonio / ({c} L_point) - 1| = {worst:.3e}");
        assert!(worst < 1e-5);
    }
}

/// Image halves light the sides pbrt-v4's mapping predicts: top half (Z < 0) lights the whole
/// floor below; bottom half (Z > 0) leaves it dark (an image with its pole on z, without the
/// y-z swap, would light half of it either way); left half (X < 0) lights x < 0 only, with
/// E = c I cos / d^2 there.
#[test]
fn image_halves_light_the_predicted_side() {
    let dir = tempfile::tempdir().unwrap();
    let tr = format!("Translate 0 0 {H_M}");
    let n = 8;
    let gonio = |name: &str, f: &dyn Fn(usize, usize) -> f32| {
        write_pfm(&dir.path().join(name), n, n, f);
        parse_light(
            dir.path(),
            &tr,
            "goniometric",
            &format!("{FLAT_I} \"string filename\" \"{name}\""),
        )
        .unwrap()
    };
    let top = gonio("top.pfm", &|_, row| if row < n / 2 { 1.0 } else { 0.0 });
    let i0 = intensity_w_sr_nm(&top);
    let w = worst_error(
        "top image half -> floor below lit",
        &render_floor(top),
        &expected(|_, _| i0),
    );
    assert!(w < 0.01);

    let bottom = gonio("bottom.pfm", &|_, row| if row >= n / 2 { 1.0 } else { 0.0 });
    let got = render_floor(bottom);
    assert!(
        got.iter().all(|v| *v == 0.0),
        "bottom image half must leave the floor below dark"
    );

    let c = 3.0;
    let left = gonio("left.pfm", &|col, _| if col < n / 2 { c } else { 0.0 });
    let want = expected(|x, _| if x < 0.0 { c as f64 * i0 } else { 0.0 });
    let w = worst_error("left image half -> x < 0 lit", &render_floor(left), &want);
    assert!(w < 0.01);
}

/// `Rotate` before the light turns its pattern: with `Rotate 90 0 0 1` the CTM's X axis is the
/// world's +y, so the left image half (X < 0) lights y < 0; with `Rotate 180 1 0 0` the CTM's Z
/// points up, so the top half (Z < 0) lights nothing below and the bottom half lights it all.
#[test]
fn rotation_turns_the_pattern() {
    let dir = tempfile::tempdir().unwrap();
    let n = 8;
    write_pfm(&dir.path().join("left.pfm"), n, n, |col, _| {
        if col < n / 2 {
            1.0
        } else {
            0.0
        }
    });
    write_pfm(&dir.path().join("top.pfm"), n, n, |_, row| {
        if row < n / 2 {
            1.0
        } else {
            0.0
        }
    });
    write_pfm(&dir.path().join("bottom.pfm"), n, n, |_, row| {
        if row >= n / 2 {
            1.0
        } else {
            0.0
        }
    });
    let light = |rot: &str, file: &str| {
        parse_light(
            dir.path(),
            &format!("Translate 0 0 {H_M}\n{rot}"),
            "goniometric",
            &format!("{FLAT_I} \"string filename\" \"{file}\""),
        )
        .unwrap()
    };
    let l = light("Rotate 90 0 0 1", "left.pfm");
    let i0 = intensity_w_sr_nm(&l);
    let w = worst_error(
        "Rotate 90 z, left half -> y < 0 lit",
        &render_floor(l),
        &expected(|_, y| if y < 0.0 { i0 } else { 0.0 }),
    );
    assert!(w < 0.01);
    let got = render_floor(light("Rotate 180 1 0 0", "top.pfm"));
    assert!(
        got.iter().all(|v| *v == 0.0),
        "Rotate 180 x: the top half now faces up"
    );
    let w = worst_error(
        "Rotate 180 x, bottom half -> floor lit",
        &render_floor(light("Rotate 180 1 0 0", "bottom.pfm")),
        &expected(|_, _| i0),
    );
    assert!(w < 0.01);
}

/// `power` (pbrt-v4 `GoniometricLight::Create`: `scale *= Phi / (4 pi mean(image))`): a
/// uniform image of any value c gives luminous intensity `Phi / (4 pi)` (checked with an
/// independent 1 nm CIE luminance integral); an image bright (value 2) in one half and black in
/// the other emits twice the intensity of a `point` light of the same power into that half and
/// none into the other, so both emit the same flux Phi.
#[test]
fn power_normalisation() {
    let dir = tempfile::tempdir().unwrap();
    let power_lm = 500.0;
    let grid_1nm = WavelengthGrid::new(360.0, 830.0, 1.0).unwrap();
    for c in [0.3f32, 7.0] {
        write_pfm(&dir.path().join("u.pfm"), 4, 4, |_, _| c);
        let l = parse_light(
            dir.path(),
            "",
            "goniometric",
            &format!("\"string filename\" \"u.pfm\" \"float power\" {power_lm}"),
        )
        .unwrap();
        let Light::Goniometric(g) = &l else {
            panic!("not goniometric")
        };
        let iv_cd = c as f64
            * camsim_core::colorimetry::luminance_cd_m2(&g.intensity.sample(&grid_1nm), &grid_1nm);
        let want = power_lm / (4.0 * PI);
        let err = iv_cd / want - 1.0;
        eprintln!("uniform image {c}, power {power_lm} lm: I_v = {iv_cd:.6} cd, want {want:.6} cd ({:+.4} %)", err * 100.0);
        assert!(err.abs() < 1e-3);
    }
    let tr = format!("Translate 0 0 {H_M}");
    let n = 8;
    write_pfm(&dir.path().join("left.pfm"), n, n, |col, _| {
        if col < n / 2 {
            2.0
        } else {
            0.0
        }
    });
    let pw = format!("{FLAT_I} \"float power\" {power_lm}");
    let point = parse_light(dir.path(), &tr, "point", &pw).unwrap();
    let gonio = parse_light(
        dir.path(),
        &tr,
        "goniometric",
        &format!("{pw} \"string filename\" \"left.pfm\""),
    )
    .unwrap();
    let (i_pt, i_g) = (intensity_w_sr_nm(&point), intensity_w_sr_nm(&gonio));
    eprintln!(
        "half image of 2 with power: I per unit image {i_g:.6e} vs point I {i_pt:.6e} W/(sr nm)"
    );
    assert!(
        (i_g / i_pt - 1.0).abs() < 1e-12,
        "mean image value 1: same scale as the point light"
    );
    let reference = render_floor(point);
    let got = render_floor(gonio);
    let want: Vec<f64> = expected(|x, _| if x < 0.0 { 1.0 } else { 0.0 })
        .iter()
        .zip(&reference)
        .map(|(m, r)| if *m > 0.0 { 2.0 * r } else { 0.0 })
        .collect();
    let w = worst_error("half image with power vs 2 x point with power", &got, &want);
    assert!(w < 1e-5);
}

/// Bad input is a typed error naming the scene file and line (the `LightSource` is on line 4): a missing image, a non-square
/// image, no `filename`, negative texels, `power` with a black image.
#[test]
fn bad_input_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    write_pfm(&dir.path().join("wide.pfm"), 4, 2, |_, _| 1.0);
    write_pfm(&dir.path().join("neg.pfm"), 2, 2, |c, _| {
        if c == 0 {
            -1.0
        } else {
            1.0
        }
    });
    write_pfm(&dir.path().join("black.pfm"), 2, 2, |_, _| 0.0);
    let cases = [
        ("\"string filename\" \"missing.pfm\"", "missing.pfm"),
        ("\"string filename\" \"wide.pfm\"", "must be square"),
        ("\"float scale\" 2", "\"filename\""),
        ("\"string filename\" \"neg.pfm\"", "negative"),
        (
            "\"string filename\" \"black.pfm\" \"float power\" 10",
            "black",
        ),
    ];
    for (params, needle) in cases {
        let e = parse_light(dir.path(), "", "goniometric", params)
            .expect_err(params)
            .to_string();
        eprintln!("{params}: {e}");
        assert!(e.contains("scene.pbrt:4:"), "{e}");
        assert!(e.contains(needle), "{e}");
    }
}

// ---- pbrt-v4 `projection` light ----
//
// The light hangs at (0, 0, H_M) under `Rotate 180 1 0 0` (its +z points down); with pbrt-v4's
// `Scale(1, -1, 1)` the light-frame direction toward floor point (x, y) is (x, y, H_M), so the
// screen point is (x, y) / (H_M tan(fov / 2)); image column 0 is at x < 0, row 0 (top) at y < 0.
// With tan(fov / 2) = 1/2 and a 2:1 image the lit window is |x| <= H_M, |y| <= H_M / 2: the
// camera's full width and its middle 8 of 16 rows (edges on pixel boundaries).

/// `fov` with tan(fov / 2) = 1/2.
fn proj_fov_deg() -> f64 {
    2.0 * 0.5f64.atan().to_degrees()
}

/// Writes an RGB PFM (`PF`, rows bottom to top) with texel `f(column, row)`, row 0 at the top.
fn write_pfm_rgb(path: &Path, n: usize, m: usize, f: impl Fn(usize, usize) -> [f32; 3]) {
    let mut bytes = format!("PF\n{n} {m}\n-1.0\n").into_bytes();
    for row in (0..m).rev() {
        for col in 0..n {
            for v in f(col, row) {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

fn projection(dir: &Path, file: &str, extra: &str) -> Result<Light, camsim_pbrt::PbrtError> {
    let tr = format!("Translate 0 0 {H_M}\nRotate 180 1 0 0");
    parse_light(
        dir,
        &tr,
        "projection",
        &format!(
            "\"string filename\" \"{file}\" \"float fov\" {} {extra}",
            proj_fov_deg()
        ),
    )
}

/// A grey image of value c projects c times a `point` light with the colour space's illuminant
/// (an RGB grey uplifts to a flat spectrum, and both lights divide `scale` by the illuminant's
/// photometric value) inside the frustum, and nothing outside; one bright image quadrant (left
/// columns, top rows) lights only x < 0, y < 0 of the window; a coloured image equals a point
/// light with that `rgb I`.
#[test]
fn projection_window_and_image_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let point = parse_light(dir.path(), &format!("Translate 0 0 {H_M}"), "point", "").unwrap();
    let reference = render_floor(point);
    let inside = |x: f64, y: f64| x.abs() <= H_M && y.abs() <= H_M / 2.0;
    let lit_where = |f: &dyn Fn(f64, f64) -> bool| -> Vec<bool> {
        expected(|x, y| if f(x, y) { 1.0 } else { 0.0 })
            .iter()
            .map(|v| *v > 0.0)
            .collect()
    };
    for c in [1.0f32, 2.5] {
        write_pfm_rgb(&dir.path().join("grey.pfm"), 8, 4, |_, _| [c; 3]);
        let got = render_floor(projection(dir.path(), "grey.pfm", "").unwrap());
        let want: Vec<f64> = lit_where(&inside)
            .iter()
            .zip(&reference)
            .map(|(l, r)| if *l { c as f64 * r } else { 0.0 })
            .collect();
        let w = worst_error(
            &format!("projection, grey {c} image vs {c} x point light in the window"),
            &got,
            &want,
        );
        assert!(w < 1e-4);
    }
    write_pfm_rgb(&dir.path().join("quad.pfm"), 8, 4, |col, row| {
        if col < 4 && row < 2 {
            [1.0; 3]
        } else {
            [0.0; 3]
        }
    });
    let got = render_floor(projection(dir.path(), "quad.pfm", "").unwrap());
    let quad = |x: f64, y: f64| inside(x, y) && x < 0.0 && y < 0.0;
    let want: Vec<f64> = lit_where(&quad)
        .iter()
        .zip(&reference)
        .map(|(l, r)| if *l { *r } else { 0.0 })
        .collect();
    let w = worst_error(
        "projection, top-left image quadrant -> x < 0, y < 0",
        &got,
        &want,
    );
    assert!(w < 1e-4);
    // A coloured texel is uplifted as pbrt-v4's RGBIlluminantSpectrum, as a point light's `rgb I`
    // (the reader tabulates that spectrum; the renderer uplifts texels per wavelength).
    let rgb = [0.8f32, 0.3, 0.1];
    let point_rgb = parse_light(
        dir.path(),
        &format!("Translate 0 0 {H_M}"),
        "point",
        &format!("\"rgb I\" [{} {} {}]", rgb[0], rgb[1], rgb[2]),
    )
    .unwrap();
    let reference = render_floor(point_rgb);
    write_pfm_rgb(&dir.path().join("rgb.pfm"), 8, 4, |_, _| rgb);
    let got = render_floor(projection(dir.path(), "rgb.pfm", "").unwrap());
    let want: Vec<f64> = lit_where(&inside)
        .iter()
        .zip(&reference)
        .map(|(l, r)| if *l { *r } else { 0.0 })
        .collect();
    let w = worst_error(
        "projection, rgb (0.8, 0.3, 0.1) image vs point light with the same rgb I",
        &got,
        &want,
    );
    assert!(w < 2e-3);
}

/// `power` Phi: a white image's luminous intensity I_v times the frustum's solid angle
/// `4 asin(a b / sqrt((1 + a^2)(1 + b^2)))` (rectangular pyramid of half-tangents a, b) is Phi;
/// pbrt-v4 normalises with the midpoint rule over the texel centres, so a 64 x 32 image is
/// within the rule's error of the exact solid angle.
#[test]
fn projection_power_normalisation() {
    let dir = tempfile::tempdir().unwrap();
    write_pfm_rgb(&dir.path().join("white.pfm"), 64, 32, |_, _| [1.0; 3]);
    let power_lm = 800.0;
    let l = projection(
        dir.path(),
        "white.pfm",
        &format!("\"float power\" {power_lm}"),
    )
    .unwrap();
    let Light::Projection(p) = &l else {
        panic!("not a projection light")
    };
    let grid_1nm = WavelengthGrid::new(360.0, 830.0, 1.0).unwrap();
    // White RGB (1, 1, 1) is the illuminant itself (2m S = 1 for rgb / 2m = 1/2).
    let iv_cd =
        camsim_core::colorimetry::luminance_cd_m2(&p.illuminant.sample(&grid_1nm), &grid_1nm);
    let (a, b) = (1.0f64, 0.5f64);
    let omega_sr = 4.0 * (a * b / ((1.0 + a * a) * (1.0 + b * b)).sqrt()).asin();
    let err = iv_cd * omega_sr / power_lm - 1.0;
    eprintln!(
        "projection power {power_lm} lm: I_v = {iv_cd:.4} cd, Omega = {omega_sr:.6} sr, flux {:.4} lm ({:+.4} %)",
        iv_cd * omega_sr,
        err * 100.0
    );
    assert!(err.abs() < 1e-3);
}

#[test]
fn projection_bad_input_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    write_pfm_rgb(&dir.path().join("w.pfm"), 2, 2, |_, _| [1.0; 3]);
    let cases = [
        ("\"string filename\" \"missing.pfm\"", "missing.pfm"),
        ("\"float scale\" 2", "\"filename\""),
        ("\"string filename\" \"w.pfm\" \"float fov\" 180", "fov"),
    ];
    for (params, needle) in cases {
        let e = parse_light(dir.path(), "", "projection", params)
            .expect_err(params)
            .to_string();
        eprintln!("{params}: {e}");
        assert!(e.contains("scene.pbrt:4:") && e.contains(needle), "{e}");
    }
}

/// An arbitrary image under an arbitrary rotation, pixel by pixel: the expected intensity at each
/// of a pixel's 8 x 8 sub-samples is the texel of `EqualAreaSphereToSquare` (camsim-scene3d's
/// mapping, checked against pbrt-v4 there) of the light-frame direction, found here through the
/// inverse rotation and pbrt-v4's y-z swap. Pixels whose sub-samples all see one texel are
/// compared (texel edges crossing a pixel make its average depend on the sub-sample pattern),
/// with the footprint's edges checked on a 17 x 17 grid.
#[test]
fn arbitrary_image_under_rotation_matches_the_mapping() {
    let dir = tempfile::tempdir().unwrap();
    let n = 8;
    let value = |col: usize, row: usize| ((col * 7 + row * 3) % 5 + 1) as f32;
    write_pfm(&dir.path().join("pattern.pfm"), n, n, value);
    let (angle_deg, axis) = (30.0, [1.0, 1.0, 0.0]);
    let l = parse_light(
        dir.path(),
        &format!(
            "Translate 0 0 {H_M}\nRotate {angle_deg} {} {} {}",
            axis[0], axis[1], axis[2]
        ),
        "goniometric",
        &format!("{FLAT_I} \"string filename\" \"pattern.pfm\""),
    )
    .unwrap();
    let i0 = intensity_w_sr_nm(&l);
    let got = render_floor(l);
    let world_to_ctm = Transform::rotate(-angle_deg, axis);
    let texel_of = |x: f64, y: f64| {
        let c = world_to_ctm.apply_vector([x, y, -H_M]);
        // pbrt-v4 swapYZ: light frame (x, y, z) = CTM (X, Z, Y).
        let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let (u, v) = camsim_scene3d::envmap::equal_area_sphere_to_square([
            c[0] / len,
            c[2] / len,
            c[1] / len,
        ]);
        (
            ((u * n as f64) as usize).min(n - 1),
            ((v * n as f64) as usize).min(n - 1),
        )
    };
    let t = (FOV_DEG.to_radians() / 2.0).tan();
    let k = 8;
    let (mut compared, mut worst) = (0, 0.0f64);
    let mut seen = std::collections::BTreeSet::new();
    for j in 0..N_PX {
        for i in 0..N_PX {
            let mut texels = std::collections::BTreeSet::new();
            let mut s = 0.0;
            for b in 0..k {
                for a in 0..k {
                    let x = (2.0 * (i as f64 + (a as f64 + 0.5) / k as f64) / N_PX as f64 - 1.0)
                        * t
                        * H_M;
                    let y = (1.0 - 2.0 * (j as f64 + (b as f64 + 0.5) / k as f64) / N_PX as f64)
                        * t
                        * H_M;
                    let tx = texel_of(x, y);
                    texels.insert(tx);
                    let d2 = H_M * H_M + x * x + y * y;
                    s += RHO / PI * i0 * value(tx.0, tx.1) as f64 * (H_M / d2.sqrt()) / d2;
                }
            }
            // The footprint's edges too (a texel edge can clip a pixel between sub-samples).
            for b in 0..=16 {
                for a in 0..=16 {
                    let x = (2.0 * (i as f64 + a as f64 / 16.0) / N_PX as f64 - 1.0) * t * H_M;
                    let y = (1.0 - 2.0 * (j as f64 + b as f64 / 16.0) / N_PX as f64) * t * H_M;
                    texels.insert(texel_of(x, y));
                }
            }
            if texels.len() == 1 {
                let want = s / (k * k) as f64;
                let g = got[j * N_PX + i];
                worst = worst.max((g / want - 1.0).abs());
                compared += 1;
                seen.extend(texels);
            }
        }
    }
    eprintln!(
        "rotated pattern: {compared} pixels inside one texel ({} texels), worst rel. error {:.4} %",
        seen.len(),
        worst * 100.0
    );
    assert!(
        compared >= 40 && seen.len() >= 3,
        "{compared} pixels, {} texels",
        seen.len()
    );
    assert!(worst < 0.01);
}
