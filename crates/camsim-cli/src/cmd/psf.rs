//! `camsim psf`: export a lens's PSFs, MTFs and line-spread functions.

use crate::common::{self, say};
use anyhow::Result;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_io::plot::{LinePlot, Series};
use camsim_optics::Optics;
use std::fmt::Write as _;
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
    #[arg(long, default_value_t = 0.35)]
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
    let out = staged.path().to_path_buf();
    let optics = Optics::from_config(&camsim_pipeline::load_lens(&a.lens)?)?;
    let [w0, w1, dw] = [
        a.wavelengths_nm[0],
        a.wavelengths_nm[1],
        a.wavelengths_nm[2],
    ];
    let grid = WavelengthGrid::new(w0, w1, dw)?;
    if !(a.spacing_um > 0.0 && a.spacing_um.is_finite()) {
        anyhow::bail!("--spacing-um {}: must be a positive number", a.spacing_um);
    }
    let spacing_m = a.spacing_um * 1e-6;
    let wf = match (a.focus_m, a.object_m) {
        (Some(f), Some(o)) => optics.wavefront_for(Some(f), o)?,
        (None, None) => optics.wavefront().clone(),
        _ => anyhow::bail!("give both --focus-m and --object-m, or neither"),
    };
    let psfs = optics.psf_stack_for(&wf, &grid.wavelengths_nm(), spacing_m)?;
    // All PSFs on one square grid (the largest), centred.
    let size = psfs.iter().map(|p| p.size).max().unwrap_or(1);
    let mut img = SpectralImage::zeros(size, size, grid, spacing_m, Quantity::Relative)?;
    for (b, p) in psfs.iter().enumerate() {
        let off = (size - p.size) / 2;
        let band = img.band_mut(b);
        for r in 0..p.size {
            for c in 0..p.size {
                band[(r + off) * size + c + off] = p.at(r, c) as f32;
            }
        }
    }
    camsim_io::exr::write_spectral_exr(&out.join("psf.exr"), &img, "psf")?;

    let mut mtf_csv = String::from("wavelength_nm,freq_cyc_per_mm,mtf_x,mtf_y,diffraction_limit\n");
    let mut lsf_csv = String::from("wavelength_nm,position_um,lsf_x,lsf_y\n");
    let mut series = Vec::new();
    // The diffraction-limited reference uses the working f-number (image distance / pupil
    // diameter) of the wavefront the PSFs come from, which exceeds the nominal one when the lens
    // is focused closer than infinity.
    let n = wf.working_f_number();
    for p in &psfs {
        let m = p.mtf();
        for ((f, mx), my) in m.freq_cyc_per_mm.iter().zip(&m.mtf_x).zip(&m.mtf_y) {
            let dl = camsim_optics::diffraction_mtf(*f, p.wavelength_nm, n);
            writeln!(
                mtf_csv,
                "{},{f:.4},{mx:.6},{my:.6},{dl:.6}",
                p.wavelength_nm
            )?;
        }
        let (lx, ly) = (p.lsf_x(), p.lsf_y());
        for (i, (x, y)) in lx.iter().zip(&ly).enumerate() {
            let pos_um = (i as f64 - (p.size / 2) as f64) * p.spacing_m * 1e6;
            writeln!(lsf_csv, "{},{pos_um:.4},{x:.6e},{y:.6e}", p.wavelength_nm)?;
        }
        series.push(Series::new(
            format!("{:.0} nm", p.wavelength_nm),
            m.freq_cyc_per_mm
                .iter()
                .zip(&m.mtf_x)
                .map(|(f, v)| (*f, *v))
                .collect(),
        ));
        series.push(dashed(
            format!("{:.0} nm diffraction limit", p.wavelength_nm),
            m.freq_cyc_per_mm
                .iter()
                .map(|f| (*f, camsim_optics::diffraction_mtf(*f, p.wavelength_nm, n)))
                .collect(),
        ));
    }
    camsim_io::atomic::write_bytes_atomic(&out.join("mtf.csv"), mtf_csv.as_bytes())?;
    camsim_io::atomic::write_bytes_atomic(&out.join("lsf.csv"), lsf_csv.as_bytes())?;
    let plot = LinePlot {
        title: format!(
            "MTF of '{}' (f/{}, working f/{:.3}, defocus c4 = {:.3} um at the lens pupil)",
            a.lens,
            optics.config().f_number,
            n,
            wf.defocus_at_lens_pupil_um()
        ),
        x_label: "spatial frequency (cycles/mm, sensor plane)".into(),
        y_label: "MTF".into(),
        series,
        x_range: Some((0.0, 1.0 / (500e-6 * n))),
        y_range: Some((0.0, 1.02)),
    };
    plot.write_png(&out.join("mtf.png"), 900, 600)?;
    say(format!(
        "wrote psf.exr ({size} x {size} at {} um), mtf.csv, mtf.png, lsf.csv in {}",
        a.spacing_um,
        a.out.display()
    ));
    common::commit(staged)?;
    Ok(())
}

/// A dashed series (model curves beside measured ones).
fn dashed(name: String, points: Vec<(f64, f64)>) -> Series {
    Series {
        dashed: true,
        ..Series::new(name, points)
    }
}
