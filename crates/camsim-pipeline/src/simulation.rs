//! The whole pipeline in memory ([`simulate`] -> [`Simulation`]) and, as a separate step, its
//! files ([`Simulation::write`]).

use crate::capture::{frame_suffix, Imaged};
use crate::outputs::{Output, OutputSet};
use crate::records::{raw_png_note, CaptureQuality, RunRecord, RunResults};
use crate::sequence::FrameFlow;
use crate::timing::FrameTime;
use crate::{mean_luminance_cd_m2, Isp, PipelineError, Progress, Result, SimulateConfig};
use camsim_core::{CfaChannel, RawImage, SpectralImage};
use camsim_io::atomic::OutputDir;
use camsim_io::dng::DngMetadata;
use camsim_io::exr::ExrOptions;
use camsim_optics::OpticsConfig;
use camsim_sensor::SensorConfig;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What [`simulate`] computes besides the default images.
#[derive(Debug, Clone, Copy, Default)]
pub struct SimulateOptions {
    /// Also compute [`Simulation::noise_free_dn`] (a second, noise-free pass of the sensor).
    pub noise_free: bool,
    /// Also compute the training-data labels of a 3D scene ([`Simulation::labels`];
    /// [`crate::OutputSet::label_request`] says which the outputs need).
    pub labels: Option<camsim_render::LabelRequest>,
    /// Also compute [`Simulation::flow`] (3D scenes: the optical flow of every frame).
    pub flow: bool,
}

/// Where a run came from, for run.json (the library reads neither the command line nor the
/// environment: the caller says).
#[derive(Debug, Clone, Default)]
pub struct RunInfo {
    /// The command line that ran it, if any.
    pub command: Option<String>,
    /// The config file it was read from, if any.
    pub config_file: Option<PathBuf>,
}

/// An sRGB 8-bit image, interleaved R, G, B, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Rgb8Image {
    pub rows: usize,
    pub cols: usize,
    /// `rows * cols * 3` values.
    pub data: Vec<u8>,
}

/// One run of the pipeline, held in memory: every stage's image and the effective configs.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The effective config (every default filled in): running it again gives the same result.
    pub config: SimulateConfig,
    /// The lens used.
    pub optics: OpticsConfig,
    /// The sensor used (its window).
    pub sensor: SensorConfig,
    /// Scene spectral radiance, W/(sr m^2 nm); `depth_m` holds the depth map of 3D scenes. `None`
    /// when the scene's camera is a lens (`realistic`, `raytransfer`): its render is already the
    /// sensor-plane irradiance, in `irradiance` (with the depth map).
    pub radiance: Option<SpectralImage>,
    /// Object and material ids per scene pixel of a rendered 3D scene (None for 2D charts).
    pub ids: Option<camsim_render::IdMaps>,
    /// With [`SimulateOptions::labels`], a 3D scene's training-data labels in the render's and
    /// the raw image's geometry (a moving scene's: the first frame's, at its window's start).
    pub labels: Option<crate::labels::SimLabels>,
    /// A moving scene with [`SimulateOptions::labels`]: the labels of raw frames 2, 3, ... (file
    /// order; each at its own window's start), with their render's depth and id maps. Empty
    /// otherwise (a static scene's `labels`, `ids` and depth serve every frame).
    pub later_frame_labels: Vec<crate::labels::FrameLabels>,
    /// Sensor-plane spectral irradiance, W/(m^2 nm).
    pub irradiance: SpectralImage,
    /// The raw frames (ADC values, DN; black and white level in each). An `[hdr]` sensor's:
    /// its high readout (HCG / large photodiode), with the rest of its capture in `hdr`.
    pub frames: Vec<RawImage>,
    /// An `[hdr]` sensor (dual conversion gain, split pixel): per raw frame its low readout and
    /// its merged linear frame, and the merge's model. `None` for other sensors.
    pub hdr: Option<crate::HdrReadouts>,
    /// A dual-pixel sensor ([`camsim_sensor::dual_pixel`]): per raw frame its left and right
    /// photodiodes' raws (`frames` holds their sums; raw_left.dng, raw_right.dng). `None` for
    /// other sensors.
    pub dual_pixel: Option<crate::capture::DualPixelReadouts>,
    /// An exposure bracket (`capture.exposures_ms`) of a plain sensor: all its frames merged
    /// into one linear HDR frame (merged.exr; the preview renders it). `None` otherwise.
    pub bracket_merge: Option<BracketMerge>,
    /// With [`SimulateOptions::noise_free`], per raw frame (file order): the ADC value each
    /// pixel would read without shot, read, DSNU and PRNU noise and without quantization, the
    /// mean dark signal included (DN, row-major, f32): the mean the frame scatters around (a
    /// moving scene's frames each their own; a bracket's each at its exposure).
    pub noise_free_dn: Option<Vec<Vec<f32>>>,
    /// The preview: bilinear demosaic of the first frame, colour-corrected to sRGB (the ISP of
    /// its CFA's family, [`crate::Isp::compute`]); where the ISP fails, the raw mosaic in grey.
    pub preview: Rgb8Image,
    /// Why the preview is the raw mosaic in grey (the ISP's error), or None.
    pub preview_note: Option<String>,
    /// Exposure time used, s.
    pub exposure_s: f64,
    /// Noise-free mean electrons per channel r, g, b.
    pub mean_electrons_rgb: [f64; 3],
    /// Mean DN of the first frame per channel r, g, b (black level included).
    pub mean_dn_rgb: [f64; 3],
    /// DNG metadata of the raw frames (camera, colour matrix, neutral, the config).
    pub dng: DngMetadata,
    /// Seconds per stage ("scene_s", "optics_s", "sensor_s" (with the noise-free pass), "isp_s",
    /// "total_s"; "labels_s" with labels; a 3D scene's "scene_setup_s", the part of "scene_s"
    /// before its first render: reading the scene, its overlays and `[render.compose]` with its
    /// settling).
    pub times_s: serde_json::Map<String, serde_json::Value>,
    /// Per raw frame (file order), its window in the scene's time ([`crate::timing`]).
    pub frame_times: Vec<FrameTime>,
    /// The 3D scene moves: every frame was rendered in its own window.
    pub moving: bool,
    /// What `[render.compose]` drew and where it came to rest (run.json's `compose`).
    pub compose: Option<camsim_compose::ComposeRecord>,
    /// A 3D scene: the samples its render took per pixel (run.json's results.render_samples).
    pub render_samples: Option<crate::records::RenderSamples>,
    /// With [`SimulateOptions::flow`] and a 3D scene: each frame's optical flow on the sensor
    /// grid (sensor pixels, raw.dng's orientation).
    pub flow: Option<Vec<FrameFlow>>,
    /// The sensor's faulty pixels (`[defects]`: hot, dead, stuck), on the raw's grid, sorted by
    /// row then column; written with the raw as `defects.json`. Empty without.
    pub defects: Vec<camsim_sensor::defects::Defect>,
    /// With the noise-free image ([`SimulateOptions::noise_free`]): the first raw's and its
    /// preview's PSNR and SSIM against their noise-free counterparts (run.json's
    /// results.quality).
    pub quality: Option<CaptureQuality>,
}

/// [`CaptureQuality`] of `raw` against its noise-free DN `noise_free_dn`.
pub fn capture_quality(
    isp: &Isp,
    raw: &RawImage,
    noise_free_dn: &[f32],
    sensor: &camsim_sensor::Sensor,
) -> Result<CaptureQuality> {
    use camsim_analysis::quality::quality;
    let black = raw.black_level_dn;
    let above = |v: &mut dyn Iterator<Item = f32>| -> Result<camsim_analysis::Plane> {
        Ok(camsim_analysis::Plane::new(
            raw.rows,
            raw.cols,
            v.map(|x| x - black as f32).collect(),
        )?)
    };
    let test = above(&mut raw.dn.iter().map(|d| *d as f32))?;
    let reference = above(&mut noise_free_dn.iter().copied())?;
    let raw_q = quality(&[reference], &[test], (raw.white_level_dn - black).max(1.0))?;
    let preview = match isp.compute_scaled(raw, sensor, 1.0) {
        Ok(noisy) => {
            let mut same = isp.clone();
            same.exposure_scale = Some(noisy.report.exposure_scale);
            let mut clean = raw.clone();
            let max = raw.white_level_dn.max(0.0) as f32;
            for (d, v) in clean.dn.iter_mut().zip(noise_free_dn) {
                *d = (v.clamp(0.0, max) + 0.5) as u16;
            }
            let clean = same.compute_scaled(&clean, sensor, 1.0)?;
            let planes = |img: &Rgb8Image| -> Result<Vec<camsim_analysis::Plane>> {
                (0..3)
                    .map(|c| {
                        Ok(camsim_analysis::Plane::new(
                            img.rows,
                            img.cols,
                            img.data
                                .iter()
                                .skip(c)
                                .step_by(3)
                                .map(|v| *v as f32)
                                .collect(),
                        )?)
                    })
                    .collect()
            };
            Some(quality(
                &planes(&clean.preview)?,
                &planes(&noisy.preview)?,
                255.0,
            )?)
        }
        Err(_) => None,
    };
    Ok(CaptureQuality {
        raw: raw_q,
        preview,
    })
}

/// Run the pipeline in memory: scene (2D chart or 3D render) -> optics -> sensor -> ISP preview.
/// Reads only the files the config names (scene files, pbrt scenes, lens or sensor files);
/// writes nothing. `progress(stage, done, total)` is called as long steps advance.
pub fn simulate(
    cfg: &SimulateConfig,
    opts: &SimulateOptions,
    progress: &Progress<'_>,
) -> Result<Simulation> {
    let t0 = Instant::now();
    let optics = cfg.optics()?;
    let sensor = cfg.sensor()?;
    if opts.noise_free && sensor.hdr_model().is_some() {
        return Err(PipelineError::config(format!(
            "sensor {}: the noise-free image of an [hdr] sensor (dual conversion gain / split pixel) is not modelled: \
             leave noise-free out (merged.exr holds its merged linear frame)",
            sensor.name()
        )));
    }
    let mut request = cfg.capture_request()?;
    request.global_reset = cfg.capture.shutter.sensor_global_reset(sensor.rows());
    let mut times = serde_json::Map::new();
    let lap = |times: &mut serde_json::Map<String, serde_json::Value>, name: &str, t: Instant| {
        times.insert(name.into(), t.elapsed().as_secs_f64().into());
    };

    // Scene, optics and sensor, frame by frame in time when the scene moves.
    let render_request = camsim_render::RenderRequest {
        labels: opts.labels,
        ..Default::default()
    };
    let crate::sequence::Staged {
        radiance,
        ids,
        labels: scene_labels,
        scene,
        map,
        imaged:
            Imaged {
                irradiance,
                frame,
                hdr,
                optics_s,
                sensor_s,
                light_split: _,
                dual,
            },
        times: frame_times,
        flow,
        noise_free: noise_free_dn,
        frame_labels,
        labels_s,
        scene_s,
        scene_setup_s,
        moving,
        compose,
        samples: render_samples,
    } = crate::sequence::stage(
        cfg,
        &sensor,
        &optics,
        &request,
        opts,
        &render_request,
        progress,
    )?;
    times.insert("scene_s".into(), scene_s.into());
    if let Some(setup_s) = scene_setup_s {
        times.insert("scene_setup_s".into(), setup_s.into());
    }
    times.insert("optics_s".into(), optics_s.into());
    let t = Instant::now();
    let mut later_frame_labels = frame_labels;
    let labels = if later_frame_labels.is_empty() {
        match (scene_labels, &scene, opts.labels) {
            (Some(l), Some(scene), Some(req)) => Some(crate::labels::sensor_labels(
                scene,
                l,
                req,
                &sensor,
                &irradiance,
                map.as_ref(),
            )?),
            _ => None,
        }
    } else {
        // A moving scene's, made frame by frame: the first frame's depth and ids are already
        // the run's (`radiance`, `ids`).
        Some(later_frame_labels.remove(0).labels)
    };
    if labels.is_some() {
        times.insert(
            "labels_s".into(),
            (t.elapsed().as_secs_f64() + labels_s).into(),
        );
    }

    times.insert("sensor_s".into(), sensor_s.into());

    let t = Instant::now();
    progress("isp", 0, 1);
    // The paper's ISP under the scene's illuminant: bilinear demosaic (RGBW frames: the W-guided
    // fusion; other CFAs: the per-filter bilinear planes), white balance from the illuminant,
    // colour matrix from the QE.
    let isp = Isp::for_config(cfg)?;
    let dng = isp.dng_metadata(&sensor, Some(serde_json::to_string(cfg)?))?;
    let raw0 = frame
        .raw
        .first()
        .ok_or_else(|| PipelineError::config("the sensor returned no frame"))?;
    // The raw is written whatever the preview does: a frame the ISP cannot render (a filter set
    // its colour fit cannot handle, say) gets its mosaic in grey as the preview, and the reason
    // in `preview_note` (run.json's note on preview.png).
    // An exposure bracket of a plain sensor: its frames merged into one linear HDR frame.
    let bracket_merge = match (&cfg.capture.exposures_ms, &hdr) {
        (Some(_), None) if frame.raw.len() > 1 => Some(merge_bracket(&frame.raw, &sensor)?),
        _ => None,
    };
    let merged_isp = merged_isp(&isp, cfg);
    let (preview, preview_note) = match &bracket_merge {
        Some(m) => merged_preview(&merged_isp, raw0, &m.merged.electrons, &m.mosaic, &sensor)?,
        None => frame_preview(&isp, &merged_isp, raw0, hdr.as_ref(), 0, &sensor)?,
    };
    let mean_dn_rgb = mean_dn_per_channel(raw0);
    let quality = match (&noise_free_dn, &hdr) {
        (Some(nf), None) => Some(capture_quality(&isp, raw0, &nf[0], &sensor)?),
        _ => None,
    };
    lap(&mut times, "isp_s", t);
    lap(&mut times, "total_s", t0);

    Ok(Simulation {
        config: cfg.clone(),
        optics: optics.config().clone(),
        sensor: sensor.config().clone(),
        radiance,
        ids,
        labels,
        later_frame_labels,
        irradiance,
        exposure_s: frame.exposure_s,
        mean_electrons_rgb: frame.mean_electrons,
        frames: frame.raw,
        hdr,
        dual_pixel: dual,
        bracket_merge,
        noise_free_dn,
        preview,
        preview_note,
        mean_dn_rgb,
        dng,
        times_s: times,
        frame_times,
        moving,
        compose,
        render_samples,
        flow,
        defects: sensor.defect_list().to_vec(),
        quality,
    })
}

/// defects.json: the faulty pixels of a `rows` x `cols` raw, with their counts by kind.
pub fn defects_record(
    rows: usize,
    cols: usize,
    defects: &[camsim_sensor::defects::Defect],
) -> serde_json::Value {
    use camsim_sensor::defects::DefectKind;
    let count = |k: DefectKind| defects.iter().filter(|d| d.kind == k).count();
    let counts = serde_json::json!({
        "hot": count(DefectKind::Hot),
        "dead": count(DefectKind::Dead),
        "stuck": count(DefectKind::Stuck),
        "rtn": count(DefectKind::Rtn),
    });
    serde_json::json!({
        "rows": rows,
        "cols": cols,
        "counts": counts,
        "defects": defects,
    })
}

/// An exposure bracket merged ([`camsim_isp::hdr_merge`]) and how its frame maps to a 16-bit
/// mosaic for the preview.
#[derive(Debug, Clone)]
pub struct BracketMerge {
    /// Electrons at the longest exposure, per pixel; per-pixel sigma; saturated count.
    pub merged: camsim_isp::hdr_merge::Merged,
    /// The merged frame's range for the preview.
    pub mosaic: MosaicRange,
}

/// How a merged linear frame (electrons) maps to a 16-bit mosaic for the ISP
/// ([`RawImage::linear_mosaic16`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosaicRange {
    /// The largest merged value (its saturation), e-.
    pub max_e: f64,
    /// The black pedestal, e- (the raw's black level over K).
    pub pedestal_e: f64,
    /// K of the readout the electrons are counted in, DN per e- (the noise model's scale).
    pub k_dn_per_e: f64,
}

/// Merge a bracket's frames with `sensor`'s noise model: K, the temporal noise at zero signal
/// (read and quantization) and the saturation (the smaller of the ADC range and the full well),
/// its DSNU pattern subtracted as a calibration dark frame.
fn merge_bracket(frames: &[RawImage], sensor: &camsim_sensor::Sensor) -> Result<BracketMerge> {
    let k = sensor.k_dn_per_e();
    let nz = sensor.predicted_noise_dn(0.0, 0.0);
    let black = frames[0].black_level_dn;
    let saturation_dn = (frames[0].white_level_dn - black).min(sensor.well_capacity_e() * k);
    let noise = camsim_isp::hdr_merge::MergeNoise {
        gain_dn_per_e: k,
        read_noise_dn: nz.read.hypot(nz.quantization),
        saturation_dn,
    };
    // The calibration dark frame (DSNU): an offset is not exposure-proportional.
    let dark = sensor.fixed_offset_dn()?;
    let merged = camsim_isp::hdr_merge::merge_frames(frames, &noise, Some(&dark))
        .map_err(PipelineError::config)?;
    let t_min = frames
        .iter()
        .map(|f| f.exposure_s)
        .fold(f64::INFINITY, f64::min);
    Ok(BracketMerge {
        mosaic: MosaicRange {
            max_e: saturation_dn / k * merged.reference_exposure_s / t_min,
            pedestal_e: black / k,
            k_dn_per_e: k,
        },
        merged,
    })
}

/// The ISP of merged HDR frames: the run's, with `[isp] tone_map` or, absent, Reinhard's.
fn merged_isp(isp: &Isp, cfg: &SimulateConfig) -> Isp {
    Isp {
        tone_map: cfg
            .isp
            .tone_map
            .unwrap_or(camsim_isp::tone::ToneMap::Reinhard),
        ..isp.clone()
    }
}

/// The preview of a merged linear frame `values` (electrons; `like`'s geometry and CFA) as a
/// 16-bit mosaic of `range` ([`RawImage::linear_mosaic16`]), so the preview shows the range the
/// merge recovers.
fn merged_preview(
    isp: &Isp,
    like: &RawImage,
    values: &[f32],
    range: &MosaicRange,
    sensor: &camsim_sensor::Sensor,
) -> Result<(Rgb8Image, Option<String>)> {
    let (m, s) = RawImage::linear_mosaic16(values, like, range.max_e, range.pedestal_e)?;
    preview_or_mosaic(isp, &m, sensor, s / range.k_dn_per_e)
}

/// The preview of raw frame `i` (`raw`): the ISP's rendering of it or, for an `[hdr]` sensor,
/// of its merged linear frame (with `merged_isp`).
fn frame_preview(
    isp: &Isp,
    merged_isp: &Isp,
    raw: &RawImage,
    hdr: Option<&crate::HdrReadouts>,
    i: usize,
    sensor: &camsim_sensor::Sensor,
) -> Result<(Rgb8Image, Option<String>)> {
    match hdr {
        Some(h) => {
            let merged = h.merged_e.get(i).ok_or_else(|| {
                PipelineError::config(format!("the HDR capture has no merged frame {i}"))
            })?;
            let m = &h.model;
            let range = MosaicRange {
                max_e: m.max_merged_e(),
                pedestal_e: m.black_dn / m.k_high_dn_per_e,
                k_dn_per_e: m.k_high_dn_per_e,
            };
            merged_preview(merged_isp, raw, merged, &range, sensor)
        }
        None => preview_or_mosaic(isp, raw, sensor, 1.0),
    }
}

/// The ISP's preview of `raw` (DN `noise_scale` x those `sensor` reads, [`Isp::compute_scaled`]),
/// or, where the ISP fails, the mosaic in grey (DN above black at the automatic exposure) with
/// the ISP's error as the note.
fn preview_or_mosaic(
    isp: &Isp,
    raw: &RawImage,
    sensor: &camsim_sensor::Sensor,
    noise_scale: f64,
) -> Result<(Rgb8Image, Option<String>)> {
    match isp.compute_scaled(raw, sensor, noise_scale) {
        Ok(o) => Ok((o.preview, None)),
        Err(e) => {
            let grey = camsim_isp::cfa_render::mono_rgb(raw)?;
            let scale = camsim_isp::cfa_render::auto_exposure_linear_srgb(&grey);
            let data = camsim_isp::cfa_render::render_linear_srgb8(
                &grey,
                scale,
                Some(raw.white_level_dn - raw.black_level_dn),
            );
            Ok((
                Rgb8Image {
                    rows: raw.rows,
                    cols: raw.cols,
                    data,
                },
                Some(format!(
                    "the raw mosaic in grey: the ISP could not render this frame ({e})"
                )),
            ))
        }
    }
}

/// Mean DN over the pixels of each channel r, g, b (0 where a channel has none).
fn mean_dn_per_channel(raw: &RawImage) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    let mut n = [0usize; 3];
    if let Some(layout) = &raw.layout {
        // A general CFA: the r, g, b filters' pixels (other filters, e.g. w, are not counted).
        let rgb: Vec<Option<usize>> = layout
            .filters()
            .iter()
            .map(|f| ["r", "g", "b"].iter().position(|c| c == f))
            .collect();
        for r in 0..raw.rows {
            for c in 0..raw.cols {
                if let Some(i) = rgb[layout.filter_at(r, c)] {
                    sum[i] += raw.at(r, c) as f64;
                    n[i] += 1;
                }
            }
        }
        return [0, 1, 2].map(|i| sum[i] / n[i].max(1) as f64);
    }
    for r in 0..raw.rows {
        for c in 0..raw.cols {
            let i = match raw.channel_at(r, c) {
                CfaChannel::R => 0,
                CfaChannel::G => 1,
                CfaChannel::B => 2,
            };
            sum[i] += raw.at(r, c) as f64;
            n[i] += 1;
        }
    }
    [0, 1, 2].map(|i| sum[i] / n[i].max(1) as f64)
}

impl Simulation {
    /// Raw frame `i`'s noise-free image (DN, row-major), with [`SimulateOptions::noise_free`].
    pub fn noise_free_frame(&self, i: usize) -> Option<&[f32]> {
        self.noise_free_dn.as_ref()?.get(i).map(|v| v.as_slice())
    }

    /// Every raw frame's preview (the ISP of the run's config: what [`Simulation::preview`] is
    /// for the first frame).
    pub fn frame_previews(&self) -> Result<Vec<Rgb8Image>> {
        let sensor = self.config.sensor()?;
        let isp = Isp::for_config(&self.config)?;
        let merged = merged_isp(&isp, &self.config);
        self.frames
            .iter()
            .enumerate()
            .map(|(i, raw)| Ok(frame_preview(&isp, &merged, raw, self.hdr.as_ref(), i, &sensor)?.0))
            .collect()
    }

    /// How long each frame of preview.gif is shown, ms: the first frame interval (10 ms
    /// minimum, GIF's unit is 10 ms), or 100 ms for a single instant.
    pub fn gif_delay_ms(&self) -> u32 {
        let dt_s = match self.frame_times.as_slice() {
            [a, b, ..] => b.start_s - a.start_s,
            _ => 0.1,
        };
        ((dt_s * 1e3).round() as u32).max(10)
    }

    /// The image the scene stage made: the radiance, or a lens camera's irradiance (which also
    /// carries the depth map and the wavelength grid then).
    pub fn scene_image(&self) -> &SpectralImage {
        self.radiance.as_ref().unwrap_or(&self.irradiance)
    }

    /// The run's record (run.json): version, configs, results, the files written and the times.
    /// `camsim simulate run.json` repeats the run from it.
    pub fn record(&self, info: &RunInfo, outputs: &OutputSet) -> RunRecord {
        RunRecord {
            camera: self.labels.as_ref().map(|l| l.cameras_json()),
            compose: self.compose.clone(),
            camsim_version: env!("CARGO_PKG_VERSION").into(),
            command: info.command.clone(),
            config: self.config.clone(),
            config_file: info.config_file.as_ref().map(|p| p.display().to_string()),
            files: self.file_notes(outputs),
            optics: self.optics.clone(),
            outputs: outputs.names(),
            results: RunResults {
                exposure_s: self.exposure_s,
                // An exposure bracket: each raw's exposure time, in file order (raw.dng,
                // raw_0001.dng, ...).
                frame_exposures_s: self
                    .config
                    .capture
                    .exposures_ms
                    .is_some()
                    .then(|| self.frames.iter().map(|r| r.exposure_s).collect()),
                frames: self.frames.len(),
                irradiance_sample_spacing_um: self.irradiance.sample_spacing_m * 1e6,
                irradiance_size: [
                    self.irradiance.rows,
                    self.irradiance.cols,
                    self.irradiance.bands(),
                ],
                // A lens camera renders irradiance (no scene radiance to average).
                lens_camera: self.radiance.is_none(),
                mean_dn_rgb: self.mean_dn_rgb,
                mean_electrons_rgb: self.mean_electrons_rgb,
                radiance_size: self.radiance.as_ref().map(|r| [r.rows, r.cols, r.bands()]),
                scene_mean_luminance_cd_m2: self.radiance.as_ref().map(mean_luminance_cd_m2),
                frame_times: self.frame_times.clone(),
                shutter: self.config.capture.shutter.describe(self.frames[0].rows),
                scene_moves: self.moving,
                hdr: self
                    .hdr
                    .as_ref()
                    .map(|h| crate::records::HdrResults::of(&h.model)),
                quality: self.quality,
                render_samples: self.render_samples.clone(),
            },
            sensor: self.sensor.clone(),
            times: self.times_s.clone(),
        }
    }

    /// [`Self::record`] as JSON (keys in alphabetical order).
    pub fn metadata(&self, info: &RunInfo, outputs: &OutputSet) -> serde_json::Value {
        self.record(info, outputs).to_value()
    }

    /// run.json's `files`: what each output holds, or why it was not written.
    fn file_notes(&self, outputs: &OutputSet) -> serde_json::Map<String, serde_json::Value> {
        let raw0 = &self.frames[0];
        let mut files = serde_json::Map::new();
        if outputs.contains(Output::Raw) {
            match &self.hdr {
                None => {
                    files.insert(
                        "raw.dng".into(),
                        "the exact ADC values (DN), black and white level in its tags".into(),
                    );
                    if let Some(b) = &self.bracket_merge {
                        files.insert("merged.exr".into(), format!(
                            "the bracket's frames merged into one linear frame, electrons at the longest exposure ({:.3} ms; channel Y): each pixel's unsaturated samples weighted by their inverse noise variance (Hasinoff et al. 2010); {} pixels saturated in every frame keep the shortest frame's clipped value; the preview renders it",
                            b.merged.reference_exposure_s * 1e3,
                            b.merged.saturated
                        ).into());
                    }
                }
                Some(h) => {
                    let (high, low) = match h.model.mode {
                        camsim_sensor::HdrMode::Dcg => {
                            ("high conversion gain (HCG)", "low conversion gain (LCG)")
                        }
                        camsim_sensor::HdrMode::SplitPixel => {
                            ("large photodiode (LPD)", "small photodiode (SPD)")
                        }
                    };
                    files.insert("raw.dng".into(), format!("the [hdr] sensor's {high} readout: exact ADC values (DN), black and white level in its tags (camsim sensor's high.dng)").into());
                    files.insert("raw_low.dng".into(), format!("its {low} readout (camsim sensor's low.dng; raw_low_0001.dng ... for more frames)").into());
                    files.insert("merged.exr".into(), format!("the merged linear frame, electrons of the high readout (channel Y; merged_0001.exr ... for more frames): the high readout below {:.0} e-, the low one scaled to it above; up to {:.0} e-, dynamic range {:.1} dB", h.model.switch_e, h.model.max_merged_e(), h.model.dynamic_range_db()).into());
                }
            }
        }
        if let (true, Some(_)) = (outputs.contains(Output::Raw), &self.dual_pixel) {
            files.insert(
                "raw.dng".into(),
                "the dual-pixel sensor's pixels: the digital sum of each pixel's two photodiode reads (DN, black level once), black and white level in its tags".into(),
            );
            files.insert(
                "raw_left.dng".into(),
                "each pixel's left photodiode (the light through the pupil's left half, x < 0): its own read, half the well (raw_left_0001.dng ... for more frames; camsim analyze dual-pixel measures the disparity)".into(),
            );
            files.insert(
                "raw_right.dng".into(),
                "each pixel's right photodiode (the pupil's right half, x > 0)".into(),
            );
        }
        if outputs.contains(Output::Raw) && !self.defects.is_empty() {
            files.insert(
                "defects.json".into(),
                "the sensor's faulty pixels ([defects]): row and column on the raw's grid and kind (hot, dead, stuck, rtn), with counts; the same for every frame and every run of this sensor and fixed_pattern_seed".into(),
            );
        }
        if outputs.contains(Output::RawPng) {
            files.insert("raw.png".into(), raw_png_note(raw0.bits));
        }
        if outputs.contains(Output::Radiance) && self.radiance.is_none() {
            files.insert(
                "radiance.exr".into(),
                "not written: the scene's lens camera renders the sensor-plane irradiance directly (irradiance.exr); the [optics] section is not used".into(),
            );
        }
        if outputs.contains(Output::Depth) {
            let note = match self.scene_image().depth_m {
                Some(_) => "the scene's depth map, m (channel Z)",
                None => "not written: this scene (a 2D chart) has no depth map",
            };
            files.insert("depth.exr".into(), note.into());
        }
        if outputs.contains(Output::Ids) {
            match &self.ids {
                Some(ids) => {
                    files.insert("object_id.png".into(), "1 + index of the shape met first through each scene pixel's centre (16-bit; 0 = none)".into());
                    files.insert(
                        "material_id.png".into(),
                        "1 + index of that shape's material (16-bit; 0 = none)".into(),
                    );
                    files.insert(
                        "ids.json".into(),
                        serde_json::to_value(ids.legend()).unwrap_or_default(),
                    );
                }
                None => {
                    files.insert(
                        "ids".into(),
                        "not written: this scene (a 2D chart or a scene file) has no object ids"
                            .into(),
                    );
                }
            }
        }
        let label_outputs = Output::LABELS.iter().any(|o| outputs.contains(*o));
        match (&self.labels, label_outputs) {
            (Some(_), _) => {
                for (o, name, what) in [
                    (Output::Instances, "instances.png", "instance id (16-bit; 0 = none) on the raw image's grid; instances.scene.png on the render's"),
                    (Output::Normals, "normals.exr", "surface normals on the raw grid, camera frame camera.X/Y/Z and world.X/Y/Z; normals.scene.exr on the render's"),
                    (Output::Albedo, "albedo.exr", "first surface's reflectance on the raw grid: linear sRGB R, G, B and spectral T.<wavelength>nm; albedo.scene.exr on the render's"),
                    (Output::Boxes, "boxes.json", "per instance: 3D box (camera frame), 2D boxes on both grids, visible fraction, truncation; the cameras"),
                    (Output::Depth, "depth.sensor.exr", "the depth map resampled onto the raw grid, m"),
                    (Output::Ids, "object_id.sensor.png", "object ids on the raw grid (material_id.sensor.png alike)"),
                ] {
                    if outputs.contains(o) {
                        files.insert(name.into(), what.into());
                    }
                }
            }
            (None, true) => {
                files.insert(
                    "labels".into(),
                    "not written: this scene (a 2D chart) has no labels".into(),
                );
            }
            (None, false) => {}
        }
        let per_frame =
            outputs.contains(Output::Depth) || outputs.contains(Output::Ids) || label_outputs;
        if per_frame && !self.later_frame_labels.is_empty() {
            files.insert(
                "labels_per_frame".into(),
                "the scene moves: depth, ids and labels are written per raw frame, each a sharp snapshot of the scene at the start of that frame's window (each render row's start under a rolling shutter: the instant of flow's first hit), while the frame's image is blurred over its window; frame 1's under the names above, later frames numbered as raw.dng's (depth_0001.exr, object_id_0001.png, instances_0001.png, instances_0001.scene.png, depth_0001.sensor.exr, boxes_0001.json, ...)".into(),
            );
        }
        if outputs.contains(Output::Flow) {
            let note = match &self.flow {
                Some(_) => "optical flow of each frame (flow.exr, flow_0001.exr, ...; flow_next*.exr to the next frame), sensor pixels, channels X (right) and Y (down), aligned with raw.dng: where the surface each pixel sees at the frame's start is at the end of its exposure",
                None => "not written: this scene (a 2D chart) has no optical flow",
            };
            files.insert("flow.exr".into(), note.into());
        }
        if outputs.contains(Output::Preview) {
            if let Some(note) = &self.preview_note {
                files.insert("preview.png".into(), note.clone().into());
            }
        }
        if outputs.contains(Output::PreviewGif) {
            let note = if self.frames.len() > 1 {
                format!(
                    "every frame's preview as an animation, {} ms per frame (256 colours per frame: for viewing)",
                    self.gif_delay_ms()
                )
            } else {
                "not written: the run has one frame".into()
            };
            files.insert("preview.gif".into(), note.into());
        }
        if outputs.contains(Output::NoiseFree) {
            files.insert(
                "noise_free.exr".into(),
                "expected ADC value per pixel without noise or quantization, DN (channel Y); one per raw frame (noise_free.exr, noise_free_0001.exr, ...)".into(),
            );
        }
        files
    }

    /// Write the chosen outputs and run.json into folder `dir`, atomically as a whole: the files
    /// go into a staging folder beside it, which then replaces `dir` (an earlier camsim run there
    /// is replaced; any other existing content is refused).
    pub fn write(
        &self,
        dir: &Path,
        outputs: &OutputSet,
        exr: ExrOptions,
        info: &RunInfo,
    ) -> Result<()> {
        let out = OutputDir::create(dir)?;
        self.write_into(&out, outputs, exr, info)?;
        out.commit()?;
        Ok(())
    }

    /// [`Self::write`] into a staging folder the caller commits.
    pub fn write_into(
        &self,
        out: &OutputDir,
        outputs: &OutputSet,
        exr: ExrOptions,
        info: &RunInfo,
    ) -> Result<()> {
        if outputs.contains(Output::NoiseFree) && self.noise_free_dn.is_none() {
            return Err(PipelineError::config("noise-free output asked for, but the run did not compute it (SimulateOptions::noise_free)"));
        }
        if outputs.contains(Output::Flow) && self.flow.is_none() && self.ids.is_some() {
            return Err(PipelineError::config(
                "flow output asked for, but the run did not compute it (SimulateOptions::flow)",
            ));
        }
        // The files are independent: write them side by side (each EXR also compresses its blocks
        // on every thread).
        let tasks: Vec<Box<dyn Fn() -> Result<()> + Sync + '_>> = {
            let mut t: Vec<Box<dyn Fn() -> Result<()> + Sync + '_>> = Vec::new();
            if let (true, Some(radiance)) =
                (outputs.contains(Output::Radiance), self.radiance.as_ref())
            {
                t.push(Box::new(move || {
                    Ok(camsim_io::exr::write_spectral_exr_with(
                        &out.join("radiance.exr"),
                        radiance,
                        "scene",
                        exr,
                    )?)
                }));
            }
            if outputs.contains(Output::Irradiance) {
                t.push(Box::new(move || {
                    Ok(camsim_io::exr::write_spectral_exr_with(
                        &out.join("irradiance.exr"),
                        &self.irradiance,
                        "optics",
                        exr,
                    )?)
                }));
            }
            // 2D charts have no depth map: depth.exr only for 3D scenes (run.json says which).
            let scene = self.scene_image();
            if let (true, Some(d)) = (outputs.contains(Output::Depth), scene.depth_m.as_deref()) {
                t.push(Box::new(move || {
                    Ok(camsim_io::exr::write_gray_exr(
                        &out.join("depth.exr"),
                        scene.rows,
                        scene.cols,
                        "Z",
                        d,
                    )?)
                }));
            }
            if let (true, Some(ids)) = (outputs.contains(Output::Ids), self.ids.as_ref()) {
                t.push(Box::new(move || write_id_maps(out.path(), ids)));
            }
            if let Some(l) = &self.labels {
                t.push(Box::new(move || l.write(out.path(), outputs, 0)));
            }
            // A moving scene's later frames: depth_0001.exr, object_id_0001.png, ... and their
            // labels (instances_0001.png, ...).
            for (j, f) in self.later_frame_labels.iter().enumerate() {
                let i = j + 1;
                if outputs.contains(Output::Depth) {
                    t.push(Box::new(move || {
                        Ok(camsim_io::exr::write_gray_exr(
                            &out.join(format!("depth{}.exr", frame_suffix(i))),
                            f.ids.height,
                            f.ids.width,
                            "Z",
                            &f.depth_m,
                        )?)
                    }));
                }
                if outputs.contains(Output::Ids) {
                    t.push(Box::new(move || id_map_pngs(out.path(), &f.ids, i)));
                }
                t.push(Box::new(move || f.labels.write(out.path(), outputs, i)));
            }
            if let (true, Some(nfs)) = (
                outputs.contains(Output::NoiseFree),
                self.noise_free_dn.as_ref(),
            ) {
                let (rows, cols) = (self.frames[0].rows, self.frames[0].cols);
                for (i, nf) in nfs.iter().enumerate() {
                    t.push(Box::new(move || {
                        Ok(camsim_io::exr::write_gray_exr(
                            &out.join(format!("noise_free{}.exr", frame_suffix(i))),
                            rows,
                            cols,
                            "Y",
                            nf,
                        )?)
                    }));
                }
            }
            if let (true, Some(flows)) = (outputs.contains(Output::Flow), self.flow.as_ref()) {
                let (rows, cols) = (self.frames[0].rows, self.frames[0].cols);
                for (i, f) in flows.iter().enumerate() {
                    let maps = std::iter::once(("flow", &f.exposure))
                        .chain(f.to_next.as_ref().map(|n| ("flow_next", n)));
                    for (base, map) in maps {
                        t.push(Box::new(move || {
                            write_flow(
                                &out.join(format!("{base}{}.exr", frame_suffix(i))),
                                rows,
                                cols,
                                map,
                            )
                        }));
                    }
                }
            }
            if outputs.contains(Output::Raw) {
                for (i, raw) in self.frames.iter().enumerate() {
                    t.push(Box::new(move || {
                        let name = format!("raw{}.dng", frame_suffix(i));
                        Ok(camsim_io::dng::write_dng(&out.join(name), raw, &self.dng)?)
                    }));
                }
                // `[defects]`: the faulty-pixel map the raw was made with.
                if !self.defects.is_empty() {
                    let (rows, cols) = (self.frames[0].rows, self.frames[0].cols);
                    let defects = &self.defects;
                    t.push(Box::new(move || {
                        Ok(camsim_io::atomic::write_json_atomic(
                            &out.join("defects.json"),
                            &defects_record(rows, cols, defects),
                        )?)
                    }));
                }
                // An exposure bracket: its merged frame.
                if let Some(b) = &self.bracket_merge {
                    let r0 = &self.frames[0];
                    t.push(Box::new(move || {
                        Ok(camsim_io::exr::write_gray_exr(
                            &out.join("merged.exr"),
                            r0.rows,
                            r0.cols,
                            "Y",
                            &b.merged.electrons,
                        )?)
                    }));
                }
                // A dual-pixel sensor: its photodiodes' raws beside each raw (their sum).
                if let Some(d) = &self.dual_pixel {
                    for (i, (l, r)) in d.left.iter().zip(&d.right).enumerate() {
                        for (side, raw) in [("left", l), ("right", r)] {
                            t.push(Box::new(move || {
                                let name = format!("raw_{side}{}.dng", frame_suffix(i));
                                Ok(camsim_io::dng::write_dng(&out.join(name), raw, &self.dng)?)
                            }));
                        }
                    }
                }
                // An [hdr] sensor: its low readout and merged frame beside each raw.
                if let Some(h) = &self.hdr {
                    for (i, (low, merged)) in h.low.iter().zip(&h.merged_e).enumerate() {
                        t.push(Box::new(move || {
                            let name = format!("raw_low{}.dng", frame_suffix(i));
                            Ok(camsim_io::dng::write_dng(&out.join(name), low, &self.dng)?)
                        }));
                        t.push(Box::new(move || {
                            Ok(camsim_io::exr::write_gray_exr(
                                &out.join(format!("merged{}.exr", frame_suffix(i))),
                                low.rows,
                                low.cols,
                                "Y",
                                merged,
                            )?)
                        }));
                    }
                }
            }
            if outputs.contains(Output::RawPng) {
                t.push(Box::new(move || {
                    let raw0 = &self.frames[0];
                    Ok(camsim_io::raster::write_png16_mosaic_scaled(
                        &out.join("raw.png"),
                        raw0.rows,
                        raw0.cols,
                        &raw0.dn,
                        raw0.bits,
                    )?)
                }));
            }
            if outputs.contains(Output::PreviewGif) && self.frames.len() > 1 {
                t.push(Box::new(move || {
                    let previews = self.frame_previews()?;
                    let p = &previews[0];
                    let data: Vec<&[u8]> = previews.iter().map(|p| p.data.as_slice()).collect();
                    Ok(camsim_io::raster::write_gif_rgb(
                        &out.join("preview.gif"),
                        p.rows,
                        p.cols,
                        &data,
                        self.gif_delay_ms(),
                    )?)
                }));
            }
            if outputs.contains(Output::PreviewJpeg) {
                t.push(Box::new(move || {
                    let p = &self.preview;
                    let q = self
                        .config
                        .isp
                        .jpeg_quality
                        .unwrap_or(crate::isp::DEFAULT_JPEG_QUALITY);
                    let bytes = camsim_isp::jpeg::encode_jpeg(p.rows, p.cols, &p.data, q)
                        .map_err(|e| PipelineError::config(format!("isp.jpeg_quality: {e}")))?;
                    Ok(camsim_io::atomic::write_bytes_atomic(
                        &out.join("preview.jpg"),
                        &bytes,
                    )?)
                }));
            }
            if outputs.contains(Output::Preview) {
                t.push(Box::new(move || {
                    let p = &self.preview;
                    Ok(camsim_io::raster::write_png8_rgb(
                        &out.join("preview.png"),
                        p.rows,
                        p.cols,
                        &p.data,
                    )?)
                }));
            }
            t
        };
        use rayon::prelude::*;
        tasks
            .par_iter()
            .map(|task| task())
            .collect::<Result<Vec<()>>>()?;
        // run.json last: its presence marks a complete run.
        self.record(info, outputs).write(&out.join("run.json"))?;
        Ok(())
    }
}

/// Write a flow map (`[dx, dy]` per pixel) as a two-channel EXR: X (right) and Y (down).
pub fn write_flow(path: &Path, rows: usize, cols: usize, flow: &[[f32; 2]]) -> Result<()> {
    let x: Vec<f32> = flow.iter().map(|f| f[0]).collect();
    let y: Vec<f32> = flow.iter().map(|f| f[1]).collect();
    Ok(camsim_io::exr::write_channels_exr(
        path,
        rows,
        cols,
        &[("X", &x), ("Y", &y)],
    )?)
}

/// Write object_id.png and material_id.png (16-bit grey, row-major scene pixels) and ids.json
/// (the legend) into folder `dir`, each file atomically.
pub fn write_id_maps(dir: &std::path::Path, ids: &camsim_render::IdMaps) -> Result<()> {
    id_map_pngs(dir, ids, 0)?;
    camsim_io::atomic::write_json_atomic(&dir.join("ids.json"), &ids.legend())?;
    Ok(())
}

/// object_id.png and material_id.png of raw frame `frame` (`object_id_0001.png`, ... for a
/// later frame of a moving scene, [`frame_suffix`]).
fn id_map_pngs(dir: &Path, ids: &camsim_render::IdMaps, frame: usize) -> Result<()> {
    if ids.max_id() > u16::MAX as u32 {
        return Err(PipelineError::config(format!(
            "ids: the scene has {} shapes or materials, more than a 16-bit id map holds (65535)",
            ids.max_id()
        )));
    }
    for (name, map) in [
        ("object_id", &ids.object_id),
        ("material_id", &ids.material_id),
    ] {
        let v: Vec<u16> = map.iter().map(|&i| i as u16).collect();
        let path = dir.join(format!("{name}{}.png", frame_suffix(frame)));
        camsim_io::raster::write_png16_gray(&path, ids.height, ids.width, &v)?;
    }
    Ok(())
}
