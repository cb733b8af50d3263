//! Quick timing of the full-size optics stage (see benches/blur.rs for the criterion figure).
use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::{Optics, OpticsConfig};
use std::time::Instant;
fn main() {
    let depth = std::env::args().any(|a| a == "depth");
    // `notail`: kernels only (psf.far_tail = false), to see what the far tail costs.
    let notail = std::env::args().any(|a| a == "notail");
    let (rows, cols) = (3024usize, 4032usize);
    let grid = WavelengthGrid::default();
    let d = 0.5;
    let f: f64 = 4.38e-3;
    let v = 1.0 / (1.0 / f - 1.0 / 0.3);
    let data = vec![0.01f32; rows * cols * grid.len()];
    let mut img =
        SpectralImage::from_data(rows, cols, grid, 1.4e-6 * d / v, Quantity::Radiance, data)
            .unwrap();
    img.geometry = ImageGeometry {
        fov_deg: 0.0,
        distance_m: d,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.focus_distance_m = Some(0.3);
    c.psf.far_tail = !notail;
    if depth {
        img.depth_m = Some(
            (0..rows * cols)
                .map(|i| 0.35 + 2.65 * (i % cols) as f32 / cols as f32)
                .collect(),
        );
        c.focus_distance_m = Some(0.5);
    }
    let o = Optics::from_config(&c).unwrap();
    for _ in 0..3 {
        let (u0, s0) = camsim_core::mem::process_cpu_s();
        let t = Instant::now();
        let out = o.compute(&img).unwrap();
        let (u1, s1) = camsim_core::mem::process_cpu_s();
        println!(
            "{} x {} x {} in {:.2} s wall, CPU user {:.2} s + sys {:.2} s (threads {})",
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
