//! Each stage alone on numpy arrays: scene, render, optics, sensor (with the application layer's
//! `SensorOverrides` and `capture`), and the ISP (the application layer's `Isp`, and its parts:
//! demosaic, white balance, colour-matrix fit), plus reading a DNG.

use crate::convert::{
    array, err, grid, lens_from, raw_from, raw_layout_items, raw_stack, rgb_from, rgb_to_array,
    sensor_from, spectral_dict, spectral_from, to_py,
};
use camsim::core::image::ImageGeometry;
use camsim::core::{Quantity, WavelengthGrid};
use camsim::optics::Optics;
use camsim::pipeline::capture::{capture, CaptureRequest, Captured, PYTHON_KEYS};
use camsim::pipeline::render::{render_scene, request_scene, RenderRequest};
use camsim::sensor::NoiseSwitches;
use camsim::{Isp, SensorOverrides};
use numpy::{PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

/// Stage 1, a 2D chart: a `[scene]` table as a dict, or a kind name alone (every default), on the
/// wavelength grid (start_nm, step_nm, count) -> dict with `radiance`.
#[pyfunction]
#[pyo3(signature = (config, start_nm = 400.0, step_nm = 10.0, count = 31))]
fn scene<'py>(
    py: Python<'py>,
    config: &Bound<'py, PyAny>,
    start_nm: f64,
    step_nm: f64,
    count: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg = match config.downcast::<PyString>() {
        Ok(kind) => {
            camsim::pipeline::scene::default_scene(&kind.extract::<String>()?)
                .map_err(err)?
                .0
        }
        Err(_) => crate::convert::from_py(config, "scene")?,
    };
    let grid = grid(start_nm, step_nm, count)?;
    let img = py
        .detach(|| camsim::scene::create(&cfg, &grid).map_err(|e| e.to_string()))
        .map_err(err)?;
    spectral_dict(py, &img, "radiance")
}

/// Stage 1, a 3D scene: a built-in scene or a pbrt-v4 file, path traced -> dict with `radiance`,
/// `depth_m`, `object_id` and `material_id` ((rows, cols) uint32: 1 + index of the shape and of
/// its material met first through each pixel centre, 0 = none) and `ids_legend` (their names).
/// `adaptive_error` (e.g. 0.05) stops each pixel once the relative standard error of its
/// luminance is below it (`samples_per_pixel` is then the most a pixel takes, `min_samples` the
/// fewest, default 32); the dict then also has `samples_per_pixel` ((rows, cols) uint32).
/// `denoise` runs Intel Open Image Denoise on the film (`$CAMSIM_OIDN_LIBRARY`).
#[pyfunction]
#[pyo3(signature = (builtin = None, pbrt = None, resolution = None, samples_per_pixel = None, seed = 1, start_nm = 400.0, step_nm = 10.0, count = 31, adaptive_error = None, min_samples = None, denoise = false))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    builtin: Option<String>,
    pbrt: Option<std::path::PathBuf>,
    resolution: Option<(usize, usize)>,
    samples_per_pixel: Option<u32>,
    seed: u64,
    start_nm: f64,
    step_nm: f64,
    count: usize,
    adaptive_error: Option<f64>,
    min_samples: Option<u32>,
    denoise: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let req = RenderRequest {
        builtin,
        pbrt,
        samples_per_pixel,
        resolution,
        adaptive_error,
        min_samples,
        denoise,
        seed: Some(seed),
        grid: grid(start_nm, step_nm, count)?,
        ..RenderRequest::default()
    };
    let out = py
        .detach(|| -> camsim::Result<camsim::render::RenderOutput> {
            render_scene(&request_scene(&req)?, &|_, _, _| {})
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
    d.set_item("ids_legend", to_py(py, &ids.legend())?)?;
    if req.adaptive_error.is_some() {
        d.set_item(
            "samples_per_pixel",
            array(py, &out.samples_per_pixel, &[ids.height, ids.width])?,
        )?;
    }
    Ok(d)
}

/// Stage 2: radiance (bands, rows, cols) -> dict with `irradiance`.
#[pyfunction]
#[pyo3(signature = (radiance, wavelengths_nm, lens, spacing_m = 0.0, distance_m = 0.0, fov_deg = 0.0, depth_m = None))]
#[allow(clippy::too_many_arguments)]
fn optics<'py>(
    py: Python<'py>,
    radiance: PyReadonlyArray3<'_, f32>,
    wavelengths_nm: Vec<f64>,
    lens: &Bound<'py, PyAny>,
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

/// Stage 3: irradiance (bands, rows, cols) -> dict with `raw` (frames, rows, cols) uint16: the
/// application layer's capture (one exposure, a bracket, or both readouts of an HDR sensor) of
/// the sensor with the overrides (window, ISO, CFA, noise).
#[pyfunction]
#[pyo3(signature = (irradiance, wavelengths_nm, spacing_m, sensor, exposure_s = None, seed = 1, frames = 1, rows = None, cols = None, exposures_s = None, iso = None, cfa = None, noise = true))]
#[allow(clippy::too_many_arguments)]
fn sensor<'py>(
    py: Python<'py>,
    irradiance: PyReadonlyArray3<'_, f32>,
    wavelengths_nm: Vec<f64>,
    spacing_m: f64,
    sensor: &Bound<'py, PyAny>,
    exposure_s: Option<f64>,
    seed: u64,
    frames: usize,
    rows: Option<usize>,
    cols: Option<usize>,
    exposures_s: Option<Vec<f64>>,
    iso: Option<f64>,
    cfa: Option<String>,
    noise: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let img = spectral_from(
        irradiance,
        wavelengths_nm,
        spacing_m,
        Quantity::Irradiance,
        ImageGeometry::default(),
    )?;
    let (s, name) = sensor_from(sensor)?;
    let overrides = SensorOverrides {
        rows,
        cols,
        iso,
        cfa,
        noise: (!noise).then(NoiseSwitches::none),
    };
    let s = overrides.apply(s, &name).map_err(err)?;
    let request = CaptureRequest::new(
        exposure_s,
        exposures_s.as_deref(),
        0.9,
        frames,
        seed,
        PYTHON_KEYS,
    )
    .map_err(err)?;
    let captured = py.detach(|| capture(&s, &img, &request)).map_err(err)?;
    let d = PyDict::new(py);
    match &captured {
        Captured::Hdr(h) => {
            // An [hdr] sensor (dual conversion gain / split pixel): both readouts and the merge.
            let r0 = &h.high[0];
            let merged: Vec<f32> = h.merged_e.iter().flat_map(|m| m.iter().copied()).collect();
            d.set_item("raw", raw_stack(py, &h.high)?)?;
            d.set_item("raw_low", raw_stack(py, &h.low)?)?;
            d.set_item(
                "merged_e",
                array(py, &merged, &[h.high.len(), r0.rows, r0.cols])?,
            )?;
            d.set_item("hdr_mode", to_py(py, &h.model.mode)?)?;
            d.set_item("dynamic_range_db", h.model.dynamic_range_db())?;
            raw_layout_items(&d, r0)?;
            d.set_item("exposure_s", h.exposure_s)?;
        }
        Captured::Frames(f) => {
            d.set_item("raw", raw_stack(py, &f.raw)?)?;
            raw_layout_items(&d, &f.raw[0])?;
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
        }
    }
    Ok(d)
}

/// Demosaic of a raw mosaic (rows, cols) uint16 -> (rows, cols, 3) float32 DN (black level
/// subtracted); `method` a name of `camsim.presets.names()["demosaic methods"]`.
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

/// The whole ISP (the application layer's `Isp`, as `camsim isp` and `camsim simulate` run it)
/// on a raw mosaic made by `sensor`, under the scene `illuminant`: returns (preview (rows, cols,
/// 3) uint8, report dict: the white-balance gains and the colour matrix).
#[pyfunction]
#[pyo3(signature = (raw, sensor, cfa = "RGGB", bits = 12, black_level = 0.0, illuminant = "D65", demosaic = "bilinear", white_balance = "illuminant", steps_json = None, exposure_scale = None))]
#[allow(clippy::too_many_arguments)]
fn isp<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'_, u16>,
    sensor: &Bound<'py, PyAny>,
    cfa: &str,
    bits: u32,
    black_level: f64,
    illuminant: &str,
    demosaic: &str,
    white_balance: &str,
    steps_json: Option<&str>,
    exposure_scale: Option<f64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let img = raw_from(raw, cfa, bits, black_level)?;
    let (s, _) = sensor_from(sensor)?;
    let illum = camsim::scene::load_illuminant(illuminant, "illuminant").map_err(err)?;
    let mut p = Isp::new(illum, WavelengthGrid::default());
    if let Some(j) = steps_json {
        // The keys of a simulate config's [isp] table, checked as the config reader checks them.
        let section: camsim::pipeline::config::IspSection =
            serde_json::from_str(j).map_err(|e| err(format!("steps: {e}")))?;
        p = p.with_section(&section).map_err(err)?;
    }
    p.demosaic = demosaic.parse().map_err(err)?;
    p.white_balance = white_balance.parse().map_err(err)?;
    p.exposure_scale = checked_scale(exposure_scale)?;
    let out = py.detach(|| p.compute(&img, &s)).map_err(err)?;
    let v = &out.preview;
    Ok((
        array(py, &v.data, &[v.rows, v.cols, 3])?,
        to_py(py, &out.report)?,
    ))
}

/// An `exposure_scale` argument: None, or a finite number > 0.
fn checked_scale(scale: Option<f64>) -> PyResult<Option<f64>> {
    match scale {
        Some(k) if !(k > 0.0 && k.is_finite()) => {
            Err(err(format!("exposure_scale {k} is not > 0")))
        }
        s => Ok(s),
    }
}

/// The inverse ISP of an 8-bit sRGB photo (rows, cols, 3) uint8 (`Isp::unprocess_photo`, as
/// `camsim unprocess` runs it): a dict with `raw` (rows, cols) uint16 of `sensor` with its
/// temporal noise, its layout (cfa, black_level, white_level, bits) and the `exposure_scale` that
/// renders it back through `isp`.
#[pyfunction]
#[pyo3(signature = (photo, sensor, illuminant = "D65", white_balance = "illuminant", tone_map = "clip", exposure_scale = None, exposure_s = 0.01, seed = 0))]
#[allow(clippy::too_many_arguments)]
fn unprocess<'py>(
    py: Python<'py>,
    photo: PyReadonlyArray3<'_, u8>,
    sensor: &Bound<'py, PyAny>,
    illuminant: &str,
    white_balance: &str,
    tone_map: &str,
    exposure_scale: Option<f64>,
    exposure_s: f64,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let a = photo.as_array();
    let (rows, cols, channels) = a.dim();
    if channels != 3 {
        return Err(err(format!(
            "photo: shape ({rows}, {cols}, {channels}); give (rows, cols, 3) uint8 sRGB"
        )));
    }
    let image = camsim::Rgb8Image {
        rows,
        cols,
        data: a.iter().copied().collect(),
    };
    let (s, _) = sensor_from(sensor)?;
    let illum = camsim::scene::load_illuminant(illuminant, "illuminant").map_err(err)?;
    let mut p = Isp::new(illum, WavelengthGrid::default());
    p.white_balance = white_balance.parse().map_err(err)?;
    p.tone_map = serde_json::from_value(serde_json::Value::String(tone_map.into()))
        .map_err(|_| err(format!("tone_map '{tone_map}': give clip or filmic")))?;
    p.exposure_scale = checked_scale(exposure_scale)?;
    if !(exposure_s > 0.0 && exposure_s.is_finite()) {
        return Err(err(format!("exposure_s {exposure_s} is not > 0")));
    }
    let (raw, inverse) = py
        .detach(|| p.unprocess_photo(&image, &s, exposure_s, seed))
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("raw", array(py, &raw.dn, &[raw.rows, raw.cols])?)?;
    raw_layout_items(&d, &raw)?;
    d.set_item("exposure_scale", inverse.exposure_scale)?;
    Ok(d)
}

/// White-balance gains (green = 1) of a linear RGB image (rows, cols, 3) by `method` (the ISP's
/// `Isp::white_balance_gains`): gray-world, white-patch (pixels at or above the `percentile` of
/// R+G+B, those with a channel at or above `saturation` left out), none, or illuminant (the
/// camera response of `sensor` to a perfect white under `illuminant`, inverted).
#[pyfunction]
#[pyo3(signature = (rgb, method, percentile, saturation, illuminant, sensor))]
fn white_balance_gains(
    rgb: PyReadonlyArray3<'_, f32>,
    method: &str,
    percentile: f64,
    saturation: Option<f64>,
    illuminant: &str,
    sensor: &Bound<'_, PyAny>,
) -> PyResult<Vec<f64>> {
    let img = rgb_from(rgb)?;
    let illum = camsim::scene::load_illuminant(illuminant, "illuminant").map_err(err)?;
    let mut p = Isp::new(illum, WavelengthGrid::default());
    p.white_balance = method.parse().map_err(err)?;
    p.white_patch_percentile = percentile;
    let s = match p.white_balance {
        camsim::isp::WhiteBalanceMethod::Illuminant => Some(sensor_from(sensor)?.0),
        _ => None,
    };
    Ok(p.white_balance_gains(&img, s.as_ref(), saturation)
        .map_err(err)?
        .to_vec())
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

/// XYZ of the 24 ColorChecker patches under a built-in illuminant (white Y = 1) and the white's XYZ.
#[pyfunction]
#[pyo3(signature = (illuminant = "D65"))]
fn macbeth_xyz(illuminant: &str) -> PyResult<(Vec<[f64; 3]>, [f64; 3])> {
    let illum = camsim::core::tables::illuminant(illuminant).map_err(err)?;
    camsim::isp::ccm::macbeth_xyz(&illum, &WavelengthGrid::default()).map_err(err)
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

/// The channels of an OpenEXR file: a dict name -> (rows, cols) float32 array.
#[pyfunction]
fn read_exr_channels<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let (rows, cols, chans) = py
        .detach(|| camsim::io::exr::read_channels_exr(&path))
        .map_err(err)?;
    let d = PyDict::new(py);
    for (name, data) in chans {
        d.set_item(name, array(py, &data, &[rows, cols])?)?;
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    for f in [
        wrap_pyfunction!(scene, m)?,
        wrap_pyfunction!(render, m)?,
        wrap_pyfunction!(optics, m)?,
        wrap_pyfunction!(sensor, m)?,
        wrap_pyfunction!(demosaic, m)?,
        wrap_pyfunction!(isp, m)?,
        wrap_pyfunction!(unprocess, m)?,
        wrap_pyfunction!(white_balance_gains, m)?,
        wrap_pyfunction!(fit_ccm, m)?,
        wrap_pyfunction!(macbeth_xyz, m)?,
        wrap_pyfunction!(read_dng, m)?,
        wrap_pyfunction!(read_exr_channels, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
