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
        Named {
            name: "mt9v024-mono",
            aliases: &[],
            about: "ON Semiconductor MT9V024, monochrome (ISETCam MT9V024SensorMono.mat)",
            value: include_str!("../presets/mt9v024-mono.toml"),
        },
        Named {
            name: "mt9v024-rgb",
            aliases: &[],
            about: "ON Semiconductor MT9V024, Bayer GRBG (ISETCam MT9V024SensorRGB.mat)",
            value: include_str!("../presets/mt9v024-rgb.toml"),
        },
        Named {
            name: "mt9v024-rccc",
            aliases: &[],
            about: "ON Semiconductor MT9V024, RCCC (ISETCam MT9V024SensorRCCC.mat)",
            value: include_str!("../presets/mt9v024-rccc.toml"),
        },
        Named {
            name: "mt9v024-rgbw",
            aliases: &[],
            about: "ON Semiconductor MT9V024, RGBW (ISETCam MT9V024SensorRGBW.mat)",
            value: include_str!("../presets/mt9v024-rgbw.toml"),
        },
        Named {
            name: "ar0132at-rgb",
            aliases: &[],
            about: "ON Semiconductor AR0132AT, Bayer GRBG (ISETCam ar0132atSensorRGB.mat)",
            value: include_str!("../presets/ar0132at-rgb.toml"),
        },
        Named {
            name: "ar0132at-rccc",
            aliases: &[],
            about: "ON Semiconductor AR0132AT, RCCC (ISETCam ar0132atSensorRCCC.mat)",
            value: include_str!("../presets/ar0132at-rccc.toml"),
        },
        Named {
            name: "imx490-large",
            aliases: &[],
            about: "Sony IMX490, large photodiode (ISETCam sensorCreate('imx490-large'))",
            value: include_str!("../presets/imx490-large.toml"),
        },
        Named {
            name: "imx490-small",
            aliases: &[],
            about: "Sony IMX490, small photodiode (ISETCam sensorCreate('imx490-small'))",
            value: include_str!("../presets/imx490-small.toml"),
        },
        Named {
            name: "imx490",
            aliases: &[],
            about: "Sony IMX490 split-pixel HDR: imx490-large with imx490-small as its [hdr]",
            value: include_str!("../presets/imx490.toml"),
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
