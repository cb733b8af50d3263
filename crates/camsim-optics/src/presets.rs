//! Built-in optics presets, TOML files embedded in the library.

/// (name, TOML text) of every preset.
const PRESETS: &[(&str, &str)] = &[
    ("pixel4a", include_str!("../presets/pixel4a.toml")),
    (
        "pixel4a-measured",
        include_str!("../presets/pixel4a-measured.toml"),
    ),
    (
        "diffraction-limited",
        include_str!("../presets/diffraction-limited.toml"),
    ),
];

/// Names of the built-in presets.
pub fn names() -> Vec<&'static str> {
    PRESETS.iter().map(|p| p.0).collect()
}

/// TOML text of preset `name`.
pub fn toml_text(name: &str) -> Option<&'static str> {
    PRESETS.iter().find(|p| p.0 == name).map(|p| p.1)
}
