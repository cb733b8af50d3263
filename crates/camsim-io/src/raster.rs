//! Raster files: 16-bit grayscale PNG for raw mosaics (and reading 16-bit PNG or TIFF mosaics
//! from elsewhere), 8-bit RGB PNG for previews. Written atomically; decoding errors name the file.

use crate::atomic::write_atomic;
use crate::error::{IoError, Result};
use image::{DynamicImage, ExtendedColorType, ImageEncoder};
use std::path::Path;

fn check_size(path: &Path, rows: usize, cols: usize, len: usize, per_pixel: usize) -> Result<()> {
    if rows == 0
        || cols == 0
        || rows > u32::MAX as usize
        || cols > u32::MAX as usize
        || len != rows * cols * per_pixel
    {
        return Err(IoError::invalid(
            path,
            format!("{len} values for {rows} x {cols} pixels x {per_pixel}"),
        ));
    }
    Ok(())
}

/// Write a PNG of `rows x cols` pixels (`data`: PNG's own sample order, big-endian for 16 bits)
/// atomically, with camsim's signature as its `Software` text chunk (PNG 1.2, 11.3.4.2). Fast
/// deflate: full-sensor images (12 Mpixel) encode several times faster than at the default level,
/// for files ~10-20 % larger (PNGs here are for viewing; DNG and EXR carry the data).
fn write_png(
    path: &Path,
    rows: usize,
    cols: usize,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) -> Result<()> {
    let failed =
        |e: png::EncodingError| IoError::invalid(path, format!("PNG encoding failed: {e}"));
    write_atomic(path, |w| {
        let mut e = png::Encoder::new(w, cols as u32, rows as u32);
        e.set_color(color);
        e.set_depth(depth);
        e.set_compression(png::Compression::Fast);
        e.set_filter(png::Filter::Adaptive);
        e.add_text_chunk("Software".into(), crate::software::SOFTWARE.into())
            .map_err(failed)?;
        let mut writer = e.write_header().map_err(failed)?;
        writer.write_image_data(data).map_err(failed)?;
        writer.finish().map_err(failed)
    })
}

/// Whether the PNG at `path` carries camsim's signature: a `Software` text chunk that starts with
/// `camsim` (only the chunks before the image data are read).
pub fn png_written_by_camsim(path: &Path) -> bool {
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    let Ok(reader) = png::Decoder::new(std::io::BufReader::new(f)).read_info() else {
        return false;
    };
    reader
        .info()
        .uncompressed_latin1_text
        .iter()
        .any(|t| t.keyword == "Software" && t.text.starts_with("camsim"))
}

/// Write a 16-bit grayscale PNG (`rows * cols` values, row-major), e.g. a raw mosaic in DN.
pub fn write_png16_gray(path: &Path, rows: usize, cols: usize, data: &[u16]) -> Result<()> {
    check_size(path, rows, cols, data.len(), 1)?;
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_be_bytes()).collect(); // PNG is big-endian
    write_png(
        path,
        rows,
        cols,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    )
}

/// The 16-bit value a `bits`-bit ADC value `dn` is written as in a scaled mosaic PNG:
/// `round(dn x 65535 / (2^bits - 1))`, so 0 stays 0 and the ADC's largest code becomes 65535
/// (full scale in every viewer). For `bits` <= 16 the map is one-to-one and
/// `dn = round(v x (2^bits - 1) / 65535)` inverts it exactly.
pub fn scale_dn_to_16(dn: u16, bits: u32) -> u16 {
    let max = ((1u64 << bits.clamp(1, 16)) - 1) as f64;
    ((dn as f64).min(max) * 65535.0 / max).round() as u16
}

/// Write a `bits`-bit raw mosaic (e.g. 12-bit ADC values) as a 16-bit grayscale PNG scaled to
/// the full 16-bit range with [`scale_dn_to_16`], so it is visible in ordinary viewers (the
/// unscaled values in a 16-bit PNG look black). The DNG keeps the exact data.
pub fn write_png16_mosaic_scaled(
    path: &Path,
    rows: usize,
    cols: usize,
    dn: &[u16],
    bits: u32,
) -> Result<()> {
    if !(1..=16).contains(&bits) {
        return Err(IoError::invalid(
            path,
            format!("{bits}-bit data: must be 1..16 bits"),
        ));
    }
    let scaled: Vec<u16> = dn.iter().map(|&v| scale_dn_to_16(v, bits)).collect();
    write_png16_gray(path, rows, cols, &scaled)
}

/// Write an 8-bit grayscale PNG (`rows * cols` values, row-major), e.g. a binary mask (0 / 255).
pub fn write_png8_gray(path: &Path, rows: usize, cols: usize, data: &[u8]) -> Result<()> {
    write_png8(path, rows, cols, data, png::ColorType::Grayscale, 1)
}

/// Write an 8-bit sRGB PNG (`rows * cols * 3` values, row-major, RGB interleaved).
pub fn write_png8_rgb(path: &Path, rows: usize, cols: usize, rgb: &[u8]) -> Result<()> {
    write_png8(path, rows, cols, rgb, png::ColorType::Rgb, 3)
}

fn write_png8(
    path: &Path,
    rows: usize,
    cols: usize,
    data: &[u8],
    colour: png::ColorType,
    channels: usize,
) -> Result<()> {
    check_size(path, rows, cols, data.len(), channels)?;
    write_png(path, rows, cols, colour, png::BitDepth::Eight, data)
}

/// An animated GIF of 8-bit RGB frames (`rows * cols * 3` bytes each, interleaved), each shown
/// for `delay_ms` and looping forever, written atomically. GIF holds 256 colours per frame: each
/// frame is quantized (NeuQuant, the `image` crate's GIF encoder), so it is for viewing only.
pub fn write_gif_rgb(
    path: &Path,
    rows: usize,
    cols: usize,
    frames: &[&[u8]],
    delay_ms: u32,
) -> Result<()> {
    for f in frames {
        check_size(path, rows, cols, f.len(), 3)?;
    }
    if cols > u16::MAX as usize || rows > u16::MAX as usize {
        return Err(IoError::invalid(
            path,
            format!("{rows} x {cols} pixels: a GIF holds at most 65535 x 65535"),
        ));
    }
    let failed = |e: image::ImageError| IoError::invalid(path, format!("GIF encoding failed: {e}"));
    write_atomic(path, |w| {
        let mut enc = image::codecs::gif::GifEncoder::new_with_speed(w, 10);
        enc.set_repeat(image::codecs::gif::Repeat::Infinite)
            .map_err(failed)?;
        let delay = image::Delay::from_numer_denom_ms(delay_ms, 1);
        for f in frames {
            let rgba: Vec<u8> = f
                .chunks_exact(3)
                .flat_map(|p| [p[0], p[1], p[2], 255])
                .collect();
            let img = image::RgbaImage::from_raw(cols as u32, rows as u32, rgba)
                .ok_or_else(|| IoError::invalid(path, "frame size"))?;
            enc.encode_frame(image::Frame::from_parts(img, 0, 0, delay))
                .map_err(failed)?;
        }
        Ok(())
    })
}

/// An 8-bit RGB image (`rows * cols * 3` bytes, interleaved) as PNG bytes, in memory (to embed
/// in a report).
pub fn encode_png8_rgb(rows: usize, cols: usize, rgb: &[u8]) -> Result<Vec<u8>> {
    let what = Path::new("<png>");
    check_size(what, rows, cols, rgb.len(), 3)?;
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(rgb, cols as u32, rows as u32, ExtendedColorType::Rgb8)
        .map_err(|e| IoError::invalid(what, format!("PNG encoding failed: {e}")))?;
    Ok(buf)
}

fn decode(path: &Path) -> Result<DynamicImage> {
    let reader = image::ImageReader::open(path).map_err(|e| IoError::io(path, e))?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| IoError::io(path, e))?;
    if reader.format().is_none() {
        return Err(IoError::format(path, "not a PNG or TIFF file"));
    }
    reader.decode().map_err(|e| match e {
        image::ImageError::IoError(io) => IoError::io(path, io),
        other => IoError::format(path, format!("cannot decode: {other}")),
    })
}

/// Read a single-channel mosaic from a 16-bit (or 8-bit) grayscale PNG or TIFF:
/// `(rows, cols, values)`. Colour or alpha images are refused: a CFA mosaic has one value per pixel.
pub fn read_mosaic_16(path: &Path) -> Result<(usize, usize, Vec<u16>)> {
    let img = decode(path)?;
    let (cols, rows) = (img.width() as usize, img.height() as usize);
    match img {
        DynamicImage::ImageLuma16(b) => Ok((rows, cols, b.into_raw())),
        DynamicImage::ImageLuma8(b) => Ok((
            rows,
            cols,
            b.into_raw().into_iter().map(u16::from).collect(),
        )),
        other => Err(IoError::format(
            path,
            format!(
                "is a {:?} image; a raw mosaic must be single-channel (grayscale) 8 or 16 bit",
                other.color()
            ),
        )),
    }
}

/// Read an 8-bit RGB PNG: `(rows, cols, rgb)` with RGB interleaved. Grayscale or RGBA files are
/// converted (alpha dropped); 16-bit files are refused.
pub fn read_png8_rgb(path: &Path) -> Result<(usize, usize, Vec<u8>)> {
    let img = decode(path)?;
    let (cols, rows) = (img.width() as usize, img.height() as usize);
    match img {
        DynamicImage::ImageRgb8(b) => Ok((rows, cols, b.into_raw())),
        DynamicImage::ImageRgba8(_)
        | DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_) => Ok((rows, cols, img.to_rgb8().into_raw())),
        other => Err(IoError::format(
            path,
            format!("is a {:?} image, not 8-bit RGB", other.color()),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png16_round_trip_keeps_every_value() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("raw.png");
        let data: Vec<u16> = (0..7 * 9)
            .map(|i| (i * 1031 % 65536) as u16)
            .chain([0, 65535])
            .take(63)
            .collect();
        write_png16_gray(&p, 7, 9, &data).unwrap();
        assert_eq!(read_mosaic_16(&p).unwrap(), (7, 9, data));
        assert!(write_png16_gray(&p, 7, 8, &[0; 63]).is_err());
    }

    #[test]
    fn scaled_mosaic_spans_the_16_bit_range_and_inverts_exactly() {
        // 12 bits: 0 -> 0, 4095 -> 65535, 2048 -> round(2048 x 65535 / 4095) = 32776.
        assert_eq!(scale_dn_to_16(0, 12), 0);
        assert_eq!(scale_dn_to_16(4095, 12), 65535);
        assert_eq!(scale_dn_to_16(2048, 12), 32776);
        assert_eq!(scale_dn_to_16(1, 1), 65535);
        for bits in [8u32, 10, 12, 14, 16] {
            let max = (1u32 << bits) - 1;
            for dn in (0..=max).step_by(7).chain([max]) {
                let v = scale_dn_to_16(dn as u16, bits) as f64;
                assert_eq!(
                    (v * max as f64 / 65535.0).round() as u32,
                    dn,
                    "{bits} bits, dn {dn}"
                );
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("raw.png");
        write_png16_mosaic_scaled(&p, 1, 3, &[0, 4095, 1000], 12).unwrap();
        assert_eq!(read_mosaic_16(&p).unwrap().2, vec![0, 65535, 16004]);
        assert!(write_png16_mosaic_scaled(&p, 1, 1, &[0], 0).is_err());
    }

    #[test]
    fn reads_16_bit_tiff_mosaic() {
        // Encode a 16-bit grayscale TIFF with the image crate's encoder (an independent writer).
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mosaic.tif");
        let data: Vec<u16> = (0..20).map(|i| 4000 + i * 3).collect();
        let buf =
            image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(5, 4, data.clone()).unwrap();
        buf.save(&p).unwrap();
        assert_eq!(read_mosaic_16(&p).unwrap(), (4, 5, data));
    }

    #[test]
    fn rgb8_round_trip_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("preview.png");
        let rgb: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7) as u8).collect();
        write_png8_rgb(&p, 4, 3, &rgb).unwrap();
        assert_eq!(read_png8_rgb(&p).unwrap(), (4, 3, rgb));
        // An RGB image is not a mosaic.
        assert!(read_mosaic_16(&p)
            .unwrap_err()
            .to_string()
            .contains("single-channel"));
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"\x89PNG\r\n\x1a\n truncated").unwrap();
        assert!(read_png8_rgb(&bad)
            .unwrap_err()
            .to_string()
            .contains("bad.png"));
        std::fs::write(&bad, b"hello").unwrap();
        assert!(read_mosaic_16(&bad).is_err());
    }
}
