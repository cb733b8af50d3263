//! Rendering options before `WorldBegin`: `Camera`, `Film`, `Sampler`, `Integrator`, and the
//! directives camsim reads but ignores (`PixelFilter`, `Accelerator`, `ColorSpace`, `Option`).
//! Called by the directive dispatch in `parser.rs` (`Parser::directive`).

use super::*;

impl Parser {
    pub(super) fn option_directive(
        &mut self,
        d: &str,
        tokens: &[Token],
        pos: &mut usize,
        file: &Path,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        let f = file;
        match d {
            "Camera" | "Film" | "Sampler" | "Integrator" => {
                self.require_world(loc, d, false)?;
                let ty = string_arg(tokens, pos, f, d)?;
                let params = parse_params(tokens, pos, f)?;
                match d {
                    "Camera" => {
                        self.camera(&ty, &params, loc)?;
                        // pbrt-v4 CameraMedium: the outside medium current at `Camera`.
                        self.media.camera = self.gs.medium.clone();
                    }
                    "Film" => self.film(&ty, &params, loc)?,
                    "Sampler" => self.sampler(&ty, &params, loc)?,
                    _ => self.integrator(&ty, &params, loc)?,
                }
            }
            "PixelFilter" => {
                self.require_world(loc, d, false)?;
                let ty = string_arg(tokens, pos, f, d)?;
                let params = parse_params(tokens, pos, f)?;
                params.params.iter().for_each(|p| p.used.set(true));
                self.note(
                    loc,
                    format!(
                        "PixelFilter \"{ty}\" ignored (camsim uses a box filter over each pixel)"
                    ),
                );
            }
            "Accelerator" => {
                self.require_world(loc, d, false)?;
                let _ = string_arg(tokens, pos, f, d)?;
                let params = parse_params(tokens, pos, f)?;
                params.params.iter().for_each(|p| p.used.set(true));
                self.note(loc, "Accelerator ignored (camsim builds its own BVH)");
            }
            "ColorSpace" => {
                let n = string_arg(tokens, pos, f, d)?;
                if n != "srgb" {
                    self.note(loc, format!("warning: ColorSpace \"{n}\" ignored: camsim reads RGB values as linear sRGB"));
                }
            }
            "Option" => {
                let params = parse_params(tokens, pos, f)?;
                params.params.iter().for_each(|p| p.used.set(true));
                self.note(loc, "Option ignored");
            }
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}
