//! The catalogue of every name table: each family of named things camsim knows (presets, scene
//! kinds, methods, colour filter arrays, outputs), from the table its crate dispatches on. `camsim
//! presets` prints it and Python's `camsim.presets.names()` returns it, so neither can list a
//! name camsim does not take or miss one it does.

use camsim_core::names::NameTable;

/// One family: its name, where the names are used, and (name, one-line description) per entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Family {
    /// The family in the plural ("sensor presets").
    pub title: &'static str,
    /// Where its names go (`camsim presets sensor NAME`, `[sensor] preset`).
    pub usage: &'static str,
    /// (name, description) in table order.
    pub entries: Vec<(&'static str, &'static str)>,
}

fn family<T: Copy>(title: &'static str, usage: &'static str, t: &NameTable<T>) -> Family {
    Family {
        title,
        usage,
        entries: t.entries.iter().map(|e| (e.name, e.about)).collect(),
    }
}

/// Every family, in the order `camsim presets` lists them.
pub fn catalogue() -> Vec<Family> {
    let mut dataset = family(
        "dataset outputs",
        "[dataset] outputs = [...]",
        &camsim_pipeline::outputs::OUTPUTS,
    );
    dataset
        .entries
        .extend(family("", "", &camsim_dataset::DATASET_OUTPUTS).entries);
    vec![
        family(
            "sensor presets",
            "camsim presets sensor NAME; [sensor] preset; --sensor",
            &camsim_sensor::presets::SENSOR_PRESETS,
        ),
        family(
            "lens presets",
            "camsim presets optics NAME; [optics] preset; --lens",
            &camsim_optics::presets::LENS_PRESETS,
        ),
        family(
            "3D scenes",
            "camsim render --builtin NAME; [render] builtin",
            &camsim_scene3d::builtin::BUILTIN_SCENES,
        ),
        family(
            "2D scene kinds",
            "[scene] kind = ...; camsim scene --kind",
            &camsim_scene::config::SCENE_KINDS,
        ),
        family(
            "demosaic methods",
            "camsim isp --demosaic; Python demosaic(method=)",
            &camsim_isp::DEMOSAIC_METHODS,
        ),
        family(
            "white balance",
            "camsim isp --white-balance; Python white_balance(method=)",
            &camsim_isp::WHITE_BALANCE_METHODS,
        ),
        family(
            "colour filter arrays",
            "camsim sensor --cfa; sensor TOML cfa",
            &camsim_core::cfa::CFA_NAMES,
        ),
        family(
            "outputs",
            "camsim simulate --save",
            &camsim_pipeline::outputs::OUTPUTS,
        ),
        dataset,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_family_is_listed_with_its_table() {
        let c = catalogue();
        let names = |title: &str| -> Vec<&str> {
            c.iter()
                .find(|f| f.title == title)
                .unwrap()
                .entries
                .iter()
                .map(|e| e.0)
                .collect()
        };
        assert_eq!(names("sensor presets"), camsim_sensor::presets::names());
        assert_eq!(names("2D scene kinds").len(), 17);
        assert!(names("2D scene kinds").contains(&"glare_target"));
        assert!(names("dataset outputs").contains(&"raw-npy"));
        assert!(names("dataset outputs").contains(&"noise-free"));
        assert!(c
            .iter()
            .all(|f| !f.entries.is_empty() && !f.usage.is_empty()));
    }
}
