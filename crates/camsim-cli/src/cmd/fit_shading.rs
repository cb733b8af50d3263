//! `camsim fit-shading`: fit lens shading to a flat-field raw capture.

use crate::common::say;
use anyhow::Result;
use std::path::PathBuf;

/// Fit a low-order 2D polynomial per CFA channel to a raw image of a uniform field (an
/// integrating sphere), as the paper estimated the Pixel 4a's lens shading. Writes a shading TOML
/// that a lens config uses as `shading = { file = "shading.toml" }`, and reports the RMS residual.
#[derive(clap::Args)]
#[command(
    after_help = "Examples (a simulated flat field, then its fit):\n  camsim scene examples/uniform.toml --out out/flat-radiance.exr\n  camsim optics --in out/flat-radiance.exr --out out/flat-irradiance.exr\n  camsim sensor --in out/flat-irradiance.exr --rows 64 --cols 64 --out out/flat\n  camsim fit-shading out/flat/raw.dng --order 4 --out out/flat-shading.toml\nthen in a lens TOML:  shading = { file = \"shading.toml\" }\n\nThe input must be a flat field: the fit is refused (exit 2) when it leaves more than 3 % RMS\nresidual beyond the pixel noise, or its relative illumination leaves [0.05, 1] or rises going\nout from its maximum."
)]
pub struct Args {
    /// Flat-field raw image (DNG) of a uniformly lit field (integrating sphere).
    pub flat: PathBuf,
    /// Polynomial total degree (0..=8).
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Output shading TOML (written only when the fit passes the flat-field checks).
    #[arg(long, default_value = "shading.toml")]
    pub out: PathBuf,
    /// Overwrite --out even when camsim did not write it (a file camsim wrote, recognised by its
    /// signature, is replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    let _claim = crate::common::claim_out_file(&a.out, a.force)?;
    let (raw, _info) = camsim::io::dng::read_dng(&a.flat)?;
    let fit = camsim::optics::fit_flat_field(&raw, a.order)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.flat.display()))?;
    camsim::io::atomic::write_bytes_atomic(&a.out, fit.to_toml().as_bytes())?;
    let corner = fit.eval(camsim::core::CfaChannel::G, 1.0, 1.0);
    say(format!(
        "fitted order-{} shading on {} x {}: RMS residual {:.3} %, green corner relative illumination {:.3} -> {}",
        fit.order,
        raw.rows,
        raw.cols,
        fit.rms_residual_percent,
        corner,
        a.out.display()
    ));
    Ok(())
}
