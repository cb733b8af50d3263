//! Fuzz the PLY reader (ASCII and binary meshes of pbrt-v4 scenes): any bytes must give Ok or
//! Err, never a panic, hang or huge allocation. Stable counterpart: the PLY property test in
//! crates/camsim-pbrt/tests/it/parser_fuzz.rs.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = camsim_pbrt::ply::parse_ply(data);
});
