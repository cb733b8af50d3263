//! Pixel vignetting: the loss of light in the pixel's dielectric "tunnel" when the chief ray
//! arrives obliquely (ISETCam `sensorVignetting` / `mlAnalyzeArrayEtendue` with methods
//! 'no microlens' (bare) and 'optimal' microlens placement; Catrysse & Wandell 2005, "Roadmap for
//! CMOS image sensors: Moore meets Planck and Sommerfeld", §3 optical efficiency).
//!
//! Geometric model, separable in x and y. Light fills the exit pupil of f-number N uniformly, so
//! the ray slopes arriving at a pixel are uniform over tan(theta) +- 1/(2N) around the chief ray's
//! slope tan(theta), theta the chief ray angle (CRA) = atan(position / exit-pupil distance). Each
//! ray enters the pixel aperture (width = pitch p), refracts into the stack of index n (Snell:
//! sin(phi') = sin(phi) / n) and after the stack height h lands shifted by h tan(phi') (minus the
//! microlens shift: 0 bare, h tan(theta') optimal, which recentres the chief ray on the
//! photodetector). The fraction collected is the overlap of the shifted aperture with the
//! photodetector (width d = p sqrt(fill factor), centred), over p:
//! L(s) = max(0, min(p/2 + s, d/2) - max(-p/2 + s, -d/2)) / p. The relative response of a pixel
//! is mean_x L x mean_y L over the pupil, divided by its on-axis value (1 on the axis).

use serde::{Deserialize, Serialize};

/// Microlens placement (ISETCam `mlAnalyzeArrayEtendue` method).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum MicrolensPlacement {
    /// No microlens (ISETCam 'no microlens', pixel vignetting flag 1, "bare").
    #[default]
    None,
    /// Shifted towards the optical axis by h tan(theta') at each pixel, so the chief ray lands on
    /// the photodetector's centre (ISETCam 'optimal', flag 3).
    Optimal,
}

/// `[pixel_vignetting]` of a sensor TOML.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PixelVignettingConfig {
    /// f-number of the imaging lens (sets the cone of rays), > 0.
    pub f_number: f64,
    /// Exit-pupil distance of the imaging lens, mm (> 0): the CRA at image height r is
    /// atan(r / distance).
    pub exit_pupil_distance_mm: f64,
    /// Height of the dielectric stack from the pixel aperture to the photodetector, um (>= 0).
    pub stack_height_um: f64,
    /// Refractive index of the stack (>= 1; SiO2 ~ 1.46, the default).
    #[serde(default = "default_index")]
    pub dielectric_index: f64,
    /// Microlens placement: "none" (bare pixel) or "optimal".
    #[serde(default)]
    pub microlens: MicrolensPlacement,
}

fn default_index() -> f64 {
    1.46
}

/// Pupil samples per axis (midpoint rule over the uniform slope distribution).
const PUPIL_SAMPLES: usize = 64;

impl PixelVignettingConfig {
    /// Check the values; the message names the key.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let pos = |k: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((k.to_string(), format!("must be a positive number, got {v}")))
            }
        };
        pos("pixel_vignetting.f_number", self.f_number)?;
        pos(
            "pixel_vignetting.exit_pupil_distance_mm",
            self.exit_pupil_distance_mm,
        )?;
        if !(self.stack_height_um.is_finite() && self.stack_height_um >= 0.0) {
            return Err((
                "pixel_vignetting.stack_height_um".into(),
                format!("must be a finite number >= 0, got {}", self.stack_height_um),
            ));
        }
        if !(self.dielectric_index.is_finite() && self.dielectric_index >= 1.0) {
            return Err((
                "pixel_vignetting.dielectric_index".into(),
                format!("must be >= 1, got {}", self.dielectric_index),
            ));
        }
        Ok(())
    }

    /// Fraction of the light through one axis of the aperture that reaches the photodetector,
    /// for chief-ray slope `tan_chief` (pitch and photodetector width in um).
    pub fn axis_fraction(&self, tan_chief: f64, pitch_um: f64, pd_um: f64) -> f64 {
        let n = self.dielectric_index;
        let h = self.stack_height_um;
        let refracted_tan = |t: f64| {
            let s = (t / (1.0 + t * t).sqrt()) / n;
            s / (1.0 - s * s).sqrt()
        };
        let shift_ml = match self.microlens {
            MicrolensPlacement::None => 0.0,
            MicrolensPlacement::Optimal => h * refracted_tan(tan_chief),
        };
        let half_cone = 1.0 / (2.0 * self.f_number);
        let overlap = |s: f64| {
            ((pitch_um / 2.0 + s).min(pd_um / 2.0) - (-pitch_um / 2.0 + s).max(-pd_um / 2.0))
                .max(0.0)
                / pitch_um
        };
        (0..PUPIL_SAMPLES)
            .map(|k| {
                let u = (k as f64 + 0.5) / PUPIL_SAMPLES as f64 * 2.0 - 1.0;
                overlap(h * refracted_tan(tan_chief + u * half_cone) - shift_ml)
            })
            .sum::<f64>()
            / PUPIL_SAMPLES as f64
    }

    /// Relative response (1 on the axis) of every pixel of a `rows` x `cols` sensor, centred on
    /// the optical axis, row-major.
    pub fn relative_response(
        &self,
        rows: usize,
        cols: usize,
        pitch_um: f64,
        fill_factor: f64,
    ) -> Vec<f32> {
        let pd_um = pitch_um * fill_factor.sqrt();
        let d_um = self.exit_pupil_distance_mm * 1e3;
        let on_axis = self.axis_fraction(0.0, pitch_um, pd_um);
        let axis = |n: usize| -> Vec<f64> {
            (0..n)
                .map(|i| {
                    let pos_um = (i as f64 + 0.5 - n as f64 / 2.0) * pitch_um;
                    if on_axis > 0.0 {
                        self.axis_fraction(pos_um / d_um, pitch_um, pd_um) / on_axis
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        let (fy, fx) = (axis(rows), axis(cols));
        fy.iter()
            .flat_map(|y| fx.iter().map(move |x| (y * x) as f32))
            .collect()
    }
}
