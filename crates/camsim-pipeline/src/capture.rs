//! Stages 2 and 3: the one wiring of the optics into the sensor ([`image_radiance`]), a capture
//! request checked in one place ([`CaptureRequest`]: one exposure or auto-exposure, a bracket /
//! burst, the frames and the seed), the capture itself for plain and HDR sensors ([`capture`])
//! and its raw files ([`Captured::write_files`]).

use crate::{PipelineError, Result};
use camsim_core::{Quantity, RawImage, SpectralImage};
use camsim_io::atomic::OutputDir;
use camsim_io::dng::DngMetadata;
use camsim_optics::Optics;
use camsim_sensor::{Capture, Exposure, Frame, HdrFrame, HdrModel, NoiseSwitches, Sensor};
use std::time::Instant;

/// How a door names the capture settings in its messages, and the unit of its exposure times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureKeys {
    /// One exposure time.
    pub exposure: &'static str,
    /// A list of exposure times (a bracket / burst).
    pub bracket: &'static str,
    /// Frames per exposure.
    pub frames: &'static str,
    /// The auto-exposure target.
    pub auto_target: &'static str,
    /// Seconds per unit of the exposure times (1e-3 for ms).
    pub unit_s: f64,
    /// The unit's name, for messages.
    pub unit: &'static str,
}

/// The keys of a simulate config's `[capture]` table (ms).
pub const CONFIG_KEYS: CaptureKeys = CaptureKeys {
    exposure: "capture.exposure_ms",
    bracket: "capture.exposures_ms",
    frames: "capture.frames",
    auto_target: "capture.auto_target_fraction",
    unit_s: 1e-3,
    unit: "ms",
};

/// The options of `camsim sensor` (ms).
pub const CLI_KEYS: CaptureKeys = CaptureKeys {
    exposure: "--exposure-ms",
    bracket: "--exposures-ms",
    frames: "--frames",
    auto_target: "--auto-target-fraction",
    unit_s: 1e-3,
    unit: "ms",
};

/// The arguments of Python's `camsim.sensor` (s).
pub const PYTHON_KEYS: CaptureKeys = CaptureKeys {
    exposure: "exposure_s",
    bracket: "exposure_s (a list)",
    frames: "frames",
    auto_target: "auto_target_fraction",
    unit_s: 1.0,
    unit: "s",
};

/// One capture, checked: the exposure (a time or auto-exposure) or a bracket of times, frames
/// per exposure and the seed of the temporal noise.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureRequest {
    /// One exposure (ignored with a bracket).
    pub exposure: Exposure,
    /// Exposure bracketing / burst (ISETCam: a vector of exposure times): one raw per time (x
    /// `frames`), s, each with its own temporal noise.
    pub bracket_s: Option<Vec<f64>>,
    /// Frames per exposure (>= 1).
    pub frames: usize,
    /// Seed of the temporal noise.
    pub seed: u64,
    /// How the door that made it names its settings (for messages).
    pub keys: CaptureKeys,
    /// Frame index of the first raw's temporal noise (0; a moving scene captured frame by frame
    /// keys frame k on k, [`crate::sequence`], so each frame has the noise it has in one capture).
    pub first_frame: u64,
    /// A global-reset sensor mode's rows (`[capture] shutter = { global_reset = ... }`,
    /// [`crate::ShutterConfig::sensor_global_reset`]); `None` otherwise.
    pub global_reset: Option<camsim_sensor::GlobalReset>,
    /// A modulated light's timing (`[flicker]`, [`crate::CaptureSection::light_timing`]);
    /// `None`: a steady light.
    pub light: Option<camsim_sensor::LightTiming>,
    /// Light groups that flicker each in its own way (`[light_flicker]`,
    /// [`crate::CaptureSection::group_light_timings`]): the group's name and timing, sorted by
    /// name; empty when none does. Only a render's light groups can take them.
    pub group_lights: Vec<(String, camsim_sensor::LightTiming)>,
}

impl CaptureRequest {
    /// Check a door's capture settings, in the door's units (`keys.unit_s`): an exposure time
    /// (None: auto-exposure to `auto_target_fraction` of the swing), or a bracket (not both),
    /// `frames` >= 1. The one place the exposure values are checked.
    pub fn new(
        exposure: Option<f64>,
        bracket: Option<&[f64]>,
        auto_target_fraction: f64,
        frames: usize,
        seed: u64,
        keys: CaptureKeys,
    ) -> Result<CaptureRequest> {
        let bad = |m: String| Err(PipelineError::Config(m));
        if frames == 0 {
            return bad(format!("{} must be at least 1", keys.frames));
        }
        let time = |key: String, t: f64| -> Result<f64> {
            if camsim_sensor::exposure_in_range(t * keys.unit_s) {
                Ok(t * keys.unit_s)
            } else {
                Err(PipelineError::Config(format!(
                    "{key} = {t}: must be in [0, {}] {} (at most an hour)",
                    camsim_sensor::MAX_EXPOSURE_S / keys.unit_s,
                    keys.unit
                )))
            }
        };
        let bracket_s = match bracket {
            None => None,
            Some(_) if exposure.is_some() => {
                return bad(format!(
                    "give either {} or {} (a bracket), not both",
                    keys.exposure, keys.bracket
                ))
            }
            Some([]) => {
                return bad(format!(
                    "{} is empty: give at least one exposure time, {}",
                    keys.bracket, keys.unit
                ))
            }
            Some(list) => Some(
                list.iter()
                    .enumerate()
                    .map(|(i, t)| time(format!("{}[{i}]", keys.bracket), *t))
                    .collect::<Result<Vec<f64>>>()?,
            ),
        };
        let exposure = match exposure {
            Some(t) => Exposure::Seconds(time(keys.exposure.to_string(), t)?),
            None => {
                if !(auto_target_fraction > 0.0 && auto_target_fraction <= 1.0) {
                    return bad(format!(
                        "{} = {auto_target_fraction}: must be in (0, 1]",
                        keys.auto_target
                    ));
                }
                Exposure::Auto {
                    target_fraction: auto_target_fraction,
                }
            }
        };
        Ok(CaptureRequest {
            exposure,
            bracket_s,
            frames,
            seed,
            keys,
            first_frame: 0,
            global_reset: None,
            light: None,
            group_lights: Vec::new(),
        })
    }

    /// The sensor's capture of one exposure.
    pub fn capture(&self) -> Capture {
        Capture {
            exposure: self.exposure,
            frames: self.frames,
            seed: self.seed,
            global_reset: self.global_reset,
            light: self.light,
        }
    }
}

/// What a capture gives: plain raw frames, or both readouts of an HDR sensor.
#[derive(Debug, Clone)]
pub enum Captured {
    /// Raw frames (one exposure x frames, or a bracket).
    Frames(Frame),
    /// An `[hdr]` sensor's readouts and merged frames.
    Hdr(HdrFrame),
}

/// Stage 3: `sensor` captures sensor-plane `irradiance` as `req` asks: an `[hdr]` sensor (dual
/// conversion gain, split pixel) both its readouts, the others raw frames of one exposure or of
/// a bracket. `camsim sensor` and Python's `camsim.sensor` both call this.
pub fn capture(
    sensor: &Sensor,
    irradiance: &SpectralImage,
    req: &CaptureRequest,
) -> Result<Captured> {
    if sensor.is_dual_pixel() {
        return Err(dual_pixel_refused(
            sensor,
            "its photodiodes see different halves of the pupil, which a sensor-plane irradiance does not hold apart; simulate the scene through the optics (camsim simulate, Python's simulate)",
        ));
    }
    if sensor.hdr_model().is_some() {
        if req.bracket_s.is_some() {
            return Err(PipelineError::Config(format!(
                "{}: an [hdr] sensor ({}) takes one exposure ({} or auto-exposure), not a bracket",
                req.keys.bracket,
                sensor.name(),
                req.keys.exposure
            )));
        }
        return Ok(Captured::Hdr(sensor.compute_hdr_from(
            irradiance,
            &req.capture(),
            req.first_frame,
        )?));
    }
    Ok(Captured::Frames(match &req.bracket_s {
        None => sensor.compute_from(irradiance, &req.capture(), req.first_frame)?,
        Some(times_s) => sensor.compute_bracket_like(irradiance, times_s, &req.capture())?,
    }))
}

/// An `[hdr]` sensor's capture besides its high readout (which is the run's raw frames): the
/// low readout and the merged linear frame of every raw frame, and the model that merged them.
#[derive(Debug, Clone)]
pub struct HdrReadouts {
    /// Low readout (LCG / SPD) raw per frame.
    pub low: Vec<RawImage>,
    /// Merged linear frame per frame, electrons of the high readout, row-major.
    pub merged_e: Vec<Vec<f32>>,
    /// The model used.
    pub model: HdrModel,
}

impl HdrReadouts {
    /// Append a later frame's readouts (a moving scene's frames, captured one by one).
    pub fn extend(&mut self, other: HdrReadouts) {
        self.low.extend(other.low);
        self.merged_e.extend(other.merged_e);
    }
}

/// An HDR capture as the run's frames (the high readout, the frame every door reads as "the
/// raw") and the rest of it.
pub fn split_hdr(h: HdrFrame) -> (Frame, HdrReadouts) {
    (
        Frame {
            raw: h.high,
            exposure_s: h.exposure_s,
            mean_electrons: h.mean_electrons,
            analog_dn: None,
            mean_electrons_by_filter: h.mean_electrons_by_filter,
        },
        HdrReadouts {
            low: h.low,
            merged_e: h.merged_e,
            model: h.model,
        },
    )
}

impl Captured {
    /// Exposure time, s (a bracket's first).
    pub fn exposure_s(&self) -> f64 {
        match self {
            Captured::Frames(f) => f.exposure_s,
            Captured::Hdr(h) => h.exposure_s,
        }
    }

    /// The (first readout's) raw frames.
    pub fn raw(&self) -> &[RawImage] {
        match self {
            Captured::Frames(f) => &f.raw,
            Captured::Hdr(h) => &h.high,
        }
    }

    /// The capture's files into `out`: raw frames as `raw.dng`, `raw_0001.dng`, ... and the first
    /// as `raw.png` (the mosaic scaled to 16 bits for viewing); an HDR capture per frame
    /// `high.dng`, `low.dng` and `merged.exr` (suffix `_0001` ... for more frames).
    pub fn write_files(&self, out: &OutputDir, meta: &DngMetadata) -> Result<()> {
        match self {
            Captured::Frames(f) => {
                write_raw_dngs(out, &f.raw, meta)?;
                let r0 = &f.raw[0];
                camsim_io::raster::write_png16_mosaic_scaled(
                    &out.join("raw.png"),
                    r0.rows,
                    r0.cols,
                    &r0.dn,
                    r0.bits,
                )?;
            }
            Captured::Hdr(h) => {
                for (i, ((hi, lo), merged)) in
                    h.high.iter().zip(&h.low).zip(&h.merged_e).enumerate()
                {
                    let suffix = frame_suffix(i);
                    camsim_io::dng::write_dng(&out.join(format!("high{suffix}.dng")), hi, meta)?;
                    camsim_io::dng::write_dng(&out.join(format!("low{suffix}.dng")), lo, meta)?;
                    camsim_io::exr::write_gray_exr(
                        &out.join(format!("merged{suffix}.exr")),
                        hi.rows,
                        hi.cols,
                        "Y",
                        merged,
                    )?;
                }
            }
        }
        Ok(())
    }
}

/// `""` for the first frame, `_0001`, `_0002`, ... for the others (file names of a run).
pub fn frame_suffix(i: usize) -> String {
    if i == 0 {
        String::new()
    } else {
        format!("_{i:04}")
    }
}

/// Raw frames as `raw.dng`, `raw_0001.dng`, ... (the order of the frames; [`frame_suffix`]).
pub fn write_raw_dngs(out: &OutputDir, frames: &[RawImage], meta: &DngMetadata) -> Result<()> {
    for (i, raw) in frames.iter().enumerate() {
        let name = format!("raw{}.dng", frame_suffix(i));
        camsim_io::dng::write_dng(&out.join(name), raw, meta)?;
    }
    Ok(())
}

/// Stages 2 and 3 on a given radiance: the optics' irradiance, the sensor's frames and the
/// seconds each stage took (the one wiring of optics into sensor; `simulate` and
/// `camsim validate` both use it). An image that is already sensor-plane irradiance (a lens
/// camera's render, [`crate::render`]) goes to the sensor as it is.
pub fn image_radiance(
    radiance: &SpectralImage,
    optics: &Optics,
    sensor: &Sensor,
    capture: &Capture,
) -> Result<Imaged> {
    let t = Instant::now();
    let irradiance = match radiance.quantity {
        Quantity::Irradiance => radiance.clone(),
        _ => optics.compute(radiance)?,
    };
    let optics_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    if sensor.is_dual_pixel() {
        return Err(dual_pixel_refused(
            sensor,
            "not in this measurement yet (it captures the whole pixel); use camsim simulate",
        ));
    }
    let frame = sensor.compute(&irradiance, capture)?;
    Ok(Imaged {
        irradiance,
        frame,
        hdr: None,
        optics_s,
        sensor_s: t.elapsed().as_secs_f64(),
        light_split: None,
        dual: None,
    })
}

/// What [`image_owned`] and its variants hand back: the radiance (`None` where the scene was
/// already sensor-plane irradiance), the imaged result and the optics' geometric map.
pub(crate) type OwnedImaged = (
    Option<SpectralImage>,
    Imaged,
    Option<camsim_optics::ImageMap>,
);

/// Stages 2 and 3 on a scene image taken by value, for [`crate::simulate`]: the capture of
/// `req` ([`capture`]). A lens camera's render, already sensor-plane irradiance, becomes
/// [`Imaged::irradiance`] without a copy (a full-frame 31-band cube is 1.5 GB), and no radiance
/// is handed back (`None`); with the optics' geometric map (`None` for irradiance).
pub(crate) fn image_owned(
    image: SpectralImage,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
) -> Result<OwnedImaged> {
    if sensor.is_dual_pixel() {
        return image_owned_dual(image, optics, sensor, req);
    }
    let t = Instant::now();
    let (radiance, irradiance, map) = match image.quantity {
        Quantity::Irradiance => (None, image, None),
        _ => {
            let (irradiance, map) = optics.compute_mapped(&image)?;
            (Some(image), irradiance, Some(map))
        }
    };
    let optics_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (frame, hdr) = match capture(sensor, &irradiance, req)? {
        Captured::Frames(f) => (f, None),
        Captured::Hdr(h) => {
            let (f, rest) = split_hdr(h);
            (f, Some(rest))
        }
    };
    Ok((
        radiance,
        Imaged {
            irradiance,
            frame,
            hdr,
            optics_s,
            sensor_s: t.elapsed().as_secs_f64(),
            light_split: None,
            dual: None,
        },
        map,
    ))
}

/// The sensor-plane irradiance of a scene whose light groups flicker each in its own way
/// (`[light_flicker]`, [`camsim_sensor::light_parts`]): the steady groups' sum and each
/// modulated group's with its timing.
#[derive(Debug, Clone)]
pub struct SplitIrradiance {
    /// The steady groups' (weighted) irradiance.
    pub steady: SpectralImage,
    /// Each modulated group's (weighted) irradiance, at its time mean, and its timing.
    pub parts: Vec<(SpectralImage, camsim_sensor::LightTiming)>,
}

impl SplitIrradiance {
    /// The parts as the sensor takes them.
    pub fn light_parts(&self) -> Vec<camsim_sensor::LightPart<'_>> {
        self.parts
            .iter()
            .map(|(irradiance, light)| camsim_sensor::LightPart {
                irradiance,
                light: *light,
            })
            .collect()
    }
}

/// Split a render's radiance by `req.group_lights`: the steady groups' weighted sum and each
/// modulated group's weighted image (`weights`: `[render] light_groups`, 1 for a group not
/// named), each on `image`'s grid and geometry. A modulated group the render lacks is an error
/// naming its key `light_flicker.NAME` and the render's groups.
pub(crate) fn split_radiance(
    image: &SpectralImage,
    groups: &[(String, SpectralImage)],
    weights: Option<&std::collections::BTreeMap<String, f64>>,
    lights: &[(String, camsim_sensor::LightTiming)],
) -> Result<(
    SpectralImage,
    Vec<(SpectralImage, camsim_sensor::LightTiming)>,
)> {
    use rayon::prelude::*;
    for (name, _) in lights {
        if !groups.iter().any(|(g, _)| g == name) {
            let names: Vec<&str> = groups.iter().map(|(g, _)| g.as_str()).collect();
            return Err(PipelineError::config(format!(
                "light_flicker.{name}: no light of the scene is in group {name:?} (its groups: {}; a light's group is pbrt's \"string lightgroup\" or an overlay's [[light_group]])",
                names.join(", ")
            )));
        }
    }
    camsim_core::mem::MemoryBudget::new(format!(
        "the light split for [light_flicker] ({} images of {} x {} x {} bands)",
        lights.len() + 1,
        image.rows,
        image.cols,
        image.grid.len()
    ))
    .f32s(
        "split radiance",
        image.data.len().saturating_mul(lights.len() + 1),
    )
    .check("flicker fewer light groups or render fewer pixels")?;
    let weight = |g: &str| weights.and_then(|w| w.get(g)).copied().unwrap_or(1.0) as f32;
    // Each part keeps the render's depth: a depth-dependent optics blurs it as the whole.
    let like = |data: Vec<f32>| SpectralImage {
        rows: image.rows,
        cols: image.cols,
        grid: image.grid,
        sample_spacing_m: image.sample_spacing_m,
        quantity: image.quantity,
        geometry: image.geometry,
        depth_m: image.depth_m.clone(),
        data,
    };
    let mut steady = vec![0.0f32; image.data.len()];
    let mut parts = Vec::with_capacity(lights.len());
    for (name, g) in groups {
        if g.data.len() != image.data.len() {
            return Err(PipelineError::config(
                "light groups: a group image differs in size from the render",
            ));
        }
        let w = weight(name);
        match lights.iter().find(|(n, _)| n == name) {
            Some((_, light)) => {
                parts.push((like(g.data.par_iter().map(|v| w * v).collect()), *light));
            }
            None => steady
                .par_iter_mut()
                .zip(&g.data)
                .for_each(|(s, v)| *s += w * v),
        }
    }
    Ok((like(steady), parts))
}

/// [`image_owned`] for a render whose light groups (`groups`, weighed by `weights`) flicker
/// each in its own way (`req.group_lights`): the optics image the steady part and each
/// modulated group (it is linear: they sum to the optics' image of the whole), and the sensor
/// integrates each group over its rows' own windows ([`camsim_sensor::light_parts`]). Without
/// modulated groups it is [`image_owned`].
pub(crate) fn image_owned_groups(
    image: SpectralImage,
    groups: &[(String, SpectralImage)],
    weights: Option<&std::collections::BTreeMap<String, f64>>,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
) -> Result<OwnedImaged> {
    use rayon::prelude::*;
    if req.group_lights.is_empty() {
        return image_owned(image, optics, sensor, req);
    }
    if req.light.is_some() {
        return Err(PipelineError::config(
            "give [flicker] (the whole scene) or [light_flicker] (by light group), not both",
        ));
    }
    let t = Instant::now();
    let (steady, parts) = split_radiance(&image, groups, weights, &req.group_lights)?;
    if sensor.is_dual_pixel() {
        return image_owned_groups_dual(image, steady, parts, optics, sensor, req);
    }
    let (radiance, split, map) = match image.quantity {
        Quantity::Irradiance => (None, SplitIrradiance { steady, parts }, None),
        _ => {
            let (steady_irr, map) = optics.compute_mapped(&steady)?;
            drop(steady);
            let parts = parts
                .into_iter()
                .map(|(p, l)| Ok((optics.compute(&p)?, l)))
                .collect::<Result<Vec<_>>>()?;
            (
                Some(image),
                SplitIrradiance {
                    steady: steady_irr,
                    parts,
                },
                Some(map),
            )
        }
    };
    // The whole scene's irradiance, for the records, previews and labels (each optics pass
    // above checked its own cube; this one is checked here).
    let mut irradiance = checked_copy(&split.steady, "the whole scene's irradiance")?;
    for (p, _) in &split.parts {
        irradiance
            .data
            .par_iter_mut()
            .zip(&p.data)
            .for_each(|(s, v)| *s += *v);
    }
    let optics_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (frame, hdr) = match capture_split(sensor, &split, req)? {
        Captured::Frames(f) => (f, None),
        Captured::Hdr(h) => {
            let (f, rest) = split_hdr(h);
            (f, Some(rest))
        }
    };
    Ok((
        radiance,
        Imaged {
            irradiance,
            frame,
            hdr,
            optics_s,
            sensor_s: t.elapsed().as_secs_f64(),
            light_split: Some(split),
            dual: None,
        },
        map,
    ))
}

/// [`capture`] of a split light ([`SplitIrradiance`]).
pub fn capture_split(
    sensor: &Sensor,
    split: &SplitIrradiance,
    req: &CaptureRequest,
) -> Result<Captured> {
    let parts = split.light_parts();
    let capture = req.capture();
    if sensor.hdr_model().is_some() {
        if req.bracket_s.is_some() {
            return Err(PipelineError::Config(format!(
                "{}: an [hdr] sensor ({}) takes one exposure ({} or auto-exposure), not a bracket",
                req.keys.bracket,
                sensor.name(),
                req.keys.exposure
            )));
        }
        return Ok(Captured::Hdr(sensor.compute_hdr_parts_from(
            &split.steady,
            &parts,
            &capture,
            req.first_frame,
        )?));
    }
    Ok(Captured::Frames(match &req.bracket_s {
        None => sensor.compute_parts_from(&split.steady, &parts, &capture, req.first_frame)?,
        Some(times_s) => sensor.compute_bracket_parts(&split.steady, &parts, times_s, &capture)?,
    }))
}

/// What [`image_radiance`] returns.
#[derive(Debug, Clone)]
pub struct Imaged {
    /// Sensor-plane spectral irradiance, W/(m^2 nm).
    pub irradiance: SpectralImage,
    /// The sensor's frames (an `[hdr]` sensor's: its high readout).
    pub frame: Frame,
    /// An `[hdr]` sensor's low readout and merged frames ([`image_radiance`]: always `None`, it
    /// takes plain sensors).
    pub hdr: Option<HdrReadouts>,
    /// Seconds in the optics stage.
    pub optics_s: f64,
    /// Seconds in the sensor stage.
    pub sensor_s: f64,
    /// With light groups that flicker each in its own way (`[light_flicker]`): the steady
    /// and the modulated groups' irradiance, which sum to `irradiance` (`None` otherwise).
    pub light_split: Option<SplitIrradiance>,
    /// A dual-pixel sensor's photodiode raws (`frame` holds their sums); `None` otherwise.
    pub dual: Option<DualPixelReadouts>,
}

/// A dual-pixel sensor's left and right photodiode raws, one of each per raw frame
/// ([`camsim_sensor::dual_pixel`]).
#[derive(Debug, Clone)]
pub struct DualPixelReadouts {
    /// The photodiodes that see the pupil's left half (x < 0), per frame.
    pub left: Vec<RawImage>,
    /// The photodiodes that see its right half, per frame.
    pub right: Vec<RawImage>,
}

impl DualPixelReadouts {
    /// Append a later frame's readouts (a moving scene's frames, captured one by one).
    pub fn extend(&mut self, other: DualPixelReadouts) {
        self.left.extend(other.left);
        self.right.extend(other.right);
    }
}

/// The refusal of a dual-pixel sensor where its halves cannot be imaged apart.
fn dual_pixel_refused(sensor: &Sensor, why: &str) -> PipelineError {
    PipelineError::config(format!("sensor {}: dual_pixel: {why}", sensor.name()))
}

/// The optics of each half of the pupil for a dual-pixel capture of `image`, after the checks
/// that refuse what cannot be imaged apart (a lens camera's irradiance, the optics' own
/// `aperture.half`, the shift-variant optics).
fn dual_pixel_half_optics(
    image: &SpectralImage,
    optics: &Optics,
    sensor: &Sensor,
) -> Result<[Optics; 2]> {
    use camsim_optics::config::{ApertureConfig, PupilHalf};
    if image.quantity == Quantity::Irradiance {
        return Err(dual_pixel_refused(
            sensor,
            "the optics stage images each half of the pupil, but the scene's lens camera renders the sensor-plane irradiance itself; use a pinhole camera with [optics] (depth-layered defocus)",
        ));
    }
    let oc = optics.config();
    if oc.aperture.as_ref().is_some_and(|a| a.half.is_some()) {
        return Err(dual_pixel_refused(
            sensor,
            "the optics' aperture.half is set; a dual-pixel sensor opens each half itself",
        ));
    }
    if oc
        .blur
        .as_ref()
        .is_some_and(|b| b.method == camsim_optics::config::BlurKind::ShiftVariant)
    {
        return Err(dual_pixel_refused(
            sensor,
            "the shift-variant optics (blur.method = \"shift-variant\") do not image half a pupil yet; use the wavefront optics",
        ));
    }
    let half = |h: PupilHalf| -> Result<Optics> {
        let mut c = oc.clone();
        c.aperture = Some(ApertureConfig {
            half: Some(h),
            ..c.aperture.unwrap_or_default()
        });
        Ok(Optics::from_config(&c)?)
    };
    Ok([half(PupilHalf::Left)?, half(PupilHalf::Right)?])
}

/// `req` with one exposure for both photodiodes: auto-exposure meters the whole pixel
/// (`irradiance`, the halves' sum).
fn dual_pixel_request(
    sensor: &Sensor,
    irradiance: &SpectralImage,
    req: &CaptureRequest,
) -> Result<CaptureRequest> {
    let mut one = req.clone();
    if let Exposure::Auto { .. } = req.exposure {
        if req.bracket_s.is_none() {
            one.exposure =
                Exposure::Seconds(sensor.metered_exposure_s(irradiance, &req.capture())?);
        }
    }
    Ok(one)
}

/// The pixel's frames from its photodiodes' ([`camsim_sensor::dual_pixel_sum`]) and the
/// photodiode raws kept beside them.
fn dual_pixel_frame(left: Frame, right: Frame) -> Result<(Frame, DualPixelReadouts)> {
    let raw = left
        .raw
        .iter()
        .zip(&right.raw)
        .map(|(l, r)| camsim_sensor::dual_pixel_sum(l, r))
        .collect::<camsim_sensor::Result<Vec<_>>>()?;
    let add = |a: &[f64; 3], b: &[f64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let frame = Frame {
        raw,
        exposure_s: left.exposure_s,
        mean_electrons: add(&left.mean_electrons, &right.mean_electrons),
        analog_dn: None,
        mean_electrons_by_filter: left
            .mean_electrons_by_filter
            .iter()
            .zip(&right.mean_electrons_by_filter)
            .map(|(a, b)| a + b)
            .collect(),
    };
    Ok((
        frame,
        DualPixelReadouts {
            left: left.raw,
            right: right.raw,
        },
    ))
}

/// A photodiode's frames (an `[hdr]` readout is refused: config checks keep it out).
fn dual_pixel_frames(sensor: &Sensor, captured: Captured) -> Result<Frame> {
    match captured {
        Captured::Frames(f) => Ok(f),
        Captured::Hdr(_) => Err(dual_pixel_refused(sensor, "not with an [hdr] pixel")),
    }
}

/// Stages 2 and 3 for a dual-pixel sensor ([`camsim_sensor::dual_pixel`]): the optics image
/// `image` through each half of the pupil (`aperture.half`), each photodiode captures its half's
/// irradiance ([`Sensor::dual_pixel_photodiodes`]) at one exposure (auto-exposure meters the
/// whole pixel, the halves' sum), and the raw is their sum. The irradiance handed back is the
/// halves' sum, the whole pixel's.
fn image_owned_dual(
    image: SpectralImage,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
) -> Result<OwnedImaged> {
    // As [`image_owned`], the whole light at once (`req.group_lights` is read by
    // [`image_owned_groups_dual`]; a metering preview takes the whole light here).
    let [left_optics, right_optics] = dual_pixel_half_optics(&image, optics, sensor)?;
    let t = Instant::now();
    let (left_e, map) = left_optics.compute_mapped(&image)?;
    let right_e = right_optics.compute(&image)?;
    let irradiance = image_sum(&left_e, &right_e)?;
    let halves = [left_e, right_e];
    let imaged = dual_pixel_imaged(sensor, irradiance, t, req, |pd, k, one| {
        capture(pd, &halves[k], one)
    })?;
    Ok((Some(image), imaged, Some(map)))
}

/// `a + b`, texel by texel.
fn image_sum(a: &SpectralImage, b: &SpectralImage) -> Result<SpectralImage> {
    let mut s = checked_copy(a, "the whole pixel's irradiance")?;
    add_into(&mut s, b);
    Ok(s)
}

/// A copy of `image` (one more irradiance cube), refused before it is allocated when it will not
/// fit beside what the capture already holds; `what` names it in the error.
fn checked_copy(image: &SpectralImage, what: &str) -> Result<SpectralImage> {
    camsim_core::mem::MemoryBudget::new(format!(
        "{what} ({} x {} x {} bands)",
        image.rows,
        image.cols,
        image.grid.len()
    ))
    .f32s(what, image.data.len())
    .check("flicker fewer light groups, render fewer pixels or use fewer bands")?;
    Ok(image.clone())
}

/// `acc += b`, texel by texel.
fn add_into(acc: &mut SpectralImage, b: &SpectralImage) {
    acc.data.iter_mut().zip(&b.data).for_each(|(x, y)| *x += y);
}

/// The sensor stage of a dual-pixel capture as [`Imaged`]: photodiode `k` (0 left, 1 right)
/// captured by `capture_half` at one exposure metered on the whole pixel's `irradiance`, the
/// pixel's frame their sum; `optics_started` when the optics stage began (no light split).
fn dual_pixel_imaged(
    sensor: &Sensor,
    irradiance: SpectralImage,
    optics_started: Instant,
    req: &CaptureRequest,
    capture_half: impl Fn(&Sensor, usize, &CaptureRequest) -> Result<Captured>,
) -> Result<Imaged> {
    let optics_s = optics_started.elapsed().as_secs_f64();
    let t = Instant::now();
    let photodiodes = sensor.dual_pixel_photodiodes()?;
    let one = dual_pixel_request(sensor, &irradiance, req)?;
    let left = dual_pixel_frames(sensor, capture_half(&photodiodes[0], 0, &one)?)?;
    let right = dual_pixel_frames(sensor, capture_half(&photodiodes[1], 1, &one)?)?;
    let (frame, dual) = dual_pixel_frame(left, right)?;
    Ok(Imaged {
        irradiance,
        frame,
        hdr: None,
        optics_s,
        sensor_s: t.elapsed().as_secs_f64(),
        light_split: None,
        dual: Some(dual),
    })
}

/// [`image_owned_groups`] for a dual-pixel sensor: the steady part and each flickering group
/// imaged through each half of the pupil, each photodiode integrating its half's groups over its
/// rows' windows ([`capture_split`]) at one exposure metered on the whole pixel, the raw their
/// sum. The split handed back ([`Imaged::light_split`]) is the whole pixel's, the halves' sums.
fn image_owned_groups_dual(
    image: SpectralImage,
    steady: SpectralImage,
    parts: Vec<(SpectralImage, camsim_sensor::LightTiming)>,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
) -> Result<OwnedImaged> {
    let [left_optics, right_optics] = dual_pixel_half_optics(&image, optics, sensor)?;
    let t = Instant::now();
    let (left_steady, map) = left_optics.compute_mapped(&steady)?;
    let half_split = |o: &Optics, steady: SpectralImage| -> Result<SplitIrradiance> {
        let parts = parts
            .iter()
            .map(|(p, l)| Ok((o.compute(p)?, *l)))
            .collect::<Result<Vec<_>>>()?;
        Ok(SplitIrradiance { steady, parts })
    };
    let halves = [
        half_split(&left_optics, left_steady)?,
        half_split(&right_optics, right_optics.compute(&steady)?)?,
    ];
    drop((steady, parts));
    let mut irradiance = image_sum(&halves[0].steady, &halves[1].steady)?;
    for (p, _) in halves.iter().flat_map(|h| &h.parts) {
        add_into(&mut irradiance, p);
    }
    let mut imaged = dual_pixel_imaged(sensor, irradiance, t, req, |pd, k, one| {
        capture_split(pd, &halves[k], one)
    })?;
    // The whole pixel's split: the right half's light added into the left's, in place.
    let [mut whole, right] = halves;
    add_into(&mut whole.steady, &right.steady);
    for ((a, _), (b, _)) in whole.parts.iter_mut().zip(&right.parts) {
        add_into(a, b);
    }
    imaged.light_split = Some(whole);
    Ok((Some(image), imaged, Some(map)))
}

/// The ADC value each pixel would read at `exposure_s` without shot, read, DSNU and PRNU noise
/// and without quantization, the mean dark signal included (DN, row-major, f32): the mean the
/// raw frames scatter around. `req` gives the global reset and a modulated light, `frame` the
/// frame index (a modulated light's window depends on it).
///
/// With `split` (light groups flickering each in its own way, [`Imaged::light_split`]) the
/// groups' irradiance replaces `irradiance`.
pub fn noise_free_dn(
    sensor: &Sensor,
    irradiance: &SpectralImage,
    split: Option<&SplitIrradiance>,
    exposure_s: f64,
    req: &CaptureRequest,
    frame: u64,
) -> Result<Vec<f32>> {
    let quiet = sensor.with_noise(NoiseSwitches {
        shot: false,
        read: false,
        dsnu: false,
        prnu: false,
        dark: true,
        quantization: false,
    });
    let capture = Capture::seconds(exposure_s)
        .with_global_reset(req.global_reset)
        .with_light(req.light);
    let nf = match split {
        Some(s) => quiet.compute_parts_from(&s.steady, &s.light_parts(), &capture, frame)?,
        None => quiet.compute_from(irradiance, &capture, frame)?,
    };
    nf.analog_dn
        .and_then(|mut v| v.drain(..).next())
        .ok_or_else(|| {
            PipelineError::config("the noise-free sensor pass returned no analog values")
        })
}
