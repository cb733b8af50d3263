//! Photometry of a spectrum as pbrt-v4 computes it (`SpectrumToPhotometric`), used to set
//! lights by luminance.

use camsim_core::{tables, Spectrum};
use std::sync::OnceLock;

fn y_bar_1nm() -> &'static Vec<f64> {
    static Y: OnceLock<Vec<f64>> = OnceLock::new();
    Y.get_or_init(|| {
        let [_, y, _] = tables::cie1931_xyz_cmfs();
        (360..=830).map(|l| y.eval(l as f64)).collect()
    })
}

/// pbrt-v4 `SpectrumToPhotometric` for a plain spectrum: `sum_{360..830} y_bar s` at 1 nm.
pub fn photometric(s: &Spectrum) -> f64 {
    y_bar_1nm()
        .iter()
        .enumerate()
        .map(|(i, y)| y * s.eval(360.0 + i as f64))
        .sum()
}
