//! Built-in sensors: TOML files under `crates/camsim-sensor/presets/`, compiled into the binary,
//! named in one table ([`SENSOR_PRESETS`], the case rule of `camsim_core::names`).

use crate::error::Result;
use camsim_core::names::{NameTable, Named};

/// The built-in sensors; each value is the preset's TOML text (comments included).
pub const SENSOR_PRESETS: NameTable<&str> = NameTable {
    family: "sensor preset",
    entries: &[
        Named {
            name: "imx363",
            aliases: &[],
            about: "Sony IMX363 with its published QE (Lyu et al. Table 1)",
            value: include_str!("../presets/imx363.toml"),
        },
        Named {
            name: "pixel4a",
            aliases: &[],
            about: "the Pixel 4a's IMX363 with the paper's corrected QE (default)",
            value: include_str!("../presets/pixel4a.toml"),
        },
        Named {
            name: "pixel4a-raw10",
            aliases: &[],
            about: "pixel4a with the phone's 10-bit raw format (black level 64)",
            value: include_str!("../presets/pixel4a-raw10.toml"),
        },
        Named {
            name: "ideal",
            aliases: &[],
            about: "QE 1, no noise, 16-bit: for tests",
            value: include_str!("../presets/ideal.toml"),
        },
    ],
};

/// Names of the built-in presets.
pub fn names() -> Vec<&'static str> {
    SENSOR_PRESETS.names()
}

/// The TOML text of preset `name` (comments included).
pub fn toml(name: &str) -> Result<&'static str> {
    Ok(SENSOR_PRESETS.get(name)?)
}
