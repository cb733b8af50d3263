//! `camsim presets`: list and print the built-in sensors, lenses and scenes.

use anyhow::{bail, Result};

/// List the built-in presets, or print one as TOML (the file you would copy and edit).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim presets\n  camsim presets sensor pixel4a > my-sensor.toml\n  camsim presets optics pixel4a"
)]
pub struct Args {
    /// sensor | optics | scene
    pub kind: Option<String>,
    /// Preset name.
    pub name: Option<String>,
}

pub fn run(a: Args) -> Result<()> {
    match (a.kind.as_deref(), a.name.as_deref()) {
        (None, _) => {
            println!(
                "sensors (camsim presets sensor NAME):  {}",
                camsim_sensor::presets::names().join(", ")
            );
            println!(
                "lenses  (camsim presets optics NAME):  {}",
                camsim_optics::presets::names().join(", ")
            );
            println!(
                "3D scenes (camsim render --builtin NAME): {}",
                camsim_scene3d::builtin::names().join(", ")
            );
            println!(
                "2D scene kinds ([scene] kind = ...):    uniform, macbeth, slanted_edge, file"
            );
            println!("simulate default config:               camsim simulate --print-config");
        }
        (Some("sensor"), Some(n)) => print!("{}", camsim_sensor::presets::toml(n)?),
        (Some("optics" | "lens"), Some(n)) => match camsim_optics::presets::toml_text(n) {
            Some(t) => print!("{t}"),
            None => bail!(
                "no lens preset '{n}': use one of {}",
                camsim_optics::presets::names().join(", ")
            ),
        },
        (Some("sensor"), None) => println!("{}", camsim_sensor::presets::names().join("\n")),
        (Some("optics" | "lens"), None) => {
            println!("{}", camsim_optics::presets::names().join("\n"))
        }
        (Some("scene"), _) => println!("{}", camsim_scene3d::builtin::names().join("\n")),
        (Some(k), _) => bail!("unknown preset kind '{k}': use sensor, optics or scene"),
    }
    Ok(())
}
