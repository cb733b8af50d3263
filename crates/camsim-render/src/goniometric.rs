//! pbrt-v4 `GoniometricLight` (4th ed. §12.2.3): a point source whose radiant intensity toward
//! light-frame direction `w` is `I(lambda) * image(EqualAreaSphereToSquare(w))`, the image one
//! channel looked up at the nearest texel (pbrt-v4 `LookupNearestChannel`). A delta light:
//! reached by light sampling only, as `point`.

use crate::envmap::equal_area_sphere_to_square;
use crate::math::V3;
use crate::scene::GoniometricLight;

/// A compiled goniometric light: the world-to-light rotation and the image.
#[derive(Debug, Clone)]
pub(crate) struct GonioLight {
    /// Rows of the world-to-light linear map.
    to_light: [V3; 3],
    size: usize,
    values: Vec<f32>,
    /// Mean image value (the light's power is `4 pi mean I`, pbrt-v4 `GoniometricLight::Phi`).
    pub mean_value: f64,
}

impl GonioLight {
    pub(crate) fn new(l: &GoniometricLight) -> Result<GonioLight, String> {
        let n = l.size;
        if n == 0 || l.values.len() != n * n {
            return Err(format!(
                "goniometric light image of {n} x {n} texels has {} values",
                l.values.len()
            ));
        }
        if l.values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err("goniometric light image has a negative or non-finite texel".into());
        }
        if !l.position_m.iter().all(|v| v.is_finite()) {
            return Err(format!(
                "goniometric light position {:?} m is not finite",
                l.position_m
            ));
        }
        let inv = crate::xform::inverse(&l.light_to_world)
            .ok_or("goniometric light transform is singular")?;
        let to_light =
            std::array::from_fn(|i| V3::from_f64([inv.m[i][0], inv.m[i][1], inv.m[i][2]]));
        if to_light.iter().any(|r: &V3| !r.is_finite()) {
            return Err("goniometric light transform is not finite".into());
        }
        let mean_value = l.values.iter().map(|v| *v as f64).sum::<f64>() / l.values.len() as f64;
        Ok(GonioLight {
            to_light,
            size: n,
            values: l.values.clone(),
            mean_value,
        })
    }

    /// Image value toward world direction `w` (leaving the light; need not be unit): nearest
    /// texel of the equal-area square of the normalised light-frame direction.
    #[inline]
    pub(crate) fn value(&self, w: V3) -> f32 {
        let d = V3::new(
            self.to_light[0].dot(w),
            self.to_light[1].dot(w),
            self.to_light[2].dot(w),
        );
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return 0.0;
        }
        let d = d / len;
        let (u, v) = equal_area_sphere_to_square([d.x as f64, d.y as f64, d.z as f64]);
        let n = self.size;
        let x = ((u * n as f64) as usize).min(n - 1);
        let y = ((v * n as f64) as usize).min(n - 1);
        self.values[y * n + x]
    }
}
