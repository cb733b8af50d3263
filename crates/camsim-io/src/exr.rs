//! Spectral OpenEXR in the layout of Fichet, Pacanowski & Wilkie 2021, "An OpenEXR Layout for
//! Spectral Images" (JCGT 10(3)), as pbrt-v4's `SpectralFilm` writes it: one channel per
//! wavelength named `S0.<wavelength>nm` with a comma as decimal point (`S0.550,000000nm`; the
//! comma because OpenEXR uses '.' to separate layers), header attributes
//! `spectralLayoutVersion` = "1.0" and `emissiveUnits`.
//!
//! `emissiveUnits` follows pbrt-v4 (film.cpp, `SpectralFilm::GetImage`) and the paper: the
//! per-nanometre is implied by the wavelength axis, so radiance is "W.m^-2.sr^-1" and irradiance
//! "W.m^-2". camsim adds its own attributes (all optional on reading):
//!
//! | attribute | type | meaning |
//! |---|---|---|
//! | `camsimQuantity` | string | `radiance`, `irradiance` or `relative` |
//! | `camsimUnits` | string | the unit of the values written out, e.g. `W.sr^-1.m^-2.nm^-1` |
//! | `camsimStage` | string | the pipeline stage that wrote the file (`scene`, `optics`, `render`) |
//! | `camsimSampleSpacingM` | double | distance between neighbouring samples in the image's plane, m |
//! | `camsimFovDeg` | double | horizontal field of view, degrees |
//! | `camsimDistanceM` | double | scene distance, m |
//! | `camsimFocalLengthM` | double | focal length of the optics that formed the image, m |
//! | `camsimFNumber` | double | f-number of those optics |
//! | `camsimStartNm`, `camsimStepNm` | double | the exact wavelength grid (channel names carry 6 decimals) |
//!
//! An optional depth map travels as channel `Z` (m, OpenEXR's conventional depth channel name).

use crate::error::{IoError, Result};
use camsim_core::image::ImageGeometry;
use camsim_core::names::{NameTable, Named};
use camsim_core::{mem, CoreError, Quantity, SpectralImage, WavelengthGrid};
use exr::prelude::*;
use rayon::prelude::*;
use std::path::Path;

/// `spectralLayoutVersion` written and understood.
pub const SPECTRAL_LAYOUT_VERSION: &str = "1.0";
/// Sample spacing assumed when a file does not carry `camsimSampleSpacingM` (pbrt-v4 files):
/// 1 um. [`SpectralExrInfo::sample_spacing_known`] is false then, so callers can substitute the
/// real value (from the camera's film size).
pub const DEFAULT_SAMPLE_SPACING_M: f64 = 1e-6;

/// pbrt-v4's spectral radiance over camsim's W/(sr m^2 nm) for the same scene: camsim reads a
/// pbrt-v4 emitter's normalised spectrum as photometric, `L / 683` W/(sr m^2 nm) (camsim-pbrt),
/// and pbrt-v4's `SpectralFilm::AddSample` multiplies radiance by `CIE_Y_integral` =
/// 106.856895 nm (src/pbrt/film.h), so pbrt-v4 writes camsim's radiance times 683 x 106.856895.
pub const PBRT_V4_RADIANCE_UNIT: f64 = 683.0 * 106.856895;

/// How the values of a spectral EXR are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SourceUnits {
    /// pbrt-v4's own files (recognised by [`is_pbrt_v4_header`]) are converted from pbrt-v4's
    /// units, every other file is read as it is.
    #[default]
    Auto,
    /// The file is pbrt-v4 output: divide by [`PBRT_V4_RADIANCE_UNIT`].
    PbrtV4,
    /// The values are W/(sr m^2 nm) (or the file's own `camsimQuantity`): no conversion.
    Absolute,
}

/// Whether an EXR header is pbrt-v4's `SpectralFilm` output: no camsim attributes, pbrt-v4's
/// `emissiveUnits` "W.m^-2.sr^-1" with a `spectralLayoutVersion`, and either one of the
/// attributes pbrt-v4's `Image::WriteEXR` adds (`worldToCamera`, `worldToNDC`,
/// `renderTimeSeconds`, `samplesPerPixel`) or pbrt-v4's channel set (R, G, B beside the `S0.`
/// channels). `attribute` names the header's attributes, `channels` its channels.
pub fn is_pbrt_v4_header<'a>(
    attribute: impl Fn(&str) -> Option<String>,
    mut channels: impl Iterator<Item = &'a str>,
) -> bool {
    let camsim = ["camsimStage", "camsimQuantity", "camsimUnits"]
        .iter()
        .any(|k| attribute(k).is_some());
    let pbrt_units = attribute("emissiveUnits").as_deref() == Some("W.m^-2.sr^-1")
        && attribute("spectralLayoutVersion").is_some();
    let pbrt_attrs = [
        "worldToCamera",
        "worldToNDC",
        "renderTimeSeconds",
        "samplesPerPixel",
    ]
    .iter()
    .any(|k| attribute(k).is_some());
    let (mut rgb, mut spectral) = (0, false);
    for c in channels.by_ref() {
        if matches!(c, "R" | "G" | "B") {
            rgb += 1;
        }
        spectral |= c.starts_with("S0.");
    }
    !camsim && pbrt_units && (pbrt_attrs || (rgb == 3 && spectral))
}

/// The horizontal field of view, degrees, of a pbrt-v4 perspective camera from the matrices
/// pbrt-v4 writes (`worldToNDC` = T(1/2) S(1/2) Perspective(fov) `worldToCamera`,
/// pbrt-v4 `ProjectiveCamera::InitMetadata`; row-major, column vectors): NDC-from-camera's
/// `[0][0] / [3][2]` is `1 / (2 tan(fov / 2))`, `fov` across the image's shorter side, here
/// `cols` x `rows`. `None` when the matrices are not a perspective projection.
pub fn pbrt_v4_horizontal_fov_deg(
    world_to_camera: &[f32; 16],
    world_to_ndc: &[f32; 16],
    cols: usize,
    rows: usize,
) -> Option<f64> {
    let m = |a: &[f32; 16], i: usize, j: usize| a[i * 4 + j] as f64;
    // camera_to_world: the inverse of the affine worldToCamera (adjugate of its 3 x 3 part).
    let w = |i, j| m(world_to_camera, i, j);
    let det = w(0, 0) * (w(1, 1) * w(2, 2) - w(1, 2) * w(2, 1))
        - w(0, 1) * (w(1, 0) * w(2, 2) - w(1, 2) * w(2, 0))
        + w(0, 2) * (w(1, 0) * w(2, 1) - w(1, 1) * w(2, 0));
    if !(det.abs() > 1e-12 && det.is_finite()) {
        return None;
    }
    let mut inv = [[0.0f64; 4]; 4];
    for i in 0..3 {
        for j in 0..3 {
            let (a, b) = ((j + 1) % 3, (j + 2) % 3);
            let (c, d) = ((i + 1) % 3, (i + 2) % 3);
            inv[i][j] = (w(a, c) * w(b, d) - w(a, d) * w(b, c)) / det;
        }
    }
    for i in 0..3 {
        inv[i][3] = -(0..3).map(|k| inv[i][k] * w(k, 3)).sum::<f64>();
    }
    inv[3][3] = 1.0;
    // NDC from camera = worldToNDC * cameraToWorld: entries [0][0] and [3][2].
    let a = |i: usize, j: usize| {
        (0..4)
            .map(|k| m(world_to_ndc, i, k) * inv[k][j])
            .sum::<f64>()
    };
    let (a00, a32) = (a(0, 0), a(3, 2));
    let tan_half = a32 / (2.0 * a00);
    if !(tan_half > 0.0 && tan_half.is_finite()) || cols == 0 || rows == 0 {
        return None;
    }
    let aspect = cols as f64 / rows as f64;
    let tan_h = if aspect >= 1.0 {
        tan_half * aspect
    } else {
        tan_half
    };
    Some(2.0 * tan_h.atan().to_degrees())
}

/// What a spectral EXR's header said, beyond the image itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SpectralExrInfo {
    /// `camsimStage`, if present.
    pub stage: Option<String>,
    /// `emissiveUnits`, if present.
    pub emissive_units: Option<String>,
    /// `spectralLayoutVersion`, if present.
    pub spectral_layout_version: Option<String>,
    /// True when the file carried `camsimSampleSpacingM`; otherwise the image holds
    /// [`DEFAULT_SAMPLE_SPACING_M`].
    pub sample_spacing_known: bool,
    /// True when the file carried `camsimQuantity`; otherwise the quantity was inferred from
    /// `emissiveUnits` (radiance when in doubt).
    pub quantity_known: bool,
    /// Names of channels that were not spectral and were ignored (e.g. pbrt-v4's R, G, B).
    pub ignored_channels: Vec<String>,
    /// Number of round-off-sized negative samples (|v| <= [`NEGATIVE_ROUNDOFF_FRACTION`] x the
    /// image's largest value) that were clamped to 0 on reading.
    pub clamped_negatives: usize,
    /// The most negative of those clamped samples (0 when none).
    pub most_negative_clamped: f32,
    /// The values were pbrt-v4's (recognised by [`is_pbrt_v4_header`], or so declared with
    /// [`SourceUnits::PbrtV4`]) and were divided by [`PBRT_V4_RADIANCE_UNIT`] into
    /// W/(sr m^2 nm).
    pub pbrt_v4_units_converted: bool,
    /// True when the horizontal field of view came from pbrt-v4's `worldToCamera` and
    /// `worldToNDC` ([`pbrt_v4_horizontal_fov_deg`]; the image's `geometry.fov_deg`).
    pub fov_from_pbrt_v4_camera: bool,
}

/// Negative samples whose magnitude is at most this fraction of the image's largest value are
/// FFT round-off, not signal, and are clamped to 0 on reading (larger ones are refused). f32
/// round-off of an FFT convolution grows like eps log2(N) of the largest value (eps = 1.19e-7,
/// Oppenheim & Schafer, Discrete-Time Signal Processing, sec. 9.7): about 1e-6 for the tile sizes
/// in use, e.g. -3.4e-10 against a maximum of 1.7e-3 (2e-7) in a blurred irradiance. 1e-5 leaves a
/// margin of 10 and is still below one step of a 16-bit quantizer (1.5e-5), so nothing a camera
/// could record is clamped.
pub const NEGATIVE_ROUNDOFF_FRACTION: f32 = 1e-5;

/// The channel name of wavelength `wavelength_nm`: `S0.550,000000nm`.
pub fn spectral_channel_name(wavelength_nm: f64) -> String {
    format!("S0.{:.6}nm", wavelength_nm)
        .replace('.', ",")
        .replacen("S0,", "S0.", 1)
}

/// The wavelength in nm of an emissive spectral channel (`S0.<value><unit>`, unit nm, um or pm;
/// decimal comma or point), or `None` when the channel is not an emissive (S0) channel.
/// `Some(Err(..))` when it is one but its wavelength cannot be read.
pub fn parse_spectral_channel(name: &str) -> Option<std::result::Result<f64, String>> {
    let rest = if let Some(r) = name.strip_prefix("S0.") {
        r
    } else {
        // A layer prefix ("spectral.S0.550,0nm").
        let i = name.find(".S0.")?;
        &name[i + 4..]
    };
    let (number, scale) = if let Some(n) = rest.strip_suffix("nm") {
        (n, 1.0)
    } else if let Some(n) = rest.strip_suffix("um") {
        (n, 1e3)
    } else if let Some(n) = rest.strip_suffix("pm") {
        (n, 1e-3)
    } else {
        return Some(Err(format!(
            "channel '{name}': wavelength unit is not nm, um or pm"
        )));
    };
    match number.replace(',', ".").parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Some(Ok(v * scale)),
        _ => Some(Err(format!(
            "channel '{name}': '{number}' is not a positive wavelength"
        ))),
    }
}

/// `emissiveUnits` for a quantity (pbrt-v4 / Fichet et al. convention, per nm implied).
fn emissive_units(q: Quantity) -> Option<&'static str> {
    match q {
        Quantity::Radiance => Some("W.m^-2.sr^-1"),
        Quantity::Irradiance => Some("W.m^-2"),
        Quantity::Relative => None,
    }
}

fn text(path: &Path, s: &str) -> Result<Text> {
    Text::new_or_none(s).ok_or_else(|| {
        IoError::invalid(
            path,
            format!("'{s}' cannot be stored as an EXR text attribute"),
        )
    })
}

fn exr_err(path: &Path, e: exr::error::Error) -> IoError {
    use std::io::ErrorKind;
    match e {
        // The file could not be opened: the operating system's reason is the message.
        exr::error::Error::Io(io)
            if matches!(io.kind(), ErrorKind::NotFound | ErrorKind::PermissionDenied) =>
        {
            IoError::io(path, io)
        }
        // An I/O error while decoding an opened file is the file's fault: a seek to a damaged
        // offset ("Invalid argument") or a read past its end ("unexpected end of file").
        exr::error::Error::Io(io) => {
            let why = if io.kind() == ErrorKind::UnexpectedEof {
                "it ends before its data does"
            } else {
                "an offset or size in it points outside the file"
            };
            IoError::format(
                path,
                format!(
                    "damaged or truncated OpenEXR file ({why}); export it again or use another file"
                ),
            )
        }
        other => IoError::format(
            path,
            format!("not a readable OpenEXR file: {other}; export it again or use another file"),
        ),
    }
}

/// Sample precision of a written spectral EXR.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExrPrecision {
    /// 32-bit float: every value comes back bit-exact (default).
    #[default]
    F32,
    /// 16-bit half float: half the size; relative error <= 2^-11, range 6e-8 .. 65504 (values
    /// below ~6e-5 lose relative precision: scale radiance and irradiance images accordingly).
    F16,
}

/// Compression of a written EXR (all lossless; blocks are compressed on every thread).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExrCompression {
    /// None (default): the fastest to write and read, the largest file (on 2 cores ZIP writes
    /// f32 spectral data at ~80 MB/s against ~2 GB/s uncompressed and saves only a third of the size).
    #[default]
    None,
    /// Run-length: fast, gains only on flat images.
    Rle,
    /// ZIP over blocks of 16 scan lines: smaller files (f16 data compresses well), slow to write.
    Zip,
    /// ZIP per scan line (faster to read a few lines).
    Zips,
    /// Wavelet (PIZ): good on noisy photographic data.
    Piz,
}

impl ExrCompression {
    fn compression(self) -> exr::compression::Compression {
        use exr::compression::Compression as C;
        match self {
            ExrCompression::None => C::Uncompressed,
            ExrCompression::Rle => C::RLE,
            ExrCompression::Zip => C::ZIP16,
            ExrCompression::Zips => C::ZIP1,
            ExrCompression::Piz => C::PIZ,
        }
    }
}

/// How spectral EXRs are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct ExrOptions {
    pub precision: ExrPrecision,
    pub compression: ExrCompression,
}

/// The EXR sample precisions by name (`--exr-precision`, Python's `exr_precision=`).
pub const EXR_PRECISIONS: NameTable<ExrPrecision> = NameTable {
    family: "EXR precision",
    entries: &[
        Named {
            name: "f32",
            aliases: &[],
            about: "32-bit float: every value comes back bit-exact",
            value: ExrPrecision::F32,
        },
        Named {
            name: "f16",
            aliases: &[],
            about: "16-bit half float: half the size, relative error <= 2^-11",
            value: ExrPrecision::F16,
        },
    ],
};

/// The EXR compressions by name (`--exr-compression`, Python's `exr_compression=`).
pub const EXR_COMPRESSIONS: NameTable<ExrCompression> = NameTable {
    family: "EXR compression",
    entries: &[
        Named {
            name: "none",
            aliases: &[],
            about: "fastest to write and read, largest",
            value: ExrCompression::None,
        },
        Named {
            name: "rle",
            aliases: &[],
            about: "run-length: fast, gains only on flat images",
            value: ExrCompression::Rle,
        },
        Named {
            name: "zip",
            aliases: &[],
            about: "ZIP over 16 scan lines: smallest, slow to write",
            value: ExrCompression::Zip,
        },
        Named {
            name: "zips",
            aliases: &[],
            about: "ZIP per scan line",
            value: ExrCompression::Zips,
        },
        Named {
            name: "piz",
            aliases: &[],
            about: "wavelet: good on noisy photographic data",
            value: ExrCompression::Piz,
        },
    ],
};

impl ExrOptions {
    /// The options by name ([`EXR_PRECISIONS`], [`EXR_COMPRESSIONS`]).
    pub fn parse(precision: &str, compression: &str) -> std::result::Result<ExrOptions, CoreError> {
        Ok(ExrOptions {
            precision: EXR_PRECISIONS.get(precision)?,
            compression: EXR_COMPRESSIONS.get(compression)?,
        })
    }
}

/// One channel of an EXR to write: its name, its `rows * cols` samples (row-major) and the
/// precision they are stored with.
struct Plane<'a> {
    name: Text,
    samples: &'a [f32],
    precision: ExrPrecision,
}

impl ExrPrecision {
    fn sample_type(self) -> SampleType {
        match self {
            ExrPrecision::F32 => SampleType::F32,
            ExrPrecision::F16 => SampleType::F16,
        }
    }
}

/// Bytes of one batch of blocks assembled before compression ([`mem::WRITE_BATCH_BYTES`]).
const BATCH_BYTES: usize = mem::WRITE_BATCH_BYTES;

/// Write `planes` as one scan-line layer, streaming: blocks of scan lines are assembled and
/// compressed on every thread a batch at a time (about [`BATCH_BYTES`]) and written in order
/// through the exr crate's block API, so no copy of the whole image is ever made. Atomic.
fn write_planes(
    path: &Path,
    rows: usize,
    cols: usize,
    planes: Vec<Plane<'_>>,
    attrs: LayerAttributes,
    compression: ExrCompression,
) -> Result<()> {
    write_planes_in_batches(path, rows, cols, planes, attrs, compression, BATCH_BYTES)
}

/// [`write_planes`] with the batch size given (tests write many small batches).
fn write_planes_in_batches(
    path: &Path,
    rows: usize,
    cols: usize,
    mut planes: Vec<Plane<'_>>,
    attrs: LayerAttributes,
    compression: ExrCompression,
    batch_bytes: usize,
) -> Result<()> {
    use exr::block::{chunk::Chunk, writer::ChunksWriter, UncompressedBlock};
    use exr::meta::attribute::ChannelDescription;
    use exr::meta::header::Header;
    // OpenEXR lists channels in increasing byte order of their names (what `AnyChannels::sort` does).
    planes.sort_by(|a, b| a.name.cmp(&b.name));
    let channels = planes
        .iter()
        .map(|p| ChannelDescription {
            name: p.name.clone(),
            sample_type: p.precision.sample_type(),
            quantize_linearly: ChannelDescription::guess_quantization_linearity(&p.name),
            sampling: Vec2(1, 1),
        })
        .collect();
    let custom: Vec<Vec<u8>> = attrs.other.keys().map(|k| k.as_slice().to_vec()).collect();
    // camsim's signature (a later run may replace a file that carries it: crate::claim).
    let mut attrs = attrs;
    attrs.software_name = Some(Text::from(crate::software::SOFTWARE));
    let header = Header::new(Text::from("camsim"), (cols, rows), channels)
        .with_encoding(
            compression.compression(),
            exr::meta::BlockDescription::ScanLines,
            LineOrder::Increasing,
        )
        .with_attributes(attrs);
    let planes = &planes;
    let pixel_bytes: usize = planes
        .iter()
        .map(|p| p.precision.sample_type().bytes_per_sample())
        .sum();
    // One block's uncompressed bytes: for each of its lines, each channel's samples of that line
    // (native byte order; the crate converts to little-endian when it compresses).
    let assemble = |index: exr::block::BlockIndex| -> UncompressedBlock {
        let (x0, width) = (index.pixel_position.x(), index.pixel_size.width());
        let lines = index.pixel_position.y()..index.pixel_position.y() + index.pixel_size.height();
        let mut data = vec![0u8; lines.len() * width * pixel_bytes];
        let mut rest = data.as_mut_slice();
        for y in lines {
            for p in planes {
                let row = &p.samples[y * cols + x0..y * cols + x0 + width];
                let bytes = p.precision.sample_type().bytes_per_sample();
                let (dst, tail) = rest.split_at_mut(width * bytes);
                rest = tail;
                // Element-wise copies of fixed size: the compiler turns these into vector moves.
                match p.precision {
                    ExrPrecision::F32 => dst
                        .chunks_exact_mut(4)
                        .zip(row)
                        .for_each(|(d, v)| d.copy_from_slice(&v.to_ne_bytes())),
                    ExrPrecision::F16 => dst
                        .chunks_exact_mut(2)
                        .zip(row)
                        .for_each(|(d, v)| d.copy_from_slice(&f16::from_f32(*v).to_ne_bytes())),
                }
            }
        }
        UncompressedBlock { index, data }
    };
    crate::atomic::with_temp_path(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| IoError::io(path, e))?;
        let out = std::io::BufWriter::with_capacity(1 << 20, file);
        exr::block::write(out, std::iter::once(header).collect(), true, |meta, writer| {
            let blocks: Vec<_> = exr::block::enumerate_ordered_header_block_indices(&meta.headers).collect();
            let block_bytes = blocks.first().map_or(1, |(_, b)| b.pixel_size.area() * pixel_bytes);
            let batch = (batch_bytes / block_bytes.max(1)).max(2 * rayon::current_num_threads());
            let compress = |group: &[(usize, exr::block::BlockIndex)]| -> Vec<exr::error::Result<(usize, Chunk)>> {
                group.par_iter().map(|&(i, index)| assemble(index).compress_to_chunk(&meta.headers).map(|c| (i, c))).collect()
            };
            let mut write = |chunks: Vec<exr::error::Result<(usize, Chunk)>>| -> exr::error::UnitResult {
                for c in chunks {
                    let (i, chunk) = c?;
                    writer.write_chunk(i, chunk)?;
                }
                Ok(())
            };
            // Batch k is written while batch k + 1 is assembled and compressed.
            let mut pending = Vec::new();
            for group in blocks.chunks(batch) {
                let (written, next) = rayon::join(|| write(std::mem::take(&mut pending)), || compress(group));
                written?;
                pending = next;
            }
            write(pending)?;
            Ok(())
        })
        .map_err(|e| exr_err(path, e))?;
        sort_custom_attributes(tmp, &custom).map_err(|e| IoError::io(path, e))
    })
}

/// The exr crate keeps custom header attributes in a `std::collections::HashMap`, whose order
/// changes from run to run (its hasher is seeded randomly), so the same image would give
/// different bytes. Sort them by name in place: the crate writes them last in the header, one
/// after another, and sorting keeps their total length, so the chunk offsets stay valid.
/// Header layout (OpenEXR file layout): magic and version (8 bytes), then attributes
/// `name\0 type\0 size (i32 LE) value`, ended by a 0 byte.
fn sort_custom_attributes(file: &Path, custom: &[Vec<u8>]) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom, Write};
    if custom.len() < 2 {
        return Ok(());
    }
    let bad = |what: &str| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("EXR header as written: {what}"),
        )
    };
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(file)?;
    let mut head = Vec::new();
    (&mut f).take(1 << 20).read_to_end(&mut head)?;
    let nul_from = |at: usize| {
        head.get(at..)
            .and_then(|h| h.iter().position(|&b| b == 0))
            .map(|i| at + i)
            .ok_or_else(|| bad("unterminated name"))
    };
    let mut spans = Vec::new(); // (name, start, end)
    let mut at = 8;
    while *head.get(at).ok_or_else(|| bad("no end of header"))? != 0 {
        let name_end = nul_from(at)?;
        let type_end = nul_from(name_end + 1)?;
        let size = head
            .get(type_end + 1..type_end + 5)
            .ok_or_else(|| bad("attribute size"))?;
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let end =
            type_end + 5 + usize::try_from(size).map_err(|_| bad("negative attribute size"))?;
        spans.push((&head[at..name_end], at, end));
        at = end;
    }
    let first = spans
        .iter()
        .position(|(n, _, _)| custom.iter().any(|c| c == n))
        .ok_or_else(|| bad("custom attributes missing"))?;
    let mut mine: Vec<_> = spans[first..].to_vec();
    if mine.len() != custom.len() || mine.iter().any(|(n, _, _)| !custom.iter().any(|c| c == n)) {
        return Err(bad("custom attributes not written last"));
    }
    let (start, end) = (mine[0].1, mine[mine.len() - 1].2);
    mine.sort_by(|a, b| a.0.cmp(b.0));
    let sorted: Vec<u8> = mine
        .iter()
        .flat_map(|(_, s, e)| head[*s..*e].iter().copied())
        .collect();
    debug_assert_eq!(sorted.len(), end - start);
    f.seek(SeekFrom::Start(start as u64))?;
    f.write_all(&sorted)
}

/// Write a spectral image as a spectral OpenEXR (see the module doc for the layout), with the
/// pipeline stage that produced it. Writes the depth map as channel `Z` when present.
/// The file is written atomically, f32 and uncompressed ([`write_spectral_exr_with`] chooses).
pub fn write_spectral_exr(path: &Path, img: &SpectralImage, stage: &str) -> Result<()> {
    write_spectral_exr_with(path, img, stage, ExrOptions::default())
}

/// Whether the OpenEXR file at `path` carries camsim's signature: a `software` header attribute
/// that starts with `camsim` (only the header is read).
pub fn written_by_camsim(path: &Path) -> bool {
    exr::meta::MetaData::read_from_file(path, false).is_ok_and(|m| {
        m.headers.iter().any(|h| {
            h.own_attributes
                .software_name
                .as_ref()
                .is_some_and(|t| t.to_string().starts_with("camsim"))
        })
    })
}

/// [`write_spectral_exr`] with a choice of sample precision and compression.
pub fn write_spectral_exr_with(
    path: &Path,
    img: &SpectralImage,
    stage: &str,
    options: ExrOptions,
) -> Result<()> {
    let n = img.pixels();
    if n == 0 || img.bands() == 0 || img.data.len() != n * img.bands() {
        return Err(IoError::invalid(
            path,
            format!(
                "spectral image has {} values for {} x {} x {} bands",
                img.data.len(),
                img.rows,
                img.cols,
                img.bands()
            ),
        ));
    }
    let mut planes = Vec::with_capacity(img.bands() + 1);
    for b in 0..img.bands() {
        planes.push(Plane {
            name: text(path, &spectral_channel_name(img.grid.wavelength_nm(b)))?,
            samples: img.band(b),
            precision: options.precision,
        });
    }
    if let Some(d) = &img.depth_m {
        if d.len() != n {
            return Err(IoError::invalid(
                path,
                format!("depth map has {} values for {} pixels", d.len(), n),
            ));
        }
        // Depth stays f32 whatever the spectral precision: half floats would lose millimetres.
        planes.push(Plane {
            name: Text::from("Z"),
            samples: d,
            precision: ExrPrecision::F32,
        });
    }
    let mut attrs = LayerAttributes::default();
    let o = &mut attrs.other;
    o.insert(
        Text::from("spectralLayoutVersion"),
        AttributeValue::Text(Text::from(SPECTRAL_LAYOUT_VERSION)),
    );
    if let Some(u) = emissive_units(img.quantity) {
        o.insert(
            Text::from("emissiveUnits"),
            AttributeValue::Text(Text::from(u)),
        );
    }
    o.insert(
        Text::from("camsimQuantity"),
        AttributeValue::Text(Text::from(img.quantity.name())),
    );
    o.insert(
        Text::from("camsimUnits"),
        AttributeValue::Text(Text::from(img.quantity.unit())),
    );
    o.insert(
        Text::from("camsimStage"),
        AttributeValue::Text(text(path, stage)?),
    );
    let g = &img.geometry;
    for (k, v) in [
        ("camsimSampleSpacingM", img.sample_spacing_m),
        ("camsimFovDeg", g.fov_deg),
        ("camsimDistanceM", g.distance_m),
        ("camsimFocalLengthM", g.focal_length_m),
        ("camsimFNumber", g.f_number),
        ("camsimStartNm", img.grid.start_nm),
        ("camsimStepNm", img.grid.step_nm),
    ] {
        o.insert(Text::from(k), AttributeValue::F64(v));
    }
    write_planes(path, img.rows, img.cols, planes, attrs, options.compression)
}

fn attr_f64(a: &LayerAttributes, key: &str) -> Option<f64> {
    match a.other.get(&Text::from(key))? {
        AttributeValue::F64(v) => Some(*v),
        AttributeValue::F32(v) => Some(*v as f64),
        AttributeValue::I32(v) => Some(*v as f64),
        _ => None,
    }
}

fn attr_text(a: &LayerAttributes, key: &str) -> Option<String> {
    match a.other.get(&Text::from(key))? {
        AttributeValue::Text(t) => Some(t.to_string()),
        _ => None,
    }
}

type AnyImage = Image<Layers<AnyChannels<FlatSamples>>>;

/// Read every layer and channel of an EXR, refusing files whose pixels would not fit in memory
/// (checked from the header before the pixels are read) and turning any failure into an error.
fn read_any(path: &Path) -> Result<AnyImage> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let meta = exr::meta::MetaData::read_from_buffered(std::io::BufReader::new(file), false)
        .map_err(|e| exr_err(path, e))?;
    let mut bytes: u64 = 0;
    for h in meta.headers.iter() {
        if h.deep {
            return Err(IoError::format(path, "deep OpenEXR data is not supported"));
        }
        let area = (h.layer_size.width() as u64).saturating_mul(h.layer_size.height() as u64);
        bytes = bytes.saturating_add(
            area.saturating_mul(h.channels.list.len() as u64)
                .saturating_mul(8),
        );
    }
    mem::check_alloc(bytes, &format!("the pixels of {}", path.display()))
        .map_err(|e| IoError::core(path, e))?;
    let p = path.to_path_buf();
    let result = std::panic::catch_unwind(move || {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_file(&p)
    });
    match result {
        Ok(r) => r.map_err(|e| exr_err(path, e)),
        Err(_) => Err(IoError::format(
            path,
            "malformed OpenEXR file (the decoder gave up)",
        )),
    }
}

fn samples_into_f32(s: FlatSamples) -> Vec<f32> {
    match s {
        FlatSamples::F32(v) => v,
        FlatSamples::F16(v) => v.into_iter().map(|x| x.to_f32()).collect(),
        FlatSamples::U32(v) => v.into_iter().map(|x| x as f32).collect(),
    }
}

/// Read a spectral OpenEXR written by camsim or pbrt-v4 (or any writer of the Fichet et al.
/// layout). See [`read_spectral_exr_with_info`].
pub fn read_spectral_exr(path: &Path) -> Result<SpectralImage> {
    read_spectral_exr_with_info(path).map(|(img, _)| img)
}

/// Read a spectral OpenEXR and report what its header said. Uses the first layer with emissive
/// `S0.*` channels (reflective `T.*` channels are read as a relative image when there are no
/// emissive ones); other channels are ignored, except `Z` (depth, m). The wavelengths must form
/// a uniform grid; f16 and u32 channels are converted to f32; NaN or infinite values are refused
/// with the pixel and wavelength named; negative values are clamped to 0 when round-off-sized
/// (see [`NEGATIVE_ROUNDOFF_FRACTION`]; counted in [`SpectralExrInfo::clamped_negatives`]),
/// refused with the file, channel, pixel and value named otherwise. Missing camsim attributes get defaults:
/// quantity from `emissiveUnits` (radiance when unknown), sample spacing
/// [`DEFAULT_SAMPLE_SPACING_M`], geometry zero.
///
/// pbrt-v4's own files ([`is_pbrt_v4_header`]) are converted to W/(sr m^2 nm) and take their
/// field of view from pbrt-v4's camera matrices: see [`read_spectral_exr_as`].
pub fn read_spectral_exr_with_info(path: &Path) -> Result<(SpectralImage, SpectralExrInfo)> {
    read_spectral_exr_as(path, SourceUnits::Auto)
}

/// [`read_spectral_exr_with_info`] with the source units chosen: with [`SourceUnits::Auto`] a
/// file recognised as pbrt-v4's (or any file with [`SourceUnits::PbrtV4`]) is divided by
/// [`PBRT_V4_RADIANCE_UNIT`], and where it carries pbrt-v4's `worldToCamera` and `worldToNDC`
/// its `geometry.fov_deg` is the horizontal field of view they give.
pub fn read_spectral_exr_as(
    path: &Path,
    units: SourceUnits,
) -> Result<(SpectralImage, SpectralExrInfo)> {
    let image = read_any(path)?;
    let mut info = SpectralExrInfo::default();
    let image_attrs = image.attributes.other.clone();
    let mut layers: Vec<_> = image.layer_data.into_iter().collect();
    let has = |l: &Layer<AnyChannels<FlatSamples>>, prefix: &str| {
        l.channel_data.list.iter().any(|c| {
            let n = c.name.to_string();
            n.starts_with(prefix) || n.contains(&format!(".{prefix}"))
        })
    };
    let (index, reflective) = match layers.iter().position(|l| has(l, "S0.")) {
        Some(i) => (i, false),
        None => match layers.iter().position(|l| has(l, "T.")) {
            Some(i) => (i, true),
            None => {
                return Err(IoError::format(
                    path,
                    "no spectral channels: expected channels named like 'S0.550,000000nm' (Fichet et al. 2021 / pbrt-v4 layout)",
                ))
            }
        },
    };
    let layer = layers.swap_remove(index);
    let rows = layer.size.height();
    let cols = layer.size.width();
    let n = rows * cols;
    let mut attrs = layer.attributes;
    // Header attributes the exr crate keeps with the image rather than the layer.
    for (k, v) in image_attrs {
        attrs.other.entry(k).or_insert(v);
    }
    // OpenEXR's standard `worldToCamera` and `worldToNDC` (the exr crate keeps them apart).
    let (world_to_camera, world_to_ndc) = (attrs.world_to_camera, attrs.world_to_normalized_device);
    let pbrt_v4 = match units {
        SourceUnits::Auto => is_pbrt_v4_header(
            |k| match k {
                "worldToCamera" => world_to_camera.map(|_| String::new()),
                "worldToNDC" => world_to_ndc.map(|_| String::new()),
                _ => attrs.other.get(&Text::from(k)).map(|v| match v {
                    AttributeValue::Text(t) => t.to_string(),
                    _ => String::new(),
                }),
            },
            layer
                .channel_data
                .list
                .iter()
                .map(|c| c.name.as_slice())
                .filter_map(|b| std::str::from_utf8(b).ok()),
        ),
        SourceUnits::PbrtV4 => true,
        SourceUnits::Absolute => false,
    };
    let mut planes: Vec<(f64, String, Vec<f32>)> = Vec::new();
    let mut depth: Option<Vec<f32>> = None;
    for ch in layer.channel_data.list.into_iter() {
        let name = ch.name.to_string();
        let parsed = if reflective {
            let t = name
                .strip_prefix("T.")
                .map(|r| format!("S0.{r}"))
                .or_else(|| name.find(".T.").map(|i| format!("S0.{}", &name[i + 3..])));
            t.and_then(|s| parse_spectral_channel(&s))
        } else {
            parse_spectral_channel(&name)
        };
        match parsed {
            Some(Ok(w)) => {
                let v = samples_into_f32(ch.sample_data);
                if v.len() != n {
                    return Err(IoError::format(
                        path,
                        format!(
                            "channel '{name}' has {} samples for {rows} x {cols} pixels",
                            v.len()
                        ),
                    ));
                }
                planes.push((w, name, v));
            }
            Some(Err(m)) => return Err(IoError::format(path, m)),
            None if name == "Z" => {
                let v = samples_into_f32(ch.sample_data);
                if v.len() == n {
                    depth = Some(v);
                }
            }
            None => info.ignored_channels.push(name),
        }
    }
    planes.sort_by(|a, b| a.0.total_cmp(&b.0));
    for w in planes.windows(2) {
        if (w[1].0 - w[0].0).abs() < 1e-9 {
            return Err(IoError::format(
                path,
                format!(
                    "channels '{}' and '{}' have the same wavelength",
                    w[0].1, w[1].1
                ),
            ));
        }
    }
    // Round-off-sized negatives are clamped to 0 (and counted); real negatives are refused.
    let max_value = planes
        .iter()
        .flat_map(|p| p.2.iter())
        .filter(|v| v.is_finite())
        .fold(0.0f32, |m, v| m.max(*v));
    let limit = NEGATIVE_ROUNDOFF_FRACTION * max_value;
    for (_, name, v) in planes.iter_mut() {
        for (i, x) in v.iter_mut().enumerate() {
            if *x < 0.0 {
                if -*x <= limit {
                    info.clamped_negatives += 1;
                    info.most_negative_clamped = info.most_negative_clamped.min(*x);
                    *x = 0.0;
                } else {
                    return Err(IoError::format(
                        path,
                        format!(
                            "channel '{name}', row {}, column {}: value {x} is negative beyond round-off \
                             (more than {NEGATIVE_ROUNDOFF_FRACTION:e} x the image maximum {max_value:e}); \
                             a spectral image must be non-negative",
                            i / cols.max(1),
                            i % cols.max(1)
                        ),
                    ));
                }
            }
        }
    }
    let wavelengths: Vec<f64> = planes.iter().map(|p| p.0).collect();
    let mut grid =
        WavelengthGrid::from_wavelengths(&wavelengths).map_err(|e| IoError::core(path, e))?;
    // camsim writes the exact grid too (channel names round to 1e-6 nm).
    if let (Some(s), Some(st)) = (
        attr_f64(&attrs, "camsimStartNm"),
        attr_f64(&attrs, "camsimStepNm"),
    ) {
        let exact = WavelengthGrid {
            start_nm: s,
            step_nm: st,
            count: grid.count,
        };
        if (exact.start_nm - grid.start_nm).abs() < 1e-5
            && (exact.step_nm - grid.step_nm).abs() < 1e-5
        {
            grid = exact;
        }
    }
    mem::check_alloc((n * planes.len()) as u64 * 4, "the spectral image")
        .map_err(|e| IoError::core(path, e))?;
    let mut data = Vec::with_capacity(n * planes.len());
    for (_, _, v) in planes.into_iter() {
        data.extend_from_slice(&v); // each plane is dropped after its copy: peak stays near 1x
    }
    if pbrt_v4 {
        let k = (1.0 / PBRT_V4_RADIANCE_UNIT) as f32;
        data.par_iter_mut().for_each(|v| *v *= k);
        info.pbrt_v4_units_converted = true;
    }

    info.stage = attr_text(&attrs, "camsimStage");
    info.emissive_units = attr_text(&attrs, "emissiveUnits");
    info.spectral_layout_version = attr_text(&attrs, "spectralLayoutVersion");
    let quantity = match attr_text(&attrs, "camsimQuantity") {
        Some(q) => {
            info.quantity_known = true;
            Quantity::from_name(&q).ok_or_else(|| {
                IoError::format(
                    path,
                    format!("camsimQuantity '{q}' is not radiance, irradiance or relative"),
                )
            })?
        }
        None if reflective => Quantity::Relative,
        None => match info.emissive_units.as_deref() {
            Some(u) if !u.contains("sr") && u.starts_with("W.m^-2") => Quantity::Irradiance,
            _ => Quantity::Radiance,
        },
    };
    let spacing = match attr_f64(&attrs, "camsimSampleSpacingM") {
        Some(s) if s > 0.0 && s.is_finite() => {
            info.sample_spacing_known = true;
            s
        }
        Some(s) => {
            return Err(IoError::format(
                path,
                format!("camsimSampleSpacingM {s} is not a positive number"),
            ))
        }
        None => DEFAULT_SAMPLE_SPACING_M,
    };
    let mut img = SpectralImage::from_data(rows, cols, grid, spacing, quantity, data)
        .map_err(|e| IoError::core(path, e))?;
    let pbrt_fov = match (pbrt_v4, world_to_camera, world_to_ndc) {
        (true, Some(c), Some(ndc)) => pbrt_v4_horizontal_fov_deg(&c, &ndc, cols, rows),
        _ => None,
    };
    info.fov_from_pbrt_v4_camera = pbrt_fov.is_some();
    img.geometry = ImageGeometry {
        fov_deg: pbrt_fov.unwrap_or_else(|| attr_f64(&attrs, "camsimFovDeg").unwrap_or(0.0)),
        distance_m: attr_f64(&attrs, "camsimDistanceM").unwrap_or(0.0),
        focal_length_m: attr_f64(&attrs, "camsimFocalLengthM").unwrap_or(0.0),
        f_number: attr_f64(&attrs, "camsimFNumber").unwrap_or(0.0),
    };
    img.depth_m = depth;
    img.validate_values("spectral EXR")
        .map_err(|e| IoError::core(path, e))?;
    Ok((img, info))
}

/// Write one f32 plane (`rows * cols`, row-major) as a single-channel EXR named `channel`
/// (e.g. "Y", "Z", "R"), atomically.
pub fn write_gray_exr(
    path: &Path,
    rows: usize,
    cols: usize,
    channel: &str,
    data: &[f32],
) -> Result<()> {
    if rows == 0 || cols == 0 || data.len() != rows * cols {
        return Err(IoError::invalid(
            path,
            format!("{} values for {rows} x {cols} pixels", data.len()),
        ));
    }
    let plane = Plane {
        name: text(path, channel)?,
        samples: data,
        precision: ExrPrecision::F32,
    };
    write_planes(
        path,
        rows,
        cols,
        vec![plane],
        LayerAttributes::default(),
        ExrCompression::None,
    )
}

/// Write several f32 planes (each `rows * cols`, row-major) as one EXR with the given channel
/// names (e.g. X, Y, Z), atomically.
pub fn write_channels_exr(
    path: &Path,
    rows: usize,
    cols: usize,
    channels: &[(&str, &[f32])],
) -> Result<()> {
    let mut chans = Vec::with_capacity(channels.len());
    for (name, data) in channels {
        if rows == 0 || cols == 0 || data.len() != rows * cols {
            return Err(IoError::invalid(
                path,
                format!(
                    "channel {name}: {} values for {rows} x {cols} pixels",
                    data.len()
                ),
            ));
        }
        chans.push(Plane {
            name: text(path, name)?,
            samples: data,
            precision: ExrPrecision::F32,
        });
    }
    write_planes(
        path,
        rows,
        cols,
        chans,
        LayerAttributes::default(),
        ExrCompression::None,
    )
}

/// Read one channel of an EXR as f32, returning `(rows, cols, data)`. With `channel = None` the
/// file must have exactly one channel.
pub fn read_gray_exr(path: &Path, channel: Option<&str>) -> Result<(usize, usize, Vec<f32>)> {
    let image = read_any(path)?;
    let mut found = Vec::new();
    for layer in image.layer_data.into_iter() {
        let (rows, cols) = (layer.size.height(), layer.size.width());
        for ch in layer.channel_data.list.into_iter() {
            let name = ch.name.to_string();
            if channel.is_none() || channel == Some(name.as_str()) {
                found.push((name, rows, cols, ch.sample_data));
            }
        }
    }
    match (found.len(), channel) {
        (1, _) => {
            let (_, rows, cols, s) = found.pop().unwrap();
            Ok((rows, cols, samples_into_f32(s)))
        }
        (0, Some(c)) => Err(IoError::format(path, format!("no channel named '{c}'"))),
        (0, None) => Err(IoError::format(path, "the file has no channels")),
        (_, Some(c)) => Err(IoError::format(
            path,
            format!("more than one channel named '{c}' (in several layers)"),
        )),
        (_, None) => Err(IoError::format(
            path,
            format!(
                "has {} channels ({}); name the one to read",
                found.len(),
                found
                    .iter()
                    .map(|f| f.0.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
    }
}

/// Named f32 channels of one image, in the file's order.
pub type NamedChannels = Vec<(String, Vec<f32>)>;

/// Read every channel of an EXR as f32: `(rows, cols, [(name, data)])`, in the file's order.
/// All channels must have the same size (one layer, or layers of one size).
pub fn read_channels_exr(path: &Path) -> Result<(usize, usize, NamedChannels)> {
    let image = read_any(path)?;
    let mut size = None;
    let mut out = Vec::new();
    for layer in image.layer_data.into_iter() {
        let (rows, cols) = (layer.size.height(), layer.size.width());
        if *size.get_or_insert((rows, cols)) != (rows, cols) {
            return Err(IoError::format(path, "has layers of different sizes"));
        }
        for ch in layer.channel_data.list.into_iter() {
            out.push((ch.name.to_string(), samples_into_f32(ch.sample_data)));
        }
    }
    let (rows, cols) = size.ok_or_else(|| IoError::format(path, "the file has no layers"))?;
    Ok((rows, cols, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_image(rows: usize, cols: usize, grid: WavelengthGrid) -> SpectralImage {
        let mut img = SpectralImage::zeros(rows, cols, grid, 1.4e-6, Quantity::Irradiance).unwrap();
        // Values spanning many binades, including subnormal-free tiny and large ones, so a
        // lossy or f16 path would show.
        let mut s = 12345u64;
        for v in img.data.iter_mut() {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let m = (s >> 40) as f32 / (1u64 << 24) as f32;
            let e = ((s >> 20) % 40) as i32 - 20;
            *v = m * 2f32.powi(e);
        }
        img.geometry = ImageGeometry {
            fov_deg: 20.0,
            distance_m: 1.5,
            focal_length_m: 4.38e-3,
            f_number: 1.73,
        };
        img.depth_m = Some((0..rows * cols).map(|i| 1.0 + i as f32 * 0.25).collect());
        img
    }

    #[test]
    fn channel_names_use_a_decimal_comma() {
        assert_eq!(spectral_channel_name(550.0), "S0.550,000000nm");
        assert_eq!(spectral_channel_name(412.5), "S0.412,500000nm");
        assert_eq!(parse_spectral_channel("S0.550,000000nm"), Some(Ok(550.0)));
        assert_eq!(parse_spectral_channel("S0.418,750nm"), Some(Ok(418.75))); // pbrt-v4's %.3f
        assert_eq!(parse_spectral_channel("S0.0,55um"), Some(Ok(550.0)));
        assert_eq!(parse_spectral_channel("R"), None);
        assert_eq!(parse_spectral_channel("S1.550,0nm"), None); // polarised: not S0
        assert!(matches!(parse_spectral_channel("S0.abcnm"), Some(Err(_))));
    }

    #[test]
    fn every_compression_and_precision_round_trips_through_many_batches() {
        // 37 rows: not a multiple of ZIP's and PIZ's 16- and 32-line blocks, so the last block is
        // short; batches of a few blocks, so writing overlaps compressing many times over.
        let dir = tempfile::tempdir().unwrap();
        let full = sample_image(37, 23, WavelengthGrid::new(400.0, 700.0, 10.0).unwrap());
        // Half floats end at 65504: the f16 files get the values clamped below that.
        let mut clamped = full.clone();
        clamped.data.iter_mut().for_each(|v| *v = v.min(6.0e4));
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for compression in [
            ExrCompression::None,
            ExrCompression::Rle,
            ExrCompression::Zip,
            ExrCompression::Zips,
            ExrCompression::Piz,
        ] {
            for precision in [ExrPrecision::F32, ExrPrecision::F16] {
                let img = if precision == ExrPrecision::F16 {
                    &clamped
                } else {
                    &full
                };
                let path = dir
                    .path()
                    .join(format!("{compression:?}-{precision:?}.exr"));
                let mut planes: Vec<Plane> = (0..img.bands())
                    .map(|b| Plane {
                        name: Text::from(spectral_channel_name(img.grid.wavelength_nm(b)).as_str()),
                        samples: img.band(b),
                        precision,
                    })
                    .collect();
                planes.push(Plane {
                    name: Text::from("Z"),
                    samples: img.depth_m.as_deref().unwrap(),
                    precision: ExrPrecision::F32,
                });
                write_planes_in_batches(
                    &path,
                    img.rows,
                    img.cols,
                    planes,
                    LayerAttributes::default(),
                    compression,
                    1,
                )
                .unwrap();
                let (back, _) = read_spectral_exr_with_info(&path).unwrap();
                assert_eq!(
                    (back.rows, back.cols, back.bands()),
                    (37, 23, img.bands()),
                    "{compression:?} {precision:?}"
                );
                assert_eq!(
                    bits(back.depth_m.as_deref().unwrap()),
                    bits(img.depth_m.as_deref().unwrap()),
                    "{compression:?} {precision:?}: depth is always f32"
                );
                match precision {
                    ExrPrecision::F32 => assert_eq!(
                        bits(&back.data),
                        bits(&img.data),
                        "{compression:?}: lossless f32"
                    ),
                    ExrPrecision::F16 => {
                        // Rounding to nearest half: relative error <= 2^-11 in the normal range
                        // (6.1e-5 .. 65504); below it the absolute error is <= 2^-25.
                        for (a, b) in back.data.iter().zip(&img.data) {
                            let tol = (b.abs() * 2f32.powi(-11)).max(2f32.powi(-25));
                            assert!((a - b).abs() <= tol, "{compression:?} f16: {a} for {b}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_same_image_gives_the_same_bytes() {
        // The custom header attributes live in a randomly seeded HashMap inside the exr crate:
        // without sorting them, two writes (two maps) order them differently.
        let dir = tempfile::tempdir().unwrap();
        let img = sample_image(5, 4, WavelengthGrid::new(400.0, 700.0, 50.0).unwrap());
        let bytes: Vec<Vec<u8>> = (0..4)
            .map(|i| {
                let p = dir.path().join(format!("{i}.exr"));
                write_spectral_exr(&p, &img, "scene").unwrap();
                std::fs::read(&p).unwrap()
            })
            .collect();
        assert!(bytes.windows(2).all(|w| w[0] == w[1]));
        let (back, info) = read_spectral_exr_with_info(&dir.path().join("0.exr")).unwrap();
        assert_eq!(back.data, img.data);
        assert_eq!(
            (info.stage.as_deref(), back.geometry),
            (Some("scene"), img.geometry)
        );
    }

    #[test]
    fn round_trip_is_bit_exact_with_metadata_and_depth() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("irr.exr");
        let img = sample_image(7, 5, WavelengthGrid::new(400.0, 700.0, 10.0).unwrap());
        write_spectral_exr(&path, &img, "optics").unwrap();
        let (back, info) = read_spectral_exr_with_info(&path).unwrap();
        assert_eq!((back.rows, back.cols), (7, 5));
        assert!(back.grid.same_as(&img.grid));
        assert_eq!(back.grid, img.grid);
        assert_eq!(back.quantity, Quantity::Irradiance);
        assert_eq!(back.sample_spacing_m, 1.4e-6);
        assert_eq!(back.geometry, img.geometry);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.data), bits(&img.data));
        assert_eq!(
            bits(back.depth_m.as_ref().unwrap()),
            bits(img.depth_m.as_ref().unwrap())
        );
        assert_eq!(info.stage.as_deref(), Some("optics"));
        assert_eq!(info.emissive_units.as_deref(), Some("W.m^-2"));
        assert_eq!(info.spectral_layout_version.as_deref(), Some("1.0"));
        assert!(info.sample_spacing_known && info.quantity_known);
        // Sorted by wavelength even where the names would sort differently (1000 < 950 as text).
        let g = WavelengthGrid::new(900.0, 1050.0, 50.0).unwrap();
        let mut img2 = sample_image(2, 3, g);
        img2.quantity = Quantity::Radiance;
        img2.depth_m = None;
        write_spectral_exr(&path, &img2, "scene").unwrap();
        let back2 = read_spectral_exr(&path).unwrap();
        assert_eq!(bits(&back2.data), bits(&img2.data));
        assert_eq!(back2.depth_m, None);
    }

    /// A file as pbrt-v4's SpectralFilm writes it: R, G, B plus `S0.%.3fnm` bucket centres,
    /// half floats, `emissiveUnits` "W.m^-2.sr^-1", no camsim attributes.
    fn write_pbrt_like(path: &Path, names: &[&str], value: impl Fn(usize, usize) -> f32) {
        write_pbrt_like_with(path, names, value, &[]);
    }

    /// As [`write_pbrt_like`], with extra header attributes (pbrt-v4's camera matrices).
    fn write_pbrt_like_with(
        path: &Path,
        names: &[&str],
        value: impl Fn(usize, usize) -> f32,
        extra: &[(&str, AttributeValue)],
    ) {
        let (rows, cols) = (3, 4);
        let mut chans = Vec::new();
        for (k, n) in ["R", "G", "B"].iter().chain(names.iter()).enumerate() {
            let v: Vec<f16> = (0..rows * cols)
                .map(|i| f16::from_f32(value(k, i)))
                .collect();
            chans.push(AnyChannel::new(*n, FlatSamples::F16(v)));
        }
        let mut attrs = LayerAttributes::default();
        attrs.other.insert(
            Text::from("spectralLayoutVersion"),
            AttributeValue::Text(Text::from("1.0")),
        );
        attrs.other.insert(
            Text::from("emissiveUnits"),
            AttributeValue::Text(Text::from("W.m^-2.sr^-1")),
        );
        for (k, v) in extra {
            match (*k, v) {
                ("worldToCamera", AttributeValue::Matrix4x4(m)) => attrs.world_to_camera = Some(*m),
                ("worldToNDC", AttributeValue::Matrix4x4(m)) => {
                    attrs.world_to_normalized_device = Some(*m)
                }
                _ => {
                    attrs.other.insert(Text::from(*k), v.clone());
                }
            }
        }
        let layer = Layer::new(
            (cols, rows),
            attrs,
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(chans.into_iter().collect()),
        );
        Image::from_layer(layer).write().to_file(path).unwrap();
    }

    #[test]
    fn reads_pbrt_v4_spectral_output() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pbrt.exr");
        // pbrt-v4 default: 16 buckets over 360-830 nm; here 4 buckets of 100 nm: centres 410..710.
        let names = [
            "S0.410,000nm",
            "S0.510,000nm",
            "S0.610,000nm",
            "S0.710,000nm",
        ];
        write_pbrt_like(&path, &names, |k, i| 0.5 * k as f32 + 0.125 * i as f32);
        let (img, info) = read_spectral_exr_as(&path, SourceUnits::Absolute).unwrap();
        assert!(!info.pbrt_v4_units_converted);
        assert_eq!(img.bands(), 4);
        assert!(img
            .grid
            .same_as(&WavelengthGrid::new(410.0, 710.0, 100.0).unwrap()));
        assert_eq!(img.quantity, Quantity::Radiance);
        assert!(!info.sample_spacing_known && !info.quantity_known);
        assert_eq!(img.sample_spacing_m, DEFAULT_SAMPLE_SPACING_M);
        assert_eq!(info.ignored_channels.len(), 3);
        // Band b is channel k = b + 3; values are exact in f16 (multiples of 1/8 below 16).
        for b in 0..4 {
            for i in 0..12 {
                assert_eq!(img.band(b)[i], 0.5 * (b + 3) as f32 + 0.125 * i as f32);
            }
        }
    }

    /// pbrt-v4's files are recognised by their header and converted from pbrt-v4's units
    /// (x 683 x 106.856895, pbrt-v4 `SpectralFilm::AddSample` and camsim-pbrt's photometric
    /// reading of emitters); the field of view comes from pbrt-v4's camera matrices, written
    /// here as pbrt-v4's `ProjectiveCamera::InitMetadata` builds them for a camera looking
    /// along world -x from (1, 2, 3) with fov 40 across the shorter side of a 4 x 3 image.
    #[test]
    fn pbrt_v4_files_are_converted_and_give_their_field_of_view() {
        let dir = tempfile::tempdir().unwrap();
        let names = ["S0.400,000nm", "S0.500,000nm"];
        // worldToCamera: camera x = world y, camera y = world z, camera z = -world x (a
        // rotation), then the translation of the camera at (1, 2, 3).
        let rot = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]];
        let eye = [1.0, 2.0, 3.0];
        let mut w2c = [0f32; 16];
        for i in 0..3 {
            for j in 0..3 {
                w2c[i * 4 + j] = rot[i][j] as f32;
            }
            w2c[i * 4 + 3] = -(0..3).map(|k| rot[i][k] * eye[k]).sum::<f64>() as f32;
        }
        w2c[15] = 1.0;
        // NDC from camera: T(1/2) S(1/2) Scale(1/t, 1/t, 1) Perspective(near 0.01, far 1000).
        let t = (20f64).to_radians().tan();
        let (n, f) = (1e-2, 1e3);
        let persp = [
            [0.5 / t, 0.0, 0.5, 0.0],
            [0.0, 0.5 / t, 0.5, 0.0],
            [0.0, 0.0, 0.5 * f / (f - n) + 0.5, -0.5 * f * n / (f - n)],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let mut w2ndc = [0f32; 16];
        for i in 0..4 {
            for j in 0..4 {
                w2ndc[i * 4 + j] = (0..4)
                    .map(|k| persp[i][k] * w2c[k * 4 + j] as f64)
                    .sum::<f64>() as f32;
            }
        }
        let path = dir.path().join("pbrt.exr");
        write_pbrt_like_with(
            &path,
            &names,
            |k, i| 100.0 * (k + i) as f32,
            &[
                ("worldToCamera", AttributeValue::Matrix4x4(w2c)),
                ("worldToNDC", AttributeValue::Matrix4x4(w2ndc)),
            ],
        );
        let (img, info) = read_spectral_exr_with_info(&path).unwrap();
        assert!(info.pbrt_v4_units_converted && info.fov_from_pbrt_v4_camera);
        let k = 683.0 * 106.856895;
        for b in 0..2 {
            for i in 0..12 {
                let want = (100.0 * (b + 3 + i) as f64 / k) as f32;
                assert!((img.band(b)[i] - want).abs() <= 1e-6 * want, "{b} {i}");
            }
        }
        // 4 x 3: the horizontal half-angle's tangent is 4/3 tan(20 deg).
        let want = 2.0 * (4.0 / 3.0 * t).atan().to_degrees();
        assert!(
            (img.geometry.fov_deg - want).abs() < 1e-4,
            "{} vs {want}",
            img.geometry.fov_deg
        );
        // Declared absolute: no conversion.
        let (raw, info) = read_spectral_exr_as(&path, SourceUnits::Absolute).unwrap();
        assert!(!info.pbrt_v4_units_converted && raw.band(0)[1] == 400.0);
        // A camsim file is never converted, even with pbrt-v4's units string.
        let mut mine = sample_image(2, 3, WavelengthGrid::new(400.0, 500.0, 100.0).unwrap());
        mine.data.iter_mut().for_each(|v| *v = 2.0);
        let p2 = dir.path().join("mine.exr");
        write_spectral_exr(&p2, &mine, "scene").unwrap();
        let (back, info) = read_spectral_exr_with_info(&p2).unwrap();
        assert!(!info.pbrt_v4_units_converted && back.data[0] == 2.0);
    }

    #[test]
    fn rejects_missing_channels_bad_values_and_truncation() {
        let dir = tempfile::tempdir().unwrap();
        // A missing band makes the grid non-uniform.
        let p = dir.path().join("gap.exr");
        write_pbrt_like(
            &p,
            &["S0.400,000nm", "S0.410,000nm", "S0.430,000nm"],
            |_, _| 1.0,
        );
        let e = read_spectral_exr(&p).unwrap_err().to_string();
        assert!(e.contains("gap.exr") && e.contains("uniformly"), "{e}");
        // No spectral channels at all.
        let p = dir.path().join("rgb.exr");
        write_pbrt_like(&p, &[], |_, _| 1.0);
        let e = read_spectral_exr(&p).unwrap_err().to_string();
        assert!(
            e.contains("rgb.exr") && e.contains("no spectral channels"),
            "{e}"
        );
        // Negative and NaN values are named.
        let p = dir.path().join("neg.exr");
        write_pbrt_like(&p, &["S0.400,000nm", "S0.410,000nm"], |k, i| {
            if k == 4 && i == 5 {
                -1.0
            } else {
                1.0
            }
        });
        let e = read_spectral_exr(&p).unwrap_err().to_string();
        assert!(
            e.contains("neg.exr") && e.contains("S0.410,000nm") && e.contains("-1"),
            "{e}"
        );
        let p = dir.path().join("nan.exr");
        write_pbrt_like(&p, &["S0.400,000nm", "S0.410,000nm"], |k, _| {
            if k == 3 {
                f32::NAN
            } else {
                1.0
            }
        });
        assert!(read_spectral_exr(&p)
            .unwrap_err()
            .to_string()
            .contains("NaN"));
        // Truncated and garbage files are errors, not panics.
        let good = dir.path().join("good.exr");
        write_spectral_exr(
            &good,
            &sample_image(6, 5, WavelengthGrid::default()),
            "scene",
        )
        .unwrap();
        let bytes = std::fs::read(&good).unwrap();
        let cut = dir.path().join("cut.exr");
        for n in [
            0,
            4,
            20,
            100,
            bytes.len() / 3,
            bytes.len() / 2,
            bytes.len() - 10,
            bytes.len() - 1,
        ] {
            std::fs::write(&cut, &bytes[..n]).unwrap();
            let r = read_spectral_exr(&cut);
            assert!(
                r.is_err(),
                "truncated at {n} of {} was accepted",
                bytes.len()
            );
            assert!(r.unwrap_err().to_string().contains("cut.exr"));
        }
        std::fs::write(&cut, b"this is not an EXR file at all").unwrap();
        assert!(read_spectral_exr(&cut).is_err());
        assert!(read_spectral_exr(&dir.path().join("absent.exr"))
            .unwrap_err()
            .to_string()
            .contains("absent.exr"));
    }

    /// Issue 1: FFT round-off leaves negatives of ~1e-7 x the maximum in other tools' blurred
    /// images; they are clamped to 0 and counted. A negative above the round-off limit
    /// (1e-5 x max) is a real error, named with the file, channel, pixel and value.
    #[test]
    fn clamps_round_off_negatives_and_refuses_real_ones() {
        let dir = tempfile::tempdir().unwrap();
        let grid = WavelengthGrid::new(400.0, 420.0, 10.0).unwrap();
        let mut img = sample_image(4, 5, grid);
        img.depth_m = None;
        let max = img.data.iter().fold(0.0f32, |m, v| m.max(*v));
        assert!(max > 0.0);
        // Two round-off negatives (2e-7 and 1e-5 x max: the limit itself is accepted).
        img.band_mut(1)[3] = -2e-7 * max;
        img.band_mut(2)[7] = -NEGATIVE_ROUNDOFF_FRACTION * max;
        let p = dir.path().join("roundoff.exr");
        write_spectral_exr(&p, &img, "optics").unwrap();
        let (back, info) = read_spectral_exr_with_info(&p).unwrap();
        assert_eq!(info.clamped_negatives, 2);
        assert_eq!(
            info.most_negative_clamped,
            -NEGATIVE_ROUNDOFF_FRACTION * max
        );
        assert_eq!(back.band(1)[3], 0.0);
        assert_eq!(back.band(2)[7], 0.0);
        assert!(back.data.iter().all(|v| *v >= 0.0));
        // Everything else is unchanged.
        assert_eq!(back.band(0), img.band(0));
        // A negative of 1e-3 x max is not round-off: refused, naming file, channel, pixel, value.
        img.band_mut(1)[3] = -1e-3 * max;
        let p = dir.path().join("real-negative.exr");
        write_spectral_exr(&p, &img, "optics").unwrap();
        let e = read_spectral_exr(&p).unwrap_err().to_string();
        assert!(
            e.contains("real-negative.exr")
                && e.contains("S0.410,000000nm")
                && e.contains("row 0, column 3")
                && e.contains(&format!("{}", -1e-3 * max)),
            "{e}"
        );
    }

    #[test]
    fn gray_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("depth.exr");
        let data: Vec<f32> = (0..12).map(|i| i as f32 * 0.3 - 1.0).collect();
        write_gray_exr(&p, 3, 4, "Z", &data).unwrap();
        assert_eq!(read_gray_exr(&p, None).unwrap(), (3, 4, data.clone()));
        assert_eq!(read_gray_exr(&p, Some("Z")).unwrap().2, data);
        assert!(read_gray_exr(&p, Some("Y"))
            .unwrap_err()
            .to_string()
            .contains("'Y'"));
        assert!(write_gray_exr(&p, 3, 5, "Z", &data).is_err());
    }
}
