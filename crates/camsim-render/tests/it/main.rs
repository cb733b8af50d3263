//! camsim-render's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

#[path = "../common/mod.rs"]
mod common;

mod adaptive;
mod area_light_breadth;
mod bsdf_physics;
mod bump_mapping;
mod curves;
mod denoise;
mod goniometric_light;
mod hair_bsdf;
mod labels;
mod layered_bsdf;
mod layered_rough_photons;
mod light_groups;
mod light_sampler;
mod materials_lights;
mod materials_render;
mod media;
mod motion_bump;
mod motion_curves;
mod motion_light_groups;
mod motion_media;
mod pixel_filters;
mod procedural_textures;
mod ray_offsets;
mod ray_transfer_camera;
mod realistic_camera;
mod render_bvh;
mod render_ids;
mod render_lights;
mod render_motion;
mod render_physics;
mod render_sampler;
mod render_sampling;
mod shading_normals;
mod spectral_environment;
mod sphere_uv;
mod texture_filtering;
mod veach_bidir_light;
