//! The `camsim` binary end to end: the default run, determinism across thread counts, and the
//! bad-input contract (exit code 2, a message naming the culprit, no partial output file).

use std::path::Path;
use std::process::{Command, Output};

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

/// Files left in a folder (temporary names included: none may remain after a failure).
fn files_in(dir: &Path) -> Vec<String> {
    match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    }
}

/// A small, fast simulate config (a 64 x 96 sensor window).
const SMALL: &str = include_str!("../small-chart.toml");

#[test]
fn simulate_writes_every_output_and_same_seed_gives_identical_dng_for_1_and_2_threads() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("small.toml");
    std::fs::write(&cfg, SMALL).unwrap();
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    let run = |out: &Path, threads: &str, seed: &str| {
        let o = camsim(&[
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--threads",
            threads,
            "--seed",
            seed,
            "--frames",
            "2",
            "--save",
            "all",
        ]);
        assert!(o.status.success(), "simulate failed: {}", stderr(&o));
    };
    run(&a, "1", "9");
    run(&b, "2", "9");
    run(&c, "2", "10");
    for f in [
        "radiance.exr",
        "irradiance.exr",
        "raw.dng",
        "raw_0001.dng",
        "raw.png",
        "preview.png",
        "run.json",
    ] {
        assert!(a.join(f).is_file(), "missing {f}");
    }
    let read = |p: &Path| std::fs::read(p).unwrap();
    assert_eq!(
        read(&a.join("raw.dng")),
        read(&b.join("raw.dng")),
        "1 and 2 threads must give the same DNG"
    );
    assert_eq!(read(&a.join("raw_0001.dng")), read(&b.join("raw_0001.dng")));
    assert_ne!(
        read(&a.join("raw.dng")),
        read(&c.join("raw.dng")),
        "another seed must give other noise"
    );
    assert_ne!(
        read(&a.join("raw.dng")),
        read(&a.join("raw_0001.dng")),
        "two frames must differ in temporal noise"
    );
    // The run can be repeated from its run.json.
    let d = dir.path().join("d");
    let o = camsim(&[
        "simulate",
        a.join("run.json").to_str().unwrap(),
        "--out",
        d.to_str().unwrap(),
        "--threads",
        "2",
        "--seed",
        "9",
        "--frames",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        read(&a.join("raw.dng")),
        read(&d.join("raw.dng")),
        "run.json must reproduce the run"
    );
}

#[test]
fn bad_input_exits_2_names_the_culprit_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "unknown key",
            SMALL.replace("seed = 5", "seed = 5\nexposre = 3"),
            "exposre",
        ),
        (
            "bits",
            SMALL.replace(
                "preset = \"pixel4a\"\nrows = 64",
                "file = \"bad_sensor.toml\"\nrows = 64",
            ),
            "bits",
        ),
        (
            "negative exposure",
            SMALL.replace("exposure_ms = 5.0", "exposure_ms = -1.0"),
            "exposure",
        ),
        (
            "fov",
            SMALL.replace("fov_deg = 2.0", "fov_deg = 0.0"),
            "fov",
        ),
        (
            "illuminant",
            SMALL.replace(
                "kind = \"macbeth\"",
                "kind = \"macbeth\"\nilluminant = \"D66\"",
            ),
            "D66",
        ),
    ];
    // A sensor file with 20-bit quantization (allowed: 1..16).
    let preset = String::from_utf8(camsim(&["presets", "sensor", "imx363"]).stdout).unwrap();
    assert!(
        preset.contains("bits = 12"),
        "the imx363 preset should have 12 bits"
    );
    std::fs::write(
        dir.path().join("bad_sensor.toml"),
        preset.replace("bits = 12", "bits = 20"),
    )
    .unwrap();
    for (what, text, needle) in cases {
        let cfg = dir.path().join("bad.toml");
        std::fs::write(&cfg, text).unwrap();
        let out = dir.path().join(format!("out-{}", what.replace(' ', "-")));
        let o = camsim(&[
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{what}: exit code, stderr: {}",
            stderr(&o)
        );
        assert!(
            stderr(&o).contains(needle),
            "{what}: message should name '{needle}': {}",
            stderr(&o)
        );
        assert!(
            files_in(&out).is_empty(),
            "{what}: left files {:?}",
            files_in(&out)
        );
    }
    // A missing file and a malformed EXR: exit 2, the file named, no output.
    let missing = camsim(&[
        "optics",
        "--in",
        "/nonexistent/radiance.exr",
        "--out",
        dir.path().join("x.exr").to_str().unwrap(),
    ]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(
        stderr(&missing).contains("/nonexistent/radiance.exr"),
        "{}",
        stderr(&missing)
    );
    let junk = dir.path().join("junk.exr");
    std::fs::write(&junk, b"this is not an OpenEXR file").unwrap();
    let out = dir.path().join("y");
    let o = camsim(&[
        "optics",
        "--in",
        junk.to_str().unwrap(),
        "--out",
        out.join("irr.exr").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("junk.exr"), "{}", stderr(&o));
    assert!(!out.join("irr.exr").exists());
    // A malformed DNG.
    let bad_dng = dir.path().join("bad.dng");
    std::fs::write(&bad_dng, b"II*\0\x08\0\0\0\xff\xff").unwrap();
    let o = camsim(&[
        "analyze",
        "sfr",
        bad_dng.to_str().unwrap(),
        "--out",
        dir.path().join("sfr").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad.dng"), "{}", stderr(&o));
    // Too big for memory: refused before allocating.
    let huge = SMALL.replace("rows = 64\ncols = 96", "rows = 2000000\ncols = 2000000");
    let cfg = dir.path().join("huge.toml");
    std::fs::write(&cfg, huge).unwrap();
    let o = camsim(&[
        "simulate",
        cfg.to_str().unwrap(),
        "--out",
        dir.path().join("huge").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn help_teaches_and_presets_print_toml() {
    let o = camsim(&["--help"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for cmd in [
        "simulate", "render", "optics", "sensor", "analyze", "validate", "Examples",
    ] {
        assert!(text.contains(cmd), "--help lacks {cmd}");
    }
    let o = camsim(&["presets", "sensor", "imx363"]);
    assert!(o.status.success());
    let toml_text = String::from_utf8_lossy(&o.stdout);
    // The paper's Table 1 values are in the preset.
    for v in ["0.4591", "1.4", "12"] {
        assert!(toml_text.contains(v), "imx363 preset lacks {v}");
    }
}
