//! camsim analysis: the measurements the paper uses to validate a camera simulation, as a library
//! working on in-memory data (file reading and the `camsim analyze` commands are wired elsewhere).
//!
//! - [`sfr`]: ISO 12233 edge SFR (e-SFR) as in the standard and Burns' `sfrmat`.
//! - [`chart`]: ColorChecker patch regions (ISETCam `chartRectangles`), patch statistics, line profiles.
//! - [`roi`]: mean and standard deviation per CFA channel in rectangles; two-image comparison.
//! - [`qefit`]: photon-counting RGB prediction from a QE and the least-squares QE correction matrix M.
//! - [`emva`]: EMVA 1288 release 4.0 photon-transfer characterization.
//! - [`scielab`]: S-CIELAB (Zhang & Wandell 1997) colour difference of two images at a viewing condition.
//! - [`noise`]: SNR of a uniform region and its noise power spectrum (IEC 62220-1 / ISO 15739 style).
//! - [`acutance`]: SFR weighted by the CPIQ contrast sensitivity at a viewing condition.
//! - [`visual_noise`]: ISO 15739 visual noise of a uniform patch at a viewing condition.
//! - [`glare`]: the veiling glare index on an ISO 18844 target (a black hole in a bright surround).
//! - [`dual_pixel`]: the disparity between a dual-pixel sensor's two photodiode images of an edge.
//!
//! Every result type is `serde::Serialize` so the CLI can write it as JSON or CSV.

// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.

pub mod chart;
pub mod color_difference;
pub mod distortion;
pub mod dual_pixel;
pub mod emva;
pub mod error;
pub mod glare;
pub mod image;
pub mod nnls;
pub mod qefit;
pub mod quality;
pub mod roi;
pub mod sfr;

pub mod acutance;
pub mod noise;
pub mod scielab;
pub mod visual_noise;

pub use color_difference::{cie94, ciede2000, delta_e_uv, xyz_to_lab, xyz_to_luv, Lab};
pub use error::{AnalysisError, Result};
pub use image::{cfa_channel_plane, Plane, Rect};
