//! Scattering flare: dust, scratches, smudges and file-given transmission / phase patterns on the
//! lens pupil of the wavefront model (`[flare]`).
//!
//! Contamination on the front surface is modelled, as Wu et al. (ICCV 2021, "How to train neural
//! networks for flare removal", sec. 3.1) do, as a perturbation of the pupil function
//! P(x, y) = A(x, y) t(x, y) exp(-i 2 pi (W(x, y) / lambda + phi(x, y))): t is the contamination's
//! amplitude transmission and phi its phase error in waves, and the PSF is |F{P}|^2 as for the
//! clean pupil ([`crate::Wavefront`]).
//!
//! - Dust: opaque (or grey) discs, log-uniform radii, centres uniform over the pupil with each disc
//!   wholly inside it and no two overlapping, so the covered fraction is sum r_i^2 / a^2 exactly.
//!   By Babinet's principle each opaque disc diffracts as much energy as it blocks, spread over its
//!   own (wide) Airy pattern: a dust coverage c scatters the fraction c of the transmitted light
//!   far from the core (for intensity transmission T of the discs, c (1 - sqrt T)^2 / (1 - c (1 - T))).
//! - Scratches: straight strips of a width and length, reduced transmission. A strip of width w
//!   and length L >> w diffracts into sinc^2 of the width across it and of the length along it:
//!   a streak perpendicular to the scratch, of angular width lambda / L and length lambda / w.
//! - Smudges: a smooth Gaussian random phase error of a given RMS (waves) and correlation length
//!   (the 1/e distance of its correlation function exp(-d^2 / l^2)): white noise convolved with a
//!   Gaussian of standard deviation l / 2, then set to zero mean and the given RMS over the pupil.
//!   The core keeps |<exp(i 2 pi phi)>|^2 ~ exp(-(2 pi sigma)^2) of the light (Ruze 1966; the
//!   Strehl ratio for a Gaussian phase error), the rest scatters over angles ~ lambda / l.
//! - `mask` (intensity transmission, as a grey image: the amplitude is its square root) and
//!   `phase_mask` (grey values times `phase_mask_waves`), stretched over the pupil's bounding
//!   square like `[aperture] mask`.
//!
//! All sizes are given on the pupil (mm or um) and normalized here by the pupil radius a.
//! Random draws come from `camsim_core::rng::key(seed, FLARE_STAGE, kind, index)`: the same seed
//! gives the same pattern on any machine and thread count.

use crate::aperture::TransmissionMask;
use crate::error::{OpticsError, Result};
use std::f64::consts::PI;
use std::sync::Arc;

/// Random stream stage key of the flare patterns (distinct from camsim_core's stage keys 1..=5).
const FLARE_STAGE: u64 = 0x0F1A_4E00;
const KIND_DUST: u64 = 1;
const KIND_SCRATCH: u64 = 2;
const KIND_SMUDGE: u64 = 3;

/// Side of the smudge raster over the pupil's bounding square.
const SMUDGE_SIDE: usize = 256;
/// Side of the lookup grid of dust and scratches over the bounding square.
const BUCKETS: usize = 32;
/// Features are listed in every bucket they come within this distance of (normalized units), so
/// a cell of up to `BUCKET_MARGIN / 0.7072` wide finds all features that touch it.
const BUCKET_MARGIN: f64 = 0.05;

/// A uniform number in [0, 1) from (seed, kind, index, draw).
fn uniform(seed: u64, kind: u64, index: u64, draw: u64) -> f64 {
    let k = camsim_core::rng::key(seed, FLARE_STAGE, kind, index.wrapping_mul(16) + draw);
    ((k >> 75) as u64 as f64) / (1u64 << 53) as f64
}

/// A standard normal number from (seed, kind, index) (Box-Muller).
fn normal(seed: u64, kind: u64, index: u64) -> f64 {
    let u1 = 1.0 - uniform(seed, kind, index, 0);
    let u2 = uniform(seed, kind, index, 1);
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// One feature: a disc (dust) or a strip (scratch), normalized pupil units.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Feature {
    /// Centre and radius.
    Disc { cx: f64, cy: f64, r: f64 },
    /// Centre, unit direction along the strip, half-length and half-width.
    Strip {
        cx: f64,
        cy: f64,
        ux: f64,
        uy: f64,
        half_len: f64,
        half_width: f64,
    },
}

impl Feature {
    /// A 1-Lipschitz lower bound of the distance to the feature outside it, and minus the depth
    /// inside it (exact for the disc; the max of the two half-widths' bounds for the strip).
    fn field(&self, x: f64, y: f64) -> f64 {
        match *self {
            Feature::Disc { cx, cy, r } => ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - r,
            Feature::Strip {
                cx,
                cy,
                ux,
                uy,
                half_len,
                half_width,
            } => {
                let (dx, dy) = (x - cx, y - cy);
                let along = (dx * ux + dy * uy).abs() - half_len;
                let across = (dx * uy - dy * ux).abs() - half_width;
                along.max(across)
            }
        }
    }

    /// Bounding box (x0, y0, x1, y1).
    fn bounds(&self) -> (f64, f64, f64, f64) {
        match *self {
            Feature::Disc { cx, cy, r } => (cx - r, cy - r, cx + r, cy + r),
            Feature::Strip {
                cx,
                cy,
                ux,
                uy,
                half_len,
                half_width,
            } => {
                let ex = (ux * half_len).abs() + (uy * half_width).abs();
                let ey = (uy * half_len).abs() + (ux * half_width).abs();
                (cx - ex, cy - ey, cx + ex, cy + ey)
            }
        }
    }
}

/// A grey image read as a phase pattern: value times `waves`.
#[derive(Debug, Clone, PartialEq)]
struct PhaseMask {
    image: TransmissionMask,
    waves: f64,
}

/// The contamination of the pupil: built by [`PupilFlare::builder`] or from a `[flare]` config
/// ([`crate::optics::flare_from_config`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PupilFlare {
    features: Vec<Feature>,
    /// Amplitude transmission of each feature (sqrt of its intensity transmission).
    amplitude: Vec<f64>,
    /// Number of leading entries of `features` that are dust.
    dust_count: usize,
    /// Feature indices per bucket, BUCKETS x BUCKETS over [-1, 1]^2.
    buckets: Vec<Vec<u32>>,
    /// Smudge phase, waves, SMUDGE_SIDE^2 over [-1, 1]^2 (pixel centres as TransmissionMask's).
    smudge: Option<Arc<[f32]>>,
    /// Intensity transmission mask.
    mask: Option<TransmissionMask>,
    phase_mask: Option<PhaseMask>,
    /// Smallest feature size (dust diameter, scratch width), normalized by the pupil radius.
    min_feature: f64,
}

impl PupilFlare {
    /// No contamination.
    pub fn new() -> Self {
        Self::default()
    }

    /// True when nothing is set (the PSF then runs the clean pupil's code).
    pub fn is_empty(&self) -> bool {
        self.features.is_empty()
            && self.smudge.is_none()
            && self.mask.is_none()
            && self.phase_mask.is_none()
    }

    /// Dust discs of intensity transmission `transmission`, radii (normalized by the pupil radius)
    /// log-uniform in `[r_min, r_max]`, placed until `count` discs (`Some`) or the covered area
    /// fraction `coverage` is reached; each disc lies wholly inside the pupil and overlaps no other.
    pub fn with_dust(
        mut self,
        seed: u64,
        count: Option<usize>,
        coverage: Option<f64>,
        (r_min, r_max): (f64, f64),
        transmission: f64,
    ) -> Result<Self> {
        if !(r_min > 0.0 && r_min <= r_max && r_max < 0.5) {
            return Err(OpticsError::config(
                "flare.dust_radius_um",
                format!(
                    "[{r_min}, {r_max}] pupil radii: need 0 < min <= max < half the pupil radius"
                ),
            ));
        }
        check_fraction("flare.dust_opacity", 1.0 - transmission)?;
        let (limit_n, limit_c) = match (count, coverage) {
            (Some(n), None) if n <= 100_000 => (n, f64::INFINITY),
            (Some(n), None) => {
                return Err(OpticsError::config(
                    "flare.dust_count",
                    format!("{n} particles; at most 100000"),
                ))
            }
            (None, Some(c)) if c > 0.0 && c <= 0.3 => (usize::MAX, c),
            (None, Some(c)) => {
                return Err(OpticsError::config(
                    "flare.dust_coverage",
                    format!("{c} is not a covered area fraction in (0, 0.3]"),
                ))
            }
            _ => {
                return Err(OpticsError::config(
                    "flare.dust_count",
                    "give one of dust_count or dust_coverage",
                ))
            }
        };
        let mut discs: Vec<(f64, f64, f64)> = Vec::new();
        let mut covered = 0.0;
        let mut index = 0u64;
        let mut misses = 0usize;
        while discs.len() < limit_n && covered < limit_c {
            let ln = (r_max / r_min).ln();
            let r = r_min * (uniform(seed, KIND_DUST, index, 0) * ln).exp();
            // Uniform over the disc of radius 1 - r (so the particle lies inside the pupil).
            let rho = (1.0 - r) * uniform(seed, KIND_DUST, index, 1).sqrt();
            let th = 2.0 * PI * uniform(seed, KIND_DUST, index, 2);
            let (cx, cy) = (rho * th.cos(), rho * th.sin());
            index += 1;
            if discs
                .iter()
                .any(|(x, y, q)| (x - cx).powi(2) + (y - cy).powi(2) < (q + r).powi(2))
            {
                misses += 1;
                if misses > 10_000 {
                    return Err(OpticsError::config(
                        "flare.dust_coverage",
                        format!(
                            "placed {} particles covering {:.4} of the pupil; no room for more without overlap (lower the coverage or the radii)",
                            discs.len(),
                            covered
                        ),
                    ));
                }
                continue;
            }
            misses = 0;
            // The last particle may overshoot a coverage target; keep it (the realized coverage
            // is reported by `dust_coverage`).
            covered += r * r;
            discs.push((cx, cy, r));
        }
        let amp = transmission.sqrt();
        let mut features: Vec<Feature> = discs
            .iter()
            .map(|&(cx, cy, r)| Feature::Disc { cx, cy, r })
            .collect();
        let mut amplitude = vec![amp; features.len()];
        // Dust first, then any scratches already set.
        features.extend(self.features.drain(self.dust_count..));
        amplitude.extend(self.amplitude.drain(self.dust_count..));
        self.dust_count = discs.len();
        self.features = features;
        self.amplitude = amplitude;
        if let Some(rm) = discs.iter().map(|d| 2.0 * d.2).reduce(f64::min) {
            self.min_feature = if self.min_feature > 0.0 {
                self.min_feature.min(rm)
            } else {
                rm
            };
        }
        self.rebuild_buckets();
        Ok(self)
    }

    /// `count` straight scratches of width `width` and length `length` (normalized by the pupil
    /// radius) and intensity transmission `transmission`; centres uniform over the pupil, the
    /// direction `angle_deg` from +x towards +y for all, or uniform at random (None).
    pub fn with_scratches(
        mut self,
        seed: u64,
        count: usize,
        width: f64,
        length: f64,
        angle_deg: Option<f64>,
        transmission: f64,
    ) -> Result<Self> {
        if count > 10_000 {
            return Err(OpticsError::config(
                "flare.scratch_count",
                format!("{count} scratches; at most 10000"),
            ));
        }
        if count == 0 {
            return Ok(self);
        }
        if !(width > 0.0 && width < 0.5) {
            return Err(OpticsError::config(
                "flare.scratch_width_um",
                format!("{width} pupil radii: need a width in (0, 0.5) pupil radii"),
            ));
        }
        if !(length >= width && length <= 4.0) {
            return Err(OpticsError::config(
                "flare.scratch_length_mm",
                format!(
                    "{length} pupil radii: need a length from the width ({width}) to 2 pupil diameters"
                ),
            ));
        }
        if let Some(a) = angle_deg {
            if !a.is_finite() {
                return Err(OpticsError::config(
                    "flare.scratch_angle_deg",
                    format!("{a} is not a finite angle"),
                ));
            }
        }
        check_fraction("flare.scratch_opacity", 1.0 - transmission)?;
        let amp = transmission.sqrt();
        for i in 0..count as u64 {
            let rho = uniform(seed, KIND_SCRATCH, i, 0).sqrt();
            let th = 2.0 * PI * uniform(seed, KIND_SCRATCH, i, 1);
            let dir = match angle_deg {
                Some(a) => a.to_radians(),
                None => PI * uniform(seed, KIND_SCRATCH, i, 2),
            };
            self.features.push(Feature::Strip {
                cx: rho * th.cos(),
                cy: rho * th.sin(),
                ux: dir.cos(),
                uy: dir.sin(),
                half_len: length / 2.0,
                half_width: width / 2.0,
            });
            self.amplitude.push(amp);
        }
        self.min_feature = if self.min_feature > 0.0 {
            self.min_feature.min(width)
        } else {
            width
        };
        self.rebuild_buckets();
        Ok(self)
    }

    /// One straight scratch centred at normalized (cx, cy), direction `angle_deg` from +x towards
    /// +y, `width` and `length` (normalized by the pupil radius), intensity transmission
    /// `transmission` (the part of it outside the pupil is clipped by the aperture).
    pub fn with_scratch(
        mut self,
        (cx, cy): (f64, f64),
        angle_deg: f64,
        width: f64,
        length: f64,
        transmission: f64,
    ) -> Result<Self> {
        if !(cx.is_finite() && cy.is_finite() && angle_deg.is_finite()) {
            return Err(OpticsError::config(
                "flare.scratch",
                format!("centre ({cx}, {cy}) or angle {angle_deg} is not finite"),
            ));
        }
        if !(width > 0.0 && width < 0.5 && length >= width && length <= 4.0) {
            return Err(OpticsError::config(
                "flare.scratch_width_um",
                format!("width {width}, length {length} pupil radii: need 0 < width < 0.5 and width <= length <= 4"),
            ));
        }
        check_fraction("flare.scratch_opacity", 1.0 - transmission)?;
        let dir = angle_deg.to_radians();
        self.features.push(Feature::Strip {
            cx,
            cy,
            ux: dir.cos(),
            uy: dir.sin(),
            half_len: length / 2.0,
            half_width: width / 2.0,
        });
        self.amplitude.push(transmission.sqrt());
        self.min_feature = if self.min_feature > 0.0 {
            self.min_feature.min(width)
        } else {
            width
        };
        self.rebuild_buckets();
        Ok(self)
    }

    /// A smooth random phase error of RMS `rms_waves` over the pupil and correlation length
    /// `correlation` (normalized by the pupil radius; the 1/e distance of the correlation).
    pub fn with_smudge(mut self, seed: u64, rms_waves: f64, correlation: f64) -> Result<Self> {
        if !(0.0..=10.0).contains(&rms_waves) {
            return Err(OpticsError::config(
                "flare.smudge_rms_waves",
                format!("{rms_waves} is not an RMS in [0, 10] waves"),
            ));
        }
        if rms_waves == 0.0 {
            return Ok(self);
        }
        let cell = 2.0 / SMUDGE_SIDE as f64;
        if !(correlation >= 2.0 * cell && correlation <= 2.0) {
            return Err(OpticsError::config(
                "flare.smudge_correlation_mm",
                format!(
                    "{correlation} pupil radii: need {} to 2 pupil radii (the smudge raster has {SMUDGE_SIDE} samples across)",
                    2.0 * cell
                ),
            ));
        }
        // White noise convolved with a unit-sum Gaussian of sigma l / 2 has the correlation
        // exp(-d^2 / l^2) (the autocorrelation of a Gaussian of sigma s is one of sigma s sqrt 2).
        let sigma_px = correlation / 2.0 / cell;
        let k = (3.0 * sigma_px).ceil() as usize;
        let n = SMUDGE_SIDE;
        let m = n + 2 * k;
        let noise: Vec<f64> = (0..(m * m) as u64)
            .map(|i| normal(seed, KIND_SMUDGE, i))
            .collect();
        let w: Vec<f64> = (0..=2 * k)
            .map(|j| (-0.5 * ((j as f64 - k as f64) / sigma_px).powi(2)).exp())
            .collect();
        // Rows (m x n), then columns (n x n).
        let mut tmp = vec![0.0f64; m * n];
        for r in 0..m {
            for c in 0..n {
                tmp[r * n + c] = (0..=2 * k).map(|j| w[j] * noise[r * m + c + j]).sum();
            }
        }
        let mut field = vec![0.0f64; n * n];
        for r in 0..n {
            for c in 0..n {
                field[r * n + c] = (0..=2 * k).map(|j| w[j] * tmp[(r + j) * n + c]).sum();
            }
        }
        // Zero mean and the RMS over the pupil disc.
        let inside = |r: usize, c: usize| {
            let (x, y) = (
                -1.0 + (c as f64 + 0.5) * cell,
                -1.0 + (r as f64 + 0.5) * cell,
            );
            x * x + y * y <= 1.0
        };
        let (mut s, mut s2, mut cnt) = (0.0, 0.0, 0.0);
        for r in 0..n {
            for c in 0..n {
                if inside(r, c) {
                    let v = field[r * n + c];
                    s += v;
                    s2 += v * v;
                    cnt += 1.0;
                }
            }
        }
        let mean = s / cnt;
        let rms = (s2 / cnt - mean * mean).max(1e-300).sqrt();
        self.smudge = Some(
            field
                .iter()
                .map(|v| ((v - mean) / rms * rms_waves) as f32)
                .collect(),
        );
        Ok(self)
    }

    /// Multiply by an intensity transmission mask (amplitude: its square root).
    pub fn with_mask(mut self, mask: TransmissionMask) -> Self {
        self.mask = Some(mask);
        self
    }

    /// Add a phase pattern: the grey image's values times `waves`.
    pub fn with_phase_mask(mut self, image: TransmissionMask, waves: f64) -> Result<Self> {
        if !(waves.is_finite() && waves.abs() <= 100.0) {
            return Err(OpticsError::config(
                "flare.phase_mask_waves",
                format!("{waves} is not a phase scale in [-100, 100] waves"),
            ));
        }
        self.phase_mask = Some(PhaseMask { image, waves });
        Ok(self)
    }

    /// Covered area fraction of the pupil by dust (sum of r^2, normalized radii: the discs lie
    /// inside the pupil and do not overlap).
    pub fn dust_coverage(&self) -> f64 {
        self.features[..self.dust_count]
            .iter()
            .map(|f| match f {
                Feature::Disc { r, .. } => r * r,
                Feature::Strip { .. } => 0.0,
            })
            .sum()
    }

    /// Number of dust particles.
    pub fn dust_count(&self) -> usize {
        self.dust_count
    }

    /// Number of scratches.
    pub fn scratch_count(&self) -> usize {
        self.features.len() - self.dust_count
    }

    /// Smallest dust diameter or scratch width, normalized by the pupil radius (0 without).
    pub fn min_feature(&self) -> f64 {
        self.min_feature
    }

    fn rebuild_buckets(&mut self) {
        let mut b = vec![Vec::new(); BUCKETS * BUCKETS];
        let side = 2.0 / BUCKETS as f64;
        let to_i = |v: f64| (((v + 1.0) / side).floor().max(0.0) as usize).min(BUCKETS - 1);
        for (i, f) in self.features.iter().enumerate() {
            let (x0, y0, x1, y1) = f.bounds();
            let (c0, c1) = (to_i(x0 - BUCKET_MARGIN), to_i(x1 + BUCKET_MARGIN));
            let (r0, r1) = (to_i(y0 - BUCKET_MARGIN), to_i(y1 + BUCKET_MARGIN));
            for row in b.chunks_exact_mut(BUCKETS).take(r1 + 1).skip(r0) {
                for cell in &mut row[c0..=c1] {
                    cell.push(i as u32);
                }
            }
        }
        self.buckets = b;
    }

    /// Amplitude transmission at one point from the features covering it (their product).
    fn feature_amplitude(&self, ids: &[u32], x: f64, y: f64) -> f64 {
        let mut t = 1.0;
        for &i in ids {
            if self.features[i as usize].field(x, y) < 0.0 {
                t *= self.amplitude[i as usize];
            }
        }
        t
    }

    /// The pupil sample cell of side `cell` centred at normalized (x, y): its mean amplitude
    /// transmission, mean intensity transmission (8 x 8 subsamples where a feature's edge crosses
    /// it, as [`crate::Aperture::cell_amplitude`]) and phase, waves.
    pub fn cell(&self, x: f64, y: f64, cell: f64) -> (f64, f64, f64) {
        let (mut amp, mut energy) = (1.0, 1.0);
        if !self.features.is_empty() {
            let reach = 0.7072 * cell;
            let all: Vec<u32>;
            let ids: &[u32] = if reach <= BUCKET_MARGIN {
                let side = 2.0 / BUCKETS as f64;
                let to_i = |v: f64| (((v + 1.0) / side).floor().max(0.0) as usize).min(BUCKETS - 1);
                &self.buckets[to_i(y) * BUCKETS + to_i(x)]
            } else {
                all = (0..self.features.len() as u32).collect();
                &all
            };
            let mut edge = false;
            for &i in ids {
                let f = self.features[i as usize].field(x, y);
                if f.abs() < reach {
                    edge = true;
                    break;
                }
                if f < 0.0 {
                    amp *= self.amplitude[i as usize];
                }
            }
            if edge {
                let sub = 8usize;
                let (mut sa, mut se) = (0.0, 0.0);
                for sy in 0..sub {
                    for sx in 0..sub {
                        let xx = x + ((sx as f64 + 0.5) / sub as f64 - 0.5) * cell;
                        let yy = y + ((sy as f64 + 0.5) / sub as f64 - 0.5) * cell;
                        let t = self.feature_amplitude(ids, xx, yy);
                        sa += t;
                        se += t * t;
                    }
                }
                let n = (sub * sub) as f64;
                amp = sa / n;
                energy = se / n;
            } else {
                energy = amp * amp;
            }
        }
        if let Some(m) = &self.mask {
            let t = m.eval(x, y);
            amp *= t.sqrt();
            energy *= t;
        }
        let mut phase = 0.0;
        if let Some(s) = &self.smudge {
            phase += raster_eval(s, SMUDGE_SIDE, x, y);
        }
        if let Some(p) = &self.phase_mask {
            phase += p.waves * p.image.eval(x, y);
        }
        (amp, energy, phase)
    }
}

fn check_fraction(key: &str, v: f64) -> Result<()> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(OpticsError::config(
            key,
            format!("{v} is not a fraction in [0, 1]"),
        ))
    }
}

/// Bilinear value of an `n` x `n` raster over [-1, 1]^2 (pixel centres at -1 + (i + 0.5) 2 / n,
/// edge pixels held).
fn raster_eval(data: &[f32], n: usize, x: f64, y: f64) -> f64 {
    let fc = ((x + 1.0) * 0.5 * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
    let fr = ((y + 1.0) * 0.5 * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
    let (c0, r0) = (fc.floor() as usize, fr.floor() as usize);
    let (c1, r1) = ((c0 + 1).min(n - 1), (r0 + 1).min(n - 1));
    let (tc, tr) = (fc - c0 as f64, fr - r0 as f64);
    let v = |r: usize, c: usize| data[r * n + c] as f64;
    (1.0 - tr) * ((1.0 - tc) * v(r0, c0) + tc * v(r0, c1))
        + tr * ((1.0 - tc) * v(r1, c0) + tc * v(r1, c1))
}
