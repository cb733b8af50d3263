//! Section 1 (paper Figure 2): slanted-edge MTF at two focus settings against the optics model.
//!
//! The built-in `slanted-edge` scene (a 5-degree black/white edge 0.5 m from the camera inside
//! the box) is rendered with the field of view of a small sensor window seen through the Pixel 4a
//! lens (4.38 mm, f/1.73), at `edge_oversampling` render samples per sensor pixel so the PSF is
//! sampled finer than the pixels. The optics run twice with the paper's defocus, written as an
//! explicit Zernike term over ISETCam's 8 mm measurement pupil: c4 = 1.225 um ("focused at
//! 50 cm") and c4 = 3.5 um ("focused at 30 cm"). The pixel4a sensor window (noise on,
//! auto-exposure) captures each; the ISO 12233 e-SFR is measured per CFA channel on the raw
//! mosaic and on the luminance of the bilinearly demosaicked image.
//!
//! Model: the wavefront MTF (camsim_optics) per wavelength, averaged with the weights
//! QE_c(lambda) S(lambda) lambda (photon-counting channel response to the scene's mean spectral
//! radiance S), times the pixel aperture |sinc(f p)| (100 % fill factor, ISETCam), times the
//! simulation's own sampling of the radiance on the render grid: a box average over each render
//! pixel (the renderer jitters samples uniformly in the pixel) and a zero-order hold when the
//! sensor integrates the piecewise-constant irradiance, sinc^2(f p / k) for k render samples per
//! pixel. (The demosaicked luminance also carries the bilinear interpolation, which the model
//! leaves out; it is reported but not checked.)

use crate::plot::{Figure, Series, Style, CHANNEL_COLORS};
use crate::report::Html;
use crate::util::{f, fo, save_png, BoxSpectra, FigurePng};
use crate::{Check, QualityParams, Result, Stages, ValidateOptions};
use camsim_analysis::image::LUMINANCE_WEIGHTS_REC709;
use camsim_analysis::sfr::{crossing, interp, SfrResult};
use camsim_analysis::Rect;
use camsim_core::SpectralImage;
use camsim_optics::config::{Padding, WavefrontConfig, ZernikeTerm, ZernikeTerms};
use camsim_optics::{lens, Optics, OpticsConfig};
use camsim_scene3d::builtin::{self, BuiltinOptions};
use camsim_sensor::{Capture, Sensor};
use rayon::prelude::*;
use serde::Serialize;

/// Target distance, m (paper: 50 cm).
pub const TARGET_DISTANCE_M: f64 = 0.5;
/// The paper's focus distance of the defocused setting, m (30 cm).
pub const DEFOCUS_FOCUS_DISTANCE_M: f64 = 0.3;
/// ISETCam's default wavefront measurement pupil, mm, over which the paper's values are given.
pub const MEASUREMENT_PUPIL_MM: f64 = 8.0;
/// The paper's defocus coefficients c4, um over the 8 mm measurement pupil: in focus, 30 cm focus.
pub const PAPER_C4_UM: [f64; 2] = [1.225, 3.5];

/// One channel's measured SFR beside the model MTF.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelMtf {
    /// "R", "G", "B" (raw CFA sub-grids) or "luminance" (demosaicked, Rec. 709 weights).
    pub channel: String,
    /// Frequencies, cycles per sensor pixel.
    pub freq_cyc_per_px: Vec<f64>,
    /// Measured SFR (ISO 12233 e-SFR).
    pub sfr: Vec<f64>,
    /// Model MTF at the same frequencies.
    pub model: Vec<f64>,
    /// Measured MTF50, cycles per sensor pixel.
    pub mtf50_cyc_per_px: Option<f64>,
    /// Measured MTF50, cycles/mm.
    pub mtf50_cyc_per_mm: Option<f64>,
    /// Model MTF50, cycles per sensor pixel.
    pub model_mtf50_cyc_per_px: Option<f64>,
    /// Model MTF50, cycles/mm.
    pub model_mtf50_cyc_per_mm: Option<f64>,
    /// Nyquist frequency of the analysed sampling grid, cycles per sensor pixel: 0.25 for a raw
    /// CFA channel (every second pixel), 0.5 for the demosaicked luminance.
    pub nyquist_cyc_per_px: f64,
    /// RMS of (SFR - model) over 0 < f <= `nyquist_cyc_per_px` (the channel's own Nyquist).
    pub rms_difference_to_nyquist: f64,
    /// Largest |SFR - model| over the same range.
    pub max_difference_to_nyquist: f64,
    /// RMS of (SFR - model) over 0 < f <= 0.5 cycles/pixel (the sensor's Nyquist; for raw
    /// channels beyond their own Nyquist, where aliasing and noise dominate the e-SFR).
    pub rms_difference_to_sensor_nyquist: f64,
    /// Edge angle found by the SFR, degrees.
    pub edge_angle_deg: f64,
}

/// One focus setting.
#[derive(Debug, Clone, Serialize)]
pub struct FocusSetting {
    /// Label ("focused at 50 cm", ...).
    pub label: String,
    /// Defocus c4 over the 8 mm measurement pupil, um (the paper's value).
    pub c4_um_over_8mm: f64,
    /// The same defocus over the lens pupil (f / N), um.
    pub c4_um_over_lens_pupil: f64,
    /// Auto-exposure time, s.
    pub exposure_s: f64,
    /// R, G, B and luminance.
    pub channels: Vec<ChannelMtf>,
}

/// The thin-lens check of the paper's defocus values.
#[derive(Debug, Clone, Serialize)]
pub struct ThinLens {
    /// Lens pupil diameter f / N, mm.
    pub lens_pupil_mm: f64,
    /// c4 over the lens pupil for an object at 0.5 m with the focus at 0.3 m (thin lens), um.
    pub c4_geometry_um: f64,
    /// The paper's 3.5 um rescaled from the 8 mm to the lens pupil, um.
    pub c4_paper_defocused_um: f64,
    /// The paper's 1.225 um rescaled to the lens pupil, um.
    pub c4_paper_in_focus_um: f64,
    /// The thin-lens c4 rescaled to the 8 mm measurement pupil, um (compare with the paper's 3.5).
    pub geometry_c4_for_20cm_shift_over_8mm_um: f64,
}

/// Section 1 results.
#[derive(Debug, Clone, Serialize)]
pub struct OpticsResults {
    /// Sensor window, pixels.
    pub window_px: usize,
    /// Render samples per pixel pitch.
    pub oversampling: usize,
    /// Render samples per render pixel.
    pub samples_per_pixel: u32,
    /// Target distance, m.
    pub target_distance_m: f64,
    /// Pixel pitch, um.
    pub pixel_pitch_um: f64,
    /// Focal length, mm.
    pub focal_length_mm: f64,
    /// f-number.
    pub f_number: f64,
    /// In focus and focused at 30 cm.
    pub settings: Vec<FocusSetting>,
    /// Thin-lens check.
    pub thin_lens: ThinLens,
    /// Checks.
    pub checks: Vec<Check>,
    /// The real camera's measured MTF against the lens presets (with `--data` holding it).
    pub measured: Option<MeasuredMtfComparison>,
    /// Figures.
    pub figures: Vec<FigurePng>,
}

/// The measured in-focus MTF of a real Pixel 4a (ISET/isetcornellbox
/// `pixel4a-measured-mtf-in-focus.csv`, the curve of the paper's Figure 2a) beside the system MTF
/// of two lens presets at 550 nm: wavefront MTF x pixel aperture |sinc(f p)| (no render sampling:
/// the measurement is a real camera's).
#[derive(Debug, Clone, Serialize)]
pub struct MeasuredMtfComparison {
    /// The file.
    pub file: String,
    /// Measured frequencies, cycles/mm.
    pub freq_cyc_per_mm: Vec<f64>,
    /// Measured MTF (fraction).
    pub mtf: Vec<f64>,
    /// Measured MTF50, cycles/mm.
    pub mtf50_cyc_per_mm: Option<f64>,
    /// Per preset (`pixel4a`: the paper's lens; `pixel4a-measured`: fitted to this curve): name,
    /// model MTF at the measured frequencies, model MTF50 (cycles/mm), RMS difference up to
    /// 250 cycles/mm.
    pub presets: Vec<(String, Vec<f64>, Option<f64>, f64)>,
}

/// Colour of the real camera's curves in Figure 2a (orange, apart from the channels and luminance).
const MEASURED_COLOR: [u8; 3] = [230, 120, 0];

/// Name of the measured MTF file inside `--data`.
pub const MEASURED_MTF_FILE: &str = "pixel4a-measured-mtf-in-focus.csv";

fn measured_comparison(
    opts: &ValidateOptions,
    pitch_m: f64,
) -> Result<Option<MeasuredMtfComparison>> {
    let Some(dir) = opts.data_dir.as_deref() else {
        return Ok(None);
    };
    let path = dir.join(MEASURED_MTF_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let m = camsim_io::measurements::read_mtf_csv(&path)
        .map_err(|e| crate::ValidateError::invalid("optics", e.to_string()))?;
    let pitch_mm = pitch_m * 1e3;
    let system = |name: &str, f_mm: &[f64]| -> Result<Vec<f64>> {
        let wf = Optics::preset(name)?.wavefront_for(None, f64::INFINITY)?;
        let c = wf.mtf(550.0)?;
        let last = c.freq_cyc_per_mm.last().copied().unwrap_or(0.0);
        Ok(f_mm
            .iter()
            .map(|f| {
                if *f > last {
                    0.0
                } else {
                    interp(&c.freq_cyc_per_mm, &c.mtf_x, *f) * sinc(f * pitch_mm).abs()
                }
            })
            .collect())
    };
    let fine: Vec<f64> = (0..=400).map(|i| i as f64).collect();
    let mut presets = Vec::new();
    for name in ["pixel4a", "pixel4a-measured"] {
        let at = system(name, &m.freq_cyc_per_mm)?;
        let (mut sq, mut n) = (0.0, 0.0);
        for ((f, a), b) in m.freq_cyc_per_mm.iter().zip(&at).zip(&m.mtf) {
            if *f <= 250.0 {
                sq += (a - b) * (a - b);
                n += 1.0;
            }
        }
        let m50 = crossing(&fine, &system(name, &fine)?, 0.5);
        presets.push((
            name.to_string(),
            at,
            m50,
            if n > 0.0 { (sq / n).sqrt() } else { f64::NAN },
        ));
    }
    Ok(Some(MeasuredMtfComparison {
        file: path.display().to_string(),
        mtf50_cyc_per_mm: crossing(&m.freq_cyc_per_mm, &m.mtf, 0.5),
        freq_cyc_per_mm: m.freq_cyc_per_mm,
        mtf: m.mtf,
        presets,
    }))
}

use camsim_core::math::sinc;

/// The model MTF for spectral weights `w` (per band of `grid`) at frequencies `f_cyc_per_px`.
struct Model {
    /// Per band: (frequencies cycles/mm, MTF).
    curves: Vec<(Vec<f64>, Vec<f64>)>,
    pitch_mm: f64,
    oversampling: f64,
}

impl Model {
    fn eval(&self, weights: &[f64], f_cyc_per_px: f64) -> f64 {
        let f_mm = f_cyc_per_px / self.pitch_mm;
        let (mut num, mut den) = (0.0, 0.0);
        for (w, (fx, m)) in weights.iter().zip(&self.curves) {
            if *w <= 0.0 || fx.is_empty() {
                continue;
            }
            let v = if f_mm > *fx.last().unwrap() {
                0.0
            } else {
                interp(fx, m, f_mm)
            };
            num += w * v;
            den += w;
        }
        let optics = if den > 0.0 { num / den } else { 0.0 };
        // Pixel aperture (100 % fill factor) and the render grid's box + hold (module docs).
        optics * sinc(f_cyc_per_px).abs() * sinc(f_cyc_per_px / self.oversampling).powi(2)
    }
}

fn optics_config(c4_um: f64) -> Result<OpticsConfig> {
    let mut c = OpticsConfig::preset("pixel4a")?;
    c.wavefront = WavefrontConfig {
        zernike_um: ZernikeTerms::Terms(vec![ZernikeTerm { j: 4, c: c4_um }]),
        measurement_pupil_mm: Some(MEASUREMENT_PUPIL_MM),
        reference_wavelength_nm: 550.0,
        chromatic_defocus: None,
    };
    c.focus_distance_m = None;
    // The render already holds a margin around the window; keep its size.
    c.padding = Padding::None;
    Ok(c)
}

/// Run section 1.
pub(crate) fn run(
    opts: &ValidateOptions,
    p: &QualityParams,
    spectra: &BoxSpectra,
    st: &mut Stages,
) -> Result<OpticsResults> {
    let sensor_full = Sensor::preset("pixel4a")?;
    let pitch_m = sensor_full.pixel_pitch_m();
    let base = OpticsConfig::preset("pixel4a")?;
    let focal_m = base.focal_length_mm * 1e-3;
    let n = base.f_number;
    let win = p.edge_window_px;
    let k = p.edge_oversampling;
    let side_px = win + 2 * p.edge_margin_px;
    let render_px = side_px * k;
    // A 20 nm grid: the MTF varies slowly with wavelength and the target is neutral, so 16
    // bands carry the polychromatic MTF and halve the optics' cost.
    let grid = camsim_core::WavelengthGrid::new(p.grid.start_nm, p.grid.end_nm(), 20.0)?;

    // Render: the field of view of side_px sensor pixels seen from the image distance of 0.5 m,
    // so one render pixel is exactly pitch / k in the sensor plane.
    let radiance: SpectralImage = st.run("optics: render slanted edge", |prog| {
        let mut bo = BuiltinOptions {
            resolution: Some((render_px, render_px)),
            samples_per_pixel: p.edge_spp,
            target_distance_m: TARGET_DISTANCE_M,
            grid,
            seed: opts.seed,
            ..BuiltinOptions::default()
        };
        spectra.apply(&mut bo);
        let mut scene = builtin::scene("slanted-edge", &bo)?;
        // The pipeline's one rule: the lens sits at the image distance of the scene's focus.
        let v = camsim_pipeline::render::sensor_image_distance_m(&base, scene.focus_distance_m)
            .map_err(|e| crate::ValidateError::invalid("optics", e.to_string()))?;
        scene.camera.fov_deg =
            camsim_pipeline::render::field_of_view_deg(side_px as f64 * pitch_m, v);
        let out = camsim_render::render(&scene, prog)?;
        Ok(out.radiance)
    })?;

    // Spectral weights: the window's mean radiance spectrum x lambda (photon counting) x QE.
    let mean_l: Vec<f64> = (0..grid.len())
        .map(|b| radiance.band(b).iter().map(|v| *v as f64).sum::<f64>() / radiance.pixels() as f64)
        .collect();
    let qe = sensor_full.channel_qe(&grid);
    let mut weights: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            (0..grid.len())
                .map(|b| qe[c][b] * mean_l[b] * grid.wavelength_nm(b))
                .collect()
        })
        .collect();
    // Luminance of DN: sum_c a_c DN_c, DN_c proportional to sum_lambda w_c.
    weights.push(
        (0..grid.len())
            .map(|b| {
                (0..3)
                    .map(|c| LUMINANCE_WEIGHTS_REC709[c] * weights[c][b])
                    .sum()
            })
            .collect(),
    );

    let sensor = sensor_full.with_size(win, win)?;
    // ROI: every row but at most 128 columns around the centre, where the edge runs (it passes
    // through the window's centre; 5 degrees over 504 rows drifts +-22 px). A narrower ROI
    // keeps pixels far from the edge, which carry only noise, out of the LSF (ISO 12233 practice).
    let roi_cols = (win - 8).min(128);
    let roi = Rect::new(4, (win - roi_cols) / 2, win - 8, roi_cols);
    let labels = [
        "focused at 50 cm (c4 = 1.225 um over 8 mm)",
        "focused at 30 cm (c4 = 3.5 um over 8 mm)",
    ];
    let mut settings = Vec::new();
    for (i, c4) in PAPER_C4_UM.iter().enumerate() {
        let cfg = optics_config(*c4)?;
        let optics = Optics::from_config(&cfg)?;
        let name = if i == 0 {
            "optics: in focus"
        } else {
            "optics: focused at 30 cm"
        };
        let (frame, model) = st.run(name, |_| {
            let cap = Capture::auto().with_seed(opts.seed.wrapping_add(i as u64));
            let frame = camsim_pipeline::image_radiance(&radiance, &optics, &sensor, &cap)?.frame;
            // Model curves per band (object at 0.5 m, lens focused there; the defocus is the Zernike term).
            let wf = optics.wavefront_for(None, TARGET_DISTANCE_M)?;
            let curves: Vec<(Vec<f64>, Vec<f64>)> = (0..grid.len())
                .into_par_iter()
                .map(|b| {
                    wf.mtf(grid.wavelength_nm(b))
                        .map(|m| (m.freq_cyc_per_mm, m.mtf_x))
                })
                .collect::<std::result::Result<_, _>>()?;
            Ok((
                frame,
                Model {
                    curves,
                    pitch_mm: pitch_m * 1e3,
                    oversampling: k as f64,
                },
            ))
        })?;
        let raw = &frame.raw[0];
        let curves = slanted_edge_curves(raw, roi, pitch_m)?;
        let mut channels = Vec::new();
        for (ci, (name, s)) in ["R", "G", "B", "luminance"].iter().zip(&curves).enumerate() {
            channels.push(channel_mtf(name, s, &model, &weights[ci], pitch_m));
        }
        settings.push(FocusSetting {
            label: labels[i].to_string(),
            c4_um_over_8mm: *c4,
            c4_um_over_lens_pupil: lens::rescale_defocus(
                *c4,
                MEASUREMENT_PUPIL_MM / 2.0,
                focal_m / n * 1e3 / 2.0,
            ),
            exposure_s: frame.exposure_s,
            channels,
        });
    }

    let lens_pupil_mm = focal_m / n * 1e3;
    let c4_geometry_um =
        lens::defocus_c4_um(focal_m, n, DEFOCUS_FOCUS_DISTANCE_M, TARGET_DISTANCE_M);
    let thin_lens = ThinLens {
        lens_pupil_mm,
        c4_geometry_um,
        c4_paper_defocused_um: lens::rescale_defocus(
            PAPER_C4_UM[1],
            MEASUREMENT_PUPIL_MM / 2.0,
            lens_pupil_mm / 2.0,
        ),
        c4_paper_in_focus_um: lens::rescale_defocus(
            PAPER_C4_UM[0],
            MEASUREMENT_PUPIL_MM / 2.0,
            lens_pupil_mm / 2.0,
        ),
        geometry_c4_for_20cm_shift_over_8mm_um: lens::rescale_defocus(
            c4_geometry_um,
            lens_pupil_mm / 2.0,
            MEASUREMENT_PUPIL_MM / 2.0,
        ),
    };

    // Checks: in focus sharper in every channel; the raw-channel SFR follows the model.
    let mut checks = Vec::new();
    let mut all_sharper = true;
    let mut detail = Vec::new();
    for c in 0..4 {
        let a = settings[0].channels[c].mtf50_cyc_per_px.unwrap_or(f64::NAN);
        let b = settings[1].channels[c].mtf50_cyc_per_px.unwrap_or(0.0);
        all_sharper &= a > b;
        detail.push(format!(
            "{} {:.3} > {:.3}",
            settings[0].channels[c].channel, a, b
        ));
    }
    checks.push(Check {
        name: "MTF50 in focus above MTF50 focused at 30 cm (every channel)".into(),
        passed: all_sharper,
        detail: format!("{} cycles/pixel", detail.join(", ")),
    });
    let worst = settings
        .iter()
        .flat_map(|s| s.channels[..3].iter().map(|c| c.rms_difference_to_nyquist))
        .fold(0.0, f64::max);
    checks.push(Check {
        name: "raw-channel SFR matches the optics model up to the channel's Nyquist".into(),
        passed: worst < 0.05,
        detail: format!(
            "largest RMS difference {worst:.4} (< 0.05) over 0 < f <= 0.25 cycles/pixel"
        ),
    });
    let thin_ok = (thin_lens.c4_paper_defocused_um - thin_lens.c4_geometry_um).abs() < 0.1;
    checks.push(Check {
        name: "the paper's 3.5 um defocus agrees with thin-lens geometry of a 20 cm focus shift".into(),
        passed: thin_ok,
        detail: format!(
            "3.5 um over 8 mm = {:.3} um over the {:.2} mm lens pupil; thin lens (object 0.5 m, focus 0.3 m): {:.3} um",
            thin_lens.c4_paper_defocused_um, lens_pupil_mm, thin_lens.c4_geometry_um
        ),
    });

    let mut res = OpticsResults {
        window_px: win,
        oversampling: k,
        samples_per_pixel: p.edge_spp,
        target_distance_m: TARGET_DISTANCE_M,
        pixel_pitch_um: pitch_m * 1e6,
        focal_length_mm: focal_m * 1e3,
        f_number: n,
        settings,
        thin_lens,
        checks,
        measured: measured_comparison(opts, pitch_m)?,
        figures: Vec::new(),
    };
    res.figures = figures(opts, &res)?;
    Ok(res)
}

fn channel_mtf(
    name: &str,
    s: &SfrResult,
    model: &Model,
    weights: &[f64],
    pitch_m: f64,
) -> ChannelMtf {
    let freq = s.freq_cyc_per_sensor_px.clone();
    let model_at: Vec<f64> = freq.iter().map(|fr| model.eval(weights, *fr)).collect();
    let nyq = 0.5 / s.sample_pitch_sensor_px;
    let stats = |limit: f64| {
        let (mut sq, mut cnt, mut mx) = (0.0, 0.0, 0.0f64);
        for ((fr, a), b) in freq.iter().zip(&s.mtf).zip(&model_at) {
            if *fr > 0.0 && *fr <= limit + 1e-9 {
                sq += (a - b) * (a - b);
                cnt += 1.0;
                mx = mx.max((a - b).abs());
            }
        }
        (
            if cnt > 0.0 {
                (sq / cnt).sqrt()
            } else {
                f64::NAN
            },
            mx,
        )
    };
    let (rms, mx) = stats(nyq);
    let (rms_sensor, _) = stats(0.5);
    // Model MTF50 on a fine grid.
    let fine: Vec<f64> = (0..=1000).map(|i| i as f64 * 1e-3).collect();
    let fine_m: Vec<f64> = fine.iter().map(|fr| model.eval(weights, *fr)).collect();
    let model50 = crossing(&fine, &fine_m, 0.5);
    let per_mm = 1.0 / (pitch_m * 1e3);
    ChannelMtf {
        channel: name.to_string(),
        freq_cyc_per_px: freq,
        sfr: s.mtf.clone(),
        model: model_at,
        mtf50_cyc_per_px: s.mtf50_cyc_per_sensor_px,
        mtf50_cyc_per_mm: s.mtf50_cyc_per_sensor_px.map(|v| v * per_mm),
        model_mtf50_cyc_per_px: model50,
        model_mtf50_cyc_per_mm: model50.map(|v| v * per_mm),
        nyquist_cyc_per_px: nyq,
        rms_difference_to_nyquist: rms,
        max_difference_to_nyquist: mx,
        rms_difference_to_sensor_nyquist: rms_sensor,
        edge_angle_deg: s.edge_angle_deg,
    }
}

fn figures(opts: &ValidateOptions, r: &OpticsResults) -> Result<Vec<FigurePng>> {
    let mut out = Vec::new();
    for (i, s) in r.settings.iter().enumerate() {
        let mut fig = Figure::new(
            format!("Figure 2{}: {}", ['a', 'b'][i], s.label),
            "spatial frequency (cycles/pixel)",
            "MTF",
        )
        .ranges(Some((0.0, 0.5)), Some((0.0, 1.05)));
        for (ci, c) in s.channels.iter().enumerate() {
            let keep = |v: &Vec<f64>| -> Vec<f64> {
                v.iter()
                    .zip(&c.freq_cyc_per_px)
                    .filter(|(_, fr)| **fr <= 0.5 + 1e-9)
                    .map(|(x, _)| *x)
                    .collect()
            };
            let fx = keep(&c.freq_cyc_per_px);
            fig = fig.with(Series::xy(
                format!("{} SFR", c.channel),
                fx.clone(),
                keep(&c.sfr),
                Style::Line,
                CHANNEL_COLORS[ci],
            ));
            fig = fig.with(Series::xy(
                format!("{} model", c.channel),
                fx,
                keep(&c.model),
                Style::Dashed,
                CHANNEL_COLORS[ci],
            ));
        }
        let mut extra = String::new();
        if let (0, Some(m)) = (i, &r.measured) {
            // The real camera, in cycles per pixel (f [cycles/mm] x pitch [mm]).
            let px = r.pixel_pitch_um * 1e-3;
            let fx: Vec<f64> = m.freq_cyc_per_mm.iter().map(|f| f * px).collect();
            fig = fig.with(Series::xy(
                "measured Pixel 4a",
                fx.clone(),
                m.mtf.clone(),
                Style::Points,
                MEASURED_COLOR,
            ));
            if let Some((name, at, _, _)) = m.presets.iter().find(|p| p.0 == "pixel4a-measured") {
                fig = fig.with(Series::xy(
                    format!("{name} lens x pixel"),
                    fx,
                    at.clone(),
                    Style::Dashed,
                    MEASURED_COLOR,
                ));
            }
            extra = "; orange points: the measured MTF of a real Pixel 4a (isetcornellbox), orange dashed: the pixel4a-measured lens (fitted to it) x pixel aperture".into();
        }
        let file = format!("fig2{}_mtf.png", ['a', 'b'][i]);
        let caption = format!(
            "Figure 2{}: slanted-edge SFR (solid) of the simulated raw channels and demosaicked luminance, {}; dashed: optics model (wavefront MTF x pixel aperture x render sampling){extra}.",
            ['a', 'b'][i],
            s.label
        );
        out.push(save_png(&opts.out_dir, &file, &caption, fig.png()?)?);
    }
    Ok(out)
}

impl OpticsResults {
    /// Write the section into the report.
    pub fn report(&self, h: &mut Html) {
        h.h2("1. Optics: slanted-edge MTF (Figure 2)", "optics");
        h.p(&format!(
            "The built-in slanted-edge target (5 degrees, reflectances 0.05 / 0.9) at {} m, rendered for a {} x {} pixel window of the \
             Pixel 4a sensor ({} um pixels, {} mm f/{} lens) at {} render samples per pixel pitch and {} samples per render pixel. \
             Defocus as the paper: a Zernike c4 term over ISETCam's 8 mm measurement pupil. SFR: ISO 12233 e-SFR per raw CFA \
             channel (its own sub-grid) and on the luminance of the bilinearly demosaicked image.",
            self.target_distance_m, self.window_px, self.window_px, self.pixel_pitch_um, self.focal_length_mm, self.f_number,
            self.oversampling, self.samples_per_pixel
        ));
        for fg in &self.figures {
            h.figure(&fg.png, &fg.caption);
        }
        let mut rows = Vec::new();
        for s in &self.settings {
            for c in &s.channels {
                rows.push(vec![
                    s.label.clone(),
                    c.channel.clone(),
                    fo(c.mtf50_cyc_per_px, 4),
                    fo(c.mtf50_cyc_per_mm, 1),
                    fo(c.model_mtf50_cyc_per_px, 4),
                    fo(c.model_mtf50_cyc_per_mm, 1),
                    f(c.nyquist_cyc_per_px, 2),
                    f(c.rms_difference_to_nyquist, 4),
                    f(c.max_difference_to_nyquist, 4),
                    f(c.rms_difference_to_sensor_nyquist, 4),
                ]);
            }
        }
        h.table(
            &[
                "setting",
                "channel",
                "MTF50 (cyc/px)",
                "MTF50 (cyc/mm)",
                "model MTF50 (cyc/px)",
                "model MTF50 (cyc/mm)",
                "channel Nyquist (cyc/px)",
                "RMS(SFR - model) to channel Nyquist",
                "max |SFR - model|",
                "RMS to 0.5 cyc/px",
            ],
            &rows,
        );
        let t = &self.thin_lens;
        h.p(&format!(
            "Thin-lens check: the lens pupil is {:.3} mm. The paper's c4 = 3.5 um over 8 mm is {:.3} um over the lens pupil; thin-lens \
             geometry for a target at 0.5 m with the focus at 0.3 m gives {:.3} um (= {:.2} um over 8 mm). The in-focus c4 = 1.225 um \
             is {:.3} um over the lens pupil (a residual blur).",
            t.lens_pupil_mm, t.c4_paper_defocused_um, t.c4_geometry_um, t.geometry_c4_for_20cm_shift_over_8mm_um, t.c4_paper_in_focus_um
        ));
        h.p("The luminance SFR includes the bilinear demosaic's low-pass, which the model curve does not; its difference is reported, not checked.");
        if let Some(m) = &self.measured {
            let rows: Vec<Vec<String>> = m
                .presets
                .iter()
                .map(|(name, _, m50, rms)| {
                    vec![
                        name.clone(),
                        fo(*m50, 1),
                        fo(m.mtf50_cyc_per_mm, 1),
                        f(*rms, 4),
                    ]
                })
                .collect();
            h.p(&format!(
                "The real camera: the measured in-focus MTF of a Pixel 4a ({}) against the lens presets' system MTF at 550 nm \
                 (wavefront MTF x 1.4 um pixel aperture). The paper's lens (pixel4a) is sharper than the camera; pixel4a-measured \
                 carries the defocus and pixel crosstalk fitted to this curve (camsim fit mtf).",
                m.file
            ));
            h.table(
                &[
                    "lens preset",
                    "model MTF50 (cyc/mm)",
                    "measured MTF50 (cyc/mm)",
                    "RMS(model - measured), 0-250 cyc/mm",
                ],
                &rows,
            );
        }
    }
}

/// The SFR curves R, G, B and luminance of a raw slanted-edge frame in `roi` (sensor pixels of
/// `pitch_m`): the application layer's measurement (`camsim_pipeline::measure::sfr`, the one
/// `camsim analyze sfr` and Python's `camsim.sfr` run), in that order.
pub fn slanted_edge_curves(
    raw: &camsim_core::RawImage,
    roi: Rect,
    pitch_m: f64,
) -> Result<Vec<SfrResult>> {
    use camsim_pipeline::measure::sfr::{measure_sfr, SfrImage, SfrRequest};
    let report = measure_sfr(
        &SfrImage::Raw(raw.clone()),
        &SfrRequest {
            roi: Some(roi),
            pixel_pitch_mm: Some(pitch_m * 1e3),
            label: "slanted edge".into(),
            ..SfrRequest::default()
        },
    )?;
    Ok(report.curves.into_iter().map(|c| c.result).collect())
}
