//! Sensor defects and structured fixed patterns (`[defects]` of a sensor TOML): column and row
//! fixed-pattern noise (offset and gain of each column's and row's readout chain), and hot, dead
//! and stuck pixels. All are fixed per sensor: drawn from the sensor's `fixed_pattern_seed` on
//! streams of their own (keyed on the row or column index, so the pattern of a window's rows and
//! columns is the full sensor's there, as the PRNU/DSNU pattern is), the same in every frame and
//! capture. ISETCam `noiseColumnFPN` (column offset and gain FPN, applied to the voltage after
//! the pixel) and `faultyInsert` (dead and hot pixels) model the same effects.
//!
//! Where they act in the readout (camsim-sensor's model, `compute.rs`): a hot pixel adds its own
//! dark current (electrons with shot noise, over the dark integration time); a dead pixel
//! collects no photo-electrons (its offset, dark signal and read noise remain); the column and row
//! chains scale and offset the pixel voltage, v' = v (1 + g_col + g_row) + o_col + o_row (all
//! normals of the configured sigma), before the analog gain and the ADC; a stuck pixel reads a
//! fixed value whatever it collects; a random-telegraph-noise (RTN) pixel's source follower
//! has a trap that is either empty or filled, so its output steps by a fixed amplitude between
//! two levels from frame to frame (Janesick, *Photon Transfer*, SPIE 2007, ch. 7 "RTS noise";
//! the trap's time constants are taken long against the readout and short against the frame
//! interval, so each frame samples the state independently: high with probability
//! `rtn_high_probability`).

use crate::{Result, SensorError};
use camsim_core::rng::{keyed, stage};
use rand::Rng as _;
use serde::{Deserialize, Serialize};

/// Stream keys of the defect maps within the fixed-pattern stage (the PRNU/DSNU stream is
/// frame 0 of [`stage::SENSOR_FIXED_PATTERN`]).
const COLUMN_STREAM: u64 = 1;
const ROW_STREAM: u64 = 2;
const DEFECT_STREAM: u64 = 3;

/// `[defects]`: structured fixed patterns and faulty pixels. Every field defaults to none.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DefectsConfig {
    /// Column FPN: standard deviation of each column's offset, mV at the pixel (before the
    /// analog gain, as `dsnu_mv`).
    #[serde(default)]
    pub column_offset_mv: f64,
    /// Column FPN: standard deviation of each column's gain error, percent.
    #[serde(default)]
    pub column_gain_percent: f64,
    /// Row FPN: standard deviation of each row's offset, mV.
    #[serde(default)]
    pub row_offset_mv: f64,
    /// Row FPN: standard deviation of each row's gain error, percent.
    #[serde(default)]
    pub row_gain_percent: f64,
    /// Fraction of pixels that are hot, in [0, 1).
    #[serde(default)]
    pub hot_fraction: f64,
    /// A hot pixel's own dark current, electrons per second (added to the sensor's).
    #[serde(default = "default_hot_e_per_s")]
    pub hot_dark_current_e_per_s: f64,
    /// Fraction of pixels that are dead (no photo-response), in [0, 1).
    #[serde(default)]
    pub dead_fraction: f64,
    /// Fraction of pixels stuck at `stuck_dn`, in [0, 1).
    #[serde(default)]
    pub stuck_fraction: f64,
    /// Fraction of pixels with random telegraph noise, in [0, 1).
    #[serde(default)]
    pub rtn_fraction: f64,
    /// An RTN pixel's step between its two levels, electrons at the pixel (the source
    /// follower's output step over the conversion gain).
    #[serde(default = "default_rtn_amplitude_e")]
    pub rtn_amplitude_e: f64,
    /// The probability that an RTN pixel is in its high state in a frame, in [0, 1] (the
    /// fraction of time its trap is filled).
    #[serde(default = "default_rtn_high")]
    pub rtn_high_probability: f64,
    /// The value stuck pixels read, DN (default: the ADC's largest value, a stuck-high pixel).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stuck_dn: Option<f64>,
    /// Fraction of the defective pixels that come as a pair with their right-hand neighbour of
    /// the same kind (a cluster of two, as defect-correction specifications count them).
    #[serde(default)]
    pub pair_fraction: f64,
}

fn default_hot_e_per_s() -> f64 {
    2000.0
}

fn default_rtn_amplitude_e() -> f64 {
    10.0
}

fn default_rtn_high() -> f64 {
    0.5
}

/// The kind of a faulty pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DefectKind {
    /// Extra dark current.
    Hot,
    /// No photo-response.
    Dead,
    /// Reads a fixed value.
    Stuck,
    /// Steps between two levels from frame to frame (random telegraph noise).
    Rtn,
}

/// One faulty pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Defect {
    /// Stored row (raw.dng's orientation).
    pub row: usize,
    /// Column.
    pub col: usize,
    /// What is wrong with it.
    pub kind: DefectKind,
}

/// The drawn patterns of one sensor size.
#[derive(Debug, Clone, PartialEq)]
pub struct DefectMap {
    /// Per column: its gain error (a fraction: the voltage is scaled by 1 + it).
    pub column_gain: Vec<f64>,
    /// Per column: its offset, V at the pixel.
    pub column_offset_v: Vec<f64>,
    /// Per row: its gain error (fraction).
    pub row_gain: Vec<f64>,
    /// Per row: its offset, V.
    pub row_offset_v: Vec<f64>,
    /// Faulty pixels, sorted by row then column (at most one per pixel).
    pub defects: Vec<Defect>,
    /// Index into `defects` of each row's first, rows + 1 entries.
    row_start: Vec<usize>,
    /// A hot pixel's extra dark current, e-/s.
    pub hot_e_per_s: f64,
    /// An RTN pixel's step, e-.
    pub rtn_amplitude_e: f64,
    /// The probability of an RTN pixel's high state in a frame.
    pub rtn_high_probability: f64,
    /// A stuck pixel's value, DN.
    pub stuck_dn: f64,
}

impl DefectsConfig {
    /// Check the values; errors name the key under `defects.`.
    pub fn validate(&self) -> std::result::Result<(), (String, String)> {
        let bad = |k: &str, m: String| Err((format!("defects.{k}"), m));
        for (k, v) in [
            ("column_offset_mv", self.column_offset_mv),
            ("column_gain_percent", self.column_gain_percent),
            ("row_offset_mv", self.row_offset_mv),
            ("row_gain_percent", self.row_gain_percent),
            ("hot_dark_current_e_per_s", self.hot_dark_current_e_per_s),
            ("rtn_amplitude_e", self.rtn_amplitude_e),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(k, format!("{v}: must be a finite number >= 0"));
            }
        }
        for (k, v) in [
            ("hot_fraction", self.hot_fraction),
            ("dead_fraction", self.dead_fraction),
            ("stuck_fraction", self.stuck_fraction),
            ("rtn_fraction", self.rtn_fraction),
            ("pair_fraction", self.pair_fraction),
        ] {
            if !(0.0..1.0).contains(&v) {
                return bad(k, format!("{v}: must be a fraction in [0, 1)"));
            }
        }
        if !(0.0..=1.0).contains(&self.rtn_high_probability) {
            return bad(
                "rtn_high_probability",
                format!(
                    "{}: must be a probability in [0, 1]",
                    self.rtn_high_probability
                ),
            );
        }
        if self.hot_fraction + self.dead_fraction + self.stuck_fraction + self.rtn_fraction >= 1.0 {
            return bad(
                "hot_fraction",
                "hot + dead + stuck + rtn fractions must add up to less than 1".into(),
            );
        }
        if let Some(d) = self.stuck_dn.filter(|d| !(d.is_finite() && *d >= 0.0)) {
            return bad("stuck_dn", format!("{d}: must be a value >= 0 DN"));
        }
        Ok(())
    }

    /// Draw the patterns of a `rows` x `cols` sensor from `seed` (the sensor's
    /// `fixed_pattern_seed`); `max_dn` is the ADC's largest value (the default stuck value).
    pub fn draw(&self, rows: usize, cols: usize, seed: u64, max_dn: f64) -> Result<DefectMap> {
        self.validate().map_err(|(k, m)| SensorError::input(k, m))?;
        let zig = crate::normal::Ziggurat::get();
        let normals = |stream: u64, n: usize, sigma_a: f64, sigma_b: f64| -> (Vec<f64>, Vec<f64>) {
            (0..n)
                .map(|i| {
                    let mut r = keyed(seed, stage::SENSOR_FIXED_PATTERN, stream, i as u64);
                    (sigma_a * zig.sample(&mut r), sigma_b * zig.sample(&mut r))
                })
                .unzip()
        };
        let (column_gain, column_offset_v) = normals(
            COLUMN_STREAM,
            cols,
            self.column_gain_percent * 1e-2,
            self.column_offset_mv * 1e-3,
        );
        let (row_gain, row_offset_v) = normals(
            ROW_STREAM,
            rows,
            self.row_gain_percent * 1e-2,
            self.row_offset_mv * 1e-3,
        );
        // Faulty pixels: per row, one uniform per pixel picks its kind (hot, dead, stuck or
        // none by the fractions), a second whether a defect takes its right neighbour too.
        let mut kinds: Vec<Option<DefectKind>> = Vec::new();
        let (h, d, s) = (self.hot_fraction, self.dead_fraction, self.stuck_fraction);
        let rtn = self.rtn_fraction;
        let mut defects = Vec::new();
        let mut row_start = Vec::with_capacity(rows + 1);
        if h + d + s + rtn > 0.0 {
            for r in 0..rows {
                let mut rng = keyed(seed, stage::SENSOR_FIXED_PATTERN, DEFECT_STREAM, r as u64);
                kinds.clear();
                kinds.resize(cols, None);
                for c in 0..cols {
                    let u: f64 = rng.gen();
                    let pair: f64 = rng.gen();
                    let kind = if u < h {
                        DefectKind::Hot
                    } else if u < h + d {
                        DefectKind::Dead
                    } else if u < h + d + s {
                        DefectKind::Stuck
                    } else if u < h + d + s + rtn {
                        DefectKind::Rtn
                    } else {
                        continue;
                    };
                    kinds[c] = Some(kind);
                    if pair < self.pair_fraction && c + 1 < cols {
                        kinds[c + 1] = kinds[c + 1].or(Some(kind));
                    }
                }
                row_start.push(defects.len());
                defects.extend(kinds.iter().enumerate().filter_map(|(c, k)| {
                    k.map(|kind| Defect {
                        row: r,
                        col: c,
                        kind,
                    })
                }));
            }
        } else {
            row_start.resize(rows, 0);
        }
        row_start.push(defects.len());
        Ok(DefectMap {
            column_gain,
            column_offset_v,
            row_gain,
            row_offset_v,
            defects,
            row_start,
            hot_e_per_s: self.hot_dark_current_e_per_s,
            rtn_amplitude_e: self.rtn_amplitude_e,
            rtn_high_probability: self.rtn_high_probability,
            stuck_dn: self.stuck_dn.unwrap_or(max_dn),
        })
    }
}

impl DefectMap {
    /// The faulty pixels of stored row `r`, by column.
    pub fn row_defects(&self, r: usize) -> &[Defect] {
        match (self.row_start.get(r), self.row_start.get(r + 1)) {
            (Some(a), Some(b)) => &self.defects[*a..*b],
            _ => &[],
        }
    }

    /// Whether the column/row chains add anything.
    pub fn has_fpn(&self) -> bool {
        self.column_gain
            .iter()
            .chain(&self.column_offset_v)
            .chain(&self.row_gain)
            .chain(&self.row_offset_v)
            .any(|v| *v != 0.0)
    }
}
