//! The compiled part of the `camsim` Python package (`camsim._camsim`): the pipeline and each stage
//! on numpy arrays. The Python layer (`python/camsim/__init__.py`) turns configs given as dicts,
//! TOML text or paths into JSON for these functions, and results into dicts.
//!
//! Every function releases the GIL while it computes; every camsim error becomes a
//! `camsim.CamsimError` carrying camsim's message (a panic becomes a Python exception too).

use camsim::analysis::chart::{chart_patch_stats_raw, ChartCorners};
use camsim::analysis::image::{Plane, Rect};
use camsim::analysis::qefit::{fit_qe_matrix, MatrixForm};
use camsim::analysis::roi::roi_stats_raw;
use camsim::analysis::sfr::{sfr_luminance, sfr_raw_channel, SfrOptions};
use camsim::core::image::ImageGeometry;
use camsim::core::{CfaChannel, CfaPattern, Quantity, RawImage, SpectralImage, WavelengthGrid};
use camsim::optics::{Optics, OpticsConfig};
use camsim::sensor::{Capture, Exposure, Sensor, SensorConfig};
use camsim::{
    ExrCompression, ExrOptions, ExrPrecision, OutputSet, RunInfo, SimulateConfig, SimulateOptions,
    Simulation,
};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _camsim,
    CamsimError,
    PyException,
    "An error reported by camsim (bad input, a file it cannot read, ...)."
);

fn err(e: impl std::fmt::Display) -> PyErr {
    CamsimError::new_err(e.to_string())
}

/// A Python object from JSON text (through the `json` module: plain dicts, lists, numbers).
fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?
        .call_method1("loads", (value.to_string(),))
}

fn array1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyAny> {
    PyArray1::from_slice(py, v).into_any()
}

/// A numpy array of `shape` holding a copy of `v`.
fn array<'py, T: numpy::Element>(
    py: Python<'py>,
    v: &[T],
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_slice(py, v).reshape(shape)?.into_any())
}

fn wavelengths(img: &SpectralImage) -> Vec<f64> {
    (0..img.bands())
        .map(|b| img.grid.wavelength_nm(b))
        .collect()
}

/// A spectral image as a dict: `key` -> (bands, rows, cols) float32, `wavelengths_nm`,
/// `spacing_m`, `fov_deg`, `distance_m`, `depth_m` ((rows, cols) or None), `units`.
fn spectral_dict<'py>(
    py: Python<'py>,
    img: &SpectralImage,
    key: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item(
        key,
        array(py, &img.data, &[img.bands(), img.rows, img.cols])?,
    )?;
    d.set_item("wavelengths_nm", array1(py, &wavelengths(img)))?;
    d.set_item("spacing_m", img.sample_spacing_m)?;
    d.set_item("fov_deg", img.geometry.fov_deg)?;
    d.set_item("distance_m", img.geometry.distance_m)?;
    d.set_item("units", img.quantity.unit())?;
    match &img.depth_m {
        Some(z) => d.set_item("depth_m", array(py, z, &[img.rows, img.cols])?)?,
        None => d.set_item("depth_m", py.None())?,
    }
    Ok(d)
}

/// A (bands, rows, cols) float32 array and its wavelengths as a SpectralImage.
fn spectral_from(
    data: PyReadonlyArray3<'_, f32>,
    wavelengths_nm: Vec<f64>,
    spacing_m: f64,
    quantity: Quantity,
    geometry: ImageGeometry,
) -> PyResult<SpectralImage> {
    let shape = data.shape().to_vec();
    if shape[0] != wavelengths_nm.len() {
        return Err(err(format!(
            "the array has {} bands (axis 0) but {} wavelengths were given",
            shape[0],
            wavelengths_nm.len()
        )));
    }
    let grid = WavelengthGrid::from_wavelengths(&wavelengths_nm).map_err(err)?;
    let values = data.as_array().iter().copied().collect::<Vec<f32>>();
    let mut img = SpectralImage::from_data(shape[1], shape[2], grid, spacing_m, quantity, values)
        .map_err(err)?;
    img.validate_values(quantity.name()).map_err(err)?;
    img.geometry = geometry;
    Ok(img)
}

fn raw_from(
    raw: PyReadonlyArray2<'_, u16>,
    cfa: &str,
    bits: u32,
    black_level: f64,
) -> PyResult<RawImage> {
    let shape = raw.shape().to_vec();
    let mut img = RawImage::new(
        shape[0],
        shape[1],
        CfaPattern::parse(cfa).map_err(err)?,
        bits,
    )
    .map_err(err)?;
    img.dn = raw.as_array().iter().copied().collect();
    img.black_level_dn = black_level;
    Ok(img)
}

fn lens_from(lens: &str) -> PyResult<OpticsConfig> {
    if lens.trim_start().starts_with('{') {
        serde_json::from_str(lens).map_err(|e| err(format!("lens: {e}")))
    } else {
        camsim::pipeline::load_lens(lens).map_err(err)
    }
}

fn sensor_from(sensor: &str) -> PyResult<Sensor> {
    if sensor.trim_start().starts_with('{') {
        let c: SensorConfig =
            serde_json::from_str(sensor).map_err(|e| err(format!("sensor: {e}")))?;
        Sensor::from_config_named(c, "the sensor dict").map_err(err)
    } else {
        camsim::pipeline::load_sensor(sensor).map_err(err)
    }
}

/// The result of `simulate`: every stage's image as numpy arrays, and the run's metadata.
#[pyclass(module = "camsim._camsim", name = "Simulation", frozen)]
struct PySimulation {
    inner: Simulation,
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
    /// The names of the ids present: {"background": 0, "objects": {"1": name, ...},
    /// "materials": {...}}; None for 2D charts.
    #[getter]
    fn ids_legend<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(ids) = &self.inner.ids else {
            return Ok(None);
        };
        let v = serde_json::to_value(ids.legend()).map_err(err)?;
        json_to_py(py, &v).map(Some)
    }
    /// Raw frames, (frames, rows, cols) uint16 ADC values (DN).
    #[getter]
    fn raw<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let f = &self.inner.frames;
        let all: Vec<u16> = f.iter().flat_map(|r| r.dn.iter().copied()).collect();
        array(py, &all, &[f.len(), f[0].rows, f[0].cols])
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
    /// The expected ADC value per pixel without noise or quantization, (rows, cols) float32 DN;
    /// None unless simulate(..., noise_free=True).
    #[getter]
    fn noise_free<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let r = &self.inner.frames[0];
        self.inner
            .noise_free_dn
            .as_ref()
            .map(|v| array(py, v, &[r.rows, r.cols]))
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
        Ok(PyArray1::from_slice(py, &p.data)
            .reshape([p.rows, p.cols, 3])?
            .into_any())
    }
    /// The run's record as a dict (what run.json holds: configs, results, times).
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(
            py,
            &self
                .inner
                .metadata(&RunInfo::default(), &OutputSet::default()),
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
        json_to_py(py, &serde_json::to_value(&self.inner.config).map_err(err)?)
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
        let precision = match exr_precision {
            "f32" => ExrPrecision::F32,
            "f16" => ExrPrecision::F16,
            o => return Err(err(format!("exr_precision {o:?}: f32 or f16"))),
        };
        let compression = match exr_compression {
            "none" => ExrCompression::None,
            "rle" => ExrCompression::Rle,
            "zip" => ExrCompression::Zip,
            "zips" => ExrCompression::Zips,
            "piz" => ExrCompression::Piz,
            o => {
                return Err(err(format!(
                    "exr_compression {o:?}: none, rle, zip, zips or piz"
                )))
            }
        };
        if outputs.contains(camsim::Output::NoiseFree) && self.inner.noise_free_dn.is_none() {
            return Err(err("save noise-free needs simulate(..., noise_free=True)"));
        }
        if outputs.contains(camsim::Output::Flow)
            && self.inner.flow.is_none()
            && self.inner.ids.is_some()
        {
            return Err(err("save flow needs simulate(..., flow=True)"));
        }
        py.detach(|| {
            self.inner.write(
                &dir,
                &outputs,
                ExrOptions {
                    precision,
                    compression,
                },
                &RunInfo::default(),
            )
        })
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

/// Run the whole pipeline on a config given as JSON (a SimulateConfig).
#[pyfunction]
#[pyo3(signature = (config_json, noise_free = false, flow = false))]
fn simulate_json(
    py: Python<'_>,
    config_json: &str,
    noise_free: bool,
    flow: bool,
) -> PyResult<PySimulation> {
    let cfg: SimulateConfig =
        serde_json::from_str(config_json).map_err(|e| err(format!("config: {e}")))?;
    cfg.check_scene_source().map_err(err)?;
    let sim = py
        .detach(|| {
            let opts = SimulateOptions { noise_free, flow };
            camsim::simulate(&cfg, &opts, &|_, _, _| {})
        })
        .map_err(err)?;
    Ok(PySimulation { inner: sim })
}

/// A SimulateConfig from TOML text, as JSON.
#[pyfunction]
fn config_from_toml(text: &str) -> PyResult<String> {
    let cfg = SimulateConfig::from_toml_str(text).map_err(err)?;
    serde_json::to_string(&cfg).map_err(err)
}

/// A SimulateConfig from JSON (checked, every default filled in), as JSON.
#[pyfunction]
fn config_from_json(text: &str) -> PyResult<String> {
    let cfg: SimulateConfig =
        serde_json::from_str(text).map_err(|e| err(format!("config: {e}")))?;
    cfg.check_scene_source().map_err(err)?;
    serde_json::to_string(&cfg).map_err(err)
}

/// A SimulateConfig from a file (TOML, or a run.json), its relative paths resolved, as JSON.
#[pyfunction]
fn config_from_file(path: std::path::PathBuf) -> PyResult<String> {
    let cfg = SimulateConfig::load(&path).map_err(err)?;
    serde_json::to_string(&cfg).map_err(err)
}

/// Presets as JSON: kind "simulate" (the built-in default config), "sensor" or "lens".
#[pyfunction]
#[pyo3(signature = (kind, name = None))]
fn preset_json(kind: &str, name: Option<&str>) -> PyResult<String> {
    match (kind, name) {
        ("simulate", _) => serde_json::to_string(&SimulateConfig::builtin_default()).map_err(err),
        ("sensor", Some(n)) => {
            serde_json::to_string(Sensor::preset(n).map_err(err)?.config()).map_err(err)
        }
        ("lens", Some(n)) => {
            serde_json::to_string(&OpticsConfig::preset(n).map_err(err)?).map_err(err)
        }
        _ => Err(err(format!(
            "unknown preset kind {kind:?} (simulate, sensor NAME, lens NAME)"
        ))),
    }
}

/// Stage 1, a 2D chart: scene config JSON (a `[scene]` table) and the wavelength grid
/// (start_nm, step_nm, count) -> dict with `radiance`.
#[pyfunction]
#[pyo3(signature = (scene_json, start_nm = 400.0, step_nm = 10.0, count = 31))]
fn scene<'py>(
    py: Python<'py>,
    scene_json: &str,
    start_nm: f64,
    step_nm: f64,
    count: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg: camsim::scene::SceneConfig =
        serde_json::from_str(scene_json).map_err(|e| err(format!("scene: {e}")))?;
    let grid = WavelengthGrid::from_wavelengths(
        &(0..count)
            .map(|i| start_nm + step_nm * i as f64)
            .collect::<Vec<_>>(),
    )
    .map_err(err)?;
    let img = py
        .detach(|| camsim::scene::create(&cfg, &grid).map_err(|e| e.to_string()))
        .map_err(err)?;
    spectral_dict(py, &img, "radiance")
}

/// Stage 1, a 3D scene: a built-in scene or a pbrt-v4 file, path traced -> dict with `radiance`,
/// `depth_m`, `object_id` and `material_id` ((rows, cols) uint32: 1 + index of the shape and of
/// its material met first through each pixel centre, 0 = none) and `ids_legend` (their names).
#[pyfunction]
#[pyo3(signature = (builtin = None, pbrt = None, resolution = None, samples_per_pixel = None, seed = 1, start_nm = 400.0, step_nm = 10.0, count = 31))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    builtin: Option<&str>,
    pbrt: Option<std::path::PathBuf>,
    resolution: Option<(usize, usize)>,
    samples_per_pixel: Option<u32>,
    seed: u64,
    start_nm: f64,
    step_nm: f64,
    count: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let grid = WavelengthGrid::from_wavelengths(
        &(0..count)
            .map(|i| start_nm + step_nm * i as f64)
            .collect::<Vec<_>>(),
    )
    .map_err(err)?;
    let mut opts = camsim::scene3d::builtin::BuiltinOptions {
        grid,
        seed,
        resolution,
        ..Default::default()
    };
    if let Some(spp) = samples_per_pixel {
        opts.samples_per_pixel = spp;
    }
    let builtin = builtin.map(str::to_string);
    let out = py
        .detach(|| -> camsim::Result<camsim::render::RenderOutput> {
            let mut scene = camsim::pipeline::render::load_scene(
                builtin.as_deref(),
                pbrt.as_deref(),
                None,
                &opts,
            )?;
            if let Some(spp) = samples_per_pixel {
                scene.settings.samples_per_pixel = spp;
            }
            camsim::pipeline::render::render_scene(&scene, &|_, _, _| {})
        })
        .map_err(err)?;
    let d = spectral_dict(py, &out.radiance, "radiance")?;
    let ids = &out.ids;
    d.set_item(
        "object_id",
        array(py, &ids.object_id, &[ids.height, ids.width])?,
    )?;
    d.set_item(
        "material_id",
        array(py, &ids.material_id, &[ids.height, ids.width])?,
    )?;
    d.set_item(
        "ids_legend",
        json_to_py(py, &serde_json::to_value(ids.legend()).map_err(err)?)?,
    )?;
    Ok(d)
}

/// Stage 2: radiance (bands, rows, cols) -> dict with `irradiance`.
#[pyfunction]
#[pyo3(signature = (radiance, wavelengths_nm, lens = "pixel4a", spacing_m = 0.0, distance_m = 0.0, fov_deg = 0.0, depth_m = None))]
#[allow(clippy::too_many_arguments)]
fn optics<'py>(
    py: Python<'py>,
    radiance: PyReadonlyArray3<'_, f32>,
    wavelengths_nm: Vec<f64>,
    lens: &str,
    spacing_m: f64,
    distance_m: f64,
    fov_deg: f64,
    depth_m: Option<PyReadonlyArray2<'_, f32>>,
) -> PyResult<Bound<'py, PyDict>> {
    let geometry = ImageGeometry {
        fov_deg,
        distance_m,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    let spacing = if spacing_m > 0.0 { spacing_m } else { 1.0 };
    let mut img = spectral_from(
        radiance,
        wavelengths_nm,
        spacing,
        Quantity::Radiance,
        geometry,
    )?;
    if let Some(z) = depth_m {
        img.depth_m = Some(z.as_array().iter().copied().collect());
    }
    let optics = Optics::from_config(&lens_from(lens)?).map_err(err)?;
    let out = py.detach(|| optics.compute(&img)).map_err(err)?;
    spectral_dict(py, &out, "irradiance")
}

/// Stage 3: irradiance (bands, rows, cols) -> dict with `raw` (frames, rows, cols) uint16.
#[pyfunction]
#[pyo3(signature = (irradiance, wavelengths_nm, spacing_m, sensor = "pixel4a", exposure_s = None, seed = 1, frames = 1, rows = None, cols = None, exposures_s = None, iso = None))]
#[allow(clippy::too_many_arguments)]
fn sensor<'py>(
    py: Python<'py>,
    irradiance: PyReadonlyArray3<'_, f32>,
    wavelengths_nm: Vec<f64>,
    spacing_m: f64,
    sensor: &str,
    exposure_s: Option<f64>,
    seed: u64,
    frames: usize,
    rows: Option<usize>,
    cols: Option<usize>,
    exposures_s: Option<Vec<f64>>,
    iso: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let img = spectral_from(
        irradiance,
        wavelengths_nm,
        spacing_m,
        Quantity::Irradiance,
        ImageGeometry::default(),
    )?;
    let mut s = sensor_from(sensor)?;
    if let Some(iso) = iso {
        // iso replaces the analog gain: gain = base_iso / iso (the sensor needs base_iso).
        let mut c = s.config().clone();
        c.iso = Some(iso);
        c.analog_gain = 1.0;
        s = Sensor::from_config_named(c, &format!("sensor with iso = {iso}")).map_err(err)?;
    }
    if rows.is_some() || cols.is_some() {
        s = s
            .window(rows.unwrap_or(s.rows()), cols.unwrap_or(s.cols()))
            .map_err(err)?;
    }
    if frames == 0 {
        return Err(err("frames must be at least 1"));
    }
    let exposure = match exposure_s {
        Some(t) if !(t >= 0.0 && t.is_finite()) => {
            return Err(err(format!("exposure_s = {t}: must be >= 0")))
        }
        Some(t) => Exposure::Seconds(t),
        None => Capture::auto().exposure,
    };
    let cap = Capture {
        exposure,
        frames,
        seed,
    };
    if let Some(model) = s.hdr_model() {
        // An [hdr] sensor (dual conversion gain / split pixel): both readouts and the merged frame.
        if exposures_s.is_some() {
            return Err(err(
                "an [hdr] sensor takes one exposure (exposure_s or auto), not a bracket",
            ));
        }
        let h = py.detach(|| s.compute_hdr(&img, &cap)).map_err(err)?;
        let r0 = &h.high[0];
        let (rows, cols, n) = (r0.rows, r0.cols, h.high.len());
        let stack = |v: &[RawImage]| {
            v.iter()
                .flat_map(|r| r.dn.iter().copied())
                .collect::<Vec<u16>>()
        };
        let merged: Vec<f32> = h.merged_e.iter().flat_map(|m| m.iter().copied()).collect();
        let d = PyDict::new(py);
        d.set_item("raw", array(py, &stack(&h.high), &[n, rows, cols])?)?;
        d.set_item("raw_low", array(py, &stack(&h.low), &[n, rows, cols])?)?;
        d.set_item("merged_e", array(py, &merged, &[n, rows, cols])?)?;
        d.set_item(
            "hdr_mode",
            match model.mode {
                camsim::sensor::HdrMode::Dcg => "dcg",
                camsim::sensor::HdrMode::SplitPixel => "split-pixel",
            },
        )?;
        d.set_item("dynamic_range_db", model.dynamic_range_db())?;
        raw_layout_items(&d, r0)?;
        d.set_item("exposure_s", h.exposure_s)?;
        return Ok(d);
    }
    let f = match exposures_s {
        Some(_) if exposure_s.is_some() => {
            return Err(err(
                "give either exposure_s or exposures_s (a bracket), not both",
            ))
        }
        Some(times) => py
            .detach(|| s.compute_bracket(&img, &times, frames, seed))
            .map_err(err)?,
        None => py.detach(|| s.compute(&img, &cap)).map_err(err)?,
    };
    let r0 = &f.raw[0];
    let all: Vec<u16> = f.raw.iter().flat_map(|r| r.dn.iter().copied()).collect();
    let d = PyDict::new(py);
    d.set_item("raw", array(py, &all, &[f.raw.len(), r0.rows, r0.cols])?)?;
    raw_layout_items(&d, r0)?;
    d.set_item("exposure_s", f.exposure_s)?;
    d.set_item(
        "exposures_s",
        f.raw.iter().map(|r| r.exposure_s).collect::<Vec<f64>>(),
    )?;
    d.set_item("mean_electrons_rgb", f.mean_electrons.to_vec())?;
    d.set_item(
        "mean_electrons_by_filter",
        f.mean_electrons_by_filter.clone(),
    )?;
    Ok(d)
}

/// The raw's CFA and levels as `sensor()` returns them: cfa, filters, black_level, white_level, bits.
fn raw_layout_items(d: &Bound<'_, PyDict>, r0: &RawImage) -> PyResult<()> {
    let layout = r0.cfa_layout();
    d.set_item("cfa", layout.name())?;
    d.set_item("filters", layout.filters().to_vec())?;
    d.set_item("black_level", r0.black_level_dn)?;
    d.set_item("white_level", r0.white_level_dn)?;
    d.set_item("bits", r0.bits)?;
    Ok(())
}

/// Demosaic of a raw mosaic (rows, cols) uint16 -> (rows, cols, 3) float32 DN (black level
/// subtracted); `method` = bilinear, malvar, adaptive-laplacian.
#[pyfunction]
#[pyo3(signature = (raw, cfa = "RGGB", bits = 12, black_level = 0.0, method = "bilinear"))]
fn demosaic<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'_, u16>,
    cfa: &str,
    bits: u32,
    black_level: f64,
    method: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let method: camsim::isp::DemosaicMethod = method.parse().map_err(err)?;
    let img = raw_from(raw, cfa, bits, black_level)?;
    let rgb = py
        .detach(|| camsim::isp::demosaic(&img, method))
        .map_err(err)?;
    rgb_to_array(py, &rgb)
}

fn rgb_to_array<'py>(py: Python<'py>, rgb: &camsim::isp::RgbImage) -> PyResult<Bound<'py, PyAny>> {
    let mut out = Vec::with_capacity(rgb.rows * rgb.cols * 3);
    for i in 0..rgb.rows * rgb.cols {
        out.extend_from_slice(&[rgb.r[i], rgb.g[i], rgb.b[i]]);
    }
    array(py, &out, &[rgb.rows, rgb.cols, 3])
}

fn rgb_from(rgb: PyReadonlyArray3<'_, f32>) -> PyResult<camsim::isp::RgbImage> {
    let shape = rgb.shape();
    if shape[2] != 3 {
        return Err(err(format!(
            "rgb has shape {shape:?}; expected (rows, cols, 3)"
        )));
    }
    let (rows, cols) = (shape[0], shape[1]);
    let mut img = camsim::isp::RgbImage::zeros(rows, cols);
    let a = rgb.as_array();
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            (img.r[i], img.g[i], img.b[i]) = (a[[y, x, 0]], a[[y, x, 1]], a[[y, x, 2]]);
        }
    }
    Ok(img)
}

/// White-balance gains (green = 1) of a linear RGB image (rows, cols, 3): gray-world or
/// white-patch (pixels at or above the `percentile` of R+G+B, those with a channel at or above
/// `saturation` left out). Returns the gains.
#[pyfunction]
#[pyo3(signature = (rgb, method = "gray-world", percentile = 99.0, saturation = None))]
fn white_balance_gains(
    rgb: PyReadonlyArray3<'_, f32>,
    method: &str,
    percentile: f64,
    saturation: Option<f64>,
) -> PyResult<Vec<f64>> {
    use camsim::isp::white_balance::{gray_world_gains, white_patch_gains};
    use camsim::isp::WhiteBalanceMethod;
    let img = rgb_from(rgb)?;
    let g = match method.parse::<WhiteBalanceMethod>().map_err(err)? {
        WhiteBalanceMethod::None => [1.0; 3],
        WhiteBalanceMethod::GrayWorld => gray_world_gains(&img).map_err(err)?,
        WhiteBalanceMethod::WhitePatch => white_patch_gains(&img, percentile, saturation).map_err(err)?,
        WhiteBalanceMethod::Illuminant => {
            return Err(err("white_balance_gains: 'illuminant' needs the sensor and illuminant; use illuminant_white_balance_gains"))
        }
    };
    Ok(g.to_vec())
}

/// White-balance gains (green = 1) from a known illuminant (built-in name) and a sensor (preset
/// name, TOML file or JSON text): the camera response to a perfect white, `sum QE_c E l dl`, inverted.
#[pyfunction]
#[pyo3(signature = (illuminant = "D65", sensor = "pixel4a"))]
fn illuminant_white_balance_gains(illuminant: &str, sensor: &str) -> PyResult<Vec<f64>> {
    let s = sensor_from(sensor)?;
    let grid = WavelengthGrid::default();
    let illum = camsim::core::tables::illuminant(illuminant).map_err(err)?;
    Ok(
        camsim::isp::white_balance::illuminant_gains(&s.channel_qe(&grid), &grid, &illum)
            .map_err(err)?
            .to_vec(),
    )
}

/// Fit a 3x3 colour-correction matrix camera RGB -> XYZ on patch pairs: `camera` and
/// `target_xyz` are (n, 3); `objective` = xyz, linear-srgb or cielab (relative to `white_xyz`).
/// Returns (matrix as 3 rows, per-patch CIEDE2000).
#[pyfunction]
#[pyo3(signature = (camera, target_xyz, white_xyz, objective = "linear-srgb"))]
#[allow(clippy::type_complexity)]
fn fit_ccm(
    camera: Vec<[f64; 3]>,
    target_xyz: Vec<[f64; 3]>,
    white_xyz: [f64; 3],
    objective: &str,
) -> PyResult<(Vec<[f64; 3]>, Vec<f64>)> {
    let obj: camsim::isp::ccm::CcmObjective = objective.parse().map_err(err)?;
    let m = camsim::isp::ccm::fit_ccm(&camera, &target_xyz, white_xyz, obj).map_err(err)?;
    let de = camsim::isp::ccm::ccm_delta_e2000(&m, &camera, &target_xyz, white_xyz);
    Ok((m.to_vec(), de))
}

/// Every demosaicking method on a gray zone plate of side `size` reaching `f_max` cycles/pixel at
/// the edge, sampled by a `cfa` mosaic: MTF per annulus, MTF50 and RMS false colour, as JSON
/// (`{method: {frequency_cy_per_px, mtf, mtf50_cy_per_px, false_colour_low_rms, false_colour_rms}}`).
#[pyfunction]
#[pyo3(signature = (size = 512, f_max = 0.5, cfa = "RGGB"))]
fn demosaic_zone_plate_json(
    py: Python<'_>,
    size: usize,
    f_max: f64,
    cfa: &str,
) -> PyResult<String> {
    use camsim::isp::demosaic_quality::{zone_plate_quality, ZonePlate};
    if !(32..=8192).contains(&size) {
        return Err(err(format!("size = {size}: give 32 to 8192 pixels")));
    }
    if !(f_max > 0.0 && f_max <= 0.5) {
        return Err(err(format!(
            "f_max = {f_max}: give a frequency in (0, 0.5] cycles/pixel"
        )));
    }
    let cfa = CfaPattern::parse(cfa).map_err(err)?;
    let out = py.detach(|| {
        let zp = ZonePlate::new(size, f_max);
        let raw = zp.mosaic(cfa);
        let mut map = serde_json::Map::new();
        for m in camsim::isp::DemosaicMethod::ALL {
            let rgb = camsim::isp::demosaic(&raw, m)?;
            let q = zone_plate_quality(&zp, &rgb, 0.01f64.min(f_max / 10.0));
            map.insert(
                m.name().to_string(),
                serde_json::to_value(q).unwrap_or_default(),
            );
        }
        Ok::<_, camsim::core::error::CoreError>(serde_json::Value::Object(map))
    });
    serde_json::to_string(&out.map_err(err)?).map_err(err)
}

/// XYZ of the 24 ColorChecker patches under a built-in illuminant (white Y = 1) and the white's XYZ.
#[pyfunction]
#[pyo3(signature = (illuminant = "D65"))]
fn macbeth_xyz(illuminant: &str) -> PyResult<(Vec<[f64; 3]>, [f64; 3])> {
    let illum = camsim::core::tables::illuminant(illuminant).map_err(err)?;
    camsim::isp::ccm::macbeth_xyz(&illum, &WavelengthGrid::default()).map_err(err)
}

fn rect(r: Option<(usize, usize, usize, usize)>) -> Option<Rect> {
    r.map(|(row, col, rows, cols)| Rect::new(row, col, rows, cols))
}

/// ISO 12233 slanted-edge SFR of one raw channel ("R", "G", "B") or of the demosaicked
/// luminance ("luminance"); roi = (row, col, rows, cols). Returns the result as JSON.
#[pyfunction]
#[pyo3(signature = (raw, cfa = "RGGB", channel = "G", roi = None, pitch_um = None, bits = 12, black_level = 0.0))]
#[allow(clippy::too_many_arguments)]
fn sfr_json(
    py: Python<'_>,
    raw: PyReadonlyArray2<'_, u16>,
    cfa: &str,
    channel: &str,
    roi: Option<(usize, usize, usize, usize)>,
    pitch_um: Option<f64>,
    bits: u32,
    black_level: f64,
) -> PyResult<String> {
    let img = raw_from(raw, cfa, bits, black_level)?;
    let opts = SfrOptions {
        pixel_pitch_mm: pitch_um.map(|p| p * 1e-3),
        ..SfrOptions::default()
    };
    let ch = match channel {
        "R" | "r" => Some(CfaChannel::R),
        "G" | "g" => Some(CfaChannel::G),
        "B" | "b" => Some(CfaChannel::B),
        "luminance" => None,
        o => return Err(err(format!("channel {o:?}: R, G, B or luminance"))),
    };
    let res = py
        .detach(|| -> Result<_, String> {
            match ch {
                Some(c) => sfr_raw_channel(&img, c, rect(roi), &opts).map_err(|e| e.to_string()),
                None => {
                    let rgb =
                        camsim::isp::try_demosaic_bilinear(&img).map_err(|e| e.to_string())?;
                    let planes = [
                        Plane::new(rgb.rows, rgb.cols, rgb.r).map_err(|e| e.to_string())?,
                        Plane::new(rgb.rows, rgb.cols, rgb.g).map_err(|e| e.to_string())?,
                        Plane::new(rgb.rows, rgb.cols, rgb.b).map_err(|e| e.to_string())?,
                    ];
                    sfr_luminance(
                        &planes,
                        camsim::analysis::image::LUMINANCE_WEIGHTS_REC709,
                        rect(roi),
                        &opts,
                    )
                    .map_err(|e| e.to_string())
                }
            }
        })
        .map_err(err)?;
    serde_json::to_string(&res).map_err(err)
}

/// Per-channel statistics of raw regions [(row, col, rows, cols), ...], as JSON.
#[pyfunction]
#[pyo3(signature = (raw, rects, cfa = "RGGB", bits = 12, black_level = 0.0))]
fn roi_json(
    raw: PyReadonlyArray2<'_, u16>,
    rects: Vec<(usize, usize, usize, usize)>,
    cfa: &str,
    bits: u32,
    black_level: f64,
) -> PyResult<String> {
    let img = raw_from(raw, cfa, bits, black_level)?;
    let rects: Vec<Rect> = rects
        .into_iter()
        .map(|(r, c, h, w)| Rect::new(r, c, h, w))
        .collect();
    serde_json::to_string(&roi_stats_raw(&img, &rects).map_err(err)?).map_err(err)
}

/// ColorChecker patch statistics of a raw capture, chart corners [x, y] in the order top-left
/// (dark skin), top-right, bottom-right, bottom-left; as JSON.
#[pyfunction]
#[pyo3(signature = (raw, corners, cfa = "RGGB", fraction = 0.5, bits = 12, black_level = 0.0))]
fn chart_json(
    raw: PyReadonlyArray2<'_, u16>,
    corners: [[f64; 2]; 4],
    cfa: &str,
    fraction: f64,
    bits: u32,
    black_level: f64,
) -> PyResult<String> {
    let img = raw_from(raw, cfa, bits, black_level)?;
    let c = ChartCorners {
        top_left: corners[0],
        top_right: corners[1],
        bottom_right: corners[2],
        bottom_left: corners[3],
    };
    serde_json::to_string(&chart_patch_stats_raw(&img, &c, fraction).map_err(err)?).map_err(err)
}

/// The 3 x 3 QE correction matrix M (the paper's eq. 2) from measured and predicted channel
/// responses, (n, 3) each; form "unconstrained", "diagonal" or "paper_lower_non_negative"; as JSON.
#[pyfunction]
#[pyo3(signature = (measured, predicted, form = "unconstrained"))]
fn fit_qe_json(measured: Vec<[f64; 3]>, predicted: Vec<[f64; 3]>, form: &str) -> PyResult<String> {
    let form: MatrixForm = serde_json::from_value(serde_json::Value::String(form.into()))
        .map_err(|e| err(format!("form {form:?}: {e}")))?;
    serde_json::to_string(&fit_qe_matrix(&measured, &predicted, form).map_err(err)?).map_err(err)
}

/// EMVA 1288 per colour channel of a raw series: `bright` and `dark` (levels, frames, rows, cols)
/// uint16 (at least 2 frames per level), `exposures_s` per level, optionally the mean photons per
/// pixel per level (for QE and responsivity). Returns the per-channel results as JSON.
#[pyfunction]
#[pyo3(signature = (bright, dark, exposures_s, photons_per_pixel = None, cfa = "RGGB", bits = 12, black_level = 0.0, fit_max_fraction = 0.7))]
#[allow(clippy::too_many_arguments)]
fn emva_json(
    py: Python<'_>,
    bright: numpy::PyReadonlyArray4<'_, u16>,
    dark: numpy::PyReadonlyArray4<'_, u16>,
    exposures_s: Vec<f64>,
    photons_per_pixel: Option<Vec<f64>>,
    cfa: &str,
    bits: u32,
    black_level: f64,
    fit_max_fraction: f64,
) -> PyResult<String> {
    let (b, d) = (bright.shape().to_vec(), dark.shape().to_vec());
    if b[0] != exposures_s.len() || d[0] != exposures_s.len() {
        return Err(err(format!(
            "{} exposures for {} bright and {} dark levels (axis 0)",
            exposures_s.len(),
            b[0],
            d[0]
        )));
    }
    if photons_per_pixel
        .as_ref()
        .is_some_and(|p| p.len() != exposures_s.len())
    {
        return Err(err("photons_per_pixel needs one value per level"));
    }
    let pattern = CfaPattern::parse(cfa).map_err(err)?;
    let frames =
        |a: &numpy::PyReadonlyArray4<'_, u16>, s: &[usize]| -> PyResult<Vec<Vec<RawImage>>> {
            let v = a.as_array();
            (0..s[0])
                .map(|l| {
                    (0..s[1])
                        .map(|f| {
                            let mut r = RawImage::new(s[2], s[3], pattern, bits).map_err(err)?;
                            r.dn = v
                                .slice(numpy::ndarray::s![l, f, .., ..])
                                .iter()
                                .copied()
                                .collect();
                            r.black_level_dn = black_level;
                            Ok(r)
                        })
                        .collect()
                })
                .collect()
        };
    let (bf, df) = (frames(&bright, &b)?, frames(&dark, &d)?);
    let opts = camsim::analysis::emva::EmvaOptions {
        fit_max_fraction,
        ..Default::default()
    };
    let res = py
        .detach(|| {
            let levels: Vec<camsim::analysis::emva::EmvaRawInput> = (0..exposures_s.len())
                .map(|l| camsim::analysis::emva::EmvaRawInput {
                    exposure_s: exposures_s[l],
                    photons_per_pixel: photons_per_pixel.as_ref().map(|p| p[l]),
                    bright: bf[l].iter().collect(),
                    dark: df[l].iter().collect(),
                })
                .collect();
            camsim::analysis::emva::emva_raw(&levels, &opts)
        })
        .map_err(err)?;
    serde_json::to_string(&res).map_err(err)
}

/// EMVA 1288 of a series on disk: the series CSV (as `camsim analyze emva` reads it) and its raw
/// frames. Returns the `emva.json` record as JSON; with `out` also writes emva.json, ptc.png and
/// snr.png there (the folder must exist).
#[pyfunction]
#[pyo3(signature = (csv, out = None, cfa = None, bits = 16, black_level = 0.0))]
fn emva_series_json(
    py: Python<'_>,
    csv: std::path::PathBuf,
    out: Option<std::path::PathBuf>,
    cfa: Option<&str>,
    bits: u32,
    black_level: f64,
) -> PyResult<String> {
    use camsim::pipeline::emva::{analyze_series, MosaicFormat};
    let cfa = cfa.map(CfaPattern::parse).transpose().map_err(err)?;
    let format = MosaicFormat {
        cfa,
        black_dn: black_level,
        bits,
    };
    let json = py
        .detach(|| -> Result<serde_json::Value, String> {
            let series = analyze_series(&csv, format, &Default::default(), &|_, _, _| {})
                .map_err(|e| e.to_string())?;
            let json = series.to_json();
            if let Some(dir) = &out {
                camsim::io::atomic::write_json_atomic(&dir.join("emva.json"), &json)
                    .map_err(|e| e.to_string())?;
                series.write_plots(dir).map_err(|e| e.to_string())?;
            }
            Ok(json)
        })
        .map_err(err)?;
    serde_json::to_string(&json).map_err(err)
}

/// A dataset spec from text (TOML, or JSON for a dict) with relative paths resolved against
/// `base_dir`, checked completely.
fn dataset_spec(
    spec: &str,
    source: &str,
    base_dir: &std::path::Path,
) -> PyResult<camsim::dataset::DatasetSpec> {
    camsim::dataset::DatasetSpec::from_toml_str(spec, source, base_dir).map_err(err)
}

/// Check a dataset spec and return its plan as JSON: samples, shards, shard size, fingerprint and
/// the first samples' parameters.
#[pyfunction]
fn dataset_plan_json(spec: &str, source: &str, base_dir: std::path::PathBuf) -> PyResult<String> {
    let s = dataset_spec(spec, source, &base_dir)?;
    let first: Vec<serde_json::Value> = (0..s.samples.min(5))
        .map(|i| {
            let x = s.sample(i).map_err(err)?;
            let p: serde_json::Map<String, serde_json::Value> = x
                .params
                .iter()
                .map(|(k, v)| (k.clone(), serde_json::to_value(v).unwrap_or_default()))
                .collect();
            Ok(serde_json::json!({ "index": i, "seed": x.seed, "params": p }))
        })
        .collect::<PyResult<_>>()?;
    let plan = serde_json::json!({
        "samples": s.samples, "shards": s.shards(), "shard_size": s.shard_size,
        "fingerprint": s.fingerprint, "outputs": s.output_names, "first_samples": first,
    });
    Ok(plan.to_string())
}

/// Run the shards of part `shard_index` of `shard_count` that are not complete, with `workers`
/// samples at once (None: all cores); returns the run summary as JSON. The GIL is released.
#[pyfunction]
#[pyo3(signature = (spec, source, base_dir, out, shard_index = 0, shard_count = 1, workers = None, verify = true))]
#[allow(clippy::too_many_arguments)]
fn dataset_run_json(
    py: Python<'_>,
    spec: &str,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
    shard_index: u64,
    shard_count: u64,
    workers: Option<usize>,
    verify: bool,
) -> PyResult<String> {
    let s = dataset_spec(spec, source, &base_dir)?;
    let select = camsim::dataset::ShardSelect::parse(&format!("{shard_index}/{shard_count}"))
        .map_err(err)?;
    let summary = py
        .detach(|| camsim::dataset::run(&s, &out, select, workers, verify, &|_, _, _| {}))
        .map_err(err)?;
    serde_json::to_string(&summary).map_err(err)
}

/// Write manifest.jsonl when every shard is complete; returns its path, or None.
#[pyfunction]
fn dataset_gather(
    py: Python<'_>,
    spec: &str,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
) -> PyResult<Option<std::path::PathBuf>> {
    let s = dataset_spec(spec, source, &base_dir)?;
    py.detach(|| camsim::dataset::gather(&s, &out, true))
        .map_err(err)
}

/// Read a raw DNG: dict with `raw` (rows, cols) uint16, `cfa`, `black_level`, `white_level`, `bits`.
#[pyfunction]
fn read_dng<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let (r, _) = py
        .detach(|| camsim::io::dng::read_dng(&path))
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("raw", array(py, &r.dn, &[r.rows, r.cols])?)?;
    d.set_item("cfa", r.cfa_layout().name())?;
    d.set_item("black_level", r.black_level_dn)?;
    d.set_item("white_level", r.white_level_dn)?;
    d.set_item("bits", r.bits)?;
    Ok(d)
}

// --- Image-quality metrics and the two-camera comparison (issue 16) ---

/// A contiguous float32 (rows, cols) array as a Plane.
fn plane_from(a: &PyReadonlyArray2<'_, f32>, what: &str) -> PyResult<Plane> {
    let shape = a.shape().to_vec();
    Plane::new(shape[0], shape[1], a.as_array().iter().copied().collect())
        .map_err(|e| err(format!("{what}: {e}")))
}

/// A (rows, cols, 3) float32 XYZ array as three planes.
fn xyz_planes(a: &PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<[Plane; 3]> {
    let shape = a.shape().to_vec();
    if shape[2] != 3 {
        return Err(err(format!(
            "{what}: shape {shape:?}, expected (rows, cols, 3) CIE XYZ"
        )));
    }
    let v = a.as_array();
    let plane = |c: usize| {
        Plane::new(
            shape[0],
            shape[1],
            v.index_axis(numpy::ndarray::Axis(2), c)
                .iter()
                .copied()
                .collect(),
        )
    };
    Ok([
        plane(0).map_err(err)?,
        plane(1).map_err(err)?,
        plane(2).map_err(err)?,
    ])
}

/// S-CIELAB difference of two (rows, cols, 3) XYZ images: dict with `delta_e` (rows, cols)
/// float32 and `mean`, `p95`, `max`.
#[pyfunction]
#[pyo3(signature = (a_xyz, b_xyz, white_xyz, samples_per_deg, formula = "cie76"))]
fn scielab<'py>(
    py: Python<'py>,
    a_xyz: PyReadonlyArray3<'_, f32>,
    b_xyz: PyReadonlyArray3<'_, f32>,
    white_xyz: [f64; 3],
    samples_per_deg: f64,
    formula: &str,
) -> PyResult<Bound<'py, PyDict>> {
    use camsim::analysis::scielab::{scielab as sc, DeltaEFormula};
    let formula: DeltaEFormula = formula.parse().map_err(err)?;
    let (a, b) = (xyz_planes(&a_xyz, "a_xyz")?, xyz_planes(&b_xyz, "b_xyz")?);
    let r = py
        .detach(|| sc(&a, &b, white_xyz, samples_per_deg, formula))
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item(
        "delta_e",
        array(py, &r.delta_e.data, &[r.delta_e.rows, r.delta_e.cols])?,
    )?;
    d.set_item("mean", r.mean)?;
    d.set_item("p95", r.p95)?;
    d.set_item("max", r.max)?;
    Ok(d)
}

/// Noise power spectrum of a (rows, cols) float32 image: dict with `nps_2d` (n, n), the
/// frequency axes and the radial average (JSON fields of camsim's NpsResult).
#[pyfunction]
#[pyo3(signature = (image, roi = None, roi_px = 64, overlap = 0.5, detrend = "mean"))]
fn nps<'py>(
    py: Python<'py>,
    image: PyReadonlyArray2<'_, f32>,
    roi: Option<(usize, usize, usize, usize)>,
    roi_px: usize,
    overlap: f64,
    detrend: &str,
) -> PyResult<Bound<'py, PyDict>> {
    use camsim::analysis::noise::{nps as n, Detrend, NpsOptions};
    let detrend = match detrend {
        "mean" => Detrend::Mean,
        "plane" => Detrend::Plane,
        o => return Err(err(format!("detrend {o:?}: mean or plane"))),
    };
    let p = plane_from(&image, "image")?;
    let r = py
        .detach(|| {
            n(
                &p,
                rect(roi),
                &NpsOptions {
                    roi_px,
                    overlap,
                    detrend,
                },
            )
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("nps_2d", array(py, &r.nps_2d, &[r.roi_px, r.roi_px])?)?;
    d.set_item("freq_cy_per_px", array1(py, &r.freq_cy_per_px))?;
    d.set_item(
        "radial_freq_cy_per_px",
        array1(py, &r.radial_freq_cy_per_px),
    )?;
    d.set_item("radial_nps", array1(py, &r.radial_nps))?;
    d.set_item("variance", r.variance)?;
    d.set_item("mean", r.mean)?;
    d.set_item("rois", r.rois)?;
    Ok(d)
}

/// SNR (mean / std, and dB) of a (rows, cols) float32 image region, as JSON.
#[pyfunction]
#[pyo3(signature = (image, roi = None))]
fn snr_json(
    image: PyReadonlyArray2<'_, f32>,
    roi: Option<(usize, usize, usize, usize)>,
) -> PyResult<String> {
    let p = plane_from(&image, "image")?;
    let r = camsim::analysis::noise::snr(&p, rect(roi)).map_err(err)?;
    serde_json::to_string(&r).map_err(err)
}

/// CPIQ acutance of an SFR (frequencies in cycles/pixel) at `pixels_per_degree`, as JSON.
#[pyfunction]
fn acutance_json(
    freq_cy_per_px: Vec<f64>,
    sfr: Vec<f64>,
    pixels_per_degree: f64,
) -> PyResult<String> {
    let r = camsim::analysis::acutance::acutance(&freq_cy_per_px, &sfr, pixels_per_degree)
        .map_err(err)?;
    serde_json::to_string(&r).map_err(err)
}

/// Compare two cameras (`camsim compare`); returns results.json's text; writes the report to
/// `out` when given.
#[pyfunction]
#[pyo3(signature = (a, b, out = None, lens_a = "pixel4a", lens_b = "pixel4a", pitch_a_um = None, pitch_b_um = None, size = 128, seed = 1))]
#[allow(clippy::too_many_arguments)]
fn compare_json(
    py: Python<'_>,
    a: &str,
    b: &str,
    out: Option<std::path::PathBuf>,
    lens_a: &str,
    lens_b: &str,
    pitch_a_um: Option<f64>,
    pitch_b_um: Option<f64>,
    size: usize,
    seed: u64,
) -> PyResult<String> {
    use camsim_validate::{CameraCompareOptions, CameraSpec};
    let mut o = CameraCompareOptions::new(
        CameraSpec {
            sensor: a.into(),
            pixel_pitch_um: pitch_a_um,
            lens: lens_a.into(),
        },
        CameraSpec {
            sensor: b.into(),
            pixel_pitch_um: pitch_b_um,
            lens: lens_b.into(),
        },
    );
    o.size_px = size;
    o.seed = seed;
    o.out_dir = out;
    o.command_line = "camsim.compare (Python)".into();
    let r = py
        .detach(|| camsim_validate::compare_cameras(&o, &|_, _, _| {}))
        .map_err(err)?;
    serde_json::to_string(&r).map_err(err)
}

#[pymodule]
fn _camsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CamsimError", m.py().get_type::<CamsimError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PySimulation>()?;
    for f in [
        wrap_pyfunction!(simulate_json, m)?,
        wrap_pyfunction!(config_from_toml, m)?,
        wrap_pyfunction!(config_from_file, m)?,
        wrap_pyfunction!(config_from_json, m)?,
        wrap_pyfunction!(preset_json, m)?,
        wrap_pyfunction!(scene, m)?,
        wrap_pyfunction!(render, m)?,
        wrap_pyfunction!(optics, m)?,
        wrap_pyfunction!(sensor, m)?,
        wrap_pyfunction!(demosaic, m)?,
        wrap_pyfunction!(white_balance_gains, m)?,
        wrap_pyfunction!(illuminant_white_balance_gains, m)?,
        wrap_pyfunction!(fit_ccm, m)?,
        wrap_pyfunction!(macbeth_xyz, m)?,
        wrap_pyfunction!(demosaic_zone_plate_json, m)?,
        wrap_pyfunction!(sfr_json, m)?,
        wrap_pyfunction!(roi_json, m)?,
        wrap_pyfunction!(chart_json, m)?,
        wrap_pyfunction!(fit_qe_json, m)?,
        wrap_pyfunction!(read_dng, m)?,
        wrap_pyfunction!(emva_json, m)?,
        wrap_pyfunction!(emva_series_json, m)?,
        wrap_pyfunction!(dataset_plan_json, m)?,
        wrap_pyfunction!(dataset_run_json, m)?,
        wrap_pyfunction!(dataset_gather, m)?,
        wrap_pyfunction!(scielab, m)?,
        wrap_pyfunction!(nps, m)?,
        wrap_pyfunction!(snr_json, m)?,
        wrap_pyfunction!(acutance_json, m)?,
        wrap_pyfunction!(compare_json, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
