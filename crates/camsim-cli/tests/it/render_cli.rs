//! `camsim render` end to end: command-line settings win over the overlay, and render.json
//! reports the samples a time-budget render really took.

use std::path::Path;
use std::process::{Command, Output};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .arg("--quiet")
        .output()
        .expect("camsim runs")
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "camsim failed ({:?}): {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Width and height of a PNG from its IHDR chunk (PNG spec: 8-byte signature, chunk length and
/// type, then width and height as big-endian u32).
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[12..16], b"IHDR", "{} is not a PNG", path.display());
    (
        u32::from_be_bytes(b[16..20].try_into().unwrap()),
        u32::from_be_bytes(b[20..24].try_into().unwrap()),
    )
}

fn render_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("render.json")).unwrap()).unwrap()
}

#[test]
fn explicit_resolution_wins_over_the_overlay() {
    let dir = tempfile::tempdir().unwrap();
    let overlay = dir.path().join("res.toml");
    std::fs::write(&overlay, "[camera]\nresolution = [20, 10]\n").unwrap();
    let ov = overlay.to_str().unwrap();
    // The overlay's resolution applies when the command line gives none ...
    let a = dir.path().join("a");
    ok(&camsim(&[
        "render",
        "--builtin",
        "cornell-box",
        "--overlay",
        ov,
        "--spp",
        "1",
        "--max-depth",
        "1",
        "--out",
        a.to_str().unwrap(),
    ]));
    assert_eq!(png_size(&a.join("preview.png")), (20, 10));
    // ... and an explicit --resolution replaces it.
    let b = dir.path().join("b");
    ok(&camsim(&[
        "render",
        "--builtin",
        "cornell-box",
        "--overlay",
        ov,
        "--resolution",
        "12x6",
        "--spp",
        "1",
        "--max-depth",
        "1",
        "--out",
        b.to_str().unwrap(),
    ]));
    assert_eq!(png_size(&b.join("preview.png")), (12, 6));
    assert_eq!(render_json(&b)["resolution"], serde_json::json!([12, 6]));
}

#[test]
fn time_budget_render_reports_the_samples_it_took() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let asked = 100_000u64;
    let t0 = std::time::Instant::now();
    ok(&camsim(&[
        "render",
        "--builtin",
        "cornell-box",
        "--resolution",
        "8x8",
        "--spp",
        &asked.to_string(),
        "--time-budget-s",
        "0.001",
        "--out",
        out.to_str().unwrap(),
    ]));
    let j = render_json(&out);
    let taken = j["samples_per_pixel"].as_u64().unwrap();
    eprintln!(
        "asked {asked}, took {taken} samples per pixel in {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(j["samples_per_pixel_requested"].as_u64(), Some(asked));
    assert_eq!(j["time_budget_s"].as_f64(), Some(0.001));
    // Whole passes of 8 samples, far fewer than asked.
    assert!(
        taken >= 8 && taken.is_multiple_of(8) && taken < asked,
        "{taken}"
    );
    // The ray count agrees: one camera ray per sample and one depth ray per pixel.
    let pixels = 64;
    assert_eq!(
        j["stats"]["camera_rays"].as_u64(),
        Some(pixels * (taken + 1)),
        "{j}"
    );
}

#[test]
fn denoise_without_its_library_exits_2_naming_how_to_get_it_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("dn");
    let o = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "render",
            "--builtin",
            "cornell-box",
            "--resolution",
            "16x16",
            "--spp",
            "8",
            "--denoise",
        ])
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .env(
            "CAMSIM_OIDN_LIBRARY",
            dir.path().join("libOpenImageDenoise.so.1"),
        )
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("libOpenImageDenoise.so.1") && err.contains("pip install oidn"),
        "{err}"
    );
    assert!(!out.exists(), "a failed render left {}", out.display());
}

/// With the library (where `CAMSIM_OIDN_LIBRARY` names one; elsewhere this says so and passes):
/// render.json names it and the radiance differs from the unbiased render of the same seed.
#[test]
fn denoise_with_its_library_records_it() {
    let Some(lib) = std::env::var_os("CAMSIM_OIDN_LIBRARY").filter(|v| !v.is_empty()) else {
        eprintln!("skipped: set CAMSIM_OIDN_LIBRARY to an OIDN library to test --denoise");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render",
        "--builtin",
        "cornell-box",
        "--resolution",
        "24x24",
        "--spp",
        "8",
    ];
    let (plain, dn) = (dir.path().join("plain"), dir.path().join("dn"));
    ok(&camsim(
        &[&args[..], &["--out", plain.to_str().unwrap()]].concat(),
    ));
    ok(&camsim(
        &[&args[..], &["--denoise", "--out", dn.to_str().unwrap()]].concat(),
    ));
    let rec = render_json(&dn);
    assert_eq!(
        rec["denoised_with"].as_str(),
        Some(Path::new(&lib).to_str().unwrap())
    );
    assert!(render_json(&plain).get("denoised_with").is_none());
    assert_ne!(
        std::fs::read(plain.join("radiance.exr")).unwrap(),
        std::fs::read(dn.join("radiance.exr")).unwrap()
    );
}

/// `--obj-scale-m`, `--obj-up`, `--gltf-camera` reach the readers from the command line: the
/// framing camera frames the object whatever its unit, so a centimetre reading of wallhole.obj
/// has a hundredth of the metre reading's depths (same image otherwise); a camera the glTF file
/// lacks and an OBJ key on a pbrt-v4 file exit 2 naming them, writing nothing.
#[test]
fn asset_options_reach_the_readers() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    let wall = shared.join("assets/trimesh/wallhole.obj");
    let dir = tempfile::tempdir().unwrap();
    let depth = |name: &str, extra: &[&str]| -> f64 {
        let out = dir.path().join(name);
        let mut args = vec![
            "render",
            wall.to_str().unwrap(),
            "--resolution",
            "16x12",
            "--spp",
            "1",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        ok(&camsim(&args));
        let (_, _, z) =
            camsim::io::exr::read_gray_exr(&out.join("depth.exr"), None).expect("depth.exr");
        let hit: Vec<f64> = z
            .iter()
            .filter(|v| v.is_finite())
            .map(|v| *v as f64)
            .collect();
        assert!(!hit.is_empty(), "{name}: no surface seen");
        hit.iter().sum::<f64>() / hit.len() as f64
    };
    let m = depth("m", &[]);
    let cm = depth("cm", &["--obj-scale-m", "0.01", "--obj-up", "z"]);
    assert!(
        (cm / m).is_finite() && cm / m > 0.0,
        "depths {m} m and {cm} m"
    );
    let cm_y = depth("cm-y", &["--obj-scale-m", "0.01"]);
    assert!(
        (cm_y / m / 0.01 - 1.0).abs() < 1e-3,
        "{cm_y} m vs {m} m / 100"
    );
    let refused = |args: &[&str], says: &str| {
        let out = dir.path().join("refused");
        let mut a = args.to_vec();
        a.extend_from_slice(&["--out", out.to_str().unwrap()]);
        let o = camsim(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(says), "{err}");
        assert!(!out.exists(), "wrote {}", out.display());
    };
    let duck = shared.join("assets/trimesh/Duck.glb");
    refused(
        &[
            "render",
            duck.to_str().unwrap(),
            "--gltf-camera",
            "no-such-camera",
        ],
        "no-such-camera",
    );
    let pbrt = shared.join("scenes/bitterli/cornell-box/scene-v4.pbrt");
    refused(
        &["render", pbrt.to_str().unwrap(), "--obj-up", "z"],
        "render.asset",
    );
}
