//! The ISETCam sensor presets (issue 42) equal ISETCam's own sensor files.
//!
//! Two checks per preset: the preset's config equals what `read_isetcam_sensor` reads from the
//! file today (so a preset cannot drift from its source), and the values themselves against the
//! file's fields as ISETCam stores them (SI units; read off the file independently of camsim:
//! MT9V024 pixel 6 um, photodiode 5.3665631459994955 um square, so fill factor 0.8; AR0132AT
//! 3.751 um and 3.24846128959543 um, 0.75; conversion gain 1.1e-4 V/e-, swing 2.8 V, dark
//! voltage 1e-3 V/s, read noise 1e-3 V, no DSNU or PRNU, analog gain 1, offset 0; the CFA
//! patterns, column-major 1-based indices: RGB [2 3 1 2] of {r, g, b} = GRBG, RCCC [2 2 2 1] of
//! {r, w} = w w / w r, RGBW [1 3 2 4] of {r, g, b, w} = r g / b w). Then the sensor model's
//! closed forms with them: well capacity = swing / conversion gain, K = 2^bits / swing x
//! conversion gain (DN per electron), read noise in DN = 1 mV x 2^bits / swing.

use camsim_sensor::isetcam::{read_isetcam_sensor, ISETCAM_PRESETS};
use camsim_sensor::Sensor;
use std::path::Path;

const DATA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcam/sensor"
);

#[test]
fn every_isetcam_preset_equals_its_file() {
    for p in ISETCAM_PRESETS {
        let path = Path::new(DATA).join(p.file);
        if !path.is_file() {
            eprintln!("skipped: {} not found", path.display());
            continue;
        }
        let mut from_file = read_isetcam_sensor(&path, Some(p.bits), Some(p.source())).unwrap();
        from_file.qe.loaded_from = None;
        let preset = Sensor::preset(p.name).unwrap();
        assert_eq!(preset.config(), &from_file, "{}", p.name);
        assert!(preset.config().source.as_deref().unwrap().contains(p.file));
    }
}

#[test]
fn isetcam_presets_have_the_files_values_and_their_closed_forms() {
    let mt = [
        "mt9v024-mono",
        "mt9v024-rgb",
        "mt9v024-rccc",
        "mt9v024-rgbw",
    ];
    for p in ISETCAM_PRESETS {
        let s = Sensor::preset(p.name).unwrap();
        let c = s.config();
        let (pitch_um, pd_um, rows, cols, bits) = if mt.contains(&p.name) {
            (6.0, 5.366_563_145_999_496, 480, 752, 10)
        } else {
            (3.751, 3.248_461_289_595_43, 960, 1280, 12)
        };
        let rel = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-12;
        assert!(
            rel(c.pixel_pitch_um, pitch_um),
            "{} pitch {}",
            p.name,
            c.pixel_pitch_um
        );
        assert!(
            rel(c.fill_factor, (pd_um / pitch_um).powi(2)),
            "{} fill factor {}",
            p.name,
            c.fill_factor
        );
        assert_eq!((c.rows, c.cols, c.bits), (rows, cols, bits), "{}", p.name);
        assert!(rel(c.conversion_gain_uv_per_e, 110.0));
        assert_eq!(c.voltage_swing_v, 2.8);
        assert!(rel(c.dark_voltage_mv_per_s, 1.0));
        assert!(rel(c.read_noise_mv, 1.0));
        assert_eq!((c.dsnu_mv, c.prnu_percent), (0.0, 0.0));
        assert_eq!((c.analog_gain, c.analog_offset_mv), (1.0, 0.0));
        // Closed forms of the sensor model with these values.
        assert!(
            rel(s.well_capacity_e(), 2.8 / 110e-6),
            "{}",
            s.well_capacity_e()
        );
        let k = (1u32 << bits) as f64 / 2.8 * 110e-6;
        assert!(rel(s.k_dn_per_e(), k), "{} K {}", p.name, s.k_dn_per_e());
        let read_dn = s.predicted_noise_dn(0.0, 0.0).read;
        assert!(
            rel(read_dn, 1e-3 * (1u32 << bits) as f64 / 2.8),
            "{read_dn}"
        );
    }
    let layout = |n: &str| Sensor::preset(n).unwrap().cfa_layout().name();
    assert_eq!(layout("mt9v024-mono"), "w");
    assert_eq!(layout("mt9v024-rgb"), "GRBG");
    assert_eq!(layout("ar0132at-rgb"), "GRBG");
    assert_eq!(layout("mt9v024-rccc"), "w w/w r");
    assert_eq!(layout("ar0132at-rccc"), "w w/w r");
    assert_eq!(layout("mt9v024-rgbw"), "r g/b w");
    // Curves: the first sample (400 nm) of each filter as the file stores it.
    let first = |n: &str, f: &str| {
        let s = Sensor::preset(n).unwrap();
        let c = s.config();
        match f {
            "r" => c.qe.r[0],
            _ => c.filter_curve(f).unwrap()[0],
        }
    };
    assert_eq!(first("mt9v024-mono", "w"), 0.3731527606244924);
    assert_eq!(first("mt9v024-rccc", "r"), 0.07289645317325538);
    assert_eq!(first("ar0132at-rccc", "r"), 0.12048324911844677);
    assert_eq!(first("mt9v024-rgb", "r"), 0.08402265001287663);
    let mono = Sensor::preset("mt9v024-mono").unwrap();
    let q = &mono.config().qe;
    assert_eq!(q.wavelengths_nm.len(), 39);
    assert_eq!((q.wavelengths_nm[0], q.wavelengths_nm[38]), (400.0, 780.0));
    assert!(q.r.is_empty() && q.g.is_empty() && q.b.is_empty());
}

#[test]
fn a_file_that_is_not_an_isetcam_sensor_is_an_error_naming_it() {
    let colorfilters = Path::new(DATA).join("../colorfilters/CMYG.mat");
    if !colorfilters.is_file() {
        return;
    }
    let e = read_isetcam_sensor(&colorfilters, Some(10), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("CMYG.mat") && e.contains("no 'sensor' variable"),
        "{e}"
    );
    let e = read_isetcam_sensor(&Path::new(DATA).join("MT9V024SensorRCCC.mat"), None, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("quantization.bits"), "{e}");
}
