//! Real-camera DNG files (issue 5) in `../shared/data/dng/` (or the folder named by
//! `CAMSIM_REAL_DNG_DIR`): a Canon EOS 550D DNG of a ColorChecker Passport (MIT, provenance and
//! the tag facts checked here in its PROVENANCE.md). `camsim analyze chart` on it is tested in
//! crates/camsim-cli/tests/chart_cli.rs.
//!
//! Per file: the reader decodes it (CFA data), the levels are consistent, the data stay below the
//! white level, and the two green sites of the 2 x 2 pattern agree (a decoder that mixes up
//! lossless-JPEG predictors, tiles, bit packing or byte order does not give two matching greens).

use camsim_core::raw::CfaChannel;
use std::path::PathBuf;

fn dng_dir() -> PathBuf {
    std::env::var_os("CAMSIM_REAL_DNG_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/dng")
        })
}

#[test]
fn real_camera_dngs_decode_consistently() {
    let dir = dng_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("dng")))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .dng files in {}", dir.display());
    for path in &files {
        let (raw, info) =
            camsim_io::dng::read_dng(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let name = path.display();
        assert!(
            raw.rows >= 16 && raw.cols >= 16,
            "{name}: {} x {}",
            raw.rows,
            raw.cols
        );
        assert!(
            raw.black_level_dn < raw.white_level_dn && raw.white_level_dn <= 65535.0,
            "{name}: levels {} / {}",
            raw.black_level_dn,
            raw.white_level_dn
        );
        let over = raw
            .dn
            .iter()
            .filter(|&&v| v as f64 > raw.white_level_dn)
            .count();
        assert!(
            over * 1000 <= raw.dn.len(),
            "{name}: {over} samples above the white level"
        );
        // Mean of each of the four 2 x 2 sites above black, over the central half of the frame.
        let mut sum = [0f64; 4];
        let mut n = [0usize; 4];
        for r in raw.rows / 4..3 * raw.rows / 4 {
            for c in raw.cols / 4..3 * raw.cols / 4 {
                let k = (r & 1) * 2 + (c & 1);
                sum[k] += raw.at(r, c) as f64 - raw.black_level_dn;
                n[k] += 1;
            }
        }
        let mean: Vec<f64> = (0..4).map(|k| sum[k] / n[k] as f64).collect();
        let greens: Vec<f64> = (0..4)
            .filter(|&k| raw.cfa.channels()[k] == CfaChannel::G)
            .map(|k| mean[k])
            .collect();
        assert_eq!(greens.len(), 2, "{name}: CFA {:?}", raw.cfa);
        let (g1, g2) = (greens[0], greens[1]);
        assert!(
            g1 > 0.0 && (g1 - g2).abs() <= 0.05 * g1.max(g2),
            "{name}: green sites {g1:.1} vs {g2:.1} DN (compression {})",
            info.compression
        );
        println!(
            "{name}: {} x {}, compression {}, {:?}, site means {mean:.1?}",
            raw.cols, raw.rows, info.compression, raw.cfa
        );
    }
}

/// The Canon file's facts as PROVENANCE.md lists them (read there with tifffile/LibRaw): the
/// ActiveArea crop is applied, the CFA pattern, levels and percentiles inside the active area.
#[test]
fn canon_550d_dng_honours_its_active_area_and_levels() {
    let path = dng_dir().join("canon-550d-colorchecker-passport.dng");
    let (raw, info) = camsim_io::dng::read_dng(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(info.stored_size, (1182, 1888));
    assert_eq!(info.active_area, [26, 152, 1182, 1886]);
    assert_eq!(
        (raw.rows, raw.cols),
        (1156, 1734),
        "the image is cropped to the ActiveArea"
    );
    assert_eq!(raw.cfa, camsim_core::CfaPattern::Rggb);
    assert_eq!(info.bits_per_sample, 14);
    assert_eq!((raw.black_level_dn, raw.white_level_dn), (2056.0, 15000.0));
    let n = info.as_shot_neutral.expect("AsShotNeutral");
    assert!(
        (n[0] - 1.0).abs() < 1e-3 && (n[1] - 2.477).abs() < 1e-3 && (n[2] - 1.462).abs() < 1e-3,
        "{n:?}"
    );
    // The crop starts at the ActiveArea's top-left: compare with samples unpacked straight from
    // the file's one strip (StripOffsets 1536; 14-bit samples packed MSB-first, 1888 per row,
    // 3304 bytes per row, TIFF 6.0 FillOrder 1).
    let bytes = std::fs::read(&path).unwrap();
    let sample = |row: usize, col: usize| -> u16 {
        let bit = (1536 + row * 3304) * 8 + col * 14;
        let word = u32::from_be_bytes([bytes[bit / 8], bytes[bit / 8 + 1], bytes[bit / 8 + 2], 0]);
        ((word >> (32 - 14 - bit % 8)) & 0x3fff) as u16
    };
    for (r, c) in [(0, 0), (0, 1), (1, 0), (577, 866), (1155, 1733), (409, 542)] {
        assert_eq!(
            raw.at(r, c),
            sample(26 + r, 152 + c),
            "pixel ({r}, {c}) of the active area"
        );
    }
    // Levels inside the active area: the 1st percentile sits at the black level (dark scene
    // parts), nothing reaches the white level (PROVENANCE.md: nothing clipped).
    let mut v = raw.dn.clone();
    v.sort_unstable();
    let pct = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize] as f64;
    assert!(
        (pct(0.01) - 2056.0).abs() < 20.0,
        "1st percentile {}",
        pct(0.01)
    );
    assert!(
        pct(0.5) > 2056.0 && (*v.last().unwrap() as f64) < raw.white_level_dn,
        "median {} max {}",
        pct(0.5),
        v.last().unwrap()
    );
}
