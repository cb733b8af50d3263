//! `LightSource`: pbrt-v4 `point`, `spot`, `goniometric`, `projection`, `distant` and `infinite`
//! (uniform `L`, or an image `filename`), with pbrt-v4's parameter names, defaults and normalisations (pbrt-v4
//! `lights.cpp`, `*Light::Create`), and camsim's absolute units (see [`crate`]).

use super::{default_illuminant, luminance_709, SceneBuilder};
use crate::params::ParamList;
use crate::scene::{
    EnvMapping, EnvironmentMap, GoniometricLight, Light, ProjectionLight, Transform,
};
use crate::spectra::SpectrumUse;
use crate::{Loc, PbrtError};
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use std::f64::consts::PI;
use std::path::Path;

pub(super) fn point3(
    params: &ParamList,
    name: &str,
    default: [f64; 3],
) -> Result<[f64; 3], PbrtError> {
    match params.get(name, &["point3"])? {
        None => Ok(default),
        Some(p) => match p.nums()?.as_slice() {
            [x, y, z] => Ok([*x, *y, *z]),
            v => Err(p.loc.err(format!(
                "\"point3 {name}\" needs one point (3 numbers), got {} numbers",
                v.len()
            ))),
        },
    }
}

impl SceneBuilder {
    pub(super) fn light_source(
        &mut self,
        ty: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<(), PbrtError> {
        let ctm = self.gs.ctm;
        match ty {
            "point" | "spot" => {
                // pbrt-v4 PointLight/SpotLight::Create: scale /= SpectrumToPhotometric(I);
                // power Phi_v: scale *= Phi_v / k_e with k_e = 4 pi (point) or
                // 2 pi ((1 - cos_start) + (cos_start - cos_end) / 2) (spot).
                let s = self
                    .spectrum_param(params, "I", SpectrumUse::Illuminant, file)?
                    .unwrap_or_else(default_illuminant);
                let mut scale = params.float("scale", 1.0)? / s.photometric;
                let power = params.float_opt("power")?;
                let from = point3(params, "from", [0.0; 3])?;
                let position_m = ctm.apply_point(from);
                let light = if ty == "point" {
                    if let Some(p) = power.filter(|p| *p > 0.0) {
                        scale *= p / (4.0 * PI);
                    }
                    params.check_unused("LightSource \"point\"")?;
                    Light::Point {
                        position_m,
                        intensity: s.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
                    }
                } else {
                    let to = point3(params, "to", [0.0, 0.0, 1.0])?;
                    let cone_angle_deg = params.float("coneangle", 30.0)?;
                    let cone_delta_deg = params.float("conedelta", 5.0)?;
                    if !(cone_angle_deg > 0.0
                        && cone_angle_deg <= 180.0
                        && cone_delta_deg >= 0.0
                        && cone_delta_deg <= cone_angle_deg)
                    {
                        return Err(loc.err(format!(
                            "LightSource \"spot\": coneangle {cone_angle_deg} must be in (0, 180] and conedelta {cone_delta_deg} in [0, coneangle]"
                        )));
                    }
                    let axis = [to[0] - from[0], to[1] - from[1], to[2] - from[2]];
                    if axis == [0.0; 3] {
                        return Err(
                            loc.err("LightSource \"spot\": \"from\" and \"to\" are the same point")
                        );
                    }
                    if let Some(p) = power.filter(|p| *p > 0.0) {
                        let cos_end = cone_angle_deg.to_radians().cos();
                        let cos_start = (cone_angle_deg - cone_delta_deg).to_radians().cos();
                        scale *= p / (2.0 * PI * ((1.0 - cos_start) + (cos_start - cos_end) / 2.0));
                    }
                    params.check_unused("LightSource \"spot\"")?;
                    Light::Spot {
                        position_m,
                        direction: crate::xform::normalize(ctm.apply_vector(axis)),
                        intensity: s.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
                        cone_angle_deg,
                        cone_delta_deg,
                        falloff: Default::default(),
                    }
                };
                self.lights.push(light);
            }
            "distant" => {
                // pbrt-v4 DistantLight::Create: scale /= SpectrumToPhotometric(L);
                // illuminance E_v: scale *= E_v (a distant light's L is the irradiance).
                let s = self
                    .spectrum_param(params, "L", SpectrumUse::Illuminant, file)?
                    .unwrap_or_else(default_illuminant);
                let mut scale = params.float("scale", 1.0)? / s.photometric;
                let from = point3(params, "from", [0.0; 3])?;
                let to = point3(params, "to", [0.0, 0.0, 1.0])?;
                if let Some(e) = params.float_opt("illuminance")?.filter(|e| *e > 0.0) {
                    scale *= e;
                }
                params.check_unused("LightSource \"distant\"")?;
                let d = ctm.apply_vector([to[0] - from[0], to[1] - from[1], to[2] - from[2]]);
                if crate::xform::dot(d, d) == 0.0 {
                    return Err(
                        loc.err("LightSource \"distant\": \"from\" and \"to\" are the same point")
                    );
                }
                self.lights.push(Light::Distant {
                    direction: crate::xform::normalize(d),
                    irradiance: s.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
                });
            }
            "infinite" => {
                if params.get("portal", &["point3"])?.is_some() {
                    return Err(loc.err("LightSource \"infinite\": portals are not supported"));
                }
                let filename = params.string("filename")?;
                let l = self.spectrum_param(params, "L", SpectrumUse::Illuminant, file)?;
                let mut scale = params.float("scale", 1.0)?;
                let illuminance = params.float_opt("illuminance")?.filter(|e| *e > 0.0);
                let Some(fname) = filename else {
                    // pbrt-v4: scale /= SpectrumToPhotometric(L); illuminance E_v: scale *= E_v / pi.
                    let s = l.unwrap_or_else(default_illuminant);
                    scale /= s.photometric;
                    if let Some(e) = illuminance {
                        scale *= e / PI;
                    }
                    params.check_unused("LightSource \"infinite\"")?;
                    self.lights.push(Light::Infinite {
                        radiance: s.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
                    });
                    return Ok(());
                };
                if l.is_some() {
                    return Err(loc.err("LightSource \"infinite\": give either \"L\" or \"filename\", not both (as pbrt-v4)"));
                }
                let (width, height, rgb) = self.light_image(&fname, params, loc, file, "LightSource \"infinite\"")?;
                params.check_unused("LightSource \"infinite\"")?;
                let mapping = if width == height {
                    EnvMapping::EqualAreaOctahedral
                } else if width == 2 * height {
                    EnvMapping::LatLong
                } else {
                    return Err(loc.err(format!(
                        "LightSource \"infinite\": {fname} is {width} x {height}: an environment map must be square (pbrt-v4 equal-area octahedral) or twice as wide as high (lat-long)"
                    )));
                };
                // pbrt-v4 ImageInfiniteLight::Create: scale /= SpectrumToPhotometric(illuminant);
                // illuminance E_v: scale *= E_v / k_e, k_e the map's illuminance on an upward
                // (+z in light space) surface: sum of luminance Y(rgb) cos(theta) d_omega.
                let illum = default_illuminant();
                scale /= illum.photometric;
                if let Some(e) = illuminance {
                    let k_e = map_upper_illuminance(width, height, &rgb, mapping);
                    if !(k_e > 0.0) {
                        return Err(loc.err("LightSource \"infinite\": \"illuminance\" given but the map is black over the upper hemisphere"));
                    }
                    scale *= e / k_e;
                }
                let rot = Transform {
                    m: [
                        [ctm.m[0][0], ctm.m[0][1], ctm.m[0][2], 0.0],
                        [ctm.m[1][0], ctm.m[1][1], ctm.m[1][2], 0.0],
                        [ctm.m[2][0], ctm.m[2][1], ctm.m[2][2], 0.0],
                        [0.0, 0.0, 0.0, 1.0],
                    ],
                };
                self.lights.push(Light::Environment(EnvironmentMap {
                    width,
                    height,
                    rgb,
                    mapping,
                    illuminant: illum.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
                    basis: None,
                    light_to_world: rot,
                }));
            }
            "goniometric" => {
                let light = self.goniometric(params, loc, file)?;
                self.lights.push(light);
            }
            "projection" => {
                let light = self.projection(params, loc, file)?;
                self.lights.push(light);
            }
            other => {
                return Err(loc.err(format!(
                    "unknown LightSource \"{other}\" (point, spot, goniometric, projection, distant, infinite)"
                )))
            }
        }
        Ok(())
    }
}

impl SceneBuilder {
    /// pbrt-v4 `GoniometricLight::Create` (lights.cpp): `I` (default the colour space's
    /// illuminant), `scale`, `filename` (a square equal-area octahedral image; RGB averaged to one
    /// channel as pbrt-v4 does), `power` (`scale *= Phi / (4 pi mean(image))`, after `scale /=
    /// SpectrumToPhotometric(I)`), and the light frame `CTM * swapYZ`. camsim extension: `from`
    /// (default the origin) moves the light as for `point`; pbrt-v4 places it with the CTM only.
    fn goniometric(
        &mut self,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<Light, PbrtError> {
        const WHAT: &str = "LightSource \"goniometric\"";
        let s = self
            .spectrum_param(params, "I", SpectrumUse::Illuminant, file)?
            .unwrap_or_else(default_illuminant);
        let mut scale = params.float("scale", 1.0)? / s.photometric;
        let power = params.float_opt("power")?;
        let from = point3(params, "from", [0.0; 3])?;
        // pbrt-v4 only warns without a file (and the light is then black); refuse instead.
        let fname = params.string("filename")?.ok_or_else(|| {
            loc.err(format!(
                "{WHAT}: \"filename\" (the intensity image) is required"
            ))
        })?;
        let (width, height, rgb) = self.light_image(&fname, params, loc, file, WHAT)?;
        params.check_unused(WHAT)?;
        if width != height || width == 0 {
            return Err(loc.err(format!(
                "{WHAT}: {fname} is {width} x {height}: the image must be square (pbrt-v4 equal-area octahedral)"
            )));
        }
        let values: Vec<f32> = rgb.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
        if let Some(p) = power.filter(|p| *p > 0.0) {
            // Every texel covers 4 pi / n^2 sr (equal-area mapping): Phi = 4 pi mean(image) I.
            let mean = values.iter().map(|v| *v as f64).sum::<f64>() / values.len() as f64;
            if !(mean > 0.0) {
                return Err(loc.err(format!("{WHAT}: \"power\" given but {fname} is black")));
            }
            scale *= p / (4.0 * PI * mean);
        }
        let ctm = self.gs.ctm;
        // pbrt-v4 swapYZ: light-frame (x, y, z) -> CTM frame (x, z, y).
        let swap_yz = Transform {
            m: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ],
        };
        let mut light_to_world = ctm.then_apply_to(&swap_yz);
        for row in light_to_world.m.iter_mut().take(3) {
            row[3] = 0.0;
        }
        Ok(Light::Goniometric(GoniometricLight {
            position_m: ctm.apply_point(from),
            light_to_world,
            size: width,
            values,
            intensity: s.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
        }))
    }
}

impl SceneBuilder {
    /// pbrt-v4 `ProjectionLight::Create` and constructor (lights.cpp): `scale`, `fov` (default
    /// 90 deg), `filename` (required, RGB), `power`; `scale /= SpectrumToPhotometric(illuminant)`
    /// and with `power` Phi: `scale *= Phi / (A mean(Y(rgb) cos^3 theta))` over the texel centres,
    /// `A = 4 tan^2(fov / 2) max(a, 1 / a)` the screen window's area at z = 1 and `cos^3 theta`
    /// the solid angle per unit area there. Light frame: CTM times `Scale(1, -1, 1)`. camsim
    /// extension: `from` (default the origin) moves the light as for `point`.
    fn projection(
        &mut self,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<Light, PbrtError> {
        const WHAT: &str = "LightSource \"projection\"";
        let mut scale = params.float("scale", 1.0)?;
        let power = params.float_opt("power")?;
        let fov_deg = params.float("fov", 90.0)?;
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(loc.err(format!("{WHAT}: fov {fov_deg} deg must be in (0, 180)")));
        }
        let from = point3(params, "from", [0.0; 3])?;
        let fname = params.string("filename")?.ok_or_else(|| {
            loc.err(format!(
                "{WHAT}: \"filename\" (the projected image) is required"
            ))
        })?;
        let (width, height, rgb) = self.light_image(&fname, params, loc, file, WHAT)?;
        params.check_unused(WHAT)?;
        let illum = default_illuminant();
        scale /= illum.photometric;
        if let Some(p) = power.filter(|p| *p > 0.0) {
            let k_e =
                crate::scene::projection_frustum_sum(width, height, &rgb, fov_deg, luminance_709);
            if !(k_e > 0.0) {
                return Err(loc.err(format!("{WHAT}: \"power\" given but {fname} is black")));
            }
            scale *= p / k_e;
        }
        let ctm = self.gs.ctm;
        let flip_y = Transform::scale([1.0, -1.0, 1.0]);
        let mut light_to_world = ctm.then_apply_to(&flip_y);
        for row in light_to_world.m.iter_mut().take(3) {
            row[3] = 0.0;
        }
        Ok(Light::Projection(ProjectionLight {
            position_m: ctm.apply_point(from),
            light_to_world,
            fov_deg,
            width,
            height,
            rgb,
            illuminant: illum.spectrum.scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
        }))
    }
}

/// Illuminance of an environment map (unit scale) on a surface facing +z (light space):
/// `sum Y(rgb) max(cos theta, 0) d_omega`, `Y` the Rec. 709 luminance, by the midpoint rule on
/// at least 128 points across the image (small maps are sub-sampled: texel centres alone are
/// 1.6 % off for a 16 x 16 map).
pub(crate) fn map_upper_illuminance(
    width: usize,
    height: usize,
    rgb: &[[f32; 3]],
    mapping: EnvMapping,
) -> f64 {
    let k = 128usize.div_ceil(width.min(height)).max(1);
    let (wk, hk) = (width * k, height * k);
    let mut e = 0.0;
    for yy in 0..hk {
        for xx in 0..wk {
            let c = rgb[(yy / k) * width + xx / k];
            let lum = luminance_709(c);
            let (u, v) = ((xx as f64 + 0.5) / wk as f64, (yy as f64 + 0.5) / hk as f64);
            let (d, d_omega) = match mapping {
                EnvMapping::EqualAreaOctahedral => (
                    crate::envmap::equal_area_square_to_sphere(u, v),
                    4.0 * PI / (wk * hk) as f64,
                ),
                EnvMapping::LatLong => (
                    crate::envmap::latlong_to_sphere(u, v),
                    2.0 * PI * PI * (PI * v).sin() / (wk * hk) as f64,
                ),
            };
            if d[2] > 0.0 {
                e += lum * d[2] * d_omega;
            }
        }
    }
    e
}
