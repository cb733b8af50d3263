//! Time the per-pixel noise stage alone (EMVA series on the full imx363 frame: 1 bright + 1 dark
//! frame per level, 2 levels). `NOISE=fpn|temporal|none|all` picks the sources (development aid).
use camsim_core::WavelengthGrid;
use camsim_sensor::Sensor;
use std::time::Instant;
fn main() {
    let mut s = Sensor::preset("imx363").unwrap();
    let mut n = s.noise();
    match std::env::var("NOISE").as_deref() {
        Ok("fpn") => {
            n.shot = false;
            n.read = false;
        }
        Ok("temporal") => {
            n.prnu = false;
            n.dsnu = false;
        }
        Ok("none") => {
            n.shot = false;
            n.read = false;
            n.prnu = false;
            n.dsnu = false;
        }
        _ => {}
    }
    s = s.with_noise(n);
    let grid = WavelengthGrid::default();
    let spec = vec![1e-3; grid.len()];
    let target_e: f64 = std::env::var("TARGET_E")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3000.0);
    let t = target_e / s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap()[1];
    for _ in 0..3 {
        let t0 = Instant::now();
        let l = s
            .emva_series(&grid, &spec, &[t], 2, s.rows(), s.cols(), 1)
            .unwrap();
        println!(
            "4 frames: {:.3} s ({:.1} ns per pixel-frame per thread)",
            t0.elapsed().as_secs_f64(),
            t0.elapsed().as_secs_f64() * 1e9 / (4.0 * 12192768.0)
                * rayon::current_num_threads() as f64
        );
        drop(l);
    }
}
