//! Helpers shared by the renderer's test binaries (each uses some of them).
#![allow(dead_code)]

use camsim_scene3d::{Geometry, Shape};

/// Where a dark-to-bright profile along a row first reaches half its bright level (the mean of
/// pixels w-8..w-2), pixels: pixel k covers [k, k + 1) and its value stands at its centre
/// k + 0.5, linear between centres.
pub fn half_crossing_px(prof: &[f64]) -> f64 {
    let w = prof.len();
    let hi = prof[w - 8..w - 2].iter().sum::<f64>() / 6.0;
    let i = (1..w)
        .find(|&i| prof[i - 1] < 0.5 * hi && prof[i] >= 0.5 * hi)
        .expect("an edge");
    i as f64 - 0.5 + (0.5 * hi - prof[i - 1]) / (prof[i] - prof[i - 1])
}

/// The first pixel of row `row` (image `w` wide) whose depth is finite: where the pinhole rays
/// start to meet a surface (the edge lies within half a pixel of its left border).
pub fn first_finite_px(depth_m: &[f32], w: usize, row: usize) -> f64 {
    depth_m[row * w..(row + 1) * w]
        .iter()
        .position(|d| d.is_finite())
        .expect("the pinhole rays meet the plane") as f64
}

/// The square `[-s, s]^2` in the plane z = 0, wound so its normal is +z, with material 0.
pub fn floor(s: f64) -> Shape {
    Shape {
        name: Some("floor".into()),
        geometry: Geometry::Triangles {
            positions: vec![[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            uvs: None,
            normals: None,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}
