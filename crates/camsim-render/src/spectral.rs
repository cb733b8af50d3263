//! Spectral sampling for the path tracer: the wavelengths a path carries, the band they splat
//! into, and spectra tabulated finely so a lookup at a continuous wavelength is one multiply,
//! one floor and one lerp.

use camsim_core::{Spectrum, WavelengthGrid};

/// The continuous wavelength range the grid represents and how paths sample it.
///
/// Each band `b` of the grid stands for `[start + (b - 1/2) step, start + (b + 1/2) step]`, so the
/// sampled range is `[start - step/2, end + step/2]`. A path carries `n` wavelengths
/// `lambda_i = lo + frac(u + i/n) (hi - lo)` (one uniform `u`, rotated equally spaced offsets:
/// pbrt-v4 `SampledWavelengths::SampleUniform` with stratification, after Wilkie et al. 2014,
/// "Hero Wavelength Spectral Sampling"). Each `lambda_i` is marginally uniform, so
/// `L(lambda_i) 1[lambda_i in band b] (hi - lo) / (n step)` summed over `i` is an unbiased
/// estimate of the band average of `L` over band `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WavelengthSampler {
    pub lo_nm: f32,
    pub hi_nm: f32,
    pub step_nm: f32,
    pub bands: usize,
    /// 1 / table spacing (1/nm) and entry count of this sampler's spectrum tables.
    table_inv_dx: f32,
    table_len: usize,
}

impl WavelengthSampler {
    /// For the given output grid.
    pub fn new(grid: &WavelengthGrid) -> WavelengthSampler {
        let step = grid.step_nm;
        let mut ws = WavelengthSampler {
            lo_nm: (grid.start_nm - step / 2.0) as f32,
            hi_nm: (grid.end_nm() + step / 2.0) as f32,
            step_nm: step as f32,
            bands: grid.len(),
            table_inv_dx: 0.0,
            table_len: 0,
        };
        let (dx, n) = ws.table_layout();
        (ws.table_inv_dx, ws.table_len) = ((1.0 / dx) as f32, n);
        ws
    }

    /// The `N` wavelengths of one path from one uniform number `u`, and the band of each.
    #[inline(always)]
    pub fn sample<const N: usize>(&self, u: f32) -> ([f32; N], [u32; N]) {
        let mut l = [0f32; N];
        let mut b = [0u32; N];
        let span = self.hi_nm - self.lo_nm;
        for i in 0..N {
            let mut x = u + i as f32 / N as f32;
            if x >= 1.0 {
                x -= 1.0;
            }
            l[i] = self.lo_nm + x * span;
            b[i] = (((l[i] - self.lo_nm) / self.step_nm) as u32).min(self.bands as u32 - 1);
        }
        (l, b)
    }

    /// Table spacing (nm) and entry count shared by every [`SpectrumTable`] of this sampler.
    fn table_layout(&self) -> (f64, usize) {
        let dx = (0.25f64).min(self.step_nm as f64 / 8.0);
        let span = (self.hi_nm - self.lo_nm) as f64;
        let n = ((span / dx).ceil() as usize + 2).min(1 << 16);
        (span / (n - 2) as f64, n)
    }

    /// A path's wavelengths with their position in this sampler's spectrum tables, computed
    /// once per path (as [`SpectrumTable::eval`] would for each lookup).
    #[inline(always)]
    pub fn locate<const N: usize>(&self, nm: [f32; N]) -> Lambdas<N> {
        let (inv_dx, n) = (self.table_inv_dx, self.table_len);
        let mut idx = [0u32; N];
        let mut frac = [0f32; N];
        for i in 0..N {
            let (k, t) = table_position(nm[i], self.lo_nm, inv_dx, n);
            idx[i] = k as u32;
            frac[i] = t;
        }
        Lambdas { nm, idx, frac, table_len: n as u32 }
    }

    /// Weight that turns `L(lambda_i)` into its share of its band's average: `(hi - lo)/(n step)`.
    pub fn splat_weight(&self, n: usize) -> f32 {
        (self.hi_nm - self.lo_nm) / (n as f32 * self.step_nm)
    }
}

/// A spectrum tabulated on a fine uniform grid covering the sampled range, with linear
/// interpolation between table entries. Spectra given as linear interpolation between samples
/// are reproduced to within the interpolation of their own breakpoints onto the table
/// (resolution <= 0.25 nm or step/8). Outside its data a spectrum is zero (as
/// `camsim_core::Spectrum::eval`), except within half a grid step of its first and last
/// wavelength, where the end value is held (so data that stops at the outermost band centres
/// still fills those bands).
#[derive(Debug, Clone)]
pub struct SpectrumTable {
    lo_nm: f32,
    inv_dx: f32,
    values: Vec<f32>,
}

impl SpectrumTable {
    /// Tabulate `s` (times `scale`) over the sampler's range; negative values clamp to 0.
    pub fn new(s: &Spectrum, scale: f64, ws: &WavelengthSampler) -> SpectrumTable {
        let (dx, n) = ws.table_layout();
        debug_assert_eq!(((1.0 / dx) as f32, n), (ws.table_inv_dx, ws.table_len));
        // Half a band of grace at the ends of the data: a spectrum sampled from the first to the
        // last band centre (e.g. 400-700 nm on the default grid) holds its end values over the
        // outer halves of the edge bands instead of dropping to zero there.
        let half = ws.step_nm as f64 / 2.0;
        let (w0, w1) = (s.wavelengths_nm[0], s.wavelengths_nm[s.wavelengths_nm.len() - 1]);
        let at = |w: f64| {
            let w = if w < w0 && w >= w0 - half - 1e-9 {
                w0
            } else if w > w1 && w <= w1 + half + 1e-9 {
                w1
            } else {
                w
            };
            s.eval(w)
        };
        let values = (0..n).map(|i| (at(ws.lo_nm as f64 + i as f64 * dx) * scale).max(0.0) as f32).collect();
        SpectrumTable { lo_nm: ws.lo_nm, inv_dx: (1.0 / dx) as f32, values }
    }

    /// Value at `wavelength_nm` (inside the sampler's range).
    #[inline(always)]
    pub fn eval(&self, wavelength_nm: f32) -> f32 {
        let (i, t) = table_position(wavelength_nm, self.lo_nm, self.inv_dx, self.values.len());
        let (a, b) = (self.values[i], self.values[i + 1]);
        a + (b - a) * t
    }

    /// Values at a path's wavelengths (located by the sampler this table was made for); equal to
    /// [`Self::eval`] at each wavelength.
    #[inline(always)]
    pub fn eval_path<const N: usize>(&self, l: &Lambdas<N>) -> [f32; N] {
        debug_assert_eq!(l.table_len as usize, self.values.len(), "wavelengths located for another sampler");
        std::array::from_fn(|k| {
            let i = l.idx[k] as usize;
            let (a, b) = (self.values[i], self.values[i + 1]);
            a + (b - a) * l.frac[k]
        })
    }

    /// Mean value over the table (for light power estimates).
    pub fn mean(&self) -> f64 {
        self.values.iter().map(|v| *v as f64).sum::<f64>() / self.values.len() as f64
    }

    /// Largest value.
    pub fn max(&self) -> f32 {
        self.values.iter().cloned().fold(0.0, f32::max)
    }
}

/// Table entry `i` (with `i + 1` inside a table of `len` entries) and interpolation weight for
/// a wavelength.
#[inline(always)]
fn table_position(wavelength_nm: f32, lo_nm: f32, inv_dx: f32, len: usize) -> (usize, f32) {
    let x = ((wavelength_nm - lo_nm) * inv_dx).max(0.0);
    let i = (x as usize).min(len - 2);
    (i, x - i as f32)
}

/// A path's `N` wavelengths and where they fall in the spectrum tables: all tables of one
/// [`WavelengthSampler`] share a layout, so the position is found once per path.
#[derive(Debug, Clone, Copy)]
pub struct Lambdas<const N: usize> {
    /// Wavelengths, nm.
    pub nm: [f32; N],
    idx: [u32; N],
    frac: [f32; N],
    table_len: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wavelengths_cover_the_range_and_bands_match() {
        let g = WavelengthGrid::default();
        let ws = WavelengthSampler::new(&g);
        assert_eq!((ws.lo_nm, ws.hi_nm), (395.0, 705.0));
        let (l, b) = ws.sample::<4>(0.9);
        for i in 0..4 {
            assert!(l[i] >= 395.0 && l[i] < 705.0);
            let centre = g.wavelength_nm(b[i] as usize) as f32;
            assert!((l[i] - centre).abs() <= 5.0 + 1e-3, "{} in band centred {}", l[i], centre);
        }
        assert!((ws.splat_weight(4) - 31.0 / 4.0).abs() < 1e-5);
    }

    #[test]
    fn table_reproduces_linear_spectrum() {
        let g = WavelengthGrid::default();
        let ws = WavelengthSampler::new(&g);
        let s = Spectrum::new(vec![380.0, 720.0], vec![0.1, 0.9], "t").unwrap();
        let t = SpectrumTable::new(&s, 2.0, &ws);
        for w in [395.0f32, 400.3, 555.5, 704.99] {
            let want = 2.0 * s.eval(w as f64) as f32;
            assert!((t.eval(w) - want).abs() < 1e-5, "{w}: {} vs {want}", t.eval(w));
        }
    }

    #[test]
    fn table_holds_ends_for_half_a_band_only() {
        let g = WavelengthGrid::default();
        let ws = WavelengthSampler::new(&g);
        let s = Spectrum::new(vec![400.0, 700.0], vec![0.5, 0.7], "t").unwrap();
        let t = SpectrumTable::new(&s, 1.0, &ws);
        assert!((t.eval(396.0) - 0.5).abs() < 1e-6 && (t.eval(704.0) - 0.7).abs() < 1e-6);
        let narrow = Spectrum::new(vec![500.0, 510.0], vec![1.0, 1.0], "t").unwrap();
        let t = SpectrumTable::new(&narrow, 1.0, &ws);
        assert_eq!(t.eval(480.0), 0.0);
        assert_eq!(t.eval(530.0), 0.0);
        assert!((t.eval(497.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn path_lookup_equals_single_lookups() {
        let ws = WavelengthSampler::new(&WavelengthGrid::default());
        let s = Spectrum::new(vec![400.0, 480.0, 520.0, 700.0], vec![0.2, 0.9, 0.1, 0.6], "t").unwrap();
        let t = SpectrumTable::new(&s, 1.5, &ws);
        for k in 0..200 {
            let (nm, _) = ws.sample::<4>(k as f32 / 200.0);
            let got = t.eval_path(&ws.locate(nm));
            for i in 0..4 {
                assert_eq!(got[i].to_bits(), t.eval(nm[i]).to_bits());
            }
        }
    }
}
