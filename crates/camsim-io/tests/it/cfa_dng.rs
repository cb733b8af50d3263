//! General CFA layouts (RGBW, Quad Bayer, CMYW) written to DNG and read back: the
//! CFARepeatPatternDim / CFAPattern / CFAPlaneColor tags carry the layout, the pixels are unchanged;
//! a layout with a filter DNG has no code for (RGB-IR) as a monochrome LinearRaw mosaic.

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

/// An RGB-IR mosaic: DNG's CFAPlaneColor has no code for `ir`, so the frame is written as a
/// monochrome LinearRaw image (PhotometricInterpretation 34892, one sample per pixel: any DNG
/// reader gets the exact ADC values) with the layout in DNGPrivateData, which camsim reads back.
#[test]
fn a_filter_without_a_dng_code_is_written_as_a_monochrome_mosaic_with_its_layout() {
    let dir = tempfile::tempdir().unwrap();
    let ir = CfaLayout::from_names(&[vec!["r".into(), "g".into()], vec!["ir".into(), "b".into()]])
        .unwrap();
    let mut raw = frame(Some(ir.clone()));
    raw.black_level_dn = 64.0;
    let path = dir.path().join("ir.dng");
    write_dng(&path, &raw, &DngMetadata::default()).unwrap();
    let (back, _) = read_dng(&path).unwrap();
    assert_eq!(back.layout.as_ref(), Some(&ir));
    assert_eq!(back.dn, raw.dn);
    assert_eq!((back.black_level_dn, back.white_level_dn), (64.0, 4095.0));
    // The file itself, as another reader sees it: one LinearRaw sample per pixel, no CFA tags.
    let bytes = std::fs::read(&path).unwrap();
    let t = camsim_io::tiff::Tiff::parse(&bytes).unwrap();
    let ifd = &t.ifds[0];
    let get = |tag: u16| ifd.entries.get(&tag).map(|e| t.uints(e).unwrap());
    assert_eq!(get(262), Some(vec![34892]), "PhotometricInterpretation");
    assert_eq!(get(277), Some(vec![1]), "SamplesPerPixel");
    assert_eq!(get(33422), None, "CFAPattern");
    let private: Vec<u8> = get(50740).unwrap().iter().map(|b| *b as u8).collect();
    assert!(private.starts_with(b"camsim\0cfa:r g/ir b"), "{private:?}");
}
