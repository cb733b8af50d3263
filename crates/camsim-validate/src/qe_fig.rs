//! Section 2 (paper Figure 3): the QE correction matrix M recovered from ColorChecker captures.
//!
//! The 24 ColorChecker patches (N. Ohta 1997 reflectances) under CIE A, F2 (cool-white
//! fluorescent) and D65, each light scaled so a perfect white diffuser has luminance
//! [`WHITE_LUMINANCE_CD_M2`]: 72 patch radiances. Each patch becomes a uniform sensor-plane
//! irradiance E = pi / (1 + 4 N^2) L (camera equation on axis, object at infinity, T = 1;
//! ISETCam `oiCalculateIrradiance`) of `qe_patch_px` pixels square, the patches of one light
//! tiled 4 x 6 in one frame.
//!
//! "Measured": the pixel4a sensor (Table 1, every noise source on) with the paper's corrected QE
//! read from ISET/isetcornellbox `p4aCorrected` (csv or mat) in the data folder (`--data`), an
//! independent measurement; without a data folder, the pixel4a preset (published QE x the paper's
//! M: then recovering M only checks that the fit inverts its input, and the report says so). One
//! exposure per light puts the brightest noise-free channel mean at 80 % of full scale;
//! mean DN above black per channel over each patch (inner part, 2-pixel border dropped).
//! "Predicted": the imx363 sensor (published QE) noise-free at the same exposure (photon counting,
//! `Sensor::mean_electrons_uniform` x K). M is fitted by least squares in the paper's
//! lower-triangular non-negative form and unconstrained (camsim_analysis::qefit).

use crate::plot::{Figure, Series, Style, CHANNEL_COLORS};
use crate::report::Html;
use crate::util::{f, save_png, FigurePng};
use crate::{Check, QualityParams, Result, Stages, ValidateError, ValidateOptions};
use camsim_analysis::qefit::{fit_qe_matrix, transform_qe, MatrixForm, QeFit, PAPER_M};
use camsim_analysis::roi::roi_stats_raw;
use camsim_analysis::Rect;
use camsim_core::colorimetry::luminance_cd_m2;
use camsim_core::{tables, Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::lens;
use camsim_sensor::{Capture, Sensor};
use serde::Serialize;

/// Luminance of a perfect white diffuser under each light, cd/m^2.
pub const WHITE_LUMINANCE_CD_M2: f64 = 100.0;
/// Brightest noise-free channel mean as a fraction of full scale.
pub const TARGET_FRACTION: f64 = 0.8;
/// The three lights: camsim_core::tables::illuminant names and descriptions.
pub const LIGHTS: [(&str, &str); 3] = [
    ("A", "CIE A (tungsten)"),
    ("F2", "CIE F2 (cool-white fluorescent)"),
    ("D65", "CIE D65 (daylight)"),
];

/// One patch under one light.
#[derive(Debug, Clone, Serialize)]
pub struct PatchRgb {
    /// Light name.
    pub light: String,
    /// Patch number 1..=24.
    pub patch: usize,
    /// Measured mean DN above black (pixel4a sensor, noise on), R, G, B.
    pub measured_dn: [f64; 3],
    /// Predicted DN with the published QE (imx363, noise-free), R, G, B.
    pub predicted_dn: [f64; 3],
}

/// Section 2 results.
#[derive(Debug, Clone, Serialize)]
pub struct QeResults {
    /// Patch side, pixels.
    pub patch_px: usize,
    /// Exposure per light, s.
    pub exposure_s: Vec<(String, f64)>,
    /// All 72 patch values.
    pub patches: Vec<PatchRgb>,
    /// The fit in the paper's form (lower triangular, non-negative).
    pub fit_paper_form: QeFit,
    /// The unconstrained fit (reference).
    pub fit_unconstrained: QeFit,
    /// The paper's M.
    pub paper_m: [[f64; 3]; 3],
    /// Largest |fitted - paper| entry of the paper-form fit.
    pub max_abs_difference_to_paper: f64,
    /// Where the measuring camera's QE came from.
    pub measured_qe_source: String,
    /// Per channel, relative RMS difference over wavelength between the published QE x the paper's
    /// M and the measuring camera's QE (0 for the preset, 15-22 % for p4aCorrected).
    pub paper_m_qe_mismatch: [f64; 3],
    /// Per column j, the tolerance on |M_fit - M_paper|: mismatch_j x |column j of the paper's M|
    /// (a relative curve error eps moves a column of M by about eps times its length), at least 0.01.
    pub tolerance_per_column: [f64; 3],
    /// Checks.
    pub checks: Vec<Check>,
    /// Figures.
    pub figures: Vec<FigurePng>,
}

fn grid_samples(s: &camsim_core::Spectrum, grid: &WavelengthGrid) -> Vec<f64> {
    s.sample(grid)
}

/// Run section 2.
pub(crate) fn run(opts: &ValidateOptions, p: &QualityParams, st: &mut Stages) -> Result<QeResults> {
    let grid = p.grid;
    let (measured_sensor, measured_qe_source) = measuring_sensor(opts)?;
    let published = Sensor::preset("imx363")?;
    let n_f = camsim_optics::OpticsConfig::preset("pixel4a")?.f_number;
    let e_per_l = lens::irradiance_factor(n_f, 0.0, 1.0);
    let refl: Vec<Vec<f64>> = tables::macbeth_reflectances()
        .iter()
        .map(|s| grid_samples(s, &grid))
        .collect();
    let ps = p.qe_patch_px;
    let (rows, cols) = (4 * ps, 6 * ps);
    let sensor = measured_sensor.with_size(rows, cols)?;

    let (patches, exposures) = st.run("sensor QE: ColorChecker under A, F2, D65", |_| {
        let mut patches = Vec::new();
        let mut exposures = Vec::new();
        for (li, (light, _)) in LIGHTS.iter().enumerate() {
            let spd = grid_samples(&tables::illuminant(light)?, &grid);
            let y = luminance_cd_m2(&spd, &grid);
            if y.is_nan() || y <= 0.0 {
                return Err(ValidateError::invalid(
                    format!("illuminant {light}"),
                    "has no luminance on the grid",
                ));
            }
            // Radiance of a perfect white diffuser of luminance WHITE_LUMINANCE_CD_M2.
            let white: Vec<f64> = spd.iter().map(|v| v * WHITE_LUMINANCE_CD_M2 / y).collect();
            let irr: Vec<Vec<f64>> = refl
                .iter()
                .map(|r| r.iter().zip(&white).map(|(a, b)| a * b * e_per_l).collect())
                .collect();
            // Exposure: brightest noise-free channel mean at TARGET_FRACTION of full scale.
            let mut e_max: f64 = 0.0;
            for e in &irr {
                let el = measured_sensor.mean_electrons_uniform(e, &grid, 1.0)?;
                e_max = e_max.max(el.iter().cloned().fold(0.0, f64::max));
            }
            let t = TARGET_FRACTION * measured_sensor.max_dn() as f64
                / (measured_sensor.k_dn_per_e() * e_max);
            exposures.push((light.to_string(), t));
            // The tiled irradiance frame, sampled at the pixel pitch (identity mapping).
            let mut img = SpectralImage::zeros(
                rows,
                cols,
                grid,
                sensor.pixel_pitch_m(),
                Quantity::Irradiance,
            )?;
            for (b, _) in grid.wavelengths_nm().iter().enumerate() {
                let plane = img.band_mut(b);
                for r in 0..rows {
                    for c in 0..cols {
                        plane[r * cols + c] = irr[(r / ps) * 6 + c / ps][b] as f32;
                    }
                }
            }
            let frame = sensor.compute(
                &img,
                &Capture::seconds(t).with_seed(opts.seed.wrapping_add(100 + li as u64)),
            )?;
            let rects: Vec<Rect> = (0..24)
                .map(|i| Rect::new((i / 6) * ps + 2, (i % 6) * ps + 2, ps - 4, ps - 4))
                .collect();
            let stats = roi_stats_raw(&frame.raw[0], &rects)?;
            let k = published.k_dn_per_e();
            for (i, s) in stats.iter().enumerate() {
                let e = published.mean_electrons_uniform(&irr[i], &grid, t)?;
                patches.push(PatchRgb {
                    light: light.to_string(),
                    patch: i + 1,
                    measured_dn: s.mean_dn,
                    predicted_dn: [e[0] * k, e[1] * k, e[2] * k],
                });
            }
        }
        Ok((patches, exposures))
    })?;

    let measured: Vec<[f64; 3]> = patches.iter().map(|p| p.measured_dn).collect();
    let predicted: Vec<[f64; 3]> = patches.iter().map(|p| p.predicted_dn).collect();
    let fit = fit_qe_matrix(&measured, &predicted, MatrixForm::PaperLowerNonNegative)?;
    let fit_u = fit_qe_matrix(&measured, &predicted, MatrixForm::Unconstrained)?;
    let max_diff = fit
        .m
        .iter()
        .flatten()
        .zip(PAPER_M.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // Tolerance from the data: how far published QE x the paper's M is from the measuring QE.
    let (published_qe, measuring_qe) = (
        published.channel_qe(&grid),
        measured_sensor.channel_qe(&grid),
    );
    let mismatch =
        camsim_analysis::qefit::qe_relative_rms_difference(&published_qe, &measuring_qe, &PAPER_M)?;
    let tol = [0, 1, 2].map(|j| {
        (mismatch[j] * (0..3).map(|i| PAPER_M[i][j].powi(2)).sum::<f64>().sqrt()).max(0.01)
    });
    let within = (0..3).all(|j| (0..3).all(|i| (fit.m[i][j] - PAPER_M[i][j]).abs() <= tol[j]));
    let checks = vec![
        Check {
            name: format!(
                "fitted M (paper's form) equals the paper's M within the QE data's mismatch (per column {:.3}, {:.3}, {:.3})",
                tol[0], tol[1], tol[2]
            ),
            passed: within,
            detail: format!("largest |M_fit - M_paper| = {max_diff:.4}; measuring QE: {measured_qe_source}"),
        },
        Check {
            name: "the correction reduces the RMS error".into(),
            passed: fit.rms_after < fit.rms_before,
            detail: format!("RMS {:.1} DN before, {:.2} DN after", fit.rms_before, fit.rms_after),
        },
    ];
    let mut res = QeResults {
        patch_px: ps,
        exposure_s: exposures,
        patches,
        fit_paper_form: fit,
        fit_unconstrained: fit_u,
        paper_m: PAPER_M,
        max_abs_difference_to_paper: max_diff,
        measured_qe_source,
        paper_m_qe_mismatch: mismatch,
        tolerance_per_column: tol,
        checks,
        figures: Vec::new(),
    };
    res.figures = figures(opts, &res, &published, &grid)?;
    Ok(res)
}

/// The measuring camera: pixel4a (Table 1) with `p4aCorrected` from the data folder when there
/// is one, else the pixel4a preset; and a description of its QE.
fn measuring_sensor(opts: &ValidateOptions) -> Result<(Sensor, String)> {
    let preset = Sensor::preset("pixel4a")?;
    let Some(dir) = opts.data_dir.as_deref() else {
        return Ok((preset, "pixel4a preset: published QE x the paper's M (self-consistency only; give --data for p4aCorrected)".into()));
    };
    let Some(path) = ["csv", "mat"]
        .iter()
        .map(|e| dir.join(format!("p4aCorrected.{e}")))
        .find(|p| p.is_file())
    else {
        return Ok((
            preset,
            format!(
                "pixel4a preset: published QE x the paper's M (no p4aCorrected in {})",
                dir.display()
            ),
        ));
    };
    let t = camsim_core::spectrum_csv::load_spectra(&path)?;
    if t.columns.len() < 3 {
        return Err(ValidateError::file(
            &path,
            format!("needs 3 columns r, g, b, has {}", t.columns.len()),
        ));
    }
    let col = |name: &str, k: usize| t.columns[t.index_of(name).unwrap_or(k)].clone();
    let mut cfg = preset.config().clone();
    cfg.name = "pixel4a (p4aCorrected QE)".into();
    cfg.qe = camsim_sensor::QeConfig {
        file: None,
        loaded_from: Some(path.display().to_string()),
        correction: None,
        wavelengths_nm: t.wavelengths_nm.clone(),
        r: col("r", 0),
        g: col("g", 1),
        b: col("b", 2),
        ir_cut: None,
        pixel_qe: None,
        filters: Default::default(),
    };
    cfg.qe_correction = None;
    let s = Sensor::from_config(cfg).map_err(|e| ValidateError::file(&path, e.to_string()))?;
    Ok((
        s,
        format!(
            "{} (ISET/isetcornellbox, the paper's corrected QE)",
            path.display()
        ),
    ))
}

fn figures(
    opts: &ValidateOptions,
    r: &QeResults,
    published: &Sensor,
    grid: &WavelengthGrid,
) -> Result<Vec<FigurePng>> {
    let mut out = Vec::new();
    let wl = grid.wavelengths_nm();
    // (a-c) the lights, relative to their maximum.
    let mut fig = Figure::new(
        "Figure 3a-c: the lights",
        "wavelength (nm)",
        "relative spectral power",
    );
    let colors = [[200, 120, 30], [60, 160, 160], [90, 90, 200]];
    for (i, (name, desc)) in LIGHTS.iter().enumerate() {
        let s = grid_samples(&tables::illuminant(name)?, grid);
        let m = s.iter().cloned().fold(0.0, f64::max).max(1e-30);
        fig = fig.with(Series::xy(
            *desc,
            wl.clone(),
            s.iter().map(|v| v / m).collect(),
            Style::Line,
            colors[i],
        ));
    }
    out.push(save_png(
        &opts.out_dir,
        "fig3a_lights.png",
        "Figure 3a-c: spectral power of the three lights (normalized to 1).",
        fig.png()?,
    )?);

    // (d) published (dashed) and transformed (solid) QE.
    let qe = published.channel_qe(grid);
    let tq = transform_qe(&qe, &r.fit_paper_form.m)?;
    let mut fig = Figure::new(
        "Figure 3d: IMX363 QE, published and transformed",
        "wavelength (nm)",
        "quantum efficiency",
    );
    for c in 0..3 {
        let ch = ["R", "G", "B"][c];
        fig = fig.with(Series::xy(
            format!("{ch} published"),
            wl.clone(),
            qe[c].clone(),
            Style::Dashed,
            CHANNEL_COLORS[c],
        ));
        fig = fig.with(Series::xy(
            format!("{ch} transformed (fitted M)"),
            wl.clone(),
            tq[c].clone(),
            Style::Line,
            CHANNEL_COLORS[c],
        ));
    }
    out.push(save_png(
        &opts.out_dir,
        "fig3d_qe.png",
        "Figure 3d: published IMX363 QE (dashed) and the QE transformed by the fitted M (solid).",
        fig.png()?,
    )?);

    // (e, f) predicted vs measured, before and after.
    let after = camsim_analysis::qefit::apply_matrix(
        &r.patches.iter().map(|p| p.predicted_dn).collect::<Vec<_>>(),
        &r.fit_paper_form.m,
    );
    for (k, (title, file)) in [
        ("Figure 3e: published QE", "fig3e_before.png"),
        ("Figure 3f: transformed QE", "fig3f_after.png"),
    ]
    .iter()
    .enumerate()
    {
        let mut fig = Figure::new(
            *title,
            "predicted mean DN",
            "measured (simulated pixel4a) mean DN",
        );
        for c in 0..3 {
            let x: Vec<f64> = r
                .patches
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    if k == 0 {
                        p.predicted_dn[c]
                    } else {
                        after[i][c]
                    }
                })
                .collect();
            let y: Vec<f64> = r.patches.iter().map(|p| p.measured_dn[c]).collect();
            fig = fig.with(Series::xy(
                ["R", "G", "B"][c],
                x,
                y,
                Style::Points,
                CHANNEL_COLORS[c],
            ));
        }
        fig = fig.with_identity_line();
        let cap = format!(
            "{title}: predicted vs measured mean DN of the 24 patches under 3 lights ({}); dashed y = x.",
            if k == 0 { "published QE, before the fit" } else { "QE transformed by the fitted M" }
        );
        out.push(save_png(&opts.out_dir, file, &cap, fig.png()?)?);
    }
    Ok(out)
}

fn m_rows(m: &[[f64; 3]; 3]) -> Vec<Vec<String>> {
    m.iter()
        .map(|r| r.iter().map(|v| f(*v, 4)).collect())
        .collect()
}

impl QeResults {
    /// Write the section into the report.
    pub fn report(&self, h: &mut Html) {
        h.h2("2. Sensor QE (Figure 3)", "qe");
        h.p(&format!(
            "The 24 ColorChecker patches under CIE A, F2 and D65 (a perfect white at {WHITE_LUMINANCE_CD_M2} cd/m2), each a uniform \
             {0} x {0} pixel irradiance. Measured: the pixel4a sensor with all noise sources, QE: {1}; predicted: \
             the published IMX363 QE, noise-free, same exposure. M minimizes the squared error of measured ~ predicted M. \
             Published QE x the paper's M differs from the measuring QE by a relative RMS of {2:.3} / {3:.3} / {4:.3} (R / G / B).",
            self.patch_px, self.measured_qe_source, self.paper_m_qe_mismatch[0], self.paper_m_qe_mismatch[1], self.paper_m_qe_mismatch[2]
        ));
        for fg in &self.figures {
            h.figure(&fg.png, &fg.caption);
        }
        h.h3("Fitted M (paper's form: lower triangular, non-negative)");
        h.table(&["r'", "g'", "b'"], &m_rows(&self.fit_paper_form.m));
        h.h3("The paper's M");
        h.table(&["r'", "g'", "b'"], &m_rows(&self.paper_m));
        h.h3("Unconstrained fit (reference)");
        h.table(&["r'", "g'", "b'"], &m_rows(&self.fit_unconstrained.m));
        let fp = &self.fit_paper_form;
        h.table(
            &[
                "fit",
                "RMS before (DN)",
                "RMS after (DN)",
                "relative RMS before",
                "relative RMS after",
            ],
            &[
                vec![
                    "paper form".into(),
                    f(fp.rms_before, 2),
                    f(fp.rms_after, 2),
                    f(fp.relative_rms_before, 4),
                    f(fp.relative_rms_after, 4),
                ],
                vec![
                    "unconstrained".into(),
                    f(self.fit_unconstrained.rms_before, 2),
                    f(self.fit_unconstrained.rms_after, 2),
                    f(self.fit_unconstrained.relative_rms_before, 4),
                    f(self.fit_unconstrained.relative_rms_after, 4),
                ],
            ],
        );
        h.p(&format!(
            "Largest |M_fit - M_paper| entry: {:.4}.",
            self.max_abs_difference_to_paper
        ));
        let ex: Vec<String> = self
            .exposure_s
            .iter()
            .map(|(l, t)| format!("{l}: {:.3} ms", t * 1e3))
            .collect();
        h.p(&format!("Exposure per light: {}.", ex.join(", ")));
    }
}
