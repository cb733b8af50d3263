//! Built-in sensors: TOML files under `crates/camsim-sensor/presets/`, compiled into the binary.

use crate::error::{Result, SensorError};

const PRESETS: &[(&str, &str)] = &[
    ("imx363", include_str!("../presets/imx363.toml")),
    ("pixel4a", include_str!("../presets/pixel4a.toml")),
    (
        "pixel4a-raw10",
        include_str!("../presets/pixel4a-raw10.toml"),
    ),
    ("ideal", include_str!("../presets/ideal.toml")),
];

const NAMES: &[&str] = &["imx363", "pixel4a", "pixel4a-raw10", "ideal"];

/// Names of the built-in presets.
pub fn names() -> &'static [&'static str] {
    NAMES
}

/// The TOML text of preset `name` (comments included).
pub fn toml(name: &str) -> Result<&'static str> {
    PRESETS
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, t)| *t)
        .ok_or_else(|| SensorError::UnknownPreset {
            name: name.to_string(),
            known: NAMES.join(", "),
        })
}
