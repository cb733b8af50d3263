//! camsim lens prescriptions and ray tracing.
//!
//! - [`Lens`] ([`prescription`]): surfaces read from ISET3d lens JSON or pbrt-v4 `realistic` lens
//!   files, checked (one stop, finite values, surfaces that do not cross);
//! - [`trace`]: sequential real-ray tracing through spherical, conic and even-asphere surfaces
//!   (vector Snell refraction, semi-apertures block), forward from object space or backward from
//!   the film, and the paraxial ABCD matrix with effective focal length and back focal distance;
//! - [`LensCamera`] ([`camera`]): a lens with its film plane, focused, tracing rays from the film
//!   out through the lens with exit-pupil bounds per film radius (the API a renderer's realistic
//!   camera calls) and the relative illumination of a traced prescription;
//! - [`ghost`]: two-bounce ghost paths (reflections between surfaces), coating reflectances and
//!   collimated ghost bundles traced to the film (Hullin et al. 2011);
//! - [`glass`]: constant or dispersive (n_d, V_d) media;
//! - [`rtf`]: ray-transfer functions (Goossens et al. 2022) and the relative illumination they
//!   imply, with a reader for Zemax relative-illumination exports.
//!
//! A crate of its own (depending on no other camsim crate): it is geometry and file formats that
//! both the wavefront optics stage and the renderer's camera can use without pulling in each
//! other or the FFT stack.

pub mod camera;
pub mod error;
pub mod ghost;
pub mod glass;
pub mod prescription;
pub mod rtf;
pub mod trace;

pub use camera::LensCamera;
pub use error::{LensError, Result};
pub use ghost::{Bundle, Coating, GhostPath};
pub use glass::Medium;
pub use prescription::{Lens, Surface};
pub use rtf::Rtf;
pub use trace::{Blocked, Paraxial, Ray, TracedPath};
