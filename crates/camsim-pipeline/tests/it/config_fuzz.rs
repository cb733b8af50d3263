//! Property tests (issue 25, the reliability suite on stable): damaged simulate configs (values
//! replaced by extreme or wrong-typed ones, lines dropped or cut) never panic the config reader
//! or the checks that follow it; a config that is refused gets a message. The cargo-fuzz target `fuzz/fuzz_targets/config.rs` explores the same reader
//! without bounds.

use camsim_pipeline::{SimulateConfig, DEFAULT_CONFIG};
use proptest::prelude::*;

const VALUES: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e300",
    "-1e300",
    "1e-300",
    "18446744073709551616",
    "\"x\"",
    "\"\"",
    "[]",
    "[1, 2]",
    "{}",
    "true",
    "{ kind = \"macbeth\" }",
    "\"pixel4a\"",
    "\"nosuch\"",
    "3.5",
    "65536",
    "4294967296",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn damaged_configs_never_panic(
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0usize..VALUES.len(), 0u8..3), 1..6),
        cut in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let mut lines: Vec<String> = DEFAULT_CONFIG.lines().map(str::to_string).collect();
        for (at, v, how) in edits {
            let i = at.index(lines.len());
            match how {
                // Replace the value of a `key = value` line.
                0 => if let Some((k, _)) = lines[i].split_once('=') {
                    lines[i] = format!("{k}= {}", VALUES[v]);
                },
                1 => { lines.remove(i); }
                // A key the config does not have, or one repeated.
                _ => lines.insert(i, format!("x{v} = {}", VALUES[v])),
            }
            if lines.is_empty() {
                break;
            }
        }
        let mut text = lines.join("\n");
        if let Some(c) = cut {
            let mut end = c.index(text.len() + 1);
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            text.truncate(end);
        }
        match SimulateConfig::from_toml_str(&text, std::path::Path::new("")) {
            Ok(cfg) => {
                // The checks every run makes before its work: errors, never panics.
                let _ = cfg.capture();
                let _ = cfg.sensor();
                let _ = cfg.optics();
                let _ = cfg.wavelengths.validate();
            }
            Err(e) => prop_assert!(!e.to_string().trim().is_empty()),
        }
    }
}
