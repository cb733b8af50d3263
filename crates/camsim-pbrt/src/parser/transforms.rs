//! Transformation directives (pbrt-v4 `ParserTarget` transform calls): the CTM at the start and
//! end times (each directive changes the active ones, `ActiveTransform`), named coordinate
//! systems, `TransformTimes` and `ReverseOrientation`.
//! Called by the directive dispatch in `parser.rs` (`ParserTarget::directive` of `SceneBuilder`).

use super::*;

impl SceneBuilder {
    /// Replace the active transforms by `t` (pbrt-v4 `ForActiveTransforms`).
    fn set_transform(&mut self, t: Transform) {
        if self.gs.start_active {
            self.gs.ctm = t;
        }
        if self.gs.end_active {
            self.gs.ctm_end = t;
        }
    }

    pub(super) fn transform_directive(
        &mut self,
        d: &str,
        args: &mut Args,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        match d {
            "Identity" => self.set_transform(Transform::identity()),
            "Translate" => {
                let v = args.nums(d, 3)?;
                self.apply_transform(Transform::translate([v[0], v[1], v[2]]));
            }
            "Scale" => {
                let v = args.nums(d, 3)?;
                self.apply_transform(Transform::scale([v[0], v[1], v[2]]));
            }
            "Rotate" => {
                let v = args.nums(d, 4)?;
                if v[1] == 0.0 && v[2] == 0.0 && v[3] == 0.0 {
                    return Err(loc.err("Rotate: the axis is the zero vector"));
                }
                self.apply_transform(Transform::rotate(v[0], [v[1], v[2], v[3]]));
            }
            "LookAt" => {
                let v = args.nums(d, 9)?;
                let t = xform::look_at([v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]])
                    .map_err(|e| loc.err(e))?;
                self.apply_transform(t);
            }
            "Transform" => {
                let t = args.matrix16(d, loc)?;
                self.set_transform(t);
            }
            "ConcatTransform" => {
                let t = args.matrix16(d, loc)?;
                self.apply_transform(t);
            }
            "CoordinateSystem" => {
                let n = args.string(d)?;
                self.named_coords_end.insert(n.clone(), self.gs.ctm_end);
                self.named_coords.insert(n, self.gs.ctm);
            }
            "CoordSysTransform" => {
                let n = args.string(d)?;
                match self.named_coords.get(&n) {
                    // pbrt-v4 sets both transforms, whichever are active.
                    Some(t) => {
                        self.gs.ctm = *t;
                        self.gs.ctm_end = self.named_coords_end.get(&n).copied().unwrap_or(*t);
                    }
                    None => self.note(loc, format!("CoordSysTransform: no coordinate system \"{n}\" (ignored, as pbrt-v4 warns)")),
                }
            }
            "ActiveTransform" => {
                let Some(w) = args.word() else {
                    return Err(loc.err("ActiveTransform: expected StartTime, EndTime or All"));
                };
                (self.gs.start_active, self.gs.end_active) = match w.as_str() {
                    "StartTime" => (true, false),
                    "EndTime" => (false, true),
                    "All" => (true, true),
                    _ => return Err(loc.err(format!("ActiveTransform: unknown \"{w}\""))),
                };
            }
            "TransformTimes" => {
                let v = args.nums(d, 2)?;
                // pbrt-v4 allows it in the options block only.
                self.require_world(loc, d, false)?;
                if v[1] < v[0] {
                    return Err(loc.err(format!(
                        "TransformTimes: the end time {} s is before the start time {} s",
                        v[1], v[0]
                    )));
                }
                self.transform_times = (v[0], v[1]);
            }
            "ReverseOrientation" => self.gs.reverse_orientation = !self.gs.reverse_orientation,
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}
