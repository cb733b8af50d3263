//! A scene whose lights flicker each in its own way (a 90 Hz LED sign beside steady street lamps
//! and a 300 Hz headlamp): the sensor-plane irradiance arrives split by group of lights (the
//! renderer's light groups, one optics pass each), the steady part and one part per modulated
//! group with its own [`LightTiming`]. Before noise the sensor is linear in light, so frame k's
//! photo-electron rate at stored row r is
//!
//! `rate_k(r, c) = steady(r, c) + sum_p gain_p(k, r) rate_p(r, c)`,
//!
//! with `gain_p` the fraction of the time-mean light group p's window captures
//! ([`crate::Flicker::window_gain`]); shot, read and every other noise are then drawn once on
//! that total, as for one light. The exposure is metered on the time-mean total (what
//! [`crate::Capture::light`] does for a scene that flickers as a whole).

use crate::compute::{Capture, Exposure, Frame};
use crate::error::{Result, SensorError};
use crate::flicker::LightTiming;
use crate::hdr::HdrFrame;
use crate::sensor::Sensor;
use camsim_core::{mem, SpectralImage};
use rayon::prelude::*;

/// One modulated group of lights: its sensor-plane irradiance (W/(m^2 nm), the geometry
/// [`Sensor::compute`] takes) and when it is on.
#[derive(Debug, Clone, Copy)]
pub struct LightPart<'a> {
    /// The group's irradiance, as if it were steady at its time mean.
    pub irradiance: &'a SpectralImage,
    /// Its modulation and the capture's timing.
    pub light: LightTiming,
}

/// The electron rates of the steady light and of each modulated part, and their sum.
struct PartRates {
    steady: Vec<f32>,
    parts: Vec<(Vec<f32>, LightTiming)>,
    total: Vec<f32>,
}

impl Sensor {
    fn part_rates(&self, steady: &SpectralImage, parts: &[LightPart<'_>]) -> Result<PartRates> {
        let n = self.rows().saturating_mul(self.cols());
        mem::MemoryBudget::new(format!(
            "the electron rates of {} light parts ({} x {} pixels)",
            parts.len() + 2,
            self.rows(),
            self.cols()
        ))
        .f32s("rates", n.saturating_mul(parts.len() + 3))
        .check("use fewer flickering light groups or a smaller sensor")?;
        for (i, p) in parts.iter().enumerate() {
            p.light
                .flicker
                .validate(&format!("light part {i}"))
                .map_err(|e| SensorError::input("light parts", e.to_string()))?;
        }
        let steady = self.electron_rate_image(steady)?;
        let mut total = steady.clone();
        let mut out = Vec::with_capacity(parts.len());
        for p in parts {
            let rate = self.electron_rate_image(p.irradiance)?;
            if rate.len() != total.len() {
                return Err(SensorError::input(
                    "light parts",
                    "a part's electron image does not match the sensor's pixels",
                ));
            }
            total.par_iter_mut().zip(&rate).for_each(|(t, r)| *t += *r);
            out.push((rate, p.light));
        }
        Ok(PartRates {
            steady,
            parts: out,
            total,
        })
    }

    /// Frame index `key`'s rates: the steady rate plus each part times its rows' gains
    /// (`one`: the resolved exposure and global reset, which set each row's light time).
    fn parts_frame_rate(
        &self,
        pr: &PartRates,
        key: u64,
        one: &Capture,
        shift: &dyn Fn(LightTiming) -> LightTiming,
    ) -> Result<Vec<f32>> {
        let Exposure::Seconds(exposure_s) = one.exposure else {
            return Err(SensorError::input(
                "exposure",
                "a modulated light needs the exposure resolved first",
            ));
        };
        let (rows, cols) = (self.rows(), self.cols());
        let g = one.global_reset.as_ref();
        let mut out = pr.steady.clone();
        for (rate, light) in &pr.parts {
            let gains = shift(*light).row_gains(key, rows, exposure_s, |r| {
                crate::compute::row_times_s(g, r, exposure_s).0
            });
            out.par_chunks_mut(cols)
                .zip(rate.par_chunks(cols))
                .zip(&gains)
                .for_each(|((o, p), gain)| {
                    let gain = *gain as f32;
                    o.iter_mut().zip(p).for_each(|(o, p)| *o += gain * *p);
                });
        }
        Ok(out)
    }

    /// The exposure of a parts capture, metered on the time-mean total.
    fn parts_exposure_s(&self, pr: &PartRates, capture: &Capture, hdr: bool) -> Result<f64> {
        if capture.light.is_some() {
            return Err(SensorError::input(
                "flicker",
                "the scene flickers as a whole (Capture::light) and by light group: give one",
            ));
        }
        let g = if hdr {
            None
        } else {
            capture.global_reset.as_ref()
        };
        let t = self.resolve_exposure(&pr.total, self.rows(), self.cols(), capture.exposure, g)?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(SensorError::input(
                "exposure",
                format!("{t} s is not a finite time >= 0"),
            ));
        }
        Ok(t)
    }

    /// [`Sensor::compute_from`] for a scene lit by `steady` and by modulated `parts`
    /// ([`crate::light_parts`]): frame k (temporal noise keyed on `first_frame + k`) integrates
    /// each part over its rows' own windows. `capture.light` must be `None`.
    pub fn compute_parts_from(
        &self,
        steady: &SpectralImage,
        parts: &[LightPart<'_>],
        capture: &Capture,
        first_frame: u64,
    ) -> Result<Frame> {
        crate::compute::check_capture(capture)?;
        self.check_memory(capture.frames, 2)?;
        let pr = self.part_rates(steady, parts)?;
        let exposure_s = self.parts_exposure_s(&pr, capture, false)?;
        self.parts_frames(&pr, capture, exposure_s, first_frame, &|l| l)
    }

    fn parts_frames(
        &self,
        pr: &PartRates,
        capture: &Capture,
        exposure_s: f64,
        first_frame: u64,
        shift: &dyn Fn(LightTiming) -> LightTiming,
    ) -> Result<Frame> {
        let one = Capture {
            exposure: Exposure::Seconds(exposure_s),
            frames: 1,
            light: None,
            ..*capture
        };
        let mut out: Option<Frame> = None;
        for k in 0..capture.frames as u64 {
            let key = first_frame + k;
            let rate = self.parts_frame_rate(pr, key, &one, shift)?;
            let f = self.capture_from_rate(&rate, self.rows(), self.cols(), &one, key)?;
            match &mut out {
                None => out = Some(f),
                Some(o) => o.append(f),
            }
        }
        out.ok_or_else(|| SensorError::input("frames", "must be at least 1"))
    }

    /// [`Sensor::compute_bracket_like`] for a scene lit by `steady` and modulated `parts`:
    /// exposure i's frames follow all the earlier ones in time, as there.
    pub fn compute_bracket_parts(
        &self,
        steady: &SpectralImage,
        parts: &[LightPart<'_>],
        exposures_s: &[f64],
        like: &Capture,
    ) -> Result<Frame> {
        if exposures_s.is_empty() {
            return Err(SensorError::input(
                "exposures_s",
                "the list of exposure times is empty",
            ));
        }
        if like.frames == 0 {
            return Err(SensorError::input("frames", "must be at least 1"));
        }
        self.check_memory(exposures_s.len().saturating_mul(like.frames), 2)?;
        let pr = self.part_rates(steady, parts)?;
        let mut out: Option<Frame> = None;
        let mut elapsed_s = 0.0;
        for (i, &t) in exposures_s.iter().enumerate() {
            let capture = Capture {
                exposure: Exposure::Seconds(t),
                ..*like
            };
            crate::compute::check_capture(&capture)?;
            let base = (i * like.frames) as u64;
            let start_shift_s = elapsed_s - base as f64 * t;
            // Back to back: exposure i's frame k of index base + k starts after the earlier
            // exposures' frames (as Sensor::compute_bracket_like does for one light).
            let shift = move |l: LightTiming| match l.frame_interval_s {
                Some(_) => l,
                None => LightTiming {
                    start_s: l.start_s + start_shift_s,
                    ..l
                },
            };
            elapsed_s += like.frames as f64 * t;
            let f = self.parts_frames(&pr, &capture, t, base, &shift)?;
            match &mut out {
                None => out = Some(f),
                Some(o) => o.append(f),
            }
        }
        out.ok_or_else(|| SensorError::input("exposures_s", "the list of exposure times is empty"))
    }

    /// [`Sensor::compute_hdr_from`] for a scene lit by `steady` and modulated `parts`: both
    /// readouts of each frame see the frame's modulated rates (a split pixel's small photodiode
    /// integrates the same window, so it flickers as the large one does).
    pub fn compute_hdr_parts_from(
        &self,
        steady: &SpectralImage,
        parts: &[LightPart<'_>],
        capture: &Capture,
        first_frame: u64,
    ) -> Result<HdrFrame> {
        crate::compute::check_capture(capture)?;
        self.check_memory(capture.frames, 8)?;
        let pr = self.part_rates(steady, parts)?;
        let exposure_s = self.parts_exposure_s(&pr, capture, true)?;
        let one = Capture {
            exposure: Exposure::Seconds(exposure_s),
            frames: 1,
            light: None,
            ..*capture
        };
        let mut out: Option<HdrFrame> = None;
        for k in 0..capture.frames as u64 {
            let key = first_frame + k;
            let rate = self.parts_frame_rate(&pr, key, &one, &|l| l)?;
            let f = self.hdr_from_rate(&rate, &one, key)?;
            match &mut out {
                None => out = Some(f),
                Some(o) => {
                    o.high.extend(f.high);
                    o.low.extend(f.low);
                    o.merged_e.extend(f.merged_e);
                }
            }
        }
        out.ok_or_else(|| SensorError::input("frames", "must be at least 1"))
    }
}
