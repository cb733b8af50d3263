//! Adaptive sampling to the sensor's own noise (`[render.adaptive]`): the render's stopping
//! target ([`camsim_scene3d::scene::AdaptiveSampling`]) made from the capture, so that each
//! pixel stops once its Monte Carlo noise is a fraction of the temporal noise the sensor will add
//! at that pixel anyway.
//!
//! The renderer tests one channel per colour filter, in electrons: the filter's photo-electrons
//! in one sensor pixel per unit of each band's radiance,
//! `w_c(lambda) = G(lambda) t QE_c(lambda) lambda / (h c) d_lambda A`,
//! with `G` the lens's peak irradiance per radiance (on axis, object at infinity,
//! [`camsim_optics::Optics::peak_irradiance_per_radiance`]; 1 for a lens camera, whose film is
//! already irradiance), `t` the exposure, `A` the photodetector area
//! ([`camsim_sensor::Sensor::electrons_per_irradiance`]). A pixel of mean `m_c` electrons gets
//! temporal noise of variance `m_c + sigma_0^2` from the sensor (photon shot noise, then
//! [`camsim_sensor::Sensor::noise_floor_variance_e2`]: read, DSNU, dark shot, quantization), so
//! the render's variance of the mean may be `f^2 (m_c + sigma_0^2)` for the noise fraction `f`:
//! `shot = f^2`, `floor = f sigma_0`. When render pixels are smaller than sensor pixels, each
//! sensor pixel averages `r = (sensor pitch / render pitch)^2` of them, so a render pixel may be
//! `r` times noisier (`shot = r f^2`, `floor = sqrt(r) f sigma_0`).
//!
//! Every approximation errs toward more samples: the on-axis, infinite-distance camera equation
//! is the largest irradiance (off axis and up close a pixel collects less, so its noise allowed
//! in radiance is larger); the optics' blur averages neighbouring render pixels' noise, which is
//! ignored; PRNU (fixed-pattern) is not counted as noise; every filter's channel is tested at
//! every render pixel, though a mosaic pixel sees only one. An exposure bracket is targeted at
//! its longest exposure, auto-exposure at the exposure metered on a preview render of
//! [`crate::sequence::METERING_SPP`] samples. An HDR sensor is targeted with its base pixel's
//! noise.

use crate::config::AdaptiveSection;
use crate::{PipelineError, Result};
use camsim_optics::Optics;
use camsim_scene3d::scene::AdaptiveSampling;
use camsim_scene3d::SceneDescription;
use camsim_sensor::Sensor;

/// The relative-error target of `camsim render --adaptive-error` and `relative_error`: each
/// pixel's luminance to `relative_error` of its mean, with `floor_cd_m2` as the error allowed
/// at a black pixel (0: none).
pub fn relative_target(
    relative_error: f64,
    floor_cd_m2: f64,
    min_samples: u32,
) -> Result<AdaptiveSampling> {
    if !(relative_error > 0.0) || !relative_error.is_finite() {
        return Err(PipelineError::config(format!(
            "render.adaptive.relative_error = {relative_error}: give a relative standard error > 0 (0.01 is 1 %)"
        )));
    }
    Ok(AdaptiveSampling::relative(
        relative_error,
        floor_cd_m2,
        min_samples,
    ))
}

/// The sensor-noise target of `sec` for rendering `scene` through `optics` onto `sensor` at
/// `exposure_s`, with render pixels `render_px_in_sensor_px` sensor pixels wide
/// (`crate::sequence::sensor_px_per_render_px`); a `relative_error` section gives
/// [`relative_target`] instead. Module docs: the formula and why it is conservative.
pub fn sensor_target(
    sec: &AdaptiveSection,
    scene: &SceneDescription,
    optics: &Optics,
    sensor: &Sensor,
    exposure_s: f64,
    render_px_in_sensor_px: f64,
) -> Result<AdaptiveSampling> {
    if let Some(rel) = sec.relative_error {
        return relative_target(rel, 0.0, sec.min_samples);
    }
    let f = sec.noise_fraction;
    if !(f > 0.0) || !f.is_finite() {
        return Err(PipelineError::config(format!(
            "render.adaptive.noise_fraction = {f}: give a fraction > 0 of the sensor's noise (0.2 adds 2 % to it)"
        )));
    }
    if !(exposure_s > 0.0) || !exposure_s.is_finite() {
        return Err(PipelineError::config(format!(
            "render.adaptive: the exposure is {exposure_s} s; adaptive sampling to the sensor's noise needs a positive exposure"
        )));
    }
    let grid = &scene.settings.grid;
    let gain: Vec<f64> = if scene.camera.lens.is_some() {
        vec![1.0; grid.len()]
    } else {
        optics.peak_irradiance_per_radiance(grid)
    };
    let channels: Vec<Vec<f64>> = sensor
        .electrons_per_irradiance(grid)
        .into_iter()
        .map(|e| {
            e.iter()
                .zip(&gain)
                .map(|(e, g)| e * g * exposure_s)
                .collect()
        })
        .collect();
    // Render pixels per sensor pixel (area), at least 1: a coarser render's noise is not
    // averaged away by the resampling.
    let r = if render_px_in_sensor_px > 0.0 && render_px_in_sensor_px.is_finite() {
        (1.0 / (render_px_in_sensor_px * render_px_in_sensor_px)).max(1.0)
    } else {
        1.0
    };
    let shot = if sensor.noise().shot { r * f * f } else { 0.0 };
    let floor = (r * sensor.noise_floor_variance_e2(exposure_s)).sqrt() * f;
    if shot == 0.0 && floor == 0.0 {
        return Err(PipelineError::config(format!(
            "render.adaptive: sensor {} has every temporal noise source switched off, so no render noise hides under it: give relative_error instead",
            sensor.name()
        )));
    }
    Ok(AdaptiveSampling {
        min_samples: sec.min_samples,
        channels,
        relative: 0.0,
        shot,
        floor,
    })
}
