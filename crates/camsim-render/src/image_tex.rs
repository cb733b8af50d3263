//! Image lookups: an RGB image texture ([`ImageTex`], pbrt-v4 `imagemap` with `uv` mapping)
//! and the bilinear texel weights with pbrt-v4's wrap modes, shared by image textures, normal
//! maps and emission images.
//!
//! MIP maps ([`Pyramid`], for every pbrt-v4 image texture: `point`, `bilinear` and `trilinear`),
//! as pbrt-v4's `MIPMap` makes and reads them (pbrt-v4 4th ed. sec. 10.4.3; 5f7a606
//! `MIPMap::Filter`; the construction is `Image::GeneratePyramid`):
//!
//! - An image whose sides are not powers of two is first resampled up to the next powers of two,
//!   separably, with a Lanczos windowed sinc of radius 2 texels and `tau = 2` (4 taps per output
//!   texel, weights normalised to 1, texels outside the image read through the wrap mode, the
//!   result clamped at 0: pbrt-v4 `Image::FloatResizeUp`). That image is level 0.
//! - Each next level halves each side (down to 1) and is the mean of 2 x 2 texels of the one
//!   below, ending with a 1 x 1 level holding the image's mean.
//! - A lookup with filter width `w` (pbrt-v4: twice the largest of `|ds/dx|`, `|ds/dy|`,
//!   `|dt/dx|`, `|dt/dy|`, in texture coordinates) reads level `l = L - 1 + log2(w)` of the `L`:
//!   the top texel where `l >= L - 1`, whatever the filter; otherwise level `i = max(0,
//!   floor(l))`: `point` its nearest texel, `bilinear` its bilinear lookup, `trilinear` the
//!   bilinear lookups of levels `i` and `i + 1` blended by `l - i` (level 0 alone where `i = 0`).
//!   So a pbrt-v4 `bilinear` texture seen from afar reads a coarser level, not the full image:
//!   a pixel spanning `2^k` texels reads level `k`.
//! - `ewa` (pbrt-v4 4th ed. sec. 10.4.4, `MIPMap::EWA`) reads the footprint as an ellipse with
//!   axes `(ds/dx, dt/dx)` and `(ds/dy, dt/dy)`: the level from the shorter axis (lengthened to
//!   at least 1/`maxanisotropy` of the longer), there and on the next level the texels inside
//!   the ellipse weighted by a Gaussian of their radius, the two levels blended. Along a
//!   grazing footprint it keeps the detail across it that the isotropic filters, picking the
//!   level from the longer axis, average away.
//!
//! glTF's filters ([`TexelFilter::Bilinear`], [`TexelFilter::Point`]) read the full-resolution
//! image without a pyramid, as Blender's Cycles does.
//!
//! pbrt-v4 stores each level back in the file's pixel format (8-bit sRGB for most textures);
//! camsim keeps the levels in f32 (a difference below half an 8-bit step).

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
    /// The MIP pyramid of an image read by a pbrt-v4 filter ([`TexelFilter::uses_mip`]; shared
    /// by every material that names it); `None` for the full-resolution filters.
    pub mip: Option<std::sync::Arc<Pyramid<3>>>,
}

impl ImageTex {
    /// Lookup at `uv` over the footprint `dst` (`[ds/dx, ds/dy, dt/dx, dt/dy]` in texture
    /// coordinates; pbrt-v4 `MIPMap::Filter`: an image with a pyramid reads what its filter
    /// picks there, [`Pyramid::filter_footprint`], the others their full resolution).
    #[inline]
    pub fn lookup_filtered(&self, uv: [f32; 2], dst: [f32; 4]) -> [f32; 3] {
        match &self.mip {
            Some(p) => {
                let s = uv[0] * self.uscale + self.udelta;
                let t = uv[1] * self.vscale + self.vdelta;
                p.filter_footprint(self.filter, s, t, dst, self.wrap)
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

/// Texel indices and weights of a lookup at `(s, t)` of a `width` x `height` image (full
/// resolution, or one MIP level) read by `filter`: [`bilinear_texels`], or for a point filter
/// the nearest of its four texels alone (pbrt-v4 `MIPMap::Filter` with `point`: texel
/// `round(s w - 1/2)`, `round((1 - t) h - 1/2)`), weight 1 (0 where black wrap leaves it outside).
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
        // The pyramid's filters read like their full-resolution counterparts on the one image
        // given (an image with a pyramid is read through `Pyramid::filter`, level by level).
        TexelFilter::Bilinear
        | TexelFilter::MipBilinear
        | TexelFilter::Trilinear
        | TexelFilter::Ewa { .. } => (idx, w),
        TexelFilter::Point | TexelFilter::MipPoint => {
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

/// Steps of the EWA weight table (pbrt-v4 `MIPFilterLUTSize`).
const EWA_LUT: usize = 128;

/// The EWA filter's weights, `e^(-2 r2) - e^(-2)` at `r2 = i / 127` (pbrt-v4's Gaussian with
/// alpha 2, zero at the ellipse's edge), computed once.
fn ewa_weights() -> &'static [f32; EWA_LUT] {
    static WEIGHTS: std::sync::OnceLock<[f32; EWA_LUT]> = std::sync::OnceLock::new();
    WEIGHTS.get_or_init(|| {
        std::array::from_fn(|i| {
            let r2 = i as f64 / (EWA_LUT - 1) as f64;
            ((-2.0 * r2).exp() - (-2.0f64).exp()) as f32
        })
    })
}

/// One level: `width` x `height` texels, row-major, row 0 at the image's top (t = 1).
#[derive(Debug, Clone)]
struct Level<const C: usize> {
    width: usize,
    height: usize,
    texels: Vec<[f32; C]>,
}

/// A MIP pyramid of a `C`-channel image (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Pyramid<const C: usize> {
    levels: Vec<Level<C>>,
}

/// pbrt-v4 `WindowedSinc(x, radius, tau)`: `sinc(x) sinc(x / tau)` within the radius.
fn windowed_sinc(x: f64, radius: f64, tau: f64) -> f64 {
    let sinc = |x: f64| {
        let px = std::f64::consts::PI * x;
        if px.abs() < 1e-9 {
            1.0
        } else {
            px.sin() / px
        }
    };
    if x.abs() > radius {
        0.0
    } else {
        sinc(x) * sinc(x / tau)
    }
}

/// pbrt-v4 `Image::ResampleWeights`: for each of `new_res` output texels, the first of its 4
/// source texels and their normalised weights.
fn resample_weights(old_res: usize, new_res: usize) -> Vec<(i64, [f32; 4])> {
    let (radius, tau) = (2.0, 2.0);
    (0..new_res)
        .map(|i| {
            let centre = (i as f64 + 0.5) * old_res as f64 / new_res as f64;
            let first = (centre - radius + 0.5).floor();
            let mut w = [0.0f64; 4];
            for (j, wj) in w.iter_mut().enumerate() {
                *wj = windowed_sinc(first + j as f64 + 0.5 - centre, radius, tau);
            }
            let sum: f64 = w.iter().sum();
            (first as i64, w.map(|v| (v / sum) as f32))
        })
        .collect()
}

/// pbrt-v4 `Image::FloatResizeUp` to `new_w` x `new_h` (module docs).
fn resize_up<const C: usize>(
    width: usize,
    height: usize,
    texels: &[[f32; C]],
    new_w: usize,
    new_h: usize,
    wrap: WrapMode,
) -> Vec<[f32; C]> {
    let read = |x: i64, y: i64| -> [f32; C] {
        match wrap_texel(x, y, width, height, wrap) {
            Some(i) => texels[i],
            None => [0.0; C],
        }
    };
    let xw = resample_weights(width, new_w);
    let yw = resample_weights(height, new_h);
    // Along x for every source row reached (rows -2 .. height + 2 through the wrap).
    let (y_lo, y_hi) = (
        yw.first().map_or(0, |w| w.0.min(0)),
        yw.last().map_or(0, |w| (w.0 + 4).max(height as i64)),
    );
    let rows = (y_hi - y_lo) as usize;
    let mut xbuf = vec![[0f32; C]; rows * new_w];
    for (r, y) in (y_lo..y_hi).enumerate() {
        for (x, (first, w)) in xw.iter().enumerate() {
            let mut acc = [0f32; C];
            for (j, wj) in w.iter().enumerate() {
                let t = read(first + j as i64, y);
                for c in 0..C {
                    acc[c] += wj * t[c];
                }
            }
            xbuf[r * new_w + x] = acc;
        }
    }
    let mut out = vec![[0f32; C]; new_w * new_h];
    for (y, (first, w)) in yw.iter().enumerate() {
        for x in 0..new_w {
            let mut acc = [0f32; C];
            for (j, wj) in w.iter().enumerate() {
                let t = xbuf[(first + j as i64 - y_lo) as usize * new_w + x];
                for c in 0..C {
                    acc[c] += wj * t[c];
                }
            }
            out[y * new_w + x] = acc.map(|v| v.max(0.0));
        }
    }
    out
}

/// Bytes a [`Pyramid`] of a `width` x `height` image of `channels` f32 channels holds at its
/// peak: its levels (level 0 at the next powers of two, each next level a quarter of the one
/// below) and one more image of level 0's size, bounding the resampling's intermediate and the
/// copy of the texels it is made from.
pub(crate) fn pyramid_bytes(width: usize, height: usize, channels: usize) -> u64 {
    let texel = 4 * channels as u64;
    let (mut w, mut h) = (
        width.max(1).next_power_of_two() as u64,
        height.max(1).next_power_of_two() as u64,
    );
    let mut total = w.saturating_mul(h).saturating_mul(texel);
    loop {
        total = total.saturating_add(w.saturating_mul(h).saturating_mul(texel));
        if w == 1 && h == 1 {
            return total;
        }
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
}

impl<const C: usize> Pyramid<C> {
    /// The pyramid of a `width` x `height` image (`texels` row-major), `wrap` its wrap mode.
    pub(crate) fn new(width: usize, height: usize, texels: &[[f32; C]], wrap: WrapMode) -> Self {
        let (w0, h0) = (
            width.max(1).next_power_of_two(),
            height.max(1).next_power_of_two(),
        );
        let base = if (w0, h0) == (width, height) {
            texels.to_vec()
        } else {
            resize_up(width, height, texels, w0, h0, wrap)
        };
        let mut levels = vec![Level {
            width: w0,
            height: h0,
            texels: base,
        }];
        while let Some(l) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
            let (w, h) = ((l.width / 2).max(1), (l.height / 2).max(1));
            let mut next = vec![[0f32; C]; w * h];
            for y in 0..h {
                for x in 0..w {
                    // The 2 x 2 texels below (a side of 1 repeats its one texel).
                    let (x0, y0) = (2 * x, 2 * y);
                    let (x1, y1) = ((x0 + 1).min(l.width - 1), (y0 + 1).min(l.height - 1));
                    let t = |xx: usize, yy: usize| l.texels[yy * l.width + xx];
                    let (a, b, c, d) = (t(x0, y0), t(x1, y0), t(x0, y1), t(x1, y1));
                    next[y * w + x] = std::array::from_fn(|k| (a[k] + b[k] + c[k] + d[k]) / 4.0);
                }
            }
            levels.push(Level {
                width: w,
                height: h,
                texels: next,
            });
        }
        Pyramid { levels }
    }

    /// Number of levels (`1 + log2` of the longer power-of-two side).
    #[cfg(test)]
    pub(crate) fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Bilinear lookup of level `k` at `(s, t)` (pbrt-v4 `Image::Bilerp`, as the full-resolution
    /// image textures read).
    fn bilerp(&self, k: usize, s: f32, t: f32, wrap: WrapMode) -> [f32; C] {
        let l = &self.levels[k];
        let (idx, w) = bilinear_texels(l.width, l.height, s, t, wrap);
        std::array::from_fn(|c| (0..4).map(|i| w[i] * l.texels[idx[i]][c]).sum())
    }

    /// pbrt-v4 `MIPMap::Filter` by `filter` at `(s, t)` over the footprint `dst` (`[ds/dx,
    /// ds/dy, dt/dx, dt/dy]`, texture coordinates): [`Self::ewa`] for `ewa`, else
    /// [`Self::filter`] at twice the largest derivative.
    #[inline]
    pub(crate) fn filter_footprint(
        &self,
        filter: TexelFilter,
        s: f32,
        t: f32,
        dst: [f32; 4],
        wrap: WrapMode,
    ) -> [f32; C] {
        if let TexelFilter::Ewa { max_anisotropy } = filter {
            return self.ewa(s, t, dst, max_anisotropy, wrap);
        }
        let width = 2.0 * dst.iter().fold(0f32, |m, v| m.max(v.abs()));
        self.filter(filter, s, t, width, wrap)
    }

    /// pbrt-v4 5f7a606 `MIPMap::Filter` for `ewa` (4th ed. sec. 10.4.4): the footprint's axes
    /// `a = (ds/dx, dt/dx)`, `b = (ds/dy, dt/dy)`, the longer one first; the shorter lengthened
    /// to at least 1 / `max_anisotropy` of the longer; the level `l = max(0, L - 1 +
    /// log2(|shorter|))`, [`Self::ewa_level`] of levels `floor(l)` and the next blended by the
    /// fraction. A footprint of zero size reads level 0 bilinearly. As in pbrt-v4 the axes'
    /// t components keep the texture's sign while `t` itself is flipped to the image's rows, so
    /// the ellipse is the footprint's mirror image across the s axis.
    pub(crate) fn ewa(
        &self,
        s: f32,
        t: f32,
        dst: [f32; 4],
        max_anisotropy: f32,
        wrap: WrapMode,
    ) -> [f32; C] {
        let (mut a, mut b) = ([dst[0], dst[2]], [dst[1], dst[3]]);
        let len2 = |v: [f32; 2]| v[0] * v[0] + v[1] * v[1];
        if len2(a) < len2(b) {
            std::mem::swap(&mut a, &mut b);
        }
        let (longer, mut shorter) = (len2(a).sqrt(), len2(b).sqrt());
        if !(longer.is_finite() && shorter.is_finite()) {
            return self.bilerp(0, s, t, wrap);
        }
        if shorter * max_anisotropy < longer && shorter > 0.0 {
            let scale = longer / (shorter * max_anisotropy);
            b = [b[0] * scale, b[1] * scale];
            shorter *= scale;
        }
        if shorter == 0.0 {
            return self.bilerp(0, s, t, wrap);
        }
        let lod = ((self.levels.len() - 1) as f32 + shorter.log2()).max(0.0);
        let i = lod.floor() as usize;
        let f = lod - i as f32;
        let (lo, hi) = (
            self.ewa_level(i, s, t, a, b, wrap),
            self.ewa_level(i + 1, s, t, a, b, wrap),
        );
        std::array::from_fn(|c| lo[c] + f * (hi[c] - lo[c]))
    }

    /// pbrt-v4 `MIPMap::EWA` on level `k` (the top texel past the last level): in the level's
    /// texel units the ellipse `A s^2 + B s t + C t^2 < 1` with `A = a_t^2 + b_t^2 + 1`, `B =
    /// -2 (a_s a_t + b_s b_t)`, `C = a_s^2 + b_s^2 + 1`, divided by `A C - B^2 / 4` (the `+ 1`
    /// keeps at least a texel's reach); each texel inside weighted by the Gaussian `e^(-2 r^2)
    /// - e^(-2)` at its squared radius `r^2` on pbrt-v4's 128-step table, the weights
    /// normalised (texels outside the image through `wrap`; `black` ones count as 0).
    fn ewa_level(
        &self,
        k: usize,
        s: f32,
        t: f32,
        a: [f32; 2],
        b: [f32; 2],
        wrap: WrapMode,
    ) -> [f32; C] {
        let Some(l) = self.levels.get(k) else {
            return self.levels[self.levels.len() - 1].texels[0];
        };
        let (w, h) = (l.width as f32, l.height as f32);
        let (ps, pt) = (s * w - 0.5, (1.0 - t) * h - 0.5);
        let (a, b) = ([a[0] * w, a[1] * h], [b[0] * w, b[1] * h]);
        let mut ca = a[1] * a[1] + b[1] * b[1] + 1.0;
        let mut cb = -2.0 * (a[0] * a[1] + b[0] * b[1]);
        let mut cc = a[0] * a[0] + b[0] * b[0] + 1.0;
        let inv_f = 1.0 / (ca * cc - cb * cb * 0.25);
        (ca, cb, cc) = (ca * inv_f, cb * inv_f, cc * inv_f);
        let det = -cb * cb + 4.0 * ca * cc;
        let inv_det = 1.0 / det;
        let (u_sqrt, v_sqrt) = ((det * cc).max(0.0).sqrt(), (ca * det).max(0.0).sqrt());
        let s0 = (ps - 2.0 * inv_det * u_sqrt).ceil() as i64;
        let s1 = (ps + 2.0 * inv_det * u_sqrt).floor() as i64;
        let t0 = (pt - 2.0 * inv_det * v_sqrt).ceil() as i64;
        let t1 = (pt + 2.0 * inv_det * v_sqrt).floor() as i64;
        let lut = ewa_weights();
        let (mut sum, mut total) = ([0f32; C], 0f32);
        for it in t0..=t1 {
            let tt = it as f32 - pt;
            for is in s0..=s1 {
                let ss = is as f32 - ps;
                let r2 = ca * ss * ss + cb * ss * tt + cc * tt * tt;
                if r2 < 1.0 {
                    let weight = lut[((r2 * EWA_LUT as f32) as usize).min(EWA_LUT - 1)];
                    if let Some(i) = wrap_texel(is, it, l.width, l.height, wrap) {
                        for (acc, v) in sum.iter_mut().zip(&l.texels[i]) {
                            *acc += weight * v;
                        }
                    }
                    total += weight;
                }
            }
        }
        if !(total > 0.0) {
            return self.bilerp(k, s, t, wrap);
        }
        sum.map(|v| v / total)
    }

    /// pbrt-v4 `MIPMap::Filter` by `filter` at `(s, t)` for filter width `width` (texture
    /// coordinates; module docs). A full-resolution filter ([`TexelFilter::Bilinear`],
    /// [`TexelFilter::Point`]) reads as its pyramid counterpart; `ewa` needs the footprint's
    /// axes ([`Self::filter_footprint`]).
    pub(crate) fn filter(
        &self,
        filter: TexelFilter,
        s: f32,
        t: f32,
        width: f32,
        wrap: WrapMode,
    ) -> [f32; C] {
        let n = self.levels.len();
        let level = (n - 1) as f32 + width.max(1e-8).log2();
        if !level.is_finite() || level >= (n - 1) as f32 {
            return self.levels[n - 1].texels[0];
        }
        let i = level.floor().max(0.0) as usize;
        if filter.is_point() {
            let l = &self.levels[i];
            let (idx, w) = texels(l.width, l.height, s, t, wrap, TexelFilter::Point);
            return std::array::from_fn(|c| (0..4).map(|k| w[k] * l.texels[idx[k]][c]).sum());
        }
        if filter != TexelFilter::Trilinear || i == 0 {
            return self.bilerp(i, s, t, wrap);
        }
        let f = level - i as f32;
        let (a, b) = (self.bilerp(i, s, t, wrap), self.bilerp(i + 1, s, t, wrap));
        std::array::from_fn(|c| a[c] + f * (b[c] - a[c]))
    }
}

#[cfg(test)]
mod mip_tests {
    use super::*;

    /// A checkerboard of single texels: every level above 0 is its mean, 1/2, exactly; the top
    /// level holds the mean; a 512 x 128 image has 10 levels (its longer side 2^9).
    #[test]
    fn a_texel_checkerboard_averages_to_one_half_above_level_zero() {
        let (w, h) = (512usize, 128usize);
        let texels: Vec<[f32; 1]> = (0..w * h).map(|i| [((i % w + i / w) % 2) as f32]).collect();
        let p = Pyramid::new(w, h, &texels, WrapMode::Repeat);
        assert_eq!(p.levels(), 10);
        for l in &p.levels[1..] {
            assert!(
                l.texels.iter().all(|t| t[0] == 0.5),
                "{}x{}",
                l.width,
                l.height
            );
        }
        // Footprint of one texel: level 0, the checks themselves (bilinear at a texel centre).
        // Texel (3, 0): row 0 is at the top, t = 1 - 0.5 / h; odd, so 1.
        let v = p.filter(
            TexelFilter::Trilinear,
            3.5 / w as f32,
            1.0 - 0.5 / h as f32,
            1.0 / w as f32,
            WrapMode::Repeat,
        );
        assert!((v[0] - 1.0).abs() < 1e-5, "{v:?}");
        // Two texels and more: 1/2 whatever the position.
        for k in 0..50 {
            let s = k as f32 * 0.0137;
            for width in [2.0 / w as f32, 3.0 / w as f32, 0.1, 5.0] {
                let v = p.filter(TexelFilter::Trilinear, s, 0.3 + s, width, WrapMode::Repeat)[0];
                assert!((v - 0.5).abs() < 1e-6, "s {s} width {width}: {v}");
            }
        }
    }

    /// EWA (pbrt-v4 `MIPMap::EWA`) against closed forms. On a ramp (texel value = its column)
    /// each level is the same ramp, and at a point halfway between texel centres on levels 0 to
    /// 2 (s and t multiples of 1/64) the ellipse's texels lie symmetrically about it, so every
    /// footprint, tilted or not, on one level or blended, reads the ramp's value there: `s w -
    /// 1/2`. On columns of
    /// alternate 0 and 1 a footprint 0.2 texel across and 1.5 along them (a grazing view of
    /// stripes) reads level 0 with an ellipse about a texel across (its neighbours at r^2 =
    /// 0.96, weight 0.011 against 0.86 at the centre), so a column keeps nearly its own value,
    /// where `trilinear`, its level picked from the longer axis, reads grey. Where the longer axis is
    /// over `max_anisotropy` times the shorter the shorter is lengthened: the level follows
    /// `longer / max_anisotropy`.
    #[test]
    fn ewa_reads_the_ellipse_of_the_footprint() {
        let (w, h) = (256usize, 256usize);
        let ramp: Vec<[f32; 1]> = (0..w * h).map(|i| [(i % w) as f32]).collect();
        let p = Pyramid::new(w, h, &ramp, WrapMode::Clamp);
        let ewa = TexelFilter::Ewa {
            max_anisotropy: 8.0,
        };
        let texel = 1.0 / w as f32;
        for (s, t) in
            [(32.0f32, 32.0f32), (19.0, 39.0), (40.0, 17.0)].map(|(s, t)| (s / 64.0, t / 64.0))
        {
            for dst in [
                [0.7, 0.0, 0.0, 0.7],
                [3.0, 0.5, 1.0, -0.4],
                [0.3, -2.5, 2.0, 0.9],
                [6.0, 0.0, 0.0, 1.5],
            ] {
                let dst = dst.map(|v: f32| v * texel);
                let v = p.filter_footprint(ewa, s, t, dst, WrapMode::Clamp)[0];
                let want = s * w as f32 - 0.5;
                assert!(
                    (v - want).abs() < 1e-3,
                    "({s}, {t}) {dst:?}: {v} against {want}"
                );
            }
        }
        let stripes: Vec<[f32; 1]> = (0..w * h).map(|i| [(i % w % 2) as f32]).collect();
        let p = Pyramid::new(w, h, &stripes, WrapMode::Repeat);
        // Column 11 (value 1) and column 12 (value 0), at their centres; the footprint 0.2
        // texel across the columns and 1.5 along them (within the anisotropy limit 8).
        let dst = [0.2 * texel, 0.0, 0.0, 1.5 * texel];
        let read = |f: TexelFilter, col: f32| {
            p.filter_footprint(f, (col + 0.5) * texel, 0.4, dst, WrapMode::Repeat)[0]
        };
        let contrast = read(ewa, 11.0) - read(ewa, 12.0);
        assert!(contrast > 0.95, "EWA keeps the columns: {contrast}");
        for col in [11.0, 12.0] {
            let tri = read(TexelFilter::Trilinear, col);
            assert!((tri - 0.5).abs() < 1e-6, "trilinear column {col}: {tri}");
        }
        // Anisotropy clamp: on the level-valued pyramid (7 levels, 64 texels) a footprint of
        // 1/64 x 16/64 reads level log2(16 / 8) = 1 with the default 8 (0 unclamped: 1/64 is one
        // level-0 texel), level 2 with 4.
        let p = level_valued_pyramid();
        let dst = [1.0 / 64.0, 0.0, 0.0, 16.0 / 64.0];
        for (max_anisotropy, want) in [(8.0, 1.0), (4.0, 2.0), (16.0, 0.0)] {
            let f = TexelFilter::Ewa { max_anisotropy };
            let v = p.filter_footprint(f, 0.4, 0.6, dst, WrapMode::Clamp)[0];
            assert!(
                (v - want).abs() < 1e-5,
                "max_anisotropy {max_anisotropy}: {v}"
            );
        }
        // No footprint: level 0 bilinearly; one over the whole image: the top texel.
        let f = TexelFilter::Ewa {
            max_anisotropy: 8.0,
        };
        assert_eq!(
            p.filter_footprint(f, 0.4, 0.6, [0.0; 4], WrapMode::Clamp)[0],
            0.0
        );
        assert_eq!(
            p.filter_footprint(f, 0.4, 0.6, [3.0, 0.0, 0.0, 3.0], WrapMode::Clamp)[0],
            6.0
        );
    }

    /// A 64 x 64 image's pyramid (7 levels) rebuilt by hand so that level k holds the value k.
    fn level_valued_pyramid() -> Pyramid<1> {
        let mut p = Pyramid::new(64, 64, &vec![[0.0f32; 1]; 64 * 64], WrapMode::Clamp);
        for (k, l) in p.levels.iter_mut().enumerate() {
            l.texels.iter_mut().for_each(|t| t[0] = k as f32);
        }
        p
    }

    /// Level selection: on an image whose levels differ (level k holds the value k through a
    /// hand-built pyramid), a width `2^(m - (L - 1))` reads exactly level `m`, and halfway in
    /// log2 between two levels reads their mean; below level 1 it is level 0 alone.
    #[test]
    fn the_level_follows_log2_of_the_filter_width() {
        let p = level_valued_pyramid();
        let n = p.levels() as i32;
        assert_eq!(n, 7);
        for m in 1..n - 1 {
            let width = 2f32.powi(m - (n - 1));
            let v = p.filter(TexelFilter::Trilinear, 0.4, 0.6, width, WrapMode::Clamp)[0];
            assert!((v - m as f32).abs() < 1e-5, "level {m}: {v}");
            let v = p.filter(
                TexelFilter::Trilinear,
                0.4,
                0.6,
                width * 2f32.sqrt(),
                WrapMode::Clamp,
            )[0];
            assert!((v - (m as f32 + 0.5)).abs() < 1e-4, "level {m}.5: {v}");
        }
        let v = p.filter(
            TexelFilter::Trilinear,
            0.4,
            0.6,
            1.4 / 64.0,
            WrapMode::Clamp,
        )[0];
        assert_eq!(v, 0.0);
        assert_eq!(
            p.filter(TexelFilter::Trilinear, 0.4, 0.6, 10.0, WrapMode::Clamp)[0],
            6.0
        );
    }

    /// pbrt-v4's `bilinear` and `point` read one level, `max(0, floor(l))` (5f7a606
    /// `MIPMap::Filter`): on the level-valued pyramid a width halfway in log2 between levels `m`
    /// and `m + 1` reads `m` alone (where `trilinear` blends to `m + 1/2`), just below level 1
    /// level 0; on a texel checkerboard a footprint of two texels reads level 1, 1/2, where one
    /// of 1.9 texels still reads the texel itself.
    #[test]
    fn pbrt_bilinear_and_point_read_the_floor_level() {
        let p = level_valued_pyramid();
        let n = p.levels() as i32;
        for filter in [TexelFilter::MipBilinear, TexelFilter::MipPoint] {
            for m in 1..n - 1 {
                let width = 2f32.powi(m - (n - 1)) * 2f32.sqrt();
                let v = p.filter(filter, 0.4, 0.6, width, WrapMode::Clamp)[0];
                assert_eq!(v, m as f32, "{filter:?} level {m}.5");
            }
            assert_eq!(
                p.filter(filter, 0.4, 0.6, 1.9 / 64.0, WrapMode::Clamp)[0],
                0.0
            );
            assert_eq!(p.filter(filter, 0.4, 0.6, 0.0, WrapMode::Clamp)[0], 0.0);
            assert_eq!(p.filter(filter, 0.4, 0.6, 10.0, WrapMode::Clamp)[0], 6.0);
        }
        let (w, h) = (512usize, 128usize);
        let checks: Vec<[f32; 1]> = (0..w * h).map(|i| [((i % w + i / w) % 2) as f32]).collect();
        let p = Pyramid::new(w, h, &checks, WrapMode::Repeat);
        // Texel (3, 0), odd: 1. A quarter texel off its centre, so that bilinear and point differ
        // at level 0 but not at level 1 (uniform 1/2).
        let (s, t) = (3.25 / w as f32, 1.0 - 0.5 / h as f32);
        let at = |f, width: f32| p.filter(f, s, t, width / w as f32, WrapMode::Repeat)[0];
        assert_eq!(at(TexelFilter::MipPoint, 1.9), 1.0);
        assert!((at(TexelFilter::MipBilinear, 1.9) - 0.75).abs() < 1e-6);
        for f in [TexelFilter::MipPoint, TexelFilter::MipBilinear] {
            assert_eq!(at(f, 2.0), 0.5, "{f:?}");
            assert_eq!(at(f, 7.9), 0.5, "{f:?}");
        }
    }

    /// The budget counts every level and one image of level 0's size: a 300 x 200 image
    /// resamples to 512 x 256, whose 10 levels hold 512 * 256 * 4/3 texels less a third of the
    /// 1 x 1 top (the sum of a geometric series of ratio 1/4 ending at 2 x 1, then 1 x 1).
    #[test]
    fn the_pyramid_budget_counts_every_level() {
        let p = Pyramid::new(300, 200, &vec![[0.5f32; 3]; 300 * 200], WrapMode::Repeat);
        let held: u64 = p.levels.iter().map(|l| (l.texels.len() * 12) as u64).sum();
        assert_eq!(pyramid_bytes(300, 200, 3), held + 512 * 256 * 12);
        let levels: u64 = (0..9).map(|k| (512u64 >> k) * (256 >> k)).sum::<u64>() + 1;
        assert_eq!(held, levels * 12);
    }

    /// The Lanczos resampling up to powers of two keeps a constant image constant (its weights
    /// sum to 1) and the mean of a smooth image (to 0.5 %); pbrt-v4's weights at a 3 -> 4
    /// resampling: output texel 0 is centred at 0.375 source texels.
    #[test]
    fn resizing_up_keeps_constants_and_means() {
        let flat = vec![[0.7f32, 0.2, 0.1]; 300 * 200];
        let p = Pyramid::new(300, 200, &flat, WrapMode::Repeat);
        assert_eq!((p.levels[0].width, p.levels[0].height), (512, 256));
        for t in &p.levels[0].texels {
            for (c, want) in [0.7f32, 0.2, 0.1].iter().enumerate() {
                assert!((t[c] - want).abs() < 1e-5, "{t:?}");
            }
        }
        let (w, h) = (100usize, 60usize);
        let smooth: Vec<[f32; 1]> =
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                    [0.5 + 0.3
                        * (std::f32::consts::TAU * x).sin()
                        * (std::f32::consts::TAU * y).cos()]
                })
                .collect();
        let mean_in = smooth.iter().map(|t| t[0] as f64).sum::<f64>() / (w * h) as f64;
        let p = Pyramid::new(w, h, &smooth, WrapMode::Repeat);
        let top = p.levels.last().unwrap().texels[0][0] as f64;
        assert!(
            (top - mean_in).abs() < 0.005 * mean_in,
            "{top} vs {mean_in}"
        );
        let wts = resample_weights(3, 4);
        // Centre 0.375: first texel floor(0.375 - 2 + 0.5) = -2, taps at -1.5 .. 1.5 from it.
        assert_eq!(wts[0].0, -2);
        let raw: Vec<f64> = (0..4)
            .map(|j| windowed_sinc(-2.0 + j as f64 + 0.5 - 0.375, 2.0, 2.0))
            .collect();
        let sum: f64 = raw.iter().sum();
        for j in 0..4 {
            assert!((wts[0].1[j] as f64 - raw[j] / sum).abs() < 1e-6);
        }
    }
}
