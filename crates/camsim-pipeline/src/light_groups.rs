//! `[render] light_groups`: one render, many lighting conditions. The renderer splits the
//! radiance by group of lights in one pass ([`camsim_render::light_groups`]); the scene image
//! the optics and sensor see is the weighted sum of the groups, which equals a render of the
//! scene with each group's lights scaled by its weight (tested in camsim-render).

use crate::{PipelineError, Result};
use camsim_core::SpectralImage;
use std::collections::BTreeMap;

/// Replace `image`'s values by `sum_g weights[g] groups[g]` (a group not in `weights` weighs
/// 1). The groups share `image`'s grid; its metadata (quantity, spacing, depth) stay. A weight
/// naming no group of the scene, or a negative or non-finite weight, is an error naming the key.
pub fn weigh(
    image: &mut SpectralImage,
    groups: &[(String, SpectralImage)],
    weights: &BTreeMap<String, f64>,
) -> Result<()> {
    for (name, w) in weights {
        if !groups.iter().any(|(g, _)| g == name) {
            let names: Vec<&str> = groups.iter().map(|(g, _)| g.as_str()).collect();
            return Err(PipelineError::config(format!(
                "render.light_groups.{name}: no light of the scene is in group {name:?} (its groups: {})",
                names.join(", ")
            )));
        }
        if !(w.is_finite() && *w >= 0.0) {
            return Err(PipelineError::config(format!(
                "render.light_groups.{name} = {w}: a weight must be a finite number >= 0"
            )));
        }
    }
    for (_, g) in groups {
        if g.data.len() != image.data.len() {
            return Err(PipelineError::config(
                "light groups: a group image differs in size from the render",
            ));
        }
    }
    let ws: Vec<f32> = groups
        .iter()
        .map(|(g, _)| weights.get(g).copied().unwrap_or(1.0) as f32)
        .collect();
    use rayon::prelude::*;
    image
        .data
        .par_chunks_mut(1 << 16)
        .enumerate()
        .for_each(|(k, out)| {
            let start = k << 16;
            for (i, v) in out.iter_mut().enumerate() {
                *v = groups
                    .iter()
                    .zip(&ws)
                    .map(|((_, g), w)| w * g.data[start + i])
                    .sum();
            }
        });
    Ok(())
}
