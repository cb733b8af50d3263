//! The scene, optics and sensor stages of a run, in time: each raw frame's exposure window
//! ([`crate::timing`]) drives the render of a 3D scene that moves, so every frame of a burst,
//! bracket or video is rendered at its own time (with a rolling shutter, each row at its own),
//! imaged and read out with its own temporal noise; optical flow comes with it on the sensor
//! grid. A 2D chart, or a 3D scene where nothing moves, is rendered once and imaged as before
//! (the same bytes).

use crate::capture::{image_owned, CaptureRequest, Imaged};
use crate::timing::{flow_on_sensor, FrameTime};
use crate::{render, scene_stage_with, PipelineError, Progress, Result, SimulateConfig};
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
    /// Seconds in the scene stage (all renders).
    pub scene_s: f64,
    /// The scene moves: every frame was rendered in its own window.
    pub moving: bool,
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

/// Run the scene, optics and sensor stages; `flow`: compute the optical flow (3D scenes);
/// `request`: the renderer's extra outputs (labels; a moving scene refuses them).
pub(crate) fn stage(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    req: &CaptureRequest,
    flow: bool,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<Staged> {
    cfg.capture.check_timing()?;
    let t = Instant::now();
    progress("scene", 0, 1);
    let Some(r) = &cfg.render else {
        let st = scene_stage_with(cfg, sensor, optics, request, progress)?;
        let scene_s = t.elapsed().as_secs_f64();
        progress("optics", 0, 1);
        let (radiance, imaged, map) = image_owned(st.image, optics, sensor, req)?;
        let times = cfg.capture.frame_times(&exposures_of(&imaged.frame), 0.0)?;
        return Ok(Staged {
            radiance,
            ids: st.ids,
            labels: st.labels,
            scene: st.scene,
            map,
            imaged,
            times,
            flow: None,
            scene_s,
            moving: false,
        });
    };
    let mut scene = render::render_section_scene(r, cfg, sensor, optics)?;
    let k = sensor_px_per_render_px(&scene, sensor, optics)?;
    let shutter = scene.settings.time.shutter;
    if !scene.settings.time.has_motion() {
        // Nothing moves: one render serves every frame (as before time was modelled).
        let out = render::render_stage(&scene, r, request, progress)?;
        let scene_s = t.elapsed().as_secs_f64();
        progress("optics", 0, 1);
        let (radiance, imaged, map) = image_owned(out.radiance, optics, sensor, req)?;
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
        return Ok(Staged {
            radiance,
            ids: Some(out.ids),
            scene: out.labels.is_some().then_some(scene),
            labels: out.labels,
            map,
            imaged,
            times,
            flow,
            scene_s,
            moving: false,
        });
    }

    // The scene moves: each raw frame in its own window.
    if request.labels.is_some() {
        // The labels trace the scene once, at one time; a moving scene's frames each have
        // their own window (and blur), so they are refused rather than written for one instant.
        return Err(PipelineError::config(
            "training-data labels are not supported for a moving 3D scene yet: leave instances, normals, albedo, boxes, depth and ids out of --save (or the labels of the Python call), or make the scene static",
        ));
    }
    let durations: Vec<f64> = match (&req.bracket_s, req.exposure) {
        (Some(b), _) => b
            .iter()
            .flat_map(|t| std::iter::repeat_n(*t, req.frames))
            .collect(),
        (None, Exposure::Seconds(t)) => vec![t; req.frames],
        // Auto-exposure: the scene's own shutter length (the exposure is not known yet).
        (None, Exposure::Auto { .. }) => vec![shutter.close_s - shutter.open_s; req.frames],
    };
    let times = cfg.capture.frame_times(&durations, shutter.open_s)?;
    scene.settings.time.shutter.rolling =
        cfg.capture
            .shutter
            .row_readout(sensor.rows(), scene.camera.height, k);
    let (rows, cols) = (sensor.rows(), sensor.cols());
    let mut scene_s = 0.0;
    let (mut optics_s, mut sensor_s) = (0.0, 0.0);
    let mut first: Option<(
        Option<SpectralImage>,
        camsim_render::IdMaps,
        SpectralImage,
        Frame,
    )> = None;
    let mut flows = Vec::new();
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
        if flow {
            flows.push(FrameFlow {
                exposure: flow_on_sensor(&out.flow[0], k, rows, cols),
                to_next: out.flow.get(1).map(|m| flow_on_sensor(m, k, rows, cols)),
            });
        }
        // Frame 0 resolves auto-exposure; the others keep its time (or their bracket's).
        let exposure = match (&first, &req.bracket_s) {
            (None, None) => req.exposure,
            (Some((_, _, _, f0)), None) => Exposure::Seconds(f0.exposure_s),
            (_, Some(_)) => Exposure::Seconds(durations[i]),
        };
        let one = CaptureRequest {
            exposure,
            bracket_s: None,
            frames: 1,
            first_frame: i as u64,
            ..req.clone()
        };
        progress("optics", i as u64, times.len() as u64);
        let (radiance, im, _) = image_owned(out.radiance, optics, sensor, &one)?;
        optics_s += im.optics_s;
        sensor_s += im.sensor_s;
        match &mut first {
            None => first = Some((radiance, out.ids, im.irradiance, im.frame)),
            Some((_, _, _, f0)) => {
                f0.raw.extend(im.frame.raw);
                if let (Some(a), Some(b)) = (&mut f0.analog_dn, im.frame.analog_dn) {
                    a.extend(b);
                }
            }
        }
    }
    let (radiance, ids, irradiance, frame) = first.expect("at least one frame (checked)");
    Ok(Staged {
        radiance,
        ids: Some(ids),
        labels: None,
        scene: None,
        map: None,
        imaged: Imaged {
            irradiance,
            frame,
            optics_s,
            sensor_s,
        },
        times,
        flow: flow.then_some(flows),
        scene_s,
        moving: true,
    })
}
