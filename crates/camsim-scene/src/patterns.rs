//! Spatial test patterns after ISETCam's `sceneCreate` (harmonic, zone plate, sweep frequency,
//! star, checkerboard, grid lines, point array, ramp, dead leaves, HDR chart, HDR lights).
//!
//! Each pattern is a spectrally flat reflectance map `rho(x, y)` in [0, 1]; the radiance is
//! `k * illuminant(lambda) * rho(x, y)` with `k` chosen so that the mean luminance over all pixels
//! is `mean_luminance_cd_m2` (ISETCam `sceneAdjustLuminance`). ISETCam builds the same patterns as
//! relative images and scales them the same way, so an affine offset/scale of its image (e.g.
//! `ieScale`) does not change the result beyond the luminance scaling; where ISETCam's image is
//! signed (`1 + c cos`), ours is the same curve halved to stay within [0, 1].
//!
//! Pixel coordinates: column `j`, row `i`, 0-based, pixel centres at integer positions unless
//! stated otherwise; rows grow downwards (as in ISETCam's `meshgrid`).

use camsim_core::error::{CoreError, Result};
use camsim_core::WavelengthGrid;
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The fields shared by every pattern scene: illuminant, geometry and mean luminance.
pub(crate) struct Header<'a> {
    pub illuminant: &'a str,
    pub fov_deg: f64,
    pub distance_m: f64,
    pub mean_luminance_cd_m2: f64,
    /// The luminance of reflectance 1 and its key, for patterns scaled by their brightest
    /// level instead of their mean (the HDR chart's strip, the HDR lights); `None`: the mean.
    pub white_luminance: Option<(f64, &'static str)>,
}

/// A pattern scene: its shared fields and its reflectance map (rows, cols, row-major values).
pub(crate) trait Pattern {
    fn header(&self) -> Header<'_>;
    /// The map; `bands` (of the radiance image made from it) sizes the stage's memory check.
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)>;
}

/// Declares a pattern scene struct: the shared fields (documented once here) followed by its own.
/// Missing keys take the values of `Default` (container-level `#[serde(default)]`), unknown keys
/// are errors.
macro_rules! pattern_scene {
    ($(#[$doc:meta])* $name:ident { $( $(#[$fdoc:meta])* $field:ident : $ty:ty = $default:expr ),* $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
        #[serde(default, deny_unknown_fields)]
        pub struct $name {
            /// Mean luminance of the image, cd/m^2 (ISETCam `sceneAdjustLuminance`); default 100.
            pub mean_luminance_cd_m2: f64,
            /// Horizontal field of view, degrees, in (0, 180); default 10.
            pub fov_deg: f64,
            /// Distance from the lens to the chart, m; default 1.2 (ISETCam's).
            pub distance_m: f64,
            /// Illuminant: a built-in name (D65, A, C, F2, F11, E, `blackbody-<K>`, the CIE 015:2018 lamps HP1-HP5 and LED-B1-B5, LED-BH1, LED-RGB1, LED-V1, LED-V2; `LPS`, a low-pressure sodium lamp) or a spectrum
            /// file (.csv or ISETCam .mat; relative units); default D65.
            pub illuminant: String,
            /// Wavelength grid, nm (optional; the default is 400-700 nm every 10 nm).
            pub wavelengths: Option<WavelengthGrid>,
            $( $(#[$fdoc])* pub $field: $ty, )*
        }

        impl Default for $name {
            fn default() -> Self {
                $name {
                    mean_luminance_cd_m2: 100.0,
                    fov_deg: 10.0,
                    distance_m: 1.2,
                    illuminant: "D65".to_string(),
                    wavelengths: None,
                    $( $field: $default, )*
                }
            }
        }

        impl $name {
            pub(crate) fn header_fields(&self) -> Header<'_> {
                Header {
                    illuminant: &self.illuminant,
                    fov_deg: self.fov_deg,
                    distance_m: self.distance_m,
                    mean_luminance_cd_m2: self.mean_luminance_cd_m2,
                    white_luminance: None,
                }
            }
        }
    };
}

pattern_scene! {
    /// A sinusoidal grating (ISETCam `sceneCreate('harmonic', parms)` / `imageHarmonic`):
    /// `rho = (1 + contrast cos(2 pi freq (cos(a) X + sin(a) Y) + phase)) / 2` with
    /// `X = j / cols`, `Y = i / rows` (ISETCam `meshgrid((0:col-1)/col, (0:row-1)/row)`).
    HarmonicScene {
        /// Spatial frequency, cycles per image (ISETCam `freq`); default 1.
        freq: f64 = 1.0,
        /// Michelson contrast (max - min) / (max + min), in [0, 1] (ISETCam `contrast`); default 1.
        contrast: f64 = 1.0,
        /// Phase of the cosine at the top-left pixel, degrees (ISETCam `ph`, radians there);
        /// default 90 (ISETCam's pi/2).
        phase_deg: f64 = 90.0,
        /// Orientation of the wave vector from the +column axis towards +row (downwards), degrees
        /// (ISETCam `ang`); 0 gives vertical bars; default 0.
        angle_deg: f64 = 0.0,
        /// Image height, pixels (ISETCam `row`); default 64.
        rows: usize = 64,
        /// Image width, pixels (ISETCam `col`); default 64.
        cols: usize = 64,
    }
}

pattern_scene! {
    /// A circular zone plate (ISETCam `sceneCreate('zone plate')` / `imgZonePlate`):
    /// `rho = (1 + amplitude cos(pi r^2 / size_px + phase)) / 2`, `r` in pixels from the centre
    /// pixel (`size_px / 2`, 0-based). The local frequency at radius `r` is `r / size_px` cycles
    /// per pixel (`k r / pi` with `k = pi / size_px`): Nyquist (0.5) at the edge's midpoints.
    ZonePlateScene {
        /// Image side, pixels (ISETCam `imSize`); default 256.
        size_px: usize = 256,
        /// Amplitude of the cosine, in [0, 1] (ISETCam `amp`); default 1.
        amplitude: f64 = 1.0,
        /// Phase at the centre, degrees (ISETCam `ph`, radians there); default 0.
        phase_deg: f64 = 0.0,
    }
}

pattern_scene! {
    /// A sweep-frequency chart (ISETCam `sceneCreate('sweep frequency')` / `imgSweep`): with
    /// `x = (j + 1) / size_px` and `c = (size_px - i) / size_px`,
    /// `rho = (1 + c sin(2 pi max_freq x^3)) / 2`. The local frequency grows left to right as
    /// `3 max_freq x^2` cycles per image (ISETCam's `freq = x^2 maxFreq` multiplied by `x`), and
    /// the contrast falls linearly from 1 on the top row to `1 / size_px` on the bottom row.
    SweepFrequencyScene {
        /// Image side, pixels (ISETCam `imSize`); default 128.
        size_px: usize = 128,
        /// ISETCam's `maxFreq`, cycles per image (the phase is `2 pi max_freq x^3`); default 8
        /// (ISETCam's `imSize / 16`).
        max_freq: f64 = 8.0,
    }
}

pattern_scene! {
    /// A Siemens star: `number_of_spokes` bright and as many dark wedges about the image centre
    /// (bright where `sin(N theta) > 0`), each pixel the mean of 4 x 4 point samples
    /// (ISETCam `sceneCreate('star pattern')`, which draws `nLines` lines instead of wedges).
    StarScene {
        /// Image side, pixels (ISETCam `imSize`); default 256.
        size_px: usize = 256,
        /// Number of bright wedges N (>= 1); default 8 (ISETCam `nLines`).
        number_of_spokes: usize = 8,
    }
}

pattern_scene! {
    /// A checkerboard of square checks, dark at the top left (ISETCam `sceneCreate('checkerboard',
    /// checkPeriod, nCheckPairs)`): one period is a dark and a light check.
    CheckerboardScene {
        /// Length of one period (a dark plus a light check), pixels, even and >= 2 (ISETCam
        /// `checkPeriod`); default 16.
        period_px: usize = 16,
        /// Number of periods along each side (ISETCam `nCheckPairs`); the image side is
        /// `period_px * number_of_checks`; default 8.
        number_of_checks: usize = 8,
    }
}

pattern_scene! {
    /// Bright horizontal and vertical lines on black (ISETCam `sceneCreate('grid lines', imageSize,
    /// pixelsBetweenLines, spectralType, lineThickness)`): lines start at row/column
    /// `round(pixels_between_lines / 2) - 1` (0-based; ISETCam's 1-based `round(s/2)`) and repeat
    /// every `pixels_between_lines`.
    GridLinesScene {
        /// Image side, pixels (ISETCam `imageSize`); default 128.
        size_px: usize = 128,
        /// Line pitch, pixels (>= 2); default 16.
        pixels_between_lines: usize = 16,
        /// Line width, pixels (>= 1, < pixels_between_lines); default 1.
        line_thickness_px: usize = 1,
    }
}

pattern_scene! {
    /// Bright square points on black on a regular grid (ISETCam `sceneCreate('point array',
    /// imageSize, pixelsBetweenPoints, spectralType, pointSize)`), placed like the grid lines.
    PointArrayScene {
        /// Image side, pixels (ISETCam `imageSize`); default 128.
        size_px: usize = 128,
        /// Point pitch, pixels (>= 2); default 16.
        pixels_between_points: usize = 16,
        /// Side of each point, pixels (>= 1, < pixels_between_points); default 1.
        point_size_px: usize = 1,
    }
}

pattern_scene! {
    /// A horizontal linear luminance ramp (ISETCam `sceneCreate('linear intensity ramp')`): the
    /// reflectance rises linearly from `1 / dynamic_range` at the left column to 1 at the right,
    /// the same on every row.
    RampScene {
        /// Image side, pixels (>= 2); default 128.
        size_px: usize = 128,
        /// Ratio of the brightest to the darkest column (>= 1); default 256.
        dynamic_range: f64 = 256.0,
    }
}

pattern_scene! {
    /// A dead-leaves texture (ISO 19567-2 texture-loss target; Cao, Guichard & Hornung 2010;
    /// ISETCam `sceneCreate('dead leaves')`): opaque discs fall one after another, each hiding
    /// what lies under it, until the image is covered. Built front to back (Kendall & Thonnat's
    /// equivalence): a disc paints only the pixels no earlier disc covered. Radii follow the
    /// density `r^-sigma` on [`r_min_px`, `r_max_px`] (sigma = 3: a scale-invariant image with a
    /// power spectrum ~ 1/f^2, as natural images), centres are uniform over the image grown by
    /// `r_max_px` on every side (so the statistics are the same everywhere in it), grey levels
    /// uniform in [`reflectance_min`, `reflectance_max`]. A pixel takes the disc covering its
    /// centre. `seed` fixes the texture.
    DeadLeavesScene {
        /// Image side, pixels; default 256.
        size_px: usize = 256,
        /// Exponent of the radius density `r^-sigma` (ISETCam `sigma`), > 1; default 3.
        sigma: f64 = 3.0,
        /// Smallest disc radius, pixels (>= 0.5); default 1.
        r_min_px: f64 = 1.0,
        /// Largest disc radius, pixels (>= r_min_px); default 64.
        r_max_px: f64 = 64.0,
        /// Lowest grey level (reflectance), fraction; default 0.05.
        reflectance_min: f64 = 0.05,
        /// Highest grey level (reflectance), fraction; default 0.95.
        reflectance_max: f64 = 0.95,
        /// Seed of the random discs; the same seed gives the same texture.
        seed: u64 = 1,
    }
}

pattern_scene! {
    /// A high-dynamic-range chart (ISETCam `sceneHDRChart`): `levels` vertical strips, each
    /// `level_width_px` wide, from dark (left) to bright (right), log-spaced over
    /// `dynamic_range`: strip i of N has reflectance `dynamic_range^((i - (N - 1)) / (N - 1))`, so
    /// neighbours differ by `dynamic_range^(1 / (N - 1))` and the brightest is `dynamic_range`
    /// times the darkest. The scale is `max_luminance_cd_m2` (the brightest strip's, ISETCam's
    /// `maxL`) when given, else `mean_luminance_cd_m2` over the image as for every pattern. A
    /// sensor's dynamic range is read off the strips it resolves above its noise floor and below
    /// saturation.
    HdrChartScene {
        /// Ratio of the brightest to the darkest strip (> 1; ISETCam `dRange`); default 1e4.
        dynamic_range: f64 = 1e4,
        /// Number of strips (2..=256; ISETCam `nLevels`); default 12.
        levels: usize = 12,
        /// Width of each strip, pixels (ISETCam `colsPerLevel`); default 8.
        level_width_px: usize = 8,
        /// Image height, pixels; default 32.
        rows: usize = 32,
        /// Luminance of the brightest strip, cd/m^2 (ISETCam `maxL`); 0 (the default): the
        /// scale is `mean_luminance_cd_m2`. Giving both (a mean other than its default 100) is an
        /// error.
        max_luminance_cd_m2: f64 = 0.0,
    }
}

impl HdrChartScene {
    /// The strips' reflectances, darkest first (type docs).
    pub fn level_reflectances(&self) -> Vec<f64> {
        let n = self.levels.max(2);
        (0..n)
            .map(|i| {
                self.dynamic_range
                    .powf((i as f64 - (n - 1) as f64) / (n - 1) as f64)
            })
            .collect()
    }
}

impl Pattern for HdrChartScene {
    fn header(&self) -> Header<'_> {
        let mut h = self.header_fields();
        // The brightest strip has reflectance 1.
        if self.max_luminance_cd_m2 > 0.0 {
            h.white_luminance = Some((self.max_luminance_cd_m2, "scene.max_luminance_cd_m2"));
        }
        h
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        let dr = self.dynamic_range;
        need(
            dr > 1.0 && dr.is_finite() && dr <= 1e30,
            "scene.dynamic_range",
            format!("{dr} is not a finite ratio above 1 (at most 1e30)"),
        )?;
        need(
            (2..=256).contains(&self.levels),
            "scene.levels",
            format!("{} levels; need 2 to 256", self.levels),
        )?;
        need(
            self.level_width_px >= 1,
            "scene.level_width_px",
            "0 pixels; need at least 1".to_string(),
        )?;
        let m = self.max_luminance_cd_m2;
        need(
            m >= 0.0 && m.is_finite(),
            "scene.max_luminance_cd_m2",
            format!("{m} is not a luminance >= 0"),
        )?;
        need(
            m == 0.0 || self.mean_luminance_cd_m2 == 100.0,
            "scene.max_luminance_cd_m2",
            "give either max_luminance_cd_m2 or mean_luminance_cd_m2, not both".to_string(),
        )?;
        let cols = self.levels.saturating_mul(self.level_width_px);
        check_side(cols, "scene.level_width_px", 2)?;
        check_side(self.rows, "scene.rows", 1)?;
        let rho: Vec<f32> = self
            .level_reflectances()
            .iter()
            .map(|v| *v as f32)
            .collect();
        let w = self.level_width_px;
        map_rows(bands, self.rows, cols, |_, line| {
            for (j, v) in line.iter_mut().enumerate() {
                *v = rho[j / w];
            }
        })
    }
}

pattern_scene! {
    /// Bright lights on a dark ground (after ISETCam `sceneHDRLights`, whose default layout this
    /// keeps): `circle_radii` discs (radii as fractions of the image side) centred on the row at
    /// a quarter of the height, evenly spaced from 0.2 to 0.8 of the width, and `lines` thin
    /// horizontal bars (`line_length` of the side long, `line_width_px` wide) centred on the
    /// middle row, evenly spaced from 0.1 to 0.8 of the width. The lights have reflectance 1 and
    /// the ground `background_reflectance` (default 0: black, ISETCam's), both times the
    /// illuminant; each pixel is its exact area mixture (8 x 8 subsamples). The scale is the
    /// lights' luminance `light_luminance_cd_m2`; headlights and street lamps are 1e4 to 1e6
    /// cd/m^2, so with a dim ground this tests flare, glare and an HDR sensor's range.
    HdrLightsScene {
        /// Image side, pixels (ISETCam `imagesize`); default 384.
        size_px: usize = 384,
        /// Radii of the discs as fractions of the side (each in (0, 0.5]; ISETCam `radius`);
        /// default [0.01, 0.035, 0.07, 0.1]. Empty: no discs.
        circle_radii: Vec<f64> = vec![0.01, 0.035, 0.07, 0.1],
        /// Number of bars (0..=16; ISETCam `nlines`); default 4.
        lines: usize = 4,
        /// Bar length as a fraction of the side, in (0, 1]; default 0.1.
        line_length: f64 = 0.1,
        /// Bar width, pixels (> 0); default 2.
        line_width_px: f64 = 2.0,
        /// Reflectance of the ground, fraction in [0, 1); default 0 (black).
        background_reflectance: f64 = 0.0,
        /// Luminance of the lights, cd/m^2 (> 0); default 10 000. Replaces
        /// `mean_luminance_cd_m2` (giving both, a mean other than its default 100, is an error).
        light_luminance_cd_m2: f64 = 10_000.0,
    }
}

/// The lights of an [`HdrLightsScene`] in pixel coordinates (pixel (i, j) covers
/// [j, j + 1) x [i, i + 1)): discs (centre x, centre y, radius) and bars (centre x, centre y).
struct LightsLayout {
    discs: Vec<(f64, f64, f64)>,
    bars: Vec<(f64, f64)>,
    half_len: f64,
    half_w: f64,
}

impl LightsLayout {
    /// Fraction of pixel (row `i`, column `j`) covered by lights: 0 or 1 where no light's edge
    /// passes within the pixel, else 8 x 8 subsamples.
    fn coverage(&self, i: usize, j: usize) -> f64 {
        let (xc, yc) = (j as f64 + 0.5, i as f64 + 0.5);
        // A pixel's points lie within sqrt(2) / 2 of its centre, and within 1/2 per axis.
        let mut edge = false;
        for &(cx, cy, r) in &self.discs {
            let d = ((xc - cx).powi(2) + (yc - cy).powi(2)).sqrt();
            if d <= r - 0.7072 {
                return 1.0;
            }
            edge |= d < r + 0.7072;
        }
        for &(cx, cy) in &self.bars {
            let (dx, dy) = ((xc - cx).abs(), (yc - cy).abs());
            if dx <= self.half_len - 0.5 && dy <= self.half_w - 0.5 {
                return 1.0;
            }
            edge |= dx < self.half_len + 0.5 && dy < self.half_w + 0.5;
        }
        if !edge {
            return 0.0;
        }
        const SUB: usize = 8;
        let mut hits = 0usize;
        for sy in 0..SUB {
            let y = i as f64 + (sy as f64 + 0.5) / SUB as f64;
            for sx in 0..SUB {
                let x = j as f64 + (sx as f64 + 0.5) / SUB as f64;
                let lit = self
                    .discs
                    .iter()
                    .any(|(cx, cy, r)| (x - cx).powi(2) + (y - cy).powi(2) < r * r)
                    || self.bars.iter().any(|(cx, cy)| {
                        (x - cx).abs() < self.half_len && (y - cy).abs() < self.half_w
                    });
                hits += lit as usize;
            }
        }
        hits as f64 / (SUB * SUB) as f64
    }
}

impl HdrLightsScene {
    /// Where the lights are (type docs).
    fn layout(&self) -> LightsLayout {
        let n = self.size_px as f64;
        let spread = |k: usize, count: usize, from: f64, to: f64| {
            let t = if count > 1 {
                k as f64 / (count - 1) as f64
            } else {
                0.5
            };
            (from + (to - from) * t) * n
        };
        let m = self.circle_radii.len();
        LightsLayout {
            discs: (self.circle_radii.iter().enumerate())
                .map(|(k, r)| (spread(k, m, 0.2, 0.8), 0.25 * n, r * n))
                .collect(),
            bars: (0..self.lines)
                .map(|k| (spread(k, self.lines, 0.1, 0.8), 0.5 * n))
                .collect(),
            half_len: self.line_length * n / 2.0,
            half_w: self.line_width_px / 2.0,
        }
    }

    fn check(&self) -> Result<()> {
        check_side(self.size_px, "scene.size_px", 8)?;
        for r in &self.circle_radii {
            need(
                *r > 0.0 && *r <= 0.5,
                "scene.circle_radii",
                format!("{r} is not a radius in (0, 0.5] of the side"),
            )?;
        }
        need(
            self.lines <= 16,
            "scene.lines",
            format!("{} bars; at most 16", self.lines),
        )?;
        need(
            self.line_length > 0.0 && self.line_length <= 1.0,
            "scene.line_length",
            format!("{} is not a length in (0, 1] of the side", self.line_length),
        )?;
        need(
            self.line_width_px > 0.0 && self.line_width_px.is_finite(),
            "scene.line_width_px",
            format!("{} pixels is not a positive width", self.line_width_px),
        )?;
        need(
            (0.0..1.0).contains(&self.background_reflectance),
            "scene.background_reflectance",
            format!("{} is not in [0, 1)", self.background_reflectance),
        )?;
        let l = self.light_luminance_cd_m2;
        need(
            l > 0.0 && l.is_finite(),
            "scene.light_luminance_cd_m2",
            format!("{l} is not a positive luminance"),
        )?;
        need(
            self.mean_luminance_cd_m2 == 100.0,
            "scene.light_luminance_cd_m2",
            "give light_luminance_cd_m2 (the lights') or mean_luminance_cd_m2, not both"
                .to_string(),
        )
    }
}

impl Pattern for HdrLightsScene {
    fn header(&self) -> Header<'_> {
        let mut h = self.header_fields();
        // The lights have reflectance 1.
        h.white_luminance = Some((self.light_luminance_cd_m2, "scene.light_luminance_cd_m2"));
        h
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        self.check()?;
        need(
            !self.circle_radii.is_empty() || self.lines > 0,
            "scene.circle_radii",
            "no discs and no bars: the scene has no lights".to_string(),
        )?;
        let n = self.size_px;
        let (layout, bg) = (self.layout(), self.background_reflectance);
        map_rows(bands, n, n, |i, line| {
            for (j, v) in line.iter_mut().enumerate() {
                let c = layout.coverage(i, j);
                *v = (c + (1.0 - c) * bg) as f32;
            }
        })
    }
}

fn need(cond: bool, key: &str, msg: String) -> Result<()> {
    if cond {
        Ok(())
    } else {
        Err(CoreError::invalid(key, msg))
    }
}

fn check_side(n: usize, key: &str, min: usize) -> Result<()> {
    need(n >= min, key, format!("{n} pixels; need at least {min}"))?;
    need(
        n <= 1 << 15,
        key,
        format!("{n} pixels; at most {} are allowed", 1 << 15),
    )
}

fn check_unit(v: f64, key: &str) -> Result<()> {
    need(
        (0.0..=1.0).contains(&v),
        key,
        format!("{v} is not in [0, 1]"),
    )
}

fn check_finite(v: f64, key: &str) -> Result<()> {
    need(v.is_finite(), key, format!("{v} is not a finite number"))
}

/// Bytes of a rows x cols f32 map.
fn f32_bytes(rows: usize, cols: usize) -> u64 {
    (rows as u64).saturating_mul(cols as u64).saturating_mul(4)
}

/// A rows x cols map filled row by row (in parallel) by `f(row, line)`, after the stage's memory
/// check for a `bands`-band radiance image made from it ([`crate::memory_budget`]).
fn map_rows(
    bands: usize,
    rows: usize,
    cols: usize,
    f: impl Fn(usize, &mut [f32]) + Sync,
) -> Result<(usize, usize, Vec<f32>)> {
    crate::check_memory(
        rows,
        cols,
        bands,
        &[("reflectance map", f32_bytes(rows, cols))],
    )?;
    let mut m = vec![0.0f32; rows * cols];
    m.par_chunks_mut(cols)
        .enumerate()
        .for_each(|(i, line)| f(i, line));
    Ok((rows, cols, m))
}

impl Pattern for HarmonicScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.rows, "scene.rows", 1)?;
        check_side(self.cols, "scene.cols", 1)?;
        check_finite(self.freq, "scene.freq")?;
        check_unit(self.contrast, "scene.contrast")?;
        check_finite(self.phase_deg, "scene.phase_deg")?;
        check_finite(self.angle_deg, "scene.angle_deg")?;
        let (c, ph) = (self.contrast, self.phase_deg.to_radians());
        let (ca, sa) = (
            self.angle_deg.to_radians().cos(),
            self.angle_deg.to_radians().sin(),
        );
        let (rows, cols, f) = (self.rows as f64, self.cols as f64, self.freq);
        map_rows(bands, self.rows, self.cols, |i, line| {
            let y = i as f64 / rows;
            for (j, v) in line.iter_mut().enumerate() {
                let x = j as f64 / cols;
                *v = (0.5 * (1.0 + c * (2.0 * PI * f * (ca * x + sa * y) + ph).cos())) as f32;
            }
        })
    }
}

impl Pattern for ZonePlateScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        check_unit(self.amplitude, "scene.amplitude")?;
        check_finite(self.phase_deg, "scene.phase_deg")?;
        let n = self.size_px as f64;
        let centre = (self.size_px / 2) as f64;
        let (amp, ph) = (self.amplitude, self.phase_deg.to_radians());
        map_rows(bands, self.size_px, self.size_px, |i, line| {
            let dy = i as f64 - centre;
            for (j, v) in line.iter_mut().enumerate() {
                let dx = j as f64 - centre;
                *v = (0.5 * (1.0 + amp * (PI * (dx * dx + dy * dy) / n + ph).cos())) as f32;
            }
        })
    }
}

impl Pattern for SweepFrequencyScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        check_finite(self.max_freq, "scene.max_freq")?;
        need(
            self.max_freq > 0.0,
            "scene.max_freq",
            format!("{} cycles per image is not positive", self.max_freq),
        )?;
        let n = self.size_px as f64;
        let f = self.max_freq;
        // The row profile is the same on every row up to the contrast: compute it once.
        let profile: Vec<f64> = (0..self.size_px)
            .map(|j| (2.0 * PI * f * ((j + 1) as f64 / n).powi(3)).sin())
            .collect();
        map_rows(bands, self.size_px, self.size_px, |i, line| {
            let c = (n - i as f64) / n;
            for (v, s) in line.iter_mut().zip(&profile) {
                *v = (0.5 * (1.0 + c * s)) as f32;
            }
        })
    }
}

impl Pattern for StarScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        need(
            (1..=4096).contains(&self.number_of_spokes),
            "scene.number_of_spokes",
            format!("{} spokes; need 1 to 4096", self.number_of_spokes),
        )?;
        // Continuous coordinates: pixel (i, j) covers [j, j + 1) x [i, i + 1); centre at size/2.
        let centre = 0.5 * self.size_px as f64;
        let spokes = self.number_of_spokes as f64;
        const SUB: usize = 4;
        map_rows(bands, self.size_px, self.size_px, |i, line| {
            for (j, v) in line.iter_mut().enumerate() {
                let mut bright = 0usize;
                for sy in 0..SUB {
                    let y = i as f64 + (sy as f64 + 0.5) / SUB as f64 - centre;
                    for sx in 0..SUB {
                        let x = j as f64 + (sx as f64 + 0.5) / SUB as f64 - centre;
                        if (spokes * y.atan2(x)).sin() > 0.0 {
                            bright += 1;
                        }
                    }
                }
                *v = bright as f32 / (SUB * SUB) as f32;
            }
        })
    }
}

impl Pattern for CheckerboardScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        need(
            self.period_px >= 2 && self.period_px.is_multiple_of(2),
            "scene.period_px",
            format!(
                "{} pixels; the period must be even and at least 2 (two checks)",
                self.period_px
            ),
        )?;
        need(
            self.number_of_checks >= 1,
            "scene.number_of_checks",
            "must be at least 1".to_string(),
        )?;
        let side = self.period_px.saturating_mul(self.number_of_checks);
        check_side(side, "scene.number_of_checks", 2)?;
        let check = self.period_px / 2;
        map_rows(bands, side, side, |i, line| {
            for (j, v) in line.iter_mut().enumerate() {
                *v = ((i / check + j / check) % 2) as f32;
            }
        })
    }
}

/// Whether 0-based index `k` lies on a line of pitch `pitch` and width `width` whose first line
/// starts at ISETCam's 1-based `round(pitch / 2)`.
fn on_line(k: usize, pitch: usize, width: usize) -> bool {
    let first = (pitch as f64 / 2.0).round() as usize - 1;
    k >= first && (k - first) % pitch < width
}

/// The image must reach the first line (or point), else it is black.
fn check_first_line(size_px: usize, pitch: usize) -> Result<()> {
    let first = (pitch as f64 / 2.0).round() as usize - 1;
    need(
        size_px > first,
        "scene.size_px",
        format!("{size_px} pixels do not reach the first line at pixel {first}"),
    )
}

impl Pattern for GridLinesScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        let (p, w) = (self.pixels_between_lines, self.line_thickness_px);
        need(
            p >= 2,
            "scene.pixels_between_lines",
            format!("{p} pixels; need at least 2"),
        )?;
        need(
            w >= 1 && w < p,
            "scene.line_thickness_px",
            format!("{w} pixels; need 1 to pixels_between_lines - 1 = {}", p - 1),
        )?;
        check_first_line(self.size_px, p)?;
        map_rows(bands, self.size_px, self.size_px, |i, line| {
            let row_on = on_line(i, p, w);
            for (j, v) in line.iter_mut().enumerate() {
                *v = if row_on || on_line(j, p, w) { 1.0 } else { 0.0 };
            }
        })
    }
}

impl Pattern for PointArrayScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        let (p, w) = (self.pixels_between_points, self.point_size_px);
        need(
            p >= 2,
            "scene.pixels_between_points",
            format!("{p} pixels; need at least 2"),
        )?;
        need(
            w >= 1 && w < p,
            "scene.point_size_px",
            format!(
                "{w} pixels; need 1 to pixels_between_points - 1 = {}",
                p - 1
            ),
        )?;
        check_first_line(self.size_px, p)?;
        map_rows(bands, self.size_px, self.size_px, |i, line| {
            let row_on = on_line(i, p, w);
            for (j, v) in line.iter_mut().enumerate() {
                *v = if row_on && on_line(j, p, w) { 1.0 } else { 0.0 };
            }
        })
    }
}

impl Pattern for RampScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        let dr = self.dynamic_range;
        need(
            dr >= 1.0 && dr.is_finite(),
            "scene.dynamic_range",
            format!("{dr} is not a finite ratio >= 1"),
        )?;
        let n = self.size_px;
        let lo = 1.0 / dr;
        map_rows(bands, n, n, |_, line| {
            for (j, v) in line.iter_mut().enumerate() {
                *v = (lo + (1.0 - lo) * j as f64 / (n - 1) as f64) as f32;
            }
        })
    }
}

impl Pattern for DeadLeavesScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.size_px, "scene.size_px", 2)?;
        let (sigma, a, b) = (self.sigma, self.r_min_px, self.r_max_px);
        need(
            sigma > 1.0 && sigma.is_finite(),
            "scene.sigma",
            format!("{sigma} is not a finite exponent > 1"),
        )?;
        need(
            a >= 0.5 && a.is_finite(),
            "scene.r_min_px",
            format!("{a} pixels; need a radius >= 0.5"),
        )?;
        need(
            b >= a && b <= 1e4,
            "scene.r_max_px",
            format!("{b} pixels; need r_min_px ({a}) to 10000"),
        )?;
        check_unit(self.reflectance_min, "scene.reflectance_min")?;
        check_unit(self.reflectance_max, "scene.reflectance_max")?;
        let (lo, hi) = (self.reflectance_min, self.reflectance_max);
        need(
            lo <= hi,
            "scene.reflectance_max",
            format!("{hi} is below reflectance_min = {lo}"),
        )?;
        let n = self.size_px;
        crate::check_memory(n, n, bands, &[("dead-leaves map", f32_bytes(n, n))])?;
        let mut map = vec![-1.0f32; n * n];
        let mut uncovered = n * n;
        let mut rng = camsim_core::rng::keyed(self.seed, camsim_core::rng::stage::SCENE, 0, 0);
        // Inverse CDF of the density r^-sigma on [a, b]: r = (a^e + u (b^e - a^e))^(1/e), e = 1 - sigma.
        let e = 1.0 - sigma;
        let (ae, be) = (a.powf(e), b.powf(e));
        let span = n as f64 + 2.0 * b;
        // Far more discs than full coverage needs (the last pixels take about ln(n^2) times the
        // discs that cover the area once); a bound against a config that cannot finish.
        let max_discs = 2_000_000usize.max(400 * n * n);
        for _ in 0..max_discs {
            let cx = -b + span * rng.gen::<f64>();
            let cy = -b + span * rng.gen::<f64>();
            let r = (ae + rng.gen::<f64>() * (be - ae)).powf(1.0 / e);
            let g = (lo + (hi - lo) * rng.gen::<f64>()) as f32;
            let (i0, i1) = (
                (cy - r).ceil().max(0.0),
                (cy + r).floor().min(n as f64 - 1.0),
            );
            if i0 > i1 {
                continue;
            }
            for i in i0 as usize..=i1 as usize {
                let dy = i as f64 - cy;
                let dx = (r * r - dy * dy).max(0.0).sqrt();
                let (j0, j1) = (
                    (cx - dx).ceil().max(0.0),
                    (cx + dx).floor().min(n as f64 - 1.0),
                );
                if j0 > j1 {
                    continue;
                }
                for v in &mut map[i * n + j0 as usize..=i * n + j1 as usize] {
                    if *v < 0.0 {
                        *v = g;
                        uncovered -= 1;
                    }
                }
            }
            if uncovered == 0 {
                return Ok((n, n, map));
            }
        }
        Err(CoreError::invalid(
            "scene.r_min_px",
            format!("{max_discs} discs left {uncovered} pixels uncovered; raise r_min_px"),
        ))
    }
}

pattern_scene! {
    /// The ISO 18844 veiling glare target: a bright surround (reflectance `surround_reflectance`)
    /// with black holes (light traps, reflectance `hole_reflectance`, near zero) of diameter
    /// `hole_diameter_px`: one at the image centre, or a `holes` x `holes` grid of them `pitch_px`
    /// apart, centred (ISO 18844:2017 measures flare at holes spread over the field). Each pixel
    /// is the exact area mixture of hole and surround (8 x 8 subsamples on a hole's rim). The mean
    /// luminance over all pixels is `mean_luminance_cd_m2`, so the surround's luminance is
    /// `mean_luminance_cd_m2 / (1 - f (1 - hole_reflectance / surround_reflectance))`, f the holes'
    /// area fraction. `camsim analyze glare` measures the veiling glare index on its image.
    GlareTargetScene {
        /// Image height, pixels; default 256.
        rows: usize = 256,
        /// Image width, pixels; default 256.
        cols: usize = 256,
        /// Hole diameter, pixels (> 0); default 64.
        hole_diameter_px: f64 = 64.0,
        /// Holes along each side of the grid (1..=64); default 1 (one hole at the centre).
        holes: usize = 1,
        /// Distance between neighbouring hole centres, pixels (needed with `holes` > 1; more than
        /// `hole_diameter_px`); default 0.
        pitch_px: f64 = 0.0,
        /// Reflectance of the surround, fraction in (0, 1]; default 1 (white).
        surround_reflectance: f64 = 1.0,
        /// Reflectance of the holes, fraction in [0, 1] (a light trap: near 0); default 0.
        hole_reflectance: f64 = 0.0,
    }
}

impl GlareTargetScene {
    /// Hole centres in continuous pixel coordinates (x = column, y = row; pixel (i, j) covers
    /// [j, j + 1) x [i, i + 1), the image centre is (cols / 2, rows / 2)).
    pub fn hole_centres(&self) -> Vec<(f64, f64)> {
        let (cx, cy) = (self.cols as f64 / 2.0, self.rows as f64 / 2.0);
        let n = self.holes.max(1);
        let off = (n as f64 - 1.0) / 2.0;
        let mut v = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                v.push((
                    cx + (j as f64 - off) * self.pitch_px,
                    cy + (i as f64 - off) * self.pitch_px,
                ));
            }
        }
        v
    }
}

impl Pattern for GlareTargetScene {
    fn header(&self) -> Header<'_> {
        self.header_fields()
    }
    fn reflectance_map(&self, bands: usize) -> Result<(usize, usize, Vec<f32>)> {
        check_side(self.rows, "scene.rows", 2)?;
        check_side(self.cols, "scene.cols", 2)?;
        let d = self.hole_diameter_px;
        need(
            d > 0.0 && d.is_finite(),
            "scene.hole_diameter_px",
            format!("{d} pixels is not a positive diameter"),
        )?;
        need(
            (1..=64).contains(&self.holes),
            "scene.holes",
            format!("{} holes per side; need 1 to 64", self.holes),
        )?;
        if self.holes > 1 {
            need(
                self.pitch_px > d && self.pitch_px.is_finite(),
                "scene.pitch_px",
                format!(
                    "{} pixels; with {} holes per side the pitch must exceed the hole diameter ({d})",
                    self.pitch_px, self.holes
                ),
            )?;
        }
        check_unit(self.surround_reflectance, "scene.surround_reflectance")?;
        need(
            self.surround_reflectance > 0.0,
            "scene.surround_reflectance",
            "0: the surround must be bright".to_string(),
        )?;
        check_unit(self.hole_reflectance, "scene.hole_reflectance")?;
        let centres = self.hole_centres();
        let r = d / 2.0;
        let (bright, dark) = (self.surround_reflectance, self.hole_reflectance);
        let n = self.holes;
        let pitch = self.pitch_px;
        let (x0, y0) = centres[0];
        // The hole nearest to a point: grid index by rounding.
        let nearest = |x: f64, y: f64| -> (f64, f64) {
            let k = |v: f64, v0: f64| {
                if n == 1 {
                    0.0
                } else {
                    ((v - v0) / pitch).round().clamp(0.0, (n - 1) as f64)
                }
            };
            (x0 + k(x, x0) * pitch, y0 + k(y, y0) * pitch)
        };
        const SUB: usize = 8;
        map_rows(bands, self.rows, self.cols, |i, line| {
            let yc = i as f64 + 0.5;
            for (j, v) in line.iter_mut().enumerate() {
                let xc = j as f64 + 0.5;
                let (hx, hy) = nearest(xc, yc);
                let dist = ((xc - hx).powi(2) + (yc - hy).powi(2)).sqrt();
                // A pixel's points lie within sqrt(2) / 2 of its centre.
                let inside = if dist <= r - 0.7072 {
                    1.0
                } else if dist >= r + 0.7072 {
                    0.0
                } else {
                    let mut c = 0usize;
                    for sy in 0..SUB {
                        let y = i as f64 + (sy as f64 + 0.5) / SUB as f64 - hy;
                        for sx in 0..SUB {
                            let x = j as f64 + (sx as f64 + 0.5) / SUB as f64 - hx;
                            if x * x + y * y < r * r {
                                c += 1;
                            }
                        }
                    }
                    c as f64 / (SUB * SUB) as f64
                };
                *v = (bright + (dark - bright) * inside) as f32;
            }
        })
    }
}

/// Build the radiance image of a pattern scene: illuminant x reflectance map, scaled to the mean
/// luminance (the map is spectrally flat, so its pixel mean is the mean reflectance in every band).
pub(crate) fn create_pattern(
    p: &dyn Pattern,
    grid: &WavelengthGrid,
) -> Result<camsim_core::SpectralImage> {
    let h = p.header();
    if let Some((l, key)) = h.white_luminance {
        need(
            l > 0.0 && l.is_finite(),
            key,
            format!("{l} is not a positive luminance"),
        )?;
    }
    let com = crate::common(
        h.illuminant,
        h.fov_deg,
        h.distance_m,
        h.white_luminance.map_or(h.mean_luminance_cd_m2, |w| w.0),
        grid,
    )?;
    let (rows, cols, map) = p.reflectance_map(grid.len())?;
    // Scaled so the map's mean (or its reflectance 1) has the luminance asked for.
    let reference = match h.white_luminance {
        Some(_) => 1.0,
        None => camsim_core::math::fixed_order_sum(&map) / map.len() as f64,
    };
    let k_illum = com.scaled_illuminant(&vec![reference; grid.len()], grid)?;
    let mut img = com.image(rows, cols, grid)?;
    let n = img.pixels();
    img.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| {
            let k = k_illum[b] as f32;
            for (o, r) in plane.iter_mut().zip(&map) {
                *o = k * r;
            }
        });
    Ok(img)
}
