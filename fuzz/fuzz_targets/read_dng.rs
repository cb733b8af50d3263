//! Fuzz the DNG reader: any bytes must give Ok or Err, never a panic, hang or huge allocation.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = camsim_io::dng::read_dng_bytes(data, std::path::Path::new("fuzz.dng"));
});
