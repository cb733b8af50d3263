//! Image files as pbrt-v4 reads them (for image textures, normal maps, light images and
//! environment maps): every format pbrt-v4's `Image::Read` (src/pbrt/util/image.cpp) accepts,
//! decoded by the `image` crate (PNG, TGA, JPEG, BMP, HDR, QOI), the `exr` crate (OpenEXR) or
//! [`crate::pfm`] (PFM, which the `image` crate does not read), and turned into linear values
//! with pbrt-v4's rules for each format:
//!
//! | format | values | `encoding` parameter |
//! |---|---|---|
//! | PNG, 8 or 16 bit | code / (2^bits - 1), then decoded | honoured (default `sRGB`) |
//! | TGA, JPEG, BMP (pbrt-v4 reads them with stb_image) | code / 255, sRGB-decoded | ignored: always sRGB |
//! | QOI | code / 255, decoded as the file's colour-space flag says | ignored |
//! | OpenEXR, PFM, HDR (Radiance RGBE) | floating point, linear | ignored |
//!
//! Grey images come back with R = G = B (pbrt-v4's one-channel images give `RGB(y, y, y)` to
//! spectrum textures and `y` to float textures); alpha is dropped.

use std::path::Path;

/// Image texel encodings (pbrt-v4 `ColorEncoding`: `linear`, `sRGB`, `gamma G`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Encoding {
    Linear,
    Srgb,
    Gamma(f32),
}

impl Encoding {
    /// A code value in [0, 1] as a linear value.
    #[inline]
    fn to_linear(self, v: f32) -> f32 {
        match self {
            Encoding::Linear => v,
            Encoding::Srgb => camsim_core::colorimetry::srgb_decode(v as f64) as f32,
            // pbrt-v4 GammaColorEncoding::ToLinear: v^gamma.
            Encoding::Gamma(g) => v.max(0.0).powf(g),
        }
    }
}

/// pbrt-v4's `encoding` string: `linear`, `sRGB` (or `srgb`), `gamma G` with G > 0.
pub(crate) fn parse_encoding(s: &str) -> Option<Encoding> {
    match s {
        "linear" => Some(Encoding::Linear),
        "sRGB" | "srgb" => Some(Encoding::Srgb),
        _ => {
            let g = s.strip_prefix("gamma ")?.trim().parse::<f32>().ok()?;
            (g > 0.0 && g.is_finite()).then_some(Encoding::Gamma(g))
        }
    }
}

/// The file's extension, lower case.
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// pbrt-v4's default `encoding` for an image file: `sRGB` for PNG, `linear` otherwise
/// (`SpectrumImageTexture::Create`; it only matters for PNG, see [`fixed_encoding`]).
pub(crate) fn default_encoding(file_name: &str) -> &'static str {
    if extension(Path::new(file_name)) == "png" {
        "sRGB"
    } else {
        "linear"
    }
}

/// How a format's values are decoded when pbrt-v4 ignores the `encoding` parameter for it
/// (everything but PNG), for a note when a file gives one; `None` for PNG.
pub(crate) fn fixed_encoding(file_name: &str) -> Option<&'static str> {
    match extension(Path::new(file_name)).as_str() {
        "png" => None,
        "exr" | "pfm" | "hdr" => Some("linear (a floating-point format)"),
        "qoi" => Some("as the QOI file's own colour-space flag says"),
        _ => Some("sRGB (pbrt-v4 reads TGA, JPEG and BMP files as sRGB)"),
    }
}

/// A decoded image: `(width, height, linear RGB texels)`, row 0 at the top.
pub(crate) type Rgb = (usize, usize, Vec<[f32; 3]>);

/// Load an image file as linear RGB with pbrt-v4's per-format rules (module docs); `encoding`
/// applies to PNG files only. Errors name the file.
pub(crate) fn load_image(path: &Path, encoding: Encoding) -> Result<Rgb, String> {
    let named = |e: String| format!("{}: {e}", path.display());
    match extension(path).as_str() {
        "pfm" => {
            let bytes = std::fs::read(path).map_err(|e| named(e.to_string()))?;
            crate::pfm::read_pfm(&bytes).map_err(named)
        }
        "exr" => load_exr(path).map_err(named),
        ext => load_with_image_crate(path, ext, encoding).map_err(named),
    }
}

/// OpenEXR through the `exr` crate: the first layer's R, G, B (linear).
fn load_exr(path: &Path) -> Result<Rgb, String> {
    // The header first, so a damaged file and a file without colour channels get messages of
    // their own (the exr crate says "no layer matched" for both).
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| {
        format!("not a readable OpenEXR file ({e}); export it again or use another file")
    })?;
    let has_rgb = meta.headers.iter().any(|h| {
        ["R", "G", "B"].iter().all(|c| {
            h.channels
                .list
                .iter()
                .any(|ch| ch.name.to_string().rsplit('.').next() == Some(*c))
        })
    });
    if !has_rgb {
        let names: Vec<String> = meta
            .headers
            .iter()
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .take(8)
            .collect();
        return Err(format!(
            "has no R, G and B channels (it has {}); an image map needs an RGB(A) OpenEXR",
            names.join(", ")
        ));
    }
    let img = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| {
            let (w, h) = (res.width(), res.height());
            let n = if (w as u64) * (h as u64) <= (1 << 28) {
                w * h
            } else {
                0
            };
            (w, vec![[0.0f32; 3]; n])
        },
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            if let Some(p) = px.get_mut(pos.y() * *w + pos.x()) {
                *p = [r, g, b];
            }
        },
    )
    .map_err(|e| {
        format!("damaged or truncated OpenEXR file ({e}); export it again or use another file")
    })?;
    let size = img.layer_data.size;
    let (w, h) = (size.width(), size.height());
    let px = img.layer_data.channel_data.pixels.1;
    if px.len() != w * h {
        return Err(format!("image of {w} x {h} pixels is too large"));
    }
    Ok((w, h, px))
}

/// PNG, TGA, JPEG, BMP, HDR and QOI (and any other format the `image` crate recognises by
/// content) through the `image` crate, with pbrt-v4's encoding for each (module docs).
fn load_with_image_crate(path: &Path, ext: &str, encoding: Encoding) -> Result<Rgb, String> {
    let reader = image::ImageReader::open(path)
        .map_err(|e| e.to_string())?
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let format = reader.format();
    if format.is_none() {
        return Err(format!(
            "\".{ext}\" is not an image format pbrt-v4 reads (PNG, TGA, JPEG, BMP, HDR, QOI, EXR, PFM)"
        ));
    }
    let (w, h) = reader
        .into_dimensions()
        .map_err(|e| format!("cannot read the image header: {e}"))?;
    let (w, h) = (w as usize, h as usize);
    // The decoded image (up to 16 bytes a texel) and the linear copy (12).
    camsim_core::mem::check_alloc((w as u64) * (h as u64) * 28, "texture image")
        .map_err(|e| e.to_string())?;
    let img = image::ImageReader::open(path)
        .map_err(|e| e.to_string())?
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    use image::ImageFormat as F;
    let enc = match format {
        Some(F::Png) => encoding,
        Some(F::Hdr) | Some(F::OpenExr) => Encoding::Linear,
        Some(F::Qoi) => {
            let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
            match qoi::decode_header(&bytes)
                .map_err(|e| e.to_string())?
                .colorspace
            {
                qoi::ColorSpace::Srgb => Encoding::Srgb,
                qoi::ColorSpace::Linear => Encoding::Linear,
            }
        }
        // pbrt-v4 reads everything else with stb_image as 8-bit sRGB.
        _ => Encoding::Srgb,
    };
    let rgb = img.to_rgb32f();
    Ok((
        w,
        h,
        rgb.pixels()
            .map(|p| p.0.map(|v| enc.to_linear(v)))
            .collect(),
    ))
}
