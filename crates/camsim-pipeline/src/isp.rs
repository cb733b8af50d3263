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
use camsim_isp::output::DisplayModel;
use camsim_isp::tone::ToneMap;
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
}

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
    /// The exposure scale used (see [`Isp::exposure_scale`]).
    #[serde(skip)]
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
        }
    }

    /// The ISP of a simulate config: the scene's illuminant (D65 when the scene has none, such
    /// as a 3D scene or a radiance file) on the config's wavelength grid.
    pub fn for_config(cfg: &SimulateConfig) -> Result<Isp> {
        let illuminant = match cfg.scene.as_ref().and_then(camsim_scene::scene_illuminant) {
            Some(r) => r?,
            None => camsim_core::tables::illuminant("D65")?,
        };
        Ok(Isp {
            tone_map: cfg.isp.tone_map.unwrap_or_default(),
            ..Isp::new(illuminant, cfg.wavelengths)
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
        let raw: Cow<RawImage> = if self.bin_2x2 {
            Cow::Owned(camsim_isp::cfa_general::bin_2x2(raw)?)
        } else {
            Cow::Borrowed(raw)
        };
        let family = CfaFamily::of(&raw.cfa_layout());
        if !matches!(family, CfaFamily::Rgb | CfaFamily::Rgbw) {
            return self.compute_other(&raw, sensor, family);
        }
        let rgb = self.demosaic(&raw, sensor)?;
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
            demosaic: report_demosaic,
            white_balance: self.white_balance.name(),
            white_balance_gains: gains,
            camera_to_linear_srgb: None,
            ccm_objective: None,
            camera_to_xyz: None,
            patch_camera_rgb: None,
            patch_delta_e2000: None,
            delta_e2000_mean: None,
            delta_e2000_max: None,
            exposure_scale: scale,
            cfa_family: family.name(),
            // Non-RGB CFAs clip (their renderer takes no tone curve yet).
            tone_map: ToneMap::Clip.name(),
            channel_fit_delta_e2000: transform
                .as_ref()
                .map(|t| [t.delta_e2000_mean(), t.delta_e2000_max()]),
            channels: transform.as_ref().map(|t| t.names.clone()),
            channel_to_linear_srgb: transform.map(|t| t.to_linear_srgb),
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
        let mut report = IspReport {
            demosaic: self.demosaic.name(),
            white_balance: self.white_balance.name(),
            white_balance_gains: gains,
            camera_to_linear_srgb: None,
            ccm_objective: None,
            camera_to_xyz: None,
            patch_camera_rgb: None,
            patch_delta_e2000: None,
            delta_e2000_mean: None,
            delta_e2000_max: None,
            exposure_scale: 1.0,
            cfa_family: CfaFamily::Rgb.name(),
            tone_map: ToneMap::Clip.name(),
            channels: None,
            channel_to_linear_srgb: None,
            channel_fit_delta_e2000: None,
        };
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
