//! Transformation directives (pbrt-v4 `ParserTarget` transform calls): the CTM, named coordinate systems and
//! `ReverseOrientation`.
//! Called by the directive dispatch in `parser.rs` (`Parser::directive`).

use super::*;

impl Parser {
    pub(super) fn transform_directive(
        &mut self,
        d: &str,
        tokens: &[Token],
        pos: &mut usize,
        file: &Path,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        let f = file;
        match d {
            "Identity" => {
                self.gs.ctm = if self.gs.start_active {
                    Transform::identity()
                } else {
                    self.gs.ctm
                }
            }
            "Translate" => {
                let v = nums(tokens, pos, f, d, 3)?;
                self.apply_transform(Transform::translate([v[0], v[1], v[2]]));
            }
            "Scale" => {
                let v = nums(tokens, pos, f, d, 3)?;
                self.apply_transform(Transform::scale([v[0], v[1], v[2]]));
            }
            "Rotate" => {
                let v = nums(tokens, pos, f, d, 4)?;
                if v[1] == 0.0 && v[2] == 0.0 && v[3] == 0.0 {
                    return Err(loc.err("Rotate: the axis is the zero vector"));
                }
                self.apply_transform(Transform::rotate(v[0], [v[1], v[2], v[3]]));
            }
            "LookAt" => {
                let v = nums(tokens, pos, f, d, 9)?;
                let t = xform::look_at([v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]])
                    .map_err(|e| loc.err(e))?;
                self.apply_transform(t);
            }
            "Transform" => {
                let t = matrix16(tokens, pos, f, d, loc)?;
                if self.gs.start_active {
                    self.gs.ctm = t;
                }
            }
            "ConcatTransform" => {
                let t = matrix16(tokens, pos, f, d, loc)?;
                self.apply_transform(t);
            }
            "CoordinateSystem" => {
                let n = string_arg(tokens, pos, f, d)?;
                self.named_coords.insert(n, self.gs.ctm);
            }
            "CoordSysTransform" => {
                let n = string_arg(tokens, pos, f, d)?;
                match self.named_coords.get(&n) {
                    Some(t) => self.gs.ctm = *t,
                    None => self.note(loc, format!("CoordSysTransform: no coordinate system \"{n}\" (ignored, as pbrt-v4 warns)")),
                }
            }
            "ActiveTransform" => {
                let w = match tokens.get(*pos) {
                    Some(Token {
                        kind: TokenKind::Word(w),
                        ..
                    }) => w.clone(),
                    _ => return Err(loc.err("ActiveTransform: expected StartTime, EndTime or All")),
                };
                *pos += 1;
                match w.as_str() {
                    "StartTime" | "All" => self.gs.start_active = true,
                    "EndTime" => {
                        self.gs.start_active = false;
                        self.note(loc, "ActiveTransform EndTime: end-time transforms are ignored (no motion blur)");
                    }
                    _ => return Err(loc.err(format!("ActiveTransform: unknown \"{w}\""))),
                }
            }
            "TransformTimes" => {
                nums(tokens, pos, f, d, 2)?;
                self.note(loc, "TransformTimes ignored (no motion blur)");
            }
            "ReverseOrientation" => self.gs.reverse_orientation = !self.gs.reverse_orientation,
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}
