//! Every file of a crate's `tests/it/` is a module its `main.rs` declares: a file left out
//! would never be compiled, and its tests would pass by not running.

use std::path::Path;

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
