//! ColorChecker patch statistics on a noise-free camsim capture equal the analytic channel
//! responses (issue 5: "patch means on a noise-free camsim ColorChecker equal the analytic channel
//! responses within 0.5 %").
//!
//! Chain: `camsim_scene::create` (macbeth, D65) -> diffraction-limited optics (f/1.73, 4.38 mm;
//! shading "none") -> the `pixel4a` sensor with every noise source off -> raw mosaic (and a DNG
//! written and read back) -> `camsim_analysis::chart` with the corners computed from the scene's
//! layout. The analytic response of a patch is the sensor's mean-signal model for a uniform field
//! of the patch's irradiance, E(lambda) = pi T / (1 + 4 N^2 (1 + m)^2) L(lambda) (camera equation,
//! ISETCam `oiCalculateIrradiance`), DN = K x sum_lambda E QE_c lambda/(h c) d_lambda A t
//! (`Sensor::mean_electrons_uniform`, ISETCam `sensorCompute`) + black level.
//!
//! Why the patch interiors are exactly uniform: the lens PSF is truncated where it leaves 2 % of
//! its energy outside (`psf.tail_energy = 0.02`; the kernel is renormalized to unit volume), a
//! radius of 2 lambda N / (pi^2 0.02) + lambda N = 13.5 um = 10 pixels at 700 nm. The scene's
//! field of view is chosen so the irradiance samples coincide with the 1.4 um pixels, and the
//! patches are 56 pixels wide: the central half measured (ISETCam `chartRectangles`' default
//! fraction 0.5 of the 60-pixel patch pitch) stays 13 pixels from every patch edge, beyond the
//! PSF's reach. The test checks that premise (margin > kernel half width) and that every region
//! is uniform (zero standard deviation on the noise-free raw data).
//!
//! Quantization: raw frames are always rounded by the ADC, so a uniform region reads round(a)
//! for an analytic value a: the raw means must be within 0.5 DN of a. The unrounded ADC input
//! (quantization switched off, `Frame::analog_dn`) must match within 0.5 % (measured: ~1e-6, f32
//! accumulation).

// Channel loops index several arrays at once (r, g, b).

use camsim_analysis::chart::{chart_patch_rects, chart_patch_stats_raw, ChartCorners};
use camsim_core::{RawImage, WavelengthGrid};
use camsim_optics::config::{ShadingConfig, ShadingName};
use camsim_optics::{lens, Optics, OpticsConfig};
use camsim_scene::{MacbethScene, SceneConfig};
use camsim_sensor::{Capture, NoiseSwitches, Sensor};

const PATCH_PX: usize = 56;
const BORDER_PX: usize = 4;
const DISTANCE_M: f64 = 1.2;

#[test]
fn chart_patch_means_equal_the_analytic_channel_responses() {
    let grid = WavelengthGrid::default();
    let mut oc = OpticsConfig::preset("diffraction-limited").unwrap();
    oc.shading = ShadingConfig::Named(ShadingName::None);
    oc.psf.tail_energy = 0.02;
    // Kernels only, trimmed and renormalized (no far tail): then no light crosses more than the
    // kernel's half width, the premise of the exact per-patch comparison below. (The far tail's
    // own accuracy is tested against the whole-image OTF in camsim-optics' image tests.)
    oc.psf.method = camsim_optics::config::BlurMethod::Kernel;
    oc.psf.far_tail = false;
    let optics = Optics::from_config(&oc).unwrap();
    let sensor_full = Sensor::preset("pixel4a").unwrap();
    let pitch_m = sensor_full.pixel_pitch_m();

    // Scene: the field of view whose image on the sensor is sampled at exactly the pixel pitch:
    // spacing at the sensor = 2 v tan(fov / 2) / cols, v the thin-lens image distance.
    let f_m = oc.focal_length_mm * 1e-3;
    let v_m = lens::image_distance_m(f_m, DISTANCE_M).unwrap();
    let probe = MacbethScene {
        patch_size_px: PATCH_PX,
        border_px: BORDER_PX,
        ..MacbethScene::default()
    };
    let (rows, cols) = (probe.layout().rows(), probe.layout().cols());
    let fov_deg = 2.0 * (pitch_m * cols as f64 / (2.0 * v_m)).atan().to_degrees();
    let scene = MacbethScene {
        fov_deg,
        distance_m: DISTANCE_M,
        ..probe
    };
    let radiance = camsim_scene::create(&SceneConfig::Macbeth(scene.clone()), &grid).unwrap();
    let irradiance = optics.compute(&radiance).unwrap();
    assert!(
        (irradiance.sample_spacing_m / pitch_m - 1.0).abs() < 1e-9,
        "irradiance spacing {}",
        irradiance.sample_spacing_m
    );
    // PSF padding on each side = the kernel half width, pixels.
    let kernel_half_px = (irradiance.cols - cols) / 2;
    assert_eq!(irradiance.rows - rows, 2 * kernel_half_px);

    // The sensor covers the scene's image: same size, both centred on the axis, so sensor pixel
    // (r, c) sees scene pixel (r, c).
    let sensor = sensor_full.with_size(rows, cols).unwrap();
    let k = sensor.k_dn_per_e();
    let black = sensor.black_level_dn();

    // Analytic response of each patch: its radiance (the scene's value at the patch) -> irradiance
    // (camera equation, on axis, no shading) -> electrons -> DN.
    let m = lens::magnification(f_m, DISTANCE_M);
    let factor: Vec<f64> = (0..grid.len())
        .map(|b| {
            lens::irradiance_factor(oc.f_number, m, optics.transmittance(grid.wavelength_nm(b)))
        })
        .collect();
    let rects = camsim_scene::macbeth_patch_rects(&scene);
    let electrons_per_s: Vec<[f64; 3]> = rects
        .iter()
        .map(|r| {
            let l = radiance.pixel_spectrum(r.row0 + r.rows / 2, r.col0 + r.cols / 2);
            let e: Vec<f64> = l.iter().zip(&factor).map(|(l, f)| l * f).collect();
            sensor.mean_electrons_uniform(&e, &grid, 1.0).unwrap()
        })
        .collect();
    // Exposure: the white patch's green at 80 % of the 12-bit range.
    let t_s = 0.8 * sensor.max_dn() as f64 / k / electrons_per_s[18][1];
    let analytic_dn: Vec<[f64; 3]> = electrons_per_s
        .iter()
        .map(|e| e.map(|v| v * t_s * k + black))
        .collect();

    // Chart corners from the scene geometry: the outer corners of the 4 x 6 grid of patch pitches
    // (patch + border), half a border outside the outer patches, mapped to sensor pixels
    // (x_sensor = (x_scene - cols/2) spacing / pitch + sensor cols / 2: the identity here).
    let to_sensor = |x: f64, n_scene: usize, n_sensor: usize| {
        (x - n_scene as f64 / 2.0) * irradiance.sample_spacing_m / pitch_m + n_sensor as f64 / 2.0
    };
    let half_border = BORDER_PX as f64 / 2.0;
    let x0 = rects[0].col0 as f64 - half_border;
    let x1 = (rects[5].col0 + PATCH_PX) as f64 + half_border;
    let y0 = rects[0].row0 as f64 - half_border;
    let y1 = (rects[18].row0 + PATCH_PX) as f64 + half_border;
    let p = |x: f64, y: f64| {
        [
            to_sensor(x, cols, sensor.cols()),
            to_sensor(y, rows, sensor.rows()),
        ]
    };
    let corners = ChartCorners {
        top_left: p(x0, y0),
        top_right: p(x1, y0),
        bottom_right: p(x1, y1),
        bottom_left: p(x0, y1),
    };

    // Premise: every measured region lies inside its patch, further from the edges than the PSF reaches.
    let regions = chart_patch_rects(&corners, 0.5, sensor.rows(), sensor.cols()).unwrap();
    for (reg, r) in regions.iter().zip(&rects) {
        let margin = [
            reg.rect.row as isize - r.row0 as isize,
            reg.rect.col as isize - r.col0 as isize,
            (r.row0 + r.rows) as isize - reg.rect.row_end() as isize,
            (r.col0 + r.cols) as isize - reg.rect.col_end() as isize,
        ];
        assert!(
            margin.iter().all(|m| *m > kernel_half_px as isize),
            "patch {}: margins {margin:?} px, PSF half width {kernel_half_px} px",
            reg.patch
        );
    }

    // Raw (always rounded by the ADC): each region reads round(analytic).
    let frame = sensor
        .with_noise(NoiseSwitches::none())
        .compute(&irradiance, &Capture::seconds(t_s))
        .unwrap();
    let raw = &frame.raw[0];
    let check_raw = |raw: &RawImage, what: &str| {
        let stats = chart_patch_stats_raw(raw, &corners, 0.5).unwrap();
        let mut worst_dn: f64 = 0.0;
        for (s, a) in stats.iter().zip(&analytic_dn) {
            for c in 0..3 {
                let expect = a[c] - black;
                let err = (s.mean[c] - expect).abs();
                worst_dn = worst_dn.max(err);
                assert!(
                    err <= 0.5 + 1e-5 * expect,
                    "{what}: patch {} ({}) channel {c}: mean {} DN vs analytic {expect} DN",
                    s.patch,
                    s.name,
                    s.mean[c]
                );
                assert_eq!(
                    s.std[c], 0.0,
                    "{what}: patch {} channel {c} is not uniform",
                    s.patch
                );
                assert!(s.n[c] > 100);
            }
        }
        println!("{what}: largest |mean - analytic| {worst_dn:.3} DN (rounding: <= 0.5 DN)");
    };
    check_raw(raw, "raw");

    // The same through a DNG file, as `camsim analyze chart` reads it.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("chart.dng");
    camsim_io::dng::write_dng(&path, raw, &camsim_io::dng::DngMetadata::default()).unwrap();
    let back = camsim_pipeline::load_raw(&path, &camsim_pipeline::MosaicFormat::default()).unwrap();
    check_raw(&back, "DNG");

    // Unrounded: quantization off, the ADC input over each region's pixels of each channel.
    let noq = sensor.with_noise(NoiseSwitches {
        quantization: false,
        ..NoiseSwitches::none()
    });
    let frame = noq.compute(&irradiance, &Capture::seconds(t_s)).unwrap();
    let analog = &frame.analog_dn.as_ref().unwrap()[0];
    let mut worst_rel: f64 = 0.0;
    for (reg, a) in regions.iter().zip(&analytic_dn) {
        let (mut sum, mut n) = ([0.0f64; 3], [0usize; 3]);
        for r in reg.rect.row..reg.rect.row_end() {
            for c in reg.rect.col..reg.rect.col_end() {
                let ch = sensor.cfa().channel_at(r, c).index();
                sum[ch] += analog[r * cols + c] as f64;
                n[ch] += 1;
            }
        }
        for c in 0..3 {
            let mean = sum[c] / n[c] as f64;
            let rel = (mean - a[c]).abs() / (a[c] - black);
            worst_rel = worst_rel.max(rel);
            assert!(
                rel < 0.005,
                "patch {} ({}) channel {c}: {mean} DN vs analytic {} DN",
                reg.patch,
                reg.name,
                a[c]
            );
        }
    }
    println!("unrounded: largest relative error {worst_rel:.2e}");
}
