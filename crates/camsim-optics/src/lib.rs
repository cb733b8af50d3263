//! camsim stage 2: radiance -> sensor irradiance (f-number, cos4, OTF/PSF, wavefront, defocus, shading).
//!
//! The model is ISETCam's (`oiCompute` with a `wvf` wavefront, Lyu et al. "Optics modeling"):
//! irradiance from radiance with the camera equation, cos^4 or fitted lens shading, then a blur per
//! wavelength by the PSF of a pupil with a Zernike wavefront aberration, optionally depth-dependent
//! defocus from thin-lens geometry.
//!
//! - [`Optics`] (from an [`OpticsConfig`] or a preset) does the whole stage: [`Optics::compute`].
//! - [`Wavefront`] computes PSFs and MTFs; [`lens`] holds the closed forms (diffraction MTF, thin
//!   lens, defocus); [`zernike`] the OSA polynomials; [`shading`] the flat-field fit.
//! - [`shift_variant`]: PSFs per field height, rotated and interpolated per image block
//!   (`blur = { method = "shift-variant" }`), from field-dependent Zernike terms or a traced lens
//!   ([`traced`]: optical path difference fitted with Zernike terms, distortion, relative illumination).

pub mod aperture;
pub mod config;
pub mod conv;
pub mod error;
pub mod flare;
pub mod glare;
pub mod image_map;
pub mod lens;
pub mod lens_maps;
pub mod measured_psf;
pub mod mtf_fit;
pub mod olpf;
pub mod optics;
pub mod presets;
pub mod psf;
pub mod rtf_psf;
pub mod shading;
pub mod shift_variant;
mod sv_blocks;
pub mod tail;
pub mod traced;
pub mod wavefront;
pub mod zernike;

pub use aperture::Aperture;
pub use config::OpticsConfig;
pub use error::{OpticsError, Result};
pub use flare::PupilFlare;
pub use glare::{GlarePlan, GlareSpread};
pub use image_map::ImageMap;
pub use lens::diffraction_mtf;
pub use mtf_fit::{fit_mtf, MtfFit, MtfFitOptions, SystemMtfModel};
pub use optics::{DepthLayers, Optics, ShadingModel};
pub use psf::{MtfCurve, Psf};
pub use shading::{fit_flat_field, ShadingFit};
pub use wavefront::Wavefront;
pub use zernike::osa_to_nm;
