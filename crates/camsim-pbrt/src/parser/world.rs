//! World-block directives that build the scene: materials, textures, area and other lights, shapes,
//! and media (`parser/media.rs`).
//! Called by the directive dispatch in `parser.rs` (`ParserTarget::directive` of `SceneBuilder`).

use super::*;

impl SceneBuilder {
    pub(super) fn world_directive(
        &mut self,
        d: &str,
        args: &mut Args,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        let file = args.file();
        match d {
            "Material" => {
                self.require_world(loc, d, true)?;
                let ty = args.string(d)?;
                let params = self.with_attributes("material", args.params()?);
                let m = self.material(&ty, &params, loc, file)?;
                self.materials.push(m);
                self.gs.material = MatRef::Index(self.materials.len() - 1);
            }
            "MakeNamedMaterial" => {
                self.require_world(loc, d, true)?;
                let name = args.string(d)?;
                let params = self.with_attributes("material", args.params()?);
                let ty = params.string("type")?.ok_or_else(|| {
                    loc.err(format!(
                        "MakeNamedMaterial \"{name}\": no \"string type\" parameter"
                    ))
                })?;
                if self.named_materials.contains_key(&name) {
                    return Err(loc.err(format!(
                        "MakeNamedMaterial: named material \"{name}\" redefined"
                    )));
                }
                let m = self.material(&ty, &params, loc, file)?;
                self.materials.push(m);
                self.named_materials.insert(name, self.materials.len() - 1);
            }
            "NamedMaterial" => {
                self.require_world(loc, d, true)?;
                let name = args.string(d)?;
                self.gs.material = MatRef::Named(name, loc.clone());
            }
            "Texture" => {
                self.require_world(loc, d, true)?;
                let name = args.string(d)?;
                let ty = args.string(d)?;
                let class = args.string(d)?;
                let params = self.with_attributes("texture", args.params()?);
                self.texture(&name, &ty, &class, &params, loc, file)?;
            }
            "AreaLightSource" => {
                self.require_world(loc, d, true)?;
                let ty = args.string(d)?;
                let params = self.with_attributes("light", args.params()?);
                if ty != "diffuse" {
                    return Err(loc.err(format!(
                        "AreaLightSource \"{ty}\" is not supported (only \"diffuse\")"
                    )));
                }
                let spectrum = self.spectrum_param(&params, "L", SpectrumUse::Illuminant, file)?;
                // pbrt-v4 DiffuseAreaLight::Create: `filename` (exclusive with `L`) gives an
                // RGB image over the shape's uv, its values illuminant spectra of the colour
                // space; scale /= SpectrumToPhotometric(colour space illuminant).
                let image = match params.string("filename")? {
                    None => None,
                    Some(fname) => {
                        if spectrum.is_some() {
                            return Err(loc.err("AreaLightSource \"diffuse\": give either \"L\" or \"filename\", not both (as pbrt-v4)"));
                        }
                        let (width, height, rgb) = self.light_image(
                            &fname,
                            &params,
                            loc,
                            file,
                            "AreaLightSource \"diffuse\"",
                        )?;
                        let mean_y = rgb.iter().map(|c| super::luminance_709(*c)).sum::<f64>()
                            / rgb.len() as f64;
                        Some((
                            std::sync::Arc::new(EmissionImage {
                                width,
                                height,
                                rgb: rgb.into(),
                                uv1: false,
                            }),
                            mean_y,
                        ))
                    }
                };
                let spectrum = match spectrum {
                    Some(s) => s,
                    None => default_illuminant(),
                };
                let scale = params.float("scale", 1.0)?;
                let two_sided = params.bool("twosided", false)?;
                let power = params.float_opt("power")?.filter(|p| *p > 0.0);
                // camsim's extension: the light group this emitter's radiance is written to.
                let group = params.string("lightgroup")?;
                params.check_unused("AreaLightSource \"diffuse\"")?;
                self.gs.area_light = Some(AreaLightSpec {
                    spectrum,
                    scale,
                    two_sided,
                    power,
                    image,
                    group,
                });
            }
            "LightSource" => {
                self.require_world(loc, d, true)?;
                let ty = args.string(d)?;
                let params = self.with_attributes("light", args.params()?);
                // camsim's extension: `"string lightgroup" "sky"` names the light's group.
                let group = params.string("lightgroup")?;
                let first = self.lights.len();
                self.light_source(&ty, &params, loc, file)?;
                self.light_groups.resize(self.lights.len(), group);
                self.light_motion(first, loc)?;
            }
            "Shape" => {
                self.require_world(loc, d, true)?;
                let ty = args.string(d)?;
                let params = self.with_attributes("shape", args.params()?);
                self.shape(&ty, &params, loc, file)?;
            }
            "MakeNamedMedium" => {
                let name = args.string(d)?;
                let params = self.with_attributes("medium", args.params()?);
                self.make_named_medium(name, &params, loc, file)?;
            }
            "MediumInterface" => {
                // pbrt-v4: `MediumInterface "inside" ["outside"]` (one name sets both).
                let inside = args.string(d)?;
                let outside = args.optional_string().unwrap_or_else(|| inside.clone());
                self.medium_interface(inside, outside, loc);
            }
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}
