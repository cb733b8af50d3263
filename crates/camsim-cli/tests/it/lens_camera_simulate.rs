//! `camsim simulate` of a pbrt-v4 scene whose camera is a lens (ISET3d `raytransfer`, pbrt-v4
//! `realistic`): the render is the sensor-plane irradiance behind that lens, so the optics stage
//! is skipped and the film is fitted to the sensor window. Checked against the pinhole camera
//! through the optics stage's camera equation on a uniform sky: E = pi T L / (1 + 4 N^2) there
//! (ISETCam `oiCalculateIrradiance`), E = Omega L behind the ray-transfer function, Omega its
//! on-axis projected solid angle (0.0661 sr, measured in the renderer's own tests against a
//! brute-force pass test over directions, 0.0663 sr).

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");
const LENS_DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/lens"
);

fn run(args: &[&str]) -> (i32, String) {
    let o = Command::new(BIN)
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Write `NAME.pbrt` (a uniform sky seen by `camera`) and `NAME.toml`, simulate, return run.json.
fn simulate(
    dir: &Path,
    name: &str,
    camera: &str,
    render_extra: &str,
    sensor_rows_cols: (usize, usize),
) -> Result<serde_json::Value, String> {
    let pbrt = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\n{camera}\nFilm \"rgb\" \"integer xresolution\" 64 \"integer yresolution\" 48 \"float diagonal\" 1\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
    );
    std::fs::write(dir.join(format!("{name}.pbrt")), pbrt).unwrap();
    // f/3.4106: pi / (1 + 4 N^2) = 0.0661 sr, the ray-transfer function's on-axis solid angle.
    let toml = format!(
        "seed = 1\n[render]\npbrt = \"{name}.pbrt\"\nsamples_per_pixel = 16\n{render_extra}\n\
         [optics.config]\nf_number = 3.4106\nfocal_length_mm = 4.38\n\
         [sensor]\npreset = \"pixel4a\"\nrows = {}\ncols = {}\n[capture]\nexposure_ms = 10\n",
        sensor_rows_cols.0, sensor_rows_cols.1
    );
    let cfg = dir.join(format!("{name}.toml"));
    std::fs::write(&cfg, toml).unwrap();
    let out = dir.join(format!("out-{name}"));
    let (code, stderr) = run(&[
        "simulate",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--save",
        "raw,radiance,irradiance",
    ]);
    if code != 0 {
        return Err(format!("exit {code}: {stderr}"));
    }
    let text = std::fs::read_to_string(out.join("run.json")).unwrap();
    assert!(
        !out.join("radiance.exr").exists() || name == "pinhole",
        "{name}: radiance.exr written for a lens camera"
    );
    Ok(serde_json::from_str(&text).unwrap())
}

fn electrons(v: &serde_json::Value) -> Vec<f64> {
    v["results"]["mean_electrons_rgb"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn a_ray_transfer_camera_images_a_uniform_sky_as_the_camera_equation_says() {
    let dir = tempfile::tempdir().unwrap();
    let rtf = format!("Camera \"raytransfer\" \"string lensfile\" \"{LENS_DIR}/pixel4a-rearcamera-ellipse-raytransfer.json\"");
    // A 640 x 480 window (0.56 mm half-diagonal) rendered at 160 x 120: 5.6 um film pixels.
    let res = "resolution = [160, 120]";
    let lens = simulate(dir.path(), "rtf", &rtf, res, (480, 640)).unwrap();
    let pinhole = simulate(
        dir.path(),
        "pinhole",
        "Camera \"perspective\" \"float fov\" 30",
        res,
        (480, 640),
    )
    .unwrap();
    assert_eq!(lens["results"]["lens_camera"], true);
    assert_eq!(pinhole["results"]["lens_camera"], false);
    assert!(
        lens["results"]["scene_mean_luminance_cd_m2"].is_null()
            && lens["results"]["radiance_size"].is_null()
    );
    let spacing = lens["results"]["irradiance_sample_spacing_um"]
        .as_f64()
        .unwrap();
    assert!(
        (spacing - 640.0 * 1.4 / 160.0).abs() < 1e-9,
        "film pixel {spacing} um"
    );
    // Same irradiance on the axis; over the window the RTF's relative illumination and the
    // optics stage's cos^4 shading differ slightly, and the autofocused film lies 16.6 um behind
    // the RTF's input plane, where the pass ellipse subtends 1.3 % less solid angle (measured
    // ratio 0.9915 to 0.9922 over r, g, b; 1.0036 to 1.0045 with the film on the input plane).
    for (c, (a, b)) in electrons(&lens).iter().zip(electrons(&pinhole)).enumerate() {
        eprintln!("channel {c}: ray transfer / pinhole electrons {:.4}", a / b);
        assert!(
            (a / b - 1.0).abs() < 0.02,
            "channel {c}: ray transfer {a} e-, pinhole through f/3.41 optics {b} e-"
        );
    }
    // Had the optics stage blurred and attenuated the lens's irradiance a second time, the ratio
    // would be 0.066.
}

#[test]
fn a_realistic_camera_simulates_and_bad_film_fits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let real = format!(
        "Camera \"realistic\" \"string lensfile\" \"{LENS_DIR}/dgauss.82deg.4.38mm.json\" \"float aperturediameter\" 1.2 \"float focusdistance\" 10"
    );
    let v = simulate(dir.path(), "real", &real, "", (48, 64)).unwrap();
    assert_eq!(v["results"]["lens_camera"], true);
    assert!(electrons(&v).iter().all(|e| *e > 0.0 && e.is_finite()));
    // A render whose aspect ratio is not the window's: exit 2, naming the key.
    let e = simulate(
        dir.path(),
        "aspect",
        &real,
        "resolution = [64, 64]",
        (48, 64),
    )
    .unwrap_err();
    assert!(
        e.starts_with("exit 2") && e.contains("render.resolution"),
        "{e}"
    );
    // The full Pixel 4a sensor's corner lies beyond the ray-transfer function's last field height.
    let rtf = format!("Camera \"raytransfer\" \"string lensfile\" \"{LENS_DIR}/pixel4a-rearcamera-ellipse-raytransfer.json\"");
    let e = simulate(
        dir.path(),
        "big",
        &rtf,
        "resolution = [400, 300]",
        (3024, 4032),
    )
    .unwrap_err();
    assert!(e.starts_with("exit 2") && e.contains("field height"), "{e}");
}
