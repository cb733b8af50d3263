//! Load time and peak memory of reading assets (BENCHMARKS.md, `scripts/bench_assets.py`):
//! reads every file given (glTF, GLB, OBJ) into a scene as `camsim render` does, and prints the
//! wall time, the triangles read and the process's peak resident memory (`VmHWM`).
//!
//! `cargo run --release -p camsim-assets --example load_assets -- FILE...`

use camsim_assets::{read_scene, ReadOptions};
use std::time::Instant;

fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn main() {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        eprintln!("usage: load_assets FILE...");
        std::process::exit(2);
    }
    let t0 = Instant::now();
    let mut tris = 0usize;
    for f in &files {
        match read_scene(std::path::Path::new(f), &ReadOptions::default()) {
            Ok(s) => {
                for sh in &s.shapes {
                    if let camsim_scene3d::Geometry::Triangles { indices, .. } = &sh.geometry {
                        tris += indices.len();
                    }
                }
            }
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{{\"files\": {}, \"triangles\": {tris}, \"seconds\": {dt:.4}, \"peak_rss_mib\": {:.1}}}",
        files.len(),
        peak_rss_mib()
    );
}
