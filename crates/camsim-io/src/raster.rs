//! Raster files: 16-bit grayscale PNG for raw mosaics (and reading 16-bit PNG or TIFF mosaics
//! from elsewhere), 8-bit RGB PNG for previews. Written atomically; decoding errors name the file.

use crate::atomic::write_atomic;
use crate::error::{IoError, Result};
use image::codecs::png::PngEncoder;
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

/// Write a 16-bit grayscale PNG (`rows * cols` values, row-major), e.g. a raw mosaic in DN.
pub fn write_png16_gray(path: &Path, rows: usize, cols: usize, data: &[u16]) -> Result<()> {
    check_size(path, rows, cols, data.len(), 1)?;
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_ne_bytes()).collect(); // the encoder wants native order
    write_atomic(path, |w| {
        PngEncoder::new(w)
            .write_image(&bytes, cols as u32, rows as u32, ExtendedColorType::L16)
            .map_err(|e| IoError::invalid(path, format!("PNG encoding failed: {e}")))
    })
}

/// Write an 8-bit sRGB PNG (`rows * cols * 3` values, row-major, RGB interleaved).
pub fn write_png8_rgb(path: &Path, rows: usize, cols: usize, rgb: &[u8]) -> Result<()> {
    check_size(path, rows, cols, rgb.len(), 3)?;
    write_atomic(path, |w| {
        PngEncoder::new(w)
            .write_image(rgb, cols as u32, rows as u32, ExtendedColorType::Rgb8)
            .map_err(|e| IoError::invalid(path, format!("PNG encoding failed: {e}")))
    })
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
