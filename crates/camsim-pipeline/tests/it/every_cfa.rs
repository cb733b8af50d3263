//! Every CFA through `simulate` (issue 42): a monochrome, an RCCC and an RGBW capture of the
//! ColorChecker (the pixel4a lens and sensor, its CFA replaced by `[sensor.config] cfa_pattern`
//! or `cfa` over the preset) give previews whose gray series is what the sensor's QE says.
//!
//! The closed form: a patch of reflectance rho under illuminant E gives filter f the mean signal
//! s_f(rho) proportional to sum QE_f E rho lambda d lambda (ISETCam `sensorCompute`; the lens
//! scales every patch alike: no lens shading here, `shading = "none"`, and the 2-degree chart is
//! on axis). The ISP is linear up to the sRGB encoding, so in the decoded preview:
//! - monochrome: grey (R = G = B exactly), patch i / white = s_w(rho_i) / s_w(rho_19);
//! - RCCC: (red x gain, clear, clear) with gain = s_w(1) / s_r(1), so a patch's R / G is
//!   (s_r(rho) / s_r(1)) / (s_w(rho) / s_w(1)): 1 for a flat grey, and for the ColorChecker's
//!   gray series (not quite flat, N. Ohta's data) the value computed here;
//! - RGBW: the W-guided fusion scales R, G, B alike, so neutral patches stay as neutral as the
//!   Bayer preview of the same sensor (the QE colour fit maps the white exactly to R = G = B).
//!
//! Tolerances: each patch mean is over the central half of the patch (hundreds of pixels), the
//! noise of the mean a fraction of a percent; the 8-bit sRGB encoding adds at most half a code,
//! 0.3 % of the linear value at the gray patches' levels. The bounds (1.5 %, 3 % for the darkest)
//! cover both several times over.

use camsim_analysis::chart::{chart_patch_stats_rgb, ChartCorners};
use camsim_analysis::Plane;
use camsim_core::colorimetry::srgb_decode;
use camsim_core::{tables, WavelengthGrid};
use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};
use std::path::Path;

fn config(cfa: &str) -> String {
    format!(
        r#"
seed = 7
[scene]
kind = "macbeth"
mean_luminance_cd_m2 = 100.0
fov_deg = 4.0
patch_size_px = 24
border_px = 4
[optics]
preset = "pixel4a"
[optics.config]
shading = "none"
[sensor]
preset = "pixel4a"
rows = 160
cols = 224
[sensor.config]
{cfa}
"#
    )
}

struct Run {
    /// Linear sRGB preview per patch 1..=24 (decoded), R, G, B.
    patch_linear: Vec<[f64; 3]>,
    /// The patch statistics behind `patch_linear` (their spread sets the tolerances).
    stats: Vec<camsim_analysis::chart::PatchStats>,
    sim: camsim_pipeline::Simulation,
    cfg: SimulateConfig,
}

fn run(cfa: &str) -> Run {
    let cfg = SimulateConfig::from_toml_str(&config(cfa), Path::new("")).unwrap();
    let sim = simulate(&cfg, &SimulateOptions::default(), &|_, _, _| {}).unwrap();
    assert_eq!(sim.preview_note, None, "{cfa}: the ISP rendered the frame");
    let p = &sim.preview;
    let plane = |c: usize| {
        Plane::new(
            p.rows,
            p.cols,
            (0..p.rows * p.cols)
                .map(|i| srgb_decode(p.data[3 * i + c] as f64 / 255.0) as f32)
                .collect(),
        )
        .unwrap()
    };
    let raw = &sim.frames[0];
    let c = camsim_pipeline::macbeth_chart_corners_px(
        &cfg,
        &sim.optics,
        sim.sensor.pixel_pitch_um * 1e-6,
        raw.rows,
        raw.cols,
    )
    .unwrap()
    .expect("a macbeth scene");
    let corners = ChartCorners {
        top_left: c[0],
        top_right: c[1],
        bottom_right: c[2],
        bottom_left: c[3],
    };
    let stats = chart_patch_stats_rgb(&[plane(0), plane(1), plane(2)], &corners, 0.5).unwrap();
    Run {
        patch_linear: stats.iter().map(|s| s.mean).collect(),
        stats,
        sim,
        cfg,
    }
}

/// Four standard errors of the ratio of channels `a` and `b` of patch `patch`'s mean (relative):
/// the pixels' spread over the sqrt of the independent samples, a quarter of the pixels (a
/// demosaicked channel is interpolated from every other pixel in each direction at best), plus
/// half an 8-bit code at the ratio's level (the encoding).
fn ratio_tolerance(run: &Run, patch: usize, a: usize, b: usize) -> f64 {
    let st = &run.stats[patch - 1];
    let rel = |k: usize| st.std[k] / st.mean[k];
    let n_eff = (st.n[a].min(st.n[b]) as f64 / 4.0).max(1.0);
    let code = |k: usize| {
        let v = st.mean[k];
        let e = camsim_core::colorimetry::srgb_encode(v) * 255.0;
        (srgb_decode((e + 0.5) / 255.0) - v) / v
    };
    4.0 * (rel(a).powi(2) + rel(b).powi(2)).sqrt() / n_eff.sqrt() + code(a) + code(b)
}

/// s_f(rho) / s_f(1) for ColorChecker patch `i` (1-based) and filter QE `qe` under D65.
fn relative_response(qe: &[f64], patch: usize, grid: &WavelengthGrid) -> f64 {
    let e = tables::illuminant("D65").unwrap().sample(grid);
    let rho = tables::macbeth_reflectances()[patch - 1].sample(grid);
    let s = |r: &dyn Fn(usize) -> f64| -> f64 {
        (0..grid.len())
            .map(|b| qe[b] * e[b] * r(b) * grid.wavelength_nm(b))
            .sum()
    };
    s(&|b| rho[b]) / s(&|_| 1.0)
}

fn filter_qe(run: &Run, name: &str) -> Vec<f64> {
    let sensor = run.cfg.sensor().unwrap();
    let l = sensor.cfa_layout();
    sensor.filter_qe_spectra()[l.filter_index(name).unwrap()].sample(&run.cfg.wavelengths)
}

#[test]
fn a_monochrome_capture_renders_the_gray_series_its_qe_says() {
    let r = run("cfa_pattern = [[\"w\"]]");
    assert_eq!(r.sim.frames[0].cfa_layout().name(), "w");
    // Grey: the three channels of every pixel are one value.
    assert!(r
        .sim
        .preview
        .data
        .chunks(3)
        .all(|p| p[0] == p[1] && p[1] == p[2]));
    let qe = filter_qe(&r, "w");
    let grid = r.cfg.wavelengths;
    let white = r.patch_linear[18][1];
    for patch in [20, 21, 22, 23] {
        let want = relative_response(&qe, patch, &grid) / relative_response(&qe, 19, &grid);
        let got = r.patch_linear[patch - 1][1] / white;
        // Two patches of one channel: the ratio of patch means (stats of both).
        let tol = {
            let (a, b) = (&r.stats[patch - 1], &r.stats[18]);
            let rel = |s: &camsim_analysis::chart::PatchStats| s.std[1] / s.mean[1];
            4.0 * (rel(a).powi(2) + rel(b).powi(2)).sqrt() / (a.n[1] as f64).sqrt() + 0.005
        };
        assert!(
            (got / want - 1.0).abs() < tol,
            "patch {patch}: {got:.4} of the white, the QE says {want:.4} (tolerance {tol:.4})"
        );
    }
}

#[test]
fn an_rccc_capture_renders_neutral_patches_neutral() {
    let r = run("cfa_pattern = [[\"r\", \"clear\"], [\"clear\", \"clear\"]]");
    assert_eq!(r.sim.frames[0].cfa_layout().name(), "r w/w w");
    let (qr, qc) = (filter_qe(&r, "r"), filter_qe(&r, "w"));
    let grid = r.cfg.wavelengths;
    for patch in 19..=23 {
        let [red, g, b] = r.patch_linear[patch - 1];
        assert_eq!(g, b, "patch {patch}: clear shows as G = B");
        let want = relative_response(&qr, patch, &grid) / relative_response(&qc, patch, &grid);
        assert!(
            (want - 1.0).abs() < 0.05,
            "patch {patch} is near neutral: {want}"
        );
        let tol = ratio_tolerance(&r, patch, 0, 1);
        assert!(
            (red / g / want - 1.0).abs() < tol,
            "patch {patch}: R / G = {:.4}, the QE says {want:.4} (tolerance {tol:.4})",
            red / g
        );
    }
    // The red patch (15) renders red: R / G as the QE says, well above 1.
    let [red, g, _] = r.patch_linear[14];
    let want = relative_response(&qr, 15, &grid) / relative_response(&qc, 15, &grid);
    let tol = ratio_tolerance(&r, 15, 0, 1);
    assert!(want > 1.5, "{want}");
    assert!(
        (red / g / want - 1.0).abs() < tol,
        "red patch: R / G = {:.4}, the QE says {want:.4} (tolerance {tol:.4})",
        red / g
    );
}

#[test]
fn an_rgbw_capture_renders_neutral_patches_as_neutral_as_bayer() {
    let rgbw = run("cfa = \"RGBW\"");
    assert_eq!(rgbw.sim.frames[0].cfa_layout().name(), "RGBW");
    // The expected preview of a patch: the QE colour pipeline (the ISP's own matrix, fitted on
    // the chart under D65) applied to the patch's camera response, the same for Bayer and RGBW
    // (the W-guided fusion scales R, G, B alike).
    let sensor = rgbw.cfg.sensor().unwrap();
    let grid = rgbw.cfg.wavelengths;
    let qe = sensor.channel_qe(&grid);
    let d65 = tables::illuminant("D65").unwrap();
    let m = camsim_isp::ColorPipeline::fit(&qe, &grid, &d65)
        .unwrap()
        .camera_to_srgb();
    let cam = camsim_isp::ccm::macbeth_camera_rgb(&qe, &d65, &grid);
    let bayer = run("cfa = \"RGGB\"");
    for patch in 19..=22 {
        let want = camsim_core::colorimetry::mat3_mul_vec(&m, cam[patch - 1]);
        for run in [&rgbw, &bayer] {
            let got = run.patch_linear[patch - 1];
            for (what, k) in [("R / G", 0), ("B / G", 2)] {
                let (v, w) = (got[k] / got[1], want[k] / want[1]);
                let tol = ratio_tolerance(run, patch, k, 1);
                assert!(
                    (v / w - 1.0).abs() < tol,
                    "{} patch {patch} {what}: {v:.4}, the QE pipeline says {w:.4} (tolerance {tol:.4})",
                    run.sim.frames[0].cfa_layout().name()
                );
                assert!((w - 1.0).abs() < 0.03, "patch {patch} is near neutral: {w}");
            }
        }
    }
}

/// A test tile: its name, the CFA cells, the named filters' curves.
type Tile<'a> = (&'a str, Vec<Vec<&'a str>>, Vec<(&'a str, Vec<f64>)>);

/// A flat grey (reflectance 0.5 at every wavelength) seen by RGB-IR and CMY sensors renders grey:
/// the fitted 3 x N transform maps the white's camera values onto the D65 white (R = G = B, to
/// the 2e-4 of the IEC matrix), and a flat grey's camera values are half the white's in every
/// channel. The frame is made here from the closed form: DN of filter f = scale x
/// sum QE_f E lambda d lambda (rounded), through `Isp::compute` with the sensor's QE. A frame
/// clipped in every channel renders grey too.
#[test]
fn rgb_ir_and_cmy_frames_render_a_flat_grey_grey() {
    let grid = WavelengthGrid::default();
    let d65 = tables::illuminant("D65").unwrap();
    let preset = camsim_sensor::Sensor::preset("pixel4a").unwrap();
    let n = preset.config().qe.wavelengths_nm.len();
    let ramp: Vec<f64> = preset
        .config()
        .qe
        .wavelengths_nm
        .iter()
        .map(|w| ((w - 380.0) / 700.0).clamp(0.0, 1.0))
        .collect();
    let r = &preset.config().qe.r;
    let g = &preset.config().qe.g;
    let b = &preset.config().qe.b;
    let mix =
        |a: &[f64], c: &[f64]| -> Vec<f64> { (0..n).map(|k| (a[k] + c[k]).min(1.0)).collect() };
    let tiles: [Tile; 2] = [
        (
            "RGB-IR",
            vec![vec!["r", "g"], vec!["ir", "b"]],
            vec![("ir", ramp.clone())],
        ),
        (
            "CMY",
            vec![vec!["c", "m"], vec!["y", "c"]],
            vec![("c", mix(g, b)), ("m", mix(r, b)), ("y", mix(r, g))],
        ),
    ];
    for (what, pattern, filters) in tiles {
        let mut c = preset.config().clone();
        c.cfa = String::new();
        c.cfa_pattern = Some(
            pattern
                .iter()
                .map(|row| row.iter().map(|s| s.to_string()).collect())
                .collect(),
        );
        c.qe.filters = filters
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        let sensor = camsim_sensor::Sensor::from_config_named(c, what).unwrap();
        let layout = sensor.cfa_layout();
        let e = d65.sample(&grid);
        let resp: Vec<f64> = sensor
            .filter_qe_spectra()
            .iter()
            .map(|s| {
                let q = s.sample(&grid);
                (0..grid.len())
                    .map(|k| 0.5 * q[k] * e[k] * grid.wavelength_nm(k))
                    .sum()
            })
            .collect();
        let top = resp.iter().cloned().fold(0.0, f64::max);
        let (rows, cols) = (16, 20);
        let mut raw =
            camsim_core::RawImage::new(rows, cols, camsim_core::CfaPattern::Rggb, 16).unwrap();
        raw.layout = Some(layout.clone());
        for y in 0..rows {
            for x in 0..cols {
                raw.dn[y * cols + x] =
                    (20000.0 * resp[layout.filter_at(y, x)] / top).round() as u16;
            }
        }
        let isp = camsim_pipeline::Isp::new(d65.clone(), grid);
        let out = isp.compute(&raw, &sensor).unwrap();
        assert_eq!(out.report.cfa_family, "multichannel", "{what}");
        let de = out.report.channel_fit_delta_e2000.unwrap();
        println!("{what}: fit dE2000 mean {:.2} max {:.2}", de[0], de[1]);
        for p in out.preview.data.chunks(3) {
            let spread = p.iter().max().unwrap() - p.iter().min().unwrap();
            assert!(spread <= 1, "{what}: a flat grey renders {p:?}");
        }
        // A clipped frame (every pixel at the white level) renders white: each channel is
        // clipped at the saturation times its share of the white, and M takes the white to
        // R = G = B.
        let mut clipped = raw.clone();
        clipped.dn.fill(clipped.white_level_dn as u16);
        let out = isp.compute(&clipped, &sensor).unwrap();
        for p in out.preview.data.chunks(3) {
            let spread = p.iter().max().unwrap() - p.iter().min().unwrap();
            assert!(spread <= 1, "{what}: a clipped frame renders {p:?}");
        }
        // The fitted transform holds the illuminant's white balance: another method is refused.
        let mut gw = isp.clone();
        gw.white_balance = camsim_isp::WhiteBalanceMethod::GrayWorld;
        let e = gw.compute(&raw, &sensor).unwrap_err().to_string();
        assert!(
            e.contains("gray-world") && e.contains("multichannel"),
            "{e}"
        );
    }
}
