//! The camera in time: when each raw frame's exposure starts and how long it lasts (bursts,
//! brackets, video), the shutter (global, or rolling row by row), how sensor rows map to the
//! rows of a render, and optical flow on the sensor's pixel grid.
//!
//! A frame's window is `[start, start + exposure]` in the scene's time (s): the first starts at
//! `capture.start_ms` (default: the pbrt camera's `shutteropen`), each next one a frame interval
//! later (`capture.fps`, `capture.frame_interval_ms`, or back to back). With a rolling shutter,
//! sensor row `r` (counted from the sensor's top edge) starts `r` line times after the frame;
//! the lens turns the image upside down, so the sensor's top row sees the bottom of the scene.
//! camsim stores every image as it is seen (raw.dng row 0 is the top of the scene, the sensor's
//! bottom row), so a `top-down` readout starts at raw.dng's last row and moves up the picture;
//! `bottom-up` starts at the top of the picture (how phones mount their sensors).

use crate::{CaptureSection, PipelineError, Result};
use camsim_scene3d::motion::RowReadout;
use serde::{Deserialize, Serialize};

/// `[capture] shutter`: `"global"`, `{ rolling = { line_time_us, direction } }` or
/// `{ global_reset = { line_time_us, direction, mechanical_shutter } }`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ShutterConfig {
    /// Every row integrates over the frame's window.
    #[default]
    Global,
    /// Rows start one after another (an electronic rolling shutter).
    Rolling {
        /// Time between the starts of two consecutive sensor rows, us.
        line_time_us: f64,
        /// Which sensor row starts first.
        #[serde(default)]
        direction: ReadoutDirection,
    },
    /// Global reset, rolling readout (a CMOS sensor's "global reset release" mode): every row
    /// starts integrating at the frame's start, rows are read one line time apart; the first
    /// row read integrates the exposure, each later one its readout delay longer. With a
    /// mechanical shutter closing for every row at the end of the exposure, every row sees the
    /// same light (the global shutter's image) and row r's dark current integrates its readout
    /// delay longer. Hamamatsu camera glossary, "Global reset trigger mode"; FLIR Spinnaker
    /// `SensorShutterMode_GlobalReset` ("opens at the same time for all pixels but ends in a
    /// sequential manner").
    GlobalReset {
        /// Time between the readouts of two consecutive sensor rows, us.
        line_time_us: f64,
        /// Which sensor row is read first.
        #[serde(default)]
        direction: ReadoutDirection,
        /// A mechanical shutter ends the light for every row at the end of the exposure.
        #[serde(default)]
        mechanical_shutter: bool,
    },
}

/// The order in which a rolling shutter reads the sensor's rows.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum ReadoutDirection {
    /// The sensor's top row first (it sees the bottom of the scene: raw.dng's last row).
    #[default]
    TopDown,
    /// The sensor's bottom row first (the top of the scene: raw.dng's row 0).
    BottomUp,
}

impl ShutterConfig {
    /// Whether it is the global shutter (the default, left out of written configs).
    pub fn is_global(&self) -> bool {
        *self == ShutterConfig::Global
    }

    /// The line time, s (0 for the global shutter).
    pub fn line_time_s(&self) -> f64 {
        match self {
            ShutterConfig::Global => 0.0,
            ShutterConfig::Rolling { line_time_us, .. }
            | ShutterConfig::GlobalReset { line_time_us, .. } => line_time_us * 1e-6,
        }
    }

    /// The readout direction (`None` for the global shutter).
    fn direction(&self) -> Option<ReadoutDirection> {
        match self {
            ShutterConfig::Global => None,
            ShutterConfig::Rolling { direction, .. }
            | ShutterConfig::GlobalReset { direction, .. } => Some(*direction),
        }
    }

    /// The variant's key in the config.
    fn key(&self) -> &'static str {
        match self {
            ShutterConfig::Global => "global",
            ShutterConfig::Rolling { .. } => "rolling",
            ShutterConfig::GlobalReset { .. } => "global_reset",
        }
    }

    fn validate(&self) -> Result<()> {
        let lt = self.line_time_s() * 1e6;
        if !(lt.is_finite() && lt >= 0.0) {
            return Err(PipelineError::config(format!(
                "capture.shutter.{}.line_time_us = {lt}: must be a time >= 0 us",
                self.key()
            )));
        }
        Ok(())
    }

    /// The readout delay of each stored sensor row (raw.dng's orientation) as `(delay of row 0,
    /// delay per row)`, s: the row read first has none. A top-down readout starts at the
    /// sensor's top row, which the lens points at the bottom of the scene (the last stored
    /// row). `None` for the global shutter.
    fn stored_row_delays_s(&self, sensor_rows: usize) -> Option<(f64, f64)> {
        let lt = self.line_time_s();
        let last = sensor_rows.saturating_sub(1) as f64;
        Some(match self.direction()? {
            ReadoutDirection::TopDown => (lt * last, -lt),
            ReadoutDirection::BottomUp => (0.0, lt),
        })
    }

    /// What the sensor integrates per row in a global-reset mode (`None` otherwise).
    pub fn sensor_global_reset(&self, sensor_rows: usize) -> Option<camsim_sensor::GlobalReset> {
        let ShutterConfig::GlobalReset {
            mechanical_shutter, ..
        } = self
        else {
            return None;
        };
        let (row0, per_row) = self.stored_row_delays_s(sensor_rows)?;
        Some(camsim_sensor::GlobalReset {
            row0_extra_s: row0,
            per_row_extra_s: per_row,
            mechanical_shutter: *mechanical_shutter,
        })
    }

    /// The delay of each render row for a sensor of `sensor_rows` rows imaged by a render
    /// `render_rows` high, `k` sensor pixels per render pixel, both centred on the optical axis
    /// (as the optics and sensor stages place them): render row `y`'s centre lies on the sensor's
    /// (stored, upright) row `rows/2 - 1/2 + (y + 1/2 - H/2) k`, which is physical row `rows - 1`
    /// minus that (the lens's inversion). `None` for the global shutter.
    pub fn row_readout(
        &self,
        sensor_rows: usize,
        render_rows: usize,
        k: f64,
    ) -> Option<RowReadout> {
        let global_reset = match self {
            ShutterConfig::Global => return None,
            ShutterConfig::Rolling { .. } => false,
            // The light stops for every row at once: the render is the global shutter's.
            ShutterConfig::GlobalReset {
                mechanical_shutter: true,
                ..
            } => return None,
            ShutterConfig::GlobalReset { .. } => true,
        };
        let direction = self.direction()?;
        let lt = self.line_time_s();
        let (rows, h) = (sensor_rows as f64, render_rows as f64);
        // Stored row of render row y: a + k y.
        let a = rows / 2.0 - 0.5 + (0.5 - h / 2.0) * k;
        Some(match direction {
            // Physical row index rows - 1 - (a + k y) is read at that many line times.
            ReadoutDirection::TopDown => RowReadout {
                row0_delay_s: lt * (rows - 1.0 - a),
                per_row_delay_s: -lt * k,
                global_reset,
            },
            ReadoutDirection::BottomUp => RowReadout {
                row0_delay_s: lt * a,
                per_row_delay_s: lt * k,
                global_reset,
            },
        })
    }

    /// For run.json: the shutter, its line time and readout time over `rows` rows.
    pub fn describe(&self, rows: usize) -> serde_json::Value {
        let Some(direction) = self.direction() else {
            return serde_json::json!({ "kind": "global" });
        };
        let mut v = serde_json::json!({
            "kind": self.key(),
            "direction": direction,
            "line_time_s": self.line_time_s(),
            "readout_s": self.line_time_s() * rows.saturating_sub(1) as f64,
            "first_row": match direction {
                ReadoutDirection::TopDown => "the sensor's top row: the bottom of the scene, raw.dng's last row",
                ReadoutDirection::BottomUp => "the sensor's bottom row: the top of the scene, raw.dng's row 0",
            },
        });
        if let ShutterConfig::GlobalReset {
            mechanical_shutter, ..
        } = self
        {
            v["mechanical_shutter"] = (*mechanical_shutter).into();
        }
        v
    }
}

/// One raw frame's window in the scene's time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameTime {
    /// Start of the exposure (of the first row to start, for a rolling shutter), s.
    pub start_s: f64,
    /// How long the scene is integrated, s: the exposure time (with auto-exposure, the scene's
    /// own shutter length: the sensor's exposure is not known before it sees the image).
    pub duration_s: f64,
}

impl CaptureSection {
    /// The frame interval the config gives, s (`fps` or `frame_interval_ms`), or `None` for
    /// back-to-back frames; the error names the key.
    pub fn frame_interval_s(&self) -> Result<Option<f64>> {
        match (self.fps, self.frame_interval_ms) {
            (Some(_), Some(_)) => Err(PipelineError::config(
                "give capture.fps or capture.frame_interval_ms, not both",
            )),
            (Some(f), None) if !(f.is_finite() && f > 0.0) => Err(PipelineError::config(format!(
                "capture.fps = {f}: must be a rate > 0 frames per second"
            ))),
            (Some(f), None) => Ok(Some(1.0 / f)),
            (None, Some(ms)) if !(ms.is_finite() && ms > 0.0) => Err(PipelineError::config(
                format!("capture.frame_interval_ms = {ms}: must be a time > 0 ms"),
            )),
            (None, Some(ms)) => Ok(Some(ms * 1e-3)),
            (None, None) => Ok(None),
        }
    }

    /// The timing a modulated light (`[flicker]`) is integrated with: frame 0 starts at
    /// `capture.start_ms` (else `default_start_s`), frames a frame interval apart (back to back
    /// without one), and a rolling shutter's stored rows start their readout delays after their
    /// frame (a global shutter's and a global reset's rows all start with the frame). `None`
    /// without `flicker`; a bad flicker key is an error naming it.
    pub fn light_timing(
        &self,
        flicker: Option<camsim_sensor::Flicker>,
        sensor_rows: usize,
        default_start_s: f64,
    ) -> Result<Option<camsim_sensor::LightTiming>> {
        let Some(flicker) = flicker else {
            return Ok(None);
        };
        flicker
            .validate("flicker")
            .map_err(|e| PipelineError::config(e.to_string()))?;
        let (row0_s, per_row_s) = match self.shutter {
            ShutterConfig::Rolling { .. } => self
                .shutter
                .stored_row_delays_s(sensor_rows)
                .unwrap_or((0.0, 0.0)),
            ShutterConfig::Global | ShutterConfig::GlobalReset { .. } => (0.0, 0.0),
        };
        Ok(Some(camsim_sensor::LightTiming {
            flicker,
            start_s: self.start_ms.map_or(default_start_s, |ms| ms * 1e-3),
            frame_interval_s: self.frame_interval_s()?,
            row0_s,
            per_row_s,
        }))
    }

    /// The timings of light groups that flicker each in its own way (`[light_flicker]`), sorted
    /// by group name, as [`CaptureSection::light_timing`] times one light; empty without the
    /// table. A bad key is an error naming it (`light_flicker.NAME.duty`).
    pub fn group_light_timings(
        &self,
        light_flicker: Option<&std::collections::BTreeMap<String, camsim_sensor::Flicker>>,
        sensor_rows: usize,
        default_start_s: f64,
    ) -> Result<Vec<(String, camsim_sensor::LightTiming)>> {
        let Some(table) = light_flicker else {
            return Ok(Vec::new());
        };
        table
            .iter()
            .map(|(name, f)| {
                f.validate(&format!("light_flicker.{name}"))
                    .map_err(|e| PipelineError::config(e.to_string()))?;
                let timing = self
                    .light_timing(Some(*f), sensor_rows, default_start_s)?
                    .expect("a flicker gives a timing");
                Ok((name.clone(), timing))
            })
            .collect()
    }

    /// Check the timing keys (start, interval, rate, shutter); the error names the key.
    pub fn check_timing(&self) -> Result<()> {
        if let Some(s) = self.start_ms {
            if !s.is_finite() {
                return Err(PipelineError::config(format!(
                    "capture.start_ms = {s}: must be a finite time, ms"
                )));
            }
        }
        self.frame_interval_s()?;
        self.shutter.validate()
    }

    /// The windows of the raw frames in file order, each `durations_s[k]` long: the first starts
    /// at `capture.start_ms` (else `default_start_s`), each next one a frame interval later
    /// (back to back without one). A duration longer than the interval is refused.
    pub fn frame_times(&self, durations_s: &[f64], default_start_s: f64) -> Result<Vec<FrameTime>> {
        self.check_timing()?;
        let interval = self.frame_interval_s()?;
        let mut t = self.start_ms.map_or(default_start_s, |ms| ms * 1e-3);
        let mut out = Vec::with_capacity(durations_s.len());
        for (k, &d) in durations_s.iter().enumerate() {
            if let Some(dt) = interval {
                if d > dt * (1.0 + 1e-9) {
                    return Err(PipelineError::config(format!(
                        "frame {k}: its exposure ({} ms) is longer than the frame interval ({} ms, capture.fps or capture.frame_interval_ms)",
                        d * 1e3,
                        dt * 1e3
                    )));
                }
            }
            out.push(FrameTime {
                start_s: t,
                duration_s: d,
            });
            t += interval.unwrap_or(d);
        }
        Ok(out)
    }
}

/// A render's flow map (render pixels) on the sensor's grid, in sensor pixels: each sensor
/// pixel takes the flow of the render pixel under its centre (nearest; both centred on the
/// optical axis, `k` sensor pixels per render pixel), scaled by `k`. Orientation as raw.dng.
pub fn flow_on_sensor(
    map: &camsim_render::flow::FlowMap,
    k: f64,
    rows: usize,
    cols: usize,
) -> Vec<[f32; 2]> {
    let (w, h) = (map.width as f64, map.height as f64);
    let index = |c: f64, n_out: usize, n_in: f64| -> usize {
        let x = n_in / 2.0 + (c + 0.5 - n_out as f64 / 2.0) / k;
        (x.floor().max(0.0) as usize).min(n_in as usize - 1)
    };
    let xs: Vec<usize> = (0..cols).map(|c| index(c as f64, cols, w)).collect();
    let mut out = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        let y = index(r as f64, rows, h);
        for &x in &xs {
            let f = map.xy_px[y * map.width + x];
            out.push([(f[0] as f64 * k) as f32, (f[1] as f64 * k) as f32]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shutter_parses_global_and_rolling_and_refuses_bad_keys() {
        #[derive(Deserialize)]
        struct T {
            shutter: ShutterConfig,
        }
        let g: T = toml::from_str("shutter = \"global\"").unwrap();
        assert!(g.shutter.is_global());
        let r: T = toml::from_str(
            "shutter = { rolling = { line_time_us = 10.0, direction = \"bottom-up\" } }",
        )
        .unwrap();
        assert_eq!(
            r.shutter,
            ShutterConfig::Rolling {
                line_time_us: 10.0,
                direction: ReadoutDirection::BottomUp
            }
        );
        assert!(toml::from_str::<T>("shutter = { rolling = { line_time = 10.0 } }").is_err());
        assert!(toml::from_str::<T>("shutter = \"rolling\"").is_err());
    }

    /// With one render row per sensor row, a top-down readout starts the last stored row (the
    /// sensor's top row, which the lens points at the bottom of the scene) first and each row
    /// above it one line time later; bottom-up the reverse.
    #[test]
    fn rows_map_through_the_lens_inversion() {
        let s = ShutterConfig::Rolling {
            line_time_us: 10.0,
            direction: ReadoutDirection::TopDown,
        };
        let r = s.row_readout(480, 480, 1.0).unwrap();
        let delay = |y: f64| r.row0_delay_s + r.per_row_delay_s * y;
        assert!((delay(479.0) - 0.0).abs() < 1e-15 && (delay(0.0) - 479e-5).abs() < 1e-12);
        let b = ShutterConfig::Rolling {
            line_time_us: 10.0,
            direction: ReadoutDirection::BottomUp,
        }
        .row_readout(480, 240, 2.0)
        .unwrap();
        // Render row 0 of a half-resolution render covers sensor rows 0 and 1: its centre is
        // row 0.5, read 5 us after the start.
        assert!((b.row0_delay_s - 5e-6).abs() < 1e-15 && (b.per_row_delay_s - 20e-6).abs() < 1e-15);
        assert!(ShutterConfig::Global.row_readout(480, 480, 1.0).is_none());
    }

    #[test]
    fn frame_times_follow_rate_interval_or_back_to_back() {
        let mut c = CaptureSection::default();
        let t = c.frame_times(&[0.01, 0.02, 0.01], 0.5).unwrap();
        assert_eq!(
            t.iter().map(|f| f.start_s).collect::<Vec<_>>(),
            [0.5, 0.51, 0.53]
        );
        c.fps = Some(25.0);
        c.start_ms = Some(100.0);
        let t = c.frame_times(&[0.01; 3], 0.0).unwrap();
        assert!((t[2].start_s - 0.18).abs() < 1e-12);
        assert!(c
            .frame_times(&[0.05], 0.0)
            .unwrap_err()
            .to_string()
            .contains("longer than"));
        c.frame_interval_ms = Some(10.0);
        assert!(c
            .check_timing()
            .unwrap_err()
            .to_string()
            .contains("not both"));
        c.frame_interval_ms = None;
        c.fps = Some(0.0);
        assert!(c
            .check_timing()
            .unwrap_err()
            .to_string()
            .contains("capture.fps"));
    }
}
