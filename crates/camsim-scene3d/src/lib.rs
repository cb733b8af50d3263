//! camsim stage 1 (3D): the scene description. What the pbrt-v4 reader (`camsim-pbrt`), the
//! built-in scenes and the TOML overlays produce and what the path tracer (`camsim-render`)
//! consumes: plain data in world space, metres and absolute spectral units.
//!
//! Modules: [`scene`] (the [`SceneDescription`] and what it is made of: shapes, materials,
//! textures, lights, camera, render settings), [`shapes`] (disks, cylinders and Loop subdivision
//! surfaces turned into triangles), [`curves`] (pbrt-v4 curves as cubic Bezier segments),
//! [`xform`] (transform and shape-bounds math), [`camera`] (look-at, focal-length and lens
//! set-ups), [`motion`] (the scene in time: animated transforms, the shutter, what moves),
//! [`envmap`] (environment-map parameterisations), [`daylight`] (the CIE daylight basis), [`media`] (participating media and measured
//! scattering presets),
//! [`transform`] (the 4x4 transform every module shares), [`uplift`] (RGB -> spectrum, Jakob and Hanika 2019), [`spectra`] (photometry) and
//! [`builtin`] (the built-in scenes: the Cornell box and its variants).

pub mod builtin;
pub mod camera;
pub mod curves;
pub mod daylight;
pub mod envmap;
pub mod media;
pub mod motion;
pub mod rgb2spec;
pub mod scene;
pub mod shapes;
pub mod spectra;
pub mod transform;
pub mod uplift;
pub mod xform;

pub use camera::{camera_from_focal_length, look_at_camera_to_world, pbrt_look_at};
pub use scene::*;
