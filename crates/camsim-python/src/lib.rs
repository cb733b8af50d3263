//! The compiled part of the `camsim` Python package (`camsim._camsim`): a door to camsim's
//! application layer (the `camsim` facade). It converts Python values and numpy arrays to camsim's
//! types and back ([`convert`]), calls one function of the application layer, and returns numpy
//! arrays, a typed [`simulate::PySimulation`] or dicts built here: no recipe is computed in this
//! crate, and nothing crosses as JSON text.
//!
//! - [`simulate`]: the whole pipeline, configs and presets, the catalogue of names.
//! - [`stages`]: each stage alone on arrays, the ISP, reading a DNG.
//! - [`measure`]: the measurements and metrics.
//! - [`dataset`]: datasets (plan, run, manifest).
//!
//! Every function releases the GIL while it computes; every camsim error becomes a
//! `camsim.CamsimError` carrying camsim's message (a panic becomes a Python exception too).

mod convert;
mod dataset;
mod measure;
mod simulate;
mod stages;

use pyo3::prelude::*;

#[pymodule]
fn _camsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CamsimError", m.py().get_type::<convert::CamsimError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    simulate::register(m)?;
    stages::register(m)?;
    measure::register(m)?;
    dataset::register(m)?;
    Ok(())
}
