//! The preview colour pipeline against independent references: exact recovery for a sensor that
//! meets the Luther condition, Lindbloom's published Bradford matrix, the sRGB encoding of the
//! patches' XYZ, and a neutral white.

use camsim_core::colorimetry::{srgb_encode_u8, XYZ_TO_LINEAR_SRGB};
use camsim_core::{tables, Spectrum, WavelengthGrid};
use camsim_isp::*;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

/// A photon-counting sensor meeting the Luther condition: QE_c = sum_k A_ck cmf_k(l) * 550 / l.
fn luther_qe(g: &WavelengthGrid) -> [Vec<f64>; 3] {
    let a = [[1.0, 0.1, 0.0], [0.3, 0.8, 0.05], [0.0, 0.02, 0.9]];
    let cmf = tables::cie1931_xyz_cmfs();
    let ch = |c: usize| -> Vec<f64> {
        (0..g.len())
            .map(|b| {
                let w = g.wavelength_nm(b);
                (0..3).map(|k| a[c][k] * cmf[k].eval(w)).sum::<f64>() * 550.0 / w
            })
            .collect()
    };
    [ch(0), ch(1), ch(2)]
}

/// The IMX363 channel QE (colour filter x IR-cut filter) from the published table.
fn imx363_qe(g: &WavelengthGrid) -> [Vec<f64>; 3] {
    let text = std::fs::read_to_string(format!("{DATA}/imx363_qe.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength"))
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect();
    let ch = |c: usize| {
        let s = Spectrum::from_pairs(
            &rows
                .iter()
                .map(|r| (r[0], r[1 + c] * r[4]))
                .collect::<Vec<_>>(),
        );
        s.sample(g)
    };
    [ch(0), ch(1), ch(2)]
}

/// Patch XYZ under an illuminant (white Y = 1), summed straight from the tables.
fn patch_xyz(g: &WavelengthGrid, illum: &Spectrum) -> (Vec<[f64; 3]>, [f64; 3]) {
    let cmf = tables::cie1931_xyz_cmfs();
    let integrate = |refl: &dyn Fn(f64) -> f64| -> [f64; 3] {
        let mut t = [0.0; 3];
        for b in 0..g.len() {
            let w = g.wavelength_nm(b);
            for k in 0..3 {
                t[k] += cmf[k].eval(w) * illum.eval(w) * refl(w);
            }
        }
        t
    };
    let white = integrate(&|_| 1.0);
    let norm = |t: [f64; 3]| [t[0] / white[1], t[1] / white[1], t[2] / white[1]];
    let patches = tables::macbeth_reflectances()
        .iter()
        .map(|r| norm(integrate(&|w| r.eval(w))))
        .collect();
    (patches, norm(white))
}

fn apply(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn camera(qe: &[Vec<f64>; 3], g: &WavelengthGrid, illum: &Spectrum, refl: &Spectrum) -> [f64; 3] {
    // Photon counts: sum QE * E * rho * lambda (independent loop, same definition as the docs).
    [0, 1, 2].map(|c| {
        (0..g.len())
            .map(|b| {
                let w = g.wavelength_nm(b);
                qe[c][b] * illum.eval(w) * refl.eval(w) * w
            })
            .sum::<f64>()
    })
}

#[test]
fn luther_sensor_fit_is_exact() {
    let g = WavelengthGrid::default();
    let qe = luther_qe(&g);
    for name in ["D65", "A", "F11"] {
        let illum = tables::illuminant(name).unwrap();
        let p = ColorPipeline::fit(&qe, &g, &illum).unwrap();
        let (xyz, white) = patch_xyz(&g, &illum);
        let flat = Spectrum::constant(&g, 1.0);
        let cw = camera(&qe, &g, &illum, &flat);
        let cmax = cw.iter().cloned().fold(0.0, f64::max);
        let m = p.camera_to_xyz();
        for (i, r) in tables::macbeth_reflectances().iter().enumerate() {
            let c = camera(&qe, &g, &illum, r).map(|v| v / cmax);
            let got = apply(&m, c);
            let err = ((got[0] - xyz[i][0]).powi(2)
                + (got[1] - xyz[i][1]).powi(2)
                + (got[2] - xyz[i][2]).powi(2))
            .sqrt();
            let size = (xyz[i][0].powi(2) + xyz[i][1].powi(2) + xyz[i][2].powi(2)).sqrt();
            assert!(
                err / size < 1e-6,
                "{name} patch {}: {got:?} vs {:?}",
                i + 1,
                xyz[i]
            );
        }
        assert!(p.fit_rms_xyz() < 1e-7);
        // DNG quantities: XYZ of the white -> camera neutral, largest 1; inverse matrices.
        let neutral = apply(&p.xyz_to_camera(), white);
        let asn = p.as_shot_neutral();
        for c in 0..3 {
            assert!((neutral[c] - asn[c]).abs() < 1e-9 && (asn[c] - cw[c] / cmax).abs() < 1e-9);
        }
        assert_eq!(asn.iter().cloned().fold(0.0, f64::max), 1.0);
    }
}

#[test]
fn bradford_matches_lindbloom() {
    // B. Lindbloom, "Chromatic Adaptation": Bradford D65 -> D50 with his white points
    // D65 = (0.95047, 1, 1.08883), D50 = (0.96422, 1, 0.82521).
    let want = [
        [1.0478112, 0.0228866, -0.0501270],
        [0.0295424, 0.9904844, -0.0170491],
        [-0.0092345, 0.0150436, 0.7521316],
    ];
    let got = bradford_adaptation([0.95047, 1.0, 1.08883], [0.96422, 1.0, 0.82521]);
    for r in 0..3 {
        for c in 0..3 {
            assert!(
                (got[r][c] - want[r][c]).abs() < 1e-6,
                "[{r}][{c}] {} vs {}",
                got[r][c],
                want[r][c]
            );
        }
    }
}

/// An image of the 24 patches (4 x 4 pixels each, chart order) in camera values.
fn chart_image(qe: &[Vec<f64>; 3], g: &WavelengthGrid, illum: &Spectrum, gain: f64) -> RgbImage {
    let mut img = RgbImage::zeros(16, 24);
    for (i, r) in tables::macbeth_reflectances().iter().enumerate() {
        let c = camera(qe, g, illum, r);
        for y in 0..4 {
            for x in 0..4 {
                let p = ((i / 6) * 4 + y) * 24 + (i % 6) * 4 + x;
                img.r[p] = (c[0] * gain) as f32;
                img.g[p] = (c[1] * gain) as f32;
                img.b[p] = (c[2] * gain) as f32;
            }
        }
    }
    img
}

#[test]
fn luther_sensor_under_d65_renders_the_patches_srgb() {
    // Independent reference: sRGB (IEC 61966-2-1) of the patches' XYZ. Under D65 the Bradford step
    // only moves the tabulated D65 white to the rounded sRGB white (x 0.3127, y 0.3290): < 1 DN.
    let g = WavelengthGrid::default();
    let qe = luther_qe(&g);
    let illum = tables::illuminant("D65").unwrap();
    let p = ColorPipeline::fit(&qe, &g, &illum).unwrap();
    let flat = Spectrum::constant(&g, 1.0);
    let cmax = camera(&qe, &g, &illum, &flat)
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    // Camera values in DN-like units (a perfect white's largest channel at 4000), and the exposure
    // scale that takes them back to the normalised camera space.
    let gain = 4000.0 / cmax;
    let img = chart_image(&qe, &g, &illum, gain);
    let srgb = p.render_srgb8(&img, Some(1.0 / 4000.0));
    let (xyz, _) = patch_xyz(&g, &illum);
    let mut max_diff = 0i32;
    for i in 0..24 {
        let lin = apply(&XYZ_TO_LINEAR_SRGB, xyz[i]);
        let px = ((i / 6) * 4 + 1) * 24 + (i % 6) * 4 + 2;
        for c in 0..3 {
            let want = srgb_encode_u8(lin[c]) as i32;
            let got = srgb[px * 3 + c] as i32;
            if (want - got).abs() > 1 {
                eprintln!("patch {} c {c}: want {want} got {got}", i + 1);
            }
            max_diff = max_diff.max((want - got).abs());
        }
    }
    assert!(max_diff <= 1, "largest difference {max_diff} DN");
}

#[test]
fn white_renders_neutral_under_d65_and_a() {
    // A spectrally flat 90 % reflector must render R = G = B (within 1 DN) after white balance and
    // adaptation, for a Luther sensor and for the real IMX363. The ColorChecker's white patch is
    // not quite flat (Ohta 1997); its own colour is 1-2 DN off neutral in sRGB (BabelColor's
    // published sRGB for patch 19 is 243, 243, 242), so it is held to 2 DN.
    let g = WavelengthGrid::default();
    for (sensor, qe) in [("luther", luther_qe(&g)), ("imx363", imx363_qe(&g))] {
        for name in ["D65", "A"] {
            let illum = tables::illuminant(name).unwrap();
            let p = ColorPipeline::fit(&qe, &g, &illum).unwrap();
            let img = chart_image(&qe, &g, &illum, 1e-3);
            let k = p.auto_exposure_scale(&img);
            let srgb = p.render_srgb8(&img, Some(k));
            assert_eq!(srgb, p.render_srgb8(&img, None));
            let px = (3 * 4 + 1) * 24 + 1; // inside patch 19 (white), bottom left
            let rgb = [srgb[px * 3], srgb[px * 3 + 1], srgb[px * 3 + 2]];
            let spread =
                |v: [u8; 3]| *v.iter().max().unwrap() as i32 - *v.iter().min().unwrap() as i32;
            assert!(
                spread(rgb) <= 2,
                "{sensor} under {name}: white patch renders {rgb:?}"
            );
            // Auto exposure: the white is the brightest patch, so it sits near Y = 0.9 (sRGB ~ 243).
            assert!(
                (238..=248).contains(&rgb[1]),
                "{sensor} under {name}: {rgb:?}"
            );
            // The flat reflector at the same exposure.
            let c =
                camera(&qe, &g, &illum, &Spectrum::constant(&g, 0.9)).map(|v| (v * 1e-3) as f32);
            let one = RgbImage {
                rows: 1,
                cols: 1,
                r: vec![c[0]],
                g: vec![c[1]],
                b: vec![c[2]],
            };
            let flat = p.render_srgb8(&one, Some(k));
            let flat = [flat[0], flat[1], flat[2]];
            println!("{sensor} under {name}: ColorChecker white {rgb:?}, flat 90 % {flat:?}");
            assert!(
                spread(flat) <= 1,
                "{sensor} under {name}: flat 90 % renders {flat:?}"
            );
            // Perfect white -> exactly neutral through the whole chain (to the 4-digit sRGB matrix).
            let white = apply(&p.camera_to_srgb(), p.as_shot_neutral());
            assert!(
                (white[0] - white[1]).abs() < 1e-3 && (white[2] - white[1]).abs() < 1e-3,
                "{white:?}"
            );
        }
    }
}

/// CIE 1976 L*a*b* (CIE 015:2018 eq. 8.1-8.3) relative to `white`.
fn lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let f = |t: f64| {
        if t > (6.0f64 / 29.0).powi(3) {
            t.cbrt()
        } else {
            t / (3.0 * (6.0f64 / 29.0).powi(2)) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (
        f(xyz[0] / white[0]),
        f(xyz[1] / white[1]),
        f(xyz[2] / white[2]),
    );
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

#[test]
fn imx363_fit_error_is_that_of_a_good_3x3_colour_correction() {
    // The IMX363 does not meet the Luther condition, so the 3x3 fit leaves a residual. A good
    // consumer sensor with a 3x3 matrix reaches a mean CIELAB Delta E*ab of a few units on the
    // ColorChecker; we require < 5 mean and < 15 worst (and print the figures).
    let g = WavelengthGrid::default();
    let qe = imx363_qe(&g);
    for name in ["D65", "A"] {
        let illum = tables::illuminant(name).unwrap();
        let p = ColorPipeline::fit(&qe, &g, &illum).unwrap();
        let (xyz, white) = patch_xyz(&g, &illum);
        let cmax = camera(&qe, &g, &illum, &Spectrum::constant(&g, 1.0))
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        let mut des = vec![];
        for (i, r) in tables::macbeth_reflectances().iter().enumerate() {
            let got = apply(
                &p.camera_to_xyz(),
                camera(&qe, &g, &illum, r).map(|v| v / cmax),
            );
            let (a, b) = (lab(got, white), lab(xyz[i], white));
            des.push(
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt(),
            );
        }
        let mean = des.iter().sum::<f64>() / 24.0;
        let max = des.iter().cloned().fold(0.0, f64::max);
        println!(
            "IMX363 under {name}: mean Delta E*ab {mean:.2}, max {max:.2}, rms XYZ {:.4}",
            p.fit_rms_xyz()
        );
        assert!(mean < 5.0 && max < 15.0, "{name}: mean {mean}, max {max}");
    }
}

#[test]
fn fit_rejects_bad_input() {
    let g = WavelengthGrid::default();
    let d65 = tables::illuminant("D65").unwrap();
    let short = [vec![1.0; 30], vec![1.0; 31], vec![1.0; 31]];
    assert!(ColorPipeline::fit(&short, &g, &d65)
        .unwrap_err()
        .to_string()
        .contains("30"));
    let blind = [vec![0.0; 31], vec![1.0; 31], vec![1.0; 31]];
    assert!(ColorPipeline::fit(&blind, &g, &d65).is_err());
    // Three identical channels cannot separate colours.
    let grey = [vec![0.5; 31], vec![0.5; 31], vec![0.5; 31]];
    assert!(ColorPipeline::fit(&grey, &g, &d65).is_err());
}

/// A pixel saturated in every raw channel must render neutral (R = G = B), not in the false
/// colour that white-balance gains would give it, once highlight clipping knows the saturation
/// level; without it the same pixel is visibly coloured.
#[test]
fn saturated_highlights_render_neutral_with_clipping() {
    use camsim_core::{tables, WavelengthGrid};
    use camsim_isp::{ColorPipeline, RgbImage};
    let grid = WavelengthGrid::default();
    // A sensor with unequal channel sensitivities (so the white-balance gains differ).
    let qe: [Vec<f64>; 3] = [
        grid.wavelengths_nm()
            .iter()
            .map(|w| if *w > 580.0 { 0.5 } else { 0.02 })
            .collect(),
        grid.wavelengths_nm()
            .iter()
            .map(|w| {
                if (*w > 490.0) && (*w < 600.0) {
                    0.8
                } else {
                    0.05
                }
            })
            .collect(),
        grid.wavelengths_nm()
            .iter()
            .map(|w| if *w < 510.0 { 0.4 } else { 0.02 })
            .collect(),
    ];
    let cp = ColorPipeline::fit(&qe, &grid, &tables::illuminant("A").unwrap()).unwrap();
    let sat = 4000.0f32;
    let img = RgbImage {
        rows: 1,
        cols: 1,
        r: vec![sat],
        g: vec![sat],
        b: vec![sat],
    };
    let clipped = cp.render_srgb8_clipped(&img, Some(1.0 / sat as f64), Some(sat as f64), None);
    assert!(
        clipped[0] == clipped[1] && clipped[1] == clipped[2],
        "clipped highlight {clipped:?} is not neutral"
    );
    let raw = cp.render_srgb8(&img, Some(1.0 / sat as f64));
    assert!(
        raw[0] != raw[1] || raw[1] != raw[2],
        "test setup: without clipping the pixel should be coloured, got {raw:?}"
    );
}

/// Gaussian camera noise, sigma 1, from Box-Muller on a fixed xorshift sequence.
fn gaussian_noise(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    move || {
        let (u, v) = (uniform(), uniform());
        ((-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()) as f32
    }
}

/// A 200 x 200 image of `mean` camera values plus Gaussian noise of sigma 1 per channel.
fn noisy_field(mean: [f32; 3], seed: u64) -> RgbImage {
    let mut gauss = gaussian_noise(seed);
    let n = 200 * 200;
    let mut plane = |m: f32| (0..n).map(|_| m + gauss()).collect::<Vec<f32>>();
    RgbImage {
        rows: 200,
        cols: 200,
        r: plane(mean[0]),
        g: plane(mean[1]),
        b: plane(mean[2]),
    }
}

/// A noise floor of 1 camera unit in every channel, nothing clipped below.
const FLOOR_1: BlackModel = BlackModel {
    sigma: [1.0; 3],
    clip: None,
};

/// Mean of the decoded (linear) sRGB values of an interleaved 8-bit image.
fn mean_linear(px: &[u8]) -> [f64; 3] {
    use camsim_core::colorimetry::srgb_decode;
    let mut mean = [0.0f64; 3];
    for p in px.chunks_exact(3) {
        for c in 0..3 {
            mean[c] += srgb_decode(p[c] as f64 / 255.0);
        }
    }
    mean.map(|m| m / (px.len() / 3) as f64)
}

/// A black field with zero-mean noise (what a dark surround is after black subtraction) must
/// render grey on average, not tinted: the colour-correction matrix amplifies each output
/// channel's noise differently (blue most under a tungsten lamp), so clipping at 0 biases each
/// channel by its own noise and the surround comes out navy. With the noise floor known, chroma
/// coring makes the mean neutral within 5 % between channels; without it the ratio is 1.7 under
/// D65 and 3.4 under A. Checked on the IMX363 (the Pixel 4a's sensor) under D65 and A, with
/// Gaussian camera noise.
#[test]
fn zero_mean_noise_on_black_renders_neutral() {
    let g = WavelengthGrid::default();
    let qe = imx363_qe(&g);
    let img = noisy_field([0.0; 3], 0x9E37_79B9_7F4A_7C15);
    let ratio = |m: [f64; 3]| {
        m.iter().cloned().fold(0.0, f64::max) / m.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    for illum in ["D65", "A"] {
        let cp = ColorPipeline::fit(&qe, &g, &tables::illuminant(illum).unwrap()).unwrap();
        // Noise of 1 camera unit at 2 % of white: a dark surround at a typical preview exposure.
        let cored = mean_linear(&cp.render_srgb8_clipped(&img, Some(0.02), None, Some(&FLOOR_1)));
        let plain = mean_linear(&cp.render_srgb8(&img, Some(0.02)));
        println!(
            "{illum}: mean linear sRGB of the noise field {cored:?}, without coring {plain:?}"
        );
        assert!(cored.iter().all(|m| *m > 0.0), "{illum}: {cored:?}");
        assert!(
            ratio(cored) < 1.05,
            "{illum}: the noise field's mean {cored:?} is tinted (max/min {:.3})",
            ratio(cored)
        );
        // The test can see the tint: without the noise floor the same field is tinted.
        assert!(ratio(plain) > 1.5, "{illum}: {plain:?}");
    }
}

/// Coring must not grey out a real but dim colour: a uniform colour whose chroma is only about
/// 1 sigma of the noise per pixel (plain to the eye over many pixels) keeps most of its mean
/// chroma, because coring judges the window's mean chroma (7 sigma here), not each pixel's.
/// Coring each pixel on its own would keep about a third.
#[test]
fn coring_keeps_a_dim_colour() {
    let g = WavelengthGrid::default();
    let qe = imx363_qe(&g);
    let cp = ColorPipeline::fit(&qe, &g, &tables::illuminant("D65").unwrap()).unwrap();
    let w = SRGB_LUMINANCE_WEIGHTS;
    let m = cp.camera_to_srgb().map(|row| row.map(|v| v * 0.02));
    // A colour 1 sigma from grey in chroma: camera red raised above a grey of 6 units.
    let grey = 6.0f32;
    let colour = [grey + 1.5, grey, grey];
    let img = noisy_field(colour, 7);
    let chroma = |v: [f64; 3]| {
        let y = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
        [v[0] - y, v[2] - y]
    };
    let truth = chroma([0, 1, 2].map(|k| (0..3).map(|j| m[k][j] * colour[j] as f64).sum()));
    let cored = chroma(mean_linear(&cp.render_srgb8_clipped(
        &img,
        Some(0.02),
        None,
        Some(&FLOOR_1),
    )));
    let plain = chroma(mean_linear(&cp.render_srgb8(&img, Some(0.02))));
    let kept = (cored[0] * truth[0] + cored[1] * truth[1]) / (truth[0].powi(2) + truth[1].powi(2));
    let kept_plain =
        (plain[0] * truth[0] + plain[1] * truth[1]) / (truth[0].powi(2) + truth[1].powi(2));
    println!("chroma kept {kept:.3} (without coring {kept_plain:.3})");
    assert!(
        kept > 0.8 * kept_plain,
        "coring kept {kept:.3} of the chroma, plain {kept_plain:.3}"
    );
}

/// Coring's gain: 0 within 3 sigma of grey, 1 - 9 / d^2 beyond, d the Mahalanobis distance of
/// the window's mean chroma (covariance C / n), here with the identity matrix and sigma 0.01.
#[test]
fn chroma_coring_gain_is_the_garrote() {
    let w = SRGB_LUMINANCE_WEIGHTS;
    let id: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let sigma = 0.01;
    let k = ChromaCoring::new(&id, w, [sigma; 3]).unwrap();
    // Closed-form covariance of (R - Y, B - Y) for identity and equal sigma.
    let q = [[1.0 - w[0], -w[1], -w[2]], [-w[0], -w[1], 1.0 - w[2]]];
    let c = [0, 1]
        .map(|a| [0, 1].map(|b| sigma * sigma * (0..3).map(|j| q[a][j] * q[b][j]).sum::<f64>()));
    let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    for (u, n) in [
        ([0.02, 0.0], 1.0),
        ([0.05, -0.03], 1.0),
        ([0.02, 0.01], 49.0),
    ] {
        let s = u.map(|v| v * n);
        let d2 = (u[0] * (c[1][1] * u[0] - c[0][1] * u[1])
            + u[1] * (-c[1][0] * u[0] + c[0][0] * u[1]))
            / det
            * n;
        let want = if d2 > 9.0 { 1.0 - 9.0 / d2 } else { 0.0 };
        assert!(
            (k.gain(s, n) - want).abs() < 1e-12,
            "{u:?} {n}: {} vs {want}",
            k.gain(s, n)
        );
    }
    assert_eq!(k.gain([0.0, 0.0], 49.0), 0.0);
    assert!(ChromaCoring::new(&id, w, [0.0; 3]).is_none());
}

/// The censored-mean inversion against its closed form: a Gaussian of mean L clipped at L has
/// mean L + sigma / sqrt(2 pi), so that observed mean maps back to L; far above the clip the
/// mean is left alone; and a forward-then-inverse round trip is exact.
#[test]
fn censored_black_mean_inverts() {
    let sigma = 45.0;
    let a0 = sigma / (2.0 * std::f64::consts::PI).sqrt();
    assert!(uncensored_offset(a0, sigma).abs() < 1e-6 * sigma);
    assert_eq!(uncensored_offset(7.0 * sigma, sigma), 7.0 * sigma);
    // Forward by numerical integration of max(0, X), X ~ N(t, sigma^2), then back.
    for t in [-2.0 * sigma, -0.5 * sigma, 0.3 * sigma, 2.0 * sigma] {
        let steps = 20_000;
        let (lo, hi) = (t - 10.0 * sigma, t + 10.0 * sigma);
        let dx = (hi - lo) / steps as f64;
        let mean: f64 = (0..steps)
            .map(|i| {
                let x = lo + (i as f64 + 0.5) * dx;
                let pdf = (-0.5 * ((x - t) / sigma).powi(2)).exp()
                    / (sigma * (2.0 * std::f64::consts::PI).sqrt());
                x.max(0.0) * pdf * dx
            })
            .sum();
        let back = uncensored_offset(mean, sigma);
        assert!((back - t).abs() < 1e-4 * sigma, "t {t}: back {back}");
    }
}

/// A sensor without a black pedestal (the paper's Table 1) clips its read noise at 0 in the
/// ADC, so black in the raw is 0.399 sigma in every channel, which white balance turns blue.
/// A report preview averages 6 x 6 pixels, which leaves that bias and divides the noise by 6, so
/// coring alone keeps the tint (the window's mean chroma is then significant). Told the clip
/// level, the preview renders the field black and neutral (the censored-mean correction, then
/// coring).
#[test]
fn a_black_clipped_at_zero_renders_black() {
    let g = WavelengthGrid::default();
    let qe = imx363_qe(&g);
    let cp = ColorPipeline::fit(&qe, &g, &tables::illuminant("A").unwrap()).unwrap();
    // 1200 x 1200 raw values of sigma 1 clipped at 0, averaged over 6 x 6 blocks.
    let k = 6;
    let mut gauss = gaussian_noise(11);
    let mut img = noisy_field([0.0; 3], 1);
    for plane in [&mut img.r, &mut img.g, &mut img.b] {
        for v in plane.iter_mut() {
            *v = (0..k * k).map(|_| gauss().max(0.0)).sum::<f32>() / (k * k) as f32;
        }
    }
    let clipped = BlackModel {
        sigma: [1.0 / k as f64; 3],
        clip: Some(([0.0; 3], [1.0; 3])),
    };
    let unknown = BlackModel {
        sigma: [1.0 / k as f64; 3],
        clip: None,
    };
    let fixed = mean_linear(&cp.render_srgb8_clipped(&img, Some(0.02), None, Some(&clipped)));
    let biased = mean_linear(&cp.render_srgb8_clipped(&img, Some(0.02), None, Some(&unknown)));
    println!("clip known {fixed:?}, unknown {biased:?}");
    let ratio = |m: [f64; 3]| {
        m.iter().cloned().fold(0.0, f64::max) / m.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    assert!(ratio(fixed) < 1.1, "{fixed:?}");
    assert!(fixed.iter().all(|m| *m < 0.001), "not black: {fixed:?}");
    assert!(
        biased[2] > 1.5 * biased[0],
        "test set-up: the bias should be blue, {biased:?}"
    );
}
