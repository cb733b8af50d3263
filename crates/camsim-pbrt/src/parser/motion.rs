//! Animated transforms (pbrt-v4 4th ed. sec. 3.9, `ActiveTransform`, `TransformTimes`): the
//! graphics state keeps the CTM at the start and at the end time; a shape, instance, light or
//! camera whose two transforms differ moves between them over the transform times, and is stored
//! at its start transform (`camsim_scene3d::motion`). The camera's `shutteropen` and
//! `shutterclose` set the window its rays sample.

use super::*;
use camsim_scene3d::motion::{Motion, MotionPart};

impl SceneBuilder {
    /// The motion of the CTM (`None` when its start and end transforms agree).
    pub(super) fn ctm_motion(&self, loc: &Loc) -> Result<Option<Motion>, PbrtError> {
        if self.gs.ctm == self.gs.ctm_end {
            return Ok(None);
        }
        let (t0, t1) = self.transform_times;
        Motion::between(&self.gs.ctm, t0, &self.gs.ctm_end, t1)
            .map(Some)
            .ok_or_else(|| {
                loc.err(
                    "the start or end transform is singular or projective: it cannot be animated",
                )
            })
    }

    /// The camera's shutter (pbrt-v4 `CameraBaseParameters`: `shutteropen` 0, `shutterclose`
    /// 1, swapped with a warning when reversed) and its motion (`world_from_camera` between the
    /// inverses of the start and end CTMs).
    pub(super) fn camera_time(&mut self, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        let mut open = params.float("shutteropen", 0.0)?;
        let mut close = params.float("shutterclose", 1.0)?;
        if !(open.is_finite() && close.is_finite()) {
            return Err(loc.err("Camera: shutteropen and shutterclose must be finite times, s"));
        }
        if close < open {
            self.note(
                loc,
                format!("Camera: shutterclose {close} < shutteropen {open}: swapped (as pbrt-v4)"),
            );
            std::mem::swap(&mut open, &mut close);
        }
        let time = &mut self.settings.time;
        time.shutter.open_s = open;
        time.shutter.close_s = close;
        time.camera = None;
        if let Some(w1) = inverse(&self.gs.ctm_end) {
            self.named_coords_end.insert("camera".into(), w1);
        }
        if self.gs.ctm != self.gs.ctm_end {
            let singular = || loc.err("Camera: the camera transform is singular");
            let w0 = inverse(&self.gs.ctm).ok_or_else(singular)?;
            let w1 = inverse(&self.gs.ctm_end).ok_or_else(singular)?;
            let (t0, t1) = self.transform_times;
            self.settings.time.camera = Some(
                Motion::between(&w0, t0, &w1, t1)
                    .ok_or_else(|| loc.err("Camera: the camera transform cannot be animated"))?,
            );
        }
        Ok(())
    }

    /// Lights `first..` were just added under the CTM: if it is animated they move with it
    /// (pbrt-v4 warns and uses the start transform; camsim moves point, spot, distant,
    /// goniometric and projection lights, and keeps infinite lights at the start transform).
    pub(super) fn light_motion(&mut self, first: usize, loc: &Loc) -> Result<(), PbrtError> {
        let Some(m) = self.ctm_motion(loc)? else {
            return Ok(());
        };
        for i in first..self.lights.len() {
            if matches!(
                self.lights[i],
                Light::Infinite { .. } | Light::Environment(_)
            ) {
                self.note(
                    loc,
                    "LightSource: an animated infinite light keeps its start transform (as pbrt-v4)",
                );
            } else {
                self.settings.time.lights.push((i, m.clone()));
            }
        }
        Ok(())
    }

    /// The motion of a shape of an object definition placed by `ObjectInstance` under the
    /// current CTM: the instance's transform (animated or fixed) outside the shape's own motion.
    pub(super) fn instance_motion(
        &self,
        own: Option<&Motion>,
        loc: &Loc,
    ) -> Result<Option<Motion>, PbrtError> {
        let outer = self.ctm_motion(loc)?;
        Ok(match (outer, own) {
            (None, None) => None,
            (Some(o), None) => Some(o),
            (outer, Some(own)) => Some(Motion {
                parts: outer
                    .map(|o| o.parts)
                    .unwrap_or_else(|| vec![MotionPart::Fixed(self.gs.ctm)])
                    .into_iter()
                    .chain(own.parts.iter().cloned())
                    .collect(),
            }),
        })
    }
}

/// The shapes `first..end` of a finished pending shape get its motion.
pub(super) fn flush_motion(
    moving: &mut Option<(usize, Motion)>,
    end: usize,
    settings: &mut RenderSettings,
) {
    if let Some((first, m)) = moving.take() {
        for i in first..end {
            settings.time.shapes.push((i, m.clone()));
        }
    }
}
