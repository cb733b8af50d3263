//! Scenes from photographs (an RGB image on a display model), the dead-leaves texture and a
//! ColorChecker from another reflectance set, each checked against a closed form or a standard:
//! IEC 61966-2-1 for the sRGB display, Matheron's two-point law for dead leaves, and the
//! reflectance file's own values for the chart.

use camsim_core::colorimetry::{srgb_decode, xyz_to_linear_srgb, Cmfs};
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::WavelengthGrid;
use camsim_scene::{create, mean_luminance_cd_m2, SceneConfig};
use std::path::Path;

fn scene(toml: &str) -> SceneConfig {
    SceneConfig::from_toml(toml, "test").unwrap()
}

fn pixel(img: &camsim_core::SpectralImage, p: usize) -> Vec<f64> {
    (0..img.grid.len()).map(|b| img.band(b)[p] as f64).collect()
}

#[test]
fn srgb_display_reproduces_the_image_colours_iec_61966_2_1() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("photo.png");
    // Black, white, the three primaries, greys and a few colours.
    let codes: [[u8; 3]; 10] = [
        [0, 0, 0],
        [255, 255, 255],
        [255, 0, 0],
        [0, 255, 0],
        [0, 0, 255],
        [128, 128, 128],
        [10, 10, 10],
        [200, 120, 30],
        [40, 180, 220],
        [250, 5, 130],
    ];
    let flat: Vec<u8> = codes.iter().flatten().copied().collect();
    camsim_io::raster::write_png8_rgb(&png, 2, 5, &flat).unwrap();
    for grid in [
        WavelengthGrid::default(),
        WavelengthGrid {
            start_nm: 380.0,
            step_nm: 5.0,
            count: 81,
        },
    ] {
        let cfg = scene(&format!(
            "kind = \"rgb\"\npath = \"{}\"\nwhite_luminance_cd_m2 = 80\n",
            png.display()
        ));
        let img = create(&cfg, &grid).unwrap();
        assert_eq!((img.rows, img.cols), (2, 5));
        let cmfs = Cmfs::on(&grid);
        let y_white = 80.0 / LUMINOUS_EFFICACY_LM_PER_W;
        for (p, code) in codes.iter().enumerate() {
            let xyz = cmfs.xyz(&pixel(&img, p)).map(|v| v / y_white);
            let rgb = xyz_to_linear_srgb(xyz);
            for c in 0..3 {
                let want = srgb_decode(code[c] as f64 / 255.0);
                // The standard's 4-digit matrices are inverse to about 1e-4.
                assert!(
                    (rgb[c] - want).abs() < 4e-4,
                    "grid {grid:?} pixel {code:?} channel {c}: {} vs {want}",
                    rgb[c]
                );
            }
        }
        // White at the reference display's 80 cd/m^2.
        let white = cmfs.luminance_cd_m2(&pixel(&img, 1));
        assert!((white - 80.0).abs() < 1e-4 * 80.0, "white {white} cd/m^2");
        // No negative radiance anywhere (the primaries are non-negative spectra).
        assert!(img.data.iter().all(|v| *v >= 0.0));
    }
}

#[test]
fn display_file_gamma_and_linear_exr_follow_their_closed_forms() {
    let dir = tempfile::tempdir().unwrap();
    // Three primaries with known spectra, W/(sr m^2 nm) at full drive.
    let csv = dir.path().join("display.csv");
    let mut text = String::from("wavelength_nm,red,green,blue\n");
    for w in (400..=700).step_by(10) {
        let r = if w >= 600 { 0.02 } else { 0.0 };
        let g = if (500..600).contains(&w) { 0.03 } else { 0.0 };
        let b = if w < 500 {
            0.01 * (w - 390) as f64 / 100.0
        } else {
            0.0
        };
        text += &format!("{w},{r},{g},{b}\n");
    }
    std::fs::write(&csv, text).unwrap();
    let png = dir.path().join("p.png");
    camsim_io::raster::write_png8_rgb(&png, 1, 2, &[128, 64, 255, 0, 255, 0]).unwrap();
    let grid = WavelengthGrid::default();
    let cfg = scene(&format!(
        "kind = \"rgb\"\npath = \"{}\"\ndisplay = \"{}\"\ntransfer = 2.2\n",
        png.display(),
        csv.display()
    ));
    let img = create(&cfg, &grid).unwrap();
    let disp = camsim_scene::Display::from_file(&csv, &grid).unwrap();
    for (p, code) in [[128u8, 64, 255], [0, 255, 0]].iter().enumerate() {
        for b in 0..grid.len() {
            let want: f64 = (0..3)
                .map(|i| (code[i] as f64 / 255.0).powf(2.2) * disp.primaries_w_per_sr_m2_nm[i][b])
                .sum();
            let got = img.band(b)[p] as f64;
            assert!(
                (got - want).abs() <= 1e-6 * want.max(1e-9),
                "pixel {p} band {b}: {got} vs {want}"
            );
        }
    }
    // Rescaled to a mean luminance.
    let cfg = scene(&format!(
        "kind = \"rgb\"\npath = \"{}\"\ndisplay = \"{}\"\nmean_luminance_cd_m2 = 50\n",
        png.display(),
        csv.display()
    ));
    let l = mean_luminance_cd_m2(&create(&cfg, &grid).unwrap());
    assert!((l - 50.0).abs() < 1e-3, "{l}");
    // An OpenEXR is linear: level 2 is twice the display's white, level 0.5 half of it.
    let exr = dir.path().join("hdr.exr");
    camsim_io::exr::write_channels_exr(
        &exr,
        1,
        2,
        &[("R", &[2.0, 0.5]), ("G", &[2.0, 0.5]), ("B", &[2.0, 0.5])],
    )
    .unwrap();
    let img = create(
        &scene(&format!("kind = \"rgb\"\npath = \"{}\"\n", exr.display())),
        &grid,
    )
    .unwrap();
    let cmfs = Cmfs::on(&grid);
    let (l0, l1) = (
        cmfs.luminance_cd_m2(&pixel(&img, 0)),
        cmfs.luminance_cd_m2(&pixel(&img, 1)),
    );
    assert!(
        (l0 - 160.0).abs() < 0.02 && (l1 - 40.0).abs() < 0.005,
        "{l0} {l1}"
    );
}

#[test]
fn rgb_scene_bad_input_names_the_key_or_file() {
    let dir = tempfile::tempdir().unwrap();
    let grid = WavelengthGrid::default();
    let missing = dir.path().join("nope.png");
    let e = create(
        &scene(&format!(
            "kind = \"rgb\"\npath = \"{}\"\n",
            missing.display()
        )),
        &grid,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nope.png"), "{e}");
    let png = dir.path().join("p.png");
    camsim_io::raster::write_png8_rgb(&png, 1, 1, &[1, 2, 3]).unwrap();
    let e = create(
        &scene(&format!(
            "kind = \"rgb\"\npath = \"{}\"\ndisplay = \"oled\"\n",
            png.display()
        )),
        &grid,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.display") && e.contains("oled"), "{e}");
    let e = create(
        &scene(&format!(
            "kind = \"rgb\"\npath = \"{}\"\ntransfer = \"gamma\"\n",
            png.display()
        )),
        &grid,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.transfer"), "{e}");
    let e = create(
        &scene(&format!(
            "kind = \"rgb\"\npath = \"{}\"\ntransfer = -1.0\n",
            png.display()
        )),
        &grid,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.transfer"), "{e}");
    // The built-in display needs the visible range.
    let narrow = WavelengthGrid {
        start_nm: 600.0,
        step_nm: 10.0,
        count: 11,
    };
    let e = create(
        &scene(&format!("kind = \"rgb\"\npath = \"{}\"\n", png.display())),
        &narrow,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.display"), "{e}");
    // An unknown key is reported at its line.
    let e = SceneConfig::from_toml("kind = \"rgb\"\npath = \"a.png\"\ngama = 2\n", "s.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("gama") && e.contains("line 3"), "{e}");
}

/// The probability that two points `tau` apart show the same disc in a dead-leaves image with
/// radius density r^-sigma on [a, b]: E|D n (D + tau)| / E|D u (D + tau)| (Matheron 1968; Bordenave,
/// Gousseau & Roueff 2006), with the lens-shaped overlap of two discs of radius r.
fn same_leaf_probability(tau: f64, sigma: f64, a: f64, b: f64) -> f64 {
    let n = 20000;
    let (mut inter, mut union) = (0.0, 0.0);
    for k in 0..n {
        // Integrate in log r: dr = r dlog r.
        let r = a * (b / a).powf((k as f64 + 0.5) / n as f64);
        let w = r.powf(-sigma) * r;
        let i = if tau < 2.0 * r {
            2.0 * r * r * (tau / (2.0 * r)).acos() - 0.5 * tau * (4.0 * r * r - tau * tau).sqrt()
        } else {
            0.0
        };
        inter += w * i;
        union += w * (2.0 * std::f64::consts::PI * r * r - i);
    }
    inter / union
}

#[test]
fn dead_leaves_two_point_correlation_follows_matheron() {
    let grid = WavelengthGrid {
        start_nm: 500.0,
        step_nm: 10.0,
        count: 3,
    };
    let (size, seeds) = (512usize, [1u64, 2, 3]);
    let taus = [1usize, 2, 4, 8, 16];
    let mut corr = vec![0.0; taus.len()];
    let mut first: Option<Vec<f32>> = None;
    for seed in seeds {
        let cfg = scene(&format!("kind = \"dead_leaves\"\nsize_px = {size}\nr_max_px = 32\nseed = {seed}\nmean_luminance_cd_m2 = 10\n"));
        let img = create(&cfg, &grid).unwrap();
        let v: Vec<f64> = img.band(1).iter().map(|x| *x as f64).collect();
        // Reflectance = radiance / k: the grey levels lie within [0.05, 0.95] x k.
        let (mn, mx) = v
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
        assert!(mn > 0.0 && mx / mn <= 0.95 / 0.05 + 1e-3, "{mn} {mx}");
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64;
        for (t, c) in taus.iter().zip(corr.iter_mut()) {
            let (mut s, mut m) = (0.0, 0usize);
            for i in 0..size {
                for j in 0..size - t {
                    // Horizontal and vertical pairs.
                    s += (v[i * size + j] - mean) * (v[i * size + j + t] - mean);
                    s += (v[j * size + i] - mean) * (v[(j + t) * size + i] - mean);
                    m += 2;
                }
            }
            *c += s / m as f64 / var / seeds.len() as f64;
        }
        // The same seed gives the same texture; another seed another one.
        let again = create(&cfg, &grid).unwrap();
        assert_eq!(again.data, img.data);
        if let Some(f) = &first {
            assert_ne!(f, &img.data);
        }
        first = Some(img.data.clone());
    }
    for (t, c) in taus.iter().zip(&corr) {
        let want = same_leaf_probability(*t as f64, 3.0, 1.0, 32.0);
        eprintln!("dead leaves, tau {t} px: correlation {c:.4}, Matheron {want:.4}");
        assert!(
            (c - want).abs() < 0.03,
            "tau {t} px: correlation {c:.4} against Matheron's {want:.4}"
        );
    }
}

#[test]
fn dead_leaves_bad_parameters_are_refused() {
    let grid = WavelengthGrid::default();
    for (text, key) in [
        ("sigma = 1.0", "scene.sigma"),
        ("r_min_px = 0.1", "scene.r_min_px"),
        ("r_min_px = 8\nr_max_px = 4", "scene.r_max_px"),
        (
            "reflectance_min = 0.9\nreflectance_max = 0.1",
            "scene.reflectance_max",
        ),
    ] {
        let e = create(
            &scene(&format!("kind = \"dead_leaves\"\nsize_px = 16\n{text}\n")),
            &grid,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(key), "{text}: {e}");
    }
}

fn write_reflectance_set(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    // Patch k (1-based) reflects k / 25 at every wavelength, 400-700 nm every 10 nm.
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let csv = dir.join("chart.csv");
    let mut text = String::from("wavelength_nm");
    for k in 1..=24 {
        text += &format!(",patch{k}");
    }
    text.push('\n');
    for w in &wl {
        text += &format!("{w}");
        for k in 1..=24 {
            text += &format!(",{}", k as f64 / 25.0);
        }
        text.push('\n');
    }
    std::fs::write(&csv, text).unwrap();
    // The same set in ISETCam's macbethChart.mat layout: wavelength (31 x 1), data (31 x 24).
    let data: Vec<f64> = (1..=24).flat_map(|k| vec![k as f64 / 25.0; 31]).collect();
    let mat = dir.join("macbethChart.mat");
    std::fs::write(
        &mat,
        camsim_core::mat::mat_v5_doubles(&[("wavelength", 31, 1, &wl), ("data", 31, 24, &data)]),
    )
    .unwrap();
    (csv, mat)
}

#[test]
fn macbeth_chart_from_a_reflectance_file_csv_and_isetcam_mat() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, mat) = write_reflectance_set(dir.path());
    let grid = WavelengthGrid::default();
    for file in [&csv, &mat] {
        let cfg = scene(&format!(
            "kind = \"macbeth\"\npatch_size_px = 4\nborder_px = 1\nreflectances = \"{}\"\n",
            file.display()
        ));
        let SceneConfig::Macbeth(m) = &cfg else {
            unreachable!()
        };
        let rects = camsim_scene::macbeth_patch_rects(m);
        let img = create(&cfg, &grid).unwrap();
        let at = |k: usize, b: usize| {
            let r = rects[k];
            img.band(b)[(r.row0 + 1) * img.cols + r.col0 + 1] as f64
        };
        for k in 0..24 {
            for b in [0, 15, 30] {
                let ratio = at(k, b) / at(0, b);
                assert!(
                    (ratio - (k + 1) as f64).abs() < 1e-5 * (k + 1) as f64,
                    "{}: patch {} band {b}: {ratio}",
                    file.display(),
                    k + 1
                );
            }
        }
    }
    // The default stays N. Ohta's chart.
    let ohta = create(
        &scene("kind = \"macbeth\"\npatch_size_px = 4\nborder_px = 1\n"),
        &grid,
    )
    .unwrap();
    let mine = create(
        &scene(&format!(
            "kind = \"macbeth\"\npatch_size_px = 4\nborder_px = 1\nreflectances = \"{}\"\n",
            csv.display()
        )),
        &grid,
    )
    .unwrap();
    assert_ne!(ohta.data, mine.data);
    // A set that is not 24 spectra is refused, naming the key.
    let bad = dir.path().join("three.csv");
    std::fs::write(
        &bad,
        "wavelength_nm,a,b,c\n400,0.1,0.2,0.3\n700,0.1,0.2,0.3\n",
    )
    .unwrap();
    let e = create(
        &scene(&format!(
            "kind = \"macbeth\"\nreflectances = \"{}\"\n",
            bad.display()
        )),
        &grid,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.reflectances") && e.contains("24"), "{e}");
}
