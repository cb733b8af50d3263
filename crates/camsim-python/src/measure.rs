//! The measurements from Python, each the application layer's (`camsim::pipeline::measure`) on
//! numpy arrays: SFR, ROI and chart statistics, the QE fit, EMVA 1288 (arrays or a series on
//! disk), demosaicking quality, and the image-quality metrics and two-camera comparison.

use crate::convert::{
    array, array1, err, plane_from, raw_from, rect, sensor_from, to_py, xyz_planes,
};
use camsim::analysis::chart::ChartCorners;
use camsim::analysis::qefit::{fit_qe_matrix, MatrixForm};
use camsim::core::{CfaPattern, RawImage};
use camsim::pipeline::measure::chart::{measure_chart, ChartRequest};
use camsim::pipeline::measure::demosaic::{demosaic_zone_plate as zone_plate, ZonePlateRequest};
use camsim::pipeline::measure::emva::{
    analyze_levels, analyze_series, simulate_series, LevelFrames, SeriesError, SeriesField,
    SeriesRequest,
};
use camsim::pipeline::measure::roi::{measure_roi, RoiRequest};
use camsim::pipeline::measure::sfr::{measure_sfr, SfrImage, SfrRequest};
use camsim::pipeline::{MeasuredImage, MosaicFormat};
use numpy::{PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// ISO 12233 slanted-edge SFR of a raw capture, as `camsim analyze sfr` measures it (one ROI for
/// every curve, found on the whole mosaic when not given; one luminance, Rec. 709): the curve of
/// `channel` ("R", "G", "B" or "luminance"); roi = (row, col, rows, cols).
#[pyfunction]
#[pyo3(signature = (raw, cfa = "RGGB", channel = "G", roi = None, pitch_um = None, bits = 12, black_level = 0.0))]
#[allow(clippy::too_many_arguments)]
fn sfr<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'_, u16>,
    cfa: &str,
    channel: &str,
    roi: Option<(usize, usize, usize, usize)>,
    pitch_um: Option<f64>,
    bits: u32,
    black_level: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let img = SfrImage::Raw(raw_from(raw, cfa, bits, black_level)?);
    let req = SfrRequest {
        roi: rect(roi),
        pixel_pitch_mm: pitch_um.map(|p| p * 1e-3),
        label: "raw".into(),
        ..SfrRequest::default()
    };
    let report = py.detach(|| measure_sfr(&img, &req)).map_err(err)?;
    let curve = report.curve(channel).ok_or_else(|| {
        err(format!(
            "channel {channel:?}: one of {}",
            report
                .curves
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    })?;
    to_py(py, curve)
}

/// Per-channel statistics of raw regions [(row, col, rows, cols), ...].
#[pyfunction]
#[pyo3(signature = (raw, rects, cfa = "RGGB", bits = 12, black_level = 0.0))]
fn roi<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'_, u16>,
    rects: Vec<(usize, usize, usize, usize)>,
    cfa: &str,
    bits: u32,
    black_level: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let img = MeasuredImage::Raw(raw_from(raw, cfa, bits, black_level)?);
    let req = RoiRequest {
        regions: rects.into_iter().map(|r| rect(Some(r)).unwrap()).collect(),
        ..RoiRequest::default()
    };
    let report = measure_roi(&img, None, &req, ["raw", ""]).map_err(err)?;
    to_py(py, &report.a)
}

/// ColorChecker patch statistics (patches 1-24 with their names) of a raw capture, chart
/// corners [x, y] in the order top-left (dark skin), top-right, bottom-right, bottom-left.
#[pyfunction]
#[pyo3(signature = (raw, corners, cfa = "RGGB", fraction = 0.5, bits = 12, black_level = 0.0))]
fn chart<'py>(
    py: Python<'py>,
    raw: PyReadonlyArray2<'_, u16>,
    corners: [[f64; 2]; 4],
    cfa: &str,
    fraction: f64,
    bits: u32,
    black_level: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let img = MeasuredImage::Raw(raw_from(raw, cfa, bits, black_level)?);
    let req = ChartRequest {
        corners: ChartCorners {
            top_left: corners[0],
            top_right: corners[1],
            bottom_right: corners[2],
            bottom_left: corners[3],
        },
        fraction,
    };
    let report = measure_chart(&img, &req, "raw").map_err(err)?;
    to_py(py, &report.patches)
}

/// The 3 x 3 QE correction matrix M (the paper's eq. 2) from measured and predicted channel
/// responses, (n, 3) each; form "unconstrained", "diagonal" or "paper_lower_non_negative".
#[pyfunction]
#[pyo3(signature = (measured, predicted, form = "unconstrained"))]
fn fit_qe<'py>(
    py: Python<'py>,
    measured: Vec<[f64; 3]>,
    predicted: Vec<[f64; 3]>,
    form: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let form: MatrixForm = serde_json::from_value(serde_json::Value::String(form.into()))
        .map_err(|e| err(format!("form {form:?}: {e}")))?;
    to_py(
        py,
        &fit_qe_matrix(&measured, &predicted, form).map_err(err)?,
    )
}

/// EMVA 1288 per colour channel of a raw series: `bright` and `dark` (levels, frames, rows, cols)
/// uint16 (at least 2 frames per level), `exposures_s` per level, optionally the mean photons per
/// pixel per level (for QE and responsivity) and the sensor-plane exposure in lux s per level
/// (for the ISO 12232 speeds, `iso_12232` in each channel's result).
#[pyfunction]
#[pyo3(signature = (bright, dark, exposures_s, photons_per_pixel = None, cfa = "RGGB", bits = 12, black_level = 0.0, fit_max_fraction = 0.7, exposure_lux_s = None))]
#[allow(clippy::too_many_arguments)]
fn emva<'py>(
    py: Python<'py>,
    bright: numpy::PyReadonlyArray4<'_, u16>,
    dark: numpy::PyReadonlyArray4<'_, u16>,
    exposures_s: Vec<f64>,
    photons_per_pixel: Option<Vec<f64>>,
    cfa: &str,
    bits: u32,
    black_level: f64,
    fit_max_fraction: f64,
    exposure_lux_s: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (b, d) = (bright.shape().to_vec(), dark.shape().to_vec());
    if exposure_lux_s
        .as_ref()
        .is_some_and(|p| p.len() != exposures_s.len())
    {
        return Err(err("exposure_lux_s needs one value per level"));
    }
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
    let format = MosaicFormat {
        cfa: Some(CfaPattern::parse(cfa).map_err(err)?),
        black_dn: black_level,
        bits,
    };
    let frames = |a: &numpy::PyReadonlyArray4<'_, u16>, l: usize, s: &[usize]| {
        let v = a.as_array();
        (0..s[1])
            .map(|f| {
                let dn = v
                    .slice(numpy::ndarray::s![l, f, .., ..])
                    .iter()
                    .copied()
                    .collect();
                camsim::pipeline::raw_from_mosaic(s[2], s[3], dn, &format).map_err(err)
            })
            .collect::<PyResult<Vec<RawImage>>>()
    };
    let levels = (0..exposures_s.len())
        .map(|l| {
            Ok(LevelFrames {
                exposure_s: exposures_s[l],
                photons_per_pixel: photons_per_pixel.as_ref().map(|p| p[l]),
                exposure_lux_s: exposure_lux_s.as_ref().map(|p| p[l]),
                bright: frames(&bright, l, &b)?,
                dark: frames(&dark, l, &d)?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let opts = camsim::analysis::emva::EmvaOptions {
        fit_max_fraction,
        ..Default::default()
    };
    let res = py.detach(|| analyze_levels(&levels, &opts)).map_err(err)?;
    to_py(py, &res)
}

/// EMVA 1288 of a series on disk: the series CSV (as `camsim analyze emva` reads it) and its raw
/// frames. Returns the `emva.json` record; with `out` also writes emva.json, ptc.png and snr.png
/// there (the folder must exist).
#[pyfunction]
#[pyo3(signature = (csv, out = None, cfa = None, bits = 16, black_level = 0.0))]
fn emva_series<'py>(
    py: Python<'py>,
    csv: std::path::PathBuf,
    out: Option<std::path::PathBuf>,
    cfa: Option<&str>,
    bits: u32,
    black_level: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let format = MosaicFormat {
        cfa: cfa.map(CfaPattern::parse).transpose().map_err(err)?,
        black_dn: black_level,
        bits,
    };
    let json = py
        .detach(|| -> camsim::Result<serde_json::Value> {
            let series = analyze_series(&csv, format, &Default::default(), &|_, _, _| {})?;
            match &out {
                Some(dir) => series.write_files(dir),
                None => Ok(series.to_json()),
            }
        })
        .map_err(err)?;
    to_py(py, &json)
}

/// The keyword of each EMVA series field (the pipeline names them neutrally).
fn series_keyword(f: SeriesField) -> &'static str {
    match f {
        SeriesField::Levels => "levels",
        SeriesField::FramesPerLevel => "frames_per_level",
        SeriesField::Rows => "rows",
        SeriesField::Cols => "cols",
    }
}

/// A refused EMVA series request, naming this function's keywords.
fn series_err(e: SeriesError) -> PyErr {
    err(e.spelled(series_keyword, "="))
}

/// Simulate an EMVA 1288 photon-transfer series, as `camsim sensor --emva-series` does: flat
/// fields balanced so every channel collects 1e5 e-/s, `levels` exposures from 0 to 1.3 x
/// saturation, `frames_per_level` bright and dark frames each, on a centred `rows` x `cols`
/// window (default 128 x 128 or the sensor). Returns bright and dark (levels, frames, rows, cols)
/// uint16, exposures_s and photons_per_pixel per level, cfa, bits, black_level and
/// analog_offset_mv: what `emva` takes.
#[pyfunction]
#[pyo3(signature = (sensor, levels = 24, frames_per_level = 8, rows = None, cols = None, analog_offset_mv = None, seed = 1))]
#[allow(clippy::too_many_arguments)]
fn emva_simulate<'py>(
    py: Python<'py>,
    sensor: &Bound<'py, PyAny>,
    levels: usize,
    frames_per_level: usize,
    rows: Option<usize>,
    cols: Option<usize>,
    analog_offset_mv: Option<f64>,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let (sensor, _) = sensor_from(sensor)?;
    let req = SeriesRequest {
        levels,
        frames_per_level,
        rows: rows.unwrap_or(128.min(sensor.rows())),
        cols: cols.unwrap_or(128.min(sensor.cols())),
        analog_offset_mv,
        seed,
    };
    req.validate(&sensor).map_err(series_err)?;
    let series = py
        .detach(|| simulate_series(&sensor, &req, &|_, _, _| {}))
        .map_err(|e| match e {
            camsim::Error::Series(e) => series_err(e),
            e => err(e),
        })?;
    let stack = |pick: fn(&camsim::sensor::EmvaLevel) -> &Vec<RawImage>| -> Vec<u16> {
        series
            .levels
            .iter()
            .flat_map(|l| pick(l).iter().flat_map(|r| r.dn.iter().copied()))
            .collect()
    };
    let shape = [series.levels.len(), frames_per_level, req.rows, req.cols];
    let first = &series.levels[0].bright[0];
    let d = PyDict::new(py);
    d.set_item("bright", array(py, &stack(|l| &l.bright), &shape)?)?;
    d.set_item("dark", array(py, &stack(|l| &l.dark), &shape)?)?;
    let per_level = |f: fn(&camsim::sensor::EmvaLevel) -> f64| -> Vec<f64> {
        series.levels.iter().map(f).collect()
    };
    d.set_item("exposures_s", per_level(|l| l.exposure_s))?;
    d.set_item("photons_per_pixel", per_level(|l| l.photons_per_pixel))?;
    d.set_item("exposure_lux_s", per_level(|l| l.exposure_lux_s))?;
    d.set_item("cfa", first.cfa_layout().name())?;
    d.set_item("bits", first.bits)?;
    d.set_item("black_level", first.black_level_dn)?;
    d.set_item("analog_offset_mv", series.analog_offset_mv)?;
    Ok(d)
}

/// Every demosaicking method on a gray zone plate of side `size` reaching `f_max` cycles/pixel at
/// the edge, sampled by a `cfa` mosaic: {method: {frequency_cy_per_px, mtf, mtf50_cy_per_px,
/// false_colour_low_rms, false_colour_rms}}.
#[pyfunction]
#[pyo3(signature = (size = 512, f_max = 0.5, cfa = "RGGB"))]
fn demosaic_zone_plate<'py>(
    py: Python<'py>,
    size: usize,
    f_max: f64,
    cfa: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let req = ZonePlateRequest {
        size_px: size,
        f_max_cyc_per_px: f_max,
        cfa: CfaPattern::parse(cfa).map_err(err)?,
    };
    let report = py.detach(|| zone_plate(&req)).map_err(err)?;
    let d = PyDict::new(py);
    for (m, q) in &report.methods {
        d.set_item(m.name(), to_py(py, q)?)?;
    }
    Ok(d)
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
/// frequency axes and the radial average.
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

/// SNR (mean / std, and dB) of a (rows, cols) float32 image region.
#[pyfunction]
#[pyo3(signature = (image, roi = None))]
fn snr<'py>(
    py: Python<'py>,
    image: PyReadonlyArray2<'_, f32>,
    roi: Option<(usize, usize, usize, usize)>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = plane_from(&image, "image")?;
    to_py(
        py,
        &camsim::analysis::noise::snr(&p, rect(roi)).map_err(err)?,
    )
}

/// ISO 15739 visual noise of a uniform patch of a (rows, cols, 3) float32 sRGB picture (code
/// values in [0, 1], or linear sRGB with `encoding = "linear"`), the same measurement as
/// `camsim analyze visual-noise`.
#[pyfunction]
#[pyo3(signature = (rgb, region = None, pixels_per_degree = None, display_height_m = 0.1, viewing_distance_m = 0.4, encoding = "srgb"))]
fn visual_noise<'py>(
    py: Python<'py>,
    rgb: PyReadonlyArray3<'_, f32>,
    region: Option<(usize, usize, usize, usize)>,
    pixels_per_degree: Option<f64>,
    display_height_m: f64,
    viewing_distance_m: f64,
    encoding: &str,
) -> PyResult<Bound<'py, PyAny>> {
    use camsim::pipeline::measure::visual_noise::{
        measure_visual_noise, DisplayImage, Viewing, VisualNoiseRequest,
    };
    let code_values = match encoding {
        "srgb" => true,
        "linear" => false,
        o => return Err(err(format!("encoding {o:?}: srgb or linear"))),
    };
    let image = DisplayImage {
        planes: xyz_planes(&rgb, "rgb")?,
        code_values,
    };
    let req = VisualNoiseRequest {
        regions: rect(region).into_iter().collect(),
        viewing: match pixels_per_degree {
            Some(p) => Viewing::PixelsPerDegree(p),
            None => Viewing::Picture {
                display_height_m,
                viewing_distance_m,
            },
        },
    };
    let mut report = py
        .detach(|| measure_visual_noise(&image, &req))
        .map_err(err)?;
    to_py(py, &report.patches.remove(0))
}

/// CPIQ acutance of an SFR (frequencies in cycles/pixel) at `pixels_per_degree`.
#[pyfunction]
fn acutance<'py>(
    py: Python<'py>,
    freq_cy_per_px: Vec<f64>,
    sfr: Vec<f64>,
    pixels_per_degree: f64,
) -> PyResult<Bound<'py, PyAny>> {
    to_py(
        py,
        &camsim::analysis::acutance::acutance(&freq_cy_per_px, &sfr, pixels_per_degree)
            .map_err(err)?,
    )
}

/// Compare two cameras (`camsim compare`); returns results.json as a dict; writes the report to
/// `out` when given.
#[pyfunction]
#[pyo3(signature = (a, b, out = None, lens_a = "pixel4a", lens_b = "pixel4a", pitch_a_um = None, pitch_b_um = None, size = 128, seed = 1))]
#[allow(clippy::too_many_arguments)]
fn compare<'py>(
    py: Python<'py>,
    a: &str,
    b: &str,
    out: Option<std::path::PathBuf>,
    lens_a: &str,
    lens_b: &str,
    pitch_a_um: Option<f64>,
    pitch_b_um: Option<f64>,
    size: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    use camsim::validate::{CameraCompareOptions, CameraSpec};
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
        .detach(|| camsim::validate::compare_cameras(&o, &|_, _, _| {}))
        .map_err(err)?;
    to_py(py, &r)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    for f in [
        wrap_pyfunction!(sfr, m)?,
        wrap_pyfunction!(roi, m)?,
        wrap_pyfunction!(chart, m)?,
        wrap_pyfunction!(fit_qe, m)?,
        wrap_pyfunction!(emva, m)?,
        wrap_pyfunction!(emva_series, m)?,
        wrap_pyfunction!(emva_simulate, m)?,
        wrap_pyfunction!(demosaic_zone_plate, m)?,
        wrap_pyfunction!(scielab, m)?,
        wrap_pyfunction!(visual_noise, m)?,
        wrap_pyfunction!(nps, m)?,
        wrap_pyfunction!(snr, m)?,
        wrap_pyfunction!(acutance, m)?,
        wrap_pyfunction!(compare, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
