//! camsim stage 1 (3D): a spectral Monte Carlo path tracer and a pbrt-v4 scene reader, producing
//! spectral radiance (W/(sr m^2 nm)) and depth (m) for the optics stage.

pub mod scene;

pub use scene::*;
