//! The scene, optics and sensor stages of a run, in time: each raw frame's exposure window
//! ([`crate::timing`]) drives the render of a 3D scene that moves, so every frame of a burst,
//! bracket or video is rendered at its own time (with a rolling shutter, each row at its own),
//! imaged and read out with its own temporal noise; optical flow comes with it on the sensor
//! grid. A 2D chart, or a 3D scene where nothing moves, is rendered once and imaged as before
//! (the same bytes).

use crate::capture::{image_owned, image_owned_groups, noise_free_dn, CaptureRequest, Imaged};
use crate::timing::{flow_on_sensor, FrameTime};
use crate::{render, scene_stage_with, Progress, Result, SimulateConfig};
use camsim_core::SpectralImage;
use camsim_optics::Optics;
use camsim_scene3d::SceneDescription;
use camsim_sensor::{Exposure, Frame, Sensor};
use std::time::Instant;

/// Optical flow of one raw frame on the sensor's grid: per pixel `[dx, dy]` in sensor pixels
/// (+x right, +y down, raw.dng's orientation), row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameFlow {
    /// From the surface each pixel sees at the frame's start to where it is at the end of the
    /// exposure.
    pub exposure: Vec<[f32; 2]>,
    /// To where it is at the next frame's start (`None` for the last frame).
    pub to_next: Option<Vec<[f32; 2]>>,
}

/// What the first three stages made.
pub(crate) struct Staged {
    pub radiance: Option<SpectralImage>,
    pub ids: Option<camsim_render::IdMaps>,
    /// The labels `request` asked for (a static 3D scene), with the rendered scene they were
    /// traced in and the optics' map, for their sensor-grid version.
    pub labels: Option<camsim_render::Labels>,
    pub scene: Option<SceneDescription>,
    pub map: Option<camsim_optics::ImageMap>,
    pub imaged: Imaged,
    /// Per raw frame, its window.
    pub times: Vec<FrameTime>,
    pub flow: Option<Vec<FrameFlow>>,
    /// Per raw frame, its noise-free image (DN), when asked for.
    pub noise_free: Option<Vec<Vec<f32>>>,
    /// A moving scene with labels asked for: per raw frame its labels, each at its own time
    /// (empty otherwise: a static scene's `labels` serve every frame).
    pub frame_labels: Vec<crate::labels::FrameLabels>,
    /// Seconds spent on `frame_labels`' raw-grid labels.
    pub labels_s: f64,
    /// Seconds in the scene stage (all renders; a 3D scene's set-up included).
    pub scene_s: f64,
    /// A 3D scene's seconds before its first render: reading the scene and its overlays, and
    /// `[render.compose]` (spawning, settling, the camera's draws and view validation).
    pub scene_setup_s: Option<f64>,
    /// The scene moves: every frame was rendered in its own window.
    pub moving: bool,
    /// What `[render.compose]` drew, when the config has one.
    pub compose: Option<camsim_compose::ComposeRecord>,
    /// The samples the (first frame's) render took per pixel, a 3D scene's.
    pub samples: Option<crate::records::RenderSamples>,
}

/// Sensor pixels per render pixel: a lens camera's film is the sensor window; a pinhole's
/// render pixel lands on the sensor at `2 v tan(hfov / 2) / width` (the optics stage's image
/// distance `v`).
pub fn sensor_px_per_render_px(
    scene: &SceneDescription,
    sensor: &Sensor,
    optics: &Optics,
) -> Result<f64> {
    if scene.camera.lens.is_some() {
        return Ok(sensor.rows() as f64 / scene.camera.height as f64);
    }
    let v_m = render::sensor_image_distance_m(optics.config(), scene.focus_distance_m)?;
    let half = (scene.camera.horizontal_fov_deg().to_radians() / 2.0).tan();
    Ok(2.0 * v_m * half / scene.camera.width as f64 / sensor.pixel_pitch_m())
}

/// Every raw's exposure time, s, in file order.
fn exposures_of(frame: &Frame) -> Vec<f64> {
    frame.raw.iter().map(|r| r.exposure_s).collect()
}

/// The noise-free image of every raw frame of `frame` (exposed as they were), all from one
/// `irradiance` (a scene that does not move); frames of the same exposure share one pass.
fn noise_free_all(sensor: &Sensor, imaged: &Imaged, req: &CaptureRequest) -> Result<Vec<Vec<f32>>> {
    let frame = &imaged.frame;
    let split = imaged.light_split.as_ref();
    let mut out: Vec<Vec<f32>> = Vec::with_capacity(frame.raw.len());
    for (i, raw) in frame.raw.iter().enumerate() {
        // Under a modulated light every frame has its own.
        let same = i > 0
            && frame.raw[i - 1].exposure_s == raw.exposure_s
            && req.light.is_none()
            && req.group_lights.is_empty();
        let nf = if same {
            out[i - 1].clone()
        } else {
            noise_free_dn(
                sensor,
                &imaged.irradiance,
                split,
                raw.exposure_s,
                req,
                i as u64,
            )?
        };
        out.push(nf);
    }
    Ok(out)
}

/// Auto-exposure of a moving scene: the exposure is what the camera meters on a preview of the
/// scene (a render over the scene's own shutter window, pbrt's `shutteropen`/`shutterclose`, at
/// up to [`METERING_SPP`] samples per pixel, through the optics and the sensor's
/// auto-exposure), as a camera meters on its viewfinder stream before it captures; every frame
/// is then rendered over that exposure.
fn metered_exposure_s(
    scene: &SceneDescription,
    r: &crate::RenderSection,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
    progress: &Progress<'_>,
) -> Result<f64> {
    let mut preview = scene.clone();
    preview.settings.samples_per_pixel = preview.settings.samples_per_pixel.min(METERING_SPP);
    preview.settings.time.shutter.rolling = None;
    preview.settings.adaptive = None;
    preview.settings.denoise = None;
    preview.settings.time.flow_intervals_s = Vec::new();
    let out = render::render_stage(
        &preview,
        r,
        &camsim_render::RenderRequest::default(),
        progress,
    )?;
    // A global reset's rows are metered as the sensor meters them (the row read last).
    let one = CaptureRequest {
        bracket_s: None,
        frames: 1,
        ..req.clone()
    };
    let (_, im, _) = image_owned(out.radiance, optics, sensor, &one)?;
    Ok(im.frame.exposure_s)
}

/// `[render.adaptive]`: set `scene`'s adaptive-sampling target ([`crate::adaptive`]). The
/// sensor's noise needs the exposure before the render: a bracket's longest, the given one, or
/// the one metered on a preview render ([`metered_exposure_s`], returned so that a moving
/// scene's frames reuse it). Nothing to do without the table.
pub(crate) fn set_adaptive_target(
    scene: &mut SceneDescription,
    r: &crate::RenderSection,
    optics: &Optics,
    sensor: &Sensor,
    req: &CaptureRequest,
    progress: &Progress<'_>,
) -> Result<Option<f64>> {
    let Some(a) = &r.adaptive else {
        return Ok(None);
    };
    let mut metered = None;
    let exposure_s = if a.relative_error.is_some() {
        0.0
    } else {
        match (&req.bracket_s, req.exposure) {
            (Some(b), _) => b.iter().copied().fold(0.0, f64::max),
            (None, Exposure::Seconds(t)) => t,
            (None, Exposure::Auto { .. }) => {
                let m = metered_exposure_s(scene, r, optics, sensor, req, progress)?;
                metered = Some(m);
                m
            }
        }
    };
    let k = sensor_px_per_render_px(scene, sensor, optics)?;
    scene.settings.adaptive = Some(crate::adaptive::sensor_target(
        a, scene, optics, sensor, exposure_s, k,
    )?);
    Ok(metered)
}

/// Samples per pixel of the metering render of [`metered_exposure_s`] (at most the scene's).
pub(crate) const METERING_SPP: u32 = 16;

/// Run the scene, optics and sensor stages: `opts.flow` computes the optical flow (3D scenes),
/// `opts.noise_free` every frame's noise-free image; `request`: the renderer's extra outputs
/// (labels: a moving scene's come per frame, in `frame_labels`).
pub(crate) fn stage(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    req: &CaptureRequest,
    opts: &crate::SimulateOptions,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<Staged> {
    cfg.capture.check_timing()?;
    let flow = opts.flow;
    let t = Instant::now();
    progress("scene", 0, 1);
    // A modulated light's timing: frame 0 at capture.start_ms, else at the scene's own start
    // (a 3D scene's shutter opening; 0 for a 2D chart).
    if cfg.flicker.is_some() && cfg.light_flicker.is_some() {
        return Err(crate::PipelineError::config(
            "give [flicker] (the whole scene) or [light_flicker] (by light group), not both",
        ));
    }
    let with_light = |start_s: f64| -> Result<CaptureRequest> {
        Ok(CaptureRequest {
            light: cfg
                .capture
                .light_timing(cfg.flicker, sensor.rows(), start_s)?,
            group_lights: cfg.capture.group_light_timings(
                cfg.light_flicker.as_ref(),
                sensor.rows(),
                start_s,
            )?,
            ..req.clone()
        })
    };
    let Some(r) = &cfg.render else {
        if cfg.light_flicker.is_some() {
            return Err(crate::PipelineError::config(
                "[light_flicker] modulates a 3D scene's light groups; a 2D scene has one light: use [flicker]",
            ));
        }
        let req = &with_light(0.0)?;
        let st = scene_stage_with(cfg, sensor, optics, request, progress)?;
        let scene_s = t.elapsed().as_secs_f64();
        progress("optics", 0, 1);
        let (radiance, imaged, map) = image_owned(st.image, optics, sensor, req)?;
        let times = cfg.capture.frame_times(&exposures_of(&imaged.frame), 0.0)?;
        let noise_free = opts
            .noise_free
            .then(|| noise_free_all(sensor, &imaged, req))
            .transpose()?;
        return Ok(Staged {
            radiance,
            ids: st.ids,
            labels: st.labels,
            scene: st.scene,
            map,
            imaged,
            times,
            flow: None,
            noise_free,
            frame_labels: Vec::new(),
            labels_s: 0.0,
            scene_s,
            scene_setup_s: None,
            moving: false,
            compose: None,
            samples: None,
        });
    };
    let (mut scene, compose) = render::render_section_scene_with_record(r, cfg, sensor, optics)?;
    let scene_setup_s = t.elapsed().as_secs_f64();
    let k = sensor_px_per_render_px(&scene, sensor, optics)?;
    let shutter = scene.settings.time.shutter;
    let req = &with_light(shutter.open_s)?;
    // Modulated light groups need the render split by group.
    let request = &camsim_render::RenderRequest {
        light_groups: request.light_groups || !req.group_lights.is_empty(),
        ..*request
    };
    // The metered exposure, when adaptive sampling metered one (kept for a moving scene's frames).
    let metered = set_adaptive_target(&mut scene, r, optics, sensor, req, progress)?;
    if !scene.settings.time.has_motion() {
        // Nothing moves: one render serves every frame (as before time was modelled).
        let out = render::render_stage(&scene, r, request, progress)?;
        let samples = crate::records::RenderSamples::of(&scene, &out);
        let scene_s = t.elapsed().as_secs_f64();
        progress("optics", 0, 1);
        let (radiance, imaged, map) = image_owned_groups(
            out.radiance,
            &out.light_groups,
            r.light_groups.as_ref(),
            optics,
            sensor,
            req,
        )?;
        let times = cfg
            .capture
            .frame_times(&exposures_of(&imaged.frame), shutter.open_s)?;
        let n = sensor.rows() * sensor.cols();
        let flow = flow.then(|| {
            (0..times.len())
                .map(|i| FrameFlow {
                    exposure: vec![[0.0; 2]; n],
                    to_next: (i + 1 < times.len()).then(|| vec![[0.0; 2]; n]),
                })
                .collect()
        });
        let noise_free = opts
            .noise_free
            .then(|| noise_free_all(sensor, &imaged, req))
            .transpose()?;
        return Ok(Staged {
            radiance,
            ids: Some(out.ids),
            scene: out.labels.is_some().then_some(scene),
            labels: out.labels,
            map,
            imaged,
            times,
            flow,
            noise_free,
            frame_labels: Vec::new(),
            labels_s: 0.0,
            scene_s,
            scene_setup_s: Some(scene_setup_s),
            moving: false,
            compose,
            samples: Some(samples),
        });
    }

    // The scene moves: each raw frame in its own window, its labels (when asked for) at that
    // window's start.
    let mut scene_s = scene_setup_s;
    let mut labels_s = 0.0;
    let mut frame_labels = Vec::new();
    let durations: Vec<f64> = match (&req.bracket_s, req.exposure) {
        (Some(b), _) => b
            .iter()
            .flat_map(|t| std::iter::repeat_n(*t, req.frames))
            .collect(),
        (None, Exposure::Seconds(t)) => vec![t; req.frames],
        (None, Exposure::Auto { .. }) => {
            let t = Instant::now();
            let metered = match metered {
                Some(m) => m,
                None => metered_exposure_s(&scene, r, optics, sensor, req, progress)?,
            };
            scene_s += t.elapsed().as_secs_f64();
            vec![metered; req.frames]
        }
    };
    let times = cfg.capture.frame_times(&durations, shutter.open_s)?;
    scene.settings.time.shutter.rolling =
        cfg.capture
            .shutter
            .row_readout(sensor.rows(), scene.camera.height, k);
    let (rows, cols) = (sensor.rows(), sensor.cols());
    let (mut optics_s, mut sensor_s) = (0.0, 0.0);
    // The first frame's radiance, ids and imaging; later frames' raws join its frame.
    let mut first: Option<(Option<SpectralImage>, camsim_render::IdMaps, Imaged)> = None;
    let mut flows = Vec::new();
    let mut noise_free = Vec::new();
    let mut samples = None;
    for (i, w) in times.iter().enumerate() {
        let next = times.get(i + 1).map(|n| n.start_s - w.start_s);
        let time = &mut scene.settings.time;
        time.shutter.open_s = w.start_s;
        time.shutter.close_s = w.start_s + w.duration_s;
        time.flow_intervals_s = if flow {
            std::iter::once(w.duration_s).chain(next).collect()
        } else {
            Vec::new()
        };
        let t = Instant::now();
        let out = render::render_stage(&scene, r, request, progress)?;
        scene_s += t.elapsed().as_secs_f64();
        if samples.is_none() {
            samples = Some(crate::records::RenderSamples::of(&scene, &out));
        }
        if flow {
            flows.push(FrameFlow {
                exposure: flow_on_sensor(&out.flow[0], k, rows, cols),
                to_next: out.flow.get(1).map(|m| flow_on_sensor(m, k, rows, cols)),
            });
        }
        // Every frame is exposed for its own window (auto-exposure was metered above).
        let one = CaptureRequest {
            exposure: Exposure::Seconds(durations[i]),
            bracket_s: None,
            frames: 1,
            first_frame: i as u64,
            // A modulated light: this frame's window starts at its own time.
            light: req.light.map(|l| camsim_sensor::LightTiming {
                start_s: w.start_s,
                frame_interval_s: Some(0.0),
                ..l
            }),
            group_lights: req
                .group_lights
                .iter()
                .map(|(name, l)| {
                    let l = camsim_sensor::LightTiming {
                        start_s: w.start_s,
                        frame_interval_s: Some(0.0),
                        ..*l
                    };
                    (name.clone(), l)
                })
                .collect(),
            ..req.clone()
        };
        progress("optics", i as u64, times.len() as u64);
        let depth_m = out.labels.as_ref().and(out.radiance.depth_m.clone());
        let (radiance, im, map) = image_owned_groups(
            out.radiance,
            &out.light_groups,
            r.light_groups.as_ref(),
            optics,
            sensor,
            &one,
        )?;
        optics_s += im.optics_s;
        sensor_s += im.sensor_s;
        if let (Some(req), Some(l), Some(depth_m)) = (request.labels, out.labels, depth_m) {
            let t = Instant::now();
            frame_labels.push(crate::labels::FrameLabels {
                depth_m,
                ids: out.ids.clone(),
                labels: crate::labels::sensor_labels(
                    &scene,
                    l,
                    req,
                    sensor,
                    &im.irradiance,
                    map.as_ref(),
                )?,
            });
            labels_s += t.elapsed().as_secs_f64();
        }
        if opts.noise_free {
            let t = Instant::now();
            noise_free.push(noise_free_dn(
                sensor,
                &im.irradiance,
                im.light_split.as_ref(),
                durations[i],
                &one,
                i as u64,
            )?);
            sensor_s += t.elapsed().as_secs_f64();
        }
        match &mut first {
            None => first = Some((radiance, out.ids, im)),
            Some((_, _, im0)) => {
                im0.frame.raw.extend(im.frame.raw);
                if let (Some(a), Some(b)) = (&mut im0.frame.analog_dn, im.frame.analog_dn) {
                    a.extend(b);
                }
                if let (Some(a), Some(b)) = (&mut im0.hdr, im.hdr) {
                    a.extend(b);
                }
                if let (Some(a), Some(b)) = (&mut im0.dual, im.dual) {
                    a.extend(b);
                }
            }
        }
    }
    let (radiance, ids, mut imaged) = first.expect("at least one frame (checked)");
    imaged.optics_s = optics_s;
    imaged.sensor_s = sensor_s;
    Ok(Staged {
        radiance,
        ids: Some(ids),
        labels: None,
        scene: None,
        map: None,
        imaged,
        times,
        flow: flow.then_some(flows),
        noise_free: opts.noise_free.then_some(noise_free),
        frame_labels,
        labels_s,
        scene_s,
        scene_setup_s: Some(scene_setup_s),
        moving: true,
        compose,
        samples,
    })
}
