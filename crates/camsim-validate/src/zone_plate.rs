//! Zone-plate MTF of a camera (`camsim compare`): the in-phase modulation of the demosaicked
//! luminance against radial frequency on ISETCam's circular zone plate (`kind = "zone_plate"`).
//!
//! The scene's reflectance is `(1 + A cos(pi r^2 / N + phase)) / 2` with `r` in scene samples from
//! the centre sample (index N/2) of an N x N scene, so its local frequency is `r / N` cycles per
//! sample ([`camsim_scene::ZonePlateScene`]). Imaged with `k` sensor pixels per scene sample (the
//! thin-lens magnification, as [`camsim_pipeline::macbeth_chart_corners_px`]), a sensor pixel at
//! radius `r_px` sees the phase `pi (r_px / k)^2 / N + phase` and the local frequency
//! `r_px / (N k^2)` cycles per pixel. In annuli of that frequency the luminance above black is
//! fitted by least squares to `a cos(phi) + b sin(phi) + c` (the method of
//! `camsim_isp::demosaic_quality`, after Wang et al. / ISETCam's zone-plate analysis), and
//! MTF = sqrt(a^2 + b^2) / (A c): the modulation transferred at that frequency, averaged over all
//! orientations (aliased energy at other frequencies does not count).

/// Where the zone plate lies on the sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZonePlateGeometry {
    /// Scene side N, samples.
    pub size_samples: usize,
    /// Sensor pixels per scene sample, k.
    pub sensor_px_per_sample: f64,
    /// Amplitude A of the reflectance cosine, (0, 1].
    pub amplitude: f64,
    /// Phase at the centre, radians.
    pub phase_rad: f64,
}

impl ZonePlateGeometry {
    /// Position of sensor pixel centre (row, col) relative to the zone plate's centre, in scene
    /// samples, for a `rows` x `cols` window centred on the optical axis like the scene.
    fn offset_samples(&self, rows: usize, cols: usize, row: usize, col: usize) -> (f64, f64) {
        let k = self.sensor_px_per_sample;
        // Scene sample j covers [j, j + 1]; the centre sample floor(N/2) has its centre at
        // floor(N/2) + 1/2, `half` samples right of and below the optical axis (the scene's middle, N/2).
        let half = (self.size_samples / 2) as f64 + 0.5 - self.size_samples as f64 / 2.0;
        let dx = (col as f64 + 0.5 - cols as f64 / 2.0) / k - half;
        let dy = (row as f64 + 0.5 - rows as f64 / 2.0) / k - half;
        (dx, dy)
    }

    /// Local frequency at sensor pixel (row, col), cycles per pixel.
    pub fn frequency_cy_per_px(&self, rows: usize, cols: usize, row: usize, col: usize) -> f64 {
        let (dx, dy) = self.offset_samples(rows, cols, row, col);
        dx.hypot(dy) / self.size_samples as f64 / self.sensor_px_per_sample
    }

    /// Phase of the reflectance cosine at sensor pixel (row, col), radians.
    pub fn phase(&self, rows: usize, cols: usize, row: usize, col: usize) -> f64 {
        let (dx, dy) = self.offset_samples(rows, cols, row, col);
        std::f64::consts::PI * (dx * dx + dy * dy) / self.size_samples as f64 + self.phase_rad
    }
}

/// MTF against radial frequency of a luminance image (`rows` x `cols`, row-major, DN with
/// `black_dn` still in), in annuli `df_cy_per_px` wide up to `f_max_cy_per_px`. Pixels within 3 of
/// the border are left out (the demosaicker's edge handling). Returns (annulus centre frequency
/// in cycles/pixel, MTF); annuli with too few pixels for the fit are skipped.
pub fn zone_plate_mtf(
    y: &[f32],
    rows: usize,
    cols: usize,
    black_dn: f64,
    geom: &ZonePlateGeometry,
    df_cy_per_px: f64,
    f_max_cy_per_px: f64,
) -> (Vec<f64>, Vec<f64>) {
    let bins = (f_max_cy_per_px / df_cy_per_px).floor() as usize;
    // Normal equations of the fit per annulus: sum of basis basis^T and basis x value.
    let mut normal = vec![[[0.0f64; 3]; 3]; bins];
    let mut rhs = vec![[0.0f64; 3]; bins];
    let mut count = vec![0usize; bins];
    for row in 3..rows.saturating_sub(3) {
        for col in 3..cols.saturating_sub(3) {
            let f = geom.frequency_cy_per_px(rows, cols, row, col);
            let bin = (f / df_cy_per_px) as usize;
            if bin >= bins {
                continue;
            }
            let phi = geom.phase(rows, cols, row, col);
            let basis = [phi.cos(), phi.sin(), 1.0];
            let v = y[row * cols + col] as f64 - black_dn;
            for i in 0..3 {
                for j in 0..3 {
                    normal[bin][i][j] += basis[i] * basis[j];
                }
                rhs[bin][i] += basis[i] * v;
            }
            count[bin] += 1;
        }
    }
    let (mut freq, mut mtf) = (Vec::new(), Vec::new());
    for b in 0..bins {
        // Fewer than 64 pixels (the innermost annuli, radius < ~6 pixels): too little of a cycle for the fit.
        if count[b] < 64 {
            continue;
        }
        let Some([a, s, c]) = solve3(&normal[b], &rhs[b]) else {
            continue;
        };
        if c <= 0.0 {
            continue;
        }
        freq.push((b as f64 + 0.5) * df_cy_per_px);
        mtf.push(a.hypot(s) / (geom.amplitude * c));
    }
    (freq, mtf)
}

/// Solve the 3x3 system m x = v by Cramer's rule (None when singular).
fn solve3(m: &[[f64; 3]; 3], v: &[f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    let scale = m
        .iter()
        .flatten()
        .map(|x| x.abs())
        .fold(0.0, f64::max)
        .powi(3);
    // Also refuses a NaN determinant.
    if d.is_nan() || d.abs() <= 1e-12 * scale {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut mc = *m;
        for r in 0..3 {
            mc[r][c] = v[r];
        }
        *xc = det(&mc) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A perfectly imaged zone plate (the scene's luminance sampled at the pixel centres) has
    /// MTF 1 at every frequency well below Nyquist; a known attenuation is recovered.
    #[test]
    fn an_ideal_image_has_unit_mtf_and_an_attenuation_is_recovered() {
        let (rows, cols) = (96, 128);
        let geom = ZonePlateGeometry {
            size_samples: 384,
            sensor_px_per_sample: 0.5,
            amplitude: 0.8,
            phase_rad: 0.3,
        };
        for gain in [1.0, 0.5] {
            let mut y = vec![0.0f32; rows * cols];
            for r in 0..rows {
                for c in 0..cols {
                    let phi = geom.phase(rows, cols, r, c);
                    y[r * cols + c] =
                        (64.0 + 1000.0 * (1.0 + gain * geom.amplitude * phi.cos())) as f32;
                }
            }
            let (f, m) = zone_plate_mtf(&y, rows, cols, 64.0, &geom, 0.02, 0.4);
            assert!(f.len() > 15, "{f:?}");
            for (fi, mi) in f.iter().zip(&m) {
                assert!((mi - gain).abs() < 2e-3, "f {fi}: MTF {mi}, want {gain}");
            }
        }
    }
}
