//! Spectra as CSV (placeholder).
