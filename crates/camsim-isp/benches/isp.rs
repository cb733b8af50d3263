//! Speed of the ISP stage at the IMX363's full resolution (4032 x 3024).
//! Run: `cargo bench -p camsim-isp --bench isp`.

use camsim_core::{tables, CfaPattern, RawImage, WavelengthGrid};
use camsim_isp::{demosaic_bilinear, ColorPipeline};
use criterion::{criterion_group, criterion_main, Criterion};

fn raw_full_res() -> RawImage {
    let (rows, cols) = (3024, 4032);
    let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 12).unwrap();
    raw.black_level_dn = 64.0;
    for (i, v) in raw.dn.iter_mut().enumerate() {
        *v = 64 + ((i * 2_654_435_761) % 3000) as u16;
    }
    raw
}

fn bench(c: &mut Criterion) {
    let raw = raw_full_res();
    let mut g = c.benchmark_group("isp_4032x3024");
    g.sample_size(10);
    g.bench_function("demosaic_bilinear", |b| b.iter(|| demosaic_bilinear(&raw)));
    let rgb = demosaic_bilinear(&raw);
    let grid = WavelengthGrid::default();
    // Any plausible QE will do for timing: the CIE CMFs.
    let qe = tables::cie1931_xyz_cmfs().map(|s| s.sample(&grid));
    let p = ColorPipeline::fit(&qe, &grid, &tables::illuminant("D65").unwrap()).unwrap();
    g.bench_function("render_srgb8_auto_exposure", |b| {
        b.iter(|| p.render_srgb8(&rgb, None))
    });
    g.bench_function("colour_fit", |b| {
        b.iter(|| ColorPipeline::fit(&qe, &grid, &tables::illuminant("A").unwrap()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
