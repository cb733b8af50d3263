//! Pixel vignetting (`[pixel_vignetting]`): 1 on the axis, the closed-form aperture/photodetector
//! overlap for a collimated chief ray, monotone fall-off with the chief ray angle, and an optimal
//! microlens shift recentres the light.

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::pixel_vignetting::{MicrolensPlacement, PixelVignettingConfig};
use camsim_sensor::{Capture, Sensor};
use common::{config, quiet, uniform_image};

fn pv(f_number: f64, microlens: MicrolensPlacement) -> PixelVignettingConfig {
    PixelVignettingConfig {
        f_number,
        exit_pupil_distance_mm: 0.2,
        stack_height_um: 4.0,
        dielectric_index: 1.5,
        microlens,
    }
}

/// Closed form for a collimated beam at chief slope t: shift s = h tan(asin(sin(atan t) / n)),
/// overlap of the pitch-wide aperture shifted by s with the centred photodetector, over its value at 0.
fn closed_form(t: f64, pitch_um: f64, pd_um: f64, h_um: f64, n: f64) -> f64 {
    let s = h_um * ((t.atan().sin() / n).asin()).tan();
    let overlap = |s: f64| {
        ((pitch_um / 2.0 + s).min(pd_um / 2.0) - (-pitch_um / 2.0 + s).max(-pd_um / 2.0)).max(0.0)
    };
    overlap(s) / overlap(0.0)
}

#[test]
fn response_is_one_on_axis_and_follows_the_overlap_closed_form() {
    let (pitch_um, ff) = (2.0, 0.25); // photodetector 1 um wide
    let pd_um = pitch_um * f64::sqrt(ff);
    // Nearly collimated (f/2000): the closed form of one ray.
    let c = pv(2000.0, MicrolensPlacement::None);
    let (rows, cols) = (2, 101);
    let map = c.relative_response(rows, cols, pitch_um, ff);
    let mut last = 2.0f32;
    for (col, &got_f32) in map[..cols].iter().enumerate().skip(50) {
        let x_um = (col as f64 + 0.5 - cols as f64 / 2.0) * pitch_um;
        let t_x = x_um / 200.0;
        let t_y = (0.5 * pitch_um) / 200.0;
        let want = closed_form(t_x, pitch_um, pd_um, 4.0, 1.5)
            * closed_form(t_y, pitch_um, pd_um, 4.0, 1.5);
        let got = got_f32 as f64;
        assert!(
            (got - want).abs() < 2e-3,
            "col {col}: {got} vs closed form {want}"
        );
        assert!(got_f32 <= last + 1e-6, "not monotone at col {col}");
        last = got_f32;
    }
    // Centre pixel of an odd row count is on the axis: exactly 1.
    assert_eq!(c.relative_response(1, 1, pitch_um, ff)[0], 1.0);
    // The edge pixel (CRA atan(100 um / 200 um) = 26.6 deg) loses light: shift 4 tan(17.3 deg) =
    // 1.25 um > (2 - 1) / 2 = 0.5 um.
    assert!(map[cols - 1] < 0.5, "{}", map[cols - 1]);
}

#[test]
fn optimal_microlens_recentres_the_light() {
    let (pitch_um, ff) = (2.0, 0.25);
    let bare = pv(2.8, MicrolensPlacement::None).relative_response(1, 101, pitch_um, ff);
    let opt = pv(2.8, MicrolensPlacement::Optimal).relative_response(1, 101, pitch_um, ff);
    let collimated =
        pv(2000.0, MicrolensPlacement::Optimal).relative_response(1, 101, pitch_um, ff);
    // Collimated with the chief ray on the photodetector centre: every pixel gets everything.
    assert!(collimated.iter().all(|v| (v - 1.0).abs() < 1e-6));
    println!(
        "edge pixel: bare {:.3}, optimal microlens {:.3}",
        bare[100], opt[100]
    );
    assert!(
        bare[100] < 0.6 && opt[100] > 0.95,
        "bare {} optimal {}",
        bare[100],
        opt[100]
    );
}

#[test]
fn sensor_applies_the_map_and_rejects_bad_values() {
    let pvc = pv(2.0, MicrolensPlacement::None);
    let s = config("ideal", |c| {
        c.rows = 9;
        c.cols = 41;
        c.pixel_vignetting = Some(pvc);
    })
    .with_noise(quiet(true));
    let plain = config("ideal", |c| {
        c.rows = 9;
        c.cols = 41;
    })
    .with_noise(quiet(true));
    let grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    let img = uniform_image(9, 41, grid, s.pixel_pitch_m(), &vec![0.01; grid.len()]);
    let a = s.compute(&img, &Capture::seconds(0.01)).unwrap();
    let b = plain.compute(&img, &Capture::seconds(0.01)).unwrap();
    let map = pvc.relative_response(9, 41, s.pixel_pitch_m() * 1e6, s.fill_factor());
    let (va, vb) = (
        &a.analog_dn.as_ref().unwrap()[0],
        &b.analog_dn.as_ref().unwrap()[0],
    );
    for i in 0..va.len() {
        assert!((va[i] - vb[i] * map[i]).abs() <= 1e-4 * vb[i], "pixel {i}");
    }
    assert!(map[4 * 41 + 40] < map[4 * 41 + 20]);
    let mut bad = s.config().clone();
    bad.pixel_vignetting = Some(PixelVignettingConfig {
        dielectric_index: 0.5,
        ..pvc
    });
    let err = Sensor::from_config(bad).unwrap_err().to_string();
    assert!(err.contains("pixel_vignetting.dielectric_index"), "{err}");
    let toml = s.to_toml();
    assert!(toml.contains("[pixel_vignetting]"));
    assert_eq!(
        Sensor::from_toml_str(&toml, "round trip")
            .unwrap()
            .config()
            .pixel_vignetting,
        Some(pvc)
    );
}
