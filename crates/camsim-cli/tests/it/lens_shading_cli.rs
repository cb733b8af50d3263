//! Lens-shading correction through the binary (issue 42 item 6): the lab's workflow, a flat field
//! fitted by `camsim fit-shading` and another capture corrected by `camsim isp --lens-shading`.
//! The flat fields are synthetic Bayer frames of a known shading, relative illumination
//! 1 - A (x^2 + y^2) / 2 (A = 0.35: 0.65 at the frame's corners, 0.84 in the blocks measured),
//! with Gaussian noise of the shot-noise size: corrected, the corner blocks come back to the
//! centre's level within noise and the fit's accuracy; uncorrected they stay at the closed form.

use std::path::Path;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_camsim");
const ROWS: usize = 96;
const COLS: usize = 128;
const FALLOFF: f64 = 0.35;
const CENTRE_DN: f64 = 2000.0;
const BLACK_DN: f64 = 64.0;

fn camsim(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn relative_illumination(r: usize, c: usize) -> f64 {
    let x = (c as f64 + 0.5) / COLS as f64 * 2.0 - 1.0;
    let y = (r as f64 + 0.5) / ROWS as f64 * 2.0 - 1.0;
    1.0 - FALLOFF * (x * x + y * y) / 2.0
}

/// A flat Bayer field of the shading with Gaussian noise of variance 0.5 x signal (DN), drawn
/// from a fixed seed (xorshift64* and Box-Muller: the test's own generator).
fn write_flat(path: &Path, seed: u64) {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        ((state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut raw =
        camsim::core::RawImage::new(ROWS, COLS, camsim::core::CfaPattern::Rggb, 12).unwrap();
    raw.black_level_dn = BLACK_DN;
    raw.white_level_dn = 4095.0;
    for r in 0..ROWS {
        for c in 0..COLS {
            let s = CENTRE_DN * relative_illumination(r, c);
            let g = (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos();
            raw.dn[r * COLS + c] = (BLACK_DN + s + (0.5 * s).sqrt() * g).round() as u16;
        }
    }
    let meta = camsim::io::dng::DngMetadata::default();
    camsim::io::dng::write_dng(path, &raw, &meta).unwrap();
}

/// Mean linear value (sRGB decoded, IEC 61966-2-1) of each channel of a preview in a block of
/// `size` pixels centred on (row, col), with its standard error (over size^2 / 4 pixels: the
/// demosaic correlates neighbours).
fn block(png: &Path, row: usize, col: usize, size: usize) -> [(f64, f64); 3] {
    let (rows, cols, rgb) = camsim::io::raster::read_png8_rgb(png).unwrap();
    assert_eq!((rows, cols), (ROWS, COLS));
    let decode = |v: u8| {
        let v = v as f64 / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    std::array::from_fn(|ch| {
        let vals: Vec<f64> = (row - size / 2..row + size / 2)
            .flat_map(|r| (col - size / 2..col + size / 2).map(move |c| (r, c)))
            .map(|(r, c)| decode(rgb[(r * cols + c) * 3 + ch]))
            .collect();
        let n = vals.len() as f64;
        let mean = vals.iter().sum::<f64>() / n;
        let var = vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (var / (n / 4.0)).sqrt())
    })
}

#[test]
fn fitted_shading_corrects_another_flat_field_back_to_flat() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    write_flat(&d("flat-a.dng"), 1);
    write_flat(&d("flat-b.dng"), 2);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let o = camsim(&[
        "fit-shading",
        &s(&d("flat-a.dng")),
        "--out",
        &s(&d("shading.toml")),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for (name, corrected) in [("plain.png", false), ("corrected.png", true)] {
        let mut args = vec![
            "isp".to_string(),
            "--in".into(),
            s(&d("flat-b.dng")),
            "--sensor".into(),
            "pixel4a".into(),
            // The synthetic field has equal DN in every channel: gray world renders it grey
            // (no channel clipped).
            "--white-balance".into(),
            "gray-world".into(),
            "--quiet".into(),
            "--out".into(),
            s(&d(name)),
        ];
        if corrected {
            args.extend(["--lens-shading".into(), s(&d("shading.toml"))]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = camsim(&args);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    // 16 x 16 blocks at the centre and 10 px in from each corner.
    let size = 16;
    let corners = [
        (10 + size / 2, 10 + size / 2),
        (10 + size / 2, COLS - 10 - size / 2),
        (ROWS - 10 - size / 2, 10 + size / 2),
        (ROWS - 10 - size / 2, COLS - 10 - size / 2),
    ];
    for (name, corrected) in [("plain.png", false), ("corrected.png", true)] {
        let centre = block(&d(name), ROWS / 2, COLS / 2, size);
        for &(r, c) in &corners {
            let at = block(&d(name), r, c, size);
            // The closed form: the block's mean relative illumination over the centre's.
            let ri = |r0: usize, c0: usize| {
                let mut sum = 0.0;
                for rr in r0 - size / 2..r0 + size / 2 {
                    for cc in c0 - size / 2..c0 + size / 2 {
                        sum += relative_illumination(rr, cc);
                    }
                }
                sum
            };
            let want = if corrected {
                1.0
            } else {
                ri(r, c) / ri(ROWS / 2, COLS / 2)
            };
            for ch in 0..3 {
                let ratio = at[ch].0 / centre[ch].0;
                let se = ratio
                    * ((at[ch].1 / at[ch].0).powi(2) + (centre[ch].1 / centre[ch].0).powi(2))
                        .sqrt();
                eprintln!(
                    "{name} block ({r}, {c}) channel {ch}: corner / centre {ratio:.4}, closed form {want:.4} (SE {se:.4})"
                );
                // 4 standard errors + 1 % (an order-4 fit of a noisy flat field).
                assert!(
                    (ratio - want).abs() < 4.0 * se + 0.01,
                    "{name} block ({r}, {c}) channel {ch}: corner / centre {ratio:.4}, closed form {want:.4} (SE {se:.4})"
                );
            }
        }
    }

    // A shading file that is not one: exit 2 naming it, no output.
    std::fs::write(d("broken.toml"), "order = 2\nred = [1.0]\n").unwrap();
    let o = camsim(&[
        "isp",
        "--in",
        &s(&d("flat-b.dng")),
        "--lens-shading",
        &s(&d("broken.toml")),
        "--out",
        &s(&d("never.png")),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("broken.toml"), "{e}");
    assert!(!d("never.png").exists());
}
