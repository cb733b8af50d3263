//! camsim-validate's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod cameras;
mod compare;
mod cycles_references;
mod pbrt_references;
mod quick;
mod silver_reference;
mod zone_plate_compare;
