//! Datasets from Python (`camsim.dataset`): a spec given as a dict or as TOML text (read from a
//! file by the Python layer), its plan, a run of some shards, and the manifest.

use crate::convert::{err, json_of, to_py};
use camsim::dataset::DatasetSpec;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

/// A dataset spec from a dict or TOML text, relative paths against `base_dir`, checked completely.
fn spec_of(
    spec: &Bound<'_, PyAny>,
    source: &str,
    base_dir: &std::path::Path,
) -> PyResult<DatasetSpec> {
    let text = match spec.downcast::<PyString>() {
        Ok(s) => s.extract::<String>()?,
        // A dict: its JSON text (the spec reader takes JSON as well as TOML).
        Err(_) => json_of(spec, source)?.to_string(),
    };
    DatasetSpec::from_toml_str(&text, source, base_dir).map_err(err)
}

/// Check a dataset spec and return its plan: samples, shards, shard size, fingerprint, outputs
/// and the first samples' parameters.
#[pyfunction]
fn dataset_plan<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    source: &str,
    base_dir: std::path::PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let s = spec_of(spec, source, &base_dir)?;
    let first = pyo3::types::PyList::empty(py);
    for i in 0..s.samples.min(5) {
        let x = s.sample(i).map_err(err)?;
        let p = PyDict::new(py);
        for (k, v) in &x.params {
            p.set_item(k, to_py(py, v)?)?;
        }
        let d = PyDict::new(py);
        d.set_item("index", i)?;
        d.set_item("seed", x.seed)?;
        d.set_item("params", p)?;
        first.append(d)?;
    }
    let plan = PyDict::new(py);
    plan.set_item("samples", s.samples)?;
    plan.set_item("shards", s.shards())?;
    plan.set_item("shard_size", s.shard_size)?;
    plan.set_item("fingerprint", &s.fingerprint)?;
    plan.set_item("outputs", s.output_names.clone())?;
    plan.set_item("first_samples", first)?;
    Ok(plan)
}

/// Run the shards of part `shard_index` of `shard_count` that are not complete, with `workers`
/// samples at once (None: all cores); returns the run summary. The GIL is released.
#[pyfunction]
#[pyo3(signature = (spec, source, base_dir, out, shard_index = 0, shard_count = 1, workers = None, verify = true))]
#[allow(clippy::too_many_arguments)]
fn dataset_run<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
    shard_index: u64,
    shard_count: u64,
    workers: Option<usize>,
    verify: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let s = spec_of(spec, source, &base_dir)?;
    let select = camsim::dataset::ShardSelect::parse(&format!("{shard_index}/{shard_count}"))
        .map_err(err)?;
    let summary = py
        .detach(|| camsim::dataset::run(&s, &out, select, workers, verify, &|_, _, _| {}))
        .map_err(err)?;
    to_py(py, &summary)
}

/// Write manifest.jsonl when every shard is complete; returns its path, or None.
#[pyfunction]
fn dataset_gather(
    py: Python<'_>,
    spec: &Bound<'_, PyAny>,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
) -> PyResult<Option<std::path::PathBuf>> {
    let s = spec_of(spec, source, &base_dir)?;
    py.detach(|| camsim::dataset::gather(&s, &out, true))
        .map_err(err)
}

/// Export a complete dataset as COCO (`out/coco/annotations.json`, `out/coco/images/`);
/// `categories` is "material", "object" or "category". Returns the annotation file's path.
#[pyfunction]
fn dataset_coco(
    py: Python<'_>,
    spec: &Bound<'_, PyAny>,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
    categories: &str,
) -> PyResult<std::path::PathBuf> {
    let s = spec_of(spec, source, &base_dir)?;
    let by = camsim::dataset::CategoryBy::parse(categories).map_err(err)?;
    py.detach(|| camsim::dataset::export_coco(&s, &out, by))
        .map_err(err)
}

/// Export a complete composed dataset in the BOP format (`out/bop/`: models, camera.json,
/// train_pbr scenes with poses, visible masks and depth). Returns the folder.
#[pyfunction]
fn dataset_bop(
    py: Python<'_>,
    spec: &Bound<'_, PyAny>,
    source: &str,
    base_dir: std::path::PathBuf,
    out: std::path::PathBuf,
) -> PyResult<std::path::PathBuf> {
    let s = spec_of(spec, source, &base_dir)?;
    py.detach(|| camsim::dataset::export_bop(&s, &out))
        .map_err(err)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dataset_plan, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_run, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_gather, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_coco, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_bop, m)?)?;
    Ok(())
}
