//! Fuzz the lossless JPEG decoder directly (reaches deeper than through the DNG container).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = camsim_io::ljpeg::decode(data, 1 << 22);
});
