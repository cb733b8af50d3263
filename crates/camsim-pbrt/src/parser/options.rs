//! Rendering options before `WorldBegin`: `Camera`, `Film`, `Sampler`, `Integrator`,
//! `PixelFilter`, and the directives camsim reads but ignores (`Accelerator`, `ColorSpace`,
//! `Option`).
//! Called by the directive dispatch in `parser.rs` (`ParserTarget::directive` of `SceneBuilder`).

use super::*;

impl SceneBuilder {
    pub(super) fn option_directive(
        &mut self,
        d: &str,
        args: &mut Args,
        loc: &Loc,
    ) -> Result<(), PbrtError> {
        match d {
            "Camera" | "Film" | "Sampler" | "Integrator" => {
                self.require_world(loc, d, false)?;
                let ty = args.string(d)?;
                let params = args.params()?;
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
                let ty = args.string(d)?;
                let params = args.params()?;
                self.pixel_filter(&ty, &params, loc)?;
            }
            "Accelerator" => {
                self.require_world(loc, d, false)?;
                let _ = args.string(d)?;
                let params = args.params()?;
                params.params.iter().for_each(|p| p.used.set(true));
                self.note(loc, "Accelerator ignored (camsim builds its own BVH)");
            }
            "ColorSpace" => {
                let n = args.string(d)?;
                if n != "srgb" {
                    self.note(loc, format!("warning: ColorSpace \"{n}\" ignored: camsim reads RGB values as linear sRGB"));
                }
            }
            "Option" => {
                let params = args.params()?;
                params.params.iter().for_each(|p| p.used.set(true));
                self.note(loc, "Option ignored");
            }
            other => return Err(loc.err(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }
}

impl SceneBuilder {
    /// pbrt-v4 `PixelFilter` (`Filter::Create`): `box` (`xradius`, `yradius` 0.5), `gaussian`
    /// (1.5, `sigma` 0.5), `mitchell` (2, `B`, `C` 1/3), `sinc` (4, `tau` 3; also read as
    /// `lanczos`), `triangle` (2). pbrt-v4's default without the directive is `gaussian`.
    fn pixel_filter(&mut self, ty: &str, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        use crate::scene::PixelFilter;
        let radius = |d: f64| -> Result<[f64; 2], PbrtError> {
            Ok([params.float("xradius", d)?, params.float("yradius", d)?])
        };
        let filter = match ty {
            "box" => PixelFilter::Box {
                radius: radius(0.5)?,
            },
            "gaussian" => PixelFilter::Gaussian {
                radius: radius(1.5)?,
                sigma: params.float("sigma", 0.5)?,
            },
            "mitchell" => PixelFilter::Mitchell {
                radius: radius(2.0)?,
                b: params.float("B", 1.0 / 3.0)?,
                c: params.float("C", 1.0 / 3.0)?,
            },
            "sinc" | "lanczos" => PixelFilter::Lanczos {
                radius: radius(4.0)?,
                tau: params.float("tau", 3.0)?,
            },
            "triangle" => PixelFilter::Triangle {
                radius: radius(2.0)?,
            },
            _ => {
                return Err(loc.err(format!(
                    "PixelFilter \"{ty}\" is not one of box, gaussian, mitchell, sinc (lanczos), triangle"
                )))
            }
        };
        params.check_unused(&format!("PixelFilter \"{ty}\""))?;
        filter
            .validate()
            .map_err(|e| loc.err(format!("PixelFilter \"{ty}\": {e}")))?;
        self.settings.filter = filter;
        Ok(())
    }
}
