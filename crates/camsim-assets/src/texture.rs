//! Images decoded for materials, shared by the glTF and OBJ readers: base colour (sRGB decoded,
//! times its factor), one channel as a float texture (metallic, roughness, alpha, specular) and
//! tangent-space normal maps (scaled in x and y, glTF 2.0 sec. 3.9.3).

use crate::units::srgb_to_linear;
use camsim_scene3d::{
    FloatTexture, MappingKind, NormalMapImage, TexelFilter, Texture, UvMapping, WrapMode,
};

/// An image as stored: RGBA, 0..1 (8- and 16-bit codes divided by their maximum), row 0 at the
/// top.
pub(crate) struct DecodedImage {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) rgba: Vec<[f32; 4]>,
}

impl DecodedImage {
    /// Decode a PNG, JPEG (or any format of the `image` crate's build) from its bytes.
    pub(crate) fn decode(bytes: &[u8]) -> Result<DecodedImage, String> {
        let img = image::load_from_memory(bytes).map_err(|e| e.to_string())?;
        Ok(Self::from_dynamic(img))
    }

    /// Read and decode an image file.
    pub(crate) fn open(path: &std::path::Path) -> Result<DecodedImage, String> {
        let img = image::open(path).map_err(|e| e.to_string())?;
        Ok(Self::from_dynamic(img))
    }

    fn from_dynamic(img: image::DynamicImage) -> DecodedImage {
        let rgba = img.to_rgba32f();
        DecodedImage {
            width: rgba.width() as usize,
            height: rgba.height() as usize,
            rgba: rgba.pixels().map(|p| p.0).collect(),
        }
    }

    /// A base-colour texture: each texel's RGB decoded from sRGB (IEC 61966-2-1), times
    /// `factor`, clamped to a reflectance.
    pub(crate) fn base_color(
        &self,
        factor: [f64; 3],
        wrap: WrapMode,
        filter: TexelFilter,
    ) -> Texture {
        let rgb: Vec<[f32; 3]> = self
            .rgba
            .iter()
            .map(|p| {
                std::array::from_fn(|k| {
                    (srgb_to_linear(p[k]) as f64 * factor[k]).clamp(0.0, 1.0) as f32
                })
            })
            .collect();
        Texture::Image {
            width: self.width,
            height: self.height,
            rgb: rgb.into(),
            uscale: 1.0,
            vscale: 1.0,
            udelta: 0.0,
            vdelta: 0.0,
            kind: MappingKind::Uv,
            wrap,
            filter,
        }
    }

    /// Channel `ch` (0..4) times `factor`, through `map`, as a float texture (linear values).
    pub(crate) fn channel(
        &self,
        ch: usize,
        factor: f64,
        map: impl Fn(f32) -> f32,
        wrap: WrapMode,
        filter: TexelFilter,
    ) -> FloatTexture {
        FloatTexture::Image {
            width: self.width,
            height: self.height,
            values: self
                .rgba
                .iter()
                .map(|p| map(p[ch] * factor as f32))
                .collect::<Vec<f32>>()
                .into(),
            mapping: UvMapping::default(),
            wrap,
            filter,
        }
    }

    /// A tangent-space normal map: each texel's `(2 c - 1)` with x and y times `scale`,
    /// renormalised and stored back as `(n + 1) / 2` (glTF 2.0 sec. 3.9.3, `normalTexture.scale`;
    /// MTL `-bm`).
    pub(crate) fn normal_map(&self, scale: f32) -> NormalMapImage {
        let rgb = self
            .rgba
            .iter()
            .map(|p| {
                let n = [
                    (2.0 * p[0] - 1.0) * scale,
                    (2.0 * p[1] - 1.0) * scale,
                    2.0 * p[2] - 1.0,
                ];
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
                n.map(|v| (v / l + 1.0) / 2.0)
            })
            .collect();
        NormalMapImage {
            width: self.width,
            height: self.height,
            rgb,
            uv1: false,
        }
    }
}

/// The base colour of the glTF and OBJ readers (glTF 2.0 sec. 3.9.2: factor x texture x
/// vertex colour): `image` (the texture times the factor) or the factor alone, wrapped so the
/// vertex colour multiplies it where the mesh has one.
pub(crate) fn base_color(
    image: Option<Texture>,
    base_rgb: [f64; 3],
    vertex_colored: bool,
) -> Texture {
    let t = match (image, vertex_colored) {
        (Some(t), _) => t,
        (None, false) => Texture::Constant(crate::units::reflectance(base_rgb)),
        (None, true) => factor_image(base_rgb),
    };
    if vertex_colored {
        Texture::VertexColored(Box::new(t))
    } else {
        t
    }
}

/// A base-colour factor as a 1 x 1 image, which a vertex colour multiplies per hit
/// ([`Texture::VertexColored`] takes an RGB texel: a constant is already a spectrum).
fn factor_image(base_rgb: [f64; 3]) -> Texture {
    Texture::Image {
        width: 1,
        height: 1,
        rgb: vec![base_rgb.map(|v| v.clamp(0.0, 1.0) as f32)].into(),
        uscale: 1.0,
        vscale: 1.0,
        udelta: 0.0,
        vdelta: 0.0,
        kind: MappingKind::Uv,
        wrap: WrapMode::Clamp,
        filter: TexelFilter::Point,
    }
}
