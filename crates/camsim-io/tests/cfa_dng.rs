//! General CFA layouts (RGBW, Quad Bayer, CMYW) written to DNG and read back: the
//! CFARepeatPatternDim / CFAPattern / CFAPlaneColor tags carry the layout, the pixels are unchanged.

use camsim_core::{CfaLayout, CfaPattern, RawImage};
use camsim_io::dng::{read_dng, write_dng, DngMetadata};

fn frame(layout: Option<CfaLayout>) -> RawImage {
    let mut raw = RawImage::new(12, 16, CfaPattern::Rggb, 12).unwrap();
    for (i, v) in raw.dn.iter_mut().enumerate() {
        *v = (i * 37 % 4096) as u16;
    }
    raw.layout = layout;
    raw
}

#[test]
fn general_layouts_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let cmyw = CfaLayout::from_names(&[
        vec!["c".into(), "y".into(), "c".into()],
        vec!["w".into(), "m".into(), "w".into()],
    ])
    .unwrap();
    for layout in [
        CfaLayout::parse("RGBW").unwrap(),
        CfaLayout::parse("quad-bayer").unwrap(),
        cmyw,
    ] {
        let raw = frame(Some(layout.clone()));
        let path = dir.path().join("cfa.dng");
        write_dng(&path, &raw, &DngMetadata::default()).unwrap();
        let (back, _) = read_dng(&path).unwrap();
        assert_eq!(back.layout.as_ref(), Some(&layout), "{}", layout.name());
        assert_eq!(back.dn, raw.dn);
    }
    // A Bayer layout reads back as the plain Bayer pattern.
    let raw = frame(Some(CfaLayout::from_bayer(CfaPattern::Gbrg)));
    let path = dir.path().join("bayer.dng");
    write_dng(&path, &raw, &DngMetadata::default()).unwrap();
    let (back, _) = read_dng(&path).unwrap();
    assert_eq!((back.cfa, back.layout), (CfaPattern::Gbrg, None));
}

#[test]
fn a_filter_without_a_dng_code_is_an_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let ir = CfaLayout::from_names(&[vec!["r".into(), "g".into()], vec!["ir".into(), "b".into()]])
        .unwrap();
    let path = dir.path().join("ir.dng");
    let err = write_dng(&path, &frame(Some(ir)), &DngMetadata::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("'ir'") && err.contains("ir.dng"), "{err}");
    assert!(!path.exists());
}
