use camsim_optics::conv::{OutputWindow, TileConvolver};
use camsim_optics::{Optics, OpticsConfig};
use std::time::Instant;
fn main() {
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.focus_distance_m = Some(0.3);
    let o = Optics::from_config(&c).unwrap();
    let wf = o.wavefront_for(Some(0.3), 0.5).unwrap();
    let k = wf.kernel_size(700.0, 1.4e-6, 0.005);
    let t = Instant::now();
    let psf = wf.psf(400.0, 1.4e-6, k).unwrap();
    println!("K = {k}; psf 400 nm: {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let t = Instant::now();
    let _ = wf.psf(700.0, 1.4e-6, k).unwrap();
    println!("psf 700 nm: {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let conv = match std::env::var("TILE") { Ok(v) => TileConvolver::with_tile(k, v.parse().unwrap()), Err(_) => TileConvolver::new(k) };
    println!("F = {}, T = {}", conv.f, conv.t);
    let spec = conv.kernel_spectrum(&psf.to_f32());
    let mut s = conv.scratch();
    let (rows, cols) = (conv.t * 4, conv.t * 4);
    let img = vec![1.0f32; rows * cols];
    let win = OutputWindow { rows, cols, off_r: 0, off_c: 0 };
    let mut out = vec![0.0f32; rows * cols];
    let t = Instant::now();
    let n = 16;
    for i in 0..n {
        let (r0, c0) = ((i / 4) * conv.t, (i % 4) * conv.t);
        conv.tile(r0, c0, conv.t, conv.t, &spec, &mut out, win, &mut s, |r, dst| {
            dst.copy_from_slice(&img[(r0 + r) * cols + c0..(r0 + r) * cols + c0 + conv.t])
        });
    }
    let per = t.elapsed().as_secs_f64() / n as f64;
    println!("tile: {:.2} ms -> {:.1} ns per input pixel", per * 1e3, per / (conv.t * conv.t) as f64 * 1e9);
}
