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
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// Upper critical value of chi-square with `k` degrees of freedom at the tail probability given
/// by the standard normal quantile `z` (Wilson & Hilferty 1931 approximation).
pub fn chi2_critical(k: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Pearson's chi-square of observed against expected counts, cells expecting fewer than 5
/// pooled into one (standard practice), which counts as a cell when it expects more than 5:
/// `(chi2, cells counted, pooled observed, pooled expected)`.
pub fn pooled_chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize, f64, f64) {
    let (mut chi2, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e > 5.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    }
    (chi2, dof, pool_o, pool_e)
}

/// A spectrum of value `v` at every wavelength (300-900 nm).
pub fn grey(v: f64) -> camsim_core::Spectrum {
    camsim_core::Spectrum::from_pairs(&[(300.0, v), (900.0, v)])
}

/// `shapes` seen by a `w` x `h` pinhole camera at the origin looking down +z (raster x along
/// world +x, raster y along world -y) with field `fov_deg` (the shorter side's): one black
/// diffuse material, no lights, one 100 nm band at 550 nm, `spp` samples, depth 1, seed 5, and
/// the time settings `time`.
pub fn origin_scene(
    w: usize,
    h: usize,
    fov_deg: f64,
    shapes: Vec<Shape>,
    spp: u32,
    time: camsim_scene3d::motion::TimeSettings,
) -> camsim_scene3d::SceneDescription {
    use camsim_scene3d::{Camera, Material, RenderSettings, SceneDescription, Texture, Transform};
    SceneDescription {
        camera: Camera {
            camera_to_world: Transform::identity(),
            fov_deg,
            width: w,
            height: h,
            lens: None,
        },
        shapes,
        materials: vec![Material::Diffuse {
            reflectance: Texture::Constant(grey(0.0)),
        }],
        named_materials: Default::default(),
        lights: vec![],
        settings: RenderSettings {
            grid: camsim_core::WavelengthGrid::new(500.0, 600.0, 100.0).unwrap(),
            samples_per_pixel: spp,
            max_depth: 1,
            seed: 5,
            time,
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: vec![],
        media: Default::default(),
        light_groups: Vec::new(),
    }
}

/// A small triangle inside the closed short block of the builtin Cornell box (material 0): no
/// ray can reach it.
pub fn hidden_in_cornell_block() -> Shape {
    Shape {
        name: Some("hidden".into()),
        geometry: Geometry::Triangles {
            positions: vec![[0.17, 0.05, 0.15], [0.2, 0.05, 0.15], [0.18, 0.08, 0.17]],
            indices: vec![[0, 1, 2]],
            uvs: None,
            normals: None,
            colors: None,
            uvs1: None,
            tangents: None,
        },
        material: 0,
        area_light: None,
        reverse_orientation: false,
        tags: Default::default(),
    }
}

/// Each pixel's luminance, cd/m^2: `683 sum_b L_b ybar_b d_lambda` of a render's radiance.
pub fn luminance(out: &camsim_render::RenderOutput) -> Vec<f64> {
    let grid = out.radiance.grid;
    let ybar = camsim_core::colorimetry::Cmfs::on(&grid).y;
    let px = out.radiance.rows * out.radiance.cols;
    (0..px)
        .map(|p| {
            (0..grid.len())
                .map(|b| out.radiance.data[b * px + p] as f64 * ybar[b] * grid.step_nm * 683.0)
                .sum()
        })
        .collect()
}
