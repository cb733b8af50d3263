//! Speed of scene creation at the IMX363's full resolution (4032 x 3024 x 31 bands).
//! Run: `cargo bench -p camsim-scene --bench scene`.

use camsim_core::WavelengthGrid;
use camsim_scene::{create, MacbethScene, SceneConfig, SlantedEdgeScene};
use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let grid = WavelengthGrid::default();
    let mut g = c.benchmark_group("scene_31_bands");
    g.sample_size(10);
    // 6 x 640 + 7 x 16 = 3952 columns, 4 x 640 + 5 x 16 = 2640 rows.
    let macbeth = SceneConfig::Macbeth(MacbethScene {
        patch_size_px: 640,
        border_px: 16,
        ..Default::default()
    });
    g.bench_function("macbeth_3952x2640", |b| {
        b.iter(|| create(&macbeth, &grid).unwrap())
    });
    let edge = SceneConfig::SlantedEdge(SlantedEdgeScene {
        rows: 3024,
        cols: 4032,
        ..Default::default()
    });
    g.bench_function("slanted_edge_4032x3024", |b| {
        b.iter(|| create(&edge, &grid).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
