//! Temporal light modulation (LED flicker): a light driven by pulse-width modulation, integrated
//! over each row's own exposure window, so short exposures and rolling shutters show the
//! flicker real cameras show (IEEE P2020 names it as a key automotive image-quality issue).
//!
//! The model: a square wave of frequency f, duty cycle D and phase phi (the fraction of a period
//! by which the on-phase starts after t = 0). The light's stated radiance is its time average
//! (what a photometer or an eye reports), so while on it emits 1/D of it. A window
//! [t0, t0 + T] then captures the fraction g = on-time(t0, t0 + T) / (D T) of the steady
//! light's signal: 1 exactly when T is a whole number of periods, between 0 and 1/D otherwise
//! (depending on where the window falls), and 0 or 1/D for T -> 0.
//! The on-time has a closed form: with u = t f - phi (in periods),
//! F(u) = floor(u) D + min(frac(u), D) is the on-time from u = 0, and
//! on-time(t0, t1) = (F(u1) - F(u0)) / f.
//!
//! A mains-driven lamp (incandescent, fluorescent, an LED with a poor driver) flickers instead
//! as a sine at twice the mains frequency (100 or 120 Hz): I(t) = I_mean (1 + m cos 2 pi u), with
//! m the modulation depth (IEEE 1789-2015's "percent flicker" is 100 m = 100 (max - min) /
//! (max + min)). Its window captures g = 1 + m (sin 2 pi u1 - sin 2 pi u0) / (2 pi (u1 - u0)):
//! 1 over whole periods, and 1 + m cos 2 pi u0 for T -> 0.

use crate::{Result, SensorError};
use serde::{Deserialize, Serialize};

/// The shape of a light's modulation.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Waveform {
    /// Pulse-width modulation: on for `duty` of each period (LED lamps, signs, car lights).
    #[default]
    Square,
    /// A sine of modulation depth `depth` about the mean (mains-driven lamps: twice the mains
    /// frequency).
    Sine,
}

/// A light's temporal modulation (`[flicker]` of a simulate config).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Flicker {
    /// Modulation frequency, Hz (LED PWM: 90 Hz - 2 kHz; a mains-driven lamp: twice the mains
    /// frequency, 100 or 120 Hz, with `waveform = "sine"`).
    pub frequency_hz: f64,
    /// "square" (PWM, the default) or "sine".
    #[serde(default)]
    pub waveform: Waveform,
    /// Square: the fraction of each period the light is on, in (0, 1]; 1 (the default) is a
    /// steady light. Not used by a sine.
    #[serde(default = "steady_duty")]
    pub duty: f64,
    /// Sine: the modulation depth m in [0, 1], I = mean x (1 + m cos 2 pi (f t - phase)) (IEEE
    /// 1789-2015's percent flicker is 100 m; a magnetic-ballast fluorescent tube about 0.3, an
    /// incandescent lamp 0.1 or less). Not used by a square wave.
    #[serde(default)]
    pub depth: f64,
    /// Fraction of a period, in [0, 1), by which the on-phase (a sine: its maximum) comes after
    /// t = 0 s of the scene's time (the capture's clock: frame windows are in the same time,
    /// `capture.start_ms`).
    #[serde(default)]
    pub phase: f64,
}

fn steady_duty() -> f64 {
    1.0
}

impl Flicker {
    /// Check the keys; errors name them under `key` (e.g. "flicker").
    pub fn validate(&self, key: &str) -> Result<()> {
        if !(self.frequency_hz.is_finite() && self.frequency_hz > 0.0) {
            return Err(SensorError::input(
                format!("{key}.frequency_hz"),
                format!("{}: must be a frequency > 0 Hz", self.frequency_hz),
            ));
        }
        if !(self.duty > 0.0 && self.duty <= 1.0) {
            return Err(SensorError::input(
                format!("{key}.duty"),
                format!("{}: must be a fraction in (0, 1]", self.duty),
            ));
        }
        match self.waveform {
            Waveform::Square if self.depth != 0.0 => {
                return Err(SensorError::input(
                    format!("{key}.depth"),
                    "is the modulation depth of waveform = \"sine\"; a square wave takes duty"
                        .to_string(),
                ))
            }
            Waveform::Sine if self.duty != 1.0 => {
                return Err(SensorError::input(
                    format!("{key}.duty"),
                    "is the on-fraction of waveform = \"square\"; a sine takes depth".to_string(),
                ))
            }
            Waveform::Sine if !(0.0..=1.0).contains(&self.depth) => {
                return Err(SensorError::input(
                    format!("{key}.depth"),
                    format!("{}: must be a modulation depth in [0, 1]", self.depth),
                ))
            }
            _ => {}
        }
        if !(self.phase >= 0.0 && self.phase < 1.0) {
            return Err(SensorError::input(
                format!("{key}.phase"),
                format!("{}: must be a fraction of a period in [0, 1)", self.phase),
            ));
        }
        Ok(())
    }

    /// On-time from u = 0 to `u` periods (u = t f - phase), in periods.
    fn on_periods(&self, u: f64) -> f64 {
        let whole = u.floor();
        whole * self.duty + (u - whole).min(self.duty)
    }

    /// Seconds the light is on within [t0_s, t1_s] (t1 >= t0).
    pub fn on_time_s(&self, t0_s: f64, t1_s: f64) -> f64 {
        let u = |t: f64| t * self.frequency_hz - self.phase;
        (self.on_periods(u(t1_s)) - self.on_periods(u(t0_s))) / self.frequency_hz
    }

    /// The fraction of the steady light's signal a window of `duration_s` from `start_s`
    /// captures: on-time / (duty x duration) (the light's radiance is its time average). A
    /// window of zero length gives the instantaneous value, 0 or 1 / duty.
    pub fn window_gain(&self, start_s: f64, duration_s: f64) -> f64 {
        if self.waveform == Waveform::Sine {
            // The mean of 1 + m cos 2 pi u over the window (u = t f - phase, in periods).
            let tau = std::f64::consts::TAU;
            let u0 = start_s * self.frequency_hz - self.phase;
            let du = duration_s * self.frequency_hz;
            if du <= 1e-9 {
                return 1.0 + self.depth * (tau * u0).cos();
            }
            let u0 = u0 - u0.floor();
            return 1.0 + self.depth * ((tau * (u0 + du)).sin() - (tau * u0).sin()) / (tau * du);
        }
        if duration_s <= 0.0 {
            let u = start_s * self.frequency_hz - self.phase;
            return if u - u.floor() < self.duty {
                1.0 / self.duty
            } else {
                0.0
            };
        }
        self.on_time_s(start_s, start_s + duration_s) / (self.duty * duration_s)
    }
}

/// When each frame and row of a capture integrates, for a modulated light ([`Flicker`]): frame
/// k (its frame index, [`crate::Sensor::compute_from`]) starts at `start_s + k x interval`,
/// stored row r at `row0_s + per_row_s x r` after its frame (a rolling shutter's delays; 0 for
/// a global shutter and for a global reset, whose rows all start together), and integrates for
/// its light time (the exposure; a global reset's row its own, [`crate::GlobalReset`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightTiming {
    /// The light's modulation.
    pub flicker: Flicker,
    /// Start of frame 0, s (the scene's time).
    pub start_s: f64,
    /// Time between frame starts, s; `None`: back to back (one exposure apart).
    pub frame_interval_s: Option<f64>,
    /// Start delay of stored row 0 after its frame's start, s.
    pub row0_s: f64,
    /// Start delay added per stored row, s (negative when the bottom row starts first).
    pub per_row_s: f64,
}

impl LightTiming {
    /// The start of frame index `k` exposed for `exposure_s` each, s.
    pub fn frame_start_s(&self, k: u64, exposure_s: f64) -> f64 {
        self.start_s + k as f64 * self.frame_interval_s.unwrap_or(exposure_s)
    }

    /// Per stored row of `rows`, the captured fraction of frame index `k`
    /// ([`Flicker::window_gain`]); `light_s(r)`: row r's light time.
    pub fn row_gains(
        &self,
        k: u64,
        rows: usize,
        exposure_s: f64,
        light_s: impl Fn(usize) -> f64,
    ) -> Vec<f64> {
        let t0 = self.frame_start_s(k, exposure_s);
        (0..rows)
            .map(|r| {
                let start = t0 + self.row0_s + self.per_row_s * r as f64;
                self.flicker.window_gain(start, light_s(r))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn led() -> Flicker {
        Flicker {
            frequency_hz: 90.0,
            waveform: Waveform::Square,
            duty: 0.1,
            depth: 0.0,
            phase: 0.0,
        }
    }

    #[test]
    fn whole_periods_capture_the_mean_and_a_steady_light_is_one() {
        let f = led();
        for start in [0.0, 0.0013, 0.5] {
            let g = f.window_gain(start, 3.0 / 90.0);
            assert!((g - 1.0).abs() < 1e-9, "{g}");
        }
        let steady = Flicker { duty: 1.0, ..f };
        assert!((steady.window_gain(0.01, 0.003) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn on_time_is_the_overlap_with_the_on_phase() {
        let f = led();
        let period = 1.0 / 90.0;
        let on = 0.1 * period;
        // A window wholly inside the on-phase, one across its end, one wholly off.
        assert!((f.on_time_s(0.2 * on, 0.7 * on) - 0.5 * on).abs() < 1e-15);
        assert!((f.on_time_s(0.5 * on, 2.0 * on) - 0.5 * on).abs() < 1e-15);
        assert_eq!(f.on_time_s(2.0 * on, 0.9 * period), 0.0);
        // The phase shifts the wave.
        let shifted = Flicker { phase: 0.5, ..f };
        assert!((shifted.on_time_s(0.5 * period, 0.5 * period + on) - on).abs() < 1e-15);
        assert!(f.validate("flicker").is_ok());
        assert!(Flicker { duty: 0.0, ..f }.validate("flicker").is_err());
        assert!(Flicker { phase: 1.0, ..f }.validate("flicker").is_err());
        assert!(Flicker {
            frequency_hz: -1.0,
            ..f
        }
        .validate("flicker")
        .is_err());
    }
}
