//! One module per subcommand.
pub mod analyze;
pub mod dataset;
pub mod demosaic_zone_plate;
pub mod fit;
pub mod fit_mtf;
pub mod emva;
pub mod fit_shading;
pub mod isp;
pub mod optics;
pub mod presets;
pub mod psf;
pub mod render;
pub mod scene;
pub mod sensor;
pub mod simulate;
pub mod validate;
pub mod isp_cfa;
