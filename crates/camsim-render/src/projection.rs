//! pbrt-v4 `ProjectionLight` (4th ed. §12.2.2): a point source projecting an RGB image through a
//! frustum along its light-frame +z; the intensity toward a direction is the nearest texel of
//! the screen point it meets, uplifted as an illuminant (pbrt-v4 `RGBIlluminantSpectrum`), zero
//! outside the screen window or behind the near plane (`w.z < 1e-3`, pbrt-v4's `hither`). A delta
//! light: reached by light sampling only, as `point`.

use crate::envmap::RgbIlluminants;
use crate::math::V3;
use crate::scene::ProjectionLight;
use crate::spectral::{Lambdas, SpectrumTable};

/// pbrt-v4 `ProjectionLight::hither`: directions with a smaller light-frame z emit nothing.
const HITHER: f32 = 1e-3;

/// A compiled projection light.
#[derive(Debug, Clone)]
pub(crate) struct ProjLight {
    /// Rows of the world-to-light linear map.
    to_light: [V3; 3],
    /// `1 / tan(fov / 2)`: light-frame slope to screen coordinate.
    inv_tan_half: f32,
    /// Screen window half extents (`[-sx, sx] x [-sy, sy]`).
    sx: f32,
    sy: f32,
    width: usize,
    height: usize,
    /// Per texel: the illuminant uplift of its RGB.
    texels: RgbIlluminants,
    /// pbrt-v4 `ProjectionLight::Phi` per unit illuminant: `A mean(mean(rgb) cos^3 theta)`
    /// (channel mean instead of the uplifted spectrum: used only to pick lights by power).
    pub power_factor: f64,
}

impl ProjLight {
    pub(crate) fn new(l: &ProjectionLight) -> Result<ProjLight, String> {
        let (w, h) = (l.width, l.height);
        if w == 0 || h == 0 || l.rgb.len() != w * h {
            return Err(format!(
                "projection light image of {w} x {h} texels has {} values",
                l.rgb.len()
            ));
        }
        if l.rgb
            .iter()
            .flatten()
            .any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err("projection light image has a negative or non-finite texel".into());
        }
        if !(l.fov_deg > 0.0 && l.fov_deg < 180.0) {
            return Err(format!(
                "projection light fov {} deg must be in (0, 180)",
                l.fov_deg
            ));
        }
        if !l.position_m.iter().all(|v| v.is_finite()) {
            return Err(format!(
                "projection light position {:?} m is not finite",
                l.position_m
            ));
        }
        let inv = crate::xform::inverse(&l.light_to_world)
            .ok_or("projection light transform is singular")?;
        let to_light: [V3; 3] =
            std::array::from_fn(|i| V3::from_f64([inv.m[i][0], inv.m[i][1], inv.m[i][2]]));
        if to_light.iter().any(|r| !r.is_finite()) {
            return Err("projection light transform is not finite".into());
        }
        let aspect = w as f64 / h as f64;
        let (sx, sy) = if aspect > 1.0 {
            (aspect, 1.0)
        } else {
            (1.0, 1.0 / aspect)
        };
        let tan_half = (l.fov_deg.to_radians() / 2.0).tan();
        Ok(ProjLight {
            to_light,
            inv_tan_half: (1.0 / tan_half) as f32,
            sx: sx as f32,
            sy: sy as f32,
            width: w,
            height: h,
            texels: RgbIlluminants::new(&l.rgb),
            power_factor: crate::scene::projection_frustum_sum(w, h, &l.rgb, l.fov_deg, |c| {
                (c[0] + c[1] + c[2]) as f64 / 3.0
            }),
        })
    }

    /// Texel lit toward world direction `w` (leaving the light; need not be unit), or `None`
    /// outside the frustum.
    #[inline]
    pub(crate) fn texel(&self, w: V3) -> Option<usize> {
        let d = V3::new(
            self.to_light[0].dot(w),
            self.to_light[1].dot(w),
            self.to_light[2].dot(w),
        );
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) || d.z / len < HITHER {
            return None;
        }
        // pbrt-v4 Perspective(fov): screen point = (x, y) / (z tan(fov / 2)).
        let (px, py) = (d.x / d.z * self.inv_tan_half, d.y / d.z * self.inv_tan_half);
        if !(px.abs() <= self.sx && py.abs() <= self.sy) {
            return None;
        }
        let (s, t) = (
            (px + self.sx) / (2.0 * self.sx),
            (py + self.sy) / (2.0 * self.sy),
        );
        let x = ((s * self.width as f32) as usize).min(self.width - 1);
        let y = ((t * self.height as f32) as usize).min(self.height - 1);
        Some(y * self.width + x)
    }

    /// Intensity of `texel` at the path's wavelengths, W/(sr nm): `2m S(lambda) illuminant`.
    #[inline]
    pub(crate) fn intensity<const N: usize>(
        &self,
        texel: usize,
        illuminant: &SpectrumTable,
        lambdas: &Lambdas<N>,
    ) -> [f32; N] {
        self.texels.eval(texel, illuminant, lambdas)
    }
}
