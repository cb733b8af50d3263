//! camsim-assets's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod bad_input;
mod gltf_animation;
mod gltf_attributes;
mod gltf_units;
mod obj_tangents;
mod obj_transparency;
mod obj_vertex_colors;
mod trimesh_models;
