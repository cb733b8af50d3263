//! `[hdr]` of a sensor TOML: which HDR pixel (dual conversion gain or split pixel) and its
//! values, checked against the few sensor values they depend on ([`HdrHost`]). The model and the
//! capture are in [`crate::hdr`].

use serde::{Deserialize, Serialize};

/// The sensor values an `[hdr]` table is checked against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HdrHost {
    /// The sensor's effective analog gain (ISETCam divisor).
    pub analog_gain: f64,
    /// Whether the sensor gives an ISO.
    pub iso_given: bool,
    /// Analog offset, mV.
    pub analog_offset_mv: f64,
    /// ADC input range, V.
    pub voltage_swing_v: f64,
    /// Conversion gain of the (HCG / LPD) pixel, uV per electron.
    pub conversion_gain_uv_per_e: f64,
}

/// Which HDR pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum HdrMode {
    /// Dual conversion gain: one photodiode, an HCG and an LCG readout of the same electrons.
    Dcg,
    /// Split pixel: a large (LPD) and a small (SPD) photodiode, each with its own electrons.
    SplitPixel,
}

/// `[hdr]` of a sensor TOML. The high readout (HCG / LPD) is the sensor's own pixel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HdrConfig {
    /// "dcg" (dual conversion gain) or "split-pixel" (large + small photodiode).
    pub mode: HdrMode,
    /// Where the merged frame switches from the high readout (HCG / LPD) to the low one (LCG /
    /// SPD): a fraction, in (0, 1], of the high readout's saturation signal in electrons
    /// (the smaller of the full well and the ADC range, [`crate::hdr::HdrModel::high_saturation_e`]).
    pub switch_level: f64,
    /// DCG: full well of the photodiode, electrons (LCG saturates at min(this, ADC range / LCG
    /// gain)); must exceed the HCG saturation signal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub full_well_e: Option<f64>,
    /// DCG: conversion gain of the LCG readout, uV per electron; below the sensor's (HCG)
    /// `conversion_gain_uv_per_e`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lcg_conversion_gain_uv_per_e: Option<f64>,
    /// DCG: read noise of the LCG readout, electrons rms (independent of the HCG read noise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lcg_read_noise_e: Option<f64>,
    /// Split pixel: SPD / LPD responsivity (electrons per photon, same light), in (0, 1)
    /// (typically 1/16 ... 1/100).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensitivity_ratio: Option<f64>,
    /// Split pixel: SPD full well, electrons.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spd_full_well_e: Option<f64>,
    /// Split pixel: SPD conversion gain, uV per electron.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spd_conversion_gain_uv_per_e: Option<f64>,
    /// Split pixel: SPD read noise, electrons rms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spd_read_noise_e: Option<f64>,
}

impl HdrConfig {
    /// Check the values against the sensor; errors name the key (`hdr.switch_level`, ...).
    pub(crate) fn validate(&self, s: &HdrHost) -> std::result::Result<(), (String, String)> {
        let bad = |k: &str, m: String| Err((format!("hdr.{k}"), m));
        if !(self.switch_level.is_finite() && self.switch_level > 0.0 && self.switch_level <= 1.0) {
            return bad(
                "switch_level",
                format!("must be in (0, 1] (a fraction of the high readout's saturation signal), got {}", self.switch_level),
            );
        }
        let need = |k: &str, v: Option<f64>| -> std::result::Result<f64, (String, String)> {
            match v {
                None => Err((
                    format!("hdr.{k}"),
                    format!("is required for mode = \"{}\"", self.mode_name()),
                )),
                Some(x) if !(x.is_finite() && x > 0.0) => Err((
                    format!("hdr.{k}"),
                    format!("must be a positive number, got {x}"),
                )),
                Some(x) => Ok(x),
            }
        };
        let non_neg = |k: &str, v: Option<f64>| -> std::result::Result<f64, (String, String)> {
            match v {
                None => Err((
                    format!("hdr.{k}"),
                    format!("is required for mode = \"{}\"", self.mode_name()),
                )),
                Some(x) if !(x.is_finite() && x >= 0.0) => Err((
                    format!("hdr.{k}"),
                    format!("must be a finite number >= 0, got {x}"),
                )),
                Some(x) => Ok(x),
            }
        };
        let forbid = |k: &str, v: Option<f64>| -> std::result::Result<(), (String, String)> {
            match v {
                Some(_) => Err((
                    format!("hdr.{k}"),
                    format!("does not belong to mode = \"{}\"", self.mode_name()),
                )),
                None => Ok(()),
            }
        };
        if s.analog_gain != 1.0 || s.iso_given {
            return Err((
                "analog_gain".into(),
                "an [hdr] sensor models no analog gain or ISO (leave analog_gain = 1, no iso)"
                    .into(),
            ));
        }
        if s.analog_offset_mv != 0.0 {
            return Err((
                "analog_offset_mv".into(),
                "an [hdr] sensor models no analog offset (use black_level_dn)".into(),
            ));
        }
        let hcg_sat_e = s.voltage_swing_v / (s.conversion_gain_uv_per_e * 1e-6);
        match self.mode {
            HdrMode::Dcg => {
                for (k, v) in [
                    ("sensitivity_ratio", self.sensitivity_ratio),
                    ("spd_full_well_e", self.spd_full_well_e),
                ] {
                    forbid(k, v)?;
                }
                forbid(
                    "spd_conversion_gain_uv_per_e",
                    self.spd_conversion_gain_uv_per_e,
                )?;
                forbid("spd_read_noise_e", self.spd_read_noise_e)?;
                let cg_l = need(
                    "lcg_conversion_gain_uv_per_e",
                    self.lcg_conversion_gain_uv_per_e,
                )?;
                if cg_l >= s.conversion_gain_uv_per_e {
                    return bad(
                        "lcg_conversion_gain_uv_per_e",
                        format!("{cg_l} uV/e- must be below the HCG conversion_gain_uv_per_e = {} uV/e-", s.conversion_gain_uv_per_e),
                    );
                }
                non_neg("lcg_read_noise_e", self.lcg_read_noise_e)?;
                let fw = need("full_well_e", self.full_well_e)?;
                if fw <= hcg_sat_e {
                    return bad(
                        "full_well_e",
                        format!("{fw} e- must exceed the HCG range voltage_swing_v / conversion gain = {hcg_sat_e:.0} e- (else DCG adds no range)"),
                    );
                }
            }
            HdrMode::SplitPixel => {
                forbid("full_well_e", self.full_well_e)?;
                forbid(
                    "lcg_conversion_gain_uv_per_e",
                    self.lcg_conversion_gain_uv_per_e,
                )?;
                forbid("lcg_read_noise_e", self.lcg_read_noise_e)?;
                let r = need("sensitivity_ratio", self.sensitivity_ratio)?;
                if r >= 1.0 {
                    return bad(
                        "sensitivity_ratio",
                        format!("must be in (0, 1) (SPD / LPD responsivity), got {r}"),
                    );
                }
                let fw = need("spd_full_well_e", self.spd_full_well_e)?;
                need(
                    "spd_conversion_gain_uv_per_e",
                    self.spd_conversion_gain_uv_per_e,
                )?;
                non_neg("spd_read_noise_e", self.spd_read_noise_e)?;
                if fw / r <= hcg_sat_e {
                    return bad(
                        "spd_full_well_e",
                        format!("{fw} e- / sensitivity_ratio {r} = {:.0} LPD e- must exceed the LPD range {hcg_sat_e:.0} e- (else the SPD adds no range)", fw / r),
                    );
                }
            }
        }
        Ok(())
    }

    fn mode_name(&self) -> &'static str {
        match self.mode {
            HdrMode::Dcg => "dcg",
            HdrMode::SplitPixel => "split-pixel",
        }
    }
}
