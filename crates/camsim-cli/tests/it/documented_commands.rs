//! Every command the documentation shows, run the way a user would run it.
//!
//! The commands are not listed here: they are extracted from the texts a user reads, so a
//! documented command cannot rot without this test failing.
//!
//! * README.md and every page of the book (`docs/src/*.md`): every line of every ```` ```sh ````
//!   block. `cargo run --release -- ARGS` is the
//!   binary under test with ARGS; other `cargo`, `pip`, `python` lines (the test command itself,
//!   tool installs) are not camsim commands and are skipped. Lines starting with `#` are comments.
//! * `--help` of the program and of every subcommand, found by walking the `Commands:` lists:
//!   every line starting with `camsim ` inside a block headed `Example:` / `Examples:` /
//!   `Example (...):`. A trailing comment is separated from the command by three or more spaces.
//!
//! All commands run with `sh -c` (so `>`, `&&` work as documented) from a scratch copy of the
//! repository root: `examples/` is copied, `../shared` points at the reference data, and outputs
//! land in the scratch `out/`. Examples may depend on each other's outputs (`camsim scene --out
//! out/radiance.exr` then `camsim optics --in out/radiance.exr`), so commands are run in passes
//! until no more succeed: every command must succeed in some pass. A command that fails in an
//! early pass (its input not made yet) must fail cleanly (exit 2), never with a panic. After
//! success, every `--out PATH` and `> FILE` the command names must exist and be non-empty, and
//! no temporary file may remain under `out/`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use crate::common;
use common::{command_tree, run_limited, subcommands, Outcome, BIN};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Lines of `Example...:` blocks that are camsim commands, comments cut off.
fn examples_in_help(help_text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in help_text.lines() {
        let t = line.trim();
        if !line.starts_with(' ') && t.starts_with("Example") && t.ends_with(':') {
            inside = true;
            continue;
        }
        if inside {
            if t.is_empty() {
                inside = false;
                continue;
            }
            if t.starts_with("camsim ") {
                out.push(strip_comment(t));
            }
        }
    }
    out
}

fn strip_comment(cmd: &str) -> String {
    match cmd.find("   ") {
        Some(i) => cmd[..i].trim().to_string(),
        None => cmd.trim().to_string(),
    }
}

/// The documents a user reads: README.md, then every page of the book under `docs/src`.
fn documents() -> Vec<(String, String)> {
    let root = repo_root();
    let mut out = vec![(
        "README.md".to_string(),
        std::fs::read_to_string(root.join("README.md")).unwrap(),
    )];
    let mut pages: Vec<PathBuf> = std::fs::read_dir(root.join("docs/src"))
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    pages.retain(|p| p.extension().is_some_and(|x| x == "md"));
    pages.sort();
    for p in pages {
        let name = p.strip_prefix(&root).unwrap().display().to_string();
        out.push((name, std::fs::read_to_string(&p).unwrap()));
    }
    out
}

/// Commands of a document's ```sh blocks, as camsim invocations.
fn sh_commands(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            inside = !inside && t == "```sh";
            continue;
        }
        if !inside || t.is_empty() || t.starts_with('#') {
            continue;
        }
        // A trailing shell comment.
        let t = match t.find("  #") {
            Some(i) => t[..i].trim(),
            None => t,
        };
        if let Some(rest) = t.strip_prefix("cargo run --release -- ") {
            out.push(format!("camsim {rest}"));
        } else if t.starts_with("camsim ") {
            out.push(t.to_string());
        }
        // Other lines (cargo test, pip install, python ...) are not camsim commands.
    }
    out
}

/// Paths a command says it writes: `--out P`, `--out=P`, `> P`.
fn claimed_outputs(cmd: &str) -> Vec<String> {
    let words: Vec<&str> = cmd.split_whitespace().collect();
    let mut out = Vec::new();
    for (i, w) in words.iter().enumerate() {
        if (*w == "--out" || *w == ">") && i + 1 < words.len() {
            out.push(words[i + 1].to_string());
        } else if let Some(p) = w.strip_prefix("--out=") {
            out.push(p.to_string());
        }
    }
    out
}

fn non_empty(p: &Path) -> bool {
    if p.is_dir() {
        std::fs::read_dir(p)
            .map(|mut d| d.next().is_some())
            .unwrap_or(false)
    } else {
        std::fs::metadata(p).map(|m| m.len() > 0).unwrap_or(false)
    }
}

/// Temporary files or folders left anywhere under `dir`.
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.contains(".tmp") {
                found.push(e.path());
            }
            if e.path().is_dir() {
                stack.push(e.path());
            }
        }
    }
    found
}

/// Run one documented command line with `sh -c` in `root`, with camsim first on PATH.
fn run_line(root: &Path, line: &str, limit: Duration) -> Outcome {
    let bin_dir = Path::new(BIN).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut cmd = Command::new("sh");
    cmd.arg("-c").arg(line).current_dir(root).env("PATH", path);
    run_limited(cmd, limit)
}

/// A scratch repository root: `examples/` linked, `../shared` pointing at the reference data.
fn scratch_root() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("repo");
    std::fs::create_dir(&root).unwrap();
    let repo = repo_root();
    // A copy, not a link: configs name paths relative to their own folder (`../out`), and the
    // kernel resolves `..` through a link to the link's target.
    copy_dir(&repo.join("examples"), &root.join("examples"));
    let shared = repo.join("../shared");
    if shared.exists() {
        std::os::unix::fs::symlink(shared.canonicalize().unwrap(), tmp.path().join("shared"))
            .unwrap();
    }
    (tmp, root)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(e.file_name());
        if e.path().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

#[test]
fn every_documented_command_runs() {
    let mut lines: Vec<(String, String)> = documents()
        .into_iter()
        .flat_map(|(doc, text)| {
            sh_commands(&text)
                .into_iter()
                .map(move |c| (doc.clone(), c))
        })
        .collect();
    let tree = command_tree();
    for (path, text) in &tree {
        let origin = format!("camsim {} --help", path.join(" ")).replace("  ", " ");
        for c in examples_in_help(text) {
            lines.push((origin.clone(), c));
        }
    }
    // The documentation must actually show commands: the README's default run and at least one
    // example for every leaf subcommand.
    assert!(
        lines
            .iter()
            .any(|(o, c)| o == "README.md" && c == "camsim simulate"),
        "README lost its default run"
    );
    for (path, text) in &tree {
        let leaf = subcommands(text).is_empty();
        if leaf && !path.is_empty() {
            assert!(
                !examples_in_help(text).is_empty(),
                "`camsim {} --help` shows no example; every subcommand should teach one",
                path.join(" ")
            );
        }
    }
    let mut seen = std::collections::HashSet::new();
    lines.retain(|(_, c)| seen.insert(c.clone()));

    let (_tmp, root) = scratch_root();
    let limit = Duration::from_secs(900);
    let mut pending: Vec<(String, String)> = lines;
    let mut failures: Vec<String> = Vec::new();
    let mut pass = 0;
    loop {
        pass += 1;
        let mut still = Vec::new();
        let mut last_err = Vec::new();
        let before = pending.len();
        for (origin, line) in pending {
            let o = run_line(&root, &line, limit);
            eprintln!(
                "[pass {pass}] {:>6.1} s  exit {:?}  {line}",
                o.seconds, o.code
            );
            match o.code {
                Some(0) => {
                    for p in claimed_outputs(&line) {
                        if !non_empty(&root.join(&p)) {
                            failures
                                .push(format!("{origin}: `{line}` exited 0 but did not write {p}"));
                        }
                    }
                }
                Some(2) => {
                    last_err.push(format!("{origin}: `{line}` exited 2:\n{}", tail(&o.stderr)));
                    still.push((origin, line));
                }
                other => failures.push(format!(
                    "{origin}: `{line}` exited {other:?} (never allowed):\n{}",
                    tail(&o.stderr)
                )),
            }
        }
        if still.is_empty() {
            break;
        }
        if still.len() == before {
            failures.extend(last_err);
            break;
        }
        pending = still;
    }
    let temps = temporaries(&root.join("out"));
    if !temps.is_empty() {
        failures.push(format!("temporary files left: {temps:?}"));
    }
    assert!(
        failures.is_empty(),
        "documented commands that fail:\n\n{}",
        failures.join("\n\n")
    );
}

fn tail(s: &str) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(8)..].join("\n")
}

#[test]
fn extraction_finds_commands_and_strips_comments() {
    let text = "Usage: x\n\nExamples:\n  camsim simulate --out out/a      (repeat)\n  then edit it\n  camsim presets sensor pixel4a > s.toml\n\nOptions:\n  camsim not-an-example\n";
    assert_eq!(
        examples_in_help(text),
        vec![
            "camsim simulate --out out/a",
            "camsim presets sensor pixel4a > s.toml"
        ]
    );
    assert_eq!(
        claimed_outputs("camsim presets sensor pixel4a > s.toml"),
        vec!["s.toml"]
    );
    assert_eq!(
        claimed_outputs("camsim psf --out=out/p --lens x"),
        vec!["out/p"]
    );
    let cmds =
        "Commands:\n  simulate  Run\n            wrapped text\n  help      Print\n\nOptions:\n";
    assert_eq!(subcommands(cmds), vec!["simulate"]);
}
