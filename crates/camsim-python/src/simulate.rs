//! The whole pipeline from Python: `simulate` (the built-in default with no config), the typed
//! result [`PySimulation`], configs and presets as dicts, the catalogue of names.

use crate::convert::{array, array1, config_from, err, to_py, wavelengths};
use camsim::io::exr::ExrOptions;
use camsim::pipeline::labels::SimLabels;
use camsim::{OutputSet, RunInfo, SimulateOptions, Simulation};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The result of `simulate`: every stage's image as numpy arrays, and the run's record.
#[pyclass(module = "camsim._camsim", name = "Simulation", frozen)]
pub struct PySimulation {
    inner: Simulation,
}

impl PySimulation {
    /// One dict per raw frame from `make` on the frame's labels: frame 1's are `labels`, a
    /// moving scene's later frames `later_frame_labels`; a static scene's frames share one.
    fn per_frame<'py>(
        &self,
        py: Python<'py>,
        make: impl Fn(Python<'py>, &SimLabels) -> PyResult<Bound<'py, PyDict>>,
    ) -> PyResult<Option<Vec<Bound<'py, PyDict>>>> {
        let Some(first) = self.inner.labels.as_ref() else {
            return Ok(None);
        };
        let first = make(py, first)?;
        let later = &self.inner.later_frame_labels;
        let mut out = vec![first];
        if later.is_empty() {
            out.resize(self.inner.frames.len(), out[0].clone());
        } else {
            for f in later {
                out.push(make(py, &f.labels)?);
            }
        }
        Ok(Some(out))
    }
}

#[pymethods]
impl PySimulation {
    /// Scene spectral radiance, (bands, rows, cols) float32, W/(sr m^2 nm); None when the
    /// scene's camera is a lens (`realistic`, `raytransfer`), whose render is the irradiance.
    #[getter]
    fn radiance<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .radiance
            .as_ref()
            .map(|r| array(py, &r.data, &[r.bands(), r.rows, r.cols]))
            .transpose()
    }
    /// Band centres of radiance and irradiance, nm.
    #[getter]
    fn wavelengths_nm<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        array1(py, &wavelengths(self.inner.scene_image()))
    }
    /// Scene sample spacing, m (at the scene's distance; see metadata for the geometry); None
    /// with a lens camera.
    #[getter]
    fn radiance_spacing_m(&self) -> Option<f64> {
        self.inner.radiance.as_ref().map(|r| r.sample_spacing_m)
    }
    /// Sensor-plane spectral irradiance, (bands, rows, cols) float32, W/(m^2 nm).
    #[getter]
    fn irradiance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = &self.inner.irradiance;
        array(py, &r.data, &[r.bands(), r.rows, r.cols])
    }
    /// Irradiance sample spacing in the sensor plane, m.
    #[getter]
    fn irradiance_spacing_m(&self) -> f64 {
        self.inner.irradiance.sample_spacing_m
    }
    /// Depth map of a 3D scene, (rows, cols) float32 m, or None.
    #[getter]
    fn depth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = self.inner.scene_image();
        r.depth_m
            .as_ref()
            .map(|z| array(py, z, &[r.rows, r.cols]))
            .transpose()
    }
    /// Object ids of a rendered 3D scene, (rows, cols) uint32 in the scene's pixels: 1 + index of
    /// the shape met first through each pixel centre, 0 = none; None for 2D charts. Names in
    /// `ids_legend`.
    #[getter]
    fn object_id<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .ids
            .as_ref()
            .map(|i| array(py, &i.object_id, &[i.height, i.width]))
            .transpose()
    }
    /// Material ids of a rendered 3D scene, (rows, cols) uint32: 1 + index of the material of the
    /// shape in `object_id`, 0 = none; None for 2D charts.
    #[getter]
    fn material_id<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .ids
            .as_ref()
            .map(|i| array(py, &i.material_id, &[i.height, i.width]))
            .transpose()
    }
    /// Training-data labels on the raw image's pixel grid (with `simulate(..., labels=True)`, 3D
    /// scenes; else None): a dict of numpy arrays "instances", "object_id", "material_id"
    /// (uint32, (rows, cols)), "depth" (float32, m), "normals" (camera frame) and
    /// "normals_world" ((rows, cols, 3)), "albedo" ((bands, rows, cols)), "albedo_srgb", "boxes"
    /// (per instance: box_3d, bbox_sensor, bbox_scene, visible_fraction, truncation, name,
    /// material), and "scene": the same maps on the render's grid. Pixel (r, c) describes the
    /// scene point imaged at raw pixel (r, c). A moving scene's: the first frame's, at its
    /// window's start (every frame's: `frame_labels`).
    #[getter]
    fn labels<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.inner
            .labels
            .as_ref()
            .map(|l| crate::labels::labels_dict(py, l))
            .transpose()
    }
    /// The camera model of the labels (with labels=True): "K" (3 x 3, raw grid, OpenCV: pixel
    /// centres at integers), "world_to_camera" (4 x 4, camera x right, y down, z forward, m),
    /// "scene_K" (the render's), "distorted" (the optics applied a lens's distortion, which K
    /// does not model), "note".
    #[getter]
    fn camera<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.inner
            .labels
            .as_ref()
            .map(|l| crate::labels::camera_dict(py, l))
            .transpose()
    }
    /// The labels of every raw frame, a list of dicts as `labels` (frame order, as `raw`):
    /// a moving 3D scene's frame k is a sharp snapshot at its window's start
    /// (`frame_times_s[k, 0]`; each row's under a rolling shutter), so its instance, depth and
    /// box labels move with the scene; a static scene's frames share one dict (the same
    /// object). None without labels=True or for 2D charts.
    #[getter]
    fn frame_labels<'py>(&self, py: Python<'py>) -> PyResult<Option<Vec<Bound<'py, PyDict>>>> {
        self.per_frame(py, crate::labels::labels_dict)
    }
    /// The camera model of every raw frame's labels, a list of dicts as `camera` (a moving
    /// camera's extrinsics at each frame's window start); None without labels=True.
    #[getter]
    fn frame_cameras<'py>(&self, py: Python<'py>) -> PyResult<Option<Vec<Bound<'py, PyDict>>>> {
        self.per_frame(py, crate::labels::camera_dict)
    }
    /// The names of the ids present: {"background": 0, "objects": {1: name, ...},
    /// "materials": {...}}; None for 2D charts.
    #[getter]
    fn ids_legend<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .ids
            .as_ref()
            .map(|ids| to_py(py, &ids.legend()))
            .transpose()
    }
    /// Raw frames, (frames, rows, cols) uint16 ADC values (DN).
    #[getter]
    fn raw<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::raw_stack(py, &self.inner.frames)
    }
    /// An [hdr] sensor (dual conversion gain, split pixel): the low readout's raw frames
    /// (LCG / small photodiode), (frames, rows, cols) uint16 DN; `raw` is the high readout.
    /// None for other sensors.
    #[getter]
    fn raw_low<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .hdr
            .as_ref()
            .map(|h| crate::convert::raw_stack(py, &h.low))
            .transpose()
    }
    /// A dual-pixel sensor (`dual_pixel = true`): the left photodiodes' raw frames (the light
    /// through the pupil's left half), (frames, rows, cols) uint16 DN; `raw` is their sum with
    /// the right ones. None for other sensors.
    #[getter]
    fn raw_left<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .dual_pixel
            .as_ref()
            .map(|d| crate::convert::raw_stack(py, &d.left))
            .transpose()
    }
    /// A dual-pixel sensor: the right photodiodes' raw frames (the pupil's right half). None
    /// for other sensors.
    #[getter]
    fn raw_right<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .dual_pixel
            .as_ref()
            .map(|d| crate::convert::raw_stack(py, &d.right))
            .transpose()
    }
    /// An [hdr] sensor: the merged linear frames, (frames, rows, cols) float32 electrons of the
    /// high readout (merged.exr). None for other sensors.
    #[getter]
    fn merged_e<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .hdr
            .as_ref()
            .map(|h| {
                let v: Vec<f32> = h.merged_e.iter().flatten().copied().collect();
                array(py, &v, &[h.merged_e.len(), r.rows, r.cols])
            })
            .transpose()
    }
    /// An [hdr] sensor: its merge's figures (run.json's results.hdr: mode, switch_e,
    /// max_merged_e, noise_floor_e, dynamic_range_db, sensitivity_ratio). None otherwise.
    #[getter]
    fn hdr<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .hdr
            .as_ref()
            .map(|h| to_py(py, &camsim::pipeline::records::HdrResults::of(&h.model)))
            .transpose()
    }
    /// With simulate(..., noise_free=True): PSNR (dB) and SSIM of the raw and of the preview
    /// against their noise-free counterparts, {"raw": {"psnr_db", "ssim"}, "preview": {...}}
    /// (run.json's results.quality); None otherwise.
    #[getter]
    fn quality<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .quality
            .as_ref()
            .map(|q| to_py(py, q))
            .transpose()
    }
    /// The sensor's faulty pixels ([defects]; defects.json): a list of (row, col, kind) on the
    /// raw's grid, kind "hot", "dead", "stuck" or "rtn"; empty without [defects].
    #[getter]
    fn defects(&self) -> Vec<(usize, usize, String)> {
        use camsim::sensor::defects::DefectKind;
        self.inner
            .defects
            .iter()
            .map(|d| {
                let kind = match d.kind {
                    DefectKind::Hot => "hot",
                    DefectKind::Dead => "dead",
                    DefectKind::Stuck => "stuck",
                    DefectKind::Rtn => "rtn",
                };
                (d.row, d.col, kind.to_string())
            })
            .collect()
    }
    /// CFA of the raw frames: a Bayer name ("RGGB", ...), "RGBW", "quad-bayer", or the tile's
    /// rows of filter names ("r c/y b").
    #[getter]
    fn cfa(&self) -> String {
        self.inner.frames[0].cfa_layout().name()
    }
    /// Black level, DN.
    #[getter]
    fn black_level(&self) -> f64 {
        self.inner.frames[0].black_level_dn
    }
    /// White level (saturation), DN.
    #[getter]
    fn white_level(&self) -> f64 {
        self.inner.frames[0].white_level_dn
    }
    /// ADC bits.
    #[getter]
    fn bits(&self) -> u32 {
        self.inner.frames[0].bits
    }
    /// Exposure time used, s.
    #[getter]
    fn exposure_s(&self) -> f64 {
        self.inner.exposure_s
    }
    /// The expected ADC value per pixel of the first frame without noise or quantization,
    /// (rows, cols) float32 DN; None unless simulate(..., noise_free=True).
    #[getter]
    fn noise_free<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .noise_free_frame(0)
            .map(|v| array(py, v, &[r.rows, r.cols]))
            .transpose()
    }
    /// The same for every raw frame, (frames, rows, cols) float32 DN (a moving scene's frames
    /// each at its own time, a bracket's each at its exposure); None unless
    /// simulate(..., noise_free=True).
    #[getter]
    fn noise_free_frames<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .noise_free_dn
            .as_ref()
            .map(|f| {
                let v: Vec<f32> = f.iter().flatten().copied().collect();
                array(py, &v, &[f.len(), r.rows, r.cols])
            })
            .transpose()
    }
    /// Each raw frame's window in the scene's time, (frames, 2) float64: start and duration, s
    /// (a burst, bracket or video of a moving 3D scene renders each frame at its own time).
    #[getter]
    fn frame_times_s<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let t = &self.inner.frame_times;
        let v: Vec<f64> = t.iter().flat_map(|f| [f.start_s, f.duration_s]).collect();
        array(py, &v, &[t.len(), 2])
    }
    /// Optical flow of each frame on the sensor grid, (frames, rows, cols, 2) float32 sensor
    /// pixels ([dx right, dy down], aligned with raw): where the surface each pixel sees at the
    /// frame's start is at the end of its exposure. None unless simulate(..., flow=True) on a 3D
    /// scene.
    #[getter]
    fn flow<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .flow
            .as_ref()
            .map(|f| {
                let v: Vec<f32> = f
                    .iter()
                    .flat_map(|m| m.exposure.iter().flatten().copied())
                    .collect();
                array(py, &v, &[f.len(), r.rows, r.cols, 2])
            })
            .transpose()
    }
    /// Flow from each frame's start to the next frame's start, (frames - 1, rows, cols, 2)
    /// float32 sensor pixels; None unless simulate(..., flow=True) on a 3D scene.
    #[getter]
    fn flow_next<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .flow
            .as_ref()
            .map(|f| {
                let v: Vec<f32> = f
                    .iter()
                    .filter_map(|m| m.to_next.as_ref())
                    .flat_map(|m| m.iter().flatten().copied())
                    .collect();
                array(py, &v, &[f.len().saturating_sub(1), r.rows, r.cols, 2])
            })
            .transpose()
    }
    /// sRGB preview, (rows, cols, 3) uint8.
    #[getter]
    fn preview<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = &self.inner.preview;
        array(py, &p.data, &[p.rows, p.cols, 3])
    }
    /// The run's record as a dict (what run.json holds: configs, results, times).
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(
            py,
            &self
                .inner
                .record(&RunInfo::default(), &OutputSet::default()),
        )
    }
    /// For a Macbeth chart scene: the chart's outer corners on the sensor, [[x, y], ...] pixels
    /// (top-left = dark skin, top-right, bottom-right, bottom-left), as `chart()` takes them;
    /// None for other scenes.
    #[getter]
    fn chart_corners(&self) -> PyResult<Option<Vec<[f64; 2]>>> {
        let s = &self.inner.sensor;
        let r = &self.inner.frames[0];
        let c = camsim::pipeline::macbeth_chart_corners_px(
            &self.inner.config,
            &self.inner.optics,
            s.pixel_pitch_um * 1e-6,
            r.rows,
            r.cols,
        )
        .map_err(err)?;
        Ok(c.map(|c| c.to_vec()))
    }
    /// The effective config as a dict (pass it back to simulate to repeat the run).
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner.config)
    }
    /// Write files into folder `dir` as `camsim simulate --save` does (atomically as a whole).
    #[pyo3(signature = (dir, save = "default", exr_precision = "f32", exr_compression = "none"))]
    fn write(
        &self,
        py: Python<'_>,
        dir: std::path::PathBuf,
        save: &str,
        exr_precision: &str,
        exr_compression: &str,
    ) -> PyResult<()> {
        let outputs = OutputSet::parse(save).map_err(err)?;
        let exr = ExrOptions::parse(exr_precision, exr_compression).map_err(err)?;
        if outputs.contains(camsim::Output::NoiseFree) && self.inner.noise_free_dn.is_none() {
            return Err(err("save noise-free needs simulate(..., noise_free=True)"));
        }
        if outputs.contains(camsim::Output::Flow)
            && self.inner.flow.is_none()
            && self.inner.ids.is_some()
        {
            return Err(err("save flow needs simulate(..., flow=True)"));
        }
        py.detach(|| self.inner.write(&dir, &outputs, exr, &RunInfo::default()))
            .map_err(err)
    }
    fn __repr__(&self) -> String {
        let r = &self.inner.frames[0];
        format!(
            "camsim.Simulation({} frame(s) {} x {} {}, exposure {:.4} s, {} {} bands)",
            self.inner.frames.len(),
            r.rows,
            r.cols,
            r.cfa_layout().name(),
            self.inner.exposure_s,
            if self.inner.radiance.is_some() {
                "radiance"
            } else {
                "lens-camera irradiance"
            },
            self.inner.scene_image().bands()
        )
    }
}

/// Run the whole pipeline on a config (None: the built-in default; a dict, TOML text or a path),
/// with `seed` in place of the config's when given.
#[pyfunction]
#[pyo3(signature = (config = None, noise_free = false, seed = None, labels = false, flow = false))]
fn simulate(
    py: Python<'_>,
    config: Option<&Bound<'_, PyAny>>,
    noise_free: bool,
    seed: Option<u64>,
    labels: bool,
    flow: bool,
) -> PyResult<PySimulation> {
    let mut cfg = config_from(config)?;
    if let Some(s) = seed {
        cfg.seed = s;
    }
    let sim = py
        .detach(|| {
            let opts = SimulateOptions {
                noise_free,
                labels: labels.then_some(camsim::render::LabelRequest {
                    normals: true,
                    albedo: true,
                    amodal: false,
                }),
                flow,
            };
            camsim::simulate(&cfg, &opts, &|_, _, _| {})
        })
        .map_err(err)?;
    Ok(PySimulation { inner: sim })
}

/// A config as a dict (checked, every default filled in): from a dict, TOML text or a path
/// (TOML or run.json, relative paths resolved); None: the built-in default.
#[pyfunction]
#[pyo3(signature = (config = None))]
fn load_config<'py>(
    py: Python<'py>,
    config: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    to_py(py, &config_from(config)?)
}

/// A preset as a dict: kind "simulate" (the built-in default config), "sensor" or "lens".
#[pyfunction]
#[pyo3(signature = (kind, name = None))]
fn preset<'py>(py: Python<'py>, kind: &str, name: Option<&str>) -> PyResult<Bound<'py, PyAny>> {
    match (kind, name) {
        ("simulate", _) => to_py(py, &camsim::SimulateConfig::builtin_default()),
        ("sensor", Some(n)) => to_py(py, camsim::sensor::Sensor::preset(n).map_err(err)?.config()),
        ("lens", Some(n)) => to_py(py, &camsim::optics::OpticsConfig::preset(n).map_err(err)?),
        _ => Err(err(format!(
            "unknown preset kind {kind:?} (simulate, sensor NAME, lens NAME)"
        ))),
    }
}

/// Every family of names camsim knows: {title: [names]} (the catalogue `camsim presets` lists).
#[pyfunction]
fn names<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for f in camsim::names::catalogue() {
        let names: Vec<&str> = f.entries.iter().map(|e| e.0).collect();
        d.set_item(f.title, names)?;
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySimulation>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(load_config, m)?)?;
    m.add_function(wrap_pyfunction!(preset, m)?)?;
    m.add_function(wrap_pyfunction!(names, m)?)?;
    Ok(())
}
