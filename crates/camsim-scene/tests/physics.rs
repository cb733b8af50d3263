//! Physics checks of the 2D scenes against independent computations: luminance from the CIE
//! table, D65 chromaticity from CIE 015:2018, Ohta reflectances, and the analytic area coverage
//! of a pixel by a half-plane.

use camsim_core::{tables, Quantity, SpectralImage, WavelengthGrid};
use camsim_scene::*;

/// 683 * sum ybar L dl averaged over pixels, straight from the CIE table (not via Cmfs).
fn independent_mean_luminance(img: &SpectralImage) -> f64 {
    let ybar = &tables::cie1931_xyz_cmfs()[1];
    let mut total = 0.0;
    for b in 0..img.bands() {
        let w = img.grid.wavelength_nm(b);
        let s: f64 = img.band(b).iter().map(|v| *v as f64).sum();
        total += 683.0 * ybar.eval(w) * s * img.grid.step_nm;
    }
    total / img.pixels() as f64
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn mean_luminance_equals_the_request_for_every_kind() {
    let g = WavelengthGrid::default();
    let cases = vec![
        SceneConfig::Uniform(UniformScene {
            mean_luminance_cd_m2: 37.5,
            illuminant: "A".into(),
            reflectance: Reflectance::Grey(0.4),
            rows: 8,
            cols: 12,
            ..Default::default()
        }),
        SceneConfig::Uniform(UniformScene {
            illuminant: "F11".into(),
            reflectance: Reflectance::Named("macbeth:blue".into()),
            ..Default::default()
        }),
        SceneConfig::Macbeth(MacbethScene {
            mean_luminance_cd_m2: 250.0,
            patch_size_px: 6,
            border_px: 2,
            ..Default::default()
        }),
        SceneConfig::Macbeth(MacbethScene {
            illuminant: "blackbody-3200".into(),
            patch_size_px: 5,
            border_px: 0,
            ..Default::default()
        }),
        SceneConfig::SlantedEdge(SlantedEdgeScene {
            mean_luminance_cd_m2: 12.0,
            illuminant: "F2".into(),
            rows: 40,
            cols: 50,
            ..Default::default()
        }),
    ];
    for cfg in cases {
        let img = create(&cfg, &g).unwrap();
        assert_eq!(img.quantity, Quantity::Radiance);
        let want = match &cfg {
            SceneConfig::Uniform(c) => c.mean_luminance_cd_m2,
            SceneConfig::Macbeth(c) => c.mean_luminance_cd_m2,
            SceneConfig::SlantedEdge(c) => c.mean_luminance_cd_m2,
            _ => unreachable!(),
        };
        let got = independent_mean_luminance(&img);
        // f32 storage: relative error ~ 1e-7 per value.
        assert!(
            rel(got, want) < 1e-5,
            "{}: {got} vs {want} cd/m^2",
            cfg.kind()
        );
        assert!(rel(mean_luminance_cd_m2(&img), want) < 1e-5);
    }
}

#[test]
fn uniform_white_under_d65_has_the_d65_chromaticity() {
    // CIE 015:2018 Table 5: D65 (2-degree observer) x = 0.31272, y = 0.32903. Summing the 5-nm
    // tables over 380-780 nm reproduces them to the fifth decimal.
    let g = WavelengthGrid::new(380.0, 780.0, 5.0).unwrap();
    let cfg = SceneConfig::Uniform(UniformScene {
        rows: 4,
        cols: 4,
        ..Default::default()
    });
    let img = create(&cfg, &g).unwrap();
    let cmfs = tables::cie1931_xyz_cmfs();
    let mut xyz = [0.0; 3];
    for b in 0..img.bands() {
        for (k, c) in cmfs.iter().enumerate() {
            xyz[k] += c.eval(g.wavelength_nm(b)) * img.at(2, 1, b) as f64;
        }
    }
    let s = xyz[0] + xyz[1] + xyz[2];
    let (x, y) = (xyz[0] / s, xyz[1] / s);
    assert!(
        (x - 0.31272).abs() < 1e-4 && (y - 0.32903).abs() < 1e-4,
        "xy = ({x}, {y})"
    );
    // On the default 400-700 nm grid the truncated integral shifts it only slightly.
    let img = create(&cfg, &WavelengthGrid::default()).unwrap();
    let g = img.grid;
    let mut xyz = [0.0; 3];
    for b in 0..img.bands() {
        for (k, c) in cmfs.iter().enumerate() {
            xyz[k] += c.eval(g.wavelength_nm(b)) * img.at(0, 0, b) as f64;
        }
    }
    let s = xyz[0] + xyz[1] + xyz[2];
    assert!((xyz[0] / s - 0.31272).abs() < 3e-3 && (xyz[1] / s - 0.32903).abs() < 3e-3);
}

#[test]
fn macbeth_patch_radiance_is_illuminant_times_ohta_reflectance_times_the_scale() {
    let g = WavelengthGrid::default();
    let (p, bw) = (8usize, 3usize);
    let target = 80.0;
    let cfg = MacbethScene {
        mean_luminance_cd_m2: target,
        illuminant: "A".into(),
        patch_size_px: p,
        border_px: bw,
        border_reflectance: 0.05,
        ..Default::default()
    };
    let img = create(&SceneConfig::Macbeth(cfg.clone()), &g).unwrap();
    assert_eq!((img.rows, img.cols), (4 * p + 5 * bw, 6 * p + 7 * bw));
    let illum = tables::illuminant("A").unwrap();
    let refl = tables::macbeth_reflectances();
    let ybar = &tables::cie1931_xyz_cmfs()[1];
    // The scale from the luminance requirement, computed from areas: 24 patches of p^2 pixels, the
    // rest border.
    let total = (img.rows * img.cols) as f64;
    let mut unit_lum = 0.0;
    for b in 0..g.len() {
        let w = g.wavelength_nm(b);
        let sum_refl: f64 = refl.iter().map(|r| r.eval(w)).sum::<f64>() * (p * p) as f64
            + 0.05 * (total - 24.0 * (p * p) as f64);
        unit_lum += 683.0 * ybar.eval(w) * illum.eval(w) * sum_refl / total * g.step_nm;
    }
    let k = target / unit_lum;
    for i in 0..24 {
        let (pr, pc) = (i / 6, i % 6);
        // Every pixel of the patch, computed from the layout rule (not from the crate's rects).
        for dr in 0..p {
            for dc in 0..p {
                let row = bw + pr * (p + bw) + dr;
                let col = bw + pc * (p + bw) + dc;
                for b in 0..g.len() {
                    let w = g.wavelength_nm(b);
                    let want = k * illum.eval(w) * refl[i].eval(w);
                    let got = img.at(row, col, b) as f64;
                    assert!(
                        rel(got, want) < 2e-6,
                        "patch {} at {w} nm: {got} vs {want}",
                        i + 1
                    );
                }
            }
        }
    }
    // Borders carry the border reflectance.
    for (row, col) in [(0, 0), (bw + p, 5), (img.rows - 1, img.cols - 1)] {
        let w = 550.0;
        let b = g.band_of(w).unwrap();
        assert!(rel(img.at(row, col, b) as f64, k * illum.eval(w) * 0.05) < 2e-6);
    }
    // The exposed rectangles agree with the layout rule.
    let rects = macbeth_patch_rects(&cfg);
    assert_eq!(rects.len(), 24);
    assert_eq!(
        rects[18],
        Rect {
            row0: bw + 3 * (p + bw),
            col0: bw,
            rows: p,
            cols: p
        }
    );
    // Geometry: sample spacing = 2 d tan(fov/2) / cols.
    let want_dx = 2.0 * 1.2 * (5.0f64).to_radians().tan() / img.cols as f64;
    assert!(rel(img.sample_spacing_m, want_dx) < 1e-12);
    assert_eq!((img.geometry.fov_deg, img.geometry.distance_m), (10.0, 1.2));
}

/// CDF of the projection of a unit pixel onto the edge normal (the sum of two uniform variables
/// of widths a = |cos|, b = |sin|): the fraction of a pixel whose centre lies at signed distance s
/// from a straight edge that is on the bright side. Trapezoid convolution, closed form.
fn pixel_step_response(s: f64, angle_deg: f64) -> f64 {
    let (sn, cs) = angle_deg.to_radians().sin_cos();
    let (a, b) = (cs.abs().max(sn.abs()), cs.abs().min(sn.abs()));
    let (h1, h2) = (0.5 * (a - b), 0.5 * (a + b));
    if s <= -h2 {
        0.0
    } else if s < -h1 {
        (s + h2).powi(2) / (2.0 * a * b)
    } else if s <= h1 {
        0.5 + s / a
    } else if s < h2 {
        1.0 - (h2 - s).powi(2) / (2.0 * a * b)
    } else {
        1.0
    }
}

#[test]
fn slanted_edge_is_the_area_sampled_ideal_step() {
    let g = WavelengthGrid::default();
    for angle in [5.0, -8.0, 2.5] {
        let c = SlantedEdgeScene {
            rows: 60,
            cols: 48,
            angle_deg: angle,
            bright_reflectance: 0.9,
            dark_reflectance: 0.1,
            illuminant: "D65".into(),
            ..Default::default()
        };
        let img = create(&SceneConfig::SlantedEdge(c.clone()), &g).unwrap();
        let b = g.band_of(550.0).unwrap();
        // Reflectance from radiance: the far-right column is fully bright.
        let bright = img.at(img.rows / 2, img.cols - 1, b) as f64;
        let refl = |row: usize, col: usize| img.at(row, col, b) as f64 / bright * 0.9;
        let tan = angle.to_radians().tan();
        let (cx, cy) = (24.0, 30.0);
        let mut ys = vec![];
        let mut xs = vec![];
        for row in 0..img.rows {
            // Mean across the row: the bright part of the row strip has area cols - x_edge(row + 1/2).
            let x_edge = cx + (row as f64 + 0.5 - cy) * tan;
            let want = 0.1 + 0.8 * (img.cols as f64 - x_edge) / img.cols as f64;
            let got = (0..img.cols).map(|col| refl(row, col)).sum::<f64>() / img.cols as f64;
            assert!(
                (got - want).abs() < 1e-5,
                "angle {angle} row {row}: {got} vs {want}"
            );
            // ESF: each pixel's coverage equals the pixel-aperture step response at its distance.
            for col in 0..img.cols {
                let (x, y) = (col as f64 + 0.5, row as f64 + 0.5);
                let s = (x - cx) * angle.to_radians().cos() - (y - cy) * angle.to_radians().sin();
                let want = 0.1 + 0.8 * pixel_step_response(s, angle);
                assert!(
                    (refl(row, col) - want).abs() < 1e-5,
                    "angle {angle} ({row},{col}) s={s}: {} vs {want}",
                    refl(row, col)
                );
            }
            // ISO 12233 edge location: centroid of the row's first difference.
            let (mut num, mut den) = (0.0, 0.0);
            for col in 0..img.cols - 1 {
                let d = refl(row, col + 1) - refl(row, col);
                num += d * (col as f64 + 1.0);
                den += d;
            }
            xs.push(num / den);
            ys.push(row as f64 + 0.5);
        }
        // Least-squares line x = x0 + slope * y; the slope is tan(angle).
        let n = ys.len() as f64;
        let (my, mx) = (ys.iter().sum::<f64>() / n, xs.iter().sum::<f64>() / n);
        let sxy: f64 = ys.iter().zip(&xs).map(|(y, x)| (y - my) * (x - mx)).sum();
        let syy: f64 = ys.iter().map(|y| (y - my).powi(2)).sum();
        let fitted = (sxy / syy).atan().to_degrees();
        assert!(
            (fitted - angle).abs() < 1e-3,
            "fitted {fitted} deg vs {angle}"
        );
        assert!((mx - (cx + (my - cy) * tan)).abs() < 1e-3);
    }
}

#[test]
fn config_parses_from_toml_with_defaults_and_round_trips() {
    let cfg = SceneConfig::from_toml(
        "kind = \"macbeth\"\nfov_deg = 20\npatch_size_px = 12\n",
        "scene.toml",
    )
    .unwrap();
    match &cfg {
        SceneConfig::Macbeth(m) => {
            assert_eq!(
                (
                    m.fov_deg,
                    m.patch_size_px,
                    m.mean_luminance_cd_m2,
                    m.distance_m
                ),
                (20.0, 12, 100.0, 1.2)
            );
            assert_eq!(m.illuminant, "D65");
        }
        _ => panic!("wrong kind"),
    }
    assert_eq!(SceneConfig::from_toml(&cfg.to_toml(), "x").unwrap(), cfg);
    let u = SceneConfig::from_toml("kind = \"uniform\"\nreflectance = 0.5\nwavelengths = { start_nm = 380, step_nm = 5, count = 81 }\n", "s").unwrap();
    assert_eq!(u.grid().count, 81);
    match u {
        SceneConfig::Uniform(u) => assert_eq!(u.reflectance, Reflectance::Grey(0.5)),
        _ => panic!(),
    }
    let e = SceneConfig::from_toml("kind = \"slanted_edge\"\nangle = 5\n", "edge.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("edge.toml") && e.contains("angle"), "{e}");
    // An unknown kind ("checkerboard" is one now: ISETCam's 'rings rays' is not).
    let e = SceneConfig::from_toml("kind = \"rings_rays\"\n", "s.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("rings_rays"), "{e}");
    let defaults = SceneConfig::default();
    assert_eq!(defaults.kind(), "macbeth");
}

#[test]
fn bad_values_are_errors_that_name_the_key() {
    let g = WavelengthGrid::default();
    let bad = |cfg: SceneConfig, key: &str| {
        let e = create(&cfg, &g).unwrap_err().to_string();
        assert!(e.contains(key), "error '{e}' should name {key}");
    };
    for fov in [0.0, -5.0, 180.0, f64::NAN] {
        bad(
            SceneConfig::Uniform(UniformScene {
                fov_deg: fov,
                ..Default::default()
            }),
            "fov_deg",
        );
    }
    bad(
        SceneConfig::Uniform(UniformScene {
            mean_luminance_cd_m2: -1.0,
            ..Default::default()
        }),
        "mean_luminance_cd_m2",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            distance_m: 0.0,
            ..Default::default()
        }),
        "distance_m",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            illuminant: "D66".into(),
            ..Default::default()
        }),
        "illuminant",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            illuminant: "no/such/lamp.csv".into(),
            ..Default::default()
        }),
        "illuminant",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            reflectance: Reflectance::Grey(1.5),
            ..Default::default()
        }),
        "reflectance",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            reflectance: Reflectance::Named("missing_refl.csv".into()),
            ..Default::default()
        }),
        "reflectance",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            reflectance: Reflectance::Named("macbeth:99".into()),
            ..Default::default()
        }),
        "reflectance",
    );
    bad(
        SceneConfig::Uniform(UniformScene {
            rows: 0,
            ..Default::default()
        }),
        "rows",
    );
    bad(
        SceneConfig::Macbeth(MacbethScene {
            patch_size_px: 0,
            ..Default::default()
        }),
        "patch_size_px",
    );
    bad(
        SceneConfig::SlantedEdge(SlantedEdgeScene {
            angle_deg: 45.0,
            ..Default::default()
        }),
        "angle_deg",
    );
    bad(
        SceneConfig::SlantedEdge(SlantedEdgeScene {
            dark_reflectance: -0.1,
            ..Default::default()
        }),
        "dark_reflectance",
    );
    // A black scene cannot be scaled to a positive luminance.
    bad(
        SceneConfig::Uniform(UniformScene {
            reflectance: Reflectance::Grey(0.0),
            ..Default::default()
        }),
        "mean_luminance_cd_m2",
    );
    // ... but a dark scene (0 cd/m^2) is allowed.
    let dark = create(
        &SceneConfig::Uniform(UniformScene {
            mean_luminance_cd_m2: 0.0,
            ..Default::default()
        }),
        &g,
    )
    .unwrap();
    assert!(dark.data.iter().all(|v| *v == 0.0));
    // Huge images are refused before allocating.
    std::env::set_var("CAMSIM_MEMORY_LIMIT_MIB", "64");
    let e = create(
        &SceneConfig::Uniform(UniformScene {
            rows: 10_000,
            cols: 10_000,
            ..Default::default()
        }),
        &g,
    );
    std::env::remove_var("CAMSIM_MEMORY_LIMIT_MIB");
    assert!(e.is_err());
}

#[test]
fn file_scene_is_rescaled_resampled_and_given_geometry() {
    // A uniform radiance image on a 5-nm grid stands in for a file.
    let g5 = WavelengthGrid::new(380.0, 780.0, 5.0).unwrap();
    let src = create(
        &SceneConfig::Uniform(UniformScene {
            rows: 6,
            cols: 8,
            illuminant: "D65".into(),
            ..Default::default()
        }),
        &g5,
    )
    .unwrap();
    let d65 = tables::illuminant("D65").unwrap();
    let cfg = FileScene {
        path: "radiance.exr".into(),
        mean_luminance_cd_m2: Some(42.0),
        fov_deg: Some(30.0),
        distance_m: Some(2.0),
        wavelengths: Some(WavelengthGrid::default()),
        units: Default::default(),
    };
    let img = from_image(&cfg, src.clone()).unwrap();
    assert_eq!(img.bands(), 31);
    assert!(rel(independent_mean_luminance(&img), 42.0) < 1e-5);
    // The spectral shape survives resampling (every default-grid wavelength is a 5-nm sample).
    let r = img.at(1, 1, 0) as f64 / d65.eval(400.0);
    for b in 0..31 {
        let w = img.grid.wavelength_nm(b);
        assert!(
            rel(img.at(1, 1, b) as f64, r * d65.eval(w)) < 1e-5,
            "{w} nm"
        );
    }
    assert!(
        rel(
            img.sample_spacing_m,
            2.0 * 2.0 * (15.0f64).to_radians().tan() / 8.0
        ) < 1e-12
    );
    // Resampling at mid-band wavelengths interpolates linearly.
    let g_mid = WavelengthGrid::new(402.5, 697.5, 10.0).unwrap();
    let mid = resample_bands(&src, &g_mid).unwrap();
    let k = src.at(0, 0, 0) as f64 / d65.eval(380.0);
    let want = k * 0.5 * (d65.eval(400.0) + d65.eval(405.0));
    assert!(rel(mid.at(0, 0, 0) as f64, want) < 1e-5);
    // Without a field of view, the file's sample spacing is kept and the fov derived from it.
    let keep = from_image(
        &FileScene {
            path: "r.exr".into(),
            mean_luminance_cd_m2: None,
            fov_deg: None,
            distance_m: None,
            wavelengths: None,
            units: Default::default(),
        },
        src.clone(),
    )
    .unwrap();
    assert_eq!(keep.sample_spacing_m, src.sample_spacing_m);
    assert!((keep.geometry.fov_deg - 10.0).abs() < 1e-9);
    assert_eq!(keep.data, src.data);
    // Scaling reports its factor and is exact.
    let mut s = src.clone();
    let f = scale_to_luminance(&mut s, 200.0).unwrap();
    assert!(rel(f, 2.0) < 1e-5);
    // Bad values in a file are rejected, naming the file.
    let mut bad = src.clone();
    bad.data[3] = f32::NAN;
    let e = from_image(&cfg, bad).unwrap_err().to_string();
    assert!(e.contains("radiance.exr"), "{e}");
    let mut irr = src;
    irr.quantity = Quantity::Irradiance;
    assert!(from_image(&cfg, irr).is_err());
}

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

#[test]
fn illuminant_and_reflectance_from_spectrum_files() {
    // The Cornell box lamp (ISET/isetcornellbox, CSV and MATLAB v5 copies of the same numbers) on a
    // Cornell box wall (cornell_box_spectra.csv, column "green").
    let g = WavelengthGrid::default();
    let lamp_csv = format!("{DATA}/isetcornellbox/cboxIlluminant.csv");
    let lamp_mat = format!("{DATA}/isetcornellbox/cboxIlluminant.mat");
    let wall = format!("{DATA}/cornell_box_spectra.csv#green");
    let mk = |lamp: &str| {
        SceneConfig::Uniform(UniformScene {
            rows: 2,
            cols: 2,
            illuminant: lamp.into(),
            reflectance: Reflectance::Named(wall.clone()),
            ..Default::default()
        })
    };
    let a = create(&mk(&lamp_csv), &g).unwrap();
    let b = create(&mk(&lamp_mat), &g).unwrap();
    for (x, y) in a.data.iter().zip(&b.data) {
        assert!(rel(*x as f64, *y as f64) < 1e-5);
    }
    assert!(rel(independent_mean_luminance(&a), 100.0) < 1e-5);
    // Radiance shape = lamp x wall, read independently from the CSV text.
    let parse = |path: &str, col: usize| -> Vec<(f64, f64)> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength"))
            .map(|l| {
                let f: Vec<f64> = l.split(',').map(|v| v.trim().parse().unwrap()).collect();
                (f[0], f[col])
            })
            .collect()
    };
    let lamp = camsim_core::Spectrum::from_pairs(&parse(&lamp_csv, 1));
    let green =
        camsim_core::Spectrum::from_pairs(&parse(&format!("{DATA}/cornell_box_spectra.csv"), 2));
    let shape = |w: f64| lamp.eval(w) * green.eval(w);
    let k = a.at(0, 0, 15) as f64 / shape(550.0);
    for band in 0..31 {
        let w = g.wavelength_nm(band);
        assert!(rel(a.at(1, 0, band) as f64, k * shape(w)) < 1e-5, "{w} nm");
    }
    // A missing column or file is an error naming the key and the file.
    let bad = SceneConfig::Uniform(UniformScene {
        reflectance: Reflectance::Named(format!("{DATA}/cornell_box_spectra.csv#blue")),
        ..Default::default()
    });
    let e = create(&bad, &g).unwrap_err().to_string();
    assert!(e.contains("scene.reflectance") && e.contains("blue"), "{e}");
}

#[test]
fn relative_paths_resolve_against_the_config_folder() {
    let mut cfg = SceneConfig::from_toml(
        "kind = \"uniform\"\nilluminant = \"lamps/lamp.csv\"\nreflectance = \"wall.mat\"\n",
        "s",
    )
    .unwrap();
    cfg.resolve_paths(std::path::Path::new("/cfg"));
    match cfg {
        SceneConfig::Uniform(u) => {
            assert_eq!(u.illuminant, "/cfg/lamps/lamp.csv");
            assert_eq!(u.reflectance, Reflectance::Named("/cfg/wall.mat".into()));
        }
        _ => panic!(),
    }
    let mut cfg =
        SceneConfig::from_toml("kind = \"macbeth\"\nilluminant = \"blackbody-6500\"\n", "s")
            .unwrap();
    cfg.resolve_paths(std::path::Path::new("/cfg"));
    assert!(matches!(cfg, SceneConfig::Macbeth(ref m) if m.illuminant == "blackbody-6500"));
}
