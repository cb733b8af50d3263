//! `Simulation.labels` and `Simulation.camera`: numpy arrays and dicts from camsim's labels
//! (camsim-pipeline `labels`).

use crate::convert::{array, to_py};
use camsim::pipeline::labels::SimLabels;
use camsim::render::Labels;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Every map of `l` as numpy arrays: instances, object_id, depth, normals (camera frame),
/// normals_world ((rows, cols, 3)), albedo ((bands, rows, cols)), albedo_srgb.
fn maps<'py>(py: Python<'py>, l: &Labels, d: &Bound<'py, PyDict>) -> PyResult<()> {
    let (h, w) = (l.height, l.width);
    d.set_item("instances", array(py, &l.instance_id, &[h, w])?)?;
    d.set_item("object_id", array(py, &l.object_id, &[h, w])?)?;
    d.set_item("depth", array(py, &l.depth_m, &[h, w])?)?;
    let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
    if let Some(n) = &l.normal_camera {
        d.set_item("normals", array(py, &flat(n), &[h, w, 3])?)?;
    }
    if let Some(n) = &l.normal_world {
        d.set_item("normals_world", array(py, &flat(n), &[h, w, 3])?)?;
    }
    if let Some(a) = &l.albedo {
        d.set_item("albedo", array(py, a, &[l.grid.len(), h, w])?)?;
    }
    if let Some(a) = &l.albedo_srgb {
        d.set_item("albedo_srgb", array(py, &flat(a), &[h, w, 3])?)?;
    }
    Ok(())
}

/// The labels on the raw image's grid (and under "scene", on the render's), with "boxes" (per
/// instance: 3D box, 2D boxes on both grids, visible fraction, truncation).
pub(crate) fn labels_dict<'py>(py: Python<'py>, s: &SimLabels) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    maps(py, &s.sensor, &d)?;
    d.set_item(
        "material_id",
        array(
            py,
            &s.sensor_ids.material_id,
            &[s.sensor.height, s.sensor.width],
        )?,
    )?;
    let scene = PyDict::new(py);
    maps(py, &s.scene, &scene)?;
    d.set_item("scene", scene)?;
    d.set_item("boxes", to_py(py, &s.boxes_json()["instances"])?)?;
    Ok(d)
}

/// K and extrinsics of the raw grid (and of the render's), as numpy arrays.
pub(crate) fn camera_dict<'py>(py: Python<'py>, s: &SimLabels) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let m3 = |k: &[[f64; 3]; 3]| k.iter().flatten().copied().collect::<Vec<f64>>();
    let m4 = |k: &[[f64; 4]; 4]| k.iter().flatten().copied().collect::<Vec<f64>>();
    d.set_item("K", array(py, &m3(&s.sensor_camera.k), &[3, 3])?)?;
    d.set_item(
        "world_to_camera",
        array(py, &m4(&s.sensor_camera.world_to_camera), &[4, 4])?,
    )?;
    d.set_item("width", s.sensor_camera.width)?;
    d.set_item("height", s.sensor_camera.height)?;
    d.set_item("distorted", s.distorted)?;
    d.set_item("scene_K", array(py, &m3(&s.scene.camera.k), &[3, 3])?)?;
    d.set_item("scene_width", s.scene.camera.width)?;
    d.set_item("scene_height", s.scene.camera.height)?;
    d.set_item("note", to_py(py, &s.cameras_json()["note"])?)?;
    Ok(d)
}
