//! The `camsim` binary: output folders that always hold one complete run (re-runs, failures half
//! way, SIGINT), never writing through a node that is not a regular file, sensor windows, QE from
//! files, config error positions, the viewable raw.png, and help texts that say what they do.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .arg("--quiet")
        .output()
        .expect("camsim runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// Entries with a temporary's name (`.tmp`, `.old-`) anywhere below `dir`.
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if n.contains(".camsim-tmp-")
                || n.contains(".camsim-old-")
                || n.ends_with(".camsim-lock")
            {
                out.push(e.path());
            }
            if e.file_type().map(|t| t.is_dir()).unwrap_or(false) {
                stack.push(e.path());
            }
        }
    }
    out
}

/// A small, fast simulate config (a 64 x 96 window of the pixel4a sensor).
fn small(seed: u64, luminance: f64) -> String {
    format!(
        r#"
seed = {seed}
[scene]
kind = "macbeth"
mean_luminance_cd_m2 = {luminance}
fov_deg = 2.0
patch_size_px = 12
border_px = 2
[sensor]
preset = "pixel4a"
rows = 64
cols = 96
[capture]
exposure_ms = 5.0
"#
    )
}

fn write(path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).unwrap();
    path.to_path_buf()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn seed_of(run_json: &Path) -> u64 {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(run_json).unwrap()).unwrap();
    v["config"]["seed"].as_u64().unwrap()
}

#[test]
fn rerun_replaces_the_earlier_run_as_a_whole_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(&dir.path().join("small.toml"), &small(11, 100.0));
    let out = dir.path().join("run");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out), "--frames", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("raw_0001.dng").is_file());
    // Without --quiet: the note about the replaced run is one `--quiet` hides.
    let o = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(["simulate", s(&cfg), "--out", s(&out), "--seed", "13"])
        .output()
        .expect("camsim runs");
    assert!(o.status.success(), "{}", stderr(&o));
    // One run: the second frame of the seed-11 run must not survive beside the seed-13 run.
    assert!(
        !out.join("raw_0001.dng").exists(),
        "stale frame left: {:?}",
        entries(&out)
    );
    assert_eq!(seed_of(&out.join("run.json")), 13);
    let e = stderr(&o);
    assert!(
        e.contains("earlier run") && e.contains("raw_0001.dng") && e.contains("replaced"),
        "{e}"
    );
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
}

#[test]
fn a_rerun_that_fails_half_way_leaves_the_earlier_run_intact() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(&dir.path().join("small.toml"), &small(11, 100.0));
    let out = dir.path().join("run");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before: Vec<(String, Vec<u8>)> = entries(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    // Another scene (200 cd/m^2, so another radiance.exr) and a sensor whose blue filter passes
    // nothing: the scene and optics run (their files are written), then the colour pipeline
    // fails ("every channel must see light") before the raw files.
    let bad = small(13, 200.0).replace(
        "[sensor]\npreset = \"pixel4a\"\nrows = 64\ncols = 96\n",
        r#"[sensor.config]
name = "no blue"
rows = 64
cols = 96
pixel_pitch_um = 1.4
fill_factor = 1.0
cfa = "RGGB"
conversion_gain_uv_per_e = 76.5
voltage_swing_v = 0.4591
bits = 12
[sensor.config.qe]
wavelengths_nm = [300.0, 1100.0]
r = [1.0, 1.0]
g = [1.0, 1.0]
b = [0.0, 0.0]
"#,
    );
    let bad = write(&dir.path().join("bad.toml"), &bad);
    let o = camsim(&["simulate", s(&bad), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("every channel must see light"),
        "{}",
        stderr(&o)
    );
    let after: Vec<(String, Vec<u8>)> = entries(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    assert_eq!(before.len(), after.len(), "{:?}", entries(&out));
    for ((n, a), (m, b)) in before.iter().zip(&after) {
        assert_eq!(n, m);
        assert!(a == b, "{n} changed by the failed run");
    }
    assert_eq!(seed_of(&out.join("run.json")), 11);
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
}

#[cfg(unix)]
#[test]
fn sigint_removes_every_temporary_and_keeps_the_earlier_run() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(&dir.path().join("small.toml"), &small(11, 100.0));
    let out = dir.path().join("run");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out), "--save", "all"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A run long enough to be interrupted: a 480 x 640 window, 80 frames.
    let slow = small(13, 100.0)
        .replace("rows = 64\ncols = 96", "rows = 480\ncols = 640")
        .replace("fov_deg = 2.0", "fov_deg = 10.0");
    let slow = write(&dir.path().join("slow.toml"), &slow);
    let mut child = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "simulate",
            s(&slow),
            "--out",
            s(&out),
            "--frames",
            "80",
            "--quiet",
            "--save",
            "all",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let staging = dir.path().join(format!("run.camsim-tmp-{}", child.id()));
    let t0 = Instant::now();
    while !staging.exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the staging folder {} never appeared",
            staging.display()
        );
        if let Some(st) = child.try_wait().unwrap() {
            panic!("camsim ended ({st}) before its staging folder was seen");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    // Let it write a file or two into the staging folder, then interrupt.
    std::thread::sleep(Duration::from_millis(150));
    let k = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(k.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(
        temporaries(dir.path()).is_empty(),
        "left behind: {:?}",
        temporaries(dir.path())
    );
    assert_eq!(
        seed_of(&out.join("run.json")),
        11,
        "the earlier run must stay"
    );
    assert!(out.join("raw.dng").is_file() && out.join("radiance.exr").is_file());
}

#[cfg(unix)]
#[test]
fn nodes_that_are_not_regular_files_are_refused_and_untouched() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("radiance.exr");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let is_fifo = |p: &Path| std::fs::symlink_metadata(p).unwrap().file_type().is_fifo();
    // A single output file.
    let o = camsim(&["scene", "--kind", "uniform", "--out", s(&fifo)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("radiance.exr") && stderr(&o).contains("FIFO"),
        "{}",
        stderr(&o)
    );
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    // An output folder.
    let cfg = write(&dir.path().join("small.toml"), &small(1, 100.0));
    let o = camsim(&["simulate", s(&cfg), "--out", s(&fifo)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("FIFO"), "{}", stderr(&o));
    assert!(is_fifo(&fifo));
    // A folder with foreign content is not an output folder camsim may replace.
    let src = dir.path().join("src");
    std::fs::create_dir(&src).unwrap();
    std::fs::write(src.join("notes.md"), "mine").unwrap();
    let o = camsim(&["simulate", s(&cfg), "--out", s(&src)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(src.join("notes.md")).unwrap(),
        "mine"
    );
    assert_eq!(
        entries(dir.path()),
        vec!["radiance.exr", "small.toml", "src"]
    );
}

#[test]
fn a_sensor_window_larger_than_the_sensor_is_refused_with_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = small(1, 100.0).replace("rows = 64\ncols = 96", "rows = 5000\ncols = 6000");
    let cfg = write(&dir.path().join("big.toml"), &cfg);
    let out = dir.path().join("out");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("3024 x 4032"), "{}", stderr(&o));
    assert!(!out.exists());
    assert!(temporaries(dir.path()).is_empty());
    let o = camsim(&[
        "sensor",
        "--in",
        "/nonexistent.exr",
        "--sensor",
        "pixel4a",
        "--rows",
        "100",
        "--cols",
        "6000",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("3024 x 4032") && stderr(&o).contains("cols"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn qe_from_a_csv_file_and_no_silent_paper_correction() {
    let dir = tempfile::tempdir().unwrap();
    // Gaussian filters, written as text with 4 decimals.
    let mut csv = String::from("# test filters\nwavelength_nm,b,g,r\n");
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let gauss = |w: f64, c: f64| {
        format!(
            "{:.4}",
            0.8 * (-(w - c).powi(2) / (2.0 * 40.0f64.powi(2))).exp()
        )
    };
    for w in &wl {
        csv.push_str(&format!(
            "{w},{},{},{}\n",
            gauss(*w, 450.0),
            gauss(*w, 540.0),
            gauss(*w, 610.0)
        ));
    }
    write(&dir.path().join("qe.csv"), &csv);
    // The pixel4a template with its [qe] table replaced by the file.
    let preset = stdout(&camsim(&["presets", "sensor", "pixel4a"]));
    assert!(
        preset.contains("M belongs to this [qe] table"),
        "the template must say what happens to M"
    );
    let head = &preset[..preset.find("\n[qe]\n").expect("a [qe] table")];
    write(
        &dir.path().join("mine.toml"),
        &format!("{head}\n[qe]\nfile = \"qe.csv\"\n"),
    );
    let cfg = small(1, 100.0).replace("preset = \"pixel4a\"", "file = \"mine.toml\"");
    let cfg = write(&dir.path().join("sim.toml"), &cfg);
    let out = dir.path().join("out");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    let sensor = &run["sensor"];
    assert!(
        sensor.get("qe_correction").is_none_or(|m| m.is_null()),
        "the paper's M was kept: {}",
        sensor["qe_correction"]
    );
    assert!(sensor["qe"]["loaded_from"]
        .as_str()
        .unwrap()
        .ends_with("qe.csv"));
    // Columns by name, not by position: r is the 610 nm filter.
    let r: Vec<f64> = serde_json::from_value(sensor["qe"]["r"].clone()).unwrap();
    let want: Vec<f64> = wl
        .iter()
        .map(|w| gauss(*w, 610.0).parse().unwrap())
        .collect();
    assert_eq!(r, want);
    // A file without a 'g' column is an error naming the file and the columns it has.
    write(
        &dir.path().join("qe.csv"),
        "wavelength_nm,r,b\n400,1,1\n700,1,1\n",
    );
    let o = camsim(&["simulate", s(&cfg), "--out", s(&dir.path().join("out2"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("qe.csv") && stderr(&o).contains("'g'"),
        "{}",
        stderr(&o)
    );
}

/// The line and column in toml's message.
fn line_col(msg: &str) -> Option<(usize, usize)> {
    let i = msg.find("line ")?;
    let rest = &msg[i + 5..];
    let line = rest.split(',').next()?.trim().parse().ok()?;
    let j = rest.find("column ")?;
    let col = rest[j + 7..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()?;
    Some((line, col))
}

#[test]
fn config_errors_point_at_the_offending_key() {
    let dir = tempfile::tempdir().unwrap();
    // small() starts with a blank line: seed is on line 2, [scene] on 3, patch_size_px on 7.
    let text = small(1, 100.0).replace("patch_size_px = 12", "patch_size_px = \"big\"");
    assert_eq!(
        text.lines().position(|l| l.starts_with("patch_size_px")),
        Some(6)
    );
    let cfg = write(&dir.path().join("a.toml"), &text);
    let o = camsim(&["simulate", s(&cfg), "--out", s(&dir.path().join("o"))]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(line_col(&stderr(&o)), Some((7, 17)), "{}", stderr(&o));
    // An unknown key inside [scene] (line 5), not the table header (line 3).
    let text = small(1, 100.0).replace("fov_deg = 2.0", "fov_dgr = 2.0");
    let cfg = write(&dir.path().join("b.toml"), &text);
    let o = camsim(&["simulate", s(&cfg), "--out", s(&dir.path().join("o"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("fov_dgr"), "{}", stderr(&o));
    assert_eq!(line_col(&stderr(&o)), Some((6, 1)), "{}", stderr(&o));
    // A scene file on its own.
    let scene = write(
        &dir.path().join("scene.toml"),
        "kind = \"uniform\"\nrows = 8\ncols = \"wide\"\n",
    );
    let o = camsim(&["scene", s(&scene), "--out", s(&dir.path().join("r.exr"))]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(line_col(&stderr(&o)), Some((3, 8)), "{}", stderr(&o));
}

#[test]
fn raw_png_spans_the_16_bit_range_and_the_dng_keeps_the_exact_values() {
    let dir = tempfile::tempdir().unwrap();
    // Bright enough that the white patch clips at the 12-bit maximum 4095.
    let cfg = write(
        &dir.path().join("small.toml"),
        &small(1, 100.0).replace("exposure_ms = 5.0", "exposure_ms = 40.0"),
    );
    let out = dir.path().join("out");
    let o = camsim(&["simulate", s(&cfg), "--out", s(&out), "--save", "all"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (raw, _) = camsim_io::dng::read_dng(&out.join("raw.dng")).unwrap();
    assert_eq!(raw.bits, 12);
    let (rows, cols, png) = camsim_io::raster::read_mosaic_16(&out.join("raw.png")).unwrap();
    assert_eq!((rows, cols), (raw.rows, raw.cols));
    assert_eq!(
        raw.dn.iter().max(),
        Some(&4095),
        "the test needs a clipped patch"
    );
    assert_eq!(png.iter().max(), Some(&65535), "full scale must be 65535");
    for (p, d) in png.iter().zip(&raw.dn) {
        // round(d x 65535 / 4095), computed here independently in integers.
        let want = ((*d as u64 * 65535 * 2 + 4095) / (2 * 4095)) as u16;
        assert_eq!(*p, want, "DN {d}");
    }
    let run: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["files"]["raw.png"]["adc_bits"], 12);
    assert!(run["files"]["raw.png"]["scale"]
        .as_str()
        .unwrap()
        .contains("65535 / 4095"));
}

#[test]
fn help_describes_every_command_option_and_the_compare_config() {
    let top = stdout(&camsim(&["--help"]));
    for line in top
        .lines()
        .filter(|l| l.trim_start().starts_with("analyze") || l.trim_start().starts_with("fit "))
    {
        assert!(
            line.split_whitespace().count() > 1,
            "no description: {line:?}"
        );
    }
    assert!(top.contains("  analyze") && top.contains("  fit"), "{top}");
    let quiet = top
        .lines()
        .skip_while(|l| !l.contains("--quiet"))
        .take(3)
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        quiet.contains("progress bars") && quiet.contains("notes"),
        "{quiet}"
    );
    for cmd in ["simulate", "sensor"] {
        let h = stdout(&camsim(&[cmd, "--help"]));
        let out = h
            .lines()
            .skip_while(|l| !l.contains("--out <OUT>"))
            .take(2)
            .collect::<Vec<_>>()
            .join(" ");
        assert!(out.contains("Output folder"), "{cmd} --out: {out:?}");
    }
    let h = stdout(&camsim(&["validate", "compare", "--help"]));
    for key in [
        "simulated",
        "measured",
        "sensor",
        "exposure_s",
        "[[region]]",
        "name",
    ] {
        assert!(h.contains(key), "validate compare --help lacks {key}");
    }
}
