//! Fuzz the pbrt-v4 scene reader and the PLY reader: any input must give Ok or an error, never a
//! panic, a hang or an unbounded allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        // A virtual path in an empty folder: Include and file names resolve to nothing.
        let _ = camsim_pbrt::parse_str(text, "/nonexistent-camsim-fuzz/scene.pbrt");
    }
    let _ = camsim_pbrt::ply::parse_ply(data);
});
