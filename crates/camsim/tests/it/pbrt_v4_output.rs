//! pbrt-v4's own spectral renders as camsim's input (`[scene] kind = "file"`): pbrt-v4's files
//! (`../shared/scenes/references/*.exr`, pbrt-v4's `Film "spectral"` output, stored at half the
//! render's width with pbrt-v4's header attributes) are recognised and converted from pbrt-v4's
//! units to W/(sr m^2 nm). Independent check: the Cornell box's ceiling light, `"rgb L" [17 12
//! 4]` with pbrt-v4's photometric normalisation (a light of `scale` 1 has a luminance of 1 nit
//! per unit of the RGB's Rec. 709 luminance), has the luminance 0.2126 x 17 + 0.7152 x 12 +
//! 0.0722 x 4 = 12.48 cd/m^2 where the reference sees it.

use camsim_core::colorimetry::luminance_cd_m2;
use std::path::{Path, PathBuf};

const REFS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/scenes/references"
);

fn references() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(REFS)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    v.sort();
    v
}

#[test]
fn pbrt_v4_references_read_in_camsim_units() {
    let files = references();
    assert!(files.len() >= 30, "{} references", files.len());
    for f in &files {
        let (img, info) = camsim_io::exr::read_spectral_exr_with_info(f).unwrap();
        assert!(
            info.pbrt_v4_units_converted,
            "{} not recognised",
            f.display()
        );
        // These copies carry no camera matrices: the field of view must come from the user.
        assert!(!info.fov_from_pbrt_v4_camera && img.geometry.fov_deg == 0.0);
        assert_eq!(img.bands(), 31, "{}", f.display());
        assert!((img.grid.start_nm - 400.0).abs() < 1e-6 && (img.grid.step_nm - 10.0).abs() < 1e-6);
    }
    // The Cornell box's light: the brightest pixels (fully on the light's plateau).
    let (img, _) = camsim_io::exr::read_spectral_exr_with_info(Path::new(&format!(
        "{REFS}/cornell-box.seed1.exr"
    )))
    .unwrap();
    let lum: Vec<f64> = (0..img.pixels())
        .map(|i| {
            let s: Vec<f64> = (0..img.bands()).map(|b| img.band(b)[i] as f64).collect();
            luminance_cd_m2(&s, &img.grid)
        })
        .collect();
    let max = lum.iter().cloned().fold(0.0, f64::max);
    let plateau: Vec<f64> = lum.iter().cloned().filter(|v| *v > 0.98 * max).collect();
    let mean = plateau.iter().sum::<f64>() / plateau.len() as f64;
    let want = 0.2126 * 17.0 + 0.7152 * 12.0 + 0.0722 * 4.0;
    eprintln!(
        "cornell-box light: {mean:.3} cd/m^2 over {} pixels (want {want:.3})",
        plateau.len()
    );
    assert!(plateau.len() >= 4);
    assert!((mean / want - 1.0).abs() < 0.02, "{mean} vs {want}");
}

/// The whole camera simulation on pbrt-v4's render: auto-exposure lands where a camera would
/// expose the scene (the light at the 99th percentile), a thousand times longer than on the
/// same file read as W/(sr m^2 nm) (the failure this fixes: 0.08 ms on a pbrt-v4 kitchen).
#[test]
fn a_pbrt_v4_render_simulates_through_the_camera() {
    let run = |units: &str| {
        let cfg = camsim::SimulateConfig::from_toml_str(&format!(
            "seed = 2\n[scene]\nkind = \"file\"\npath = \"{REFS}/cornell-box.seed1.exr\"\nfov_deg = 19.5\nunits = \"{units}\"\n\
             [sensor]\npreset = \"pixel4a\"\nrows = 48\ncols = 48\n"
        ), std::path::Path::new(""))
        .unwrap();
        camsim::simulate(&cfg, &camsim::SimulateOptions::default(), &|_, _, _| {}).unwrap()
    };
    let auto = run("auto");
    let raw = run("absolute");
    let ratio = auto.exposure_s / raw.exposure_s;
    eprintln!(
        "auto-exposure: {:.3} ms (pbrt-v4 units converted), {:.6} ms (read as W/(sr m^2 nm)), ratio {ratio:.0}",
        auto.exposure_s * 1e3,
        raw.exposure_s * 1e3
    );
    // Exposure is inversely proportional to radiance: the ratio is the unit factor (the sensor
    // and optics are linear; the percentile pixel is the same).
    assert!((ratio / (683.0 * 106.856895) - 1.0).abs() < 0.01, "{ratio}");
    // A Cornell box lit at ~12 cd/m^2 on its light: milliseconds, not microseconds.
    assert!(auto.exposure_s > 1e-3, "{}", auto.exposure_s);
}
