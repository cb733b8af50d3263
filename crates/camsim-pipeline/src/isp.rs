//! Stage 4 as a value: [`Isp`], ISETCam's `ip` (`ipCreate` / `ipCompute`): how a raw frame
//! becomes a display image (demosaic, white balance, colour matrix, sRGB), with
//! [`Isp::compute`]. `camsim simulate`'s preview, `camsim isp`, the DNG colour metadata of
//! `camsim sensor` and `camsim validate`'s previews all come from it, so one raw with one set of
//! settings gives one preview whichever command made it.

use crate::{PipelineError, Result, SimulateConfig};
use camsim_analysis::chart::{chart_patch_stats_rgb, ChartCorners};
use camsim_analysis::Plane;
use camsim_core::{RawImage, Spectrum, WavelengthGrid};
use camsim_io::dng::DngMetadata;
use camsim_isp::ccm::{self, CcmObjective};
use camsim_isp::cfa_render::{self, CfaFamily, ChannelTransform, RcccClear};
use camsim_isp::defect_correction::{self, DefectCorrection, DEFECT_DETECTION_SIGMAS};
use camsim_isp::denoise::{self, Denoise, NoiseModel};
use camsim_isp::line_noise::{ColumnCorrection, LineOffsets};
use camsim_isp::output::DisplayModel;
use camsim_isp::sharpen::UnsharpMask;
use camsim_isp::tone::{ToneCurve, ToneMap};
use camsim_isp::unprocess::{self, Unprocess};
use camsim_isp::white_balance::{self, WHITE_PATCH_PERCENTILE};
use camsim_isp::{BlackModel, ColorPipeline, DemosaicMethod, Mat3, RgbImage, WhiteBalanceMethod};
use camsim_sensor::Sensor;
use serde::Serialize;
use std::borrow::Cow;

/// Where the colour matrix comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum CcmSource {
    /// Fitted by least squares on the ColorChecker from the sensor's QE under the illuminant
    /// (white balance and Bradford adaptation to D65 included; no image data).
    Qe,
    /// Fitted on the ColorChecker photographed in the image: the 24 patch means after white
    /// balance against the chart's XYZ under D65.
    Chart {
        /// The chart's four outer corners in the image.
        corners: ChartCorners,
        /// What the fit minimises.
        objective: CcmObjective,
        /// The 24 patch reflectances of the photographed chart (None: N. Ohta's ColorChecker).
        reflectances: Option<Vec<Spectrum>>,
    },
}

/// ISETCam's image processor as a value. [`Isp::new`] is the paper's: bilinear demosaic, white
/// balance from the known illuminant, colour matrix from the sensor's QE.
#[derive(Debug, Clone, PartialEq)]
pub struct Isp {
    /// Demosaicking method (Bayer frames; other CFAs take their own, see [`Isp::demosaic`]).
    pub demosaic: DemosaicMethod,
    /// White balance.
    pub white_balance: WhiteBalanceMethod,
    /// Percentile of R+G+B above which pixels count as white ([`WhiteBalanceMethod::WhitePatch`]).
    pub white_patch_percentile: f64,
    /// Colour matrix.
    pub ccm: CcmSource,
    /// The scene illuminant (relative SPD): the white balance of
    /// [`WhiteBalanceMethod::Illuminant`] and the QE colour fit.
    pub illuminant: Spectrum,
    /// The wavelength grid of the QE colour fit.
    pub grid: WavelengthGrid,
    /// Bin 2x2 same-filter blocks first (Quad Bayer -> Bayer at half the size, 4x the signal).
    pub bin_2x2: bool,
    /// Camera values are multiplied by this before the colour matrix (None: the 99th percentile
    /// of the adapted luminance at 0.9 of the white, `ColorPipeline::auto_exposure_scale`;
    /// the chart matrix takes 1).
    pub exposure_scale: Option<f64>,
    /// How an RCCC frame's clear channel is filled at the R sites
    /// ([`camsim_isp::cfa_render::RcccClear`]: ISETCam's analog kernel or edge-aware).
    pub rccc_clear: RcccClear,
    /// The preview's tone curve (RGB CFAs; [`camsim_isp::tone`]): `Clip` (the default) or, for
    /// HDR frames, `Reinhard` / `Filmic`, which also set the exposure (the log-average at the
    /// key 0.18) unless `exposure_scale` is given.
    pub tone_map: ToneMap,
    /// Defect-pixel correction on the raw (first of all steps; [`camsim_isp::defect_correction`]):
    /// off (the default), the sensor's defect list, or detection at `defect_sigmas`.
    pub defect_correction: DefectCorrection,
    /// Detection threshold of [`DefectCorrection::Detect`], robust sigmas of the residual from
    /// the same-filter median.
    pub defect_sigmas: f64,
    /// Column and row noise correction on the raw (before the defect correction;
    /// [`camsim_isp::line_noise`]): off (the default) or the sensor's fixed dark frame.
    pub column_correction: ColumnCorrection,
    /// Column and row offsets measured on a dark frame ([`LineOffsets::from_dark_raw`]): when
    /// given they are subtracted whatever `column_correction` says.
    pub dark_offsets: Option<LineOffsets>,
    /// Denoising of the raw after the corrections ([`camsim_isp::denoise`]): off (the default) or
    /// non-local means per CFA sub-lattice with the sensor's noise model.
    pub denoise: Denoise,
    /// Strength of the denoising: h = 0.4 x strength x sigma (1: 'auto', sigma from the sensor's
    /// shot and read noise).
    pub denoise_strength: f64,
    /// Lens-shading correction of the raw after the denoising, before the demosaic
    /// ([`camsim_isp::shading_correction`]): each pixel divided by the relative illumination
    /// of its filter in this flat-field fit (`camsim fit-shading`; None: no correction).
    pub lens_shading: Option<std::sync::Arc<camsim_optics::shading::ShadingFit>>,
    /// Unsharp mask on the demosaicked camera RGB (RGB CFAs; None: no sharpening).
    pub sharpen: Option<UnsharpMask>,
    /// JPEG quality of [`Isp::jpeg`] (1-100; None: the integrator's default for a JPEG output).
    pub jpeg_quality: Option<u8>,
}

/// Default IJG quality of [`Isp::jpeg`] when [`Isp::jpeg_quality`] is not given.
pub const DEFAULT_JPEG_QUALITY: u8 = 90;

/// What [`Isp::compute`] returns.
#[derive(Debug, Clone)]
pub struct IspOutput {
    /// The demosaicked camera RGB, DN above black (before white balance).
    pub rgb: RgbImage,
    /// The 8-bit sRGB image.
    pub preview: crate::Rgb8Image,
    /// The settings and fitted values (`camsim isp --json`).
    pub report: IspReport,
}

/// The fitted values of one [`Isp::compute`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IspReport {
    /// Demosaicking method.
    pub demosaic: &'static str,
    /// White-balance method.
    pub white_balance: &'static str,
    /// Gains applied per channel (green = 1).
    pub white_balance_gains: [f64; 3],
    /// QE colour matrix: camera -> linear sRGB (illuminant white balance included).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_to_linear_srgb: Option<Mat3>,
    /// Chart colour matrix: what it minimised.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ccm_objective: Option<String>,
    /// Chart colour matrix: white-balanced camera -> XYZ (D65).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_to_xyz: Option<Mat3>,
    /// Chart colour matrix: the 24 patch means (white-balanced camera RGB), patches 1-24.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub patch_camera_rgb: Option<Vec<[f64; 3]>>,
    /// Chart colour matrix: CIEDE2000 of each patch after the matrix, patches 1-24.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub patch_delta_e2000: Option<Vec<f64>>,
    /// Chart colour matrix: mean CIEDE2000.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_e2000_mean: Option<f64>,
    /// Chart colour matrix: largest CIEDE2000.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_e2000_max: Option<f64>,
    /// The exposure scale used (see [`Isp::exposure_scale`]): linear sRGB = scale x the colour
    /// matrix x camera DN above black; `camsim isp --exposure-scale` takes it back.
    pub exposure_scale: f64,
    /// The ISP path the frame's CFA took ([`CfaFamily`]: rgb, rgbw, monochrome, rccc,
    /// multichannel).
    pub cfa_family: &'static str,
    /// The tone curve of the preview ([`Isp::tone_map`]: clip, reinhard, filmic).
    pub tone_map: &'static str,
    /// Multichannel CFAs: the channels (filter names) of `channel_to_linear_srgb`'s columns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channels: Option<Vec<String>>,
    /// Multichannel CFAs: the fitted 3 x N matrix, channels (white largest = 1) -> linear sRGB,
    /// rows R, G, B ([`ChannelTransform`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channel_to_linear_srgb: Option<[Vec<f64>; 3]>,
    /// Multichannel CFAs: CIEDE2000 of the fit on the 24 ColorChecker patches (the sensor's QE
    /// under the illuminant; no image data), mean and max.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channel_fit_delta_e2000: Option<[f64; 2]>,
}

impl IspReport {
    /// A report of the settings alone: `gains`, `exposure_scale`, the CFA path and tone curve,
    /// and no fitted matrix (the ISP fills in what its path fits).
    fn settings(
        demosaic: &'static str,
        white_balance: &'static str,
        gains: [f64; 3],
        exposure_scale: f64,
        cfa_family: CfaFamily,
        tone_map: ToneMap,
    ) -> IspReport {
        IspReport {
            demosaic,
            white_balance,
            white_balance_gains: gains,
            camera_to_linear_srgb: None,
            ccm_objective: None,
            camera_to_xyz: None,
            patch_camera_rgb: None,
            patch_delta_e2000: None,
            delta_e2000_mean: None,
            delta_e2000_max: None,
            exposure_scale,
            cfa_family: cfa_family.name(),
            tone_map: tone_map.name(),
            channels: None,
            channel_to_linear_srgb: None,
            channel_fit_delta_e2000: None,
        }
    }
}

impl Isp {
    /// The paper's ISP for a scene under `illuminant`, the colour fit on `grid`.
    pub fn new(illuminant: Spectrum, grid: WavelengthGrid) -> Isp {
        Isp {
            demosaic: DemosaicMethod::Bilinear,
            white_balance: WhiteBalanceMethod::Illuminant,
            white_patch_percentile: WHITE_PATCH_PERCENTILE,
            ccm: CcmSource::Qe,
            illuminant,
            grid,
            bin_2x2: false,
            exposure_scale: None,
            rccc_clear: RcccClear::default(),
            tone_map: ToneMap::Clip,
            defect_correction: DefectCorrection::Off,
            defect_sigmas: DEFECT_DETECTION_SIGMAS,
            column_correction: ColumnCorrection::Off,
            dark_offsets: None,
            denoise: Denoise::Off,
            denoise_strength: 1.0,
            lens_shading: None,
            sharpen: None,
            jpeg_quality: None,
        }
    }

    /// The ISP of a simulate config: the scene's illuminant (D65 when the scene has none, such
    /// as a 3D scene or a radiance file) on the config's wavelength grid.
    pub fn for_config(cfg: &SimulateConfig) -> Result<Isp> {
        let illuminant = match cfg.scene.as_ref().and_then(camsim_scene::scene_illuminant) {
            Some(r) => r?,
            None => camsim_core::tables::illuminant("D65")?,
        };
        Isp::new(illuminant, cfg.wavelengths).with_section(&cfg.isp)
    }

    /// This ISP with the steps an `[isp]` table sets (tone curve, column and defect correction,
    /// denoising, lens-shading correction, sharpening, JPEG quality); keys it leaves out keep
    /// their defaults. The one reading of `[isp]` for configs and for Python's `isp(...,
    /// steps=...)`. Errors name a shading file that cannot be read.
    pub fn with_section(self, i: &crate::config::IspSection) -> Result<Isp> {
        let lens_shading = match &i.lens_shading {
            Some(p) => Some(std::sync::Arc::new(
                camsim_optics::shading::ShadingFit::from_file(p)
                    .map_err(|e| PipelineError::config(format!("isp.lens_shading: {e}")))?,
            )),
            None => None,
        };
        Ok(Isp {
            lens_shading,
            tone_map: i.tone_map.unwrap_or_default(),
            defect_correction: i.defect_correction.unwrap_or_default(),
            defect_sigmas: i.defect_sigmas.unwrap_or(self.defect_sigmas),
            column_correction: i.column_correction.unwrap_or_default(),
            denoise: i.denoise.unwrap_or_default(),
            denoise_strength: i.denoise_strength.unwrap_or(self.denoise_strength),
            sharpen: i.sharpen,
            jpeg_quality: i.jpeg_quality,
            ..self
        })
    }

    /// The QE colour pipeline of `sensor` under the ISP's illuminant (the matrix of
    /// [`CcmSource::Qe`], the DNG's ColorMatrix1 and AsShotNeutral).
    pub fn color(&self, sensor: &Sensor) -> Result<ColorPipeline> {
        ColorPipeline::fit(&sensor.channel_qe(&self.grid), &self.grid, &self.illuminant)
            .map_err(|e| PipelineError::config(format!("colour pipeline: {e}")))
    }

    /// DNG metadata: camera name, the QE colour matrix and neutral of [`Isp::color`] (r, g, b
    /// CFAs only: Bayer, Quad Bayer, RGBW), the ISO
    /// of a sensor that states one, and `description` (a run's config) as the image description.
    pub fn dng_metadata(
        &self,
        sensor: &Sensor,
        description: Option<String>,
    ) -> Result<DngMetadata> {
        // The 3x3 ColorMatrix1 and AsShotNeutral are of r, g, b cameras; a monochrome, RCCC or
        // multichannel DNG carries none (its ISP fits its own transform).
        let rgb = matches!(
            CfaFamily::of(&sensor.cfa_layout()),
            CfaFamily::Rgb | CfaFamily::Rgbw
        );
        let color = if rgb { Some(self.color(sensor)?) } else { None };
        Ok(DngMetadata {
            camera_model: format!("camsim {}", sensor.name()),
            color_matrix1: color.as_ref().map(|c| c.xyz_to_camera()),
            as_shot_neutral: color.as_ref().map(|c| c.as_shot_neutral()),
            description,
            // Only a sensor that states its ISO (`iso`) gets the EXIF tag: the DNGs of the other
            // presets stay byte-identical.
            iso: sensor.config().iso,
            ..DngMetadata::default()
        })
    }

    /// RGB of a raw frame, DN above black: a Bayer mosaic with [`Isp::demosaic`]; a tile with
    /// r, g, b and w filters by the W-guided fusion (`camsim_isp::cfa_general::rgbw_to_rgb`), W
    /// predicted from R, G, B with weights fitted to `sensor`'s QE under the frame's CFA; any
    /// other tile with r, g, b filters by the per-filter bilinear interpolation (which is the only
    /// method such frames take).
    pub fn demosaic(&self, raw: &RawImage, sensor: &Sensor) -> Result<RgbImage> {
        let Some(layout) = raw.layout.as_ref() else {
            return Ok(camsim_isp::demosaic(raw, self.demosaic)?);
        };
        if let Some(p) = layout.as_bayer() {
            let mut bayer = raw.clone();
            (bayer.cfa, bayer.layout) = (p, None);
            return Ok(camsim_isp::demosaic(&bayer, self.demosaic)?);
        }
        if self.demosaic != DemosaicMethod::Bilinear {
            return Err(PipelineError::config(format!(
                "demosaic {}: a {} frame takes the bilinear method only (or bin Quad Bayer 2x2 first)",
                self.demosaic.name(),
                layout.name()
            )));
        }
        if CfaFamily::of(layout) == CfaFamily::Rgbw {
            let weights = frame_sensor(sensor, layout)?.filter_from_rgb_weights("w")?;
            return Ok(camsim_isp::cfa_general::rgbw_to_rgb(raw, weights)?);
        }
        Ok(camsim_isp::cfa_general::demosaic_any(raw)?)
    }

    /// The whole ISP on one raw frame made by `sensor` (whose QE sets the illuminant white
    /// balance and the QE colour matrix): bin, demosaic, then [`Isp::render`].
    pub fn compute(&self, raw: &RawImage, sensor: &Sensor) -> Result<IspOutput> {
        self.compute_scaled(raw, sensor, 1.0)
    }

    /// [`Isp::compute`] of a frame whose DN are `noise_scale` x the DN `sensor` reads (an HDR
    /// sensor's merged frame as a 16-bit mosaic, [`camsim_sensor::HdrModel::merged_raw16`]): the
    /// sensor's noise at black, which the censored-black correction needs, scaled alike.
    pub fn compute_scaled(
        &self,
        raw: &RawImage,
        sensor: &Sensor,
        noise_scale: f64,
    ) -> Result<IspOutput> {
        let raw = self.correct_raw(raw, sensor, noise_scale)?;
        let raw: Cow<RawImage> = if self.bin_2x2 {
            Cow::Owned(camsim_isp::cfa_general::bin_2x2(&raw)?)
        } else {
            raw
        };
        let family = CfaFamily::of(&raw.cfa_layout());
        if !matches!(family, CfaFamily::Rgb | CfaFamily::Rgbw) {
            return self.compute_other(&raw, sensor, family);
        }
        let mut rgb = self.demosaic(&raw, sensor)?;
        if let Some(usm) = &self.sharpen {
            rgb = usm
                .apply(&rgb)
                .map_err(|e| PipelineError::config(format!("isp.sharpen: {e}")))?;
        }
        // Binning sums four pixels: twice the noise of one, and a sum of clipped values is not a
        // clipped Gaussian (no censored-black correction).
        let black = if self.bin_2x2 {
            RawBlack {
                noise_factor: 2.0 * noise_scale,
                clip_dn: None,
            }
        } else {
            RawBlack {
                noise_factor: noise_scale,
                clip_dn: Some(-raw.black_level_dn),
            }
        };
        let (preview, mut report) = self.render(
            &rgb,
            sensor,
            raw.white_level_dn - raw.black_level_dn,
            &black,
        )?;
        report.cfa_family = family.name();
        Ok(IspOutput {
            rgb,
            preview,
            report,
        })
    }

    /// The raw-domain steps, in order: column and row noise correction (`dark_offsets`, or
    /// the sensor's fixed dark frame with [`ColumnCorrection::Sensor`], except on a merged HDR
    /// frame, `noise_scale` != 1, whose merge subtracted it already), defect correction
    /// ([`Isp::defect_correction`]), denoising ([`Isp::denoise`], the sensor's noise model
    /// scaled by `noise_scale` as in [`Isp::compute_scaled`]) and lens-shading correction
    /// ([`Isp::lens_shading`]: last, since it scales the noise the denoiser models). The frame
    /// itself when all are off.
    pub fn correct_raw<'a>(
        &self,
        raw: &'a RawImage,
        sensor: &Sensor,
        noise_scale: f64,
    ) -> Result<Cow<'a, RawImage>> {
        let mut raw: Cow<RawImage> = Cow::Borrowed(raw);
        let offsets = match (&self.dark_offsets, self.column_correction) {
            (Some(o), _) => Some(Cow::Borrowed(o)),
            // A merged HDR frame (noise_scale != 1) had the dark frame subtracted by the merge.
            (None, ColumnCorrection::Sensor) if noise_scale == 1.0 => {
                if (sensor.rows(), sensor.cols()) != (raw.rows, raw.cols) {
                    return Err(PipelineError::config(format!(
                        "isp.column_correction = \"sensor\": the frame is {} x {}, the sensor {} x {}",
                        raw.rows,
                        raw.cols,
                        sensor.rows(),
                        sensor.cols()
                    )));
                }
                let dark = sensor.fixed_offset_dn()?;
                Some(Cow::Owned(LineOffsets::from_dark(
                    &dark, raw.rows, raw.cols, true,
                )?))
            }
            (None, _) => None,
        };
        if let Some(o) = offsets {
            raw = Cow::Owned(
                o.subtract(&raw)
                    .map_err(|e| PipelineError::config(format!("isp.column_correction: {e}")))?,
            );
        }
        match self.defect_correction {
            DefectCorrection::Off => {}
            DefectCorrection::Sensor => {
                let list: Vec<(usize, usize)> = sensor
                    .defect_list()
                    .iter()
                    .map(|d| (d.row, d.col))
                    .collect();
                if !list.is_empty() {
                    raw = Cow::Owned(defect_correction::correct_defects(&raw, &list).map_err(
                        |e| PipelineError::config(format!("isp.defect_correction: {e}")),
                    )?);
                }
            }
            DefectCorrection::Detect => {
                let (fixed, _) = defect_correction::detect_and_correct(&raw, self.defect_sigmas)
                    .map_err(|e| PipelineError::config(format!("isp.defect_sigmas: {e}")))?;
                raw = Cow::Owned(fixed);
            }
        }
        if self.denoise == Denoise::Nlm {
            let noise = self.noise_model(sensor, noise_scale);
            raw = Cow::Owned(
                denoise::nlm_raw(&raw, &noise, self.denoise_strength)
                    .map_err(|e| PipelineError::config(format!("isp.denoise_strength: {e}")))?,
            );
        }
        if let Some(fit) = &self.lens_shading {
            let gains = fit.correction_gains(raw.rows, raw.cols, &raw.cfa_layout());
            raw = Cow::Owned(
                camsim_isp::shading_correction::correct_shading(&raw, &gains)
                    .map_err(|e| PipelineError::config(format!("isp.lens_shading: {e}")))?,
            );
        }
        Ok(raw)
    }

    /// The sensor's noise model in the frame's DN ([`NoiseModel`]): K and the noise at black
    /// (read, DSNU, quantization), for a frame whose DN are `noise_scale` x the sensor's
    /// (variance noise_scale K v + (noise_scale floor)^2).
    pub fn noise_model(&self, sensor: &Sensor, noise_scale: f64) -> NoiseModel {
        NoiseModel {
            k_dn_per_e: sensor.k_dn_per_e() * noise_scale,
            floor_dn: sensor.predicted_noise_dn(0.0, 0.0).total * noise_scale,
        }
    }

    /// The JPEG bytes of a preview at [`Isp::jpeg_quality`] (default [`DEFAULT_JPEG_QUALITY`]).
    pub fn jpeg(&self, preview: &crate::Rgb8Image) -> Result<Vec<u8>> {
        let q = self.jpeg_quality.unwrap_or(DEFAULT_JPEG_QUALITY);
        camsim_isp::jpeg::encode_jpeg(preview.rows, preview.cols, &preview.data, q)
            .map_err(|e| PipelineError::config(format!("isp.jpeg_quality: {e}")))
    }

    /// What [`Isp::unprocess`] undoes for a preview this ISP rendered with `report` (its
    /// colour matrix, white balance and exposure) from a frame of `sensor`.
    pub fn unprocess_params(&self, sensor: &Sensor, report: &IspReport) -> Result<Unprocess> {
        let tone = match self.tone_map {
            ToneMap::Clip => ToneCurve::Clip,
            ToneMap::Filmic => ToneCurve::Filmic,
            ToneMap::Reinhard => {
                return Err(PipelineError::config(
                    "unprocess: the reinhard tone curve's white level is fitted per image and not reported; unprocess takes clip or filmic",
                ))
            }
        };
        let (m, gains) = match &self.ccm {
            CcmSource::Qe => {
                let m = report.camera_to_linear_srgb.ok_or_else(|| {
                    PipelineError::config(
                        "unprocess: the report holds no colour matrix (an RGB CFA's preview is needed)",
                    )
                })?;
                let gains = if self.white_balance == WhiteBalanceMethod::Illuminant {
                    [1.0; 3]
                } else {
                    // render(): camera values scaled by as_shot_neutral x gains before the matrix.
                    let asn = self.color(sensor)?.as_shot_neutral();
                    let g = report.white_balance_gains;
                    [asn[0] * g[0], asn[1] * g[1], asn[2] * g[2]]
                };
                (m, gains)
            }
            CcmSource::Chart { .. } => {
                let xyz = report.camera_to_xyz.ok_or_else(|| {
                    PipelineError::config("unprocess: the report holds no chart colour matrix")
                })?;
                let to_srgb = DisplayModel::srgb().xyz_to_rgb()?;
                (
                    camsim_isp::color::mat3_mul(&to_srgb, &xyz),
                    report.white_balance_gains,
                )
            }
        };
        Ok(Unprocess {
            camera_to_linear_srgb: m,
            white_balance_gains: gains,
            exposure_scale: report.exposure_scale,
            tone,
        })
    }

    /// The inverse ISP (Brooks et al. 2019, [`camsim_isp::unprocess`]): an 8-bit sRGB image ->
    /// the linear mosaic of `sensor`'s CFA, DN above black, row-major, with the colour matrix,
    /// white balance and exposure of `report` (this ISP's [`Isp::compute`] of a frame of
    /// `sensor`). Expected electrons are these / `sensor.k_dn_per_e()`.
    pub fn unprocess(
        &self,
        image: &crate::Rgb8Image,
        sensor: &Sensor,
        report: &IspReport,
    ) -> Result<Vec<f32>> {
        let p = self.unprocess_params(sensor, report)?;
        Ok(p.mosaic_dn(image.rows, image.cols, &image.data, &sensor.cfa_layout())?)
    }

    /// [`Isp::unprocess`] with the sensor's temporal noise: Poisson electrons (DN / K), its read
    /// noise, black level, white level and ADC ([`camsim_isp::unprocess::add_sensor_noise`];
    /// the fixed patterns are not added), seeded by `seed`: a training raw of the image's size.
    pub fn unprocess_raw(
        &self,
        image: &crate::Rgb8Image,
        sensor: &Sensor,
        report: &IspReport,
        exposure_s: f64,
        seed: u64,
    ) -> Result<RawImage> {
        let dn = self.unprocess(image, sensor, report)?;
        self.noisy_raw(&dn, image.rows, image.cols, sensor, exposure_s, seed)
    }

    /// A linear mosaic `dn` (DN above black) with `sensor`'s temporal noise, levels and ADC.
    fn noisy_raw(
        &self,
        dn: &[f32],
        rows: usize,
        cols: usize,
        sensor: &Sensor,
        exposure_s: f64,
        seed: u64,
    ) -> Result<RawImage> {
        let k = sensor.k_dn_per_e();
        let electrons = unprocess::dn_to_electrons(dn, k)?;
        let layout = sensor.cfa_layout();
        let mut like = RawImage::new(rows, cols, sensor.cfa(), sensor.bits())?;
        if layout.as_bayer().is_none() {
            like.layout = Some(layout);
        }
        like.black_level_dn = sensor.black_level_dn();
        like.white_level_dn = sensor.max_dn() as f64;
        like.exposure_s = exposure_s;
        like.pixel_pitch_m = sensor.pixel_pitch_m();
        let read_dn = sensor.predicted_noise_dn(0.0, 0.0).read;
        Ok(unprocess::add_sensor_noise(
            &electrons, &like, k, read_dn, seed,
        )?)
    }

    /// The inverse ISP of a photo this ISP's settings would have rendered, without the frame
    /// that made it: the colour matrix from `sensor`'s QE under the illuminant, white balance
    /// `illuminant` or `none` (gray world and white patch fit their gains to a frame, which a
    /// photo does not have), the tone curve clip or filmic, and the exposure scale
    /// [`Isp::exposure_scale`], or when it is `None` the scale that puts the photo's white
    /// (255, 255, 255) at `sensor`'s saturation in its largest camera channel.
    pub fn photo_unprocess_params(&self, sensor: &Sensor) -> Result<Unprocess> {
        if let CcmSource::Chart { .. } = self.ccm {
            return Err(PipelineError::config(
                "unprocess: a colour matrix fitted on a photographed chart needs that frame; unprocessing a photo takes the QE matrix",
            ));
        }
        if matches!(
            self.white_balance,
            WhiteBalanceMethod::GrayWorld | WhiteBalanceMethod::WhitePatch
        ) {
            return Err(PipelineError::config(format!(
                "unprocess: white balance {} fits its gains to the frame, which a photo does not carry; give illuminant or none",
                self.white_balance.name()
            )));
        }
        let report = IspReport {
            camera_to_linear_srgb: Some(self.color(sensor)?.camera_to_srgb()),
            ..IspReport::settings(
                self.demosaic.name(),
                self.white_balance.name(),
                [1.0; 3],
                self.exposure_scale.unwrap_or(1.0),
                CfaFamily::Rgb,
                self.tone_map,
            )
        };
        let mut p = self.unprocess_params(sensor, &report)?;
        if self.exposure_scale.is_none() {
            // Display white decoded and untoned, through M^-1 and the gains at scale 1: camera
            // DN_c = (M^-1 v)_c / (scale g_c) (the forward render, camsim_isp::unprocess).
            let v = unprocess::inverse_tone(p.tone, 1.0);
            let inv = camsim_isp::color::mat3_inverse(&p.camera_to_linear_srgb)
                .ok_or_else(|| PipelineError::config("unprocess: the colour matrix is singular"))?;
            let cam = camsim_core::colorimetry::mat3_mul_vec(&inv, [v; 3]);
            let peak = (0..3)
                .map(|c| cam[c] / p.white_balance_gains[c])
                .fold(0.0, f64::max);
            let saturation_dn = sensor.max_dn() as f64 - sensor.black_level_dn();
            if !(peak > 0.0 && peak.is_finite() && saturation_dn > 0.0) {
                return Err(PipelineError::config(
                    "unprocess: the photo's white maps to no positive camera value; give --exposure-scale",
                ));
            }
            p.exposure_scale = peak / saturation_dn;
        }
        Ok(p)
    }

    /// A training raw of `sensor` from an 8-bit sRGB photo (Brooks et al. 2019): the inverse of
    /// [`Isp::photo_unprocess_params`], mosaicked to the sensor's CFA (r, g, b filters only), then
    /// the sensor's temporal noise seeded by `seed` ([`Isp::unprocess_raw`]). The raw has the
    /// photo's size; returned with the inverse it used (its exposure scale renders the raw back).
    pub fn unprocess_photo(
        &self,
        image: &crate::Rgb8Image,
        sensor: &Sensor,
        exposure_s: f64,
        seed: u64,
    ) -> Result<(RawImage, Unprocess)> {
        let p = self.photo_unprocess_params(sensor)?;
        let dn = p.mosaic_dn(image.rows, image.cols, &image.data, &sensor.cfa_layout())?;
        let raw = self.noisy_raw(&dn, image.rows, image.cols, sensor, exposure_s, seed)?;
        Ok((raw, p))
    }

    /// The ISP of a frame whose CFA is not an RGB one (`camsim_isp::cfa_render`): monochrome (a
    /// grey image of the DN above black, no demosaic), RCCC ((red x gain, clear, clear): the
    /// clear channel interpolated at the R sites by [`Isp::rccc_clear`], red by the per-filter
    /// bilinear, the gain from the illuminant and `sensor`'s QE, gray world or none) and
    /// multichannel (every channel bilinear, then a 3 x N matrix to linear sRGB fitted on the
    /// ColorChecker from `sensor`'s QE of the frame's filters under the illuminant: white
    /// balance 'illuminant' only). Then the exposure scale and the sRGB encoding, highlights
    /// clipped at the saturation (multichannel: each channel at its white's share of it, so
    /// clipped highlights render neutral). Bilinear demosaic and the QE colour
    /// matrix only (`--ccm chart` needs an RGB CFA).
    fn compute_other(
        &self,
        raw: &RawImage,
        sensor: &Sensor,
        family: CfaFamily,
    ) -> Result<IspOutput> {
        let layout = raw.cfa_layout();
        let refuse = |what: String| {
            PipelineError::config(format!(
                "{what}: a {} frame (CFA {}) does not take it",
                family.name(),
                layout.name()
            ))
        };
        if self.demosaic != DemosaicMethod::Bilinear {
            return Err(refuse(format!(
                "demosaic {} (it takes bilinear)",
                self.demosaic.name()
            )));
        }
        if !matches!(self.ccm, CcmSource::Qe) {
            return Err(refuse(
                "the colour matrix from the photographed chart (--ccm chart needs an RGB CFA)"
                    .into(),
            ));
        }
        let saturation_dn = raw.white_level_dn - raw.black_level_dn;
        let mut gains = [1.0; 3];
        let mut report_demosaic = "none (monochrome)";
        let mut transform = None;
        let (rgb, clip) = match family {
            CfaFamily::Monochrome => (cfa_render::mono_rgb(raw)?, Some(saturation_dn)),
            CfaFamily::Rccc => {
                let red_gain = match self.white_balance {
                    WhiteBalanceMethod::None => 1.0,
                    WhiteBalanceMethod::Illuminant => {
                        let s = frame_sensor(sensor, &layout)?;
                        let qe = filter_qe_on(&s, &self.grid);
                        let (r, w) = (
                            layout.filter_index("r").unwrap_or(0),
                            layout.filter_index("w").unwrap_or(1),
                        );
                        cfa_render::rccc_red_gain(&qe[r], &qe[w], &self.grid, &self.illuminant)?
                    }
                    WhiteBalanceMethod::GrayWorld => {
                        // Gray world: the frame's mean red equals its mean clear.
                        let unbalanced = cfa_render::rccc_rgb(raw, 1.0, self.rccc_clear)?;
                        let mean = |p: &[f32]| p.iter().map(|v| *v as f64).sum::<f64>();
                        let (r, c) = (mean(&unbalanced.r), mean(&unbalanced.g));
                        if !(r > 0.0 && c > 0.0) {
                            return Err(PipelineError::config(format!(
                                "gray-world white balance of an RCCC frame: mean red {r}, mean clear {c} above black; both must be positive"
                            )));
                        }
                        c / r
                    }
                    WhiteBalanceMethod::WhitePatch => {
                        return Err(refuse("white balance white-patch".into()))
                    }
                };
                gains = [red_gain, 1.0, 1.0];
                report_demosaic = match self.rccc_clear {
                    RcccClear::Analog => "rccc analog (EE-358 kernel)",
                    RcccClear::EdgeAware => "rccc edge-aware (Hamilton-Adams)",
                };
                (
                    cfa_render::rccc_rgb(raw, red_gain, self.rccc_clear)?,
                    Some(saturation_dn),
                )
            }
            _ => {
                if self.white_balance != WhiteBalanceMethod::Illuminant {
                    return Err(refuse(format!(
                        "white balance {} (the fitted colour transform holds the illuminant's)",
                        self.white_balance.name()
                    )));
                }
                let s = frame_sensor(sensor, &layout)?;
                let t = ChannelTransform::fit(
                    layout.filters(),
                    &filter_qe_on(&s, &self.grid),
                    &self.grid,
                    &self.illuminant,
                )?;
                report_demosaic = "bilinear per channel";
                let rgb = t.apply(raw, Some(saturation_dn))?;
                transform = Some(t);
                (rgb, None)
            }
        };
        let scale = self
            .exposure_scale
            .unwrap_or_else(|| cfa_render::auto_exposure_linear_srgb(&rgb));
        let data = cfa_render::render_linear_srgb8(&rgb, scale, clip);
        let report = IspReport {
            channel_fit_delta_e2000: transform
                .as_ref()
                .map(|t| [t.delta_e2000_mean(), t.delta_e2000_max()]),
            channels: transform.as_ref().map(|t| t.names.clone()),
            channel_to_linear_srgb: transform.map(|t| t.to_linear_srgb),
            // Non-RGB CFAs clip (their renderer takes no tone curve yet).
            ..IspReport::settings(
                report_demosaic,
                self.white_balance.name(),
                gains,
                scale,
                family,
                ToneMap::Clip,
            )
        };
        Ok(IspOutput {
            preview: crate::Rgb8Image {
                rows: rgb.rows,
                cols: rgb.cols,
                data,
            },
            rgb,
            report,
        })
    }

    /// The white-balance gains (green = 1) of demosaicked camera RGB `rgb` by the ISP's method:
    /// none, gray world, white patch (pixels with a channel at `saturation_dn` left out), or from
    /// the illuminant and `sensor`'s QE (which that method needs).
    pub fn white_balance_gains(
        &self,
        rgb: &RgbImage,
        sensor: Option<&Sensor>,
        saturation_dn: Option<f64>,
    ) -> Result<[f64; 3]> {
        Ok(match self.white_balance {
            WhiteBalanceMethod::None => [1.0; 3],
            WhiteBalanceMethod::GrayWorld => white_balance::gray_world_gains(rgb)?,
            WhiteBalanceMethod::WhitePatch => {
                white_balance::white_patch_gains(rgb, self.white_patch_percentile, saturation_dn)?
            }
            WhiteBalanceMethod::Illuminant => {
                let sensor = sensor.ok_or_else(|| {
                    PipelineError::config(
                        "white balance 'illuminant' needs the sensor (its QE) and the illuminant",
                    )
                })?;
                white_balance::illuminant_gains(
                    &sensor.channel_qe(&self.grid),
                    &self.grid,
                    &self.illuminant,
                )?
            }
        })
    }

    /// White balance, colour matrix and sRGB encoding of demosaicked camera RGB (DN above black,
    /// `saturation_dn` the clipping level above black): the part of [`Isp::compute`] after the
    /// demosaic, for an image the caller demosaicked (and, say, downsampled) itself.
    /// `black` says how `rgb`'s values relate to the raw pixels at black (their noise, a clip
    /// below), for the censored-black correction and chroma coring ([`camsim_isp::coring`]).
    pub fn render(
        &self,
        rgb: &RgbImage,
        sensor: &Sensor,
        saturation_dn: f64,
        black: &RawBlack,
    ) -> Result<(crate::Rgb8Image, IspReport)> {
        let gains = self.white_balance_gains(rgb, Some(sensor), Some(saturation_dn))?;
        // The noise of `rgb` at black (the sensor's read, DSNU and quantization noise, scaled to
        // these values), DN: chroma coring removes the chroma this noise explains, so a dark
        // surround renders grey, not tinted (camsim_isp::ChromaCoring).
        let raw_floor_dn = sensor.predicted_noise_dn(0.0, 0.0).total;
        // The model in the units of values scaled by `gains` per channel.
        let model = |gains: [f64; 3]| BlackModel {
            sigma: gains.map(|g| g * raw_floor_dn * black.noise_factor),
            clip: black
                .clip_dn
                .map(|level| (gains.map(|g| g * level), gains.map(|g| g * raw_floor_dn))),
        };
        let mut report = IspReport::settings(
            self.demosaic.name(),
            self.white_balance.name(),
            gains,
            1.0,
            CfaFamily::Rgb,
            ToneMap::Clip,
        );
        let data = match &self.ccm {
            CcmSource::Qe => {
                let color = self.color(sensor)?;
                // The pipeline's matrix includes the illuminant's white balance
                // diag(1 / as_shot_neutral). Another method's gains g replace it: camera values
                // are first scaled by as_shot_neutral * g, so what g takes to neutral renders
                // neutral. With the illuminant method the pipeline is used as it is (the paper's
                // preview).
                let mut clip = saturation_dn;
                let mut value_gains = [1.0; 3];
                let rgb: Cow<RgbImage> = if self.white_balance != WhiteBalanceMethod::Illuminant {
                    let asn = color.as_shot_neutral();
                    let pre = [asn[0] * gains[0], asn[1] * gains[1], asn[2] * gains[2]];
                    value_gains = pre;
                    let mut balanced = rgb.clone();
                    white_balance::apply_gains(&mut balanced, pre);
                    // Saturated pixels (s in every channel) become s * pre; clip where the
                    // channel saturated first so clipped highlights stay neutral.
                    clip *= gains.iter().cloned().fold(f64::INFINITY, f64::min);
                    Cow::Owned(balanced)
                } else {
                    Cow::Borrowed(rgb)
                };
                let auto = self
                    .exposure_scale
                    .unwrap_or_else(|| color.auto_exposure_scale(&rgb));
                // A tone curve sets its own exposure (the log-average at the key) unless one
                // is given.
                let (fitted, curve) = self.tone_map.fit(&rgb, color.luminance_weights(), auto);
                let scale = self.exposure_scale.unwrap_or(fitted);
                report.exposure_scale = scale;
                report.tone_map = self.tone_map.name();
                report.camera_to_linear_srgb = Some(color.camera_to_srgb());
                color.render_srgb8_toned(
                    &rgb,
                    Some(scale),
                    Some(clip),
                    Some(&model(value_gains)),
                    curve,
                )
            }
            CcmSource::Chart {
                corners,
                objective,
                reflectances,
            } => {
                let mut balanced = rgb.clone();
                white_balance::apply_gains(&mut balanced, gains);
                let planes = [0, 1, 2]
                    .map(|c| Plane::new(balanced.rows, balanced.cols, balanced.plane(c).to_vec()));
                let [r, g, b] = planes;
                let stats = chart_patch_stats_rgb(&[r?, g?, b?], corners, 0.5).map_err(|e| {
                    PipelineError::config(format!(
                        "colour matrix from the chart: measuring the patches: {e}"
                    ))
                })?;
                let camera: Vec<[f64; 3]> = stats.iter().map(|s| s.mean).collect();
                let d65 = camsim_core::tables::illuminant("D65")?;
                let (target, white) = match reflectances {
                    Some(r) => ccm::chart_xyz(r, &d65, &self.grid)?,
                    None => ccm::macbeth_xyz(&d65, &self.grid)?,
                };
                let m = ccm::fit_ccm(&camera, &target, white, *objective).map_err(|e| {
                    PipelineError::config(format!("colour matrix from the chart: {e}"))
                })?;
                let de = ccm::ccm_delta_e2000(&m, &camera, &target, white);
                let mean = de.iter().sum::<f64>() / de.len() as f64;
                let max = de.iter().cloned().fold(0.0, f64::max);
                if !mean.is_finite() {
                    return Err(PipelineError::config(
                        "colour matrix from the chart: the fit gave no finite colour error (are the corners on the chart?)",
                    ));
                }
                let scale = self.exposure_scale.unwrap_or(1.0);
                report.exposure_scale = scale;
                report.ccm_objective = Some(objective.to_string());
                report.camera_to_xyz = Some(m);
                report.patch_camera_rgb = Some(camera);
                report.patch_delta_e2000 = Some(de);
                report.delta_e2000_mean = Some(mean);
                report.delta_e2000_max = Some(max);
                camsim_isp::output::render_rgb8(
                    &balanced,
                    &m,
                    &DisplayModel::srgb(),
                    scale,
                    Some(&model(gains)),
                )?
            }
        };
        Ok((
            crate::Rgb8Image {
                rows: rgb.rows,
                cols: rgb.cols,
                data,
            },
            report,
        ))
    }
}

/// How the demosaicked values given to [`Isp::render`] relate to the raw pixels at black.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawBlack {
    /// One raw pixel's noise scaled to that of the values: 1 as read, 1/k after a k x k box
    /// average, 2 after a 2x2 binned sum.
    pub noise_factor: f64,
    /// Black-subtracted DN at which the raw was clipped below (minus the black level: the ADC
    /// clips at 0), when each value is a mean of such clipped pixels; `None` where that does not
    /// hold (binned sums) or is not known.
    pub clip_dn: Option<f64>,
}

/// `sensor` with the frame's CFA `layout` (its QE curves for the frame's filters; a DNG carries
/// its CFA, `--sensor` the curves): the sensor itself when it has that layout already.
fn frame_sensor<'a>(
    sensor: &'a Sensor,
    layout: &camsim_core::CfaLayout,
) -> Result<Cow<'a, Sensor>> {
    if sensor.cfa_layout() == *layout {
        return Ok(Cow::Borrowed(sensor));
    }
    let mut c = sensor.config().clone();
    c.cfa = String::new();
    c.cfa_pattern = Some(
        (0..layout.rows())
            .map(|r| {
                (0..layout.cols())
                    .map(|col| layout.filters()[layout.filter_at(r, col)].clone())
                    .collect()
            })
            .collect(),
    );
    // Named filters the frame does not use would be refused as typos: keep the frame's only.
    c.qe.filters.retain(|k, _| layout.filter_index(k).is_some());
    Ok(Cow::Owned(Sensor::from_config_named(
        c,
        &format!("{} with the frame's CFA {}", sensor.name(), layout.name()),
    )?))
}

/// The spectral QE of each filter of `sensor`'s CFA, in the layout's filter order, on `grid`.
fn filter_qe_on(sensor: &Sensor, grid: &WavelengthGrid) -> Vec<Vec<f64>> {
    sensor
        .filter_qe_spectra()
        .iter()
        .map(|s| s.sample(grid))
        .collect()
}
