//! The reliability promises of the README's "Output folders, determinism and bad input" section,
//! tested as stated, through the program a user runs (issue 25: each case below was a way to lose
//! a file, get different bytes, leave litter, panic, or exhaust memory):
//!
//! - a user's files are never replaced or deleted (folders by their marker, single files by
//!   camsim's signature, `--force` for the latter);
//! - one run at a time per output: a second run fails at once;
//! - a run killed with SIGKILL leaves temporaries that the next run into the same output removes,
//!   saying so, for `simulate`, `render` and `dataset`;
//! - the same bytes for any `--threads` and `--workers`;
//! - a closed stdout (`| head -1`) ends quietly;
//! - work that does not fit in memory is refused before it is allocated;
//! - bad values are refused naming the file, line or key.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

/// The program under test: this build, or another one named by `CAMSIM_TEST_BIN` (to show that
/// a test fails on a build without the fix it guards).
fn bin() -> String {
    std::env::var("CAMSIM_TEST_BIN").unwrap_or_else(|_| common::BIN.to_string())
}

fn camsim(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .arg("--quiet")
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Wait until `dir` holds an entry whose name contains `tag`, or `limit` passes.
fn wait_for_entry(dir: &Path, tag: &str, child: &mut Child, limit: Duration) -> Option<PathBuf> {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if let Ok(rd) = std::fs::read_dir(dir) {
            for e in rd.flatten() {
                if e.file_name().to_string_lossy().contains(tag) {
                    return Some(e.path());
                }
            }
        }
        if child.try_wait().unwrap().is_some() {
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

/// A capture big enough to take a moment (so a test can catch it at work), small enough for CI.
const SLOW: &str = r#"
seed = 3
[scene]
kind = "macbeth"
fov_deg = 10.0
patch_size_px = 64
border_px = 8
[sensor]
preset = "pixel4a"
rows = 600
cols = 800
[capture]
exposure_ms = 5.0
frames = 4
"#;

const TINY: &str = r#"
seed = 5
[scene]
kind = "macbeth"
fov_deg = 2.0
patch_size_px = 8
border_px = 2
[sensor]
preset = "pixel4a"
rows = 48
cols = 64
[capture]
exposure_ms = 5.0
"#;

/// Issue 25 item 1: `camsim simulate --out d` deleted `d/IMG_0001.dng` (and .png, .tif, .exr,
/// .csv, .json, .txt): a folder is replaced only when its marker lists everything in it.
#[test]
fn a_folder_of_the_users_files_is_refused_and_kept() {
    let root = tempfile::tempdir().unwrap();
    std::fs::write(root.path().join("tiny.toml"), TINY).unwrap();
    let cfg = root.path().join("tiny.toml");
    for ext in ["dng", "png", "tif", "exr", "csv", "json", "txt"] {
        let d = root.path().join(format!("d-{ext}"));
        std::fs::create_dir(&d).unwrap();
        let photo = d.join(format!("IMG_0001.{ext}"));
        std::fs::write(&photo, b"the user's photo").unwrap();
        let o = camsim(&["simulate", s(&cfg), "--out", s(&d)]);
        assert_eq!(o.status.code(), Some(2), "{ext}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("IMG_0001.{ext}")),
            "{}",
            stderr(&o)
        );
        assert_eq!(std::fs::read(&photo).unwrap(), b"the user's photo");
        assert_eq!(entries(&d), vec![format!("IMG_0001.{ext}")]);
    }
    // camsim's own folder is replaced; a file the user adds to it makes it the user's again.
    let run = root.path().join("run");
    assert!(camsim(&["simulate", s(&cfg), "--out", s(&run)])
        .status
        .success());
    assert!(camsim(&["simulate", s(&cfg), "--out", s(&run)])
        .status
        .success());
    std::fs::write(run.join("notes.md"), b"mine").unwrap();
    let o = camsim(&["simulate", s(&cfg), "--out", s(&run)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("notes.md"), "{}", stderr(&o));
    assert_eq!(std::fs::read(run.join("notes.md")).unwrap(), b"mine");
    // Nothing but the folders is left beside them (no staging folder, no lock file).
    let mut names = entries(root.path());
    names.retain(|n| !n.starts_with("d-"));
    assert_eq!(names, vec!["run".to_string(), "tiny.toml".into()]);
}

/// Issue 25 item 1: `camsim scene --out notes.txt` overwrote a text file with EXR data.
#[test]
fn a_single_output_file_camsim_did_not_write_needs_force() {
    let root = tempfile::tempdir().unwrap();
    let notes = root.path().join("notes.txt");
    std::fs::write(&notes, b"my notes").unwrap();
    let o = camsim(&["scene", "--kind", "uniform", "--out", s(&notes)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("notes.txt") && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&notes).unwrap(), b"my notes");
    // camsim's own EXR is replaced; --force replaces the user's file.
    let exr = root.path().join("r.exr");
    assert!(camsim(&["scene", "--kind", "uniform", "--out", s(&exr)])
        .status
        .success());
    assert!(camsim(&["scene", "--kind", "uniform", "--out", s(&exr)])
        .status
        .success());
    // A killed run's temporary of that file is removed by the next run writing it.
    let mut c = Command::new("true").spawn().unwrap();
    let dead = c.id();
    c.wait().unwrap();
    let stale = root.path().join(format!(".r.exr.camsim-tmp-{dead}-0"));
    std::fs::write(&stale, vec![0u8; 4096]).unwrap();
    let o = camsim(&["scene", "--kind", "uniform", "--out", s(&exr)]);
    assert!(o.status.success() && !stale.exists(), "{}", stderr(&o));
    assert!(stderr(&o).contains("removed"), "{}", stderr(&o));
    let o = camsim(&["scene", "--kind", "uniform", "--out", s(&notes), "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_ne!(std::fs::read(&notes).unwrap(), b"my notes");
    assert_eq!(
        entries(root.path()),
        vec!["notes.txt".to_string(), "r.exr".into()]
    );
}

/// Issue 25 item 4: two runs into one `--out` both exited 0. Now the second fails at once, the
/// first completes.
#[test]
fn a_second_run_into_the_same_folder_fails_and_the_first_completes() {
    let root = tempfile::tempdir().unwrap();
    std::fs::write(root.path().join("slow.toml"), SLOW).unwrap();
    let cfg = root.path().join("slow.toml");
    let out = root.path().join("run");
    let mut first = Command::new(bin())
        .args(["simulate", s(&cfg), "--out", s(&out), "--quiet"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let staging = wait_for_entry(
        root.path(),
        "run.camsim-tmp-",
        &mut first,
        Duration::from_secs(60),
    );
    assert!(staging.is_some(), "the first run never staged its folder");
    let second = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
    let first = first.wait_with_output().unwrap();
    assert!(first.status.success(), "{}", stderr(&first));
    assert_eq!(second.status.code(), Some(2), "{}", stderr(&second));
    assert!(
        stderr(&second).contains("being written by another camsim run"),
        "{}",
        stderr(&second)
    );
    assert!(out.join("raw.dng").is_file());
}

/// Kill `args` with SIGKILL once `tag` appears in `watch`, check that temporaries are left,
/// then run it again to completion and check that they are gone and that it said so.
fn kill_then_rerun(args: &[&str], watch: &Path, tag: &str) {
    let mut child = Command::new(bin())
        .args(args)
        .arg("--quiet")
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let seen = wait_for_entry(watch, tag, &mut child, Duration::from_secs(120));
    let _ = child.kill(); // SIGKILL: no handler runs
    let _ = child.wait();
    let seen = seen.unwrap_or_else(|| panic!("`camsim {}` never made {tag}", args.join(" ")));
    assert!(seen.exists(), "the kill left nothing to clean up");
    let o = camsim(args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!seen.exists(), "{} is still there", seen.display());
    assert!(
        stderr(&o).contains("removed")
            && stderr(&o).contains(seen.file_name().unwrap().to_str().unwrap()),
        "the re-run did not say what it removed: {}",
        stderr(&o)
    );
    let left: Vec<String> = entries(watch)
        .into_iter()
        .filter(|n| n.contains("camsim-tmp") || n.contains("camsim-old"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// Issue 25 item 3: after SIGKILL the staging folder `DIR.tmp-PID/` stayed forever.
#[test]
fn a_killed_simulate_render_or_dataset_is_cleaned_up_by_the_next_run() {
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    std::fs::write(r.join("slow.toml"), SLOW).unwrap();
    let sim = r.join("sim");
    kill_then_rerun(
        &["simulate", s(&r.join("slow.toml")), "--out", s(&sim)],
        r,
        "sim.camsim-tmp-",
    );
    assert!(sim.join("raw.dng").is_file());
    let render = r.join("render");
    kill_then_rerun(
        &[
            "render",
            "--builtin",
            "cornell-box",
            "--resolution",
            "64x64",
            "--spp",
            "16",
            "--out",
            s(&render),
        ],
        r,
        "render.camsim-tmp-",
    );
    assert!(render.join("radiance.exr").is_file());
    let spec = r.join("ds.toml");
    std::fs::write(
        &spec,
        r#"
[dataset]
samples = 4
shard_size = 4
[base]
wavelengths = { start_nm = 400.0, step_nm = 10.0, count = 31 }
scene = { kind = "macbeth" }
sensor = { preset = "pixel4a", rows = 300, cols = 400 }
capture = { exposure_ms = 5.0 }
"#,
    )
    .unwrap();
    let ds = r.join("ds");
    kill_then_rerun(
        &["dataset", s(&spec), "--out", s(&ds), "--workers", "1"],
        &ds,
        ".camsim-tmp-",
    );
    assert!(ds.join("manifest.jsonl").is_file());
}
