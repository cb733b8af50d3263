//! The optics stage's geometric map: for each sample of the sensor-plane irradiance, where in the
//! scene radiance the light imaged there comes from (what labels need to follow the image).
//!
//! The map is the one the stage applies, not a model of it: one radiance sample per irradiance
//! sample (the scene spacing times v / d, [`crate::Optics::compute`]), shifted by the output's
//! padding, upright (camsim's optics does not invert the image: like ISETCam's optical image, the
//! irradiance is the scene as the sensor reads it out), and with a traced lens or ray-transfer
//! function (shift-variant blur) the radial distortion as its resampling applies it (the same
//! table, [`crate::lens_maps`]).

use crate::lens_maps::RadialLut;

/// Where each output sample of one optics run images from (see the module docs).
#[derive(Debug, Clone)]
pub struct ImageMap {
    /// Radiance image size, samples.
    pub in_rows: usize,
    pub in_cols: usize,
    /// Irradiance image size, samples (the radiance plus the padding on each side).
    pub out_rows: usize,
    pub out_cols: usize,
    /// Distortion of a traced lens or ray-transfer function, as applied to the output.
    distortion: Option<RadialLut>,
}

impl ImageMap {
    pub(crate) fn new(
        in_rows: usize,
        in_cols: usize,
        out_rows: usize,
        out_cols: usize,
        distortion: Option<RadialLut>,
    ) -> ImageMap {
        ImageMap {
            in_rows,
            in_cols,
            out_rows,
            out_cols,
            distortion,
        }
    }

    /// Whether the map has the lens's distortion.
    pub fn is_distorted(&self) -> bool {
        self.distortion.is_some()
    }

    /// The radiance position `[x, y]` imaged at irradiance position `[x, y]`, both in samples
    /// with sample (r, c) covering [c, c + 1) x [r, r + 1) of its image.
    pub fn scene_position(&self, out_xy: [f64; 2]) -> [f64; 2] {
        let (hw, hh) = (self.out_cols as f64 / 2.0, self.out_rows as f64 / 2.0);
        let ideal = match &self.distortion {
            // The resampling reads the ideal image at film offset times the ideal/film ratio.
            Some(lut) => {
                let (x, y) = (out_xy[0] - hw, out_xy[1] - hh);
                let (f, _) = lut.at(x, y);
                [x * f + hw, y * f + hh]
            }
            None => out_xy,
        };
        // The padding is split evenly (`Padding`), so the centres coincide.
        [
            ideal[0] - (self.out_cols - self.in_cols) as f64 / 2.0,
            ideal[1] - (self.out_rows - self.in_rows) as f64 / 2.0,
        ]
    }

    /// The irradiance position imaged from radiance position `scene_xy` (the inverse of
    /// [`ImageMap::scene_position`], same conventions): where a scene point seen by the render at
    /// `scene_xy` lands on the sensor plane, for keypoints. `None` where the lens's distortion
    /// table does not reach.
    pub fn image_position(&self, scene_xy: [f64; 2]) -> Option<[f64; 2]> {
        let (hw, hh) = (self.out_cols as f64 / 2.0, self.out_rows as f64 / 2.0);
        let ideal = [
            scene_xy[0] + (self.out_cols - self.in_cols) as f64 / 2.0,
            scene_xy[1] + (self.out_rows - self.in_rows) as f64 / 2.0,
        ];
        let Some(lut) = &self.distortion else {
            return Some(ideal);
        };
        // Radial: the film offset lies along the ideal one, at the radius whose image is it.
        let (x, y) = (ideal[0] - hw, ideal[1] - hh);
        let rho_ideal = x.hypot(y);
        if rho_ideal == 0.0 {
            return Some([hw, hh]);
        }
        let t = lut.film_radius(rho_ideal)? / rho_ideal;
        Some([x * t + hw, y * t + hh])
    }
}
