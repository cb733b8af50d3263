//! Image lookups: an RGB image texture ([`ImageTex`], pbrt-v4 `imagemap` with `uv` mapping)
//! and the bilinear texel weights with pbrt-v4's wrap modes, shared by image textures, normal
//! maps and emission images.

use crate::scene::{TexelFilter, WrapMode};

/// An RGB image texture (pbrt-v4 `imagemap` with `uv` mapping, `wrap` outside the image,
/// bilinear or point `filter`).
#[derive(Debug, Clone)]
pub(crate) struct ImageTex {
    pub width: usize,
    pub height: usize,
    /// Row-major texels, shared with the scene description's texture.
    pub rgb: std::sync::Arc<[[f32; 3]]>,
    pub uscale: f32,
    pub vscale: f32,
    pub udelta: f32,
    pub vdelta: f32,
    pub wrap: WrapMode,
    pub filter: TexelFilter,
    /// The MIP pyramid of a [`TexelFilter::Trilinear`] image (shared by every material that
    /// names it); `None` for the full-resolution filters.
    pub mip: Option<std::sync::Arc<crate::mipmap::Pyramid<3>>>,
}

impl ImageTex {
    /// Lookup at `uv` with filter width `width` in texture coordinates (pbrt-v4 `MIPMap::Filter`:
    /// a [`TexelFilter::Trilinear`] image reads its pyramid, the others their full resolution).
    #[inline]
    pub fn lookup_filtered(&self, uv: [f32; 2], width: f32) -> [f32; 3] {
        match &self.mip {
            Some(p) => {
                let s = uv[0] * self.uscale + self.udelta;
                let t = uv[1] * self.vscale + self.vdelta;
                p.trilinear(s, t, width, self.wrap)
            }
            None => self.lookup(uv),
        }
    }

    /// Lookup at texture coordinates `uv` (pbrt-v4: `st = (su u + du, sv v + dv)`,
    /// t flipped so image row 0 is at t = 1, texel centres at half-integers, [`texels`]).
    #[inline]
    pub fn lookup(&self, uv: [f32; 2]) -> [f32; 3] {
        let s = uv[0] * self.uscale + self.udelta;
        let t = uv[1] * self.vscale + self.vdelta;
        let (idx, w) = texels(self.width, self.height, s, t, self.wrap, self.filter);
        let mut out = [0f32; 3];
        for k in 0..3 {
            out[k] = w[0] * self.rgb[idx[0]][k]
                + w[1] * self.rgb[idx[1]][k]
                + w[2] * self.rgb[idx[2]][k]
                + w[3] * self.rgb[idx[3]][k];
        }
        out
    }
}

/// The texel that integer texel coordinates `(x, y)` outside (or inside) a `width` x `height`
/// image read, or `None` where `wrap` is [`WrapMode::Black`] and the texel lies outside (pbrt-v4
/// `RemapPixelCoords`).
#[inline]
pub(crate) fn wrap_texel(
    x: i64,
    y: i64,
    width: usize,
    height: usize,
    wrap: WrapMode,
) -> Option<usize> {
    let (w, h) = (width as i64, height as i64);
    let (x, y) = match wrap {
        WrapMode::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
        WrapMode::Clamp => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
        WrapMode::Black => {
            if !(0..w).contains(&x) || !(0..h).contains(&y) {
                return None;
            }
            (x, y)
        }
        WrapMode::OctahedralSphere => {
            // Mirror across the crossed edge's midpoint: u = 0 or 1 flips v about 0.5, v = 0
            // or 1 flips u about 0.5 (the equal-area square's edges fold onto each other).
            let (mut x, mut y) = (x, y);
            if x < 0 {
                x = -x;
                y = h - 1 - y;
            } else if x >= w {
                x = 2 * w - 1 - x;
                y = h - 1 - y;
            }
            if y < 0 {
                x = w - 1 - x;
                y = -y;
            } else if y >= h {
                x = w - 1 - x;
                y = 2 * h - 1 - y;
            }
            // Farther than one image away (or a 1-texel side): stay inside.
            (x.clamp(0, w - 1), y.clamp(0, h - 1))
        }
    };
    Some(y as usize * width + x as usize)
}

/// Texel indices and weights of a bilinear lookup at `(s, t)` in a `width` x `height` image
/// (pbrt-v4 `Image::Bilerp`: row 0 at t = 1, texel centres at half-integers), the texels outside
/// the image remapped by `wrap`; a texel that black wrap leaves outside gets weight 0 (reads 0).
#[inline]
pub(crate) fn bilinear_texels(
    width: usize,
    height: usize,
    s: f32,
    t: f32,
    wrap: WrapMode,
) -> ([usize; 4], [f32; 4]) {
    let t = 1.0 - t;
    let x = s * width as f32 - 0.5;
    let y = t * height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xi, yi) = if x0.is_finite() && y0.is_finite() {
        (x0 as i64, y0 as i64)
    } else {
        (0, 0)
    };
    let mut idx = [0usize; 4];
    let mut w = [
        (1.0 - fx) * (1.0 - fy),
        fx * (1.0 - fy),
        (1.0 - fx) * fy,
        fx * fy,
    ];
    for (k, (dx, dy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        match wrap_texel(xi + dx, yi + dy, width, height, wrap) {
            Some(i) => idx[k] = i,
            None => w[k] = 0.0,
        }
    }
    if !(fx.is_finite() && fy.is_finite()) {
        w = [1.0, 0.0, 0.0, 0.0];
    }
    (idx, w)
}

/// Texel indices and weights of a lookup at `(s, t)` read by `filter`: [`bilinear_texels`], or
/// for [`TexelFilter::Point`] the nearest of its four texels alone (pbrt-v4 `MIPMap::Filter`
/// with `point`: texel `round(s w - 1/2)`, `round((1 - t) h - 1/2)` at full resolution), weight 1
/// (0 where black wrap leaves it outside).
#[inline]
pub(crate) fn texels(
    width: usize,
    height: usize,
    s: f32,
    t: f32,
    wrap: WrapMode,
    filter: TexelFilter,
) -> ([usize; 4], [f32; 4]) {
    let (idx, w) = bilinear_texels(width, height, s, t, wrap);
    match filter {
        // A trilinear image's level 0 (its pyramid, `crate::mipmap`, reads the other levels).
        TexelFilter::Bilinear | TexelFilter::Trilinear => (idx, w),
        TexelFilter::Point => {
            // The same fractions as `bilinear_texels`: corner (dx, dy) is nearest where the
            // fraction along that axis is at least 1/2; its bilinear weight is then > 0 unless
            // black wrap zeroed it (a NaN fraction picks corner 0, as the bilinear fallback).
            let fx = s * width as f32 - 0.5;
            let fy = (1.0 - t) * height as f32 - 0.5;
            let k = usize::from(fx - fx.floor() >= 0.5) + 2 * usize::from(fy - fy.floor() >= 0.5);
            let mut one = [0.0; 4];
            one[k] = if w[k] > 0.0 { 1.0 } else { 0.0 };
            (idx, one)
        }
    }
}
