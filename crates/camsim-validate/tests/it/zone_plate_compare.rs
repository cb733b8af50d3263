//! The zone-plate MTF of `camsim compare` (`compare_cameras`): a camera compared with itself gives
//! identical curves, a defocused lens transfers less modulation at mid frequencies, and the
//! zone-plate and slanted-edge MTFs of one camera agree at mid frequencies within the difference
//! their methods explain (orientation average vs a near-vertical edge, demosaic aliasing).

use camsim_validate::{compare_cameras, CameraCompareOptions, CameraSpec};

/// Mean of `mtf` over the annuli with frequency in [lo, hi] cycles/pixel.
fn band_mean(freq: &[f64], mtf: &[f64], lo: f64, hi: f64) -> f64 {
    let v: Vec<f64> = freq
        .iter()
        .zip(mtf)
        .filter(|(f, _)| **f >= lo && **f <= hi)
        .map(|(_, m)| *m)
        .collect();
    assert!(!v.is_empty(), "no annulus in [{lo}, {hi}]");
    v.iter().sum::<f64>() / v.len() as f64
}

/// Linear interpolation of a curve at `f`.
fn at(freq: &[f64], mtf: &[f64], f: f64) -> f64 {
    let i = freq.iter().position(|x| *x >= f).unwrap();
    if i == 0 {
        return mtf[0];
    }
    let t = (f - freq[i - 1]) / (freq[i] - freq[i - 1]);
    mtf[i - 1] + t * (mtf[i] - mtf[i - 1])
}

#[test]
fn zone_plate_mtf_self_defocus_and_agreement_with_the_edge() {
    let dir = tempfile::tempdir().unwrap();
    // The pixel4a lens focused at 0.15 m instead of on the charts (1-1.2 m): a large defocus.
    let mut lens = camsim_optics::OpticsConfig::preset("pixel4a").unwrap();
    lens.focus_distance_m = Some(0.15);
    let blurry = dir.path().join("blurry.toml");
    std::fs::write(&blurry, toml::to_string(&lens).unwrap()).unwrap();

    let mut o = CameraCompareOptions::new(
        CameraSpec::new("pixel4a", "pixel4a"),
        CameraSpec::new("pixel4a", "pixel4a"),
    );
    o.size_px = 96;
    let same = compare_cameras(&o, &|_, _, _| {}).unwrap();
    assert_eq!(same.a.zone_plate.mtf, same.b.zone_plate.mtf);
    assert_eq!(
        same.a.zone_plate.freq_cy_per_px,
        same.b.zone_plate.freq_cy_per_px
    );
    let zp = &same.a.zone_plate;
    let edge = &same.a.mtf;
    for (f, m) in zp.freq_cy_per_px.iter().zip(&zp.mtf) {
        eprintln!(
            "f {f:.3} cy/px: zone plate {m:.3}, edge {:.3}",
            at(&edge.freq_cy_per_px, &edge.mtf, *f)
        );
    }
    // Below ~0.08 cycles/pixel an annulus holds less than a few cycles' worth of pixels (radius
    // f N k^2 = 2 ... 8 pixels), so only the mid band is compared.
    // Mid frequencies: the zone plate averages all orientations, the edge measures one (5 degrees
    // off vertical); the bilinear demosaic's aliasing differs between them.
    let mut worst: f64 = 0.0;
    for f in [0.1, 0.15, 0.2, 0.25] {
        let d = at(&zp.freq_cy_per_px, &zp.mtf, f) - at(&edge.freq_cy_per_px, &edge.mtf, f);
        worst = worst.max(d.abs());
    }
    eprintln!("zone plate vs slanted edge, 0.1-0.25 cy/px: largest difference {worst:.3}");
    assert!(
        worst < 0.06,
        "zone-plate and edge MTF differ by {worst:.3} at mid frequencies"
    );

    o.b = CameraSpec::new("pixel4a", blurry.to_string_lossy());
    o.out_dir = Some(dir.path().join("report"));
    let r = compare_cameras(&o, &|_, _, _| {}).unwrap();
    let sharp = band_mean(
        &r.a.zone_plate.freq_cy_per_px,
        &r.a.zone_plate.mtf,
        0.1,
        0.3,
    );
    let soft = band_mean(
        &r.b.zone_plate.freq_cy_per_px,
        &r.b.zone_plate.mtf,
        0.1,
        0.3,
    );
    eprintln!("zone-plate MTF 0.1-0.3 cy/px: in focus {sharp:.3}, focused at 0.15 m {soft:.3}");
    assert!(soft < 0.7 * sharp, "defocus: {soft:.3} vs {sharp:.3}");
    assert!(dir.path().join("report/compare_zone_plate.png").is_file());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("report/results.json")).unwrap())
            .unwrap();
    assert_eq!(
        json["b"]["zone_plate"]["mtf"].as_array().map(|v| v.len()),
        Some(r.b.zone_plate.mtf.len())
    );
}
