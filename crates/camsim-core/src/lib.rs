//! camsim-core: the types every stage of the pipeline exchanges.
//!
//! Light flows one way through camsim: `scene` (spectral radiance) -> `optics` (spectral irradiance)
//! -> `sensor` (raw digital values) -> `isp`. The stages hand each other a [`SpectralImage`]
//! (band-sequential f32 planes with their [`WavelengthGrid`], sample spacing and [`Quantity`]) and
//! a [`RawImage`] (a CFA mosaic of digital values). This crate holds those types, the
//! physical constants and unit conversions, the built-in spectral tables, spectrum files (CSV and
//! ISETCam MATLAB v5) and keyed random streams that make output independent of thread count.

pub mod cfa;
pub mod colorimetry;
pub mod csv_records;
pub mod error;
pub mod grid;
pub mod image;
pub mod mat;
pub mod math;
pub mod mem;
pub mod names;
pub mod raw;
pub mod rng;
pub mod spectra_table;
pub mod spectrum;
pub mod spectrum_csv;
pub mod tables;
pub mod units;

pub use cfa::{CfaChannel, CfaLayout, CfaPattern};
pub use error::CoreError;
pub use grid::WavelengthGrid;
pub use image::{Quantity, SpectralImage};
pub use names::{NameTable, Named};
pub use raw::RawImage;
pub use spectrum::Spectrum;
