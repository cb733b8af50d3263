//! No input makes camsim panic: every subcommand, fed malformed option values and malformed
//! files, exits 2 with a message (exit 1 is kept for internal errors, 101 would be a panic).
//!
//! The subcommands and their options are read from `--help` (the same walk as
//! `documented_commands.rs`), so a new subcommand or option is covered without editing this
//! file; only the valid base invocation of each subcommand is listed here (a test fails if a
//! subcommand has none). Every malformed value is tried on top of a valid, small invocation, so
//! the value reaches the command's own checks, not only clap's.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::Duration;

use crate::common;
use common::{command_tree, help, run_limited, subcommands, BIN};

/// Run camsim with a time limit; returns (exit code, stderr). `None` = killed at the limit.
fn camsim(args: &[String], limit: Duration) -> (Option<i32>, String) {
    let mut cmd = Command::new(BIN);
    cmd.args(args).arg("--quiet");
    let o = run_limited(cmd, limit);
    (o.code, o.stderr)
}

fn run_ok(args: &[&str]) -> Output {
    let o = Command::new(BIN)
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "fixture `camsim {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Options of a help text that take a value: `--name <VALUE>`.
fn value_options(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let t = line.trim_start();
        // `-q, --quiet`: the long form follows the short one.
        let t = if t.starts_with('-') && t.as_bytes().get(1) != Some(&b'-') {
            t.split_once(", ").map_or("", |(_, long)| long)
        } else {
            t
        };
        if let Some(rest) = t.strip_prefix("--") {
            let mut words = rest.split_whitespace();
            let name = words.next().unwrap_or("");
            if words.next().is_some_and(|w| w.starts_with('<')) && !out.contains(&name.to_string())
            {
                out.push(name.to_string());
            }
        }
    }
    out
}

/// The leaf subcommands (those that do the work), from the help walk.
fn leaves() -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = command_tree()
        .into_iter()
        .filter(|(_, text)| subcommands(text).is_empty())
        .map(|(p, _)| p)
        .collect();
    out.sort();
    out
}

struct Fixture {
    _dir: tempfile::TempDir,
    root: PathBuf,
}

const SMALL: &str = r#"
seed = 5
[scene]
kind = "macbeth"
fov_deg = 2.0
patch_size_px = 12
border_px = 2
[sensor]
preset = "pixel4a"
rows = 96
cols = 128
[capture]
exposure_ms = 5.0
"#;

const FLAT: &str = r#"
[scene]
kind = "uniform"
rows = 64
cols = 64
fov_deg = 4.0
[sensor]
preset = "pixel4a"
rows = 64
cols = 96
"#;

const EDGE: &str = r#"
[scene]
kind = "slanted_edge"
rows = 256
cols = 256
fov_deg = 2.5
[sensor]
preset = "pixel4a"
rows = 96
cols = 96
"#;

/// An ISO 18844 glare target (a black hole in a bright surround) for `analyze glare`.
const GLARE: &str = r#"
[scene]
kind = "glare_target"
rows = 96
cols = 96
hole_diameter_px = 24
fov_deg = 4.0
[sensor]
preset = "pixel4a"
rows = 96
cols = 96
"#;

/// A dataset of 3 tiny ColorChecker captures with a grid and a random draw.
const DATASET: &str = r#"
[dataset]
samples = 3
shard_size = 2
[base]
wavelengths = { start_nm = 400.0, step_nm = 20.0, count = 16 }
scene = { kind = "macbeth" }
sensor = { preset = "pixel4a", rows = 16, cols = 24 }
[[vary]]
key = "optics.config.f_number"
values = [2.0, 4.0]
[[vary]]
key = "capture.exposure_ms"
log_uniform = [1.0, 4.0]
"#;

/// Small inputs every subcommand can start from, made once with camsim itself.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        let p = |s: &str| root.join(s).to_string_lossy().into_owned();
        std::fs::write(root.join("small.toml"), SMALL).unwrap();
        std::fs::write(root.join("flat.toml"), FLAT).unwrap();
        std::fs::write(root.join("edge.toml"), EDGE).unwrap();
        std::fs::write(root.join("glare.toml"), GLARE).unwrap();
        std::fs::write(root.join("dataset.toml"), DATASET).unwrap();
        run_ok(&[
            "simulate",
            &p("small.toml"),
            "--out",
            &p("sim"),
            "--save",
            "all",
        ]);
        run_ok(&["simulate", &p("flat.toml"), "--out", &p("flat")]);
        run_ok(&["simulate", &p("edge.toml"), "--out", &p("edge")]);
        run_ok(&["simulate", &p("glare.toml"), "--out", &p("glare")]);
        // A dual-pixel capture (the example, 0.3 s): raw_left.dng and raw_right.dng.
        let dual = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/dual-pixel.toml"
        );
        run_ok(&["simulate", dual, "--out", &p("dual")]);
        run_ok(&[
            "sensor",
            "--emva-series",
            "--sensor",
            "imx363",
            "--rows",
            "32",
            "--cols",
            "32",
            "--levels",
            "6",
            "--frames-per-level",
            "2",
            "--out",
            &p("emva"),
        ]);
        // Chart means in the `fit qe` format: 24 patches under three lights.
        let mut csv = String::from("light,patch,r,g,b\n");
        for light in ["A", "F2", "D65"] {
            for patch in 1..=24 {
                let v = 40.0 + 10.0 * patch as f64;
                csv.push_str(&format!("{light},{patch},{},{},{}\n", v, 1.5 * v, 0.8 * v));
            }
        }
        std::fs::write(root.join("means.csv"), csv).unwrap();
        // A measured MTF in the `fit mtf` format: a Gaussian blur of sigma 2 um, in percent.
        let mut mtf = String::from("frequency_cy_per_mm,mtf_percent\n");
        for i in 1..=20 {
            let f = 12.5 * i as f64;
            let g = (-2.0 * std::f64::consts::PI.powi(2) * (2e-3 * f).powi(2)).exp();
            mtf.push_str(&format!("{f},{}\n", 100.0 * g));
        }
        std::fs::write(root.join("mtf.csv"), mtf).unwrap();
        Fixture { _dir: dir, root }
    })
}

/// A small valid invocation of each leaf subcommand (`{F}` = fixture folder, `{O}` = output).
fn base(path: &[String]) -> Option<Vec<&'static str>> {
    let p: Vec<&str> = path.iter().map(|s| s.as_str()).collect();
    Some(match p.as_slice() {
        ["simulate"] => vec!["simulate", "{F}/small.toml", "--out", "{O}"],
        ["scene"] => vec!["scene", "{F}/small.toml", "--out", "{O}/r.exr"],
        ["render"] => vec![
            "render",
            "--builtin",
            "cornell-box",
            "--resolution",
            "16x16",
            "--spp",
            "1",
            "--out",
            "{O}",
        ],
        ["optics"] => vec![
            "optics",
            "--in",
            "{F}/sim/radiance.exr",
            "--out",
            "{O}/i.exr",
        ],
        ["psf"] => vec!["psf", "--lens", "pixel4a", "--out", "{O}"],
        ["fit-shading"] => vec!["fit-shading", "{F}/flat/raw.dng", "--out", "{O}/s.toml"],
        ["sensor"] => vec![
            "sensor",
            "--in",
            "{F}/sim/irradiance.exr",
            "--exposure-ms",
            "5",
            "--out",
            "{O}",
        ],
        ["isp"] => vec!["isp", "--in", "{F}/sim/raw.dng", "--out", "{O}/p.png"],
        ["unprocess"] => vec![
            "unprocess",
            "--in",
            "{F}/sim/preview.png",
            "--out",
            "{O}/u.dng",
        ],
        ["presets"] => vec!["presets", "sensor", "imx363"],
        ["analyze", "sfr"] => vec!["analyze", "sfr", "{F}/edge/raw.dng", "--out", "{O}"],
        ["analyze", "chart"] => vec!["analyze", "chart", "{F}/sim/raw.dng", "--out", "{O}"],
        ["analyze", "roi"] => vec![
            "analyze",
            "roi",
            "{F}/sim/raw.dng",
            "--region",
            "8,8,16,16",
            "--out",
            "{O}",
        ],
        ["analyze", "demosaic"] => vec!["analyze", "demosaic", "--size", "64", "--out", "{O}"],
        ["analyze", "glare"] => vec!["analyze", "glare", "{F}/glare/raw.dng", "--out", "{O}"],
        ["analyze", "dual-pixel"] => vec![
            "analyze",
            "dual-pixel",
            "{F}/dual/raw_left.dng",
            "{F}/dual/raw_right.dng",
            "--out",
            "{O}",
        ],
        ["analyze", "visual-noise"] => vec![
            "analyze",
            "visual-noise",
            "{F}/sim/preview.png",
            "--out",
            "{O}",
        ],
        ["analyze", "emva"] => vec!["analyze", "emva", "{F}/emva/series.csv", "--out", "{O}"],
        ["fit", "qe"] => vec!["fit", "qe", "--measured", "{F}/means.csv", "--out", "{O}"],
        ["fit", "mtf"] => vec!["fit", "mtf", "--measured", "{F}/mtf.csv", "--out", "{O}"],
        ["validate"] => vec!["validate", "cornell-box", "--out", "{O}"],
        ["dataset"] => vec!["dataset", "{F}/dataset.toml", "--out", "{O}"],
        ["compare"] => vec!["compare", "--size", "64", "--out", "{O}"],
        _ => return None,
    })
}

fn expand(args: &[&str], f: &Path, o: &Path) -> Vec<String> {
    args.iter()
        .map(|a| {
            a.replace("{F}", &f.to_string_lossy())
                .replace("{O}", &o.to_string_lossy())
        })
        .collect()
}

fn is_internal_error(code: Option<i32>, stderr: &str) -> bool {
    !matches!(code, Some(0) | Some(2))
        || stderr.contains("panicked")
        || stderr.contains("internal error")
}

#[test]
fn malformed_option_values_exit_2_never_panic() {
    let f = fixture();
    let limit = Duration::from_secs(120);
    let mut failures = Vec::new();
    let mut tried = 0;
    for path in leaves() {
        let Some(args) = base(&path) else {
            failures.push(format!(
                "`camsim {}` has no base invocation in bad_input_cli.rs: add one",
                path.join(" ")
            ));
            continue;
        };
        let out = f.root.join(format!("out-{}", path.join("-")));
        // The base itself must succeed, or the malformed values below test nothing.
        let (code, err) = camsim(&expand(&args, &f.root, &out), limit);
        if code != Some(0) {
            failures.push(format!(
                "base `camsim {}` failed ({code:?}): {err}",
                args.join(" ")
            ));
            continue;
        }
        for opt in value_options(&help(&path)) {
            if opt == "out" {
                continue; // any string is a valid output path
            }
            for value in ["x", "nan", "-1", "1e999", ""] {
                let mut a = expand(&args, &f.root, &out);
                // Replace an option the base already gives, else add it.
                let flag = format!("--{opt}");
                if let Some(i) = a.iter().position(|s| *s == flag) {
                    a[i + 1] = value.to_string();
                } else {
                    a.push(flag.clone());
                    a.push(value.to_string());
                }
                tried += 1;
                let (code, err) = camsim(&a, limit);
                if is_internal_error(code, &err) {
                    failures.push(format!(
                        "`camsim {}` exited {code:?}: {}",
                        a.join(" "),
                        err.trim()
                    ));
                } else if code == Some(2) && err.trim().is_empty() {
                    failures.push(format!(
                        "`camsim {}` exited 2 without a message",
                        a.join(" ")
                    ));
                } else if code == Some(0)
                    && (value == "nan" || value == "1e999")
                    && !accepts_any_text(&opt)
                {
                    failures.push(format!(
                        "`camsim {}` accepted a non-finite value for --{opt}",
                        a.join(" ")
                    ));
                }
            }
        }
    }
    assert!(
        tried > 100,
        "only {tried} malformed invocations found: did the help format change?"
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Options whose value is free text (a name that can legitimately be "nan", a file that may be
/// created): a non-finite number is not refused there.
fn accepts_any_text(opt: &str) -> bool {
    matches!(opt, "out" | "json")
}

#[test]
fn malformed_files_exit_2_and_name_the_file() {
    let f = fixture();
    let limit = Duration::from_secs(120);
    let bad = f.root.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    // Each input slot of each command, with a valid file to truncate.
    let slots: Vec<(Vec<&str>, &str, &str)> = vec![
        (
            vec!["simulate", "{X}", "--out", "{O}"],
            "small.toml",
            "toml",
        ),
        (
            vec!["scene", "{X}", "--out", "{O}/r.exr"],
            "small.toml",
            "toml",
        ),
        (
            vec![
                "render",
                "{X}",
                "--resolution",
                "8x8",
                "--spp",
                "1",
                "--out",
                "{O}",
            ],
            "small.toml",
            "pbrt",
        ),
        (
            vec![
                "render",
                "--builtin",
                "cornell-box",
                "--overlay",
                "{X}",
                "--resolution",
                "8x8",
                "--spp",
                "1",
                "--out",
                "{O}",
            ],
            "small.toml",
            "toml",
        ),
        (
            vec!["optics", "--in", "{X}", "--out", "{O}/i.exr"],
            "sim/radiance.exr",
            "exr",
        ),
        (
            vec![
                "optics",
                "--in",
                "{F}/sim/radiance.exr",
                "--lens",
                "{X}",
                "--out",
                "{O}/i.exr",
            ],
            "small.toml",
            "toml",
        ),
        (
            vec!["psf", "--lens", "{X}", "--out", "{O}"],
            "small.toml",
            "toml",
        ),
        (
            vec!["fit-shading", "{X}", "--out", "{O}/s.toml"],
            "flat/raw.dng",
            "dng",
        ),
        (
            vec![
                "sensor",
                "--in",
                "{X}",
                "--exposure-ms",
                "5",
                "--out",
                "{O}",
            ],
            "sim/irradiance.exr",
            "exr",
        ),
        (
            vec![
                "sensor",
                "--in",
                "{F}/sim/irradiance.exr",
                "--sensor",
                "{X}",
                "--exposure-ms",
                "5",
                "--out",
                "{O}",
            ],
            "small.toml",
            "toml",
        ),
        (
            vec!["isp", "--in", "{X}", "--out", "{O}/p.png"],
            "sim/raw.dng",
            "dng",
        ),
        (
            vec!["analyze", "sfr", "{X}", "--out", "{O}"],
            "edge/raw.dng",
            "dng",
        ),
        (
            vec!["analyze", "sfr", "{X}", "--out", "{O}"],
            "sim/irradiance.exr",
            "exr",
        ),
        (
            vec!["analyze", "chart", "{X}", "--out", "{O}"],
            "sim/raw.dng",
            "dng",
        ),
        (
            vec![
                "analyze",
                "roi",
                "{X}",
                "--region",
                "8,8,16,16",
                "--out",
                "{O}",
            ],
            "sim/raw.dng",
            "dng",
        ),
        (
            vec!["analyze", "emva", "{X}", "--out", "{O}"],
            "emva/series.csv",
            "csv",
        ),
        (
            vec!["fit", "qe", "--measured", "{X}", "--out", "{O}"],
            "means.csv",
            "csv",
        ),
        (
            vec!["fit", "mtf", "--measured", "{X}", "--out", "{O}"],
            "mtf.csv",
            "csv",
        ),
        (
            vec!["validate", "compare", "{X}", "--out", "{O}"],
            "small.toml",
            "toml",
        ),
        (
            vec!["dataset", "{X}", "--out", "{O}"],
            "dataset.toml",
            "toml",
        ),
        (
            vec!["compare", "--size", "64", "--a", "{X}", "--out", "{O}"],
            "small.toml",
            "toml",
        ),
    ];
    let mut failures = Vec::new();
    for (i, (args, valid, ext)) in slots.iter().enumerate() {
        let whole = std::fs::read(f.root.join(valid)).unwrap();
        let cases: Vec<(&str, Option<Vec<u8>>)> = vec![
            ("missing", None),
            ("empty", Some(Vec::new())),
            (
                "junk",
                Some(b"\x00\xffnot a camsim file\n[[[ = \"".to_vec()),
            ),
            ("truncated", Some(whole[..whole.len() / 3].to_vec())),
            ("bitflipped", Some(flip_bits(&whole))),
        ];
        for (what, bytes) in cases {
            let file = bad.join(format!("{i}-{what}.{ext}"));
            if let Some(b) = &bytes {
                std::fs::write(&file, b).unwrap();
            }
            let out = bad.join(format!("out-{i}-{what}"));
            let a: Vec<String> = args
                .iter()
                .map(|s| {
                    s.replace("{X}", &file.to_string_lossy())
                        .replace("{F}", &f.root.to_string_lossy())
                        .replace("{O}", &out.to_string_lossy())
                })
                .collect();
            let (code, err) = camsim(&a, limit);
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            if is_internal_error(code, &err) {
                failures.push(format!(
                    "`camsim {}` ({what}) exited {code:?}: {}",
                    a.join(" "),
                    err.trim()
                ));
            } else if what == "bitflipped" || (what == "truncated" && *ext == "csv") {
                // A CSV cut at a line end, or a bit flip, may leave a valid (smaller) file.
                // When refused, the file must be named.
                if code == Some(2) && !err.contains(&name) {
                    failures.push(format!(
                        "`camsim {}` ({what}): message does not name the file: {}",
                        a.join(" "),
                        err.trim()
                    ));
                }
            } else if code != Some(2) {
                failures.push(format!(
                    "`camsim {}` ({what}) exited {code:?}, expected 2",
                    a.join(" ")
                ));
            } else if !err.contains(&name) {
                failures.push(format!(
                    "`camsim {}` ({what}): message does not name the file: {}",
                    a.join(" "),
                    err.trim()
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The file with a few bytes in the middle inverted (a damaged header or payload).
fn flip_bits(b: &[u8]) -> Vec<u8> {
    let mut v = b.to_vec();
    let n = v.len();
    for k in 1..8 {
        let i = n * k / 9;
        if i < n {
            v[i] ^= 0xa5;
        }
    }
    v
}

#[test]
fn option_parser_sees_every_value_option() {
    let text = "Options:\n      --in <INPUT>\n          Spectral\n  -q, --quiet  Hide\n      --json   Print\n      --out <OUT>  [default: x]\n";
    assert_eq!(value_options(text), vec!["in", "out"]);
}
