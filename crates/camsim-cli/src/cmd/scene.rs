//! `camsim scene`: a 2D test chart -> spectral radiance EXR.

use crate::common::{self, say};
use anyhow::Result;
use std::path::PathBuf;

/// Make a 2D scene's spectral radiance (W/(sr m^2 nm)) and write it as a spectral OpenEXR.
///
/// CONFIG is a scene TOML (the `[scene]` table of a simulate config, on its own: kind = "uniform" |
/// "macbeth" | "slanted_edge" | "file" (a spectral EXR) | "rgb" (a PNG/JPEG/TIFF/EXR photograph on
/// a display model) | an ISETCam test pattern: "harmonic" | "zone_plate" | "sweep_frequency" |
/// "star" | "checkerboard" | "grid_lines" | "point_array" | "ramp" | "dead_leaves"), or a whole
/// simulate config whose `[scene]` is used. Relative paths in it are relative to its folder.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim scene examples/macbeth-d65.toml --out out/radiance.exr\n  camsim scene --kind slanted_edge --out out/edge.exr\n  camsim scene examples/zone-plate.toml --out out/zone-plate.exr\n  camsim scene --kind star --out out/star.exr\n  camsim scene examples/dead-leaves.toml --out out/dead-leaves.exr\n  camsim scene examples/rgb-photo.toml --out out/rgb-photo.exr"
)]
pub struct Args {
    /// Scene TOML (or a simulate config with a `[scene]` table).
    pub config: Option<PathBuf>,
    #[arg(long, default_value = "macbeth", conflicts_with = "config", help = format!("With no CONFIG: a built-in scene of this kind with default settings, one of {}", camsim::scene::config::SCENE_KINDS.known()))]
    pub kind: String,
    /// Output spectral EXR.
    #[arg(long, default_value = "out/radiance.exr")]
    pub out: PathBuf,
    /// Overwrite --out even when camsim did not write it (a file camsim wrote, recognised by its
    /// signature, is replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    let _claim = common::claim_out_file(&a.out, a.force)?;
    let (cfg, grid) = match &a.config {
        Some(p) => camsim::pipeline::scene::load_scene_config(p)?,
        None => camsim::pipeline::scene::default_scene(&a.kind)
            .map_err(|e| anyhow::anyhow!("--kind: {e}"))?,
    };
    let img = camsim::scene::create(&cfg, &grid)?;
    camsim::io::exr::write_spectral_exr(&a.out, &img, "scene")?;
    say(format!(
        "wrote {} ({} x {} x {} bands, {:.3} mm per sample)",
        a.out.display(),
        img.rows,
        img.cols,
        img.bands(),
        img.sample_spacing_m * 1e3
    ));
    Ok(())
}
