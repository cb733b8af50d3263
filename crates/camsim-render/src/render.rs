//! The film and the render loop: passes of samples over 16 x 16 tiles in parallel (rayon),
//! deterministic for any thread count, with a sample-count or time-budget stop.
//!
//! Determinism: with the Sobol sampler (default) sample `i` of pixel (x, y) depends only on
//! (seed, x, y, i) (`crate::sampler`); with the independent sampler the random stream of tile
//! `k` in pass `p` is `camsim_core::rng::keyed(seed, stage::RENDER, p, k)`. Each tile is
//! rendered sequentially by one thread, and passes are added to the film in pass order, so the
//! radiance is bit-identical for any number of threads. Passes hold [`SAMPLES_PER_PASS`] samples per pixel (fewer in the
//! last one); a time budget is checked between passes, so a render that stopped after `k` passes
//! equals a render with `samples_per_pixel = k * SAMPLES_PER_PASS` of the same seed.

pub use crate::error::RenderError;

use crate::camera::CameraRig;
use crate::filter::FilterSampler;
use crate::integrator::{RayCounts, Tracer};
use crate::light_groups::GroupRadiance;
use crate::motion::{PathTime, TimeCache};
use crate::sampler::{dim, IndependentSampler, PathSampler, SamplerKind, SobolSampler};
use crate::scene::SceneDescription;
use crate::spectral::WavelengthSampler;
use camsim_core::image::ImageGeometry;
use camsim_core::rng::{keyed, stage};
use camsim_core::{Quantity, SpectralImage};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Tile edge in pixels.
pub const TILE: usize = 16;
/// Samples per pixel in one pass (the granularity of the time budget).
pub const SAMPLES_PER_PASS: u32 = 8;

/// Ray and throughput counters of one render.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderStats {
    /// Primary rays (one per sample, plus one depth ray per pixel).
    pub camera_rays: u64,
    /// Closest-hit rays after a bounce.
    pub bounce_rays: u64,
    /// Shadow (visibility) rays of next-event estimation.
    pub shadow_rays: u64,
    /// Wall-clock time of the render, s (scene compile and BVH build included).
    pub seconds: f64,
    /// Camera samples (paths) per second.
    pub samples_per_second: f64,
    /// All rays (camera + bounce + shadow) per second.
    pub rays_per_second: f64,
}

/// What a render produces.
#[derive(Debug, Clone)]
pub struct RenderOutput {
    /// Spectral radiance, W/(sr m^2 nm), on `settings.grid`: each band holds the average of the
    /// radiance over that band's wavelength interval (`step_nm` wide). `geometry.fov_deg` is the
    /// horizontal field of view, `geometry.distance_m` the scene's focus distance (0 if none),
    /// `depth_m` is `Some(depth)`, and `sample_spacing_m` is the pixel pitch projected to the
    /// focus distance (or to 1 m when the scene has none): `2 d tan(hfov/2) / width`.
    pub radiance: SpectralImage,
    /// Distance along the camera's +z (optical) axis from the pinhole to the first surface
    /// through each pixel centre, m, row-major; `f32::INFINITY` where the ray escapes. For a lens
    /// camera (`realistic`, `raytransfer`) the pinhole is the lens's entrance pupil, with the
    /// image distance of its chief rays near the axis, so depth and ids line up with the image
    /// through the lens up to its distortion.
    pub depth_m: Vec<f32>,
    /// Per pixel: variance of the mean luminance estimate, (cd/m^2)^2, i.e. the sample variance
    /// of the per-sample luminance `683 sum L(lambda) ybar(lambda) dlambda` divided by the number
    /// of samples (y-bar from the Wyman et al. 2013 fit); 0 with fewer than 2 samples.
    pub variance: Vec<f32>,
    /// Samples taken per pixel: `samples_per_pixel` for every pixel, or fewer where adaptive
    /// sampling stopped it (`RenderSettings::adaptive`).
    pub samples_per_pixel: Vec<u32>,
    /// Object and material ids of the first surface through each pixel centre (the depth ray).
    pub ids: crate::ids::IdMaps,
    /// Optical flow for each interval of `settings.time.flow_intervals_s` (`crate::flow`).
    pub flow: Vec<crate::flow::FlowMap>,
    /// Ray counts and speed.
    pub stats: RenderStats,
    /// Training-data labels, when [`RenderRequest::labels`] asked for them.
    pub labels: Option<crate::labels::Labels>,
    /// With [`RenderRequest::light_groups`]: the radiance of each light group (sorted by name,
    /// [`crate::light_groups`]), on the radiance's grid and geometry; they sum to `radiance`.
    pub light_groups: Vec<(String, SpectralImage)>,
    /// The denoiser library the film (and the light-group films) went through, when
    /// `RenderSettings::denoise` asked for one ([`crate::denoise`]); `variance` is still the
    /// film's before denoising.
    pub denoised_with: Option<std::path::PathBuf>,
}

/// What a render computes besides radiance, depth and ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RenderRequest {
    /// The labels ([`crate::labels`]): instance map, boxes, camera, and the maps asked for.
    pub labels: Option<crate::labels::LabelRequest>,
    /// Split the radiance by light group, in the same pass ([`crate::light_groups`]).
    pub light_groups: bool,
    /// How next-event estimation chooses a light; `None`: the scene's own choice
    /// (`RenderSettings::light_sampler`, from a pbrt-v4 file's `lightsampler`).
    pub light_sampler: Option<LightSampler>,
}

/// How next-event estimation chooses among a scene's lights (pbrt-v4's `lightsampler`).
pub use camsim_scene3d::scene::LightSampler;

/// A raw pointer that tiles share to write their own disjoint pixels.
#[derive(Clone, Copy)]
struct SharedMut<T>(*mut T);
// SAFETY: every tile writes only the pixels it owns (disjoint index sets), and all writes of a
// pass finish (rayon joins) before anything reads the buffers.
unsafe impl<T> Send for SharedMut<T> {}
unsafe impl<T> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    /// The pointer (a method, so closures capture the whole `Sync` wrapper).
    #[inline(always)]
    fn ptr(&self) -> *mut T {
        self.0
    }
}

/// What every pixel of a render shares.
struct TraceCtx<'a> {
    tracer: &'a Tracer,
    rig: &'a CameraRig,
    ws: &'a WavelengthSampler,
    /// Film weight of one wavelength sample.
    splat: f32,
    /// Luminance weight per band, cd/m^2 per W/(sr m^2 nm) of one wavelength sample.
    lum_w: &'a [f64],
    /// The pixel filter: film positions and sample weights (`crate::filter`).
    filter: &'a FilterSampler,
    /// Bands of the output grid.
    bands: usize,
    /// Light groups, when the radiance is split by them.
    groups: Option<&'a crate::light_groups::GroupTable>,
    /// Per image row, its shutter window `[start, end]`, s, when the scene moves (else empty:
    /// no time is drawn).
    windows: &'a [(f64, f64)],
}

impl TraceCtx<'_> {
    /// The time of a path of row `y` from the uniform number drawn for it.
    #[inline]
    fn time_at(&self, y: usize, u: f32) -> f64 {
        let (a, b) = self.windows[y];
        a + (b - a) * u as f64
    }
}

/// A tile's light-group accumulators: `acc[(group * bands + band) * tile_px + local]`, and one
/// path's per-group radiance.
struct GroupAcc<'a, const N: usize> {
    acc: &'a mut [f64],
    scratch: &'a mut [[f32; N]],
    group_of: &'a [u16],
}

/// Adaptive sampling's per-sample channel weights and one pixel's sums: `weights[c * bands + b]`
/// (the channel's weight of band `b` times the film weight of one wavelength sample), and
/// `sums[2 c]`, `sums[2 c + 1]` the sums of channel `c`'s filter-weighted value and its square.
struct ChannelSums<'a> {
    weights: &'a [f64],
    sums: &'a mut [f64],
}

/// One pixel's share of a pass: samples `first .. first + count` of pixel (`x`, `y`).
struct PixelJob {
    x: usize,
    y: usize,
    first: u64,
    count: u32,
    /// Index of the pixel in its tile, and the tile's pixel count (band stride of `acc`).
    local: usize,
    tile_px: usize,
}

impl PixelJob {
    /// Trace the samples, add their filter-weighted spectral radiance to the tile accumulator
    /// `acc` (band-major) and return the sums of the weighted per-sample luminance (cd/m^2), of
    /// its square and of the filter weights; with `chan`, add each adaptive channel's sums too.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn trace<const N: usize, S: PathSampler>(
        &self,
        ctx: &TraceCtx,
        sampler: &mut S,
        acc: &mut [f64],
        mut split: Option<GroupAcc<'_, N>>,
        mut chan: Option<ChannelSums<'_>>,
        c: &mut RayCounts,
        cache: &TimeCache,
    ) -> [f64; 3] {
        let (mut ls, mut ls2, mut ws) = (0f64, 0f64, 0f64);
        for i in 0..self.count as u64 {
            sampler.start_sample(self.first + i);
            // Wavelength before film position: the independent sampler's draw order since
            // before the Sobol sampler, so its renders are unchanged.
            let u_l = sampler.get_1d(dim::WAVELENGTH);
            let [jx, jy] = sampler.get_2d(dim::FILM);
            let (lambdas, band) = ctx.ws.sample::<N>(u_l);
            // pbrt-v4 filter importance sampling: the film position from the filter, weight f/pdf.
            let (fx, fy, w_filter) = ctx.filter.film_point(self.x, self.y, [jx, jy]);
            // The path's time, uniform in its row's shutter window (pbrt-v4
            // `CameraBase::SampleTime`); a static scene draws none.
            let pt = if ctx.windows.is_empty() {
                PathTime::STATIC
            } else {
                cache.at(ctx.time_at(self.y, sampler.get_1d(dim::TIME)))
            };
            let (ray, w_cam) = if ctx.rig.has_lens() {
                // Realistic camera: a point in the exit pupil, the ray traced through the lens at
                // the hero wavelength and weighted (cos^4 A / D^2); a blocked ray carries nothing.
                let u_pupil = sampler.get_2d(dim::LENS);
                match ctx.rig.lens_ray(fx, fy, u_pupil, lambdas[0]) {
                    Some((ray, w)) => (Some(ctx.tracer.camera_ray(ray, &pt)), w),
                    None => (None, 0f32),
                }
            } else {
                (Some(ctx.tracer.camera_ray(ctx.rig.ray(fx, fy), &pt)), 1f32)
            };
            let l = match (&mut split, ray) {
                (_, None) => [0f32; N],
                (None, Some(ray)) => {
                    ctx.tracer
                        .radiance::<N, S>(ray, &ctx.ws.locate(lambdas), sampler, c, &pt)
                }
                (Some(g), Some(ray)) => {
                    g.scratch.fill([0f32; N]);
                    let mut sink = GroupRadiance {
                        total: [0f32; N],
                        groups: g.scratch,
                        group_of: g.group_of,
                    };
                    ctx.tracer.radiance_into(
                        ray,
                        &ctx.ws.locate(lambdas),
                        sampler,
                        c,
                        &pt,
                        &mut sink,
                    );
                    let total = sink.total;
                    // Each group's share, as the total's (non-finite values dropped).
                    let stride = ctx.bands * self.tile_px;
                    for (k, lg) in g.scratch.iter().enumerate() {
                        for j in 0..N {
                            let v = if lg[j].is_finite() && total[j].is_finite() {
                                lg[j] * w_cam * w_filter
                            } else {
                                0.0
                            };
                            g.acc[k * stride + band[j] as usize * self.tile_px + self.local] +=
                                (v * ctx.splat) as f64;
                        }
                    }
                    total
                }
            };
            let mut y_lum = 0f64;
            for j in 0..N {
                let v = if l[j].is_finite() { l[j] * w_cam } else { 0.0 };
                acc[band[j] as usize * self.tile_px + self.local] +=
                    (v * ctx.splat * w_filter) as f64;
                y_lum += v as f64 * ctx.lum_w[band[j] as usize];
            }
            let y_w = y_lum * w_filter as f64;
            ls += y_w;
            ls2 += y_w * y_w;
            ws += w_filter as f64;
            if let Some(ch) = &mut chan {
                for (k, w) in ch.weights.chunks_exact(ctx.bands).enumerate() {
                    let mut y = 0f64;
                    for j in 0..N {
                        if l[j].is_finite() {
                            y += (l[j] * w_cam) as f64 * w[band[j] as usize];
                        }
                    }
                    let y = y * w_filter as f64;
                    ch.sums[2 * k] += y;
                    ch.sums[2 * k + 1] += y * y;
                }
            }
        }
        [ls, ls2, ws]
    }
}

/// Render `scene`. `progress(done, total)` is called after every finished tile with the
/// number of tile-passes done and planned.
pub fn render(
    scene: &SceneDescription,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<RenderOutput, RenderError> {
    render_with(scene, &RenderRequest::default(), progress)
}

/// The peak memory of rendering `scene` with `request` (`crate::budget` sums it), checked by
/// [`render_with`] before anything is allocated.
pub fn memory_budget(
    scene: &SceneDescription,
    request: &RenderRequest,
) -> camsim_core::mem::MemoryBudget {
    crate::budget::memory_budget(
        scene,
        crate::budget::RenderNeeds {
            light_groups: request.light_groups,
            labels: request.labels.map(|l| (l.normals, l.albedo)),
            tile_px: TILE,
        },
    )
}

/// [`render`] with the extra outputs of `request` (labels).
pub fn render_with(
    scene: &SceneDescription,
    request: &RenderRequest,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<RenderOutput, RenderError> {
    let start = Instant::now();
    let st = &scene.settings;
    st.grid
        .validate()
        .map_err(|e| RenderError::Settings(e.to_string()))?;
    if st.samples_per_pixel == 0 {
        return Err(RenderError::Settings(
            "samples_per_pixel must be at least 1".into(),
        ));
    }
    if let Some(b) = st.time_budget_s {
        if b.is_nan() || b <= 0.0 {
            return Err(RenderError::Settings(format!(
                "time_budget_s = {b} s is not a positive number"
            )));
        }
    }
    let rig = CameraRig::new(&scene.camera).map_err(RenderError::Camera)?;
    // Everything the render will hold at once, before any of it is allocated.
    memory_budget(scene, request).check(crate::budget::ADVICE)?;
    // The denoiser's library, before the render: a missing one fails in a moment, not after it.
    let oidn = st
        .denoise
        .as_ref()
        .map(|d| crate::denoise::Oidn::load(d.library.as_deref()))
        .transpose()?;
    let ws = WavelengthSampler::new(&st.grid);
    let filter = FilterSampler::new(&st.filter)
        .map_err(|e| RenderError::Settings(format!("pixel filter: {e}")))?;
    let mut tracer = Tracer::new(scene, &ws)?;
    match request
        .light_sampler
        .unwrap_or(scene.settings.light_sampler)
    {
        LightSampler::Bvh => {}
        LightSampler::Power => tracer.lights.disable_spatial(),
        LightSampler::Uniform => tracer.lights.make_uniform(),
    }
    // Light groups follow motion: a hit on a moving emitter keeps its slot's light (moving
    // primitives' records follow the static ones in `Tracer::info`), and a moving light is
    // sampled in its reference pose under its own index (`Tracer::sample_light`).
    let groups = if request.light_groups {
        if tracer.media.as_ref().is_some_and(|m| m.emissive()) {
            return Err(RenderError::Settings(
                "light groups are not supported in scenes with an emissive medium (its emission belongs to no light group)".into(),
            ));
        }
        let g = crate::light_groups::GroupTable::new(scene, &tracer.light_source);
        Some(g)
    } else {
        None
    };
    // One monomorphised tracer per supported path width; the arguments are the same for all.
    macro_rules! run_n {
        ($n:literal) => {
            run::<$n>(
                scene,
                &tracer,
                &rig,
                &ws,
                &filter,
                groups.as_ref(),
                progress,
                start,
            )
        };
    }
    let mut out = match st.wavelengths_per_path {
        1 => run_n!(1),
        2 => run_n!(2),
        3 => run_n!(3),
        4 => run_n!(4),
        8 => run_n!(8),
        16 => run_n!(16),
        n => Err(RenderError::Settings(format!(
            "wavelengths_per_path = {n}; supported: 1, 2, 3, 4, 8, 16"
        ))),
    }?;
    if let Some(req) = request.labels {
        out.labels = Some(crate::labels::compute(
            scene, &tracer, &rig, &ws, req, None,
        )?);
    }
    if let Some(oidn) = &oidn {
        let t = Instant::now();
        // The guides: the labels' albedo and normals when they were asked for, else their own.
        let own = match &out.labels {
            Some(l) if l.albedo.is_some() && l.normal_camera.is_some() => None,
            _ => Some(crate::labels::compute(
                scene,
                &tracer,
                &rig,
                &ws,
                crate::labels::LabelRequest {
                    normals: true,
                    albedo: true,
                    amodal: false,
                },
                None,
            )?),
        };
        let l = own.as_ref().or(out.labels.as_ref()).expect("guides");
        let direct: Vec<bool> = out
            .ids
            .object_id
            .iter()
            .map(|&o| {
                o.checked_sub(1)
                    .and_then(|s| scene.shapes.get(s as usize))
                    .is_none_or(|shape| shape.area_light.is_some())
            })
            .collect();
        let guides = crate::denoise::Guides {
            albedo: l.albedo.as_deref(),
            normal: l.normal_camera.as_deref(),
            direct: Some(&direct),
        };
        out.radiance = crate::denoise::denoise(oidn, &out.radiance, guides)?;
        for (_, img) in &mut out.light_groups {
            *img = crate::denoise::denoise(oidn, img, guides)?;
        }
        out.stats.seconds += t.elapsed().as_secs_f64();
        out.denoised_with = Some(oidn.path().to_path_buf());
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn run<const N: usize>(
    scene: &SceneDescription,
    tracer: &Tracer,
    rig: &CameraRig,
    ws: &WavelengthSampler,
    filter: &FilterSampler,
    groups: Option<&crate::light_groups::GroupTable>,
    progress: &(dyn Fn(u64, u64) + Sync),
    start: Instant,
) -> Result<RenderOutput, RenderError> {
    let st = &scene.settings;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let pixels = width * height;
    let bands = st.grid.len();
    let hfov_deg = scene.camera.horizontal_fov_deg();
    let distance_m = scene.focus_distance_m.filter(|d| *d > 0.0 && d.is_finite());
    let spacing_m =
        distance_m.unwrap_or(1.0) * 2.0 * (hfov_deg.to_radians() / 2.0).tan() / width as f64;
    let mut radiance = SpectralImage::zeros(height, width, st.grid, spacing_m, Quantity::Radiance)?;
    radiance.geometry = ImageGeometry {
        fov_deg: hfov_deg,
        distance_m: distance_m.unwrap_or(0.0),
        ..Default::default()
    };
    let mut depth = vec![f32::INFINITY; pixels];
    let mut object_id = vec![0u32; pixels];
    // Per pixel: sums of the weighted luminance, its square and the filter weights.
    let mut lum = vec![[0f64; 3]; pixels];

    let tiles_x = width.div_ceil(TILE);
    let tiles_y = height.div_ceil(TILE);
    let n_tiles = tiles_x * tiles_y;
    let spp = st.samples_per_pixel;
    let n_passes = spp.div_ceil(SAMPLES_PER_PASS);
    let total_work = n_tiles as u64 * n_passes as u64;
    let done = AtomicU64::new(0);
    let splat = ws.splat_weight(N);
    // Luminance weight per band: 683 ybar(lambda_b) (hi - lo)/N per wavelength sample (CIE 1931 ybar).
    let ybar = camsim_core::colorimetry::Cmfs::on(&st.grid).y;
    let lum_w: Vec<f64> = (0..bands)
        .map(|b| {
            camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * ybar[b] * (ws.hi_nm - ws.lo_nm) as f64
                / N as f64
        })
        .collect();

    // Adaptive sampling: each channel's weight per band and wavelength sample (luminance's
    // `lum_w` when no channels are given), the pixels' channel sums, sample counts and flags.
    let adaptive = st.adaptive.as_ref();
    if let Some(a) = adaptive {
        a.validate(bands)
            .map_err(|e| RenderError::Settings(format!("adaptive sampling: {e}")))?;
    }
    let chan_w: Vec<f64> = match adaptive {
        None => Vec::new(),
        Some(a) if a.channels.is_empty() => lum_w.clone(),
        Some(a) => a
            .channels
            .iter()
            .flat_map(|w| w.iter().map(|v| v * splat as f64))
            .collect(),
    };
    let n_chan = if adaptive.is_some() {
        chan_w.len() / bands
    } else {
        0
    };
    let mut chan_sums = vec![0f64; 2 * n_chan * pixels];
    let chan_ptr = SharedMut(chan_sums.as_mut_ptr());
    let mut active = vec![true; if adaptive.is_some() { pixels } else { 0 }];
    let mut n_pix = vec![0u32; pixels];
    // The first test after `min_samples`, on a pass boundary.
    let first_test = adaptive.map_or(u32::MAX, |a| {
        a.min_samples.div_ceil(SAMPLES_PER_PASS) * SAMPLES_PER_PASS
    });

    // Row windows when something moves (`crate::motion`); a static scene samples no time.
    let time = &st.time;
    let windows: Vec<(f64, f64)> = if tracer.motion.is_some() {
        (0..height).map(|y| time.shutter.row_window_s(y)).collect()
    } else {
        Vec::new()
    };
    let flow_dts = &time.flow_intervals_s;
    let mut flow = vec![
        [0f32; 2];
        if tracer.motion.is_some() {
            pixels * flow_dts.len()
        } else {
            0
        }
    ];
    let ctx = TraceCtx {
        tracer,
        rig,
        ws,
        splat,
        lum_w: &lum_w,
        filter,
        bands,
        groups,
        windows: &windows,
    };
    let n_groups = groups.map_or(0, |g| g.names.len());
    // Light groups: band-sequential images one after the other.
    let mut group_data = vec![0f32; n_groups * bands * pixels];
    let group_ptr = SharedMut(group_data.as_mut_ptr());
    let flow_ptr = SharedMut(flow.as_mut_ptr());
    let img_ptr = SharedMut(radiance.data.as_mut_ptr());
    let depth_ptr = SharedMut(depth.as_mut_ptr());
    let id_ptr = SharedMut(object_id.as_mut_ptr());
    let lum_ptr = SharedMut(lum.as_mut_ptr());
    let mut counts_total = RayCounts::default();
    let mut samples_done = 0u32;

    for pass in 0..n_passes {
        let s0 = pass * SAMPLES_PER_PASS;
        let k = (spp - s0).min(SAMPLES_PER_PASS);
        let active_ref = &active;
        let counts: Vec<RayCounts> = (0..n_tiles)
            .into_par_iter()
            .map(|tile| {
                let (tx, ty) = (tile % tiles_x, tile / tiles_x);
                let (x0, y0) = (tx * TILE, ty * TILE);
                let (x1, y1) = ((x0 + TILE).min(width), (y0 + TILE).min(height));
                let mut rng = keyed(st.seed, stage::RENDER, pass as u64, tile as u64);
                let mut c = RayCounts::default();
                let cache = TimeCache::new(tracer.motion.as_deref());
                // This pass's sums for the tile, band-major (`acc[b * tile_px + local]`), written
                // to the band-sequential image once per tile: band by band, row by row, instead of
                // 31 pages apart for every pixel.
                let tw = x1 - x0;
                let tile_px = tw * (y1 - y0);
                let mut acc = vec![0f64; bands * tile_px];
                let mut acc_g = vec![0f64; n_groups * bands * tile_px];
                let mut scratch = vec![[0f32; N]; n_groups];
                for y in y0..y1 {
                    for x in x0..x1 {
                        let pix = y * width + x;
                        let local = (y - y0) * tw + (x - x0);
                        if pass == 0 {
                            // Depth, ids and flow: the scene at the start of the row's window.
                            let pt = match windows.get(y) {
                                Some(w) => cache.at(w.0),
                                None => PathTime::STATIC,
                            };
                            let r = tracer.camera_ray(rig.ray(x as f32 + 0.5, y as f32 + 0.5), &pt);
                            let forward = tracer.camera_vector(rig.forward, &pt);
                            let (d, id) = tracer.first_surface(&r, forward, &mut c, &pt);
                            // SAFETY: pixel `pix` belongs to this tile only.
                            unsafe {
                                *depth_ptr.ptr().add(pix) = d;
                                *id_ptr.ptr().add(pix) = id;
                            }
                            if !windows.is_empty() {
                                for (k, dt) in flow_dts.iter().enumerate() {
                                    let f = crate::flow::pixel_flow(tracer, rig, x, y, &pt, *dt);
                                    // SAFETY: pixel `pix` of every flow map belongs to this tile only.
                                    unsafe { *flow_ptr.ptr().add(k * pixels + pix) = f };
                                }
                            }
                        }
                        // A pixel that met its adaptive target takes no more samples (its
                        // samples so far were 0 .. s0: every pixel samples until it stops).
                        if !active_ref.is_empty() && !active_ref[pix] {
                            continue;
                        }
                        let px = PixelJob {
                            x,
                            y,
                            first: s0 as u64,
                            count: k,
                            local,
                            tile_px,
                        };
                        let chan = (n_chan > 0).then(|| ChannelSums {
                            weights: &chan_w,
                            // SAFETY: pixel `pix`'s sums belong to this tile only.
                            sums: unsafe {
                                std::slice::from_raw_parts_mut(
                                    chan_ptr.ptr().add(2 * n_chan * pix),
                                    2 * n_chan,
                                )
                            },
                        });
                        let split = ctx.groups.map(|g| GroupAcc {
                            acc: &mut acc_g,
                            scratch: &mut scratch,
                            group_of: &g.group_of,
                        });
                        let sums = match st.sampler {
                            SamplerKind::Independent => {
                                let mut smp = IndependentSampler { rng: &mut rng };
                                px.trace::<N, _>(
                                    &ctx, &mut smp, &mut acc, split, chan, &mut c, &cache,
                                )
                            }
                            SamplerKind::Sobol => {
                                let mut smp = SobolSampler::new(st.seed, x as u32, y as u32);
                                px.trace::<N, _>(
                                    &ctx, &mut smp, &mut acc, split, chan, &mut c, &cache,
                                )
                            }
                        };
                        // SAFETY: pixel `pix` belongs to this tile only.
                        unsafe {
                            let e = &mut *lum_ptr.ptr().add(pix);
                            for (a, b) in e.iter_mut().zip(sums) {
                                *a += b;
                            }
                        }
                    }
                }
                for (b, plane) in acc.chunks_exact(tile_px).enumerate() {
                    for (ly, row) in plane.chunks_exact(tw).enumerate() {
                        let start = b * pixels + (y0 + ly) * width + x0;
                        // SAFETY: these `tw` samples of band `b` belong to this tile only.
                        let dst =
                            unsafe { std::slice::from_raw_parts_mut(img_ptr.ptr().add(start), tw) };
                        for (d, a) in dst.iter_mut().zip(row) {
                            *d += *a as f32;
                        }
                    }
                }
                // The groups' planes, (group, band) after (group, band), as the total's.
                for (gb, plane) in acc_g.chunks_exact(tile_px).enumerate() {
                    for (ly, row) in plane.chunks_exact(tw).enumerate() {
                        let start = gb * pixels + (y0 + ly) * width + x0;
                        // SAFETY: these `tw` samples of plane `gb` belong to this tile only.
                        let dst = unsafe {
                            std::slice::from_raw_parts_mut(group_ptr.ptr().add(start), tw)
                        };
                        for (d, a) in dst.iter_mut().zip(row) {
                            *d += *a as f32;
                        }
                    }
                }
                let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(d, total_work);
                c
            })
            .collect();
        for c in counts {
            counts_total.camera += c.camera;
            counts_total.bounce += c.bounce;
            counts_total.shadow += c.shadow;
        }
        samples_done += k;
        if let Some(a) = adaptive {
            for (n, on) in n_pix.iter_mut().zip(&active) {
                if *on {
                    *n += k;
                }
            }
            if samples_done >= first_test && samples_done < spp {
                let still = adaptive_step(a, &mut active, &lum, &chan_sums, &n_pix, n_chan, width);
                if still == 0 {
                    break;
                }
            }
        }
        if let Some(budget) = st.time_budget_s {
            if start.elapsed().as_secs_f64() >= budget {
                break;
            }
        }
    }

    if adaptive.is_none() {
        n_pix.fill(samples_done);
    }
    let total_samples: f64 = n_pix.iter().map(|n| *n as f64).sum();
    // A pixel is the weighted mean of its samples, sum(w L) / sum(w) (pbrt-v4 `RGBFilm`; a
    // zero weight sum leaves 0). With the default box filter every weight is 1 and sum(w) = n.
    let inv_w: Vec<f32> = lum
        .iter()
        .map(|e| if e[2] != 0.0 { 1.0 / e[2] as f32 } else { 0.0 })
        .collect();
    radiance
        .data
        .par_chunks_mut(pixels)
        .for_each(|band| band.iter_mut().zip(&inv_w).for_each(|(v, k)| *v *= k));
    // Light groups: (group, band) planes one after the other, each normalised as the total.
    group_data
        .par_chunks_mut(pixels)
        .for_each(|plane| plane.iter_mut().zip(&inv_w).for_each(|(v, k)| *v *= k));

    let light_groups: Vec<(String, SpectralImage)> = match groups {
        None => Vec::new(),
        Some(g) => g
            .names
            .iter()
            .zip(group_data.chunks_exact(bands * pixels))
            .map(|(name, data)| {
                let mut img = SpectralImage::zeros(
                    height,
                    width,
                    st.grid,
                    radiance.sample_spacing_m,
                    Quantity::Radiance,
                )?;
                img.geometry = radiance.geometry;
                img.data.copy_from_slice(data);
                Ok((name.clone(), img))
            })
            .collect::<Result<_, RenderError>>()?,
    };
    // The variance of the mean of the weighted luminance, over the squared mean weight (the
    // ratio estimator's variance to first order; exactly the sample variance / n for weights 1).
    let variance: Vec<f32> = lum
        .iter()
        .zip(&n_pix)
        .map(|([s, s2, w], n)| mean_variance(*s, *s2, *w, *n) as f32)
        .collect();
    radiance.depth_m = Some(depth.clone());
    let seconds = start.elapsed().as_secs_f64();
    let rays = counts_total.camera + counts_total.bounce + counts_total.shadow;
    let stats = RenderStats {
        camera_rays: counts_total.camera,
        bounce_rays: counts_total.bounce,
        shadow_rays: counts_total.shadow,
        seconds,
        samples_per_second: total_samples / seconds,
        rays_per_second: rays as f64 / seconds,
    };
    let ids = crate::ids::IdMaps::from_object_ids(scene, width, height, object_id);
    let flow = crate::flow::flow_maps(flow_dts, flow, width, height);
    Ok(RenderOutput {
        radiance,
        depth_m: depth,
        variance,
        samples_per_pixel: n_pix,
        ids,
        flow,
        stats,
        labels: None,
        light_groups,
        denoised_with: None,
    })
}

/// The variance of a pixel's weighted mean `s / w` from its `n` samples' sums of the weighted
/// value `s`, its square `s2` and the weights `w`: the sample variance over `n`, over the
/// squared mean weight (the ratio estimator's variance to first order; exactly the sample
/// variance / n for weights 1). 0 with fewer than 2 samples or no weight.
#[inline]
fn mean_variance(s: f64, s2: f64, w: f64, n: u32) -> f64 {
    let n = n as f64;
    let mean_w = w / n;
    if n >= 2.0 && mean_w != 0.0 {
        ((s2 - s * s / n) / (n - 1.0)).max(0.0) / n / (mean_w * mean_w)
    } else {
        0.0
    }
}

/// One adaptive test between passes ([`camsim_scene3d::scene::AdaptiveSampling`]): a pixel still
/// sampling has converged when every channel's variance of the mean is within the target; it
/// stops when it and its 8 neighbours (those inside the image) have converged or stopped.
/// Returns how many pixels go on. Sequential and in pixel order, so the same for any thread
/// count.
fn adaptive_step(
    a: &camsim_scene3d::scene::AdaptiveSampling,
    active: &mut [bool],
    lum: &[[f64; 3]],
    chan_sums: &[f64],
    n_pix: &[u32],
    n_chan: usize,
    width: usize,
) -> usize {
    let pixels = active.len();
    let height = pixels / width.max(1);
    let rel2 = a.relative * a.relative;
    let floor2 = a.floor * a.floor;
    let converged: Vec<bool> = (0..pixels)
        .map(|p| {
            if !active[p] {
                return true;
            }
            let w = lum[p][2];
            if w == 0.0 {
                return true;
            }
            chan_sums[2 * n_chan * p..2 * n_chan * (p + 1)]
                .chunks_exact(2)
                .all(|s| {
                    let mean = s[0] / w;
                    let var = mean_variance(s[0], s[1], w, n_pix[p]);
                    var <= rel2 * mean * mean + a.shot * mean.max(0.0) + floor2
                })
        })
        .collect();
    let mut still = 0;
    for y in 0..height {
        for x in 0..width {
            let p = y * width + x;
            if !active[p] {
                continue;
            }
            let (y0, y1) = (y.saturating_sub(1), (y + 1).min(height - 1));
            let (x0, x1) = (x.saturating_sub(1), (x + 1).min(width - 1));
            let done = (y0..=y1).all(|yy| (x0..=x1).all(|xx| converged[yy * width + xx]));
            if done {
                active[p] = false;
            } else {
                still += 1;
            }
        }
    }
    still
}
