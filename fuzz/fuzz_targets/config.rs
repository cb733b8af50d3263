//! Fuzz the simulate config reader and the checks every run makes before its work: any text
//! must give Ok or Err, never a panic. Stable counterpart:
//! crates/camsim-pipeline/tests/it/config_fuzz.rs.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(cfg) = camsim_pipeline::SimulateConfig::from_toml_str(text, std::path::Path::new("")) {
        let _ = cfg.capture();
        let _ = cfg.sensor();
        let _ = cfg.optics();
    }
});
