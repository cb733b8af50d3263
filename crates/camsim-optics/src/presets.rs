//! Built-in optics presets: TOML files under `crates/camsim-optics/presets/`, embedded in the
//! library, named in one table ([`LENS_PRESETS`], the case rule of `camsim_core::names`).

use crate::error::Result;
use camsim_core::names::{NameTable, Named};

/// The built-in lenses; each value is the preset's TOML text (comments included).
pub const LENS_PRESETS: NameTable<&str> = NameTable {
    family: "lens preset",
    entries: &[
        Named {
            name: "pixel4a",
            aliases: &[],
            about: "Pixel 4a lens: f/1.73, 4.38 mm, the paper's defocus and shading (default)",
            value: include_str!("../presets/pixel4a.toml"),
        },
        Named {
            name: "pixel4a-measured",
            aliases: &[],
            about: "pixel4a fitted to the camera's measured MTF (defocus, crosstalk)",
            value: include_str!("../presets/pixel4a-measured.toml"),
        },
        Named {
            name: "diffraction-limited",
            aliases: &[],
            about: "f/1.73, 4.38 mm, no aberrations, cos^4 falloff",
            value: include_str!("../presets/diffraction-limited.toml"),
        },
    ],
};

/// Names of the built-in presets.
pub fn names() -> Vec<&'static str> {
    LENS_PRESETS.names()
}

/// The TOML text of preset `name` (comments included).
pub fn toml(name: &str) -> Result<&'static str> {
    Ok(LENS_PRESETS.get(name)?)
}
