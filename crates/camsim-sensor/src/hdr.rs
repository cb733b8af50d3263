//! HDR pixels: dual conversion gain (DCG) and split pixel (large + small photodiode), `[hdr]` in
//! the sensor TOML.
//!
//! Models (Solhusvik et al., "A 1280x960 2.8 um HDR CIS with DCG and Split-Pixel Combined",
//! IISW 2019; Willassen et al., "A 1280x1080 4.2 um split-diode pixel HDR sensor in 110 nm BSI
//! CMOS", IISW 2015):
//!
//! * **DCG**: one photodiode (full well `full_well_e`) read twice. The high-conversion-gain
//!   readout (HCG) is the sensor's own: `conversion_gain_uv_per_e`, `read_noise_mv`, ADC
//!   (`voltage_swing_v`, `bits`, `black_level_dn`), so it saturates at the ADC's range,
//!   ~ swing / conversion gain electrons. The low-conversion-gain readout (LCG) converts the *same
//!   electrons* with `lcg_conversion_gain_uv_per_e` through the same ADC and adds its own,
//!   independent read noise `lcg_read_noise_e` (electrons rms at the LCG node); it saturates at
//!   min(full well, ADC range / LCG gain). Shot noise is shared, read noise is not.
//! * **Split pixel**: the large photodiode (LPD) is the sensor's own pixel; the small photodiode
//!   (SPD) collects `sensitivity_ratio` x the LPD's electrons (its own Poisson draw: different
//!   electrons), with its own full well, conversion gain and read noise (electrons), read through
//!   the same ADC. Its dark current is the LPD's x `sensitivity_ratio` (dark current scales with
//!   the collecting area, an assumption), its PRNU an independent draw of the same sigma.
//!
//! The merged frame (f32, linear) is in **electrons of the HCG / LPD readout**, black level
//! removed: e_high = (DN_high - black) / K_high while e_high < `switch_level` x the HCG / LPD
//! saturation signal; above it the other readout, e_low = (DN_low - black) / K_low (DCG: the same
//! electrons), / `sensitivity_ratio` for the split pixel. K = conversion gain x 2^bits / swing
//! (DN per electron, EMVA 1288 K). Expected SNR per branch (EMVA 1288 rel. 4.0 eq. 9, photon
//! shot + read + quantization): S / sqrt(S + sigma_read^2 + 1/(12 K^2)) in the readout's own
//! electrons. Dynamic range: 20 log10(largest merged signal / merged noise at zero light).
//!
//! Analog gain, ISO and analog offset are not modelled for HDR pixels (an error names the key);
//! DSNU (a voltage at the HCG / LPD readout) offsets the HCG / LPD readout only.

use crate::compute::{Capture, Exposure, POISSON_EXACT_BELOW_E};
use crate::error::{Result, SensorError};
pub use crate::hdr_config::{HdrConfig, HdrMode};
use crate::normal::Ziggurat;
use crate::poisson;
use crate::sensor::Sensor;
use camsim_core::rng::{keyed, stage};
use camsim_core::{mem, RawImage, SpectralImage};
use rayon::prelude::*;

/// Everything the HDR computation needs, in electrons and DN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HdrModel {
    /// The pixel kind.
    pub mode: HdrMode,
    /// High readout (HCG / LPD) system gain, DN per electron.
    pub k_high_dn_per_e: f64,
    /// Low readout (LCG / SPD) system gain, DN per electron (of its own electrons).
    pub k_low_dn_per_e: f64,
    /// High readout read noise, electrons rms (sensor `read_noise_mv` / conversion gain).
    pub read_high_e: f64,
    /// Low readout read noise, electrons rms.
    pub read_low_e: f64,
    /// Electrons the high photodiode holds (DCG: `full_well_e`; split: the ADC range of the LPD).
    pub full_well_high_e: f64,
    /// Electrons the low readout's photodiode holds (DCG: the same photodiode; split: the SPD).
    pub full_well_low_e: f64,
    /// Low readout electrons per high readout electron: 1 (DCG) or `sensitivity_ratio`.
    pub ratio: f64,
    /// Switch level, electrons of the high readout.
    pub switch_e: f64,
    /// ADC black level (pedestal), DN, and white level, DN.
    pub black_dn: f64,
    /// White level 2^bits - 1, DN.
    pub white_dn: f64,
}

impl HdrModel {
    /// Largest signal the high readout reports, electrons: min(full well, ADC range / K).
    pub fn high_saturation_e(&self) -> f64 {
        self.full_well_high_e
            .min((self.white_dn - self.black_dn) / self.k_high_dn_per_e)
    }
    /// Largest signal the low readout reports, its own electrons: min(full well, ADC range / K).
    pub fn low_saturation_e(&self) -> f64 {
        self.full_well_low_e
            .min((self.white_dn - self.black_dn) / self.k_low_dn_per_e)
    }
    /// Largest merged signal, high-readout electrons: low saturation / ratio.
    pub fn max_merged_e(&self) -> f64 {
        self.low_saturation_e() / self.ratio
    }
    /// Merged noise at zero light, electrons: sqrt(read_high^2 + 1/(12 K_high^2)) (EMVA 1288
    /// eq. 9 dark noise with quantization).
    pub fn noise_floor_e(&self) -> f64 {
        (self.read_high_e.powi(2) + 1.0 / (12.0 * self.k_high_dn_per_e.powi(2))).sqrt()
    }
    /// Dynamic range, dB: 20 log10(max merged signal / noise floor).
    pub fn dynamic_range_db(&self) -> f64 {
        20.0 * (self.max_merged_e() / self.noise_floor_e()).log10()
    }
    /// Predicted SNR of the merged frame at `signal_e` high-readout electrons (shot + read +
    /// quantization of the branch the mean signal falls in, EMVA 1288 eq. 9; no fixed pattern).
    pub fn predicted_snr(&self, signal_e: f64) -> f64 {
        if signal_e < self.switch_e {
            signal_e
                / (signal_e
                    + self.read_high_e.powi(2)
                    + 1.0 / (12.0 * self.k_high_dn_per_e.powi(2)))
                .sqrt()
        } else {
            let s = signal_e * self.ratio;
            s / (s + self.read_low_e.powi(2) + 1.0 / (12.0 * self.k_low_dn_per_e.powi(2))).sqrt()
        }
    }
    /// Merged value, high-readout electrons, of a pair of raw values.
    #[inline]
    pub fn merge(&self, dn_high: u16, dn_low: u16) -> f32 {
        let e_high = (dn_high as f64 - self.black_dn) / self.k_high_dn_per_e;
        if e_high < self.switch_e {
            e_high as f32
        } else {
            ((dn_low as f64 - self.black_dn) / self.k_low_dn_per_e / self.ratio) as f32
        }
    }
}

/// An HDR capture: both readouts as raws and the merged linear frame, per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct HdrFrame {
    /// High readout (HCG / LPD) raw per frame.
    pub high: Vec<RawImage>,
    /// Low readout (LCG / SPD) raw per frame.
    pub low: Vec<RawImage>,
    /// Merged linear frame per frame, electrons of the high readout, row-major.
    pub merged_e: Vec<Vec<f32>>,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// The model used.
    pub model: HdrModel,
    /// Noise-free mean electrons (photo + dark) of the high photodiode over the pixels of each
    /// channel r, g, b (0 where a channel has no pixel), as [`crate::Frame::mean_electrons`].
    pub mean_electrons: [f64; 3],
    /// The same per filter of [`Sensor::cfa_layout`].
    pub mean_electrons_by_filter: Vec<f64>,
}

impl Sensor {
    /// The HDR model of an `[hdr]` sensor (None without `[hdr]`).
    pub fn hdr_model(&self) -> Option<HdrModel> {
        let h = self.config().hdr.as_ref()?;
        let dpv = self.dn_per_v();
        let cg_h = self.conversion_gain_v_per_e;
        let k_high = cg_h * dpv;
        let white_dn = self.max_dn() as f64;
        let black_dn = self.black_level_pedestal_dn;
        let adc_range_high_e = (white_dn - black_dn) / k_high;
        let (k_low, read_low_e, fw_high, fw_low, ratio) = match h.mode {
            HdrMode::Dcg => {
                let fw = h.full_well_e.unwrap_or(0.0);
                (
                    h.lcg_conversion_gain_uv_per_e.unwrap_or(0.0) * 1e-6 * dpv,
                    h.lcg_read_noise_e.unwrap_or(0.0),
                    fw,
                    fw,
                    1.0,
                )
            }
            HdrMode::SplitPixel => (
                h.spd_conversion_gain_uv_per_e.unwrap_or(0.0) * 1e-6 * dpv,
                h.spd_read_noise_e.unwrap_or(0.0),
                // The LPD's well is the sensor's own (swing / conversion gain, ISETCam).
                self.well_capacity_e(),
                h.spd_full_well_e.unwrap_or(0.0),
                h.sensitivity_ratio.unwrap_or(1.0),
            ),
        };
        let full_sat = fw_high.min(adc_range_high_e);
        Some(HdrModel {
            mode: h.mode,
            k_high_dn_per_e: k_high,
            k_low_dn_per_e: k_low,
            read_high_e: self.read_noise_v / cg_h,
            read_low_e,
            full_well_high_e: fw_high,
            full_well_low_e: fw_low,
            ratio,
            switch_e: h.switch_level * full_sat,
            black_dn,
            white_dn,
        })
    }

    /// HDR capture of a sensor-plane irradiance image (as [`Sensor::compute`]): both readouts
    /// and the merged frame. Errors when the sensor has no `[hdr]`.
    pub fn compute_hdr(&self, irradiance: &SpectralImage, capture: &Capture) -> Result<HdrFrame> {
        self.compute_hdr_from(irradiance, capture, 0)
    }

    /// [`Sensor::compute_hdr`] with the temporal noise of frame k keyed on frame index
    /// `first_frame + k` (the frames of a moving scene, one irradiance each, as
    /// [`Sensor::compute_from`]).
    pub fn compute_hdr_from(
        &self,
        irradiance: &SpectralImage,
        capture: &Capture,
        first_frame: u64,
    ) -> Result<HdrFrame> {
        // Per frame: a high and a low raw frame (2 + 2 bytes) and the merged frame (4 bytes).
        self.check_memory(capture.frames, 8)?;
        let rate = self.electron_rate_image(irradiance)?;
        self.hdr_from_rate(&rate, capture, first_frame)
    }

    /// HDR capture from a noise-free photo-electron rate per pixel (e-/s of the high photodiode,
    /// rows x cols row-major). Temporal noise is keyed on (capture seed, frame, row), the fixed
    /// pattern on (fixed_pattern_seed, row): bit-identical for any thread count. Auto-exposure
    /// puts the 99th percentile at the target fraction of the HCG / LPD swing.
    pub fn compute_hdr_from_rate(
        &self,
        rate_e_per_s: &[f32],
        capture: &Capture,
    ) -> Result<HdrFrame> {
        self.hdr_from_rate(rate_e_per_s, capture, 0)
    }

    pub(crate) fn hdr_from_rate(
        &self,
        rate_e_per_s: &[f32],
        capture: &Capture,
        first_frame: u64,
    ) -> Result<HdrFrame> {
        let Some(model) = self.hdr_model() else {
            return Err(SensorError::input(
                "hdr",
                "the sensor has no [hdr] table (dual conversion gain or split pixel)",
            ));
        };
        let (rows, cols) = (self.rows(), self.cols());
        let n = rows * cols;
        if rate_e_per_s.len() != n {
            return Err(SensorError::input(
                "hdr",
                format!(
                    "{} electron rates for {rows} x {cols} pixels",
                    rate_e_per_s.len()
                ),
            ));
        }
        if capture.frames == 0 {
            return Err(SensorError::input("frames", "must be at least 1"));
        }
        if capture.global_reset.is_some() {
            return Err(SensorError::input(
                "global reset",
                "an [hdr] sensor's global-reset readout is not modelled; use the global or rolling shutter",
            ));
        }
        let exposure_s = self.resolve_exposure(rate_e_per_s, rows, cols, capture.exposure, None)?;
        if !(exposure_s.is_finite() && exposure_s >= 0.0) {
            return Err(SensorError::input(
                "exposure",
                format!("{exposure_s} s is not a finite time >= 0"),
            ));
        }
        mem::check_alloc(
            (n * 8 * capture.frames) as u64,
            &format!("{} HDR frames of {rows} x {cols}", capture.frames),
        )?;
        let new_raw = || -> Result<RawImage> {
            let mut raw = RawImage::new(rows, cols, self.cfa, self.bits)?;
            raw.black_level_dn = model.black_dn;
            raw.white_level_dn = model.white_dn;
            raw.exposure_s = exposure_s;
            raw.pixel_pitch_m = self.pixel_pitch_m;
            raw.layout = self.layout.clone();
            Ok(raw)
        };
        let (mean_electrons, mean_electrons_by_filter) =
            self.frame_mean_electrons(rate_e_per_s, rows, cols, exposure_s, None);
        let mut out = HdrFrame {
            high: Vec::new(),
            low: Vec::new(),
            merged_e: Vec::new(),
            exposure_s,
            model,
            mean_electrons,
            mean_electrons_by_filter,
        };
        for k in 0..capture.frames {
            // A modulated light: this frame's rows see their own share of it (the exposure was
            // metered on the steady light).
            let key = first_frame + k as u64;
            let modulated = match &capture.light {
                Some(light) => {
                    let one = Capture {
                        exposure: Exposure::Seconds(exposure_s),
                        ..*capture
                    };
                    Some(self.modulated_rate(rate_e_per_s, rows, cols, light, key, &one)?)
                }
                None => None,
            };
            let rate_e_per_s = modulated.as_deref().unwrap_or(rate_e_per_s);
            if k == 0 && modulated.is_some() {
                // The noise-free means are those of the first frame, as it was lit.
                (out.mean_electrons, out.mean_electrons_by_filter) =
                    self.frame_mean_electrons(rate_e_per_s, rows, cols, exposure_s, None);
            }
            let (mut hi, mut lo) = (new_raw()?, new_raw()?);
            let mut merged = vec![0.0f32; n];
            hi.dn
                .par_chunks_mut(cols)
                .zip(lo.dn.par_chunks_mut(cols))
                .zip(merged.par_chunks_mut(cols))
                .enumerate()
                .for_each(|(r, ((h, l), m))| {
                    self.hdr_row(
                        &model,
                        r,
                        &rate_e_per_s[r * cols..(r + 1) * cols],
                        exposure_s,
                        capture.seed,
                        key,
                        h,
                        l,
                        m,
                    )
                });
            out.high.push(hi);
            out.low.push(lo);
            out.merged_e.push(merged);
        }
        Ok(out)
    }

    /// One row of one HDR frame. Draw order per pixel (temporal stream): high photodiode
    /// electrons, [split: SPD electrons], high read noise, low read noise.
    #[allow(clippy::too_many_arguments)]
    fn hdr_row(
        &self,
        m: &HdrModel,
        r: usize,
        rate: &[f32],
        exposure_s: f64,
        seed: u64,
        frame_key: u64,
        hi: &mut [u16],
        lo: &mut [u16],
        merged: &mut [f32],
    ) {
        let nz = self.noise;
        let dark_e = self.dark_electrons(exposure_s);
        let prnu = if nz.prnu { self.prnu_fraction } else { 0.0 };
        let dsnu_e = if nz.dsnu {
            self.dsnu_v / self.conversion_gain_v_per_e
        } else {
            0.0
        };
        let fpn = nz.prnu || nz.dsnu;
        let split = m.mode == HdrMode::SplitPixel;
        let (read_h, read_l) = if nz.read {
            (m.read_high_e, m.read_low_e)
        } else {
            (0.0, 0.0)
        };
        let mut fp = keyed(
            self.config().fixed_pattern_seed,
            stage::SENSOR_FIXED_PATTERN,
            0,
            r as u64,
        );
        let mut tr = keyed(seed, stage::SENSOR_TEMPORAL, frame_key, r as u64);
        let zig = Ziggurat::get();
        // Electrons of a photodiode of mean mu: Poisson (normal with the same mean and variance
        // at mu >= POISSON_EXACT_BELOW_E, as the base model), clipped to [0, full well].
        let electrons = |tr: &mut _, mu: f64, fw: f64| -> f64 {
            let e = if !nz.shot {
                mu
            } else if mu >= POISSON_EXACT_BELOW_E {
                mu + mu.sqrt() * zig.sample(tr)
            } else {
                poisson::sample(tr, mu)
            };
            e.clamp(0.0, fw)
        };
        let adc =
            |e: f64, k: f64| -> u16 { (e * k + m.black_dn).clamp(0.0, m.white_dn).round() as u16 };
        for c in 0..rate.len() {
            let (g_high, offset_e, g_low) = if fpn {
                // Same two draws per pixel as the base model (PRNU, DSNU), then the SPD's PRNU.
                let z1 = zig.sample(&mut fp);
                let z2 = zig.sample(&mut fp);
                let g_low = if split {
                    1.0 + prnu * zig.sample(&mut fp)
                } else {
                    1.0 + prnu * z1
                };
                (1.0 + prnu * z1, dsnu_e * z2, g_low)
            } else {
                (1.0, 0.0, 1.0)
            };
            let mu = (rate[c] as f64 * exposure_s).max(0.0);
            let e_high = electrons(&mut tr, mu * g_high + dark_e, m.full_well_high_e);
            let e_low = if split {
                electrons(&mut tr, (mu * g_low + dark_e) * m.ratio, m.full_well_low_e)
            } else {
                e_high
            };
            let zh = if nz.read { zig.sample(&mut tr) } else { 0.0 };
            let zl = if nz.read { zig.sample(&mut tr) } else { 0.0 };
            let dh = adc(e_high + offset_e + read_h * zh, m.k_high_dn_per_e);
            let dl = adc(e_low + read_l * zl, m.k_low_dn_per_e);
            hi[c] = dh;
            lo[c] = dl;
            merged[c] = m.merge(dh, dl);
        }
    }
}
