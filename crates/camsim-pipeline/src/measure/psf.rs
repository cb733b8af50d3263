//! A lens's point-spread functions per wavelength, as the optics stage computes them (wavefront
//! model, Zernike terms), with their MTF and line-spread functions (`camsim psf`).

use super::write_text;
use crate::{PipelineError, Result};
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_io::atomic::OutputDir;
use camsim_io::plot::{Figure, Series};
use camsim_optics::psf::Psf;
use camsim_optics::wavefront::Wavefront;
use camsim_optics::Optics;
use std::fmt::Write as _;

/// What to export.
#[derive(Debug, Clone, PartialEq)]
pub struct PsfRequest {
    /// PSF sample spacing in the sensor plane, um.
    pub spacing_um: f64,
    /// The wavelengths.
    pub grid: WavelengthGrid,
    /// (focus distance, object distance), m: the thin-lens defocus between them (None: the lens
    /// as configured, object in focus).
    pub focus_object_m: Option<(f64, f64)>,
}

/// The PSFs of one lens.
#[derive(Debug, Clone)]
pub struct PsfReport {
    /// The wavefront the PSFs come from.
    pub wavefront: Wavefront,
    /// One PSF per wavelength.
    pub psfs: Vec<Psf>,
    /// The lens's nominal f-number.
    pub f_number: f64,
    /// Sample spacing, m.
    pub spacing_m: f64,
}

/// The PSF of `optics` at each wavelength of `req`.
pub fn lens_psfs(optics: &Optics, req: &PsfRequest) -> Result<PsfReport> {
    if !(req.spacing_um > 0.0 && req.spacing_um.is_finite()) {
        return Err(PipelineError::config(format!(
            "spacing {} um: must be a positive number",
            req.spacing_um
        )));
    }
    let spacing_m = req.spacing_um * 1e-6;
    let wavefront = match req.focus_object_m {
        Some((f, o)) => optics.wavefront_for(Some(f), o)?,
        None => optics.wavefront().clone(),
    };
    let psfs = optics.psf_stack_for(&wavefront, &req.grid.wavelengths_nm(), spacing_m)?;
    Ok(PsfReport {
        wavefront,
        psfs,
        f_number: optics.config().f_number,
        spacing_m,
    })
}

impl PsfReport {
    /// Side of the largest PSF, samples.
    pub fn size(&self) -> usize {
        self.psfs.iter().map(|p| p.size).max().unwrap_or(1)
    }

    /// The PSFs centred on one square grid (the largest), one band per wavelength, unit volume.
    pub fn image(&self, grid: WavelengthGrid) -> Result<SpectralImage> {
        let size = self.size();
        let mut img = SpectralImage::zeros(size, size, grid, self.spacing_m, Quantity::Relative)?;
        for (b, p) in self.psfs.iter().enumerate() {
            let off = (size - p.size) / 2;
            let band = img.band_mut(b);
            for r in 0..p.size {
                for c in 0..p.size {
                    band[(r + off) * size + c + off] = p.at(r, c) as f32;
                }
            }
        }
        Ok(img)
    }

    /// The working f-number (image distance / pupil diameter) of the wavefront, which exceeds
    /// the nominal one when the lens is focused closer than infinity: the diffraction limit's.
    pub fn working_f_number(&self) -> f64 {
        self.wavefront.working_f_number()
    }

    /// mtf.csv (with the diffraction-limited MTF at the working f-number) and lsf.csv.
    pub fn csvs(&self) -> (String, String) {
        let n = self.working_f_number();
        let mut mtf_csv =
            String::from("wavelength_nm,freq_cyc_per_mm,mtf_x,mtf_y,diffraction_limit\n");
        let mut lsf_csv = String::from("wavelength_nm,position_um,lsf_x,lsf_y\n");
        for p in &self.psfs {
            let m = p.mtf();
            for ((f, mx), my) in m.freq_cyc_per_mm.iter().zip(&m.mtf_x).zip(&m.mtf_y) {
                let dl = camsim_optics::diffraction_mtf(*f, p.wavelength_nm, n);
                let _ = writeln!(
                    mtf_csv,
                    "{},{f:.4},{mx:.6},{my:.6},{dl:.6}",
                    p.wavelength_nm
                );
            }
            let (lx, ly) = (p.lsf_x(), p.lsf_y());
            for (i, (x, y)) in lx.iter().zip(&ly).enumerate() {
                let pos_um = (i as f64 - (p.size / 2) as f64) * p.spacing_m * 1e6;
                let _ = writeln!(lsf_csv, "{},{pos_um:.4},{x:.6e},{y:.6e}", p.wavelength_nm);
            }
        }
        (mtf_csv, lsf_csv)
    }

    /// The MTF plot of every wavelength with its diffraction limit dashed; `lens` names the lens.
    pub fn figure(&self, lens: &str) -> Figure {
        let n = self.working_f_number();
        let mut fig = Figure::new(
            format!(
                "MTF of '{lens}' (f/{}, working f/{n:.3}, defocus c4 = {:.3} um at the lens pupil)",
                self.f_number,
                self.wavefront.defocus_at_lens_pupil_um()
            ),
            "spatial frequency (cycles/mm, sensor plane)",
            "MTF",
        )
        .ranges(Some((0.0, 1.0 / (500e-6 * n))), Some((0.0, 1.02)))
        .sized(900, 600);
        for p in &self.psfs {
            let m = p.mtf();
            fig = fig
                .with(Series::new(
                    format!("{:.0} nm", p.wavelength_nm),
                    m.freq_cyc_per_mm
                        .iter()
                        .zip(&m.mtf_x)
                        .map(|(f, v)| (*f, *v))
                        .collect(),
                ))
                .with(
                    Series::new(
                        format!("{:.0} nm diffraction limit", p.wavelength_nm),
                        m.freq_cyc_per_mm
                            .iter()
                            .map(|f| (*f, camsim_optics::diffraction_mtf(*f, p.wavelength_nm, n)))
                            .collect(),
                    )
                    .dashed(),
                );
        }
        fig
    }

    /// Write psf.exr, mtf.csv, lsf.csv and mtf.png into `out`.
    pub fn write_files(&self, out: &OutputDir, grid: WavelengthGrid, lens: &str) -> Result<()> {
        camsim_io::exr::write_spectral_exr(&out.join("psf.exr"), &self.image(grid)?, "psf")?;
        let (mtf_csv, lsf_csv) = self.csvs();
        write_text(&out.join("mtf.csv"), &mtf_csv)?;
        write_text(&out.join("lsf.csv"), &lsf_csv)?;
        self.figure(lens).write_png(&out.join("mtf.png"))?;
        Ok(())
    }
}
