//! Colour photographs as input: an RGB image (PNG, JPEG, TIFF: display-encoded code values; or
//! OpenEXR: linear values) read into interleaved f32 RGB, for a scene made through a display
//! model (`camsim_scene`'s `kind = "rgb"`, ISETCam `sceneFromFile`).

use crate::error::{IoError, Result};
use camsim_core::mem;
use std::path::Path;

/// How the values of an [`RgbFile`] relate to light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RgbEncoding {
    /// Display code values in [0, 1] (8-bit / 255, 16-bit / 65535): a display's transfer
    /// function (gamma) turns them into light.
    CodeValues,
    /// Values proportional to light (an OpenEXR file): no transfer function applies.
    Linear,
}

/// An RGB image: `rows * cols * 3` values, row-major, RGB interleaved.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbFile {
    /// Image height, pixels.
    pub rows: usize,
    /// Image width, pixels.
    pub cols: usize,
    /// Interleaved R, G, B values (code values in [0, 1], or linear values).
    pub rgb: Vec<f32>,
    /// What the values are.
    pub encoding: RgbEncoding,
}

/// Read an RGB image: PNG, JPEG or TIFF (8 or 16 bit; grey images are copied to all three
/// channels, alpha is dropped) as code values in [0, 1], or OpenEXR (channels `R`, `G`, `B`, or a
/// single `Y`) as linear values. The format is found from the file's contents.
pub fn read_rgb_image(path: &Path) -> Result<RgbFile> {
    let is_exr = {
        use std::io::Read;
        let mut magic = [0u8; 4];
        let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
        f.read(&mut magic).map_err(|e| IoError::io(path, e))? == 4
            && magic == [0x76, 0x2f, 0x31, 0x01]
    };
    if is_exr {
        return read_exr_rgb(path);
    }
    let reader = image::ImageReader::open(path).map_err(|e| IoError::io(path, e))?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| IoError::io(path, e))?;
    if reader.format().is_none() {
        return Err(IoError::format(
            path,
            "not a PNG, JPEG, TIFF or OpenEXR image",
        ));
    }
    let (cols, rows) = reader
        .into_dimensions()
        .map_err(|e| IoError::format(path, format!("cannot read the image size: {e}")))?;
    // The decoded image (up to 16 bit x 4 channels) and the f32 copy.
    let bytes = (rows as u64) * (cols as u64) * (8 + 12);
    mem::check_alloc(bytes, &format!("the pixels of {}", path.display()))
        .map_err(|e| IoError::core(path, e))?;
    let img = image::ImageReader::open(path)
        .map_err(|e| IoError::io(path, e))?
        .with_guessed_format()
        .map_err(|e| IoError::io(path, e))?
        .decode()
        .map_err(|e| match e {
            image::ImageError::IoError(io) => IoError::io(path, io),
            other => IoError::format(path, format!("cannot decode: {other}")),
        })?;
    let rgb: Vec<f32> = if img.color().bytes_per_pixel() / img.color().channel_count().max(1) >= 2 {
        img.to_rgb16()
            .into_raw()
            .into_iter()
            .map(|v| v as f32 / 65535.0)
            .collect()
    } else {
        img.to_rgb8()
            .into_raw()
            .into_iter()
            .map(|v| v as f32 / 255.0)
            .collect()
    };
    Ok(RgbFile {
        rows: rows as usize,
        cols: cols as usize,
        rgb,
        encoding: RgbEncoding::CodeValues,
    })
}

fn read_exr_rgb(path: &Path) -> Result<RgbFile> {
    let (rows, cols, channels) = crate::exr::read_channels_exr(path)?;
    let find = |n: &str| {
        channels
            .iter()
            .find(|(c, _)| c == n)
            .map(|(_, d)| d.as_slice())
    };
    let planes: Vec<&[f32]> = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => vec![r, g, b],
        (_, _, _, Some(y)) => vec![y],
        _ => {
            let names: Vec<&str> = channels.iter().map(|(c, _)| c.as_str()).collect();
            return Err(IoError::format(
                path,
                format!(
                    "has channels {}; an RGB image needs R, G and B (or Y)",
                    names.join(", ")
                ),
            ));
        }
    };
    let mut rgb = vec![0f32; rows * cols * 3];
    for (i, px) in rgb.chunks_exact_mut(3).enumerate() {
        for (c, v) in px.iter_mut().enumerate() {
            *v = planes[c.min(planes.len() - 1)][i];
        }
    }
    if let Some(i) = rgb.iter().position(|v| !v.is_finite()) {
        let p = i / 3;
        return Err(IoError::format(
            path,
            format!("pixel (row {}, col {}) is not finite", p / cols, p % cols),
        ));
    }
    Ok(RgbFile {
        rows,
        cols,
        rgb,
        encoding: RgbEncoding::Linear,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png8_png16_and_exr_read_as_code_values_or_linear() {
        let dir = tempfile::tempdir().unwrap();
        // 8-bit RGB PNG: code values / 255.
        let p8 = dir.path().join("a.png");
        crate::raster::write_png8_rgb(&p8, 1, 2, &[0, 51, 255, 128, 7, 9]).unwrap();
        let f = read_rgb_image(&p8).unwrap();
        assert_eq!(
            (f.rows, f.cols, f.encoding),
            (1, 2, RgbEncoding::CodeValues)
        );
        assert_eq!(
            f.rgb,
            [0.0, 0.2, 1.0, 128.0 / 255.0, 7.0 / 255.0, 9.0 / 255.0]
        );
        // 16-bit grey PNG: / 65535, copied to R, G and B.
        let p16 = dir.path().join("g.png");
        crate::raster::write_png16_gray(&p16, 1, 1, &[65535 / 5]).unwrap();
        let f = read_rgb_image(&p16).unwrap();
        assert_eq!(f.rgb, [(65535 / 5) as f32 / 65535.0; 3]);
        // EXR: linear values as stored.
        let pe = dir.path().join("l.exr");
        crate::exr::write_channels_exr(
            &pe,
            1,
            2,
            &[("R", &[0.5, 4.0]), ("G", &[0.25, 0.0]), ("B", &[1.0, 2.0])],
        )
        .unwrap();
        let f = read_rgb_image(&pe).unwrap();
        assert_eq!(f.encoding, RgbEncoding::Linear);
        assert_eq!(f.rgb, [0.5, 0.25, 1.0, 4.0, 0.0, 2.0]);
        // Not an image: the message names the file.
        let bad = dir.path().join("x.png");
        std::fs::write(&bad, b"hello").unwrap();
        let e = read_rgb_image(&bad).unwrap_err().to_string();
        assert!(e.contains("x.png"), "{e}");
        let pz = dir.path().join("z.exr");
        crate::exr::write_channels_exr(&pz, 1, 1, &[("Z", &[1.0])]).unwrap();
        let e = read_rgb_image(&pz).unwrap_err().to_string();
        assert!(e.contains("z.exr") && e.contains("R, G and B"), "{e}");
    }
}
