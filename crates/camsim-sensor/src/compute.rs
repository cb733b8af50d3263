//! The sensor computation in ISETCam's order (`sensorCompute`, `sensorComputeNoise`):
//! irradiance -> pixel grid (area integration, fill factor) -> electrons (QE, lambda/(h c)) ->
//! dark current -> shot noise -> PRNU/DSNU -> read noise -> analog gain/offset -> clip -> quantize.

use crate::defects::DefectKind;
use crate::error::{Result, SensorError};
use crate::normal::Ziggurat;
use crate::poisson;
use crate::sensor::Sensor;
use camsim_core::rng::{keyed, stage};
use camsim_core::{mem, Quantity, RawImage, SpectralImage};
use rayon::prelude::*;

/// Shot noise is drawn from the exact Poisson distribution (inversion below a mean of 10,
/// Hörmann's PTRS above) below this mean and from a normal distribution with the same mean and variance (mu, mu) at or above it. The
/// normal draw is exact in mean and variance (all the EMVA 1288 analysis uses); its third moment
/// is 0 where Poisson's skewness is 1/sqrt(mu) <= 0.1. It makes a 12-MP frame several times faster.
pub const POISSON_EXACT_BELOW_E: f64 = 100.0;

/// How the exposure time is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// A given exposure time, s (>= 0).
    Seconds(f64),
    /// Auto-exposure: the time at which the 99th percentile of the noise-free signal of the
    /// brightest colour filter reaches `target_fraction` of the voltage swing after gain and
    /// offset (ISETCam `autoExposure`, a percentile per filter instead of the maximum). The
    /// percentile is taken over each filter's own pixels, so a white patch covering more than 1 %
    /// of the frame is never clipped by the mix of filters (over the whole mosaic, the reddest
    /// filter's white pixels are only 1/4 of the patch).
    Auto {
        /// Fraction of the voltage swing, in (0, 1].
        target_fraction: f64,
    },
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure::Auto {
            target_fraction: 0.9,
        }
    }
}

/// One capture: exposure, number of frames and the seed of the temporal noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capture {
    /// Exposure time or auto-exposure.
    pub exposure: Exposure,
    /// Frames of the same exposure (>= 1); each has new temporal noise, the same fixed pattern.
    pub frames: usize,
    /// Seed of the temporal noise (shot, read). The fixed pattern uses the sensor's own seed.
    pub seed: u64,
    /// A global-reset sensor mode read out row by row (`None`: every row integrates the
    /// exposure, as a global or rolling shutter does).
    pub global_reset: Option<GlobalReset>,
    /// The scene's light is modulated in time (LED flicker, [`crate::flicker`]): each frame's
    /// rows integrate it over their own windows. `None`: a steady light.
    pub light: Option<crate::flicker::LightTiming>,
}

/// A global-reset / rolling-readout capture (a CMOS sensor's "global reset release" mode): every
/// row is reset at the same instant and starts integrating, and the rows are then read one
/// after another, row r `extra(r)` after the first one read. Hamamatsu's camera glossary
/// ("Global reset trigger mode"): the first line exposes for the set exposure time, each later
/// line for the exposure time plus its readout delay. With a mechanical shutter that closes
/// for every row at the end of the exposure (the classic still-camera cycle, Kodak/Foveon F7
/// "global reset ... uses an external mechanical shutter"), light stops for all rows at once,
/// but the photodiode's dark current keeps integrating until its row is read: every row sees
/// the same light and row r `extra(r)` more dark charge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalReset {
    /// Readout delay of stored row 0 (raw.dng's top row) after the first row read, s.
    pub row0_extra_s: f64,
    /// Readout delay added per stored row, s (negative when the bottom row is read first).
    pub per_row_extra_s: f64,
    /// A mechanical shutter ends the light for every row at the end of the exposure.
    pub mechanical_shutter: bool,
}

impl GlobalReset {
    /// The readout delay of stored row `r`, s.
    #[inline]
    pub fn extra_s(&self, r: usize) -> f64 {
        self.row0_extra_s + self.per_row_extra_s * r as f64
    }

    /// (light, dark) integration times of stored row `r` for an exposure of `exposure_s`, s.
    #[inline]
    pub fn row_times_s(&self, r: usize, exposure_s: f64) -> (f64, f64) {
        let dark = exposure_s + self.extra_s(r);
        let light = if self.mechanical_shutter {
            exposure_s
        } else {
            dark
        };
        (light, dark)
    }
}

/// The mean over `rows` rows of their dark integration times, s.
pub(crate) fn mean_dark_s(g: Option<&GlobalReset>, rows: usize, exposure_s: f64) -> f64 {
    g.map_or(exposure_s, |g| {
        exposure_s + g.row0_extra_s + g.per_row_extra_s * rows.saturating_sub(1) as f64 / 2.0
    })
}

/// The weight of stored row `r`'s electron rates in a mean: 1 without a global reset (the mean
/// is then multiplied by the exposure, as it always was), its light time with one.
pub(crate) fn row_weight_s(g: Option<&GlobalReset>, r: usize, exposure_s: f64) -> f64 {
    g.map_or(1.0, |g| g.row_times_s(r, exposure_s).0)
}

/// (light, dark) integration times of stored row `r`: the exposure for both unless a global
/// reset extends them.
#[inline]
pub(crate) fn row_times_s(g: Option<&GlobalReset>, r: usize, exposure_s: f64) -> (f64, f64) {
    g.map_or((exposure_s, exposure_s), |g| g.row_times_s(r, exposure_s))
}

impl Default for Capture {
    fn default() -> Self {
        Capture {
            exposure: Exposure::default(),
            frames: 1,
            seed: 0,
            global_reset: None,
            light: None,
        }
    }
}

impl Capture {
    /// One frame of `exposure_s` seconds with seed 0.
    pub fn seconds(exposure_s: f64) -> Capture {
        Capture {
            exposure: Exposure::Seconds(exposure_s),
            frames: 1,
            seed: 0,
            global_reset: None,
            light: None,
        }
    }
    /// One auto-exposed frame (99th percentile at 90 % of the swing) with seed 0.
    pub fn auto() -> Capture {
        Capture::default()
    }
    /// The same capture with `frames` frames.
    pub fn with_frames(mut self, frames: usize) -> Capture {
        self.frames = frames;
        self
    }
    /// The same capture with temporal-noise seed `seed`.
    pub fn with_seed(mut self, seed: u64) -> Capture {
        self.seed = seed;
        self
    }
    /// The same capture in a global-reset mode.
    pub fn with_global_reset(mut self, global_reset: Option<GlobalReset>) -> Capture {
        self.global_reset = global_reset;
        self
    }

    /// The same capture under a modulated light (`None`: steady).
    pub fn with_light(mut self, light: Option<crate::flicker::LightTiming>) -> Capture {
        self.light = light;
        self
    }
}

/// The result of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// One raw mosaic per frame (black level = analog offset in DN, white level 2^bits - 1).
    pub raw: Vec<RawImage>,
    /// Exposure time used, s.
    pub exposure_s: f64,
    /// Noise-free mean electrons (photo + dark) over the pixels of each channel r, g, b (0 where a
    /// channel has no pixel).
    pub mean_electrons: [f64; 3],
    /// With the quantization switch off: per frame, the unrounded ADC value (volts x dn_per_v after
    /// gain, offset and clipping, plus the black-level pedestal), row-major. `None` otherwise.
    pub analog_dn: Option<Vec<Vec<f32>>>,
    /// Noise-free mean electrons (photo + dark) per filter of the sensor's CFA
    /// ([`Sensor::cfa_layout`] order: r, g, b, then e.g. w; 0 where a filter has no pixel).
    pub mean_electrons_by_filter: Vec<f64>,
}

impl Frame {
    /// Append a later frame's raws (and analog values) to these.
    pub(crate) fn append(&mut self, f: Frame) {
        self.raw.extend(f.raw);
        if let (Some(a), Some(b)) = (&mut self.analog_dn, f.analog_dn) {
            a.extend(b);
        }
    }
}

/// Offset of the centre of pixel `c` from the optical axis, m, for pixels of `pitch_m` centred
/// on the axis (`half_out` = pixel count / 2).
fn pixel_centre_m(c: usize, half_out: f64, pitch_m: f64) -> f64 {
    (c as f64 + 0.5 - half_out) * pitch_m
}

/// Where the centre of pixel `c` (of `n_out` pixels of `pitch_m`) lies on an input sampling of
/// `n_in` samples of `spacing_m`, both centred on the optical axis, in input samples (sample j
/// covers [j, j + 1)): the geometry [`Sensor::compute`] integrates with, for labels that follow
/// the image onto the pixel grid.
pub fn pixel_centre_on_input(
    c: usize,
    n_out: usize,
    pitch_m: f64,
    n_in: usize,
    spacing_m: f64,
) -> f64 {
    pixel_centre_m(c, n_out as f64 / 2.0, pitch_m) / spacing_m + n_in as f64 / 2.0
}

/// 1D area-integration weights from an input sampling (cells of `spacing` centred on the axis) to
/// output photodetectors (width `pd_width` centred in pixels of `pitch`, centred on the axis).
pub(crate) struct Axis {
    /// Per output index: first input index, and range into `w`.
    start: Vec<usize>,
    range: Vec<(usize, usize)>,
    w: Vec<f32>,
    /// Some((offset, first, last)) when output c (first <= c < last) maps to input c + offset with
    /// weight 1, and to nothing outside.
    identity: Option<(isize, usize, usize)>,
}

impl Axis {
    pub(crate) fn new(
        n_out: usize,
        pitch_m: f64,
        pd_width_m: f64,
        n_in: usize,
        spacing_m: f64,
    ) -> Axis {
        let mut start = Vec::with_capacity(n_out);
        let mut range = Vec::with_capacity(n_out);
        let mut w = Vec::new();
        let half_in = n_in as f64 / 2.0;
        let half_out = n_out as f64 / 2.0;
        for c in 0..n_out {
            let centre_m = pixel_centre_m(c, half_out, pitch_m);
            // In input-index units: cell j covers [j, j + 1].
            let lo = (centre_m - pd_width_m / 2.0) / spacing_m + half_in;
            let hi = (centre_m + pd_width_m / 2.0) / spacing_m + half_in;
            let width = hi - lo;
            let j0 = lo.floor().max(0.0) as usize;
            let j1 = (hi.ceil().min(n_in as f64)).max(0.0) as usize;
            let first_w = w.len();
            let mut first_j = usize::MAX;
            for j in j0..j1.max(j0) {
                let ov = (hi.min(j as f64 + 1.0) - lo.max(j as f64)) / width;
                if ov > 1e-7 {
                    if first_j == usize::MAX {
                        first_j = j;
                    }
                    // Keep contiguity: fill any skipped slivers with 0.
                    while first_j + (w.len() - first_w) < j {
                        w.push(0.0);
                    }
                    w.push(ov as f32);
                }
            }
            start.push(if first_j == usize::MAX { 0 } else { first_j });
            range.push((first_w, w.len()));
        }
        // Identity detection (same pitch and spacing, integer offset): the fast path.
        let mut first: Option<usize> = None;
        let mut last = 0;
        let mut offset: Option<isize> = None;
        let mut ok = true;
        for c in 0..n_out {
            let (a, b) = range[c];
            if b == a {
                continue;
            }
            if b - a != 1 || (w[a] - 1.0).abs() > 1e-5 {
                ok = false;
                break;
            }
            let o = start[c] as isize - c as isize;
            if *offset.get_or_insert(o) != o {
                ok = false;
                break;
            }
            if first.is_none() {
                first = Some(c);
            } else if last != c {
                ok = false;
                break;
            }
            last = c + 1;
        }
        let identity = if ok {
            // Snap the weights to exactly 1 (they differ from it by round-off only).
            w.iter_mut().for_each(|v| *v = 1.0);
            Some((offset.unwrap_or(0), first.unwrap_or(0), last))
        } else {
            None
        };
        Axis {
            start,
            range,
            w,
            identity,
        }
    }

    #[inline]
    pub(crate) fn entries(&self, c: usize) -> (usize, &[f32]) {
        let (a, b) = self.range[c];
        (self.start[c], &self.w[a..b])
    }

    /// The range `[first, end)` of input indices that any output index touches, or None when no
    /// output sees the input (the row buffer of the general integration path).
    pub(crate) fn input_span(&self) -> Option<(usize, usize)> {
        let (lo, hi) = (0..self.start.len()).fold((usize::MAX, 0usize), |(a, b), c| {
            let (s, w) = self.entries(c);
            if w.is_empty() {
                (a, b)
            } else {
                (a.min(s), b.max(s + w.len()))
            }
        });
        (lo < hi).then_some((lo, hi))
    }
}

impl Sensor {
    /// Compute raw frames from a sensor-plane spectral irradiance image (ISETCam `sensorCompute`).
    ///
    /// `irradiance` holds W/(m^2 nm) with `sample_spacing_m` at the sensor plane, centred on the
    /// optical axis like the sensor. Each pixel integrates the irradiance (piecewise constant over
    /// each sample's cell) over its photodetector, a centred square of area pitch^2 x fill factor;
    /// light outside the image is 0. Temporal noise is keyed on (capture seed, frame, row), the
    /// fixed pattern on (fixed_pattern_seed, row), so the output is bit-identical for any number
    /// of threads. NaN or negative irradiance counts as no light (the image is not scanned for them).
    pub fn compute(&self, irradiance: &SpectralImage, capture: &Capture) -> Result<Frame> {
        self.compute_from(irradiance, capture, 0)
    }

    /// [`Sensor::compute`] with the temporal noise of frame k keyed on frame index
    /// `first_frame + k`: the frames of a sequence whose irradiance changes from frame to frame
    /// (a moving scene, one irradiance per frame) get the noise they would have in one capture,
    /// each its own.
    pub fn compute_from(
        &self,
        irradiance: &SpectralImage,
        capture: &Capture,
        first_frame: u64,
    ) -> Result<Frame> {
        check_capture(capture)?;
        self.check_memory(capture.frames, 2)?;
        let rate = self.electron_rate_image(irradiance)?;
        self.capture_from_rate(&rate, self.rows(), self.cols(), capture, first_frame)
    }

    /// The exposure time `capture` gives this sensor for `irradiance`: its time, or the
    /// auto-exposure's metering ([`Exposure::Auto`]) of the noise-free signal (a dual-pixel
    /// sensor meters the whole pixel once, then captures both photodiodes at that time).
    pub fn metered_exposure_s(&self, irradiance: &SpectralImage, capture: &Capture) -> Result<f64> {
        if let Exposure::Seconds(t) = capture.exposure {
            return Ok(t);
        }
        let rate = self.electron_rate_image(irradiance)?;
        self.resolve_exposure(
            &rate,
            self.rows(),
            self.cols(),
            capture.exposure,
            capture.global_reset.as_ref(),
        )
    }

    /// Exposure bracketing / bursts (ISETCam: a vector `exposure time`, one capture per entry):
    /// `frames_per_exposure` raw frames for each exposure time of `exposures_s`, exposure-major
    /// (all frames of the first exposure, then the next...). Each raw carries its own
    /// `exposure_s`. Temporal noise of raw k (0-based, in that order) is keyed on frame index k
    /// with the capture `seed`, so every frame has independent shot and read noise and a
    /// one-entry list gives exactly [`Sensor::compute`]'s frames; the fixed pattern (DSNU, PRNU)
    /// is the sensor's own, the same in every frame. The returned [`Frame`]'s `exposure_s` and
    /// `mean_electrons` are those of the first exposure.
    pub fn compute_bracket(
        &self,
        irradiance: &SpectralImage,
        exposures_s: &[f64],
        frames_per_exposure: usize,
        seed: u64,
    ) -> Result<Frame> {
        let like = Capture::default()
            .with_frames(frames_per_exposure)
            .with_seed(seed);
        self.compute_bracket_like(irradiance, exposures_s, &like)
    }

    /// [`Sensor::compute_bracket`] with `like`'s frames per exposure, seed and global reset
    /// (its exposure is ignored: each entry of `exposures_s` is one).
    pub fn compute_bracket_like(
        &self,
        irradiance: &SpectralImage,
        exposures_s: &[f64],
        like: &Capture,
    ) -> Result<Frame> {
        let frames_per_exposure = like.frames;
        if exposures_s.is_empty() {
            return Err(SensorError::input(
                "exposures_s",
                "the list of exposure times is empty",
            ));
        }
        if let Some((i, t)) = exposures_s
            .iter()
            .enumerate()
            .find(|(_, t)| !exposure_in_range(**t))
        {
            return Err(SensorError::input(
                "exposures_s",
                format!("entry {i}: {t} s is outside [0, {MAX_EXPOSURE_S}] s (at most an hour)"),
            ));
        }
        if frames_per_exposure == 0 {
            return Err(SensorError::input("frames", "must be at least 1"));
        }
        self.check_memory(exposures_s.len().saturating_mul(frames_per_exposure), 2)?;
        let rate = self.electron_rate_image(irradiance)?;
        let mut out: Option<Frame> = None;
        // Back-to-back frames under a modulated light: exposure i's frames start after all the
        // earlier ones, its frame k of index base + k at (earlier exposures) + k t.
        let mut elapsed_s = 0.0;
        for (i, &t) in exposures_s.iter().enumerate() {
            let base = (i * frames_per_exposure) as u64;
            let light = like.light.map(|l| match l.frame_interval_s {
                Some(_) => l,
                None => crate::flicker::LightTiming {
                    start_s: l.start_s + elapsed_s - base as f64 * t,
                    ..l
                },
            });
            elapsed_s += frames_per_exposure as f64 * t;
            let capture = Capture {
                exposure: Exposure::Seconds(t),
                light,
                ..*like
            };
            let f = self.capture_from_rate(&rate, self.rows(), self.cols(), &capture, base)?;
            match &mut out {
                None => out = Some(f),
                Some(o) => {
                    o.raw.extend(f.raw);
                    if let (Some(a), Some(b)) = (&mut o.analog_dn, f.analog_dn) {
                        a.extend(b);
                    }
                }
            }
        }
        out.ok_or_else(|| SensorError::input("exposures_s", "the list of exposure times is empty"))
    }

    /// The sensor stage's peak memory for `frames` frames of the whole sensor, `bytes_per_pixel`
    /// per frame (2: a raw frame; HDR: two raw frames and the merged f32 frame), checked against
    /// the memory limit before any of it is allocated ([`camsim_core::mem::MemoryBudget`]): the
    /// electron image, the pixel vignetting map, the frames, the analog frames (quantization
    /// off), and one frame's encoding to DNG and PNG.
    pub fn check_memory(&self, frames: usize, bytes_per_pixel: usize) -> Result<()> {
        let (rows, cols) = (self.rows(), self.cols());
        let n = rows.saturating_mul(cols);
        let mut b = mem::MemoryBudget::new(format!(
            "the sensor stage ({rows} x {cols} pixels, {frames} frame(s))"
        ))
        .f32s("electron image", n);
        if self.config().pixel_vignetting.is_some() {
            b = b.f32s("pixel vignetting map", n);
        }
        b = b.bytes(
            "frames",
            (n as u64).saturating_mul((bytes_per_pixel * frames) as u64),
        );
        if !self.noise.quantization {
            b = b.f32s("analog frames", n.saturating_mul(frames));
        }
        b.bytes("DNG and PNG encoding", (n as u64).saturating_mul(6))
            .check("use a smaller sensor (rows and cols, or --rows/--cols) or fewer frames")?;
        Ok(())
    }

    /// Noise-free photo-electrons per second at every pixel (its own CFA channel), row-major:
    /// steps 1-2 of [`Sensor::compute`]. Reads each band plane once, in blocks of rows (rayon over
    /// row blocks), accumulating in f32; no per-pixel allocation.
    /// With `[pixel_vignetting]`, each pixel's rate is scaled by its relative response
    /// ([`crate::pixel_vignetting`]).
    pub fn electron_rate_image(&self, irr: &SpectralImage) -> Result<Vec<f32>> {
        let mut rate = self.electron_rate_image_bare(irr)?;
        if let Some(pv) = &self.config().pixel_vignetting {
            let gain = pv.relative_response(
                self.rows(),
                self.cols(),
                self.pixel_pitch_m * 1e6,
                self.fill_factor,
            );
            rate.par_iter_mut()
                .zip(gain.par_iter())
                .for_each(|(r, g)| *r *= g);
        }
        Ok(rate)
    }

    fn electron_rate_image_bare(&self, irr: &SpectralImage) -> Result<Vec<f32>> {
        check_irradiance(irr)?;
        if let Some(layout) = &self.layout {
            return self.electron_rate_image_layout(irr, layout);
        }
        let (rows, cols) = (self.rows(), self.cols());
        mem::check_alloc((rows * cols * 4) as u64, "the sensor electron image")?;
        let pd_width_m = self.pixel_pitch_m * self.fill_factor.sqrt();
        let ax = Axis::new(
            cols,
            self.pixel_pitch_m,
            pd_width_m,
            irr.cols,
            irr.sample_spacing_m,
        );
        let ay = Axis::new(
            rows,
            self.pixel_pitch_m,
            pd_width_m,
            irr.rows,
            irr.sample_spacing_m,
        );
        let fac: Vec<[f32; 3]> = self
            .band_factors(&irr.grid)
            .iter()
            .map(|f| [f[0] as f32, f[1] as f32, f[2] as f32])
            .collect();
        let in_cols = irr.cols;
        let cfa = self.cfa;
        let mut rate = vec![0.0f32; rows * cols];
        // Range of input columns any output column touches (for the general path's row buffer).
        let Some((jmin, jmax)) = ax.input_span() else {
            return Ok(rate); // no pixel sees the image
        };
        let range = jmax - jmin;
        let fast = match (ax.identity, ay.identity) {
            (Some(x), Some(y)) => Some((x, y)),
            _ => None,
        };
        // Blocks of rows per task, bands outermost within a block: each task reads a few
        // neighbouring rows of one band plane at a time (prefetch- and cache-friendly). The block
        // structure is fixed by row index, so the result does not depend on the thread count.
        const BLOCK_ROWS: usize = 8;
        rate.par_chunks_mut(cols * BLOCK_ROWS)
            .enumerate()
            .for_each_init(Vec::<f32>::new, |tmp, (blk, out)| {
                let nrows = out.len() / cols;
                if let Some(((ox, c0, c1), (oy, _, _))) = fast {
                    // Same pitch and spacing, integer offsets: pixel (r, c) sees sample
                    // (r + oy, c + ox) alone. One multiply-add per sample and band.
                    if c1 <= c0 {
                        return;
                    }
                    for (b, f) in fac.iter().enumerate() {
                        let plane = irr.band(b);
                        for (k, orow) in out.chunks_mut(cols).enumerate() {
                            let r = blk * BLOCK_ROWS + k;
                            if ay.entries(r).1.is_empty() {
                                continue;
                            }
                            let (f0, f1) = (
                                f[cfa.channel_at(r, 0).index()],
                                f[cfa.channel_at(r, 1).index()],
                            );
                            if f0 == 0.0 && f1 == 0.0 {
                                continue;
                            }
                            let i = (r as isize + oy) as usize;
                            let src =
                                &plane[((i * in_cols + c0) as isize + ox) as usize..][..c1 - c0];
                            let d = &mut orow[c0..c1];
                            let (fa, fb) = if c0 % 2 == 0 { (f0, f1) } else { (f1, f0) };
                            // Alternating channel factors in blocks of 16 (vectorises).
                            let mut pat = [fa; 16];
                            for k in (1..16).step_by(2) {
                                pat[k] = fb;
                            }
                            let mut dc = d.chunks_exact_mut(16);
                            let mut sc = src.chunks_exact(16);
                            for (dd, ss) in (&mut dc).zip(&mut sc) {
                                for k in 0..16 {
                                    dd[k] += pat[k] * ss[k];
                                }
                            }
                            for (k, (dd, ss)) in dc
                                .into_remainder()
                                .iter_mut()
                                .zip(sc.remainder())
                                .enumerate()
                            {
                                *dd += pat[k] * ss;
                            }
                        }
                    }
                    return;
                }
                // General case. The area integration is linear and the channel of an output pixel
                // depends only on its column parity, so first sum the bands, weighted by the
                // even- and odd-column channel factors and the y weights, into two input-resolution
                // rows per output row (vectorised), then integrate along x once per pixel.
                tmp.clear();
                tmp.resize(nrows * 2 * range, 0.0);
                for (b, f) in fac.iter().enumerate() {
                    let plane = irr.band(b);
                    for k in 0..nrows {
                        let r = blk * BLOCK_ROWS + k;
                        let (i0, wy) = ay.entries(r);
                        let (f0, f1) = (
                            f[cfa.channel_at(r, 0).index()],
                            f[cfa.channel_at(r, 1).index()],
                        );
                        if wy.is_empty() || (f0 == 0.0 && f1 == 0.0) {
                            continue;
                        }
                        let (s0, s1) = tmp[k * 2 * range..(k + 1) * 2 * range].split_at_mut(range);
                        for (kk, w) in wy.iter().enumerate() {
                            if *w == 0.0 {
                                continue;
                            }
                            let row = &plane[(i0 + kk) * in_cols + jmin..][..range];
                            let (a0, a1) = (w * f0, w * f1);
                            for ((x0, x1), e) in s0.iter_mut().zip(s1.iter_mut()).zip(row) {
                                *x0 += a0 * e;
                                *x1 += a1 * e;
                            }
                        }
                    }
                }
                for (k, orow) in out.chunks_mut(cols).enumerate() {
                    let (s0, s1) = tmp[k * 2 * range..(k + 1) * 2 * range].split_at(range);
                    for (c, o) in orow.iter_mut().enumerate() {
                        let (st, wx) = ax.entries(c);
                        let src = if c % 2 == 0 { s0 } else { s1 };
                        *o = wx
                            .iter()
                            .zip(&src[st.saturating_sub(jmin)..])
                            .map(|(a, b)| a * b)
                            .sum();
                    }
                }
            });
        Ok(rate)
    }

    /// Exposure time for a capture, given the noise-free electron-rate image (`rows` x `cols`).
    /// With a global reset (`global_reset`), auto-exposure meters the row that integrates
    /// longest (the row read last): its light (without a mechanical shutter) and its dark
    /// current run for the exposure plus its readout delay, so that no row passes the target.
    pub(crate) fn resolve_exposure(
        &self,
        rate: &[f32],
        rows: usize,
        cols: usize,
        exposure: Exposure,
        global_reset: Option<&GlobalReset>,
    ) -> Result<f64> {
        match exposure {
            Exposure::Seconds(t) => Ok(t),
            Exposure::Auto { target_fraction } => {
                let p99 = self.brightest_filter_p99(rate, rows, cols)?;
                let dark_rate_e = if self.noise.dark {
                    self.dark_voltage_v_per_s / self.conversion_gain_v_per_e
                } else {
                    0.0
                };
                // (v + offset) / gain = target x swing, v = cg x (rate + dark rate) x t.
                let v_needed = target_fraction * self.voltage_swing_v * self.analog_gain
                    - self.analog_offset_v;
                let v_rate = self.conversion_gain_v_per_e * (p99 + dark_rate_e);
                if !(v_rate > 0.0 && v_rate.is_finite()) {
                    return Err(SensorError::input(
                        "auto exposure",
                        "the irradiance reaching the sensor is zero (or not finite), so no exposure time reaches the target",
                    ));
                }
                if v_needed <= 0.0 {
                    return Err(SensorError::input(
                        "auto exposure",
                        format!(
                            "the analog offset alone exceeds {target_fraction} of the voltage swing; give the exposure time instead"
                        ),
                    ));
                }
                // The longest row: light for t + e (t with a mechanical shutter), dark for
                // t + e, e its readout delay: cg ((p99 + dark) t + (light? p99 : 0) e + dark e)
                // = v_needed.
                let e_s = global_reset.map_or(0.0, |g| {
                    g.extra_s(0).max(g.extra_s(rows.saturating_sub(1))).max(0.0)
                });
                let light_e = global_reset.is_some_and(|g| !g.mechanical_shutter);
                let extra_v = self.conversion_gain_v_per_e
                    * (if light_e { p99 } else { 0.0 } + dark_rate_e)
                    * e_s;
                if e_s > 0.0 && extra_v >= v_needed {
                    return Err(SensorError::input(
                        "auto exposure",
                        format!(
                            "the global reset's readout ({e_s} s for the row read last) alone fills the pixels past the target; use a shorter line time, a mechanical shutter or a fixed exposure"
                        ),
                    ));
                }
                Ok((v_needed - extra_v) / v_rate)
            }
        }
    }

    /// The largest, over the CFA's filters, of the 99th percentile of that filter's pixels in
    /// `rate` (e-/s): a deterministic sample of every `stride`-th row and column (<= ~1 M pixels).
    fn brightest_filter_p99(&self, rate: &[f32], rows: usize, cols: usize) -> Result<f64> {
        if rate.is_empty() || rows * cols != rate.len() {
            return Err(SensorError::input(
                "auto exposure",
                "the sensor has no pixels",
            ));
        }
        let layout = self.cfa_layout();
        // A stride that keeps whole CFA tiles: step over tiles, take every pixel of a sampled tile.
        let tiles = (rows / layout.rows()).max(1) * (cols / layout.cols()).max(1);
        let tile_stride = ((tiles as f64 / 1e6).sqrt().ceil() as usize).max(1);
        let mut by_filter: Vec<Vec<f32>> = vec![Vec::new(); layout.filters().len()];
        for r in (0..rows).filter(|r| (r / layout.rows()).is_multiple_of(tile_stride)) {
            let row = &rate[r * cols..(r + 1) * cols];
            for (c, v) in row
                .iter()
                .enumerate()
                .filter(|(c, _)| (c / layout.cols()).is_multiple_of(tile_stride))
            {
                by_filter[layout.filter_at(r, c)].push(*v);
            }
        }
        let mut p99 = 0.0f64;
        for sample in by_filter.iter_mut().filter(|s| !s.is_empty()) {
            let k = ((sample.len() - 1) as f64 * 0.99).round() as usize;
            let (_, v, _) = sample.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
            p99 = p99.max(*v as f64);
        }
        Ok(p99)
    }

    /// Frames from an electron-rate image (`rows` x `cols`, row-major, e-/s). Temporal noise of
    /// frame k is keyed on frame index `frame_base + k`.
    pub(crate) fn capture_from_rate(
        &self,
        rate: &[f32],
        rows: usize,
        cols: usize,
        capture: &Capture,
        frame_base: u64,
    ) -> Result<Frame> {
        check_capture(capture)?;
        let exposure_s = self.resolve_exposure(
            rate,
            rows,
            cols,
            capture.exposure,
            capture.global_reset.as_ref(),
        )?;
        if !(exposure_s.is_finite() && exposure_s >= 0.0) {
            return Err(SensorError::input(
                "exposure",
                format!("{exposure_s} s is not a finite time >= 0"),
            ));
        }
        if let Some(light) = capture.light {
            // A modulated light: every frame sees its own share of it, row by row. The exposure
            // is metered on the steady (time-mean) light, as above; then each frame is captured
            // alone from its modulated rates.
            let one = Capture {
                exposure: Exposure::Seconds(exposure_s),
                frames: 1,
                light: None,
                ..*capture
            };
            let mut out: Option<Frame> = None;
            for k in 0..capture.frames as u64 {
                let key = frame_base + k;
                let modulated = self.modulated_rate(rate, rows, cols, &light, key, &one)?;
                let f = self.capture_from_rate(&modulated, rows, cols, &one, key)?;
                match &mut out {
                    None => out = Some(f),
                    Some(o) => {
                        o.raw.extend(f.raw);
                        if let (Some(a), Some(b)) = (&mut o.analog_dn, f.analog_dn) {
                            a.extend(b);
                        }
                    }
                }
            }
            return out.ok_or_else(|| SensorError::input("frames", "must be at least 1"));
        }
        let n = rows * cols;
        let frames = capture.frames;
        mem::check_alloc(
            (n * 2 * frames) as u64,
            &format!("{frames} raw frames of {rows} x {cols}"),
        )?;
        let keep_analog = !self.noise.quantization;
        if keep_analog {
            mem::check_alloc(
                (n * 4 * frames) as u64,
                &format!("{frames} analog frames of {rows} x {cols}"),
            )?;
        }
        let mut raws = Vec::with_capacity(frames);
        let mut analogs = Vec::new();
        for k in 0..frames {
            let mut raw = RawImage::new(rows, cols, self.cfa, self.bits)?;
            raw.black_level_dn = self.black_level_dn();
            raw.white_level_dn = self.max_dn() as f64;
            raw.exposure_s = exposure_s;
            raw.pixel_pitch_m = self.pixel_pitch_m;
            raw.layout = self.layout.clone();
            let mut analog = if keep_analog {
                vec![0.0f32; n]
            } else {
                Vec::new()
            };
            let frame_key = frame_base + k as u64;
            if keep_analog {
                raw.dn
                    .par_chunks_mut(cols)
                    .zip(analog.par_chunks_mut(cols))
                    .enumerate()
                    .for_each(|(r, (d, a))| {
                        self.noise_row(
                            r,
                            &rate[r * cols..(r + 1) * cols],
                            exposure_s,
                            capture,
                            frame_key,
                            d,
                            Some(a),
                        )
                    });
            } else {
                raw.dn.par_chunks_mut(cols).enumerate().for_each(|(r, d)| {
                    self.noise_row(
                        r,
                        &rate[r * cols..(r + 1) * cols],
                        exposure_s,
                        capture,
                        frame_key,
                        d,
                        None,
                    )
                });
            }
            raws.push(raw);
            if keep_analog {
                analogs.push(analog);
            }
        }
        let (mean_electrons, mean_electrons_by_filter) =
            self.frame_mean_electrons(rate, rows, cols, exposure_s, capture.global_reset.as_ref());
        Ok(Frame {
            raw: raws,
            exposure_s,
            mean_electrons,
            analog_dn: if keep_analog { Some(analogs) } else { None },
            mean_electrons_by_filter,
        })
    }

    /// Noise-free mean electrons (photo + dark) of an electron-rate image exposed for
    /// `exposure_s`: per channel r, g, b (0 where a channel has no pixel) and per filter of
    /// [`Sensor::cfa_layout`]. Per-row sums then a sequential total, so the figures do not depend
    /// on the thread count.
    pub(crate) fn frame_mean_electrons(
        &self,
        rate: &[f32],
        rows: usize,
        cols: usize,
        exposure_s: f64,
        g: Option<&GlobalReset>,
    ) -> ([f64; 3], Vec<f64>) {
        if let Some(layout) = &self.layout {
            let by_filter = self.layout_mean_electrons(layout, rate, rows, cols, exposure_s, g);
            let mut mean_electrons = [0.0; 3];
            for (c, name) in ["r", "g", "b"].iter().enumerate() {
                if let Some(i) = layout.filter_index(name) {
                    mean_electrons[c] = by_filter[i];
                }
            }
            return (mean_electrons, by_filter);
        }
        // Photo-electrons per row (its light time), dark electrons at the rows' mean dark time.
        let dark_e = self.dark_electrons(mean_dark_s(g, rows, exposure_s));
        let per_pixel_s = if g.is_some() { 1.0 } else { exposure_s };
        let row_sums: Vec<[f64; 3]> = rate
            .par_chunks(cols)
            .enumerate()
            .map(|(r, row)| {
                let mut s = [0.0f64; 3];
                let (mut even, mut odd) = (0.0f64, 0.0f64);
                for pair in row.chunks(2) {
                    even += pair[0] as f64;
                    odd += pair.get(1).map_or(0.0, |v| *v as f64);
                }
                let light_s = row_weight_s(g, r, exposure_s);
                s[self.cfa.channel_at(r, 0).index()] += even * light_s;
                s[self.cfa.channel_at(r, 1).index()] += odd * light_s;
                s
            })
            .collect();
        let mut sums = [0.0f64; 3];
        for s in &row_sums {
            for c in 0..3 {
                sums[c] += s[c];
            }
        }
        let mut counts = [0usize; 3];
        for r in 0..rows.min(2) {
            for c in 0..cols.min(2) {
                let per_r = (rows - r).div_ceil(2);
                let per_c = (cols - c).div_ceil(2);
                counts[self.cfa.channel_at(r, c).index()] += per_r * per_c;
            }
        }
        let mut mean_electrons = [0.0; 3];
        for c in 0..3 {
            if counts[c] > 0 {
                mean_electrons[c] = sums[c] / counts[c] as f64 * per_pixel_s + dark_e;
            }
        }
        (mean_electrons, mean_electrons.to_vec())
    }

    /// Per pixel, the fixed offset above the black level at zero light and zero exposure (the
    /// DSNU pattern, as the sensor draws it), DN, row-major: the calibration dark frame an HDR
    /// merge subtracts before it rescales frames of different exposures (an offset is not an
    /// exposure-proportional signal). Zeros with DSNU off.
    pub fn fixed_offset_dn(&self) -> Result<Vec<f32>> {
        let quiet = self.with_noise(crate::NoiseSwitches {
            shot: false,
            read: false,
            dsnu: self.noise.dsnu,
            prnu: false,
            dark: false,
            quantization: false,
        });
        let (rows, cols) = (self.rows(), self.cols());
        mem::check_alloc((rows * cols * 8) as u64, "the sensor's dark offset map")?;
        let rate = vec![0.0f32; rows * cols];
        let f = quiet.capture_from_rate(&rate, rows, cols, &Capture::seconds(0.0), 0)?;
        let black = self.black_level_dn() as f32;
        let mut a = f
            .analog_dn
            .and_then(|mut v| v.drain(..).next())
            .ok_or_else(|| SensorError::input("dsnu", "the dark pass returned no analog values"))?;
        a.iter_mut().for_each(|v| *v -= black);
        Ok(a)
    }

    /// The electron rates of frame index `key` under a modulated light: each stored row's rates
    /// times the fraction of the steady light its window captures ([`LightTiming::row_gains`]);
    /// `one` gives the (resolved) exposure and the global reset, which sets each row's light
    /// time.
    pub(crate) fn modulated_rate(
        &self,
        rate: &[f32],
        rows: usize,
        cols: usize,
        light: &crate::flicker::LightTiming,
        key: u64,
        one: &Capture,
    ) -> Result<Vec<f32>> {
        let Exposure::Seconds(exposure_s) = one.exposure else {
            return Err(SensorError::input(
                "exposure",
                "a modulated light needs the exposure resolved first",
            ));
        };
        mem::check_alloc(
            (rate.len() * 4) as u64,
            &format!("the modulated electron rates of {rows} x {cols}"),
        )?;
        let g = one.global_reset.as_ref();
        let gains = light.row_gains(key, rows, exposure_s, |r| row_times_s(g, r, exposure_s).0);
        let mut out = rate.to_vec();
        out.par_chunks_mut(cols)
            .zip(&gains)
            .for_each(|(row, gain)| row.iter_mut().for_each(|v| *v *= *gain as f32));
        Ok(out)
    }

    /// One row of one frame: electrons -> noise -> volts -> DN (ISETCam sensorComputeNoise order).
    #[allow(clippy::too_many_arguments)]
    fn noise_row(
        &self,
        r: usize,
        rate: &[f32],
        exposure_s: f64,
        capture: &Capture,
        frame_key: u64,
        out: &mut [u16],
        mut analog: Option<&mut [f32]>,
    ) {
        let nz = self.noise;
        let cg = self.conversion_gain_v_per_e;
        let (light_s, dark_s) = row_times_s(capture.global_reset.as_ref(), r, exposure_s);
        let dark_e = self.dark_electrons(dark_s);
        let read_v = if nz.read { self.read_noise_v } else { 0.0 };
        let read_var = read_v * read_v;
        let prnu = if nz.prnu { self.prnu_fraction } else { 0.0 };
        let dsnu = if nz.dsnu { self.dsnu_v } else { 0.0 };
        let fpn = nz.prnu || nz.dsnu;
        let offset = self.analog_offset_v;
        let inv_gain = 1.0 / self.analog_gain;
        let pedestal_dn = self.black_level_pedestal_dn;
        let swing = self.voltage_swing_v;
        let dn_per_v = self.dn_per_v();
        let max_dn = self.max_dn() as f64;
        // Fixed pattern: the sensor's own stream per row (two normals per pixel, PRNU then DSNU),
        // the same for every frame and call. Temporal: the capture's stream per frame and row.
        // A dual pixel's right photodiode: streams of its own (`stream_tag`; 0 otherwise).
        let tag = self.stream_tag;
        let mut fp = keyed(
            self.config().fixed_pattern_seed,
            stage::SENSOR_FIXED_PATTERN,
            tag,
            r as u64,
        );
        let mut tr = keyed(
            capture.seed,
            stage::SENSOR_TEMPORAL,
            frame_key ^ tag,
            r as u64,
        );
        let well_v = self.photodiode_clip_v.unwrap_or(f64::INFINITY);
        let zig = Ziggurat::get();
        // `[defects]`: this row's chain and faulty pixels (the row's defects in column order).
        let defects = self.defects.as_deref();
        let chain = defects.filter(|d| d.has_fpn()).map(|d| {
            (
                &d.column_gain,
                &d.column_offset_v,
                d.row_gain.get(r).copied().unwrap_or(0.0),
                d.row_offset_v.get(r).copied().unwrap_or(0.0),
            )
        });
        let row_faults = defects.map_or(&[][..], |d| d.row_defects(r));
        let mut faulty = row_faults.iter().peekable();
        // RTN pixels' states: a stream of their own per frame and row (one uniform per RTN
        // pixel in column order), so a sensor without them draws exactly as before.
        let mut rtn_rng = row_faults
            .iter()
            .any(|f| f.kind == DefectKind::Rtn)
            .then(|| keyed(capture.seed, stage::SENSOR_RTN, frame_key ^ tag, r as u64));
        for (c, o) in out.iter_mut().enumerate() {
            let fault = match faulty.peek() {
                Some(f) if f.col == c => faulty.next().map(|f| f.kind),
                _ => None,
            };
            // max(0) maps NaN (and negative input) to no light.
            let mut mu_e = (rate[c] as f64 * light_s + dark_e).max(0.0);
            match fault {
                Some(DefectKind::Hot) => {
                    mu_e += defects.map_or(0.0, |d| d.hot_e_per_s) * dark_s;
                }
                Some(DefectKind::Dead) => mu_e = dark_e.max(0.0),
                _ => {}
            }
            let (gain_map, offset_map_v) = if fpn {
                let z1 = zig.sample(&mut fp);
                let z2 = zig.sample(&mut fp);
                // ISETCam binNoiseFPN: v = (1 + PRNU) v + DSNU.
                (1.0 + prnu * z1, dsnu * z2)
            } else {
                (1.0, 0.0)
            };
            let v = if nz.shot && mu_e >= POISSON_EXACT_BELOW_E {
                // Shot (normal, same mean and variance as Poisson) and read noise are independent
                // normals after the PRNU gain: one normal draw with the summed variance.
                let sd_shot_v = cg * gain_map * mu_e.sqrt();
                let z = zig.sample(&mut tr);
                cg * gain_map * mu_e + offset_map_v + (sd_shot_v * sd_shot_v + read_var).sqrt() * z
            } else {
                let e = if nz.shot {
                    poisson::sample(&mut tr, mu_e)
                } else {
                    mu_e
                };
                let mut v = e * cg * gain_map + offset_map_v;
                if nz.read {
                    let z = zig.sample(&mut tr);
                    v += read_v * z;
                }
                v
            };
            // A dual pixel's photodiode holds half the pixel's well (its charge clips there).
            let v = v.min(well_v);
            // RTN: the source follower's trap adds its step in the high state.
            let v = match (fault, rtn_rng.as_mut(), defects) {
                (Some(DefectKind::Rtn), Some(rng), Some(d)) => {
                    let u: f64 = rand::Rng::gen(rng);
                    if u < d.rtn_high_probability {
                        v + cg * d.rtn_amplitude_e
                    } else {
                        v
                    }
                }
                _ => v,
            };
            // The column and row readout chains (ISETCam noiseColumnFPN): gain and offset of
            // the pixel voltage.
            let v = match chain {
                Some((cg_col, co_col, g_row, o_row)) => {
                    v * (1.0 + cg_col[c] + g_row) + co_col[c] + o_row
                }
                None => v,
            };
            // ISETCam: analog gain and offset, (v + offset) / gain; clip to [0, swing].
            let x = if pedestal_dn == 0.0 {
                ((v + offset) * inv_gain).clamp(0.0, swing) * dn_per_v
            } else {
                // With a black-level pedestal the ADC sees the signal plus the pedestal, so noise
                // below zero light survives down to 0 DN (real raws; DNG BlackLevel).
                (((v + offset) * inv_gain).min(swing) * dn_per_v + pedestal_dn).max(0.0)
            };
            // Quantization: DN = round(v / (swing / 2^bits)), clipped to 2^bits - 1.
            // x >= 0, so x + 0.5 truncated is round-half-away-from-zero (f64::round is a libm
            // call on baseline x86-64).
            let x = match fault {
                Some(DefectKind::Stuck) => defects.map_or(x, |d| d.stuck_dn.min(max_dn)),
                _ => x,
            };
            *o = (x + 0.5).min(max_dn) as u16;
            if let Some(a) = analog.as_deref_mut() {
                a[c] = x as f32;
            }
        }
    }
}

fn check_irradiance(irradiance: &SpectralImage) -> Result<()> {
    if irradiance.quantity != Quantity::Irradiance {
        return Err(SensorError::input(
            "sensor input",
            format!(
                "needs a sensor-plane irradiance image (W/(m^2 nm)), got {}",
                irradiance.quantity.name()
            ),
        ));
    }
    if !(irradiance.sample_spacing_m.is_finite() && irradiance.sample_spacing_m > 0.0) {
        return Err(SensorError::input(
            "sensor input",
            format!(
                "sample spacing {} m is not a positive number",
                irradiance.sample_spacing_m
            ),
        ));
    }
    if irradiance.rows == 0 || irradiance.cols == 0 || irradiance.bands() == 0 {
        return Err(SensorError::input(
            "sensor input",
            "the irradiance image is empty",
        ));
    }
    if irradiance.data.len() != irradiance.rows * irradiance.cols * irradiance.bands() {
        return Err(SensorError::input(
            "sensor input",
            "image data length does not match rows x cols x bands",
        ));
    }
    Ok(())
}

/// The longest exposure accepted: an hour. Longer ones are typing mistakes (`exposure_ms =
/// 1e300`), not captures: dark current alone fills any pixel long before.
pub const MAX_EXPOSURE_S: f64 = 3600.0;

/// Whether `t` is an exposure time camsim accepts: finite, in [0, [`MAX_EXPOSURE_S`]].
pub fn exposure_in_range(t: f64) -> bool {
    (0.0..=MAX_EXPOSURE_S).contains(&t)
}

pub(crate) fn check_capture(capture: &Capture) -> Result<()> {
    if capture.frames == 0 {
        return Err(SensorError::input("frames", "must be at least 1"));
    }
    if let Some(g) = &capture.global_reset {
        if !(g.row0_extra_s.is_finite() && g.per_row_extra_s.is_finite()) {
            return Err(SensorError::input(
                "global reset",
                "the rows' readout delays are not finite",
            ));
        }
    }
    match capture.exposure {
        Exposure::Seconds(t) if !exposure_in_range(t) => Err(SensorError::input(
            "exposure_s",
            format!("{t} s is outside [0, {MAX_EXPOSURE_S}] s (at most an hour)"),
        )),
        Exposure::Auto { target_fraction }
            if !(target_fraction > 0.0 && target_fraction <= 1.0) =>
        {
            Err(SensorError::input(
                "auto exposure target_fraction",
                format!("must be in (0, 1], got {target_fraction}"),
            ))
        }
        _ => Ok(()),
    }
}
