//! Training-data labels of a 3D scene's run in two geometries: the render's pixel grid (the
//! scene geometry, as the renderer makes them) and the raw image's pixel grid (the sensor
//! geometry), where label pixel (r, c) describes the scene point imaged at raw pixel (r, c).
//!
//! The sensor-geometry labels follow the radiance exactly as the stages move it: the sensor
//! pixel's centre on the irradiance grid ([`camsim_sensor::compute::pixel_centre_on_input`], the
//! geometry the sensor integrates with), then the optics' own map back to the radiance
//! ([`camsim_optics::ImageMap`]: magnification, padding, a traced lens's distortion; camsim's
//! optics keeps the image upright), which is a continuous position on the render's film; the
//! render's camera then traces the pinhole ray through that very position
//! ([`camsim_render::labels::trace_labels`]), so every map (ids, depth, normals, albedo) is the
//! surface seen at the point imaged on the pixel: nothing is interpolated or blended, and no
//! nearest-pixel rounding adds to the sensor's own half pixel. A lens camera's render is the
//! irradiance itself: its labels take the sensor step only (they keep the pinhole geometry of
//! its depth map, without the lens's distortion). Pixels whose point lies outside the render
//! are background (id 0, infinite depth, zero normal and albedo).

use crate::outputs::{Output, OutputSet};
use crate::{PipelineError, Result};
use camsim_core::SpectralImage;
use camsim_optics::ImageMap;
use camsim_render::labels::{
    boxes_2d, trace_labels, Box2d, LabelRequest, Labels, PinholeCamera, RasterPositions,
};
use camsim_render::IdMaps;
use camsim_scene3d::SceneDescription;
use camsim_sensor::compute::pixel_centre_on_input;
use camsim_sensor::Sensor;
use std::path::Path;

/// The labels of one run (see the module docs).
#[derive(Debug, Clone)]
pub struct SimLabels {
    /// In the render's geometry.
    pub scene: Labels,
    /// On the raw image's pixel grid (with its depth, m, along the optical axis).
    pub sensor: Labels,
    /// Object and material ids on the raw grid (`IdMaps`' numbering).
    pub sensor_ids: IdMaps,
    /// The pinhole model of the raw grid: the render's camera with K scaled by the irradiance
    /// sample spacing over the pixel pitch about the sensor's centre (distortion-free; see
    /// `distorted`).
    pub sensor_camera: PinholeCamera,
    /// The optics applied a lens's distortion: the raw grid departs from `sensor_camera`'s
    /// pinhole by it (the label maps follow it, the pinhole model does not).
    pub distorted: bool,
    /// With `distorted`: OpenCV's distortion coefficients fitted to the optics' own map, so
    /// `sensor_camera.k` with them reproduces the raw grid (see [`SensorDistortion`]).
    pub sensor_distortion: Option<SensorDistortion>,
    /// Per instance of `scene.instances` (same order): its keypoints on the raw grid, those of
    /// its `keypoints_3d` (an asset's own) in their order, else [`KEYPOINT_NAMES`] (its 3D box's
    /// centre and corners); empty for an instance with neither.
    pub keypoints: Vec<Vec<Keypoint>>,
}

/// The keypoints of every instance: its 3D box's centre, then its 8 corners in
/// [`camsim_render::labels::Box3d::corners_m`]'s order (the Objectron layout).
pub const KEYPOINT_NAMES: [&str; 9] = [
    "center", "corner_0", "corner_1", "corner_2", "corner_3", "corner_4", "corner_5", "corner_6",
    "corner_7",
];

/// The 12 edges of the box between [`KEYPOINT_NAMES`] (0-based): corners one bit apart.
pub fn keypoint_skeleton() -> Vec<[usize; 2]> {
    let mut e = Vec::with_capacity(12);
    for i in 0..8usize {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                e.push([1 + i, 1 + (i | bit)]);
            }
        }
    }
    e
}

/// A 3D point of an instance where the optics images it on the raw grid.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Keypoint {
    /// Raw-grid position `[x, y]` in pixel edges (pixel (r, c) covers [c, c + 1) x [r, r + 1),
    /// as the 2D boxes; the sensor K's u + 0.5), through the optics' own map (a traced lens's
    /// distortion included); `None` behind the camera or beyond the lens's field.
    pub xy_px: Option<[f64; 2]>,
    /// Its depth along the optical axis, m.
    pub depth_m: f64,
    /// COCO's flag: 0 outside the frame (or not imaged), 1 in the frame but behind a nearer
    /// surface, 2 visible (nothing on its pinhole ray nearer than it, less 1 mm + 0.1 %).
    pub visibility: u8,
}

/// [`Keypoint`]s of every instance of `scene` (see [`SimLabels::keypoints`]): each point
/// projected through the render's pinhole to its raster position, carried onto the sensor plane
/// by the optics' map inverted ([`ImageMap::image_position`]) and onto the pixel grid by the
/// sensor's sampling ([`pixel_centre_on_input`] inverted); its visibility from the depth the
/// render's pinhole ray through it meets first.
fn instance_keypoints(
    scene_desc: &SceneDescription,
    scene: &Labels,
    sensor: &Sensor,
    irradiance: &SpectralImage,
    map: Option<&ImageMap>,
) -> Result<Vec<Vec<Keypoint>>> {
    let k = scene.camera.k;
    let (rows, cols) = (sensor.rows() as f64, sensor.cols() as f64);
    let s = irradiance.sample_spacing_m / sensor.pixel_pitch_m();
    let (in_cols, in_rows) = (irradiance.cols as f64, irradiance.rows as f64);
    let mut points: Vec<(usize, [f64; 3])> = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        if let Some(k) = &inst.keypoints_3d {
            points.extend(k.points_m.iter().map(|p| (i, *p)));
        } else if let Some(b) = &inst.box_3d {
            points.push((i, b.center_m));
            points.extend(b.corners_m.iter().map(|c| (i, *c)));
        }
    }
    if points.is_empty() {
        return Ok(vec![Vec::new(); scene.instances.len()]);
    }
    // Render raster positions (pixel edges) of the points in front of the camera.
    let raster_xy: Vec<Option<[f64; 2]>> = points
        .iter()
        .map(|(_, p)| {
            (p[2] > 0.0).then(|| {
                [
                    k[0][0] * p[0] / p[2] + k[0][2] + 0.5,
                    k[1][1] * p[1] / p[2] + k[1][2] + 0.5,
                ]
            })
        })
        .collect();
    let (w, h) = (scene.width as f64, scene.height as f64);
    let raster = RasterPositions {
        width: points.len(),
        height: 1,
        xy: raster_xy
            .iter()
            .map(|q| match q {
                Some(q) if q[0] >= 0.0 && q[1] >= 0.0 && q[0] < w && q[1] < h => {
                    [q[0] as f32, q[1] as f32]
                }
                _ => [f32::NAN; 2],
            })
            .collect(),
    };
    let first = trace_labels(
        scene_desc,
        LabelRequest::default(),
        &raster,
        &scene.instances,
    )?;
    let mut out = vec![Vec::new(); scene.instances.len()];
    for (j, ((i, p), q)) in points.iter().zip(&raster_xy).enumerate() {
        let xy = q.and_then(|q| match map {
            Some(m) => m.image_position(q),
            None => Some(q),
        });
        // Irradiance samples to pixel edges: pixel c's centre lies at
        // ((c + 1/2 - cols/2) pitch) / spacing + in_cols / 2 (`pixel_centre_on_input`).
        let xy = xy.map(|q| {
            [
                (q[0] - in_cols / 2.0) * s + cols / 2.0,
                (q[1] - in_rows / 2.0) * s + rows / 2.0,
            ]
        });
        let inside = xy.is_some_and(|q| q[0] >= 0.0 && q[1] >= 0.0 && q[0] < cols && q[1] < rows);
        let nearest = first.depth_m[j] as f64;
        let visibility = if !inside {
            0
        } else if nearest >= p[2] - (1e-3 + 1e-3 * p[2]) {
            2
        } else {
            1
        };
        out[*i].push(Keypoint {
            xy_px: xy,
            depth_m: p[2],
            visibility,
        });
    }
    Ok(out)
}

/// The raw grid's distortion as OpenCV's model ([`camsim_analysis::distortion`]) fitted to the
/// optics' map: for sensor pixels on a grid, the undistorted normalized coordinates of the
/// scene point imaged there (the render camera's K inverted at the map's render position) and
/// the distorted ones (the sensor camera's K inverted at the pixel).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SensorDistortion {
    /// OpenCV's `distCoeffs`, `[k1, k2, p1, p2, k3]`, for `cameras.sensor.k`.
    pub dist_coeffs: [f64; 5],
    /// Reprojection error of the fit over the fitted pixels, sensor pixels (RMS and largest).
    pub rms_px: f64,
    pub max_px: f64,
    /// How many sensor pixels were fitted.
    pub points: usize,
}

/// Fit [`SensorDistortion`] on every `step`-th raw pixel of `raster` (render raster positions
/// in pixel-edge coordinates, NaN outside the render) between the render's K and the sensor's.
fn fit_sensor_distortion(
    raster: &RasterPositions,
    render_k: &[[f64; 3]; 3],
    sensor_k: &[[f64; 3]; 3],
) -> Result<SensorDistortion> {
    let step = (raster.width.max(raster.height) / 48).max(1);
    let (mut und, mut dis, mut px) = (Vec::new(), Vec::new(), Vec::new());
    for r in (0..raster.height).step_by(step) {
        for c in (0..raster.width).step_by(step) {
            let p = raster.xy[r * raster.width + c];
            if !(p[0].is_finite() && p[1].is_finite()) {
                continue;
            }
            // K's pixel centres sit at integer coordinates; the raster's at + 0.5.
            let (u, v) = (p[0] as f64 - 0.5, p[1] as f64 - 0.5);
            und.push([
                (u - render_k[0][2]) / render_k[0][0],
                (v - render_k[1][2]) / render_k[1][1],
            ]);
            dis.push([
                (c as f64 - sensor_k[0][2]) / sensor_k[0][0],
                (r as f64 - sensor_k[1][2]) / sensor_k[1][1],
            ]);
            px.push([c as f64, r as f64]);
        }
    }
    let d = camsim_analysis::distortion::fit_opencv(&und, &dis)
        .map_err(|e| PipelineError::config(format!("labels: {e}")))?;
    let (mut sum2, mut max) = (0.0f64, 0.0f64);
    for (x, want) in und.iter().zip(&px) {
        let [xd, yd] = d.apply(*x);
        let (u, v) = (
            sensor_k[0][0] * xd + sensor_k[0][2],
            sensor_k[1][1] * yd + sensor_k[1][2],
        );
        let e = (u - want[0]).hypot(v - want[1]);
        sum2 += e * e;
        max = max.max(e);
    }
    Ok(SensorDistortion {
        dist_coeffs: d.coefficients(),
        rms_px: (sum2 / px.len() as f64).sqrt(),
        max_px: max,
        points: px.len(),
    })
}

/// The labels of one raw frame of a moving 3D scene: every frame is rendered in its own window,
/// and its labels describe the scene at the start of that window (each render row's start, the
/// instant of flow's first hit), a sharp snapshot while the image is blurred over the window.
#[derive(Debug, Clone)]
pub struct FrameLabels {
    /// The render's depth map, m (row-major render pixels, `ids.width` x `ids.height`).
    pub depth_m: Vec<f32>,
    /// The render's object and material ids.
    pub ids: IdMaps,
    /// The labels in both geometries.
    pub labels: SimLabels,
}

/// Where each raw pixel looks in the render: the pixel's centre on the irradiance grid (the
/// sensor's geometry), then the optics' map back to the radiance (`None`: the render is the
/// irradiance itself), as the render's continuous raster position (NaN: outside the render).
pub fn sensor_raster(
    sensor: &Sensor,
    irradiance: &SpectralImage,
    map: Option<&ImageMap>,
    render_width: usize,
    render_height: usize,
) -> RasterPositions {
    let (rows, cols, pitch) = (sensor.rows(), sensor.cols(), sensor.pixel_pitch_m());
    let on_irr = |c: usize, n: usize, n_in: usize| {
        pixel_centre_on_input(c, n, pitch, n_in, irradiance.sample_spacing_m)
    };
    let xs: Vec<f64> = (0..cols)
        .map(|c| on_irr(c, cols, irradiance.cols))
        .collect();
    let ys: Vec<f64> = (0..rows)
        .map(|r| on_irr(r, rows, irradiance.rows))
        .collect();
    let mut xy = Vec::with_capacity(rows * cols);
    for &y in &ys {
        for &x in &xs {
            let p = match map {
                Some(m) => m.scene_position([x, y]),
                None => [x, y],
            };
            let inside = p[0] >= 0.0
                && p[1] >= 0.0
                && p[0] < render_width as f64
                && p[1] < render_height as f64;
            xy.push(if inside {
                [p[0] as f32, p[1] as f32]
            } else {
                [f32::NAN; 2]
            });
        }
    }
    RasterPositions {
        width: cols,
        height: rows,
        xy,
    }
}

/// The labels of a run on the raw grid: the surfaces the render's camera sees at each raw
/// pixel's [`sensor_raster`] position, traced exactly (not resampled from the render's pixels).
pub fn sensor_labels(
    scene_desc: &SceneDescription,
    scene: Labels,
    request: LabelRequest,
    sensor: &Sensor,
    irradiance: &SpectralImage,
    map: Option<&ImageMap>,
) -> Result<SimLabels> {
    let (rows, cols) = (sensor.rows(), sensor.cols());
    let raster = sensor_raster(sensor, irradiance, map, scene.width, scene.height);
    let sensor_labels = trace_labels(scene_desc, request, &raster, &scene.instances)?;
    let sensor_ids =
        IdMaps::from_object_ids(scene_desc, cols, rows, sensor_labels.object_id.clone());
    // One render pixel spans one irradiance sample: K scales by spacing / pitch about the
    // centres (u = fx X / Z + (W - 1) / 2 on both grids).
    let s = irradiance.sample_spacing_m / sensor.pixel_pitch_m();
    let k = scene.camera.k;
    let sensor_camera = PinholeCamera {
        width: cols,
        height: rows,
        k: [
            [k[0][0] * s, 0.0, cols as f64 / 2.0 - 0.5],
            [0.0, k[1][1] * s, rows as f64 / 2.0 - 0.5],
            [0.0, 0.0, 1.0],
        ],
        world_to_camera: scene.camera.world_to_camera,
    };
    let distorted = map.is_some_and(|m| m.is_distorted());
    let sensor_distortion = if distorted {
        Some(fit_sensor_distortion(
            &raster,
            &scene.camera.k,
            &sensor_camera.k,
        )?)
    } else {
        None
    };
    let keypoints = instance_keypoints(scene_desc, &scene, sensor, irradiance, map)?;
    Ok(SimLabels {
        scene,
        sensor: sensor_labels,
        sensor_ids,
        sensor_camera,
        distorted,
        sensor_distortion,
        keypoints,
    })
}

/// COCO's uncompressed RLE of a mask given by its pixels (row-major indices into a `width` x
/// `height` grid): run lengths in column-major order, alternately outside and inside the mask,
/// starting outside (a first run of 0 when pixel (0, 0) is inside). COCO's `mask.py`, format.
fn column_major_rle(pixels: &[u32], width: usize, height: usize) -> Vec<u64> {
    let mut cm: Vec<u64> = pixels
        .iter()
        .map(|&p| {
            let (y, x) = (p as usize / width, p as usize % width);
            (x * height + y) as u64
        })
        .collect();
    cm.sort_unstable();
    cm.dedup();
    let total = (width * height) as u64;
    let mut counts = Vec::new();
    let mut at = 0u64; // the next pixel not yet counted
    let mut k = 0;
    while k < cm.len() {
        let start = cm[k];
        let mut end = start + 1;
        k += 1;
        while k < cm.len() && cm[k] == end {
            end += 1;
            k += 1;
        }
        counts.push(start - at);
        counts.push(end - start);
        at = end;
    }
    if at < total {
        counts.push(total - at);
    }
    counts
}

/// The box `[x0, y0, x1, y1]` (pixel edges, ends exclusive) of pixels given by row-major index.
fn pixel_box(pixels: &[u32], width: usize) -> Option<[usize; 4]> {
    let mut b: Option<[usize; 4]> = None;
    for &p in pixels {
        let (y, x) = (p as usize / width, p as usize % width);
        b = Some(match b {
            None => [x, y, x + 1, y + 1],
            Some(b) => [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)],
        });
    }
    b
}

/// What the labels' files say about their conventions (boxes.json and run.json).
const NOTE: &str = "Camera frame: OpenCV (x right, y down, z forward, m), origin at the pinhole (a lens camera's entrance pupil). K: pixel centres at integer coordinates (u = fx X/Z + cx). 2D boxes: [x0, y0, x1, y1] in pixel edges (pixel (r, c) covers [c, c+1) x [r, r+1), ends exclusive, as COCO). 'sensor' maps are on the raw image's pixel grid: label pixel (r, c) describes the scene point imaged at raw pixel (r, c) (through the optics' magnification, padding and distortion; camsim's optics keeps the image upright); 'scene' maps are on the render's grid. visible_fraction and truncation are measured on the render. sensor_distortion_opencv (with a distorting lens): OpenCV's distCoeffs [k1, k2, p1, p2, k3] for the sensor K, fitted to the optics' map, with the fit's reprojection RMS and largest error in sensor pixels. mask_all_sensor (the amodal output): an instance's full silhouette on the raw grid, occluders ignored (every surface along each pixel's ray, up to 64), as COCO's uncompressed RLE (column-major runs, first outside), with pixels_sensor_all and bbox_sensor_all.";

/// What boxes.json says about `keypoints_sensor`.
const KEYPOINT_NOTE: &str = "keypoints_sensor: per instance, [x, y, visibility] for each of its keypoints_3d.names when it has its own (an asset manifest's keypoints; keypoints_3d.points_m: camera frame, m), else for each of keypoints.names (its 3D box's centre and 8 corners, box_3d.corners_m's order), on the raw grid in pixel edges (as the 2D boxes: the sensor K's u + 0.5), imaged through the optics' own map (a traced lens's distortion included); visibility as COCO's: 0 outside the frame (x = y = 0 when not imaged at all), 1 in the frame behind a nearer surface, 2 visible. skeleton: the box's 12 edges, 0-based indices into names (an instance's own: keypoints_3d.skeleton).";

impl SimLabels {
    /// The camera models of both geometries, for run.json and boxes.json.
    pub fn cameras_json(&self) -> serde_json::Value {
        serde_json::json!({
            "note": NOTE,
            "scene": self.scene.camera,
            "sensor": self.sensor_camera,
            "sensor_distorted": self.distorted,
            "sensor_distortion_opencv": self.sensor_distortion,
        })
    }

    /// boxes.json: the cameras and every instance with its 3D box and its 2D boxes in both
    /// geometries.
    pub fn boxes_json(&self) -> serde_json::Value {
        let index = |b: Vec<Box2d>| {
            let mut v: Vec<Option<Box2d>> = vec![None; self.scene.instances.len() + 1];
            for x in b {
                if let Some(slot) = v.get_mut(x.id as usize) {
                    *slot = Some(x);
                }
            }
            v
        };
        let scene = index(boxes_2d(&self.scene.instance_id, self.scene.width));
        let sensor = index(boxes_2d(&self.sensor.instance_id, self.sensor.width));
        let instances: Vec<serde_json::Value> = self
            .scene
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| {
                let k = inst.id as usize;
                let mut v = serde_json::to_value(inst).unwrap_or_default();
                v["bbox_scene"] =
                    serde_json::to_value(scene[k].map(|b| b.bbox)).unwrap_or_default();
                v["pixels_scene"] = scene[k].map_or(0, |b| b.pixels).into();
                v["bbox_sensor"] =
                    serde_json::to_value(sensor[k].map(|b| b.bbox)).unwrap_or_default();
                v["pixels_sensor"] = sensor[k].map_or(0, |b| b.pixels).into();
                if let Some(px) = self.sensor.amodal.as_ref().and_then(|a| a.get(i)) {
                    let (w, h) = (self.sensor.width, self.sensor.height);
                    v["mask_all_sensor"] = serde_json::json!({
                        "size": [h, w],
                        "counts": column_major_rle(px, w, h),
                    });
                    v["pixels_sensor_all"] = px.len().into();
                    v["bbox_sensor_all"] =
                        pixel_box(px, w).map_or(serde_json::Value::Null, |b| serde_json::json!(b));
                }
                if let Some(kp) = self.keypoints.get(i).filter(|kp| !kp.is_empty()) {
                    v["keypoints_sensor"] = kp
                        .iter()
                        .map(|p| {
                            let [x, y] = p.xy_px.unwrap_or([0.0; 2]);
                            serde_json::json!([x, y, p.visibility])
                        })
                        .collect();
                }
                v
            })
            .collect();
        serde_json::json!({
            "cameras": self.cameras_json(),
            "keypoints": {
                "names": KEYPOINT_NAMES,
                "skeleton": keypoint_skeleton(),
                "note": KEYPOINT_NOTE,
            },
            "instances": instances,
        })
    }

    /// Write the label files `outputs` asks for into `dir` (each atomically): instances,
    /// normals, albedo, boxes (sensor geometry, `.scene` for the render's), and with depth / ids
    /// their sensor-geometry versions. `frame`: the raw frame they belong to (0: instances.png,
    /// ...; a later frame of a moving scene: instances_0001.png, instances_0001.scene.png, ...,
    /// [`crate::capture::frame_suffix`]).
    pub fn write(&self, dir: &Path, outputs: &OutputSet, frame: usize) -> Result<()> {
        let n = crate::capture::frame_suffix(frame);
        let both = [(&self.sensor, ""), (&self.scene, ".scene")];
        if outputs.contains(Output::Instances) {
            for (l, suffix) in both {
                let max = l.instance_id.iter().copied().max().unwrap_or(0);
                if max > u16::MAX as u32 {
                    return Err(PipelineError::config(format!(
                        "instances: the scene has {max} instances, more than a 16-bit map holds (65535)"
                    )));
                }
                let v: Vec<u16> = l.instance_id.iter().map(|&i| i as u16).collect();
                camsim_io::raster::write_png16_gray(
                    &dir.join(format!("instances{n}{suffix}.png")),
                    l.height,
                    l.width,
                    &v,
                )?;
            }
        }
        if outputs.contains(Output::Normals) {
            for (l, suffix) in both {
                let (Some(nw), Some(nc)) = (&l.normal_world, &l.normal_camera) else {
                    continue;
                };
                let ch = |v: &[[f32; 3]], i: usize| v.iter().map(|n| n[i]).collect::<Vec<f32>>();
                let planes = [
                    ch(nc, 0),
                    ch(nc, 1),
                    ch(nc, 2),
                    ch(nw, 0),
                    ch(nw, 1),
                    ch(nw, 2),
                ];
                let names = [
                    "camera.X", "camera.Y", "camera.Z", "world.X", "world.Y", "world.Z",
                ];
                let chans: Vec<(&str, &[f32])> = names
                    .iter()
                    .zip(&planes)
                    .map(|(n, p)| (*n, p.as_slice()))
                    .collect();
                camsim_io::exr::write_channels_exr(
                    &dir.join(format!("normals{n}{suffix}.exr")),
                    l.height,
                    l.width,
                    &chans,
                )?;
            }
        }
        if outputs.contains(Output::Albedo) {
            for (l, suffix) in both {
                let (Some(a), Some(rgb)) = (&l.albedo, &l.albedo_srgb) else {
                    continue;
                };
                let n = l.width * l.height;
                let ch = |i: usize| rgb.iter().map(|c| c[i]).collect::<Vec<f32>>();
                let rgb_planes = [ch(0), ch(1), ch(2)];
                // Reflective spectral channels (Fichet et al. 2021: `T.<wavelength>nm`).
                let names: Vec<String> = (0..l.grid.len())
                    .map(|b| {
                        camsim_io::exr::spectral_channel_name(l.grid.wavelength_nm(b))
                            .replacen("S0.", "T.", 1)
                    })
                    .collect();
                let mut chans: Vec<(&str, &[f32])> = vec![
                    ("R", rgb_planes[0].as_slice()),
                    ("G", rgb_planes[1].as_slice()),
                    ("B", rgb_planes[2].as_slice()),
                ];
                for (b, name) in names.iter().enumerate() {
                    chans.push((name.as_str(), &a[b * n..(b + 1) * n]));
                }
                camsim_io::exr::write_channels_exr(
                    &dir.join(format!("albedo{n}{suffix}.exr")),
                    l.height,
                    l.width,
                    &chans,
                )?;
            }
        }
        if outputs.contains(Output::Boxes) {
            camsim_io::atomic::write_json_atomic(
                &dir.join(format!("boxes{n}.json")),
                &self.boxes_json(),
            )?;
        }
        if outputs.contains(Output::Depth) {
            camsim_io::exr::write_gray_exr(
                &dir.join(format!("depth{n}.sensor.exr")),
                self.sensor.height,
                self.sensor.width,
                "Z",
                &self.sensor.depth_m,
            )?;
        }
        if outputs.contains(Output::Ids) {
            let ids = &self.sensor_ids;
            for (name, map) in [
                ("object_id", &ids.object_id),
                ("material_id", &ids.material_id),
            ] {
                let v: Vec<u16> = map.iter().map(|&i| i.min(u16::MAX as u32) as u16).collect();
                camsim_io::raster::write_png16_gray(
                    &dir.join(format!("{name}{n}.sensor.png")),
                    ids.height,
                    ids.width,
                    &v,
                )?;
            }
        }
        Ok(())
    }
}
