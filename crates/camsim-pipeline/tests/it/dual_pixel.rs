//! Dual-pixel sensors through `simulate` (issue 42 item 5): each photodiode sees half of the
//! pupil, so a defocused edge's two images are displaced by the half discs' centroids, and the
//! disparity `camsim analyze dual-pixel` measures grows with defocus as thin-lens geometry says.
//!
//! Closed form: a point out of focus images through the whole pupil as a disc of diameter
//! c = A |v_sensor - v_object| / v_object (A = f / N; [`camsim_optics::lens::circle_of_confusion_m`]);
//! through half the pupil as a half disc, whose centroid lies 4 (c / 2) / (3 pi) from the
//! disc's centre (the centroid of a half disc of radius r is 4 r / (3 pi) from its diameter).
//! The PSF's centroid is the mean ray intercept over the open pupil in wave optics too (the
//! first moment of |FT P|^2 is the pupil-averaged wavefront slope), so the two photodiodes'
//! images are d = 4 c / (3 pi) apart, with opposite signs in front of and behind focus, and 0 in
//! focus. The Pixel 4a's sensor with its noise off and a 3-band grid keep the run small; the halves'
//! sum keeps the whole pupil's light (each half passes half of it).

use camsim_pipeline::measure::dual_pixel::{measure_dual_pixel, DualPixelRequest};
use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};
use std::path::Path;

const FOCUS_M: f64 = 0.5;
const PITCH_M: f64 = 1.4e-6;

fn config(distance_m: f64, dual: bool) -> SimulateConfig {
    let text = format!(
        r#"
seed = 5
[scene]
kind = "slanted_edge"
mean_luminance_cd_m2 = 200.0
fov_deg = 2.0
distance_m = {distance_m}
illuminant = "D65"
rows = 128
cols = 128
angle_deg = 3.0
bright_reflectance = 0.9
dark_reflectance = 0.1
wavelengths = {{ start_nm = 500.0, step_nm = 50.0, count = 3 }}
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
focus_distance_m = {FOCUS_M}
[sensor]
preset = "pixel4a"
rows = 64
cols = 64
[sensor.config]
dual_pixel = {dual}
[sensor.config.noise]
shot = false
read = false
dsnu = false
prnu = false
dark = false
[capture]
auto_target_fraction = 0.6
"#
    );
    SimulateConfig::from_toml_str(&text, Path::new(".")).unwrap()
}

#[test]
fn the_dual_pixel_disparity_grows_with_defocus_as_the_thin_lens_says() {
    let (f_m, n) = (4.38e-3, 1.73);
    let mut signs = Vec::new();
    for distance_m in [0.3, 0.5, 1.0] {
        let sim = simulate(
            &config(distance_m, true),
            &SimulateOptions::default(),
            &|_, _, _| {},
        )
        .unwrap();
        let d = sim
            .dual_pixel
            .as_ref()
            .expect("a dual-pixel run keeps both halves");
        assert_eq!((d.left.len(), d.right.len()), (1, 1));
        let report =
            measure_dual_pixel(&d.left[0], &d.right[0], &DualPixelRequest::default()).unwrap();
        let c_m = camsim_optics::lens::circle_of_confusion_m(f_m, n, FOCUS_M, distance_m).unwrap();
        let want_px = 4.0 * c_m / (3.0 * std::f64::consts::PI) / PITCH_M;
        println!(
            "object at {distance_m} m (focus {FOCUS_M} m): circle of confusion {:.2} um, disparity {:+.3} px (+- {:.3}; closed form {want_px:.3} px); per filter {:?}",
            c_m * 1e6,
            report.disparity_px,
            report.standard_error_px,
            report
                .filters
                .iter()
                .map(|f| format!("{} {:+.3}", f.filter, f.disparity_px))
                .collect::<Vec<_>>()
        );
        assert!(
            (report.disparity_px.abs() - want_px).abs() < 0.03 * want_px + 0.05,
            "disparity {} px, closed form {want_px} px",
            report.disparity_px
        );
        if want_px > 0.5 {
            signs.push(report.disparity_px.signum());
        }
        // The halves' sum is the whole pixel: the plain sensor's signal within the ADC's
        // rounding (the two halves are read and rounded apart).
        if distance_m == 1.0 {
            let plain = simulate(
                &config(distance_m, false),
                &SimulateOptions::default(),
                &|_, _, _| {},
            )
            .unwrap();
            let mean = |dn: &[u16]| dn.iter().map(|&v| v as f64).sum::<f64>() / dn.len() as f64;
            let (m_sum, m_plain) = (mean(&sim.frames[0].dn), mean(&plain.frames[0].dn));
            println!("mean DN: halves' sum {m_sum:.2}, plain pixel {m_plain:.2}");
            assert!((m_sum / m_plain - 1.0).abs() < 2e-3, "{m_sum} vs {m_plain}");
        }
    }
    // In front of and behind focus the halves swap sides.
    assert_eq!(signs.len(), 2);
    assert_eq!(signs[0], -signs[1], "{signs:?}");
}

#[test]
fn a_dual_pixel_sensor_is_refused_where_its_halves_cannot_be_imaged() {
    // The sensor stage alone gets one irradiance, which does not hold the halves apart.
    let cfg = config(1.0, true);
    let sensor = cfg.sensor().unwrap();
    let irradiance = camsim_core::SpectralImage::from_data(
        4,
        4,
        camsim_core::WavelengthGrid::new(500.0, 600.0, 100.0).unwrap(),
        1e-6,
        camsim_core::Quantity::Irradiance,
        vec![1.0; 32],
    )
    .unwrap();
    let req = cfg.capture_request().unwrap();
    let Err(e) = camsim_pipeline::capture::capture(&sensor, &irradiance, &req) else {
        panic!("a dual-pixel sensor was accepted by capture()");
    };
    let e = e.to_string();
    assert!(e.contains("dual_pixel"), "{e}");
    // With an [hdr] pixel.
    let mut c = cfg.sensor().unwrap().config().clone();
    c.hdr = camsim_sensor::Sensor::preset("imx490")
        .ok()
        .and_then(|s| s.config().hdr.clone());
    if c.hdr.is_some() {
        let Err(e) = camsim_sensor::Sensor::from_config(c) else {
            panic!("a dual-pixel sensor with an [hdr] pixel was accepted");
        };
        let e = e.to_string();
        assert!(e.contains("dual_pixel"), "{e}");
    }
}
