//! Timing of the full-size shift-variant blur against the shift-invariant one (release build):
//! `cargo run --release -p camsim-optics --example time_shift_variant [invariant|zernike|lens|rtf]...`
//! (default: all three). 4032 x 3024 x 31 bands, 1.4 um samples, the pixel4a lens geometry.
//! - invariant: the pixel4a preset with kernels (as examples/time_blur.rs, far tail on);
//! - zernike: shift-variant, 12 field heights, astigmatism growing with field height (rotated
//!   kernels);
//! - lens: shift-variant from the traced dgauss.82deg.4.38mm lens at f/2.8 (Zernike fits per
//!   field height and wavelength, distortion and relative illumination);
//! - rtf: shift-variant from the Pixel 4a ray-transfer function at its f/3.44 (traced spots with
//!   diffraction, distortion and relative illumination).
//!
//! `SV_BLOCK_PX=N` sets the shift-variant cases' `block_px` (default: the automatic tile).
use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::config::{BlurConfig, BlurKind, FieldZernikeConfig, ShadingConfig, ShadingName};
use camsim_optics::{Optics, OpticsConfig};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let which: Vec<&str> = if args.is_empty() {
        vec!["invariant", "zernike", "lens"]
    } else {
        args.iter().map(|s| s.as_str()).collect()
    };
    let (rows, cols) = (3024usize, 4032usize);
    let grid = WavelengthGrid::default();
    let f: f64 = 4.38e-3;
    let spacing = 1.4e-6;
    let data: Vec<f32> = (0..rows * cols * grid.len())
        .map(|i| 0.01 + 0.005 * ((i % 4032) / 64 % 2) as f32)
        .collect();
    let mut img =
        SpectralImage::from_data(rows, cols, grid, spacing, Quantity::Radiance, data).unwrap();
    let fov = 2.0 * (cols as f64 * spacing / 2.0 / f).atan().to_degrees();
    img.geometry = ImageGeometry {
        fov_deg: fov,
        distance_m: 0.0,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    for w in which {
        let mut c = OpticsConfig::preset("pixel4a").unwrap();
        let sv = |fz: Option<FieldZernikeConfig>,
                  lens: Option<std::path::PathBuf>,
                  rtf: Option<std::path::PathBuf>| BlurConfig {
            method: BlurKind::ShiftVariant,
            field_heights: 12,
            block_px: std::env::var("SV_BLOCK_PX")
                .ok()
                .and_then(|v| v.parse().ok()),
            rotation_oversampling: 3,
            lens_file: lens,
            rtf_file: rtf,
            field_zernike: fz,
            measured_psf: None,
            ghosts: None,
        };
        match w {
            "invariant" => {}
            "zernike" => {
                let row = |s: f64| vec![0.0, 0.0, 0.0, 0.0, 0.1 * s, 0.15 * s];
                c.blur = Some(sv(
                    Some(FieldZernikeConfig {
                        field_height_mm: None,
                        field_height_normalized: Some(vec![0.0, 1.0]),
                        zernike_um: vec![row(0.0), row(1.0)],
                    }),
                    None,
                    None,
                ));
            }
            "lens" => {
                c.f_number = 2.8;
                c.wavefront = Default::default();
                c.shading = ShadingConfig::Named(ShadingName::None);
                let p = std::path::PathBuf::from(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../../../shared/data/isetcornellbox/lens/dgauss.82deg.4.38mm.json"
                ));
                c.blur = Some(sv(None, Some(p), None));
            }
            "rtf" => {
                c.f_number = 3.44;
                c.wavefront = Default::default();
                c.shading = ShadingConfig::Named(ShadingName::None);
                let p = std::path::PathBuf::from(concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../../../shared/data/isetcornellbox/lens/pixel4a-rearcamera-ellipse-raytransfer.json"
                ));
                c.blur = Some(sv(None, None, Some(p)));
            }
            other => panic!("unknown case {other}: invariant, zernike, lens or rtf"),
        }
        let o = Optics::from_config(&c).unwrap();
        for _ in 0..2 {
            let (u0, s0) = camsim_core::mem::process_cpu_s();
            let t = Instant::now();
            let out = o.compute(&img).unwrap();
            let (u1, s1) = camsim_core::mem::process_cpu_s();
            println!(
                "{w}: {} x {} x {} in {:.2} s wall, CPU user {:.2} s + sys {:.2} s (threads {})",
                out.rows,
                out.cols,
                out.bands(),
                t.elapsed().as_secs_f64(),
                u1 - u0,
                s1 - s0,
                rayon::current_num_threads()
            );
        }
    }
}
