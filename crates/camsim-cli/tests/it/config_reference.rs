//! docs/src/config.md is generated from the config types' doc comments (through their derived
//! JSON schemas) by `examples/config-reference`; it must match what the generator writes today,
//! and every config key must have a doc comment.

#[path = "../../examples/config-reference/reference.rs"]
mod reference;

use std::path::Path;

#[test]
fn every_config_key_has_a_doc_comment() {
    let (_, missing) = reference::page();
    assert!(
        missing.is_empty(),
        "these config keys have no doc comment (write one, with the unit, on the config type's \
         field):\n  {}",
        missing.join("\n  ")
    );
}

#[test]
fn config_reference_page_is_generated_from_the_config_types() {
    let (page, _) = reference::page();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/src/config.md");
    let committed = std::fs::read_to_string(&path).expect("docs/src/config.md");
    if committed != page {
        let line = committed
            .lines()
            .zip(page.lines())
            .position(|(a, b)| a != b)
            .map_or(committed.lines().count().min(page.lines().count()), |i| i);
        panic!(
            "docs/src/config.md differs from the config types' doc comments (first at line {}: \
             committed {:?}, generated {:?}); rewrite it with\n  {}",
            line + 1,
            committed.lines().nth(line).unwrap_or("<end>"),
            page.lines().nth(line).unwrap_or("<end>"),
            reference::COMMAND
        );
    }
}

#[test]
fn the_reference_documents_every_simulate_section_and_scene_kind() {
    // The generator walks the types; an independent list (the TOML tables a user writes, and the
    // scene kinds the scene door dispatches on) checks that it reached them all.
    let (page, _) = reference::page();
    for table in [
        "`[capture]`",
        "`[optics]`",
        "`[optics.config]`",
        "`[sensor]`",
        "`[sensor.config]`",
        "`[render]`",
        "`[scene]`",
        "`[wavelengths]`",
        "`[camera]`",
        "`[[object]]`",
        "`[[material]]`",
        "`[light]`",
        "`[dataset]`",
        "`[[vary]]`",
    ] {
        assert!(page.contains(&format!("### {table}")), "no section {table}");
    }
    for kind in camsim::scene::config::SCENE_KINDS.entries {
        assert!(
            page.contains(&format!("#### `kind = \"{}\"`", kind.name)),
            "scene kind {} is not documented",
            kind.name
        );
    }
}
