//! Block structure: attribute and transform blocks, object definitions and instances, `Attribute`,
//! and the `WorldBegin` boundary (`Include` and `Import` are the reader's, `reader.rs`).
//! Called by the directive dispatch in `parser.rs` (`ParserTarget::directive` of `SceneBuilder`).

use super::*;

impl SceneBuilder {
    pub(super) fn block_directive(
        &mut self,
        d: &str,
        args: &mut Args,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        match d {
            "AttributeBegin" | "TransformBegin" => {
                if d == "TransformBegin" {
                    self.note(
                        loc,
                        "TransformBegin is deprecated in pbrt-v4 (treated as a CTM push)",
                    );
                }
                if self.stack.len() > 10_000 {
                    return Err(loc.err("attribute blocks nested more than 10000 deep"));
                }
                let b = if d == "AttributeBegin" {
                    Block::Attribute
                } else {
                    Block::Transform
                };
                self.stack.push((self.gs.clone(), b, loc.clone()));
            }
            "AttributeEnd" | "TransformEnd" => match self.stack.pop() {
                None => self.note(
                    loc,
                    format!("unmatched {d} ignored (pbrt-v4 reports and ignores it)"),
                ),
                Some((saved, block, _)) => match block {
                    Block::Attribute => {
                        if d != "AttributeEnd" {
                            return Err(loc.err("TransformEnd closes an AttributeBegin"));
                        }
                        self.gs = saved;
                    }
                    Block::Transform => {
                        if d != "TransformEnd" {
                            return Err(loc.err("AttributeEnd closes a TransformBegin"));
                        }
                        self.gs.ctm = saved.ctm;
                        self.gs.ctm_end = saved.ctm_end;
                        self.gs.start_active = saved.start_active;
                        self.gs.end_active = saved.end_active;
                    }
                },
            },
            "WorldBegin" => {
                self.require_world(loc, d, false)?;
                self.in_world = true;
                self.camera_world_check();
                // pbrt-v4 WorldBegin: both transforms reset, both active.
                self.gs.ctm = Transform::identity();
                self.gs.ctm_end = Transform::identity();
                self.gs.start_active = true;
                self.gs.end_active = true;
                self.named_coords
                    .insert("world".into(), Transform::identity());
                self.named_coords_end
                    .insert("world".into(), Transform::identity());
            }
            "WorldEnd" => {
                return Err(loc.err("WorldEnd is a pbrt-v3 directive; pbrt-v4 files end after the world block (convert with `pbrt --upgrade`)"));
            }
            "ObjectBegin" => {
                self.require_world(loc, d, true)?;
                let name = args.string(d)?;
                if self.current_object.is_some() {
                    return Err(loc.err("ObjectBegin inside another ObjectBegin"));
                }
                if self.objects.contains_key(&name) {
                    return Err(loc.err(format!("ObjectBegin: object \"{name}\" redefined")));
                }
                self.stack
                    .push((self.gs.clone(), Block::Attribute, loc.clone()));
                self.current_object = Some((name, Vec::new(), loc.clone()));
            }
            "ObjectEnd" => {
                let Some((name, shapes, _)) = self.current_object.take() else {
                    return Err(loc.err("ObjectEnd without ObjectBegin"));
                };
                self.objects.insert(name, shapes);
                if let Some((saved, _, _)) = self.stack.pop() {
                    self.gs = saved;
                }
            }
            "ObjectInstance" => {
                self.require_world(loc, d, true)?;
                let name = args.string(d)?;
                if self.current_object.is_some() {
                    return Err(loc.err("ObjectInstance inside an object definition"));
                }
                let shapes = self
                    .objects
                    .get(&name)
                    .ok_or_else(|| loc.err(format!("ObjectInstance: no object named \"{name}\"")))?
                    .clone();
                let total: usize = self.shapes.len() + shapes.len();
                camsim_core::mem::check_alloc(total as u64 * 256, "object instances")
                    .map_err(|e| loc.err(e.to_string()))?;
                // One instance: all of the object's shapes share its number.
                let instance = self.instances;
                self.instances += 1;
                for mut s in shapes {
                    s.shape.tags.instance = Some(instance);
                    s.motion = self.instance_motion(s.motion.as_ref(), loc)?;
                    xform::transform_shape(&mut s.shape, &self.gs.ctm)
                        .map_err(|e| loc.err(format!("ObjectInstance \"{name}\": {e}")))?;
                    if s.shape.name.is_none() {
                        s.shape.name = Some(self.gs.name.clone().unwrap_or_else(|| name.clone()));
                    }
                    self.shapes.push(s);
                }
            }
            "Attribute" => {
                let cat = args.string(d)?;
                let params = args.params()?;
                let Some(cat) = ["shape", "light", "material", "medium", "texture"]
                    .into_iter()
                    .find(|c| *c == cat)
                else {
                    return Err(loc.err(format!(
                        "Attribute: unknown category \"{cat}\" (shape, light, material, medium, texture)"
                    )));
                };
                // A later Attribute for the same name replaces the earlier one.
                for p in params.params {
                    self.gs
                        .attributes
                        .retain(|(c, q)| !(*c == cat && q.name == p.name));
                    self.gs.attributes.push((cat, p));
                }
            }
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}
