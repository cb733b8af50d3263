//! Experiment: R/G of the ColorChecker's gray series at three positions from well-converged
//! renders (radiance x pixel4a QE, no sensor), to size the inter-reflection effect.
use camsim_scene3d::builtin::{self, BuiltinOptions, MccPosition};
fn main() {
    let spp: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(128);
    let res = (252usize, 189usize);
    let sensor = camsim_sensor::Sensor::preset("pixel4a").unwrap();
    for pos in [MccPosition::Left, MccPosition::Center, MccPosition::Right] {
        let bo = BuiltinOptions {
            resolution: Some(res),
            samples_per_pixel: spp,
            mcc_position: pos,
            seed: std::env::args()
                .nth(2)
                .and_then(|s| s.parse().ok())
                .unwrap_or(7),
            ..Default::default()
        };
        let scene = builtin::scene("cornell-box-mcc", &bo).unwrap();
        let t0 = std::time::Instant::now();
        let out = camsim_render::render(&scene, &|_, _| {}).unwrap();
        let rad = out.radiance;
        let grid = rad.grid;
        let qe = sensor.channel_qe(&grid);
        let (centers, side) = builtin::mcc_patch_centers_px(&bo).unwrap();
        let mut sums = [[0.0f64; 3]; 2];
        for (i, c) in centers.iter().enumerate() {
            let h = (side * 0.3).max(0.6);
            for y in (c[1] - h).floor() as usize..=(c[1] + h).floor() as usize {
                for x in (c[0] - h).floor() as usize..=(c[0] + h).floor() as usize {
                    for ch in 0..3 {
                        let v: f64 = (0..grid.len())
                            .map(|b| rad.at(y, x, b) as f64 * qe[ch][b] * grid.wavelength_nm(b))
                            .sum();
                        sums[0][ch] += v;
                        if i >= 18 {
                            sums[1][ch] += v;
                        }
                    }
                }
            }
        }
        println!("{pos:?}: all patches R/G {:.4} B/G {:.4}; gray R/G {:.4}  ({:.1} s, side {side:.1} px)", sums[0][0] / sums[0][1], sums[0][2] / sums[0][1], sums[1][0] / sums[1][1], t0.elapsed().as_secs_f64());
    }
}
