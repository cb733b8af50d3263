//! One name table per family: `camsim presets` lists every name of every family camsim
//! dispatches on, the same names work in the commands under one case rule, and an unknown name
//! is refused with the known ones (exit 2).

use std::process::{Command, Output};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn presets_lists_every_family_and_name() {
    let o = camsim(&["presets"]);
    assert!(o.status.success());
    let list = text(&o.stdout);
    let catalogue = camsim::names::catalogue();
    assert!(catalogue.len() >= 9);
    for f in &catalogue {
        assert!(list.contains(f.title), "{} missing:\n{list}", f.title);
        for (name, _) in &f.entries {
            assert!(
                list.lines()
                    .any(|l| l.trim_start().starts_with(&format!("{name} "))),
                "{}: {name} missing:\n{list}",
                f.title
            );
        }
    }
    // Every 2D scene kind (the old list had 4 of the 14) and the dataset-only outputs.
    for name in [
        "dead_leaves",
        "zone_plate",
        "rgb",
        "raw-npy",
        "xyz",
        "quad-bayer",
    ] {
        assert!(list.contains(name), "{name}");
    }
    // A family alone, by a word of its title.
    let demosaic = text(&camsim(&["presets", "demosaic"]).stdout);
    assert_eq!(
        demosaic.lines().collect::<Vec<_>>(),
        ["bilinear", "malvar", "adaptive-laplacian"]
    );
}

#[test]
fn one_case_rule_and_unknown_names_list_the_known_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    let out = out.to_str().unwrap();
    // Sensor and lens presets: the same lookup, any case.
    for (kind, name) in [("sensor", "PIXEL4A"), ("optics", "Diffraction-Limited")] {
        let o = camsim(&["presets", kind, name]);
        assert!(o.status.success(), "{kind} {name}: {}", text(&o.stderr));
    }
    for (args, want) in [
        (
            vec!["presets", "sensor", "pixel5"],
            "unknown sensor preset 'pixel5'; known: imx363, pixel4a, pixel4a-raw10, ideal",
        ),
        (
            vec!["presets", "optics", "pixel5"],
            "unknown lens preset 'pixel5'; known: pixel4a, pixel4a-measured, diffraction-limited",
        ),
        (
            vec!["scene", "--kind", "zone-plates", "--out", out],
            "unknown scene kind 'zone-plates'; known: uniform, macbeth",
        ),
        (
            vec!["render", "--builtin", "cornel-box", "--out", out],
            "unknown built-in scene 'cornel-box'; known: cornell-box, cornell-box-mcc",
        ),
        (
            vec!["simulate", "--save", "radience", "--out", out],
            "unknown output 'radience'; known: raw, raw-png, preview",
        ),
        (
            vec!["simulate", "--exr-precision", "f8", "--out", out],
            "unknown EXR precision 'f8'; known: f32, f16",
        ),
    ] {
        let o = camsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = text(&o.stderr);
        assert!(e.contains(want), "{args:?}: {e}");
    }
    // A scene kind written with '-' is the kind of the table.
    let o = camsim(&[
        "scene",
        "--kind",
        "Slanted-Edge",
        "--out",
        dir.path().join("edge.exr").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}
