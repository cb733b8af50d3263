//! camsim-pbrt's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod bitterli_scenes;
mod builtin_overlay;
mod curves_hair;
mod hair_curl_reference;
mod overlay_motion;
mod parser;
mod parser_fuzz;
mod parser_materials;
mod pbrt_breadth;
mod pbrt_images;
mod pbrt_lights_shapes;
mod pbrt_media;
mod pbrt_motion;
mod pbrt_options;
mod pbrt_real_scenes;
