//! `camsim psf`: export a lens's PSFs, MTFs and line-spread functions.

use crate::common::{self, say};
use anyhow::Result;
use camsim::core::WavelengthGrid;
use camsim::optics::Optics;
use camsim::pipeline::measure::psf::{lens_psfs, PsfRequest};
use std::path::PathBuf;

/// Write a lens's point-spread functions per wavelength (psf.exr, one channel per wavelength,
/// unit volume), MTF curves in cycles/mm (mtf.csv and mtf.png) and line-spread functions
/// (lsf.csv). The PSF is computed as the optics stage uses it (wavefront model, Zernike terms).
/// mtf.csv's `diffraction_limit` column is the aberration-free MTF at the working f-number
/// (image distance / pupil diameter) of the same focus.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim psf --lens pixel4a --out out/psf\n  camsim psf --lens diffraction-limited --spacing-um 0.25 --out out/psf-dl\n  camsim psf --lens pixel4a --focus-m 0.3 --object-m 0.5 --out out/psf-defocus"
)]
pub struct Args {
    /// Lens preset or TOML file.
    #[arg(long, default_value = "pixel4a")]
    pub lens: String,
    /// PSF sample spacing in the sensor plane, um.
    #[arg(long, default_value_t = 0.35, value_parser = crate::common::positive_f64)]
    pub spacing_um: f64,
    /// Wavelengths: first, last, step (nm).
    #[arg(long, num_args = 3, default_values_t = [450.0, 650.0, 100.0])]
    pub wavelengths_nm: Vec<f64>,
    /// Focus distance, m (with --object-m: adds the thin-lens defocus between the two).
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub focus_m: Option<f64>,
    /// Object distance, m.
    #[arg(long, value_parser = crate::common::positive_f64)]
    pub object_m: Option<f64>,
    /// Output folder.
    #[arg(long, default_value = "out/psf")]
    pub out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let staged = common::stage_out_dir(&a.out)?;
    let optics = Optics::from_config(&camsim::pipeline::load_lens(&a.lens)?)?;
    let [w0, w1, dw] = [
        a.wavelengths_nm[0],
        a.wavelengths_nm[1],
        a.wavelengths_nm[2],
    ];
    let grid = WavelengthGrid::new(w0, w1, dw)?;
    let focus_object_m = match (a.focus_m, a.object_m) {
        (Some(f), Some(o)) => Some((f, o)),
        (None, None) => None,
        _ => anyhow::bail!("give both --focus-m and --object-m, or neither"),
    };
    let report = lens_psfs(
        &optics,
        &PsfRequest {
            spacing_um: a.spacing_um,
            grid,
            focus_object_m,
        },
    )?;
    report.write_files(&staged, grid, &a.lens)?;
    let size = report.size();
    say(format!(
        "wrote psf.exr ({size} x {size} at {} um), mtf.csv, mtf.png, lsf.csv in {}",
        a.spacing_um,
        a.out.display()
    ));
    common::commit(staged)?;
    Ok(())
}
