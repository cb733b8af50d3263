//! Comparisons with Blender's Cycles: glTF and OBJ scenes exported by Blender's own exporters
//! (`../shared/scenes/gltf/`, README there) rendered by camsim and compared with Cycles'
//! renders of the same Blender scenes, by the criteria of the pbrt-v4 comparison
//! ([`crate::pbrt_reference`]): mean luminance within 1 % after the unit factor, at most 3 % of
//! 16 x 12 luminance blocks beyond 4 combined standard errors.
//!
//! Units: Cycles' scene-linear value 1 is the radiance of an emitter of strength 1. Blender's
//! glTF exporter writes an emission strength S as `emissiveStrength` S, which camsim reads as
//! S cd/m^2, so camsim's luminance (cd/m^2) equals Cycles' luminance (`0.2126 R + 0.7152 G +
//! 0.0722 B`, Rec. 709) for emissive-lit scenes (unit factor 1); it writes a point light of P W
//! as P 683 / (4 pi) cd, so for lamp-lit scenes camsim's luminance is 683 times Cycles' (unit
//! factor 683). Standard errors come from each renderer's two seeds (the variance of a pixel
//! from its seed difference, `(a - b)^2 / 2` per render).

use crate::{Result, ValidateError};
use camsim_core::colorimetry::Cmfs;
use camsim_core::SpectralImage;
use std::path::Path;

/// The outcome of [`compare_luminance`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct CyclesComparison {
    /// camsim's mean luminance over Cycles' times the unit factor: 1 when they agree.
    pub mean_ratio: f64,
    /// Its standard error (both renderers' seed differences).
    pub mean_ratio_se: f64,
    /// Blocks across and down (16 x 12).
    pub blocks: (usize, usize),
    /// Blocks whose mean luminance differs by more than 4 combined standard errors.
    pub blocks_off: usize,
    /// The largest |difference| / standard error over the blocks.
    pub worst_block_sigmas: f64,
}

impl CyclesComparison {
    /// Mean within 1 % and at most 3 % of the blocks off.
    pub fn pass(&self) -> bool {
        (self.mean_ratio - 1.0).abs() <= 0.01
            && self.blocks_off as f64 <= 0.03 * (self.blocks.0 * self.blocks.1) as f64
    }
}

/// A Cycles render's luminance per pixel (Rec. 709 weights of its linear R, G, B), row-major,
/// with its size ([`crate::pbrt_reference::exr_rgb_luminance`]).
pub fn load_cycles_luminance(path: &Path) -> Result<(usize, usize, Vec<f64>)> {
    crate::pbrt_reference::exr_rgb_luminance(path)
}

/// camsim's luminance per pixel, cd/m^2 (`683 sum y_bar L dl`, CIE 015:2018), band by band.
pub fn luminance_cd_m2(img: &SpectralImage) -> Vec<f64> {
    let cmfs = Cmfs::on(&img.grid);
    crate::pbrt_reference::luminance_of(
        img,
        &cmfs.y,
        camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * img.grid.step_nm,
    )
}

/// Compare two camsim seeds (luminance, cd/m^2) with two Cycles seeds (scene-linear
/// luminance) of the same size: `unit_factor` is camsim's luminance per unit of Cycles'.
pub fn compare_luminance(
    camsim: [&[f64]; 2],
    cycles: [&[f64]; 2],
    cols: usize,
    rows: usize,
    unit_factor: f64,
) -> Result<CyclesComparison> {
    let n = cols * rows;
    if [camsim[0], camsim[1], cycles[0], cycles[1]]
        .iter()
        .any(|v| v.len() != n)
    {
        return Err(ValidateError::invalid(
            "images to compare",
            format!("all four renders must be {cols} x {rows}"),
        ));
    }
    // Pixel means and the variances of the two-seed means, (a - b)^2 / 4.
    let stats = |v: [&[f64]; 2], k: f64| -> (Vec<f64>, Vec<f64>) {
        let m = (0..n).map(|p| k * (v[0][p] + v[1][p]) / 2.0).collect();
        let s = (0..n)
            .map(|p| (k * (v[0][p] - v[1][p])).powi(2) / 4.0)
            .collect();
        (m, s)
    };
    let (cm, cv) = stats(camsim, 1.0);
    let (ym, yv) = stats(cycles, unit_factor);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
    let (mc, my) = (mean(&cm), mean(&ym));
    if !(my > 0.0) {
        return Err(ValidateError::invalid("Cycles render", "is black"));
    }
    let ratio = mc / my;
    // Var(mean) = sum var / n^2; the ratio's relative variance is the sum of both.
    let var_c = cv.iter().sum::<f64>() / (n * n) as f64;
    let var_y = yv.iter().sum::<f64>() / (n * n) as f64;
    let se = ratio * (var_c / (mc * mc) + var_y / (my * my)).sqrt();
    let (nx, ny) = (16usize, 12usize);
    let (mut off, mut worst) = (0usize, 0f64);
    for by in 0..ny {
        for bx in 0..nx {
            let (x0, x1) = (bx * cols / nx, (bx + 1) * cols / nx);
            let (y0, y1) = (by * rows / ny, (by + 1) * rows / ny);
            let (mut a, mut b, mut va, mut vb, mut k) = (0.0, 0.0, 0.0, 0.0, 0usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = y * cols + x;
                    a += cm[p];
                    b += ym[p];
                    va += cv[p];
                    vb += yv[p];
                    k += 1;
                }
            }
            if k == 0 {
                continue;
            }
            let kk = k as f64;
            let sd = ((va + vb) / (kk * kk)).sqrt();
            let z = if sd > 0.0 {
                ((a - b) / kk).abs() / sd
            } else if a == b {
                0.0
            } else {
                f64::INFINITY
            };
            worst = worst.max(z);
            if z > 4.0 {
                off += 1;
            }
        }
    }
    Ok(CyclesComparison {
        mean_ratio: ratio,
        mean_ratio_se: se,
        blocks: (nx, ny),
        blocks_off: off,
        worst_block_sigmas: worst,
    })
}

/// One row of the Cycles table: a scene file (and the file whose camera it is seen through,
/// for OBJ files, which have none), the Cycles render name and the unit factor.
#[derive(Debug, Clone, Copy)]
pub struct CyclesScene {
    /// The scene file in `../shared/scenes/gltf/`.
    pub file: &'static str,
    /// The file whose camera renders it (OBJ files have none).
    pub camera_from: Option<&'static str>,
    /// The Cycles renders' name (`NAME-cycles-seed{1,2}.exr`).
    pub reference: &'static str,
    /// camsim's luminance (cd/m^2) per unit of Cycles' scene-linear luminance.
    pub unit_factor: f64,
}

/// The scenes of `../shared/scenes/gltf/` (README there).
pub const CYCLES_SCENES: [CyclesScene; 3] = [
    CyclesScene {
        file: "room.glb",
        camera_from: None,
        reference: "room",
        unit_factor: 1.0,
    },
    CyclesScene {
        file: "room.obj",
        camera_from: Some("room.glb"),
        reference: "room",
        unit_factor: 1.0,
    },
    CyclesScene {
        file: "textured.glb",
        camera_from: None,
        reference: "textured",
        unit_factor: 683.0,
    },
];

/// Render `scene` from `dir` as the Cycles references were made (256 x 192, box filter, 8
/// bounces) with two seeds of `spp` samples, and compare it with the two Cycles seeds.
pub fn compare_scene(dir: &Path, scene: &CyclesScene, spp: u32) -> Result<CyclesComparison> {
    let opts = camsim_scene3d::builtin::BuiltinOptions {
        resolution: Some((256, 192)),
        ..Default::default()
    };
    let read = |f: &str| {
        camsim_pipeline::render::read_scene_file(&dir.join(f), &opts)
            .map_err(|e| ValidateError::invalid("scene", e.to_string()))
    };
    let mut s = read(scene.file)?;
    if let Some(c) = scene.camera_from {
        s.camera = read(c)?.camera;
    }
    s.camera.width = 256;
    s.camera.height = 192;
    s.settings.samples_per_pixel = spp;
    s.settings.max_depth = 8;
    s.settings.filter = camsim_scene3d::PixelFilter::default();
    let mut lum = Vec::new();
    for seed in [1u64, 2] {
        s.settings.seed = seed;
        let out = camsim_render::render(&s, &|_, _| {})
            .map_err(|e| ValidateError::invalid("render", e.to_string()))?;
        lum.push(luminance_cd_m2(&out.radiance));
    }
    let (w, h, y1) =
        load_cycles_luminance(&dir.join(format!("{}-cycles-seed1.exr", scene.reference)))?;
    let (_, _, y2) =
        load_cycles_luminance(&dir.join(format!("{}-cycles-seed2.exr", scene.reference)))?;
    compare_luminance([&lum[0], &lum[1]], [&y1, &y2], w, h, scene.unit_factor)
}
