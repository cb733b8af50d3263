//! Optics stage at full IMX363 size: 4032 x 3024 samples at 1.4 um, 31 bands (400-700 nm).
//!
//! - `shift_invariant_defocus`: pixel4a lens, scene at 0.5 m, focus at 0.3 m (c4 = 0.43 um over the
//!   lens pupil), one PSF per band, tiled FFT convolution.
//! - `depth_layered`: the same with a depth map from 0.35 m to 3 m across the image (focus 0.5 m),
//!   split into defocus layers (tolerance 0.02 um).
//! - `shift_variant_traced_lens`: the traced dgauss.82deg.4.38mm lens at f/2.8 (12 field heights,
//!   Zernike fits per height and wavelength, distortion and relative illumination), blockwise.
//! - `shift_variant_rtf`: the Pixel 4a ray-transfer function at its f/3.44 (traced spots with
//!   diffraction per height).
//!
//! The two shift-variant cases read the shared reference data (`../shared/data`); the goal
//! is <= 3x `shift_invariant_defocus`. `examples/time_shift_variant.rs` prints CPU times too.
//!
//! Run: `cargo bench -p camsim-optics --bench blur` (set RAYON_NUM_THREADS=2 for the 2-core figure).

use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::config::{BlurConfig, BlurKind, ShadingConfig, ShadingName};
use camsim_optics::{Optics, OpticsConfig};
use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;

fn scene(depth: bool) -> SpectralImage {
    let (rows, cols) = (3024usize, 4032usize);
    let grid = WavelengthGrid::default();
    let d = 0.5;
    let f: f64 = 4.38e-3;
    let v = 1.0 / (1.0 / f - 1.0 / 0.3);
    let scene_dx = 1.4e-6 * d / v;
    let mut data = vec![0.0f32; rows * cols * grid.len()];
    data.chunks_mut(cols).enumerate().for_each(|(i, row)| {
        let r = i % rows;
        for (c, v) in row.iter_mut().enumerate() {
            *v = if ((r / 64) + (c / 64)) % 2 == 0 {
                0.02
            } else {
                0.01
            };
        }
    });
    let mut img =
        SpectralImage::from_data(rows, cols, grid, scene_dx, Quantity::Radiance, data).unwrap();
    img.geometry = ImageGeometry {
        fov_deg: 0.0,
        distance_m: d,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    if depth {
        img.depth_m = Some(
            (0..rows * cols)
                .map(|i| 0.35 + 2.65 * (i % cols) as f32 / cols as f32)
                .collect(),
        );
    }
    img
}

fn optics(focus: f64) -> Optics {
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.focus_distance_m = Some(focus);
    c.shading = ShadingConfig::Named(ShadingName::Cos4);
    Optics::from_config(&c).unwrap()
}

/// The shift-variant optics from a traced lens file or an RTF file (shared reference data).
fn shift_variant(f_number: f64, lens: Option<&str>, rtf: Option<&str>) -> Optics {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens/"
    );
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.f_number = f_number;
    c.wavefront = Default::default();
    c.shading = ShadingConfig::Named(ShadingName::None);
    c.blur = Some(BlurConfig {
        method: BlurKind::ShiftVariant,
        field_heights: 12,
        block_px: None,
        rotation_oversampling: 3,
        lens_file: lens.map(|f| format!("{dir}{f}").into()),
        rtf_file: rtf.map(|f| format!("{dir}{f}").into()),
        field_zernike: None,
        measured_psf: None,
        ghosts: None,
    });
    Optics::from_config(&c).unwrap()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("optics_imx363_31bands");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(40));
    let img = scene(false);
    let o = optics(0.3);
    g.bench_function("shift_invariant_defocus", |b| {
        b.iter(|| o.compute(&img).unwrap())
    });
    drop(img);
    let img = scene(true);
    let o = optics(0.5);
    g.bench_function("depth_layered", |b| b.iter(|| o.compute(&img).unwrap()));
    drop(img);
    // The shift-variant cases image a scene at infinity on the sensor grid (1.4 um samples over
    // the lens's field of view), as examples/time_shift_variant.rs.
    let mut img = scene(false);
    img.sample_spacing_m = 1.4e-6;
    img.geometry = ImageGeometry {
        fov_deg: 2.0 * (4032.0 * 1.4e-6 / 2.0 / 4.38e-3f64).atan().to_degrees(),
        ..Default::default()
    };
    let o = shift_variant(2.8, Some("dgauss.82deg.4.38mm.json"), None);
    g.bench_function("shift_variant_traced_lens", |b| {
        b.iter(|| o.compute(&img).unwrap())
    });
    let o = shift_variant(
        3.44,
        None,
        Some("pixel4a-rearcamera-ellipse-raytransfer.json"),
    );
    g.bench_function("shift_variant_rtf", |b| b.iter(|| o.compute(&img).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
