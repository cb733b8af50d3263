//! The spectral image every stage exchanges: band-sequential f32 planes plus their wavelengths,
//! physical sample spacing and the radiometric quantity they hold.

use crate::error::{CoreError, Result};
use crate::grid::WavelengthGrid;
use crate::mem;
use serde::{Deserialize, Serialize};

/// What the values of a spectral image are, with their unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Scene spectral radiance, W/(sr m^2 nm) (stage `scene`).
    Radiance,
    /// Sensor-plane spectral irradiance, W/(m^2 nm) (stage `optics`).
    Irradiance,
    /// Dimensionless fraction (reflectance, transmittance, relative values).
    Relative,
}

impl Quantity {
    /// Unit string, as written in file headers.
    pub fn unit(&self) -> &'static str {
        match self {
            Quantity::Radiance => "W.sr^-1.m^-2.nm^-1",
            Quantity::Irradiance => "W.m^-2.nm^-1",
            Quantity::Relative => "1",
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            Quantity::Radiance => "radiance",
            Quantity::Irradiance => "irradiance",
            Quantity::Relative => "relative",
        }
    }
    pub fn from_name(s: &str) -> Option<Quantity> {
        match s {
            "radiance" => Some(Quantity::Radiance),
            "irradiance" => Some(Quantity::Irradiance),
            "relative" => Some(Quantity::Relative),
            _ => None,
        }
    }
}

/// Geometry that travels with an image so later stages can reason about it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct ImageGeometry {
    /// Horizontal field of view, degrees (scene images; 0 when unknown).
    pub fov_deg: f64,
    /// Distance of the scene plane from the lens, m (scene images; 0 when unknown or 3D).
    pub distance_m: f64,
    /// Focal length of the optics that formed the image, m (irradiance images; 0 before optics).
    pub focal_length_m: f64,
    /// f-number of the optics that formed the image (0 before optics).
    pub f_number: f64,
}

/// A spectral image, band-sequential: band `b` is the contiguous plane
/// `data[b * rows * cols .. (b + 1) * rows * cols]`, row-major within the plane.
///
/// `sample_spacing_m` is the physical distance between neighbouring samples in the plane the
/// image lives in: the scene plane for radiance (object space), the sensor plane for irradiance.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralImage {
    pub rows: usize,
    pub cols: usize,
    pub grid: WavelengthGrid,
    pub sample_spacing_m: f64,
    pub quantity: Quantity,
    pub geometry: ImageGeometry,
    /// Optional per-pixel depth (distance along the optical axis to the surface), m.
    pub depth_m: Option<Vec<f32>>,
    pub data: Vec<f32>,
}

impl SpectralImage {
    /// A zero image, refusing sizes that do not fit in memory before allocating.
    pub fn zeros(
        rows: usize,
        cols: usize,
        grid: WavelengthGrid,
        sample_spacing_m: f64,
        quantity: Quantity,
    ) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(CoreError::invalid(
                "image size",
                format!("{rows} x {cols} has no pixels"),
            ));
        }
        if !(sample_spacing_m > 0.0 && sample_spacing_m.is_finite()) {
            return Err(CoreError::invalid(
                "sample spacing",
                format!("{sample_spacing_m} m is not a positive number"),
            ));
        }
        let n = rows
            .checked_mul(cols)
            .and_then(|p| p.checked_mul(grid.len()))
            .ok_or_else(|| {
                CoreError::invalid(
                    "image size",
                    format!("{rows} x {cols} x {} overflows", grid.len()),
                )
            })?;
        mem::check_alloc(
            n as u64 * 4,
            &format!("a {rows} x {cols} x {}-band spectral image", grid.len()),
        )?;
        Ok(SpectralImage {
            rows,
            cols,
            grid,
            sample_spacing_m,
            quantity,
            geometry: ImageGeometry::default(),
            depth_m: None,
            data: mem::zeroed_f32(n),
        })
    }

    /// Wrap existing band-sequential data.
    pub fn from_data(
        rows: usize,
        cols: usize,
        grid: WavelengthGrid,
        sample_spacing_m: f64,
        quantity: Quantity,
        data: Vec<f32>,
    ) -> Result<Self> {
        if data.len() != rows * cols * grid.len() {
            return Err(CoreError::invalid(
                "spectral image",
                format!(
                    "{} values for {rows} x {cols} x {} bands",
                    data.len(),
                    grid.len()
                ),
            ));
        }
        Ok(SpectralImage {
            rows,
            cols,
            grid,
            sample_spacing_m,
            quantity,
            geometry: ImageGeometry::default(),
            depth_m: None,
            data,
        })
    }

    pub fn bands(&self) -> usize {
        self.grid.len()
    }
    pub fn pixels(&self) -> usize {
        self.rows * self.cols
    }
    pub fn band(&self, b: usize) -> &[f32] {
        let n = self.pixels();
        &self.data[b * n..(b + 1) * n]
    }
    pub fn band_mut(&mut self, b: usize) -> &mut [f32] {
        let n = self.pixels();
        &mut self.data[b * n..(b + 1) * n]
    }
    /// Mutable band planes, for `rayon` over bands.
    pub fn bands_mut(&mut self) -> std::slice::ChunksExactMut<'_, f32> {
        let n = self.pixels();
        self.data.chunks_exact_mut(n)
    }
    pub fn at(&self, row: usize, col: usize, band: usize) -> f32 {
        self.data[band * self.pixels() + row * self.cols + col]
    }
    /// The spectrum at one pixel (allocates; not for hot loops).
    pub fn pixel_spectrum(&self, row: usize, col: usize) -> Vec<f64> {
        (0..self.bands())
            .map(|b| self.at(row, col, b) as f64)
            .collect()
    }
    /// Width and height of the image in metres in its own plane.
    pub fn width_m(&self) -> f64 {
        self.cols as f64 * self.sample_spacing_m
    }
    pub fn height_m(&self) -> f64 {
        self.rows as f64 * self.sample_spacing_m
    }

    /// Mean over all pixels of `sum_b value_b * weight_b * step_nm` (a spectral integral with the
    /// given weights, e.g. luminance with 683 * ybar). `weights` must match the grid.
    pub fn mean_weighted_integral(&self, weights: &[f64]) -> f64 {
        assert_eq!(weights.len(), self.bands());
        let mut total = 0.0;
        for (b, w) in weights.iter().enumerate() {
            let s: f64 = self.band(b).iter().map(|v| *v as f64).sum();
            total += s * w;
        }
        total * self.grid.step_nm / self.pixels() as f64
    }

    /// Reject NaN, infinite, negative or absurdly large values (file input: above
    /// [`MAX_SPECTRAL_VALUE`] in the image's unit), naming `what`, the pixel and the wavelength.
    pub fn validate_values(&self, what: &str) -> Result<()> {
        let n = self.pixels();
        let at = |i: usize| {
            let p = i % n;
            format!(
                "value {:e} at row {}, column {}, {} nm",
                self.data[i],
                p / self.cols,
                p % self.cols,
                self.grid.wavelength_nm(i / n)
            )
        };
        if let Some(i) = self.data.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(CoreError::invalid(
                what,
                format!("{} is not a finite non-negative number", at(i)),
            ));
        }
        if let Some(i) = self.data.iter().position(|v| *v > MAX_SPECTRAL_VALUE) {
            return Err(CoreError::invalid(
                what,
                format!(
                    "{} is above {MAX_SPECTRAL_VALUE:e} {}: the values must lie in [0, {MAX_SPECTRAL_VALUE:e}] (is the file in these units?)",
                    at(i),
                    self.quantity.unit()
                ),
            ));
        }
        Ok(())
    }
}

/// The largest spectral value camsim accepts from a file: 1e20 in the image's unit
/// (W/(sr m^2 nm) for radiance). The Sun's surface is about 2e7 W/(sr m^2 nm) at its peak
/// (Planck's law at 5772 K), so anything near this is a unit mistake or a damaged file (an EXR
/// pixel of 3e38 is the f32 range, not a scene).
pub const MAX_SPECTRAL_VALUE: f32 = 1e20;

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 25 item 7: EXR pixels of 3e38 were accepted.
    #[test]
    fn absurd_values_are_refused_with_the_pixel_and_the_range() {
        let g = WavelengthGrid::new(400.0, 420.0, 10.0).unwrap();
        let mut img = SpectralImage::zeros(2, 3, g, 1e-6, Quantity::Radiance).unwrap();
        img.data.iter_mut().for_each(|v| *v = 1e19);
        assert!(img.validate_values("r.exr").is_ok());
        img.data[6 + 4] = 3e38;
        let e = img.validate_values("r.exr").unwrap_err().to_string();
        assert!(
            e.starts_with("r.exr: value 3e38 at row 1, column 1, 410 nm is above 1e20")
                && e.contains("[0, 1e20]"),
            "{e}"
        );
    }

    #[test]
    fn band_sequential_layout() {
        let g = WavelengthGrid::new(400.0, 420.0, 10.0).unwrap();
        let mut img = SpectralImage::zeros(2, 3, g, 1e-6, Quantity::Radiance).unwrap();
        img.band_mut(1)[4] = 7.0;
        assert_eq!(img.at(1, 1, 1), 7.0);
        assert_eq!(img.data[6 + 4], 7.0);
    }

    #[test]
    fn refuses_impossible_sizes_before_allocating() {
        let g = WavelengthGrid::default();
        assert!(SpectralImage::zeros(1 << 20, 1 << 20, g, 1e-6, Quantity::Radiance).is_err());
        assert!(SpectralImage::zeros(0, 5, g, 1e-6, Quantity::Radiance).is_err());
        assert!(SpectralImage::zeros(5, 5, g, -1.0, Quantity::Radiance).is_err());
    }
}
