//! Sampled point-spread functions and the curves derived from them (line spread, MTF).

/// A point-spread function sampled on a square grid, centred on the middle sample
/// (`data[(size/2) * size + size/2]` is the optical axis), normalized to unit volume
/// (`sum(data) = 1`, so a convolution with it conserves energy). Row-major; rows run along the
/// image's row direction (y), columns along x.
#[derive(Debug, Clone, PartialEq)]
pub struct Psf {
    /// Wavelength, nm.
    pub wavelength_nm: f64,
    /// Sample spacing in the sensor plane, m.
    pub spacing_m: f64,
    /// Samples per side (odd).
    pub size: usize,
    /// Values (fraction of the energy in each sample), row-major, `size * size`.
    pub data: Vec<f64>,
}

/// An MTF curve: modulation against spatial frequency in the sensor plane.
#[derive(Debug, Clone, PartialEq)]
pub struct MtfCurve {
    /// Wavelength, nm.
    pub wavelength_nm: f64,
    /// Spatial frequency, cycles per mm in the sensor plane.
    pub freq_cyc_per_mm: Vec<f64>,
    /// MTF along x (horizontal frequencies, vertical lines), 1 at 0.
    pub mtf_x: Vec<f64>,
    /// MTF along y (vertical frequencies).
    pub mtf_y: Vec<f64>,
}

impl Psf {
    /// Value at (row, col).
    pub fn at(&self, row: usize, col: usize) -> f64 {
        self.data[row * self.size + col]
    }

    /// Sum of all samples (1 after normalization).
    pub fn sum(&self) -> f64 {
        self.data.iter().sum()
    }

    /// Line-spread function along x: the PSF integrated over y (column sums), unit sum;
    /// sample `i` lies at x = (i - size/2) * spacing_m.
    pub fn lsf_x(&self) -> Vec<f64> {
        let n = self.size;
        let mut l = vec![0.0; n];
        for r in 0..n {
            for c in 0..n {
                l[c] += self.data[r * n + c];
            }
        }
        l
    }

    /// Line-spread function along y (row sums).
    pub fn lsf_y(&self) -> Vec<f64> {
        self.data
            .chunks_exact(self.size)
            .map(|row| row.iter().sum())
            .collect()
    }

    /// MTF from this PSF at the frequencies of its own grid, k / (size * spacing) for
    /// k = 0..=size/2, as the modulus of the discrete Fourier transform of the line-spread function
    /// (OTF(f, 0) = FT of the LSF along x; projection-slice theorem). For a PSF that is the
    /// complete periodized PSF of a pupil these are exact samples of the OTF of the sampled pupil.
    pub fn mtf(&self) -> MtfCurve {
        let n = self.size;
        let lx = self.lsf_x();
        let ly = self.lsf_y();
        let dft = |l: &[f64], k: usize| {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in l.iter().enumerate() {
                let ph = -2.0 * std::f64::consts::PI * (k * i % n) as f64 / n as f64;
                re += v * ph.cos();
                im += v * ph.sin();
            }
            (re * re + im * im).sqrt()
        };
        let ks: Vec<usize> = (0..=n / 2).collect();
        MtfCurve {
            wavelength_nm: self.wavelength_nm,
            freq_cyc_per_mm: ks
                .iter()
                .map(|k| *k as f64 / (n as f64 * self.spacing_m) * 1e-3)
                .collect(),
            mtf_x: ks.iter().map(|k| dft(&lx, *k)).collect(),
            mtf_y: ks.iter().map(|k| dft(&ly, *k)).collect(),
        }
    }

    /// Fraction of the energy within `radius_m` of the centre (sample centres inside the circle).
    pub fn encircled_energy(&self, radius_m: f64) -> f64 {
        let n = self.size;
        let c = (n / 2) as f64;
        let r2 = (radius_m / self.spacing_m).powi(2);
        let mut e = 0.0;
        for r in 0..n {
            for col in 0..n {
                let (dy, dx) = (r as f64 - c, col as f64 - c);
                if dx * dx + dy * dy <= r2 {
                    e += self.data[r * n + col];
                }
            }
        }
        e
    }

    /// The PSF as f32 values (for convolution kernels and image files).
    pub fn to_f32(&self) -> Vec<f32> {
        self.data.iter().map(|v| *v as f32).collect()
    }
}
