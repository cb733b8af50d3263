//! The layout of the tests and of their build.
//!
//! - Every file of a crate's `tests/it/` is a module its `main.rs` declares: a file left out
//!   would never be compiled, and its tests would pass by not running.
//! - The Python package's build (scripts/test-python: `maturin develop --profile dev`, the
//!   package alone) reuses the crates `cargo test --workspace` compiled: the test profile is the
//!   dev profile's (Cargo.toml has no `[profile.test]` of its own) and every dependency the
//!   package shares with the workspace resolves with the same features (`cargo tree`). A
//!   mismatch would not fail anything else, only compile the whole workspace once more in CI.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// Each package of `cargo tree ARGS` with the feature sets it is built with.
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(&root)
        .args(["tree", "-q", "--prefix", "none", "-f", "{p}|{f}"])
        .args(args)
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        if let Some((p, f)) = line.trim_end_matches(" (*)").split_once('|') {
            map.entry(p.to_string()).or_default().insert(f.to_string());
        }
    }
    map
}

#[test]
fn the_python_build_resolves_dependencies_as_the_workspace_test_build() {
    let toml =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../Cargo.toml"))
            .unwrap();
    assert!(
        !toml.lines().any(|l| l.trim().starts_with("[profile.test")),
        "the test profile must stay the dev profile's (scripts/test-python builds with dev)"
    );
    let python = features(&["-p", "camsim-python", "-e", "normal,build"]);
    let workspace = features(&["--workspace", "-e", "normal,build,dev"]);
    assert!(python.len() > 100, "{} packages", python.len());
    let differ: Vec<String> = python
        .iter()
        .filter_map(|(p, f)| {
            let w = workspace.get(p)?;
            (w != f).then(|| format!("{p}: the Python build {f:?}, the workspace {w:?}"))
        })
        .collect();
    assert!(
        differ.is_empty(),
        "dependencies the Python package's build would compile again (add the workspace's \
         features to crates/camsim-python/Cargo.toml's unused dependencies):\n{}",
        differ.join("\n")
    );
}

#[test]
fn every_file_in_tests_it_is_declared_in_its_main() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut missing = Vec::new();
    let mut dirs = 0;
    for krate in std::fs::read_dir(&crates).unwrap().flatten() {
        let it = krate.path().join("tests/it");
        let Ok(main) = std::fs::read_to_string(it.join("main.rs")) else {
            continue;
        };
        dirs += 1;
        for f in std::fs::read_dir(&it).unwrap().flatten() {
            let p = f.path();
            let Some(stem) = p.file_stem().and_then(|s| s.to_str()) else {
                continue;
            };
            if p.extension().is_some_and(|e| e == "rs")
                && stem != "main"
                && !main.lines().any(|l| l.trim() == format!("mod {stem};"))
            {
                missing.push(p.display().to_string());
            }
        }
    }
    assert!(dirs >= 17, "found only {dirs} tests/it folders");
    assert!(
        missing.is_empty(),
        "not declared in their main.rs: {missing:?}"
    );
}
