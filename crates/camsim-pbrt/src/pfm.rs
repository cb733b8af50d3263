//! Portable Float Map reader (`.pfm`), the float image format pbrt-v4 reads for environment
//! maps and image textures (the Bitterli scene collection ships its environment maps as PFM).
//!
//! Format (as pbrt-v4 `ReadPFM`, src/pbrt/util/image.cpp, reads it): a header of three
//! whitespace-separated tokens `PF` (RGB) or `Pf` (grey), `width height`, and `scale`, then one
//! whitespace byte and `width * height * channels` 32-bit floats, rows from the BOTTOM of the
//! image to the top. A negative scale means little-endian data; `|scale|` multiplies every value
//! (pbrt-v4 applies it when it is not 1). Grey maps are returned with R = G = B.

/// Reads a PFM image: `(width, height, texels)` with row 0 at the top of the image.
/// Malformed files give an error naming the problem, never a panic.
pub fn read_pfm(bytes: &[u8]) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let mut pos = 0usize;
    let mut token = |what: &str| -> Result<String, String> {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(format!("PFM: header ends before the {what}"));
        }
        Ok(String::from_utf8_lossy(&bytes[start..pos]).into_owned())
    };
    let channels = match token("magic")?.as_str() {
        "PF" => 3usize,
        "Pf" => 1usize,
        m => return Err(format!("PFM: bad magic \"{m}\" (expected PF or Pf)")),
    };
    let dim = |s: String, what: &str| -> Result<usize, String> {
        s.parse::<usize>()
            .ok()
            .filter(|v| (1..=1 << 16).contains(v))
            .ok_or_else(|| format!("PFM: {what} \"{s}\" is not an integer in 1..=65536"))
    };
    let width = dim(token("width")?, "width")?;
    let height = dim(token("height")?, "height")?;
    let scale_s = token("scale")?;
    let scale: f32 = scale_s
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| format!("PFM: scale \"{scale_s}\" is not a finite non-zero number"))?;
    // Exactly one whitespace byte separates the header from the raster.
    pos += 1;
    let n = width * height * channels;
    let raster = bytes
        .get(pos..)
        .filter(|r| r.len() >= 4 * n)
        .ok_or_else(|| {
            format!("PFM: {width} x {height} x {channels} floats announced but the file is shorter")
        })?;
    let little = scale < 0.0;
    let mul = scale.abs();
    let value = |i: usize| -> f32 {
        let b = [
            raster[4 * i],
            raster[4 * i + 1],
            raster[4 * i + 2],
            raster[4 * i + 3],
        ];
        let v = if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        if mul != 1.0 {
            v * mul
        } else {
            v
        }
    };
    let mut px = vec![[0.0f32; 3]; width * height];
    for file_row in 0..height {
        // File rows run bottom to top; flip so that row 0 is the top (pbrt-v4 flips in Y too).
        let y = height - 1 - file_row;
        for x in 0..width {
            let i = (file_row * width + x) * channels;
            px[y * width + x] = if channels == 3 {
                [value(i), value(i + 1), value(i + 2)]
            } else {
                let g = value(i);
                [g, g, g]
            };
        }
    }
    Ok((width, height, px))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pfm(magic: &str, w: usize, h: usize, scale: f32, vals: &[f32]) -> Vec<u8> {
        let mut b = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        for v in vals {
            if scale < 0.0 {
                b.extend_from_slice(&v.to_le_bytes());
            } else {
                b.extend_from_slice(&v.to_be_bytes());
            }
        }
        b
    }

    #[test]
    fn rows_are_flipped_and_endianness_follows_the_scale_sign() {
        // 1 x 2 RGB: the file's first row is the image's bottom row.
        let vals = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        for scale in [-1.0f32, 1.0] {
            let (w, h, px) = read_pfm(&pfm("PF", 1, 2, scale, &vals)).unwrap();
            assert_eq!((w, h), (1, 2));
            assert_eq!(px, vec![[4.0, 5.0, 6.0], [1.0, 2.0, 3.0]]);
        }
    }

    #[test]
    fn grey_maps_and_scale_magnitude() {
        let (_, _, px) = read_pfm(&pfm("Pf", 2, 1, -2.0, &[0.25, 1.5])).unwrap();
        assert_eq!(px, vec![[0.5, 0.5, 0.5], [3.0, 3.0, 3.0]]);
    }

    #[test]
    fn malformed_files_are_errors() {
        assert!(read_pfm(b"P6\n1 1\n-1\n").is_err());
        assert!(read_pfm(b"PF\n2 2\n-1\n\0\0\0\0").is_err());
        assert!(read_pfm(b"PF\n0 2\n-1\n").is_err());
        assert!(read_pfm(b"PF\n1 1\nnan\n").is_err());
        assert!(read_pfm(b"PF\n1").is_err());
    }
}
