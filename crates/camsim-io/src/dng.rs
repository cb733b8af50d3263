//! DNG (Adobe Digital Negative 1.4, a TIFF/EP extension) raw files.
//!
//! Writing: an uncompressed 16-bit CFA image in IFD0 with the tags LibRaw, exiftool and
//! darktable need (DNGVersion, CFARepeatPatternDim, CFAPattern, BlackLevel, WhiteLevel,
//! ColorMatrix1, AsShotNeutral, UniqueCameraModel, ExposureTime, ...).
//!
//! Reading: camsim's files and real cameras': the raw CFA IFD is found among IFD0 and its
//! SubIFDs (NewSubfileType 0, PhotometricInterpretation 32803); strips or tiles; uncompressed
//! 8..16-bit (16 and 8 bits per sample, or bit-packed MSB-first) or lossless JPEG
//! (Compression 7, see [`crate::ljpeg`]; the JPEG frame's width/components need not match the
//! tile's, only the sample count, DNG 1.4 spec p. 20); LinearizationTable; BlackLevel per CFA
//! position (BlackLevelRepeatDim), BlackLevelDeltaH/V; WhiteLevel; ActiveArea (the image is
//! cropped to it; the CFA pattern and the black-level pattern are relative to its top-left
//! corner, as in the DNG SDK); DefaultCropOrigin/Size and Orientation are reported.

use crate::error::{IoError, Result};
use crate::tiff::{Ifd, IfdSpec, Tiff, Value};
use camsim_core::{mem, CfaLayout, CfaPattern, RawImage};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// TIFF / TIFF-EP / EXIF / DNG tag numbers used here.
pub mod tag {
    pub const NEW_SUBFILE_TYPE: u16 = 254;
    pub const IMAGE_WIDTH: u16 = 256;
    pub const IMAGE_LENGTH: u16 = 257;
    pub const BITS_PER_SAMPLE: u16 = 258;
    pub const COMPRESSION: u16 = 259;
    pub const PHOTOMETRIC: u16 = 262;
    pub const IMAGE_DESCRIPTION: u16 = 270;
    pub const MAKE: u16 = 271;
    pub const MODEL: u16 = 272;
    pub const STRIP_OFFSETS: u16 = 273;
    pub const ORIENTATION: u16 = 274;
    pub const SAMPLES_PER_PIXEL: u16 = 277;
    pub const ROWS_PER_STRIP: u16 = 278;
    pub const STRIP_BYTE_COUNTS: u16 = 279;
    pub const PLANAR_CONFIGURATION: u16 = 284;
    pub const SOFTWARE: u16 = 305;
    pub const TILE_WIDTH: u16 = 322;
    pub const TILE_LENGTH: u16 = 323;
    pub const TILE_OFFSETS: u16 = 324;
    pub const TILE_BYTE_COUNTS: u16 = 325;
    pub const CFA_REPEAT_PATTERN_DIM: u16 = 33421;
    pub const CFA_PATTERN: u16 = 33422;
    pub const EXPOSURE_TIME: u16 = 33434;
    pub const ISO_SPEED: u16 = 34855;
    pub const FOCAL_PLANE_X_RESOLUTION_EP: u16 = 37390;
    pub const FOCAL_PLANE_RESOLUTION_UNIT_EP: u16 = 37392;
    pub const FOCAL_PLANE_X_RESOLUTION: u16 = 41486;
    pub const FOCAL_PLANE_RESOLUTION_UNIT: u16 = 41488;
    pub const DNG_VERSION: u16 = 50706;
    pub const DNG_BACKWARD_VERSION: u16 = 50707;
    pub const UNIQUE_CAMERA_MODEL: u16 = 50708;
    pub const CFA_PLANE_COLOR: u16 = 50710;
    pub const CFA_LAYOUT: u16 = 50711;
    pub const LINEARIZATION_TABLE: u16 = 50712;
    pub const BLACK_LEVEL_REPEAT_DIM: u16 = 50713;
    pub const BLACK_LEVEL: u16 = 50714;
    pub const BLACK_LEVEL_DELTA_H: u16 = 50715;
    pub const BLACK_LEVEL_DELTA_V: u16 = 50716;
    pub const WHITE_LEVEL: u16 = 50717;
    pub const DEFAULT_CROP_ORIGIN: u16 = 50719;
    pub const DEFAULT_CROP_SIZE: u16 = 50720;
    pub const COLOR_MATRIX_1: u16 = 50721;
    pub const AS_SHOT_NEUTRAL: u16 = 50728;
    pub const CALIBRATION_ILLUMINANT_1: u16 = 50778;
    pub const ACTIVE_AREA: u16 = 50829;
    pub const DNG_PRIVATE_DATA: u16 = 50740;
}

/// What `DNGPrivateData` starts with when it holds the colour filter layout of a mosaic written
/// as a monochrome LinearRaw image (a filter DNG has no colour code for, such as `ir`): the
/// owner's name, NUL-terminated (DNG 1.4, DNGPrivateData), then `cfa:` and the layout's rows
/// joined by `/`, filters by spaces (`r g/ir b`).
const PRIVATE_CFA_PREFIX: &[u8] = b"camsim\0cfa:";

fn private_cfa_bytes(l: &CfaLayout) -> Vec<u8> {
    let rows: Vec<String> = (0..l.rows())
        .map(|r| {
            (0..l.cols())
                .map(|c| l.filters()[l.filter_at(r, c)].as_str())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect();
    let mut v = PRIVATE_CFA_PREFIX.to_vec();
    v.extend_from_slice(rows.join("/").as_bytes());
    v
}

fn parse_private_cfa(bytes: &[u8]) -> Option<std::result::Result<CfaLayout, String>> {
    let rest = bytes.strip_prefix(PRIVATE_CFA_PREFIX)?;
    let text = String::from_utf8_lossy(rest);
    let names: Vec<Vec<String>> = text
        .trim_end_matches('\0')
        .split('/')
        .map(|r| r.split_whitespace().map(str::to_string).collect())
        .collect();
    Some(CfaLayout::from_names(&names).map_err(|e| format!("camsim's CFA layout {text:?}: {e}")))
}

/// ExifVersion tag (EXIF IFD).
const EXIF_VERSION: u16 = 36864;
/// PhotometricInterpretation of a CFA image (TIFF/EP).
pub const PHOTOMETRIC_CFA: u16 = 32803;
/// PhotometricInterpretation of a demosaiced linear raw image (DNG).
pub const PHOTOMETRIC_LINEAR_RAW: u16 = 34892;
/// EXIF LightSource code of CIE D65 (for `CalibrationIlluminant1`).
pub const ILLUMINANT_D65: u16 = 21;
/// EXIF LightSource code of CIE standard illuminant A.
pub const ILLUMINANT_A: u16 = 17;

/// What camsim writes into a DNG beside the pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DngMetadata {
    /// UniqueCameraModel and Model (e.g. "camsim imx363").
    pub camera_model: String,
    /// Make (default "camsim").
    pub make: String,
    /// ColorMatrix1: XYZ (D50-adapted per DNG) -> camera native, row-major. `None` writes the
    /// identity (DNG requires the tag for colour images).
    pub color_matrix1: Option<[[f64; 3]; 3]>,
    /// AsShotNeutral: the camera's response to the scene white, per channel (R, G, B), relative.
    pub as_shot_neutral: Option<[f64; 3]>,
    /// CalibrationIlluminant1 as an EXIF LightSource code (21 = D65, 17 = A).
    pub calibration_illuminant: u16,
    /// ImageDescription, e.g. the run parameters as JSON.
    pub description: Option<String>,
    /// Orientation (TIFF: 1 = rows top to bottom, columns left to right).
    pub orientation: u16,
    /// ActiveArea: top, left, bottom, right in pixels (`None`: the whole image).
    pub active_area: Option<[u32; 4]>,
    /// ISO speed (EXIF ISOSpeedRatings, tag 34855, rounded to an integer): written when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iso: Option<f64>,
}

impl Default for DngMetadata {
    fn default() -> Self {
        DngMetadata {
            camera_model: "camsim".into(),
            make: "camsim".into(),
            color_matrix1: None,
            as_shot_neutral: None,
            calibration_illuminant: ILLUMINANT_D65,
            description: None,
            orientation: 1,
            active_area: None,
            iso: None,
        }
    }
}

/// What a DNG said beyond the pixels, as read.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct DngInfo {
    /// DNGVersion (None: a TIFF/EP file without it).
    pub dng_version: Option<[u8; 4]>,
    pub make: Option<String>,
    pub model: Option<String>,
    pub unique_camera_model: Option<String>,
    pub software: Option<String>,
    pub description: Option<String>,
    /// Orientation (TIFF codes 1..8; 1 when absent). Pixels are returned as stored, not rotated.
    pub orientation: u16,
    /// Compression of the raw IFD (1 uncompressed, 7 lossless JPEG).
    pub compression: u16,
    /// BitsPerSample of the stored data.
    pub bits_per_sample: u16,
    /// Stored image size before the ActiveArea crop (rows, cols).
    pub stored_size: (usize, usize),
    /// ActiveArea applied: top, left, bottom, right.
    pub active_area: [usize; 4],
    /// DefaultCropOrigin (x, y) relative to the active area, if present.
    pub default_crop_origin: Option<[f64; 2]>,
    /// DefaultCropSize (width, height), if present.
    pub default_crop_size: Option<[f64; 2]>,
    /// Black level (DN) at each 2x2 CFA position: top-left, top-right, bottom-left,
    /// bottom-right of the (cropped) image, including the mean BlackLevelDeltaH/V.
    pub black_level_cfa_dn: [f64; 4],
    /// WhiteLevel (DN, first sample).
    pub white_level_dn: f64,
    /// True when a LinearizationTable was applied to the values.
    pub linearized: bool,
    pub color_matrix1: Option<[[f64; 3]; 3]>,
    pub as_shot_neutral: Option<[f64; 3]>,
    pub calibration_illuminant1: Option<u16>,
    /// ExposureTime, s.
    pub exposure_s: Option<f64>,
    /// ISO speed rating.
    pub iso: Option<f64>,
}

fn rational(x: f64) -> (u32, u32) {
    let x = x.max(0.0);
    if x == 0.0 || !x.is_finite() {
        return (0, 1);
    }
    // Largest power-of-ten denominator that keeps the numerator in range (<= 1e6).
    let mut den: u64 = 1_000_000;
    while den > 1 && x * den as f64 > u32::MAX as f64 {
        den /= 10;
    }
    let num = (x * den as f64).round().min(u32::MAX as f64) as u64;
    let g = gcd(num, den);
    ((num / g.max(1)) as u32, (den / g.max(1)) as u32)
}

fn srational(x: f64) -> (i32, i32) {
    let (n, d) = rational(x.abs().min(i32::MAX as f64 / 2.0));
    let n = (n.min(i32::MAX as u32)) as i32;
    (if x < 0.0 { -n } else { n }, d as i32)
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

/// Exposure time as a rational the way cameras write it (1/N when that is exact enough).
fn exposure_rational(t: f64) -> (u32, u32) {
    if t > 0.0 && t < 1.0 {
        let inv = 1.0 / t;
        if (inv - inv.round()).abs() < 1e-6 * inv && inv.round() <= u32::MAX as f64 {
            return (1, inv.round() as u32);
        }
    }
    rational(t)
}

/// Write `raw` as an uncompressed 16-bit CFA DNG, atomically. A mosaic with a filter DNG has
/// no colour code for (an RGB-IR sensor's `ir`: CFAPlaneColor knows red, green, blue, cyan,
/// magenta, yellow and white) is written as a monochrome LinearRaw image of the same ADC values
/// with its layout in DNGPrivateData: any DNG reader sees the exact mosaic, [`read_dng`] restores
/// the layout.
pub fn write_dng(path: &Path, raw: &RawImage, meta: &DngMetadata) -> Result<()> {
    let layout = raw.cfa_layout();
    let (cfa, private_cfa) = match layout.dng_codes() {
        Ok(_) => (Some(layout), None),
        Err(_) => (None, Some(layout)),
    };
    let image = Samples {
        rows: raw.rows,
        cols: raw.cols,
        dn: &raw.dn,
        cfa,
        private_cfa,
        black_level_dn: &[raw.black_level_dn],
        white_level_dn: &[raw.white_level_dn],
        exposure_s: raw.exposure_s,
        pixel_pitch_m: raw.pixel_pitch_m,
    };
    write_samples(path, &image, meta)
}

/// Write a demosaiced RGB image as an uncompressed 16-bit LinearRaw DNG
/// (PhotometricInterpretation 34892, 3 samples per pixel, per-sample black and white levels),
/// atomically.
pub fn write_linear_raw_dng(path: &Path, img: &LinearRawImage, meta: &DngMetadata) -> Result<()> {
    let image = Samples {
        rows: img.rows,
        cols: img.cols,
        dn: &img.dn,
        cfa: None,
        private_cfa: None,
        black_level_dn: &img.black_level_dn,
        white_level_dn: &img.white_level_dn,
        exposure_s: img.exposure_s,
        pixel_pitch_m: img.pixel_pitch_m,
    };
    write_samples(path, &image, meta)
}

/// What the writer needs of a CFA (`cfa` set, 1 sample per pixel) or LinearRaw (3) image.
struct Samples<'a> {
    rows: usize,
    cols: usize,
    dn: &'a [u16],
    cfa: Option<CfaLayout>,
    /// A mosaic written as a monochrome LinearRaw image (see [`write_dng`]).
    private_cfa: Option<CfaLayout>,
    black_level_dn: &'a [f64],
    white_level_dn: &'a [f64],
    exposure_s: f64,
    pixel_pitch_m: f64,
}

fn write_samples(path: &Path, raw: &Samples, meta: &DngMetadata) -> Result<()> {
    let (rows, cols) = (raw.rows, raw.cols);
    let spp = if raw.cfa.is_some() || raw.private_cfa.is_some() {
        1
    } else {
        3
    };
    if rows == 0 || cols == 0 || raw.dn.len() != rows * cols * spp {
        return Err(IoError::invalid(
            path,
            format!(
                "raw image has {} values for {rows} x {cols} pixels of {spp} samples",
                raw.dn.len()
            ),
        ));
    }
    if rows > u32::MAX as usize / 2 || cols > 65535 * 4 {
        return Err(IoError::invalid(
            path,
            format!("{rows} x {cols} is too large for a DNG"),
        ));
    }
    let row_samples = cols * spp;
    let strip_rows = (256 * 1024 / (row_samples * 2)).clamp(1, rows);
    let n_strips = rows.div_ceil(strip_rows);
    let strip_lens: Vec<u64> = (0..n_strips)
        .map(|s| ((rows - s * strip_rows).min(strip_rows) * row_samples * 2) as u64)
        .collect();
    let cm = meta
        .color_matrix1
        .unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let mut tags: Vec<(u16, Value)> = vec![
        (tag::NEW_SUBFILE_TYPE, Value::Long(vec![0])),
        (tag::IMAGE_WIDTH, Value::Long(vec![cols as u32])),
        (tag::IMAGE_LENGTH, Value::Long(vec![rows as u32])),
        (tag::BITS_PER_SAMPLE, Value::Short(vec![16; spp])),
        (tag::COMPRESSION, Value::Short(vec![1])),
        (
            tag::PHOTOMETRIC,
            Value::Short(vec![if raw.cfa.is_some() {
                PHOTOMETRIC_CFA
            } else {
                PHOTOMETRIC_LINEAR_RAW
            }]),
        ),
        (tag::MAKE, Value::Ascii(meta.make.clone())),
        (tag::MODEL, Value::Ascii(meta.camera_model.clone())),
        (tag::ORIENTATION, Value::Short(vec![meta.orientation])),
        (tag::SAMPLES_PER_PIXEL, Value::Short(vec![spp as u16])),
        (tag::ROWS_PER_STRIP, Value::Long(vec![strip_rows as u32])),
        (tag::PLANAR_CONFIGURATION, Value::Short(vec![1])),
        (
            tag::SOFTWARE,
            Value::Ascii(format!("camsim {}", env!("CARGO_PKG_VERSION"))),
        ),
        (tag::DNG_VERSION, Value::Byte(vec![1, 4, 0, 0])),
        (tag::DNG_BACKWARD_VERSION, Value::Byte(vec![1, 1, 0, 0])),
        (
            tag::UNIQUE_CAMERA_MODEL,
            Value::Ascii(meta.camera_model.clone()),
        ),
        (tag::BLACK_LEVEL_REPEAT_DIM, Value::Short(vec![1, 1])),
        (
            tag::BLACK_LEVEL,
            Value::Rational(raw.black_level_dn.iter().map(|b| rational(*b)).collect()),
        ),
        (
            tag::WHITE_LEVEL,
            Value::Long(
                raw.white_level_dn
                    .iter()
                    .map(|w| w.round().clamp(1.0, 65535.0) as u32)
                    .collect(),
            ),
        ),
    ];
    if let Some(l) = &raw.private_cfa {
        // One colour plane: no colour matrix (DNG: ColorPlanes x 3 values) and no neutral.
        tags.push((tag::DNG_PRIVATE_DATA, Value::Byte(private_cfa_bytes(l))));
    } else {
        tags.push((
            tag::COLOR_MATRIX_1,
            Value::SRational(cm.iter().flatten().map(|v| srational(*v)).collect()),
        ));
        tags.push((
            tag::CALIBRATION_ILLUMINANT_1,
            Value::Short(vec![meta.calibration_illuminant]),
        ));
    }
    if let Some(cfa) = &raw.cfa {
        // DNG 1.4: CFAPattern holds plane indices, CFAPlaneColor each plane's TIFF/EP colour code
        // (0 red, 1 green, 2 blue, 3 cyan, 4 magenta, 5 yellow, 6 white); planes = our filters.
        // A filter without a code (e.g. `ir`) cannot be written.
        let colours = cfa
            .dng_codes()
            .map_err(|e| IoError::invalid(path, e.to_string()))?;
        let (n, m) = (cfa.rows(), cfa.cols());
        let mut plane_colour = vec![0u8; cfa.filters().len()];
        let mut pattern = Vec::with_capacity(n * m);
        for r in 0..n {
            for c in 0..m {
                let f = cfa.filter_at(r, c);
                plane_colour[f] = colours[r * m + c];
                pattern.push(f as u8);
            }
        }
        tags.push((
            tag::CFA_REPEAT_PATTERN_DIM,
            Value::Short(vec![n as u16, m as u16]),
        ));
        tags.push((tag::CFA_PATTERN, Value::Byte(pattern)));
        tags.push((tag::CFA_PLANE_COLOR, Value::Byte(plane_colour)));
        tags.push((tag::CFA_LAYOUT, Value::Short(vec![1])));
    }
    if let Some(d) = &meta.description {
        tags.push((tag::IMAGE_DESCRIPTION, Value::Ascii(d.clone())));
    }
    if let Some(n) = meta.as_shot_neutral.filter(|_| raw.private_cfa.is_none()) {
        tags.push((
            tag::AS_SHOT_NEUTRAL,
            Value::Rational(n.iter().map(|v| rational(*v)).collect()),
        ));
    }
    // EXIF IFD (where exiftool and LibRaw expect these): exposure time, pixel pitch.
    let mut exif_tags = Vec::new();
    if raw.exposure_s > 0.0 {
        exif_tags.push((
            tag::EXPOSURE_TIME,
            Value::Rational(vec![exposure_rational(raw.exposure_s)]),
        ));
    }
    if let Some(iso) = meta.iso.filter(|v| v.is_finite() && *v >= 1.0) {
        exif_tags.push((
            tag::ISO_SPEED,
            Value::Short(vec![iso.round().min(65535.0) as u16]),
        ));
    }
    if raw.pixel_pitch_m > 0.0 {
        // FocalPlaneX/YResolution in pixels per cm (unit 3).
        let res = Value::Rational(vec![rational(0.01 / raw.pixel_pitch_m)]);
        exif_tags.push((tag::FOCAL_PLANE_X_RESOLUTION, res.clone()));
        exif_tags.push((tag::FOCAL_PLANE_X_RESOLUTION + 1, res));
        exif_tags.push((tag::FOCAL_PLANE_RESOLUTION_UNIT, Value::Short(vec![3])));
    }
    if !exif_tags.is_empty() {
        exif_tags.push((EXIF_VERSION, Value::Undefined(b"0230".to_vec())));
    }
    if let Some(a) = meta.active_area {
        if !(a[0] < a[2] && a[1] < a[3] && a[2] as usize <= rows && a[3] as usize <= cols) {
            return Err(IoError::invalid(
                path,
                format!("ActiveArea {a:?} is not inside the {rows} x {cols} image"),
            ));
        }
        tags.push((tag::ACTIVE_AREA, Value::Long(a.to_vec())));
    }
    let spec = IfdSpec {
        tags,
        segment_offsets_tag: tag::STRIP_OFFSETS,
        segment_counts_tag: tag::STRIP_BYTE_COUNTS,
        segment_lens: strip_lens,
        sub_ifds: Vec::new(),
        exif_tags,
    };
    let head = crate::tiff::layout(&spec, true).map_err(|m| IoError::invalid(path, m))?;
    crate::atomic::write_atomic(path, |w: &mut dyn Write| {
        w.write_all(&head)?;
        let mut buf = Vec::with_capacity(row_samples * 2);
        for r in 0..rows {
            buf.clear();
            for v in &raw.dn[r * row_samples..(r + 1) * row_samples] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            w.write_all(&buf)?; // strips are even-length: no padding needed
        }
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Reading

struct Reader<'a, 'p> {
    t: Tiff<'a>,
    path: &'p Path,
}

impl<'a, 'p> Reader<'a, 'p> {
    fn fail<T>(&self, m: impl Into<String>) -> Result<T> {
        Err(IoError::format(self.path, m.into()))
    }
    fn uints(&self, ifd: &Ifd, t: u16) -> Result<Option<Vec<u64>>> {
        match ifd.entries.get(&t) {
            Some(e) => self
                .t
                .uints(e)
                .map(Some)
                .map_err(|m| IoError::format(self.path, format!("tag {t}: {m}"))),
            None => Ok(None),
        }
    }
    fn uint(&self, ifd: &Ifd, t: u16) -> Result<Option<u64>> {
        Ok(self.uints(ifd, t)?.and_then(|v| v.first().copied()))
    }
    fn floats(&self, ifd: &Ifd, t: u16) -> Result<Option<Vec<f64>>> {
        match ifd.entries.get(&t) {
            Some(e) => self
                .t
                .floats(e)
                .map(Some)
                .map_err(|m| IoError::format(self.path, format!("tag {t}: {m}"))),
            None => Ok(None),
        }
    }
    fn text(&self, ifd: &Ifd, t: u16) -> Option<String> {
        ifd.entries
            .get(&t)
            .map(|e| self.t.ascii(e))
            .filter(|s| !s.is_empty())
    }
    /// A tag from the raw IFD, else IFD0, else the EXIF IFDs.
    fn find<'s>(&'s self, raw: &'s Ifd, t: u16) -> Option<&'s Ifd> {
        if raw.entries.contains_key(&t) {
            return Some(raw);
        }
        if self.t.ifds[0].entries.contains_key(&t) {
            return Some(&self.t.ifds[0]);
        }
        self.t
            .exif
            .iter()
            .map(|i| &self.t.ifds[*i])
            .find(|i| i.entries.contains_key(&t))
    }
}

/// A demosaiced linear raw image (DNG PhotometricInterpretation 34892 "LinearRaw", as phones
/// write after their own demosaicking): RGB samples per pixel, linear in light, not
/// black-subtracted. Cropped to the ActiveArea and linearized like the CFA image.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearRawImage {
    /// Rows, pixels.
    pub rows: usize,
    /// Columns, pixels.
    pub cols: usize,
    /// Interleaved R, G, B samples, row-major: `rows * cols * 3` values, DN.
    pub dn: Vec<u16>,
    /// Black level per sample (R, G, B), DN: the mean of the BlackLevel pattern plus the mean
    /// BlackLevelDeltaH/V.
    pub black_level_dn: [f64; 3],
    /// White level per sample (R, G, B), DN.
    pub white_level_dn: [f64; 3],
    /// Exposure time, s (0 when unknown).
    pub exposure_s: f64,
    /// Pixel pitch, m (0 when unknown).
    pub pixel_pitch_m: f64,
}

impl LinearRawImage {
    /// Value of sample `channel` (0 R, 1 G, 2 B) at pixel (row, col), DN.
    pub fn at(&self, row: usize, col: usize, channel: usize) -> u16 {
        self.dn[(row * self.cols + col) * 3 + channel]
    }
}

/// The raw image of a DNG: a CFA mosaic or a demosaiced LinearRaw image.
#[derive(Debug, Clone, PartialEq)]
pub enum DngImage {
    /// PhotometricInterpretation 32803: one sample per pixel behind a Bayer CFA.
    Cfa(RawImage),
    /// PhotometricInterpretation 34892: three samples (R, G, B) per pixel.
    LinearRaw(LinearRawImage),
}

/// Read a DNG's raw CFA image and its metadata. The image is cropped to the ActiveArea and
/// linearized (LinearizationTable) but not black-subtracted; `black_level_dn` is the mean of
/// the per-position black levels (see [`DngInfo::black_level_cfa_dn`]). A LinearRaw DNG is an
/// error here; [`read_dng_image`] reads both kinds.
pub fn read_dng(path: &Path) -> Result<(RawImage, DngInfo)> {
    let data = read_file(path)?;
    read_dng_bytes(&data, path)
}

/// [`read_dng`] on bytes in memory; `path` only names the file in errors.
pub fn read_dng_bytes(data: &[u8], path: &Path) -> Result<(RawImage, DngInfo)> {
    match read_dng_image_bytes(data, path)? {
        (DngImage::Cfa(raw), info) => Ok((raw, info)),
        (DngImage::LinearRaw(_), _) => Err(IoError::format(
            path,
            "holds a demosaiced LinearRaw image, not CFA raw data (only `camsim analyze chart` and `analyze roi` read LinearRaw DNGs)",
        )),
    }
}

/// Read a DNG's raw image, CFA or LinearRaw (3 samples per pixel, chunky), with its metadata.
pub fn read_dng_image(path: &Path) -> Result<(DngImage, DngInfo)> {
    let data = read_file(path)?;
    read_dng_image_bytes(&data, path)
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    let len = std::fs::metadata(path)
        .map_err(|e| IoError::io(path, e))?
        .len();
    mem::check_alloc(len, &format!("reading {}", path.display()))
        .map_err(|e| IoError::core(path, e))?;
    std::fs::read(path).map_err(|e| IoError::io(path, e))
}

/// [`read_dng_image`] on bytes in memory; `path` only names the file in errors. DNG 1.4 spec
/// order: pick the raw IFD, decode its pixels, linearize (chapter 5), crop to the ActiveArea,
/// read the black and white levels and the descriptive tags.
pub fn read_dng_image_bytes(data: &[u8], path: &Path) -> Result<(DngImage, DngInfo)> {
    let t = Tiff::parse(data).map_err(|m| IoError::format(path, m))?;
    let r = Reader { t, path };
    let ifd0 = &r.t.ifds[0];
    let mut info = DngInfo {
        dng_version: r
            .uints(ifd0, tag::DNG_VERSION)?
            .filter(|v| v.len() >= 4)
            .map(|v| [v[0] as u8, v[1] as u8, v[2] as u8, v[3] as u8]),
        ..Default::default()
    };
    let (raw_index, linear) = raw_ifd(&r)?;
    let raw = &r.t.ifds[raw_index];
    let g = raw_layout(&r, raw, linear, data.len())?;
    info.compression = g.compression as u16;
    info.bits_per_sample = g.bps as u16;

    // CFA pattern (Bayer or a general N x M layout), with CFAPlaneColor mapping codes to colours.
    let cfa = if linear {
        None
    } else {
        Some(cfa_pattern(&r, raw)?)
    };
    // Pixels (interleaved samples).
    let mut img = decode_pixels(&r, raw, g.width, g.height, g.spp, g.bps, g.compression)?;
    info.linearized = linearize(&r, raw, &mut img)?;
    let ((rows, cols), dn) = crop_active_area(&r, raw, &g, img, &mut info)?;
    let levels = levels(&r, raw, &g, &mut info)?;
    let pitch = descriptive_tags(&r, raw, &mut info)?;

    // A one-plane LinearRaw image is a monochrome mosaic: camsim's layout when it wrote one
    // (DNGPrivateData), else one panchromatic filter.
    let cfa = match cfa {
        Some(c) => Some(c),
        None if g.spp == 1 => {
            let private = r
                .find(raw, tag::DNG_PRIVATE_DATA)
                .map(|ifd| r.uints(ifd, tag::DNG_PRIVATE_DATA))
                .transpose()?
                .flatten()
                .map(|v| v.iter().map(|b| *b as u8).collect::<Vec<u8>>());
            let layout = match private.as_deref().and_then(parse_private_cfa) {
                Some(l) => l.map_err(|m| IoError::format(path, m))?,
                None => CfaLayout::from_names(&[vec!["w".to_string()]])
                    .map_err(|e| IoError::core(path, e))?,
            };
            Some(match layout.as_bayer() {
                Some(p) => (p, None),
                None => (CfaPattern::Rggb, Some(layout)),
            })
        }
        None => None,
    };
    let image = match cfa {
        Some((cfa, layout)) => DngImage::Cfa(RawImage {
            rows,
            cols,
            cfa,
            layout,
            dn,
            black_level_dn: levels.black,
            white_level_dn: levels.white,
            bits: (levels.white + 1.0).log2().ceil().clamp(1.0, 16.0) as u32,
            exposure_s: info.exposure_s.unwrap_or(0.0),
            pixel_pitch_m: pitch,
        }),
        None => DngImage::LinearRaw(LinearRawImage {
            rows,
            cols,
            dn,
            black_level_dn: levels.black_per_sample,
            white_level_dn: levels.white_per_sample,
            exposure_s: info.exposure_s.unwrap_or(0.0),
            pixel_pitch_m: pitch,
        }),
    };
    Ok((image, info))
}

/// The raw IFD: full-resolution (NewSubfileType 0) CFA, the largest if several; a LinearRaw IFD
/// only when there is no CFA one. Returns (IFD index, LinearRaw).
fn raw_ifd(r: &Reader) -> Result<(usize, bool)> {
    let mut best_cfa: Option<(usize, u64)> = None;
    let mut best_linear: Option<(usize, u64)> = None;
    for (i, ifd) in r.t.ifds.iter().enumerate() {
        if r.t.exif.contains(&i) {
            continue;
        }
        let photometric = r.uint(ifd, tag::PHOTOMETRIC)?.unwrap_or(0);
        let subfile = r.uint(ifd, tag::NEW_SUBFILE_TYPE)?.unwrap_or(0);
        let slot = match photometric {
            p if p == PHOTOMETRIC_CFA as u64 => &mut best_cfa,
            p if p == PHOTOMETRIC_LINEAR_RAW as u64 => &mut best_linear,
            _ => continue,
        };
        if subfile == 0 {
            let area = r.uint(ifd, tag::IMAGE_WIDTH)?.unwrap_or(0)
                * r.uint(ifd, tag::IMAGE_LENGTH)?.unwrap_or(0);
            if !matches!(*slot, Some(b) if area <= b.1) {
                *slot = Some((i, area));
            }
        }
    }
    match (best_cfa, best_linear) {
        (Some((i, _)), _) => Ok((i, false)),
        (None, Some((i, _))) => Ok((i, true)),
        (None, None) => r.fail(
            "no raw image (no IFD with PhotometricInterpretation 32803 (CFA) or 34892 (LinearRaw) and NewSubfileType 0)",
        ),
    }
}

/// A raw IFD's stored size and sample layout, checked.
struct RawLayout {
    width: usize,
    height: usize,
    /// Samples per pixel: 1 (CFA) or 3 (LinearRaw, chunky).
    spp: usize,
    bps: u32,
    compression: u64,
}

fn raw_layout(r: &Reader, raw: &Ifd, linear: bool, file_len: usize) -> Result<RawLayout> {
    let width = r.uint(raw, tag::IMAGE_WIDTH)?.unwrap_or(0) as usize;
    let height = r.uint(raw, tag::IMAGE_LENGTH)?.unwrap_or(0) as usize;
    if width == 0 || height == 0 || width > 1 << 17 || height > 1 << 17 {
        return r.fail(format!(
            "raw image size {width} x {height} is not plausible"
        ));
    }
    let spp = r.uint(raw, tag::SAMPLES_PER_PIXEL)?.unwrap_or(1);
    // LinearRaw: RGB, or one plane (a monochrome camera's, or a mosaic camsim wrote so).
    let spp_ok = if linear {
        spp == 3 || spp == 1
    } else {
        spp == 1
    };
    if !spp_ok {
        return r.fail(if linear {
            format!("LinearRaw image has {spp} samples per pixel; only 3 (RGB) or 1 (monochrome) is supported")
        } else {
            format!("raw CFA image has {spp} samples per pixel; expected 1")
        });
    }
    let spp = spp as usize;
    if linear && r.uint(raw, tag::PLANAR_CONFIGURATION)?.unwrap_or(1) != 1 {
        return r.fail("LinearRaw image is stored planar (PlanarConfiguration 2); only chunky (1) is supported");
    }
    // Every sample takes at least one bit, compressed or not: a size the file cannot hold is corrupt.
    if (width * height * spp) as u64 > 8 * file_len as u64 {
        return r.fail(format!(
            "raw image size {width} x {height} is more than a {file_len}-byte file can hold"
        ));
    }
    mem::check_alloc((width * height * spp * 2) as u64, "the raw image")
        .map_err(|e| IoError::core(r.path, e))?;
    let bps = r.uint(raw, tag::BITS_PER_SAMPLE)?.unwrap_or(1);
    if !(1..=16).contains(&bps) {
        return r.fail(format!("BitsPerSample {bps} is not 1..16"));
    }
    Ok(RawLayout {
        width,
        height,
        spp,
        bps: bps as u32,
        compression: r.uint(raw, tag::COMPRESSION)?.unwrap_or(1),
    })
}

/// Apply the LinearizationTable, if any (DNG spec, chapter 5 "Mapping Raw Values to Linear
/// Reference Values"). Returns whether there was one.
fn linearize(r: &Reader, raw: &Ifd, img: &mut [u16]) -> Result<bool> {
    let Some(table) = r.uints(raw, tag::LINEARIZATION_TABLE)? else {
        return Ok(false);
    };
    if table.is_empty() {
        return r.fail("LinearizationTable is empty");
    }
    let last = table.len() - 1;
    let lut: Vec<u16> = table.iter().map(|v| (*v).min(65535) as u16).collect();
    for v in img.iter_mut() {
        *v = lut[(*v as usize).min(last)];
    }
    Ok(true)
}

/// Crop the decoded samples to the ActiveArea; returns ((rows, cols), samples).
fn crop_active_area(
    r: &Reader,
    raw: &Ifd,
    g: &RawLayout,
    img: Vec<u16>,
    info: &mut DngInfo,
) -> Result<((usize, usize), Vec<u16>)> {
    let (width, height, spp) = (g.width, g.height, g.spp);
    let area = match r.uints(raw, tag::ACTIVE_AREA)? {
        Some(a) if a.len() >= 4 => {
            let a = [a[0] as usize, a[1] as usize, a[2] as usize, a[3] as usize];
            if !(a[0] < a[2] && a[1] < a[3] && a[2] <= height && a[3] <= width) {
                return r.fail(format!(
                    "ActiveArea {a:?} is not inside the {height} x {width} image"
                ));
            }
            a
        }
        Some(a) => return r.fail(format!("ActiveArea has {} values; expected 4", a.len())),
        None => [0, 0, height, width],
    };
    info.stored_size = (height, width);
    info.active_area = area;
    let (rows, cols) = (area[2] - area[0], area[3] - area[1]);
    let dn: Vec<u16> = if area == [0, 0, height, width] {
        img
    } else {
        let mut v = Vec::with_capacity(rows * cols * spp);
        for row in area[0]..area[2] {
            v.extend_from_slice(&img[(row * width + area[1]) * spp..(row * width + area[3]) * spp]);
        }
        v
    };
    Ok(((rows, cols), dn))
}

/// Black and white levels of the raw image.
struct Levels {
    /// Mean black level over the 2x2 CFA positions, DN.
    black: f64,
    /// Black level per sample (LinearRaw R, G, B), DN.
    black_per_sample: [f64; 3],
    /// White level (of the first sample), DN.
    white: f64,
    /// White level per sample, DN.
    white_per_sample: [f64; 3],
}

/// BlackLevel per CFA position (relative to the active area's top-left) and per sample
/// (BlackLevelRepeatRows x BlackLevelRepeatCols x SamplesPerPixel values) plus the mean
/// BlackLevelDeltaH/V; WhiteLevel per sample (default 2^BitsPerSample - 1).
fn levels(r: &Reader, raw: &Ifd, g: &RawLayout, info: &mut DngInfo) -> Result<Levels> {
    let spp = g.spp;
    let bdim = r
        .uints(raw, tag::BLACK_LEVEL_REPEAT_DIM)?
        .unwrap_or_else(|| vec![1, 1]);
    let (br, bc) = (
        bdim.first().copied().unwrap_or(1) as usize,
        bdim.get(1).copied().unwrap_or(1) as usize,
    );
    if br == 0 || bc == 0 || br > 16 || bc > 16 {
        return r.fail(format!("BlackLevelRepeatDim {bdim:?} is not plausible"));
    }
    let blacks = r
        .floats(raw, tag::BLACK_LEVEL)?
        .unwrap_or_else(|| vec![0.0]);
    let black_at = |i: usize, j: usize, s: usize| -> f64 {
        // Mean over the black-level pattern cells that fall on CFA position (i, j).
        let mut sum = 0.0;
        let mut n = 0usize;
        for a in 0..br.max(2) {
            for b in 0..bc.max(2) {
                if a % 2 == i && b % 2 == j {
                    let k = ((a % br) * bc + (b % bc)) * spp + s;
                    sum += blacks.get(k).or(blacks.first()).copied().unwrap_or(0.0);
                    n += 1;
                }
            }
        }
        sum / n.max(1) as f64
    };
    let mean_of = |v: Option<Vec<f64>>| {
        v.filter(|v| !v.is_empty())
            .map_or(0.0, |v| v.iter().sum::<f64>() / v.len() as f64)
    };
    let delta = mean_of(r.floats(raw, tag::BLACK_LEVEL_DELTA_H)?)
        + mean_of(r.floats(raw, tag::BLACK_LEVEL_DELTA_V)?);
    let black_of_sample = |s: usize| {
        (black_at(0, 0, s) + black_at(0, 1, s) + black_at(1, 0, s) + black_at(1, 1, s)) / 4.0
            + delta
    };
    info.black_level_cfa_dn = [
        black_at(0, 0, 0) + delta,
        black_at(0, 1, 0) + delta,
        black_at(1, 0, 0) + delta,
        black_at(1, 1, 0) + delta,
    ];
    let black = info.black_level_cfa_dn.iter().sum::<f64>() / 4.0;
    let default_white = ((1u64 << g.bps) - 1) as f64;
    let whites = r
        .floats(raw, tag::WHITE_LEVEL)?
        .filter(|v| !v.is_empty())
        .unwrap_or_else(|| vec![default_white]);
    let white_of_sample = |s: usize| whites.get(s).copied().unwrap_or(whites[0]);
    for s in 0..spp {
        let w = white_of_sample(s);
        if !(w > 0.0 && w.is_finite()) {
            return r.fail(format!("WhiteLevel {w} is not a positive number"));
        }
    }
    info.white_level_dn = whites[0];
    Ok(Levels {
        black,
        black_per_sample: [0, 1, 2].map(black_of_sample),
        white: whites[0],
        white_per_sample: [0, 1, 2].map(white_of_sample),
    })
}

/// The descriptive tags into `info` (orientation, names, crop, colour matrix, neutral, exposure,
/// ISO); returns the pixel pitch from FocalPlaneXResolution, m (0 when absent).
fn descriptive_tags(r: &Reader, raw: &Ifd, info: &mut DngInfo) -> Result<f64> {
    info.orientation = r
        .find(raw, tag::ORIENTATION)
        .map_or(Ok(None), |i| r.uint(i, tag::ORIENTATION))?
        .unwrap_or(1) as u16;
    info.make = r.find(raw, tag::MAKE).and_then(|i| r.text(i, tag::MAKE));
    info.model = r.find(raw, tag::MODEL).and_then(|i| r.text(i, tag::MODEL));
    info.unique_camera_model = r
        .find(raw, tag::UNIQUE_CAMERA_MODEL)
        .and_then(|i| r.text(i, tag::UNIQUE_CAMERA_MODEL));
    info.software = r
        .find(raw, tag::SOFTWARE)
        .and_then(|i| r.text(i, tag::SOFTWARE));
    info.description = r
        .find(raw, tag::IMAGE_DESCRIPTION)
        .and_then(|i| r.text(i, tag::IMAGE_DESCRIPTION));
    let fl = |t: u16| -> Result<Option<Vec<f64>>> {
        r.find(raw, t).map_or(Ok(None), |i| r.floats(i, t))
    };
    info.default_crop_origin = fl(tag::DEFAULT_CROP_ORIGIN)?
        .filter(|v| v.len() >= 2)
        .map(|v| [v[0], v[1]]);
    info.default_crop_size = fl(tag::DEFAULT_CROP_SIZE)?
        .filter(|v| v.len() >= 2)
        .map(|v| [v[0], v[1]]);
    info.color_matrix1 = fl(tag::COLOR_MATRIX_1)?
        .filter(|v| v.len() >= 9)
        .map(|v| [[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]]);
    info.as_shot_neutral = fl(tag::AS_SHOT_NEUTRAL)?
        .filter(|v| v.len() >= 3)
        .map(|v| [v[0], v[1], v[2]]);
    info.calibration_illuminant1 =
        fl(tag::CALIBRATION_ILLUMINANT_1)?.and_then(|v| v.first().map(|x| *x as u16));
    info.exposure_s = fl(tag::EXPOSURE_TIME)?
        .and_then(|v| v.first().copied())
        .filter(|v| *v > 0.0);
    info.iso = fl(tag::ISO_SPEED)?.and_then(|v| v.first().copied());
    let (res_t, unit_t) = if r.find(raw, tag::FOCAL_PLANE_X_RESOLUTION_EP).is_some() {
        (
            tag::FOCAL_PLANE_X_RESOLUTION_EP,
            tag::FOCAL_PLANE_RESOLUTION_UNIT_EP,
        )
    } else {
        (
            tag::FOCAL_PLANE_X_RESOLUTION,
            tag::FOCAL_PLANE_RESOLUTION_UNIT,
        )
    };
    let res = fl(res_t)?.and_then(|v| v.first().copied()).unwrap_or(0.0);
    let unit_m = match fl(unit_t)?.and_then(|v| v.first().copied()).unwrap_or(2.0) as u32 {
        3 => 0.01,
        4 => 0.001,
        5 => 1e-6,
        _ => 0.0254, // 2 = inch (the TIFF default)
    };
    Ok(if res > 0.0 && res.is_finite() {
        unit_m / res
    } else {
        0.0
    })
}

/// The CFA of a raw IFD, with CFAPlaneColor mapping plane indices to TIFF/EP colours: a Bayer
/// pattern (layout `None`), or any N x M pattern (N, M <= 8) of red, green, blue, cyan, magenta,
/// yellow and white cells as a [`CfaLayout`] (with `CfaPattern::Rggb` as the unused Bayer field).
fn cfa_pattern(r: &Reader, raw: &Ifd) -> Result<(CfaPattern, Option<CfaLayout>)> {
    let dim = r
        .uints(raw, tag::CFA_REPEAT_PATTERN_DIM)?
        .unwrap_or_else(|| vec![2, 2]);
    let max = camsim_core::cfa::MAX_CFA_SIDE as u64;
    if dim.len() < 2 || !(1..=max).contains(&dim[0]) || !(1..=max).contains(&dim[1]) {
        return r.fail(format!(
            "CFARepeatPatternDim {dim:?}: expected two sides of 1..={max} cells"
        ));
    }
    let (n, m) = (dim[0] as usize, dim[1] as usize);
    let Some(codes) = r.uints(raw, tag::CFA_PATTERN)? else {
        return r.fail("no CFAPattern tag");
    };
    if codes.len() < n * m {
        return r.fail(format!(
            "CFAPattern has {} values; expected {}",
            codes.len(),
            n * m
        ));
    }
    let plane = r
        .uints(raw, tag::CFA_PLANE_COLOR)?
        .unwrap_or_else(|| vec![0, 1, 2]);
    let mapped: Vec<u8> = codes[..n * m]
        .iter()
        .map(|c| plane.get(*c as usize).copied().unwrap_or(99).min(255) as u8)
        .collect();
    if n == 2 && m == 2 {
        if let Some(cfa) = CfaPattern::from_dng_codes(&mapped) {
            return Ok((cfa, None));
        }
    }
    match CfaLayout::from_dng_codes(n, m, &mapped) {
        Ok(l) => Ok(match l.as_bayer() {
            Some(p) => (p, None),
            None => (CfaPattern::Rggb, Some(l)),
        }),
        Err(e) => r.fail(format!("CFAPattern {:?}: {e}", &codes[..n * m])),
    }
}

/// One strip or tile: where its data is and where it goes.
struct Segment {
    offset: usize,
    len: usize,
    x0: usize,
    y0: usize,
    /// Width and height of the segment as stored (tiles include their padding).
    w: usize,
    h: usize,
}

fn segments(r: &Reader, raw: &Ifd, width: usize, height: usize) -> Result<Vec<Segment>> {
    let get = |t: u16| r.uints(raw, t);
    let mut out = Vec::new();
    if let Some(offs) = get(tag::TILE_OFFSETS)? {
        let tw = r.uint(raw, tag::TILE_WIDTH)?.unwrap_or(0) as usize;
        let th = r.uint(raw, tag::TILE_LENGTH)?.unwrap_or(0) as usize;
        if tw == 0 || th == 0 || tw > 1 << 16 || th > 1 << 16 {
            return r.fail(format!("tile size {tw} x {th} is not plausible"));
        }
        let across = width.div_ceil(tw);
        let down = height.div_ceil(th);
        let counts = get(tag::TILE_BYTE_COUNTS)?.unwrap_or_default();
        if offs.len() < across * down || counts.len() < across * down {
            return r.fail(format!(
                "{} tile offsets and {} byte counts for {across} x {down} tiles",
                offs.len(),
                counts.len()
            ));
        }
        for ty in 0..down {
            for tx in 0..across {
                let k = ty * across + tx;
                out.push(Segment {
                    offset: offs[k] as usize,
                    len: counts[k] as usize,
                    x0: tx * tw,
                    y0: ty * th,
                    w: tw,
                    h: th,
                });
            }
        }
    } else if let Some(offs) = get(tag::STRIP_OFFSETS)? {
        let rps =
            (r.uint(raw, tag::ROWS_PER_STRIP)?.unwrap_or(height as u64) as usize).clamp(1, height);
        let n = height.div_ceil(rps);
        let counts = get(tag::STRIP_BYTE_COUNTS)?;
        if offs.len() < n {
            return r.fail(format!(
                "{} strip offsets for {n} strips of {rps} rows",
                offs.len()
            ));
        }
        for (s, &offset) in offs.iter().enumerate().take(n) {
            let len = match &counts {
                Some(c) => *c.get(s).ok_or_else(|| {
                    IoError::format(
                        r.path,
                        format!("{} strip byte counts for {n} strips", c.len()),
                    )
                })? as usize,
                None => usize::MAX, // bounded below by the file size
            };
            out.push(Segment {
                offset: offset as usize,
                len,
                x0: 0,
                y0: s * rps,
                w: width,
                h: rps.min(height - s * rps),
            });
        }
    } else {
        return r.fail("raw IFD has neither StripOffsets nor TileOffsets");
    }
    Ok(out)
}

fn decode_pixels(
    r: &Reader,
    raw: &Ifd,
    width: usize,
    height: usize,
    spp: usize,
    bps: u32,
    compression: u64,
) -> Result<Vec<u16>> {
    let data = r.t.data;
    // Interleaved samples: a pixel row holds width x spp samples (chunky, PlanarConfiguration 1).
    let mut img = vec![0u16; width * height * spp];
    let mut seg_buf: Vec<u16> = Vec::new();
    for (si, s) in segments(r, raw, width, height)?.into_iter().enumerate() {
        if s.offset >= data.len() {
            return r.fail(format!(
                "segment {si} starts at offset {} beyond the end of the file ({} bytes)",
                s.offset,
                data.len()
            ));
        }
        let avail = data.len() - s.offset;
        let bytes = &data[s.offset..s.offset + s.len.min(avail)];
        let valid_w = (width - s.x0).min(s.w) * spp;
        let valid_h = (height - s.y0).min(s.h);
        let sw = s.w * spp;
        seg_buf.clear();
        seg_buf.resize(sw * s.h, 0);
        match compression {
            1 => unpack(bytes, &mut seg_buf, sw, valid_h, bps, r.t.little_endian)
                .map_err(|m| IoError::format(r.path, format!("segment {si}: {m}")))?,
            7 => {
                let j = crate::ljpeg::decode(bytes, sw * s.h)
                    .map_err(|e| IoError::format(r.path, format!("segment {si}: {e}")))?;
                let need = sw * valid_h;
                if j.samples.len() < need {
                    return r.fail(format!(
                        "segment {si}: lossless JPEG holds {} samples ({} x {} x {}); the {} x {} segment needs {need}",
                        j.samples.len(),
                        j.width,
                        j.height,
                        j.components,
                        s.w,
                        valid_h
                    ));
                }
                // DNG: only the sample count must match; samples fill the segment in order.
                let n = j.samples.len().min(seg_buf.len());
                seg_buf[..n].copy_from_slice(&j.samples[..n]);
            }
            c => {
                return r.fail(format!(
                    "Compression {c} is not supported (only 1 = uncompressed and 7 = lossless JPEG){}",
                    match c {
                        8 => ": Deflate (floating-point DNG)",
                        34892 => ": lossy JPEG",
                        52546 => ": JPEG XL",
                        _ => "",
                    }
                ));
            }
        }
        for y in 0..valid_h {
            let dst = ((s.y0 + y) * width + s.x0) * spp;
            img[dst..dst + valid_w].copy_from_slice(&seg_buf[y * sw..y * sw + valid_w]);
        }
    }
    Ok(img)
}

/// Uncompressed samples: 8 or 16 bits (16 in the file's byte order), otherwise packed MSB-first
/// with each row starting on a byte boundary (TIFF 6.0, FillOrder 1).
fn unpack(
    bytes: &[u8],
    out: &mut [u16],
    w: usize,
    rows: usize,
    bps: u32,
    le: bool,
) -> std::result::Result<(), String> {
    let row_bytes = (w * bps as usize).div_ceil(8);
    let need = row_bytes * rows;
    if bytes.len() < need {
        return Err(format!(
            "{} bytes of pixel data where {rows} rows of {w} {bps}-bit samples need {need}",
            bytes.len()
        ));
    }
    for y in 0..rows {
        let src = &bytes[y * row_bytes..(y + 1) * row_bytes];
        let dst = &mut out[y * w..(y + 1) * w];
        match bps {
            16 => {
                for (d, c) in dst.iter_mut().zip(src.chunks_exact(2)) {
                    *d = if le {
                        u16::from_le_bytes([c[0], c[1]])
                    } else {
                        u16::from_be_bytes([c[0], c[1]])
                    };
                }
            }
            8 => {
                for (d, c) in dst.iter_mut().zip(src) {
                    *d = *c as u16;
                }
            }
            _ => {
                let mut acc: u32 = 0;
                let mut n: u32 = 0;
                let mut it = src.iter();
                for d in dst.iter_mut() {
                    while n < bps {
                        acc = (acc << 8) | *it.next().unwrap_or(&0) as u32;
                        n += 8;
                    }
                    *d = ((acc >> (n - bps)) & ((1 << bps) - 1)) as u16;
                    n -= bps;
                    acc &= (1 << n) - 1;
                }
            }
        }
    }
    Ok(())
}

/// Build a DNG in memory from a raw IFD spec (for tests and tools that assemble DNGs
/// themselves): `segments` are the encoded strips/tiles in order.
pub fn assemble_tiff(
    spec: &IfdSpec,
    segments: &[Vec<u8>],
    little_endian: bool,
) -> std::result::Result<Vec<u8>, String> {
    let mut out = crate::tiff::layout(spec, little_endian)?;
    for s in segments {
        out.extend_from_slice(s);
        if s.len() & 1 == 1 {
            out.push(0);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ljpeg::tests::encode as ljpeg_encode;

    fn lcg(seed: u64) -> impl FnMut() -> u64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s >> 33
        }
    }

    fn base_tags(
        w: usize,
        h: usize,
        bps: u16,
        compression: u16,
        cfa: [u8; 4],
    ) -> Vec<(u16, Value)> {
        vec![
            (tag::NEW_SUBFILE_TYPE, Value::Long(vec![0])),
            (tag::IMAGE_WIDTH, Value::Long(vec![w as u32])),
            (tag::IMAGE_LENGTH, Value::Short(vec![h as u16])),
            (tag::BITS_PER_SAMPLE, Value::Short(vec![bps])),
            (tag::COMPRESSION, Value::Short(vec![compression])),
            (tag::PHOTOMETRIC, Value::Short(vec![PHOTOMETRIC_CFA])),
            (tag::SAMPLES_PER_PIXEL, Value::Short(vec![1])),
            (tag::CFA_REPEAT_PATTERN_DIM, Value::Short(vec![2, 2])),
            (tag::CFA_PATTERN, Value::Byte(cfa.to_vec())),
        ]
    }

    fn spec_like(s: &IfdSpec) -> IfdSpec {
        IfdSpec {
            tags: s.tags.clone(),
            segment_offsets_tag: s.segment_offsets_tag,
            segment_counts_tag: s.segment_counts_tag,
            segment_lens: s.segment_lens.clone(),
            sub_ifds: vec![],
            exif_tags: vec![],
        }
    }

    fn pack_msb(values: &[u16], w: usize, bps: u32) -> Vec<u8> {
        let mut out = Vec::new();
        for row in values.chunks(w) {
            let (mut acc, mut n) = (0u64, 0u32);
            for v in row {
                acc = (acc << bps) | *v as u64;
                n += bps;
                while n >= 8 {
                    out.push((acc >> (n - 8)) as u8);
                    n -= 8;
                }
            }
            if n > 0 {
                out.push((acc << (8 - n)) as u8);
            }
        }
        out
    }

    #[test]
    fn camsim_write_read_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("raw.dng");
        let mut next = lcg(5);
        for (k, cfa) in [
            CfaPattern::Rggb,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
            CfaPattern::Bggr,
        ]
        .into_iter()
        .enumerate()
        {
            let (rows, cols) = (37 + k, 50 + 3 * k);
            let mut raw = RawImage::new(rows, cols, cfa, 12).unwrap();
            raw.dn.iter_mut().for_each(|v| *v = (next() % 4096) as u16);
            raw.black_level_dn = 64.0 + 0.25 * k as f64;
            raw.exposure_s = 1.0 / 60.0;
            raw.pixel_pitch_m = 1.4e-6;
            let cm = [[0.9, -0.3, -0.05], [-0.4, 1.25, 0.12], [-0.08, 0.2, 0.55]];
            let meta = DngMetadata {
                camera_model: "camsim imx363".into(),
                color_matrix1: Some(cm),
                as_shot_neutral: Some([0.5, 1.0, 0.625]),
                description: Some(r#"{"seed":7,"sensor":"imx363"}"#.into()),
                ..Default::default()
            };
            write_dng(&path, &raw, &meta).unwrap();
            let (back, info) = read_dng(&path).unwrap();
            assert_eq!((back.rows, back.cols, back.cfa), (rows, cols, cfa));
            assert_eq!(back.dn, raw.dn, "pixels differ for {}", cfa.name());
            assert_eq!(back.black_level_dn, raw.black_level_dn);
            assert_eq!(back.white_level_dn, 4095.0);
            assert_eq!(back.bits, 12);
            assert!((back.exposure_s * 60.0 - 1.0).abs() < 1e-12);
            assert!((back.pixel_pitch_m / 1.4e-6 - 1.0).abs() < 1e-6);
            assert_eq!(info.dng_version, Some([1, 4, 0, 0]));
            assert_eq!(info.unique_camera_model.as_deref(), Some("camsim imx363"));
            assert_eq!(info.description, meta.description);
            assert_eq!(info.orientation, 1);
            assert_eq!(info.compression, 1);
            assert_eq!(info.calibration_illuminant1, Some(ILLUMINANT_D65));
            let m = info.color_matrix1.unwrap();
            for i in 0..3 {
                for j in 0..3 {
                    assert!((m[i][j] - cm[i][j]).abs() < 1e-6);
                }
            }
            assert_eq!(info.as_shot_neutral, Some([0.5, 1.0, 0.625]));
            // Manual check with other readers (exiftool, rawpy): CAMSIM_DNG_DIR=/some/dir.
            if let Ok(d) = std::env::var("CAMSIM_DNG_DIR") {
                std::fs::copy(
                    &path,
                    Path::new(&d).join(format!("camsim_{}.dng", cfa.name())),
                )
                .unwrap();
            }
        }
    }

    #[test]
    fn reads_big_endian_tiles_in_a_sub_ifd_with_linearization_active_area_and_black_pattern() {
        let (w, h, tw, th) = (24usize, 20usize, 8usize, 8usize);
        let mut next = lcg(11);
        let stored: Vec<u16> = (0..w * h).map(|_| (next() % 1024) as u16).collect();
        // Tiles, 16-bit big-endian, padded at the bottom edge (20 rows = 2.5 tiles).
        let mut tiles = Vec::new();
        for ty in 0..h.div_ceil(th) {
            for tx in 0..w.div_ceil(tw) {
                let mut t = Vec::new();
                for y in 0..th {
                    for x in 0..tw {
                        let (r, c) = (ty * th + y, tx * tw + x);
                        let v = if r < h && c < w {
                            stored[r * w + c]
                        } else {
                            0xABCD
                        };
                        t.extend_from_slice(&v.to_be_bytes());
                    }
                }
                tiles.push(t);
            }
        }
        let mut tags = base_tags(w, h, 16, 1, [1, 0, 2, 1]); // GRBG
        tags.push((tag::TILE_WIDTH, Value::Short(vec![tw as u16])));
        tags.push((tag::TILE_LENGTH, Value::Short(vec![th as u16])));
        tags.push((tag::ACTIVE_AREA, Value::Long(vec![2, 3, 18, 21])));
        tags.push((
            tag::LINEARIZATION_TABLE,
            Value::Short((0..1024).map(|i| 2 * i as u16).collect()),
        ));
        tags.push((tag::BLACK_LEVEL_REPEAT_DIM, Value::Short(vec![2, 2])));
        tags.push((tag::BLACK_LEVEL, Value::Long(vec![10, 20, 30, 40])));
        tags.push((tag::WHITE_LEVEL, Value::Short(vec![2046])));
        tags.push((tag::DEFAULT_CROP_ORIGIN, Value::Short(vec![1, 1])));
        tags.push((tag::DEFAULT_CROP_SIZE, Value::Short(vec![16, 14])));
        let raw_ifd = IfdSpec {
            tags,
            segment_offsets_tag: tag::TILE_OFFSETS,
            segment_counts_tag: tag::TILE_BYTE_COUNTS,
            segment_lens: tiles.iter().map(|t| t.len() as u64).collect(),
            sub_ifds: vec![],
            exif_tags: vec![],
        };
        // IFD0: a 4 x 4 RGB preview, as cameras write.
        let thumb = vec![200u8; 48];
        let ifd0 = IfdSpec {
            tags: vec![
                (tag::NEW_SUBFILE_TYPE, Value::Long(vec![1])),
                (tag::IMAGE_WIDTH, Value::Long(vec![4])),
                (tag::IMAGE_LENGTH, Value::Long(vec![4])),
                (tag::BITS_PER_SAMPLE, Value::Short(vec![8, 8, 8])),
                (tag::COMPRESSION, Value::Short(vec![1])),
                (tag::PHOTOMETRIC, Value::Short(vec![2])),
                (tag::SAMPLES_PER_PIXEL, Value::Short(vec![3])),
                (tag::ORIENTATION, Value::Short(vec![6])),
                (tag::MAKE, Value::Ascii("TestMaker".into())),
                (tag::DNG_VERSION, Value::Byte(vec![1, 4, 0, 0])),
                (tag::UNIQUE_CAMERA_MODEL, Value::Ascii("Test Phone".into())),
            ],
            segment_offsets_tag: tag::STRIP_OFFSETS,
            segment_counts_tag: tag::STRIP_BYTE_COUNTS,
            segment_lens: vec![48],
            sub_ifds: vec![raw_ifd],
            exif_tags: vec![],
        };
        let mut segs = vec![thumb];
        segs.extend(tiles);
        let bytes = assemble_tiff(&ifd0, &segs, false).unwrap();
        let (img, info) = read_dng_bytes(&bytes, Path::new("be.dng")).unwrap();
        assert_eq!((img.rows, img.cols), (16, 18));
        for r in 0..16 {
            for c in 0..18 {
                assert_eq!(
                    img.at(r, c),
                    2 * stored[(r + 2) * w + c + 3],
                    "pixel {r},{c}"
                );
            }
        }
        assert_eq!(img.cfa, CfaPattern::Grbg);
        assert_eq!(info.black_level_cfa_dn, [10.0, 20.0, 30.0, 40.0]);
        assert_eq!(img.black_level_dn, 25.0);
        assert_eq!(img.white_level_dn, 2046.0);
        assert_eq!(img.bits, 11);
        assert!(info.linearized);
        assert_eq!(info.orientation, 6);
        assert_eq!(info.make.as_deref(), Some("TestMaker"));
        assert_eq!(info.stored_size, (20, 24));
        assert_eq!(info.active_area, [2, 3, 18, 21]);
        assert_eq!(info.default_crop_origin, Some([1.0, 1.0]));
        assert_eq!(info.default_crop_size, Some([16.0, 14.0]));
    }

    #[test]
    fn reads_lossless_jpeg_tiles_with_two_components() {
        // A phone-style DNG: 32 x 16 raw in 16 x 16 tiles, each tile a lossless JPEG of
        // 8 columns x 16 rows x 2 components (so the predictor works across like colours).
        // (LibRaw, used for the manual check below, wants at least 22 x 22 pixels.)
        let (w, h, tw, th) = (48usize, 32usize, 16usize, 16usize);
        let mut next = lcg(3);
        let stored: Vec<u16> = (0..w * h)
            .map(|i| ((i % w) * 80 + (next() % 200) as usize) as u16 % 4096)
            .collect();
        let mut tiles = Vec::new();
        for ty in 0..h / th {
            for tx in 0..w / tw {
                let mut s = Vec::new();
                for y in ty * th..(ty + 1) * th {
                    s.extend_from_slice(&stored[y * w + tx * tw..y * w + tx * tw + tw]);
                }
                tiles.push(ljpeg_encode(tw / 2, th, 2, 12, 1, 0, &s));
            }
        }
        let mut tags = base_tags(w, h, 12, 7, [0, 1, 1, 2]);
        tags.push((tag::TILE_WIDTH, Value::Long(vec![tw as u32])));
        tags.push((tag::TILE_LENGTH, Value::Long(vec![th as u32])));
        tags.push((tag::BLACK_LEVEL, Value::Rational(vec![(1025, 16)])));
        tags.push((tag::WHITE_LEVEL, Value::Long(vec![4095])));
        tags.push((tag::DNG_VERSION, Value::Byte(vec![1, 4, 0, 0])));
        tags.push((tag::UNIQUE_CAMERA_MODEL, Value::Ascii("ljpeg test".into())));
        tags.push((
            tag::COLOR_MATRIX_1,
            Value::SRational(vec![
                (1, 1),
                (0, 1),
                (0, 1),
                (0, 1),
                (1, 1),
                (0, 1),
                (0, 1),
                (0, 1),
                (1, 1),
            ]),
        ));
        let spec = IfdSpec {
            tags,
            segment_offsets_tag: tag::TILE_OFFSETS,
            segment_counts_tag: tag::TILE_BYTE_COUNTS,
            segment_lens: tiles.iter().map(|t| t.len() as u64).collect(),
            sub_ifds: vec![],
            exif_tags: vec![],
        };
        let bytes = assemble_tiff(&spec, &tiles, true).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ljpeg.dng");
        std::fs::write(&path, &bytes).unwrap();
        let (img, info) = read_dng(&path).unwrap();
        assert_eq!(info.compression, 7);
        assert_eq!(img.dn, stored);
        if let Ok(d) = std::env::var("CAMSIM_DNG_DIR") {
            // For a manual check of the test encoder against LibRaw (rawpy): the raw values.
            std::fs::copy(&path, Path::new(&d).join("ljpeg_tiles.dng")).unwrap();
            let txt: Vec<String> = stored.iter().map(|v| v.to_string()).collect();
            std::fs::write(Path::new(&d).join("ljpeg_tiles.txt"), txt.join(" ")).unwrap();
        }
        assert_eq!(img.cfa, CfaPattern::Rggb);
        assert_eq!(img.black_level_dn, 1025.0 / 16.0);
        // A strip of one-component lossless JPEG with restarts, predictor 6.
        let s1 = ljpeg_encode(w, h, 1, 12, 6, w, &stored);
        let mut tags = base_tags(w, h, 12, 7, [2, 1, 1, 0]);
        tags.push((tag::ROWS_PER_STRIP, Value::Long(vec![h as u32])));
        tags.push((tag::DNG_VERSION, Value::Byte(vec![1, 4, 0, 0])));
        tags.push((tag::UNIQUE_CAMERA_MODEL, Value::Ascii("ljpeg test".into())));
        let spec = IfdSpec {
            tags,
            segment_offsets_tag: tag::STRIP_OFFSETS,
            segment_counts_tag: tag::STRIP_BYTE_COUNTS,
            segment_lens: vec![s1.len() as u64],
            sub_ifds: vec![],
            exif_tags: vec![],
        };
        let bytes = assemble_tiff(&spec, &[s1], true).unwrap();
        let (img, _) = read_dng_bytes(&bytes, Path::new("strip.dng")).unwrap();
        assert_eq!(img.dn, stored);
        if let Ok(d) = std::env::var("CAMSIM_DNG_DIR") {
            std::fs::write(Path::new(&d).join("ljpeg_strip_p6_rst.dng"), &bytes).unwrap();
            for (p, rst) in [
                (1u8, 0usize),
                (2, 0),
                (3, 0),
                (4, 0),
                (5, 0),
                (6, 0),
                (7, 0),
                (1, w),
                (1, 2 * w),
            ] {
                let s1 = ljpeg_encode(w, h, 1, 12, p, rst, &stored);
                let spec = IfdSpec {
                    segment_lens: vec![s1.len() as u64],
                    ..spec_like(&spec)
                };
                let b = assemble_tiff(&spec, &[s1], true).unwrap();
                std::fs::write(Path::new(&d).join(format!("ljpeg_p{p}_rst{rst}.dng")), &b).unwrap();
            }
        }
        assert_eq!(img.cfa, CfaPattern::Bggr);
    }

    #[test]
    fn reads_8_bit_and_packed_10_12_14_bit_strips() {
        let (w, h) = (13usize, 6usize); // odd width: packed rows end mid-byte
        for bps in [8u32, 10, 12, 14] {
            let mut next = lcg(bps as u64);
            let vals: Vec<u16> = (0..w * h).map(|_| (next() % (1 << bps)) as u16).collect();
            let packed = pack_msb(&vals, w, bps);
            let row_bytes = (w * bps as usize).div_ceil(8);
            let strips: Vec<Vec<u8>> = packed.chunks(row_bytes * 4).map(|c| c.to_vec()).collect();
            let mut tags = base_tags(w, h, bps as u16, 1, [0, 1, 1, 2]);
            tags.push((tag::ROWS_PER_STRIP, Value::Long(vec![4])));
            let spec = IfdSpec {
                tags,
                segment_offsets_tag: tag::STRIP_OFFSETS,
                segment_counts_tag: tag::STRIP_BYTE_COUNTS,
                segment_lens: strips.iter().map(|s| s.len() as u64).collect(),
                sub_ifds: vec![],
                exif_tags: vec![],
            };
            let bytes = assemble_tiff(&spec, &strips, true).unwrap();
            let (img, _) = read_dng_bytes(&bytes, Path::new("packed.dng")).unwrap();
            assert_eq!(img.dn, vals, "{bps} bits");
            assert_eq!(img.white_level_dn, ((1u32 << bps) - 1) as f64);
        }
    }

    #[test]
    fn reads_a_hand_built_linear_raw_dng_with_active_area_and_per_sample_levels() {
        // 5 x 4 stored pixels of 3 big-endian 16-bit samples, ActiveArea rows 1..4, cols 1..4:
        // sample s of pixel (r, c) = 1000 s + 10 r + c, so every value names its place.
        let (w, h) = (4usize, 5usize);
        let mut bytes = Vec::new();
        for r in 0..h {
            for c in 0..w {
                for s in 0..3 {
                    bytes.extend_from_slice(&((1000 * s + 10 * r + c) as u16).to_be_bytes());
                }
            }
        }
        let spec = IfdSpec {
            tags: vec![
                (tag::NEW_SUBFILE_TYPE, Value::Long(vec![0])),
                (tag::IMAGE_WIDTH, Value::Long(vec![w as u32])),
                (tag::IMAGE_LENGTH, Value::Long(vec![h as u32])),
                (tag::BITS_PER_SAMPLE, Value::Short(vec![16, 16, 16])),
                (tag::COMPRESSION, Value::Short(vec![1])),
                (tag::PHOTOMETRIC, Value::Short(vec![PHOTOMETRIC_LINEAR_RAW])),
                (tag::SAMPLES_PER_PIXEL, Value::Short(vec![3])),
                (tag::ROWS_PER_STRIP, Value::Long(vec![2])),
                (tag::PLANAR_CONFIGURATION, Value::Short(vec![1])),
                (tag::DNG_VERSION, Value::Byte(vec![1, 4, 0, 0])),
                (tag::BLACK_LEVEL_REPEAT_DIM, Value::Short(vec![1, 1])),
                (tag::BLACK_LEVEL, Value::Long(vec![5, 6, 7])),
                (tag::WHITE_LEVEL, Value::Long(vec![4000, 4001, 4002])),
                (tag::ACTIVE_AREA, Value::Long(vec![1, 1, 4, 4])),
            ],
            segment_offsets_tag: tag::STRIP_OFFSETS,
            segment_counts_tag: tag::STRIP_BYTE_COUNTS,
            segment_lens: vec![48, 48, 24],
            sub_ifds: vec![],
            exif_tags: vec![],
        };
        let segs = vec![
            bytes[..48].to_vec(),
            bytes[48..96].to_vec(),
            bytes[96..].to_vec(),
        ];
        let t = assemble_tiff(&spec, &segs, false).unwrap();
        let (img, info) = read_dng_image_bytes(&t, Path::new("lin.dng")).unwrap();
        let DngImage::LinearRaw(img) = img else {
            panic!("expected a LinearRaw image")
        };
        assert_eq!((img.rows, img.cols), (3, 3));
        assert_eq!(info.active_area, [1, 1, 4, 4]);
        for r in 0..3 {
            for c in 0..3 {
                for s in 0..3 {
                    assert_eq!(img.at(r, c, s) as usize, 1000 * s + 10 * (r + 1) + c + 1);
                }
            }
        }
        assert_eq!(img.black_level_dn, [5.0, 6.0, 7.0]);
        assert_eq!(img.white_level_dn, [4000.0, 4001.0, 4002.0]);
        // The CFA reader refuses it and says why.
        let e = read_dng_bytes(&t, Path::new("lin.dng"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("LinearRaw"), "{e}");
    }

    #[test]
    fn linear_raw_write_read_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lin.dng");
        let mut next = lcg(9);
        let (rows, cols) = (7, 11);
        let img = LinearRawImage {
            rows,
            cols,
            dn: (0..rows * cols * 3)
                .map(|_| (next() % 65536) as u16)
                .collect(),
            black_level_dn: [64.0, 65.0, 66.5],
            white_level_dn: [65535.0, 60000.0, 50000.0],
            exposure_s: 0.01,
            pixel_pitch_m: 0.0, // (a pitch comes back through a rational: not bit-exact)
        };
        write_linear_raw_dng(&path, &img, &DngMetadata::default()).unwrap();
        let (back, info) = read_dng_image(&path).unwrap();
        assert_eq!(back, DngImage::LinearRaw(img.clone()), "{info:?}");
        assert!(write_linear_raw_dng(
            &path,
            &LinearRawImage { rows: 8, ..img },
            &DngMetadata::default()
        )
        .is_err());
    }

    fn small_valid_dng() -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.dng");
        let mut raw = RawImage::new(8, 10, CfaPattern::Rggb, 10).unwrap();
        raw.dn
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = i as u16);
        write_dng(&path, &raw, &DngMetadata::default()).unwrap();
        std::fs::read(&path).unwrap()
    }

    #[test]
    fn truncated_garbage_and_unsupported_files_are_errors() {
        let good = small_valid_dng();
        for n in 0..good.len() {
            let r = read_dng_bytes(&good[..n], Path::new("cut.dng"));
            assert!(
                r.is_err(),
                "truncated at {n} of {} was accepted",
                good.len()
            );
            assert!(r.unwrap_err().to_string().starts_with("cut.dng: "));
        }
        assert!(read_dng_bytes(b"garbage garbage garbage", Path::new("g.dng")).is_err());
        // A plain RGB TIFF has no CFA image.
        let spec = IfdSpec {
            tags: vec![
                (tag::IMAGE_WIDTH, Value::Long(vec![2])),
                (tag::IMAGE_LENGTH, Value::Long(vec![2])),
                (tag::PHOTOMETRIC, Value::Short(vec![2])),
            ],
            segment_offsets_tag: tag::STRIP_OFFSETS,
            segment_counts_tag: tag::STRIP_BYTE_COUNTS,
            segment_lens: vec![12],
            sub_ifds: vec![],
            exif_tags: vec![],
        };
        let t = assemble_tiff(&spec, &[vec![0; 12]], true).unwrap();
        let e = read_dng_bytes(&t, Path::new("rgb.tif"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no raw image"), "{e}");
        let e = read_dng(Path::new("/nonexistent/x.dng"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.dng"));
    }

    #[test]
    fn mutated_files_never_panic() {
        let good = small_valid_dng();
        let mut next = lcg(77);
        for _ in 0..3000 {
            let mut b = good.clone();
            for _ in 0..1 + next() % 4 {
                let i = (next() as usize) % b.len();
                b[i] = next() as u8;
            }
            let _ = read_dng_bytes(&b, Path::new("m.dng"));
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]
        #[test]
        fn random_bytes_never_panic(mut bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600), le in proptest::prelude::any::<bool>()) {
            if bytes.len() >= 8 {
                // A valid header half the time, so the IFD parser gets exercised.
                bytes[..4].copy_from_slice(if le { b"II*\0" } else { b"MM\0*" });
                bytes[4..8].copy_from_slice(&if le { 8u32.to_le_bytes() } else { 8u32.to_be_bytes() });
            }
            let _ = read_dng_bytes(&bytes, Path::new("p.dng"));
            let _ = crate::ljpeg::decode(&bytes, 1 << 16);
        }
    }
}
