//! Property tests (issue 25, the reliability suite on stable): damaged OpenEXR files (bytes
//! flipped, overwritten with extreme values, cut short) never panic, hang or allocate without
//! limit in camsim's EXR readers; each read gives Ok or an error that names the file. The
//! cargo-fuzz target `fuzz/fuzz_targets/read_exr.rs` explores the same readers without bounds.

use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_io::exr::{self, ExrCompression, ExrOptions, ExrPrecision};
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// Small valid spectral EXRs to damage: uncompressed f32 and ZIP-compressed f16.
fn originals() -> &'static [Vec<u8>] {
    static O: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    O.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let grid = WavelengthGrid::new(400.0, 460.0, 20.0).unwrap();
        let mut img = SpectralImage::zeros(5, 7, grid, 1e-5, Quantity::Radiance).unwrap();
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = 0.01 * i as f32;
        }
        img.depth_m = Some(vec![2.0; 35]);
        [
            (ExrPrecision::F32, ExrCompression::None),
            (ExrPrecision::F16, ExrCompression::Zip),
        ]
        .iter()
        .map(|&(precision, compression)| {
            let p = dir.path().join("r.exr");
            exr::write_spectral_exr_with(
                &p,
                &img,
                "scene",
                ExrOptions {
                    precision,
                    compression,
                },
            )
            .unwrap();
            std::fs::read(&p).unwrap()
        })
        .collect()
    })
}

fn read_all(path: &Path) {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    for r in [
        exr::read_spectral_exr(path).map(|_| ()),
        exr::read_gray_exr(path, None).map(|_| ()),
        exr::read_channels_exr(path).map(|_| ()),
    ] {
        if let Err(e) = r {
            assert!(e.to_string().contains(&name), "{e}");
        }
    }
    let _ = camsim_io::claim::written_by_camsim(path);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn damaged_exr_files_never_panic(
        which in 0usize..2,
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..4), 1..12),
        cut in prop::option::of(any::<prop::sample::Index>()),
    ) {
        // A damaged header may claim a huge image: the readers must refuse it, not allocate it.
        std::env::set_var("CAMSIM_MEMORY_LIMIT_MIB", "512");
        let mut b = originals()[which].clone();
        for (at, byte, how) in edits {
            let i = at.index(b.len());
            match how {
                0 => b[i] ^= byte | 1,
                1 => b[i] = byte,
                // An extreme 32-bit value (offsets, sizes, counts, samples).
                2 => {
                    let v = [u32::MAX, 0x7f7f_ffff, 0x8000_0000, 0x7fc0_0000][byte as usize % 4];
                    let end = (i + 4).min(b.len());
                    b[i..end].copy_from_slice(&v.to_le_bytes()[..end - i]);
                }
                _ => {
                    let end = (i + 8).min(b.len());
                    b[i..end].fill(0xff);
                }
            }
        }
        if let Some(c) = cut {
            b.truncate(c.index(b.len()));
        }
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("damaged.exr");
        std::fs::write(&p, &b).unwrap();
        read_all(&p);
    }
}
