//! Writes the ISETCam sensor presets (`crates/camsim-sensor/presets/<name>.toml`) from ISETCam's
//! own sensor files in `../shared/data/isetcam/sensor` ([`camsim_sensor::isetcam`]):
//!
//!   cargo run -p camsim-sensor --example isetcam-presets
//!
//! `crates/camsim-sensor/tests/it/isetcam_presets.rs` checks that every preset equals its file.

use camsim_sensor::isetcam::{read_isetcam_sensor, ISETCAM_PRESETS};
use std::path::Path;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let data = root.join("../../../shared/data/isetcam/sensor");
    for p in ISETCAM_PRESETS {
        let file = data.join(p.file);
        let mut c = read_isetcam_sensor(&file, Some(p.bits), Some(p.source()))
            .unwrap_or_else(|e| panic!("{e}"));
        c.qe.loaded_from = None;
        let text = format!(
            "# {}\n# Written by `cargo run -p camsim-sensor --example isetcam-presets` from ISETCam's {}\n\
             # (../shared/data/isetcam/sensor; ISETCam, MIT licence). Every value is the file's (SI units\n\
             # converted to camsim's) except `bits` (the file's quantization is analog):\n# {}.\n{}",
            p.about,
            p.file,
            p.bits_source,
            c.to_toml()
        );
        let out = root.join("presets").join(format!("{}.toml", p.name));
        std::fs::write(&out, text).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
        println!("wrote {}", out.display());
    }
}
