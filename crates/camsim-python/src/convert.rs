//! Conversions between Python and camsim: numpy arrays to and from camsim's images, Python
//! values (dicts, lists, numbers) to and from camsim's serde types (through `pythonize`), and
//! camsim's errors as `camsim.CamsimError`. No computation: that is the application layer's.

use camsim::analysis::image::{Plane, Rect};
use camsim::core::image::ImageGeometry;
use camsim::core::{CfaPattern, Quantity, RawImage, SpectralImage, WavelengthGrid};
use camsim::isp::RgbImage;
use camsim::optics::OpticsConfig;
use camsim::pipeline::MosaicFormat;
use camsim::sensor::{Sensor, SensorConfig};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use serde::de::DeserializeOwned;
use serde::Serialize;

create_exception!(
    _camsim,
    CamsimError,
    PyException,
    "An error reported by camsim (bad input, a file it cannot read, ...)."
);

/// A camsim error as `camsim.CamsimError`, with camsim's message.
pub fn err(e: impl std::fmt::Display) -> PyErr {
    CamsimError::new_err(e.to_string())
}

/// A camsim value (any serde type) as plain Python objects: dicts, lists, numbers, strings.
pub fn to_py<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    pythonize::pythonize(py, value).map_err(err)
}

/// A camsim value from plain Python objects; `what` names it in errors.
pub fn from_py<T: DeserializeOwned>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    pythonize::depythonize(obj).map_err(|e| err(format!("{what}: {e}")))
}

/// A JSON value from plain Python objects (for the config door).
pub fn json_of(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<serde_json::Value> {
    from_py(obj, what)
}

/// A 1-D float64 array.
pub fn array1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyAny> {
    PyArray1::from_slice(py, v).into_any()
}

/// A numpy array of `shape` holding a copy of `v`.
pub fn array<'py, T: numpy::Element>(
    py: Python<'py>,
    v: &[T],
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_slice(py, v).reshape(shape)?.into_any())
}

/// Band centres of a spectral image, nm.
pub fn wavelengths(img: &SpectralImage) -> Vec<f64> {
    (0..img.bands())
        .map(|b| img.grid.wavelength_nm(b))
        .collect()
}

/// A wavelength grid from (start, step, count).
pub fn grid(start_nm: f64, step_nm: f64, count: usize) -> PyResult<WavelengthGrid> {
    WavelengthGrid::from_wavelengths(
        &(0..count)
            .map(|i| start_nm + step_nm * i as f64)
            .collect::<Vec<_>>(),
    )
    .map_err(err)
}

/// A spectral image as a dict: `key` -> (bands, rows, cols) float32, `wavelengths_nm`,
/// `spacing_m`, `fov_deg`, `distance_m`, `depth_m` ((rows, cols) or None), `units`.
pub fn spectral_dict<'py>(
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
pub fn spectral_from(
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

/// How a numpy mosaic is read: its Bayer pattern, ADC bits and black level.
pub fn mosaic_format(cfa: &str, bits: u32, black_level: f64) -> PyResult<MosaicFormat> {
    Ok(MosaicFormat {
        cfa: Some(CfaPattern::parse(cfa).map_err(err)?),
        black_dn: black_level,
        bits,
    })
}

/// A (rows, cols) uint16 mosaic as a raw frame.
pub fn raw_from(
    raw: PyReadonlyArray2<'_, u16>,
    cfa: &str,
    bits: u32,
    black_level: f64,
) -> PyResult<RawImage> {
    let shape = raw.shape().to_vec();
    camsim::pipeline::raw_from_mosaic(
        shape[0],
        shape[1],
        raw.as_array().iter().copied().collect(),
        &mosaic_format(cfa, bits, black_level)?,
    )
    .map_err(err)
}

/// The raw's CFA and levels as the stage functions return them: cfa, filters, black_level,
/// white_level, bits.
pub fn raw_layout_items(d: &Bound<'_, PyDict>, r0: &RawImage) -> PyResult<()> {
    let layout = r0.cfa_layout();
    d.set_item("cfa", layout.name())?;
    d.set_item("filters", layout.filters().to_vec())?;
    d.set_item("black_level", r0.black_level_dn)?;
    d.set_item("white_level", r0.white_level_dn)?;
    d.set_item("bits", r0.bits)?;
    Ok(())
}

/// Raw frames stacked as (frames, rows, cols) uint16.
pub fn raw_stack<'py>(py: Python<'py>, frames: &[RawImage]) -> PyResult<Bound<'py, PyAny>> {
    let all: Vec<u16> = frames.iter().flat_map(|r| r.dn.iter().copied()).collect();
    let (rows, cols) = frames.first().map_or((0, 0), |r| (r.rows, r.cols));
    array(py, &all, &[frames.len(), rows, cols])
}

/// A planar RGB image as (rows, cols, 3) float32.
pub fn rgb_to_array<'py>(py: Python<'py>, rgb: &RgbImage) -> PyResult<Bound<'py, PyAny>> {
    let mut out = Vec::with_capacity(rgb.rows * rgb.cols * 3);
    for i in 0..rgb.rows * rgb.cols {
        out.extend_from_slice(&[rgb.r[i], rgb.g[i], rgb.b[i]]);
    }
    array(py, &out, &[rgb.rows, rgb.cols, 3])
}

/// A (rows, cols, 3) float32 array as a planar RGB image.
pub fn rgb_from(rgb: PyReadonlyArray3<'_, f32>) -> PyResult<RgbImage> {
    let shape = rgb.shape();
    if shape[2] != 3 {
        return Err(err(format!(
            "rgb has shape {shape:?}; expected (rows, cols, 3)"
        )));
    }
    let (rows, cols) = (shape[0], shape[1]);
    let mut img = RgbImage::zeros(rows, cols);
    let a = rgb.as_array();
    for y in 0..rows {
        for x in 0..cols {
            let i = y * cols + x;
            (img.r[i], img.g[i], img.b[i]) = (a[[y, x, 0]], a[[y, x, 1]], a[[y, x, 2]]);
        }
    }
    Ok(img)
}

/// A contiguous float32 (rows, cols) array as a Plane.
pub fn plane_from(a: &PyReadonlyArray2<'_, f32>, what: &str) -> PyResult<Plane> {
    let shape = a.shape().to_vec();
    Plane::new(shape[0], shape[1], a.as_array().iter().copied().collect())
        .map_err(|e| err(format!("{what}: {e}")))
}

/// A (rows, cols, 3) float32 XYZ array as three planes.
pub fn xyz_planes(a: &PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<[Plane; 3]> {
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

/// (row, col, rows, cols) as a Rect.
pub fn rect(r: Option<(usize, usize, usize, usize)>) -> Option<Rect> {
    r.map(|(row, col, rows, cols)| Rect::new(row, col, rows, cols))
}

/// A path or preset name given as a string or an `os.PathLike`.
fn spec_string(obj: &Bound<'_, PyAny>) -> PyResult<Option<String>> {
    if let Ok(s) = obj.downcast::<PyString>() {
        return Ok(Some(s.extract::<String>()?));
    }
    let os = obj.py().import("os")?;
    if obj.is_instance(&os.getattr("PathLike")?)? {
        let p = os.call_method1("fspath", (obj,))?;
        return Ok(Some(p.extract::<String>()?));
    }
    Ok(None)
}

/// A lens: a preset name, a lens TOML path, or a dict (the keys of a lens TOML).
pub fn lens_from(lens: &Bound<'_, PyAny>) -> PyResult<OpticsConfig> {
    match spec_string(lens)? {
        Some(s) => camsim::pipeline::load_lens(&s).map_err(err),
        None => from_py(lens, "lens"),
    }
}

/// A sensor: a preset name, a sensor TOML path, or a dict (the keys of a sensor TOML).
pub fn sensor_from(sensor: &Bound<'_, PyAny>) -> PyResult<(Sensor, String)> {
    match spec_string(sensor)? {
        Some(s) => Ok((camsim::pipeline::load_sensor(&s).map_err(err)?, s)),
        None => {
            let c: SensorConfig = from_py(sensor, "sensor")?;
            let s = Sensor::from_config_named(c, "the sensor dict").map_err(err)?;
            Ok((s, "the sensor dict".into()))
        }
    }
}

/// A simulate config: None (the built-in default), a dict, TOML text, or a path (TOML or
/// run.json) — through the config door (`SimulateConfig::from_value`).
pub fn config_from(config: Option<&Bound<'_, PyAny>>) -> PyResult<camsim::SimulateConfig> {
    let Some(config) = config.filter(|c| !c.is_none()) else {
        return Ok(camsim::SimulateConfig::builtin_default());
    };
    let here = std::path::Path::new("");
    if let Ok(text) = config.downcast::<PyString>() {
        let text: String = text.extract()?;
        let text = text.as_str();
        // TOML text has a newline or an `=`; anything else is a path.
        if text.contains('\n') || text.contains('=') {
            return camsim::SimulateConfig::from_toml_str(text, here).map_err(err);
        }
    }
    if let Some(path) = spec_string(config)? {
        return camsim::SimulateConfig::load(std::path::Path::new(&path)).map_err(err);
    }
    if config.downcast::<PyDict>().is_ok() {
        let v = json_of(config, "config")?;
        return camsim::SimulateConfig::from_value(v, here).map_err(err);
    }
    Err(err(format!(
        "config must be a dict, TOML text or a path, not {}",
        config.get_type().name()?
    )))
}
