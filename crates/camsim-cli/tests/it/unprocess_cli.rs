//! `camsim unprocess` (issue 42, the ISP "from denoise to JPEG and back"): an sRGB photo of two
//! flat fields becomes a raw whose per-channel means are the inverse of the ISP's colour chain in
//! closed form (IEC 61966-2-1 decoding, the inverse of the colour matrix that `camsim isp --json`
//! reports, white balance included, over the exposure scale), whose variance is the photon-transfer law of
//! the sensor's shot and read noise, and which `camsim isp --exposure-scale` renders back to the
//! photo's codes; the same seed gives the same bytes, and bad input exits 2 writing nothing.

use std::path::Path;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_camsim");
const ROWS: usize = 64;
const HALF: usize = 64;
/// The photo: left half a light grey (shot noise above read noise), right half a warm colour.
const LEFT: [u8; 3] = [230, 230, 230];
const RIGHT: [u8; 3] = [180, 90, 60];

fn camsim(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn write_photo(path: &Path) {
    let mut rgb = Vec::with_capacity(ROWS * 2 * HALF * 3);
    for _ in 0..ROWS {
        for c in 0..2 * HALF {
            rgb.extend_from_slice(if c < HALF { &LEFT } else { &RIGHT });
        }
    }
    camsim::io::raster::write_png8_rgb(path, ROWS, 2 * HALF, &rgb).unwrap();
}

/// The columns of half `h` away from the boundary and the frame edge (demosaic support).
fn half_cols(h: usize) -> std::ops::Range<usize> {
    h * HALF + 4..(h + 1) * HALF - 4
}

/// The exposure scale `camsim unprocess` reports on stderr.
fn reported_scale(stderr: &str) -> f64 {
    let tail = stderr
        .split("exposure scale ")
        .nth(1)
        .unwrap_or_else(|| panic!("no exposure scale in: {stderr}"));
    tail.split_whitespace().next().unwrap().parse().unwrap()
}

fn mat3(v: &serde_json::Value) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            *x = v[r][c].as_f64().unwrap();
        }
    }
    m
}

/// Solve m x = y (Cramer's rule).
fn solve3(m: &[[f64; 3]; 3], y: [f64; 3]) -> [f64; 3] {
    let det = |a: &[[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut a = *m;
        for r in 0..3 {
            a[r][k] = y[r];
        }
        *xk = det(&a) / d;
    }
    x
}

/// sRGB decoding, IEC 61966-2-1.
fn srgb_decode(code: u8) -> f64 {
    let v = code as f64 / 255.0;
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn unprocessed_photo_has_the_inverse_means_the_sensor_noise_and_renders_back() {
    let dir = tempfile::tempdir().unwrap();
    let photo = dir.path().join("photo.png");
    write_photo(&photo);
    let dng = dir.path().join("raw.dng");
    let (p, d) = (photo.to_str().unwrap(), dng.to_str().unwrap());
    let o = camsim(&[
        "unprocess",
        "--in",
        p,
        "--sensor",
        "pixel4a",
        "--seed",
        "7",
        "--out",
        d,
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let scale = reported_scale(&stderr);

    // The ISP's colour chain for this sensor and illuminant, as `camsim isp` reports it.
    let back = dir.path().join("back.png");
    let scale_arg = format!("{scale:e}");
    let o = camsim(&[
        "isp",
        "--in",
        d,
        "--sensor",
        "pixel4a",
        "--exposure-scale",
        &scale_arg,
        "--json",
        "--quiet",
        "--out",
        back.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = mat3(&report["camera_to_linear_srgb"]);
    let reported = report["exposure_scale"].as_f64().unwrap();
    assert!(
        (reported / scale - 1.0).abs() < 1e-5,
        "{reported} vs {scale}"
    );

    let (raw, _) = camsim::io::dng::read_dng(&dng).unwrap();
    assert_eq!((raw.rows, raw.cols), (ROWS, 2 * HALF));
    let sensor = camsim::pipeline::load_sensor("pixel4a").unwrap();
    let k = sensor.k_dn_per_e();
    let read_dn = sensor.predicted_noise_dn(0.0, 0.0).read;
    for (h, code) in [LEFT, RIGHT].iter().enumerate() {
        // Camera DN above black: linear sRGB = scale M DN (the forward render; with illuminant
        // white balance the gains are inside M, as the report says), so DN = M^-1 v / scale.
        let v = code.map(srgb_decode);
        let cam = solve3(&m, v);
        let mut stats = [(0.0f64, 0.0f64, 0usize); 3];
        for r in 2..ROWS - 2 {
            for c in half_cols(h) {
                let ch = raw.channel_at(r, c).index();
                let x = raw.dn[r * raw.cols + c] as f64 - raw.black_level_dn;
                let s = &mut stats[ch];
                s.0 += x;
                s.1 += x * x;
                s.2 += 1;
            }
        }
        for ch in 0..3 {
            let (sum, sum2, n) = stats[ch];
            let n_f = n as f64;
            let mean = sum / n_f;
            let var = (sum2 - sum * sum / n_f) / (n_f - 1.0);
            let want = cam[ch] / scale;
            assert!(
                want > 50.0,
                "half {h} channel {ch}: {want} DN is too dark a test"
            );
            // Mean: within 4 standard errors (+ 0.1 DN for the ADC's rounding).
            let se = (var / n_f).sqrt();
            assert!(
                (mean - want).abs() < 4.0 * se + 0.1,
                "half {h} channel {ch}: mean {mean:.2} DN, the inverse ISP gives {want:.2} (SE {se:.2})"
            );
            // Photon transfer: var = K mean + read^2 + 1/12 (rounding); a sample variance's
            // relative standard error is sqrt(2 / (n - 1)).
            let want_var = k * want + read_dn * read_dn + 1.0 / 12.0;
            let rel = (2.0 / (n_f - 1.0)).sqrt();
            eprintln!(
                "half {h} channel {ch}: mean {mean:.2} / {want:.2} DN (z {:.2}), variance {var:.2} / {want_var:.2} DN^2 (z {:.2})",
                (mean - want) / se,
                (var / want_var - 1.0) / rel
            );
            assert!(
                (var / want_var - 1.0).abs() < 4.0 * rel,
                "half {h} channel {ch}: variance {var:.2} DN^2, shot + read noise give {want_var:.2}"
            );
        }
    }

    // Back through the ISP at the same scale: the photo's colour, compared in linear sRGB (the
    // mean of the decoded codes; the encoded mean is biased low by the noise, as the sRGB curve
    // is concave), within 4 standard errors (of n / 4 independent pixels: the demosaic
    // correlates neighbours) + half a code's linear step.
    let (rows, cols, rgb) = camsim::io::raster::read_png8_rgb(&back).unwrap();
    assert_eq!((rows, cols), (ROWS, 2 * HALF));
    for (h, code) in [LEFT, RIGHT].iter().enumerate() {
        for ch in 0..3 {
            let (mut sum, mut sum2, mut n) = (0.0, 0.0, 0.0);
            for r in 4..ROWS - 4 {
                for c in half_cols(h) {
                    let v = srgb_decode(rgb[(r * cols + c) * 3 + ch]);
                    sum += v;
                    sum2 += v * v;
                    n += 1.0;
                }
            }
            let mean = sum / n;
            let se = ((sum2 / n - mean * mean).max(0.0) / (n / 4.0)).sqrt();
            let want = srgb_decode(code[ch]);
            let half_code = 0.5 * (srgb_decode(code[ch] + 1) - srgb_decode(code[ch] - 1)) / 2.0;
            eprintln!(
                "half {h} channel {ch}: back {mean:.5} / {want:.5} linear (z {:.2})",
                (mean - want) / se
            );
            assert!(
                (mean - want).abs() < 4.0 * se + half_code,
                "half {h} channel {ch}: rendered back {mean:.5} linear, the photo has {want:.5} (SE {se:.5})"
            );
        }
    }

    // The same seed gives the same bytes; another seed other noise.
    let again = dir.path().join("again.dng");
    let other = dir.path().join("other.dng");
    for (path, seed) in [(&again, "7"), (&other, "8")] {
        let o = camsim(&[
            "unprocess",
            "--in",
            p,
            "--sensor",
            "pixel4a",
            "--seed",
            seed,
            "--quiet",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0));
    }
    assert_eq!(std::fs::read(&dng).unwrap(), std::fs::read(&again).unwrap());
    let (raw2, _) = camsim::io::dng::read_dng(&other).unwrap();
    assert_ne!(raw.dn, raw2.dn);
}

#[test]
fn bad_input_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("raw.dng");
    let o_s = out.to_str().unwrap();
    let text = dir.path().join("notes.png");
    std::fs::write(&text, "not a png").unwrap();
    let photo = dir.path().join("photo.png");
    write_photo(&photo);
    let (t, p) = (text.to_str().unwrap(), photo.to_str().unwrap());
    for (args, named) in [
        // Not an image.
        (vec!["--in", t], "notes.png"),
        // A white balance a photo cannot undo.
        (
            vec!["--in", p, "--white-balance", "gray-world"],
            "gray-world",
        ),
        // A sensor whose CFA has no r, g, b filters.
        (vec!["--in", p, "--sensor", "mt9v024-mono"], "mt9v024-mono"),
    ] {
        let mut all = vec!["unprocess"];
        all.extend(args);
        all.extend(["--out", o_s]);
        let o = camsim(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{all:?}: {stderr}");
        assert!(stderr.contains(named), "{all:?}: {stderr}");
        assert!(!out.exists(), "{all:?} wrote {o_s}");
    }
    // A file camsim did not write is never replaced.
    std::fs::write(&out, "precious").unwrap();
    let o = camsim(&["unprocess", "--in", p, "--out", o_s]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious");
}
