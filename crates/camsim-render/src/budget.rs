//! The renderer's peak memory, summed before any of it is allocated
//! ([`camsim_core::mem::MemoryBudget`]): [`render_with`](crate::render_with) refuses a render
//! that would not fit with the image size, the bands, the largest buffers and the limit.
//!
//! What a render holds at once (bytes; `P` pixels, `B` bands, `G` light groups, `F` flow
//! intervals, `T` worker threads): from the first pass to the written files, the spectral film
//! (`4 P B`), the depth map and its copy in the film (`8 P`), the object and material id maps
//! (`8 P`), the variance and samples-per-pixel maps (`8 P`), the flow maps (`8 P F`, twice with
//! motion: the traced buffer and the maps cut from it), the light-group films (`4 P B G`, twice:
//! the accumulator and the images made from it) and the BVH; then the largest of three phases
//! that follow one another: the trace (per-pixel luminance sums and weights `24 P`, the inverse
//! weights `4 P`, per thread a tile's f64 sums `8 B (1 + G) TILE^2`, and with motion the rows'
//! shutter windows `16 H`; with adaptive sampling each pixel's channel sums, sample count and
//! flags, `(16 C + 6) P` for `C` channels), the labels (each row's buffers and the assembled maps),
//! the denoise ([`crate::denoise`]: its guide labels, the denoised film and the spectral
//! shape it is shared out by, `8 P B`, the broad-band
//! colour, its noisy copy, albedo, normals and result as FLOAT3 images, `60 P`, and OIDN's
//! scratch, `128 P`, the
//! last an estimate), or the writing of the outputs (the sRGB preview, the id maps as 16-bit PNGs, and the EXR writer's
//! blocks in flight: [`camsim_core::mem::WRITE_BATCH_BYTES`] twice at most).

use crate::scene::SceneDescription;
use camsim_core::mem::{MemoryBudget, WRITE_BATCH_BYTES};

/// BVH bytes per primitive: prim (44 B) + info (16 B) + normal (12 B) + bounds, centroid and
/// index during the build (40 B) + binary nodes (16 B) + wide nodes (43 B) + one packet per leaf
/// (<= 192 B / 2: leaves hold ~2 prims).
pub(crate) const BVH_BYTES_PER_PRIM: u64 = 256;

/// Bytes per pixel of the labels: each row's buffers and the assembled maps (instance and object
/// ids and depth, 12 B; normals in two frames, 24 B; spectral albedo and its sRGB, `4 B + 12`),
/// plus one u32 per pixel for the instances met along its ray (at least the first surface).
pub(crate) fn label_bytes_per_pixel(normals: bool, albedo: bool, bands: usize) -> u64 {
    let per_map = 12 + if normals { 24 } else { 0 } + if albedo { 4 * bands + 12 } else { 0 };
    2 * per_map as u64 + 4
}

/// What of a render request the budget depends on (the request itself is
/// `crate::RenderRequest`, whose `memory_budget` fills this in).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderNeeds {
    /// Light-group films are rendered.
    pub light_groups: bool,
    /// Labels are rendered: `(normals, albedo)`.
    pub labels: Option<(bool, bool)>,
    /// Side of a render tile, pixels.
    pub tile_px: usize,
}

/// The peak memory of rendering `scene` with what `needs` asks ([module docs](self)), on
/// `rayon::current_num_threads()` threads.
pub fn memory_budget(scene: &SceneDescription, needs: RenderNeeds) -> MemoryBudget {
    let tile = needs.tile_px.max(1);
    let (width, height) = (scene.camera.width, scene.camera.height);
    let st = &scene.settings;
    let bands = st.grid.len() as u64;
    let p = (width as u64).saturating_mul(height as u64);
    let px = |bytes_per_pixel: u64| p.saturating_mul(bytes_per_pixel);
    let motion = st.time.has_motion();
    let flows = st.time.flow_intervals_s.len() as u64;
    let groups = if needs.light_groups {
        crate::light_groups::light_group_names(scene).len() as u64
    } else {
        0
    };
    let film_bytes = px(4 * bands);
    let tiles = width.div_ceil(tile) * height.div_ceil(tile);
    let threads = rayon::current_num_threads().min(tiles.max(1)) as u64;
    let trace = px(24 + 4)
        + threads * 8 * bands * (1 + groups) * (tile * tile) as u64
        + if motion { 16 * height as u64 } else { 0 }
        + st.adaptive
            .as_ref()
            .map_or(0, |a| px(16 * a.channels.len().max(1) as u64 + 6));
    let labels = needs.labels.map_or(0, |(normals, albedo)| {
        px(label_bytes_per_pixel(normals, albedo, bands as usize))
    });
    let denoise = if st.denoise.is_some() {
        px(label_bytes_per_pixel(true, true, bands as usize))
            + film_bytes.saturating_mul(2 + groups)
            + px(5 * 12 + 128)
    } else {
        0
    };
    // The preview: XYZ (12 B), its luminances (4 B) and the sRGB bytes (3 B, and 3 B more as the
    // PNG encoder's image); the id maps as u16 (2 B); the EXR blocks in flight.
    let writing = px(12 + 4 + 3 + 3 + 2) + 2 * film_bytes.min(WRITE_BATCH_BYTES as u64);
    let (phase, phase_bytes) = [
        ("trace sums", trace),
        ("labels", labels),
        ("denoise", denoise),
        ("output writing", writing),
    ]
    .into_iter()
    .max_by_key(|(_, b)| *b)
    .expect("four phases");
    MemoryBudget::new(format!(
        "the render ({width} x {height} pixels, {bands} bands)"
    ))
    .bytes("spectral film", film_bytes)
    .bytes("depth maps", px(8))
    .bytes("id maps", px(8))
    .bytes("variance and sample counts", px(8))
    .bytes("flow maps", px(8 * flows * if motion { 2 } else { 1 }))
    .bytes("light-group films", film_bytes.saturating_mul(2 * groups))
    .bytes(
        "BVH",
        crate::integrator::prim_count(scene).saturating_mul(BVH_BYTES_PER_PRIM),
    )
    .bytes(phase, phase_bytes)
}

/// What to change when a render does not fit.
pub(crate) const ADVICE: &str =
    "use a smaller image (resolution, width x height), fewer wavelengths, or fewer light groups or labels";

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget of a closed-form render is the sum of its buffers, item by item.
    #[test]
    fn the_render_budget_is_the_sum_of_its_buffers() {
        let mut scene = camsim_scene3d::builtin::scene("cornell-box", &Default::default()).unwrap();
        scene.camera.width = 320;
        scene.camera.height = 240;
        let st = &scene.settings;
        assert!(!st.time.has_motion());
        let (p, b) = (320u64 * 240, st.grid.len() as u64);
        let f = st.time.flow_intervals_s.len() as u64;
        let prims = crate::integrator::prim_count(&scene);
        assert!(prims > 0);
        let threads = rayon::current_num_threads().min(20 * 15) as u64;
        let held = 4 * p * b + 8 * p + 8 * p + 8 * p + 8 * p * f + 256 * prims;
        // Plain render: the trace sums (28 B/px + a tile per thread) against the writing
        // (24 B/px + two EXR batches).
        let trace = 28 * p + threads * 8 * b * 256;
        let writing = 24 * p + 2 * (4 * p * b).min(64 << 20);
        let tile_px = 16;
        let plain = memory_budget(
            &scene,
            RenderNeeds {
                tile_px,
                ..Default::default()
            },
        )
        .total_bytes();
        assert_eq!(plain, held + trace.max(writing));
        // Labels with normals and albedo: 2 x (12 + 24 + 4 B + 12) + 4 bytes per pixel.
        let req = RenderNeeds {
            labels: Some((true, true)),
            light_groups: true,
            tile_px,
        };
        let g = crate::light_groups::light_group_names(&scene).len() as u64;
        assert_eq!(g, 1);
        let labels = (2 * (12 + 24 + 4 * b + 12) + 4) * p;
        let trace_g = 28 * p + threads * 8 * b * 2 * 256;
        let with = memory_budget(&scene, req).total_bytes();
        assert_eq!(
            with,
            held + 2 * 4 * p * b * g + labels.max(trace_g).max(writing)
        );
    }
}
