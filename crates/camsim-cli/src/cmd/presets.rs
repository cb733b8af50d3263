//! `camsim presets`: list every name camsim knows (the catalogue of name tables), or print a
//! sensor or lens preset as TOML.

use anyhow::{bail, Result};

/// List every built-in name (sensor and lens presets, 3D scenes, 2D scene kinds, demosaic and
/// white-balance methods, colour filter arrays, outputs), or print one preset as TOML (the file
/// you would copy and edit; a sensor preset's source, the data it was built from, also on stderr).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim presets\n  camsim presets sensor pixel4a > my-sensor.toml\n  camsim presets optics pixel4a"
)]
pub struct Args {
    /// sensor | optics (lens) | scene; or a family's title word to list it alone.
    pub kind: Option<String>,
    /// Preset name.
    pub name: Option<String>,
}

pub fn run(a: Args) -> Result<()> {
    let catalogue = camsim::names::catalogue();
    match (a.kind.as_deref(), a.name.as_deref()) {
        (None, _) => {
            for f in &catalogue {
                println!("{} ({}):", f.title, f.usage);
                let w = f.entries.iter().map(|e| e.0.len()).max().unwrap_or(0);
                for (name, about) in &f.entries {
                    println!("  {name:<w$}  {about}");
                }
            }
            println!("simulate default config: camsim simulate --print-config");
        }
        (Some("sensor"), Some(n)) => {
            print!("{}", camsim::sensor::presets::toml(n)?);
            // Where its figures come from, also on stderr (the TOML's `source`).
            let sensor = camsim::sensor::Sensor::preset(n)?;
            crate::common::say(format!(
                "source: {}",
                sensor.config().source.as_deref().unwrap_or("not stated")
            ));
        }
        (Some("optics" | "lens"), Some(n)) => print!("{}", camsim::optics::presets::toml(n)?),
        (Some("sensor"), None) => println!("{}", camsim::sensor::presets::names().join("\n")),
        (Some("optics" | "lens"), None) => {
            println!("{}", camsim::optics::presets::names().join("\n"))
        }
        (Some("scene"), _) => println!("{}", camsim::scene3d::builtin::names().join("\n")),
        (Some(k), _) => match catalogue
            .iter()
            .find(|f| f.title.split(' ').any(|w| w.eq_ignore_ascii_case(k)))
        {
            Some(f) => {
                for (name, _) in &f.entries {
                    println!("{name}");
                }
            }
            None => bail!(
                "unknown preset kind '{k}'; known: sensor, optics, scene, or a word of: {}",
                catalogue
                    .iter()
                    .map(|f| f.title)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    }
    Ok(())
}
