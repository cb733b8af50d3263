//! Spectral sampling for the path tracer: the wavelengths a path carries, the band they splat
//! into, and spectra tabulated finely so a lookup at a continuous wavelength is one multiply,
//! one floor and one lerp.

use camsim_core::spectrum::Extrapolation;
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
        Lambdas {
            nm,
            idx,
            frac,
            table_len: n as u32,
        }
    }

    /// Weight that turns `L(lambda_i)` into its share of its band's average: `(hi - lo)/(n step)`.
    pub fn splat_weight(&self, n: usize) -> f32 {
        (self.hi_nm - self.lo_nm) / (n as f32 * self.step_nm)
    }
}

/// A spectrum tabulated on a fine uniform grid covering the sampled range, with linear
/// interpolation between table entries. Spectra given as linear interpolation between samples
/// are reproduced to within the interpolation of their own breakpoints onto the table
/// (resolution <= 0.25 nm or step/8). Outside its data a spectrum is zero, as pbrt-v4's
/// `PiecewiseLinearSpectrum` and `camsim_core::Spectrum::eval` (with its default
/// `Extrapolation::Zero`; a spectrum marked `Extrapolation::Hold` holds its end values): data
/// on 400-700 nm fills only the inner halves of the 400 nm and 700 nm bands of the default grid.
/// The table entry nearest each end of the data is placed so the table's linear interpolation
/// drops to zero within one table step (<= 0.25 nm) of the last sample.
#[derive(Debug, Clone)]
pub struct SpectrumTable {
    lo_nm: f32,
    inv_dx: f32,
    /// The spectrum at each table wavelength, with its end values held beyond its data so that
    /// interpolation inside the data never mixes in a zero from outside.
    values: Vec<f32>,
    /// The range with data, nm (infinite for `Extrapolation::Hold`): zero outside.
    data_lo_nm: f32,
    data_hi_nm: f32,
}

impl SpectrumTable {
    /// Tabulate `s` (times `scale`) over the sampler's range; negative values clamp to 0.
    pub fn new(s: &Spectrum, scale: f64, ws: &WavelengthSampler) -> SpectrumTable {
        Self::tabulate(s, scale, ws, 0.0)
    }

    /// As [`Self::new`], keeping negative values (a basis function, such as the CIE daylight
    /// S1 and S2, that is summed with others before it means a radiance).
    pub fn new_signed(s: &Spectrum, scale: f64, ws: &WavelengthSampler) -> SpectrumTable {
        Self::tabulate(s, scale, ws, f64::NEG_INFINITY)
    }

    fn tabulate(s: &Spectrum, scale: f64, ws: &WavelengthSampler, floor: f64) -> SpectrumTable {
        let (dx, n) = ws.table_layout();
        debug_assert_eq!(((1.0 / dx) as f32, n), (ws.table_inv_dx, ws.table_len));
        let (w0, w1) = (
            s.wavelengths_nm[0],
            s.wavelengths_nm[s.wavelengths_nm.len() - 1],
        );
        let values = (0..n)
            .map(|i| {
                (s.eval((ws.lo_nm as f64 + i as f64 * dx).clamp(w0, w1)) * scale).max(floor) as f32
            })
            .collect();
        let (data_lo_nm, data_hi_nm) = match s.extrapolation {
            Extrapolation::Zero => (w0 as f32, w1 as f32),
            Extrapolation::Hold => (f32::NEG_INFINITY, f32::INFINITY),
        };
        SpectrumTable {
            lo_nm: ws.lo_nm,
            inv_dx: (1.0 / dx) as f32,
            values,
            data_lo_nm,
            data_hi_nm,
        }
    }

    /// True where the spectrum has data (or holds its end values).
    #[inline(always)]
    fn covers(&self, wavelength_nm: f32) -> bool {
        wavelength_nm >= self.data_lo_nm && wavelength_nm <= self.data_hi_nm
    }

    /// The table's wavelength of entry `i`, nm.
    fn wavelength_of(&self, i: usize) -> f32 {
        self.lo_nm + i as f32 / self.inv_dx
    }

    /// Value at `wavelength_nm` (inside the sampler's range).
    #[inline(always)]
    pub fn eval(&self, wavelength_nm: f32) -> f32 {
        if !self.covers(wavelength_nm) {
            return 0.0;
        }
        let (i, t) = table_position(wavelength_nm, self.lo_nm, self.inv_dx, self.values.len());
        let (a, b) = (self.values[i], self.values[i + 1]);
        a + (b - a) * t
    }

    /// Values at a path's wavelengths (located by the sampler this table was made for); equal to
    /// [`Self::eval`] at each wavelength.
    #[inline(always)]
    pub fn eval_path<const N: usize>(&self, l: &Lambdas<N>) -> [f32; N] {
        debug_assert_eq!(
            l.table_len as usize,
            self.values.len(),
            "wavelengths located for another sampler"
        );
        std::array::from_fn(|k| {
            if !self.covers(l.nm[k]) {
                return 0.0;
            }
            let i = l.idx[k] as usize;
            let (a, b) = (self.values[i], self.values[i + 1]);
            a + (b - a) * l.frac[k]
        })
    }

    /// The table's values with zero outside the data.
    fn effective(&self) -> impl Iterator<Item = f32> + '_ {
        self.values.iter().enumerate().map(|(i, v)| {
            if self.covers(self.wavelength_of(i)) {
                *v
            } else {
                0.0
            }
        })
    }

    /// Mean value over the table (for light power estimates).
    pub fn mean(&self) -> f64 {
        self.effective().map(|v| v as f64).sum::<f64>() / self.values.len() as f64
    }

    /// Largest value.
    pub fn max(&self) -> f32 {
        self.effective().fold(0.0, f32::max)
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
            assert!(
                (l[i] - centre).abs() <= 5.0 + 1e-3,
                "{} in band centred {}",
                l[i],
                centre
            );
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
            assert!(
                (t.eval(w) - want).abs() < 1e-5,
                "{w}: {} vs {want}",
                t.eval(w)
            );
        }
    }

    /// Band average of a table over `[lo, hi]` nm (midpoint rule, 0.001 nm steps).
    fn band_average(t: &SpectrumTable, lo: f64, hi: f64) -> f64 {
        let n = ((hi - lo) / 0.001).round() as usize;
        (0..n)
            .map(|i| t.eval((lo + (i as f64 + 0.5) * (hi - lo) / n as f64) as f32) as f64)
            .sum::<f64>()
            / n as f64
    }

    /// pbrt-v4 `PiecewiseLinearSpectrum`: zero outside the data. A constant 400-700 nm spectrum
    /// fills half of the 400 nm (395-405) and 700 nm (695-705) bands, so their averages are half
    /// the value, to within the table's resolution (0.25 nm of a 10 nm band: the error bound
    /// 1e-3 is well below the 100 % of the old half-band hold).
    #[test]
    fn spectrum_is_zero_beyond_its_data() {
        let g = WavelengthGrid::default();
        let ws = WavelengthSampler::new(&g);
        let s = Spectrum::new(vec![400.0, 700.0], vec![0.5, 0.5], "t").unwrap();
        let t = SpectrumTable::new(&s, 1.0, &ws);
        assert_eq!(t.eval(399.9), 0.0);
        assert_eq!(t.eval(700.1), 0.0);
        assert_eq!(t.eval(400.0), 0.5);
        assert_eq!(t.eval(700.0), 0.5);
        for (lo, want) in [(395.0, 0.25), (405.0, 0.5), (685.0, 0.5), (695.0, 0.25)] {
            let got = band_average(&t, lo, lo + 10.0);
            assert!(
                (got - want).abs() < 1e-3 * want,
                "band {lo}-{} nm: {got} vs {want}",
                lo + 10.0
            );
        }
        // A sloped spectrum keeps its exact values up to its last sample (no ramp to zero
        // between the last table entry inside and the first outside).
        let s = Spectrum::new(vec![401.3, 698.6], vec![0.2, 0.8], "t").unwrap();
        let t = SpectrumTable::new(&s, 1.0, &ws);
        for w in [401.3f32, 401.4, 698.5, 698.6] {
            // (clamped: the f32 ends may fall a hair outside the f64 data). Tolerance: the slope
            // (0.002 / nm) times the table step (0.25 nm); a ramp to zero would be off by ~0.1.
            let want = s.eval((w as f64).clamp(401.3, 698.6));
            assert!(
                (t.eval(w) as f64 - want).abs() < 5e-4,
                "{w}: {} vs {want}",
                t.eval(w)
            );
        }
        assert_eq!(t.eval(401.2), 0.0);
        assert_eq!(t.eval(698.7), 0.0);
        // Light power estimates see the same zero: the mean is the data's share of the range.
        let flat = Spectrum::new(vec![400.0, 700.0], vec![1.0, 1.0], "t").unwrap();
        let m = SpectrumTable::new(&flat, 1.0, &ws).mean();
        assert!((m - 300.0 / 310.0).abs() < 2e-3, "{m}");
        // A spectrum marked Extrapolation::Hold holds its end values.
        let held = SpectrumTable::new(
            &flat.clone().with_extrapolation(Extrapolation::Hold),
            1.0,
            &ws,
        );
        assert_eq!((held.eval(396.0), held.eval(704.0)), (1.0, 1.0));
        let narrow = Spectrum::new(vec![500.0, 510.0], vec![1.0, 1.0], "t").unwrap();
        let t = SpectrumTable::new(&narrow, 1.0, &ws);
        assert_eq!(t.eval(497.0), 0.0);
        assert_eq!(t.eval(530.0), 0.0);
        assert_eq!(t.eval(505.0), 1.0);
    }

    #[test]
    fn path_lookup_equals_single_lookups() {
        let ws = WavelengthSampler::new(&WavelengthGrid::default());
        let s = Spectrum::new(
            vec![400.0, 480.0, 520.0, 700.0],
            vec![0.2, 0.9, 0.1, 0.6],
            "t",
        )
        .unwrap();
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
