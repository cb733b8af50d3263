//! `camsim optics`: spectral radiance EXR -> sensor-plane spectral irradiance EXR.

use crate::common::{self, say};
use anyhow::Result;
use camsim::optics::Optics;
use std::path::PathBuf;

/// Turn scene radiance into sensor irradiance (W/(m^2 nm)): f-number and magnification
/// (ISETCam oiCalculateIrradiance), lens transmittance, shading (cos^4, a relative-illumination
/// table or a fitted shading file), and blur by the wavefront PSF per wavelength (Zernike
/// aberrations; depth-dependent defocus when the radiance carries a depth map and the lens has a
/// focus distance).
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim scene --out out/radiance.exr\n  camsim optics --in out/radiance.exr --lens pixel4a --out out/irradiance.exr\n  camsim optics --in out/radiance.exr --lens diffraction-limited --focus-m 0.3 --out out/irradiance-defocus.exr\n\nNegative samples of FFT round-off size in the input (at most 1e-5 x its maximum) are clamped to 0\nwith a warning; larger negatives are refused. The output irradiance is non-negative."
)]
pub struct Args {
    /// Spectral radiance EXR (from `camsim scene`, `camsim render` or pbrt-v4).
    #[arg(long = "in")]
    pub input: PathBuf,
    #[arg(long, default_value = "pixel4a", help = format!("Lens: a preset ({}) or a lens TOML file", camsim::optics::presets::LENS_PRESETS.known()))]
    pub lens: String,
    /// Override the focus distance, m (depth-dependent defocus needs a depth map in the input).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub focus_m: Option<f64>,
    /// Output spectral EXR.
    #[arg(long, default_value = "out/irradiance.exr")]
    pub out: PathBuf,
    /// Overwrite --out even when camsim did not write it (a file camsim wrote, recognised by its
    /// signature, is replaced without this; anything else is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: Args) -> Result<()> {
    let _claim = common::claim_out_file(&a.out, a.force)?;
    let radiance = common::read_spectral_exr(&a.input)?;
    let mut cfg = camsim::pipeline::load_lens(&a.lens)?;
    if a.focus_m.is_some() {
        cfg.focus_distance_m = a.focus_m;
    }
    let optics = Optics::from_config(&cfg)?;
    let sp = common::spinner("optics");
    let irr = optics.compute(&radiance)?;
    sp.finish_and_clear();
    camsim::io::exr::write_spectral_exr(&a.out, &irr, "optics")?;
    say(format!(
        "wrote {} ({} x {}, {:.3} um per sample at the sensor)",
        a.out.display(),
        irr.rows,
        irr.cols,
        irr.sample_spacing_m * 1e6
    ));
    Ok(())
}
