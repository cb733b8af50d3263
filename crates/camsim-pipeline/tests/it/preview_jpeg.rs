//! `preview-jpeg`: the run's preview as a baseline JPEG at `[isp] jpeg_quality`. Decoded, it is
//! the preview within the codec's quantization error (an independent decoder, the `image`
//! crate's), smaller and further from it at a lower quality.

use camsim_pipeline::{simulate, OutputSet, SimulateConfig, SimulateOptions};
use std::path::Path;

fn run(quality: u8, dir: &Path) -> (Vec<u8>, u64, f64) {
    let text = format!(
        "seed = 5\n[scene]\nkind = \"macbeth\"\nfov_deg = 2.0\npatch_size_px = 12\nborder_px = 2\n\
         [optics]\npreset = \"pixel4a\"\n[sensor]\npreset = \"pixel4a\"\nrows = 64\ncols = 96\n\
         [capture]\nexposure_ms = 5.0\n[isp]\njpeg_quality = {quality}\n"
    );
    let cfg = SimulateConfig::from_toml_str(&text, Path::new(".")).unwrap();
    let sim = simulate(&cfg, &SimulateOptions::default(), &|_, _, _| {}).unwrap();
    let out = dir.join(format!("q{quality}"));
    sim.write(
        &out,
        &OutputSet::parse("preview-jpeg").unwrap(),
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    let path = out.join("preview.jpg");
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(
        (img.height() as usize, img.width() as usize),
        (sim.preview.rows, sim.preview.cols)
    );
    let mean_abs = img
        .as_raw()
        .iter()
        .zip(&sim.preview.data)
        .map(|(a, b)| (*a as f64 - *b as f64).abs())
        .sum::<f64>()
        / img.as_raw().len() as f64;
    (
        img.into_raw(),
        std::fs::metadata(&path).unwrap().len(),
        mean_abs,
    )
}

#[test]
fn the_jpeg_preview_decodes_to_the_preview_within_its_quality() {
    let dir = tempfile::tempdir().unwrap();
    let (_, size_hi, err_hi) = run(95, dir.path());
    let (_, size_lo, err_lo) = run(20, dir.path());
    // Quality 95 keeps 8-bit sRGB values within a few codes on average; most of it is the
    // chroma subsampling at the chart's colour edges (2.96 codes measured on this 96 x 64 chart).
    assert!(err_hi < 4.0, "q95 mean |error| {err_hi:.2} codes");
    assert!(
        size_lo < size_hi && err_lo > err_hi,
        "q20 {size_lo} B, {err_lo:.2}; q95 {size_hi} B, {err_hi:.2}"
    );
}
