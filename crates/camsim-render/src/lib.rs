//! camsim stage 1 (3D): a spectral Monte Carlo path tracer rendering a
//! [`camsim_scene3d::SceneDescription`] (from the pbrt-v4 reader `camsim-pbrt` or a built-in
//! scene) to spectral radiance (W/(sr m^2 nm)) and depth (m) for the optics stage.
//!
//! Renderer layout (pbrt-v4's split of concepts, one module each): [`math`] (f32 vectors,
//! frames), [`geometry`] (rays, boxes, triangle and sphere tests), [`bvh`] (binned-SAH BVH
//! collapsed to 4 wide, with 4-lane box and triangle-packet tests), [`curve`] (pbrt-v4 curves:
//! ray-facing ribbons by recursive Bezier subdivision), [`sampling`] (warps and
//! pdfs), [`sampler`] (Sobol and independent samplers), [`spectral`] (wavelength sampling, spectrum tables), [`bsdf`] (materials'
//! scattering: diffuse, conductor, dielectric, thin dielectric, diffuse transmission, coated
//! diffuse and coated conductor by pbrt-v4's layered random walk, hair (Chiang et al. 2016), with Fresnel equations and the Trowbridge-Reitz microfacet model), `texture`
//! (texture graphs), `lights` (area, infinite, point, spot, goniometric, projection and distant lights), [`envmap`]
//! (environment maps), `camera` (ray generation for the pinhole, realistic and ray-transfer cameras), `materials` (materials compiled for the
//! tracer, `mix` choice), `integrator` (the path tracer, and in `integrator/volpath.rs` the
//! volumetric path tracer for scenes with participating media), `media` (media compiled for
//! tracing: coefficients, majorants, delta tracking), [`phase`] (the Henyey-Greenstein phase
//! function) and [`render()`] (tiles, passes, film,
//! statistics).
//! The scene contract shared with the pbrt-v4 reader is the `camsim-scene3d` crate.

pub mod bsdf;
pub mod budget;
mod bump;
pub mod bvh;
mod camera;
pub mod curve;
pub mod denoise;
pub mod envmap;
mod error;
mod filter;
pub mod flow;
pub mod geometry;
mod goniometric;
pub mod ids;
mod image_tex;
mod integrator;
pub mod labels;
mod light_bvh;
pub mod light_groups;
mod lights;
mod materials;
pub mod math;
mod media;
mod motion;
pub mod noise;
pub mod phase;
mod projection;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod spectral;
mod spherical_triangle;
mod texture;

// The scene-description modules the tracer reads, under the paths the tracer's modules use.
use camsim_scene3d::{scene, uplift, xform};

pub use ids::IdMaps;
pub use labels::{LabelRequest, Labels};
pub use render::{
    render, render_with, LightSampler, RenderError, RenderOutput, RenderRequest, RenderStats,
};
pub use sampler::SamplerKind;
