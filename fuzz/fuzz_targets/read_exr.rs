//! Fuzz the OpenEXR readers (spectral, single-channel, all channels) and the signature check:
//! any bytes must give Ok or Err, never a panic, hang or huge allocation. The readers take a
//! path, so each input is written to a temporary file. Stable counterpart:
//! crates/camsim-io/tests/exr_fuzz.rs.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    std::env::set_var("CAMSIM_MEMORY_LIMIT_MIB", "512");
    let dir = std::env::temp_dir().join(format!("camsim-fuzz-exr-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("fuzz.exr");
    if std::fs::write(&path, data).is_err() {
        return;
    }
    let _ = camsim_io::exr::read_spectral_exr(&path);
    let _ = camsim_io::exr::read_gray_exr(&path, None);
    let _ = camsim_io::exr::read_channels_exr(&path);
    let _ = camsim_io::claim::written_by_camsim(&path);
});
