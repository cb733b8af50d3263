//! A reader for MATLAB Level 5 MAT-files (the "-v6"/"-v7" format ISETCam uses for its spectral data
//! files: variables `wavelength`, `data`, `comment` and, for sensor filters, `filterNames`).
//!
//! Implemented from MathWorks' "MAT-File Format" specification (R2024: Level 5 MAT-files):
//! a 128-byte header (text, subsystem offset, version 0x0100, endian indicator `IM` for
//! little-endian or `MI` for big-endian files), then data elements, each an 8-byte tag
//! (type, byte count) or a 4-byte "small element" tag with up to 4 bytes of data, padded to 8 bytes;
//! variables are `miMATRIX` elements (array flags, dimensions, name, real and imaginary parts,
//! cells or struct fields) and may be wrapped in zlib-compressed `miCOMPRESSED` elements.
//!
//! Every length read from the file is bounds-checked: malformed input gives an error naming the
//! file, the byte offset and what is wrong, never a panic. MATLAB 7.3 files (HDF5) and v4 files are
//! recognised and refused with a clear message.

use crate::error::{CoreError, Result};
use crate::spectra_table::{read_limited, SpectraTable};
use std::io::Read;
use std::path::Path;

// Data types (MAT-File Format, Table 1-1).
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;
const MI_UTF16: u32 = 17;
const MI_UTF32: u32 = 18;

/// Deepest nesting of cells/structs accepted (guards the stack against crafted files).
const MAX_DEPTH: usize = 64;

/// MATLAB array classes (MAT-File Format, Table 1-3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatClass {
    /// mxCELL_CLASS (1).
    Cell,
    /// mxSTRUCT_CLASS (2).
    Struct,
    /// mxOBJECT_CLASS (3).
    Object,
    /// mxCHAR_CLASS (4).
    Char,
    /// mxSPARSE_CLASS (5).
    Sparse,
    /// mxDOUBLE_CLASS (6).
    Double,
    /// mxSINGLE_CLASS (7).
    Single,
    /// mxINT8_CLASS (8).
    Int8,
    /// mxUINT8_CLASS (9).
    UInt8,
    /// mxINT16_CLASS (10).
    Int16,
    /// mxUINT16_CLASS (11).
    UInt16,
    /// mxINT32_CLASS (12).
    Int32,
    /// mxUINT32_CLASS (13).
    UInt32,
    /// mxINT64_CLASS (14).
    Int64,
    /// mxUINT64_CLASS (15).
    UInt64,
    /// Any other class code (function handles, opaque objects).
    Other(u8),
}

impl MatClass {
    fn from_code(c: u8) -> MatClass {
        match c {
            1 => MatClass::Cell,
            2 => MatClass::Struct,
            3 => MatClass::Object,
            4 => MatClass::Char,
            5 => MatClass::Sparse,
            6 => MatClass::Double,
            7 => MatClass::Single,
            8 => MatClass::Int8,
            9 => MatClass::UInt8,
            10 => MatClass::Int16,
            11 => MatClass::UInt16,
            12 => MatClass::Int32,
            13 => MatClass::UInt32,
            14 => MatClass::Int64,
            15 => MatClass::UInt64,
            other => MatClass::Other(other),
        }
    }

    fn is_numeric(self) -> bool {
        matches!(
            self,
            MatClass::Double
                | MatClass::Single
                | MatClass::Int8
                | MatClass::UInt8
                | MatClass::Int16
                | MatClass::UInt16
                | MatClass::Int32
                | MatClass::UInt32
                | MatClass::Int64
                | MatClass::UInt64
        )
    }
}

/// The value of one MATLAB variable. Arrays are column-major, as MATLAB stores them.
#[derive(Debug, Clone, PartialEq)]
pub enum MatValue {
    /// A numeric or logical array, converted to f64 (64-bit integers beyond 2^53 lose precision).
    Numeric {
        /// The array's MATLAB class.
        class: MatClass,
        /// Dimensions (rows, columns, ...).
        dims: Vec<usize>,
        /// Real part, column-major.
        real: Vec<f64>,
        /// Imaginary part of a complex array.
        imag: Option<Vec<f64>>,
        /// True for a MATLAB logical array.
        logical: bool,
    },
    /// A char array (dims rows x columns), column-major characters.
    Char {
        /// Dimensions (rows, columns, ...).
        dims: Vec<usize>,
        /// Characters, column-major.
        chars: Vec<char>,
    },
    /// A cell array, column-major cells.
    Cell {
        /// Dimensions.
        dims: Vec<usize>,
        /// The cells' values.
        cells: Vec<MatValue>,
    },
    /// A struct array: `elements[k][f]` is field `field_names[f]` of element `k` (column-major).
    Struct {
        /// Dimensions.
        dims: Vec<usize>,
        /// Field names in file order.
        field_names: Vec<String>,
        /// Field values per element.
        elements: Vec<Vec<MatValue>>,
    },
    /// A class this reader does not decode (sparse, objects, function handles); its bytes are skipped.
    Unsupported {
        /// The class.
        class: MatClass,
        /// Dimensions as stored.
        dims: Vec<usize>,
    },
}

impl MatValue {
    /// Dimensions of the array.
    pub fn dims(&self) -> &[usize] {
        match self {
            MatValue::Numeric { dims, .. }
            | MatValue::Char { dims, .. }
            | MatValue::Cell { dims, .. }
            | MatValue::Struct { dims, .. }
            | MatValue::Unsupported { dims, .. } => dims,
        }
    }

    /// The real values of a numeric array (column-major), if this is one.
    pub fn as_f64(&self) -> Option<&[f64]> {
        match self {
            MatValue::Numeric { real, .. } => Some(real),
            _ => None,
        }
    }

    /// The rows of a char array as strings (trailing blanks removed, as MATLAB's `cellstr`).
    pub fn char_rows(&self) -> Option<Vec<String>> {
        match self {
            MatValue::Char { dims, chars } => {
                let rows = dims.first().copied().unwrap_or(0);
                if rows == 0 || chars.is_empty() {
                    return Some(if rows <= 1 {
                        vec![String::new()]
                    } else {
                        vec![String::new(); rows]
                    });
                }
                let cols = chars.len() / rows;
                Some(
                    (0..rows)
                        .map(|r| {
                            (0..cols)
                                .map(|c| chars[c * rows + r])
                                .collect::<String>()
                                .trim_end()
                                .to_string()
                        })
                        .collect(),
                )
            }
            _ => None,
        }
    }

    /// A char array as one string (rows joined with line breaks).
    pub fn as_string(&self) -> Option<String> {
        self.char_rows().map(|r| r.join("\n"))
    }

    /// Strings of a cell array of char arrays, or the rows of a char matrix.
    pub fn as_strings(&self) -> Option<Vec<String>> {
        match self {
            MatValue::Cell { cells, .. } => cells.iter().map(|c| c.as_string()).collect(),
            MatValue::Char { .. } => self.char_rows(),
            _ => None,
        }
    }
}

/// One named variable of a MAT-file.
#[derive(Debug, Clone, PartialEq)]
pub struct MatVariable {
    /// Variable name.
    pub name: String,
    /// True when saved with the global flag.
    pub global: bool,
    /// Its value.
    pub value: MatValue,
}

type PResult<T> = std::result::Result<T, String>;

#[derive(Clone, Copy)]
struct Endian {
    big: bool,
}

impl Endian {
    fn u16(self, b: &[u8]) -> u16 {
        let a = [b[0], b[1]];
        if self.big {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }
    fn u32(self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.big {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }
    fn u64(self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        a.copy_from_slice(&b[..8]);
        if self.big {
            u64::from_be_bytes(a)
        } else {
            u64::from_le_bytes(a)
        }
    }
}

/// One data element: its type, its data bytes, and where it starts (for messages).
struct Element<'a> {
    data_type: u32,
    data: &'a [u8],
    offset: usize,
}

/// Reads consecutive data elements from a byte slice. `base` is the slice's offset in the file
/// (or in a decompressed block) for messages.
struct Elements<'a> {
    buf: &'a [u8],
    pos: usize,
    e: Endian,
    base: usize,
    context: &'static str,
}

impl<'a> Elements<'a> {
    fn new(buf: &'a [u8], e: Endian, base: usize, context: &'static str) -> Self {
        Elements {
            buf,
            pos: 0,
            e,
            base,
            context,
        }
    }

    fn at_end(&self) -> bool {
        self.pos >= self.buf.len()
    }

    fn where_(&self, off: usize) -> String {
        format!("{} byte {}", self.context, self.base + off)
    }

    /// Next element; `pad` is false only for top-level compressed elements (not padded).
    fn next(&mut self) -> PResult<Element<'a>> {
        let start = self.pos;
        let rest = &self.buf[start..];
        if rest.len() < 4 {
            return Err(format!(
                "{}: truncated data element tag ({} bytes left)",
                self.where_(start),
                rest.len()
            ));
        }
        let first = self.e.u32(&rest[..4]);
        if first >> 16 != 0 {
            // Small data element: type in the low 16 bits, byte count (<= 4) in the high 16.
            let n = (first >> 16) as usize;
            let data_type = first & 0xffff;
            if n > 4 {
                return Err(format!(
                    "{}: small data element claims {n} bytes (at most 4)",
                    self.where_(start)
                ));
            }
            if rest.len() < 8 {
                return Err(format!(
                    "{}: truncated small data element",
                    self.where_(start)
                ));
            }
            self.pos = start + 8;
            return Ok(Element {
                data_type,
                data: &rest[4..4 + n],
                offset: start,
            });
        }
        if rest.len() < 8 {
            return Err(format!(
                "{}: truncated data element tag ({} bytes left)",
                self.where_(start),
                rest.len()
            ));
        }
        let data_type = first;
        let n = self.e.u32(&rest[4..8]) as usize;
        let avail = rest.len() - 8;
        if n > avail {
            return Err(format!(
                "{}: data element of type {data_type} claims {n} bytes but only {avail} remain (truncated file?)",
                self.where_(start)
            ));
        }
        let data = &rest[8..8 + n];
        // Elements are padded to a multiple of 8 bytes, except compressed ones.
        let padded = if data_type == MI_COMPRESSED {
            n
        } else {
            n.div_ceil(8) * 8
        };
        // A missing pad at the very end of a block is tolerated.
        self.pos = (start + 8 + padded).min(self.buf.len());
        Ok(Element {
            data_type,
            data,
            offset: start,
        })
    }
}

fn type_size(t: u32) -> Option<usize> {
    match t {
        MI_INT8 | MI_UINT8 | MI_UTF8 => Some(1),
        MI_INT16 | MI_UINT16 | MI_UTF16 => Some(2),
        MI_INT32 | MI_UINT32 | MI_SINGLE | MI_UTF32 => Some(4),
        MI_DOUBLE | MI_INT64 | MI_UINT64 => Some(8),
        _ => None,
    }
}

/// Numbers of a numeric data element as f64.
fn numbers(el: &Element, e: Endian, what: &str, ctx: &Elements) -> PResult<Vec<f64>> {
    let size = match el.data_type {
        MI_INT8 | MI_UINT8 | MI_INT16 | MI_UINT16 | MI_INT32 | MI_UINT32 | MI_SINGLE
        | MI_DOUBLE | MI_INT64 | MI_UINT64 => type_size(el.data_type).unwrap_or(1),
        t => {
            return Err(format!(
                "{}: {what} has data type {t}, not a numeric type",
                ctx.where_(el.offset)
            ))
        }
    };
    let d = el.data;
    if !d.len().is_multiple_of(size) {
        return Err(format!(
            "{}: {what} has {} bytes, not a multiple of its {size}-byte element size",
            ctx.where_(el.offset),
            d.len()
        ));
    }
    let out = d
        .chunks_exact(size)
        .map(|c| match el.data_type {
            MI_INT8 => c[0] as i8 as f64,
            MI_UINT8 => c[0] as f64,
            MI_INT16 => e.u16(c) as i16 as f64,
            MI_UINT16 => e.u16(c) as f64,
            MI_INT32 => e.u32(c) as i32 as f64,
            MI_UINT32 => e.u32(c) as f64,
            MI_SINGLE => f32::from_bits(e.u32(c)) as f64,
            MI_DOUBLE => f64::from_bits(e.u64(c)),
            MI_INT64 => e.u64(c) as i64 as f64,
            _ => e.u64(c) as f64,
        })
        .collect();
    Ok(out)
}

/// Characters of a char array's data element (UTF-16 code units as MATLAB writes, or UTF-8/UTF-32/bytes).
fn characters(el: &Element, e: Endian, ctx: &Elements) -> PResult<Vec<char>> {
    let d = el.data;
    let bad = |what: &str| format!("{}: char data is not valid {what}", ctx.where_(el.offset));
    match el.data_type {
        MI_UINT16 | MI_UTF16 | MI_INT16 => {
            if !d.len().is_multiple_of(2) {
                return Err(bad("UTF-16 (odd byte count)"));
            }
            let units: Vec<u16> = d.chunks_exact(2).map(|c| e.u16(c)).collect();
            // MATLAB char arrays hold UTF-16 code units, one per element; keep one char per unit.
            Ok(units
                .iter()
                .map(|u| char::from_u32(*u as u32).unwrap_or(char::REPLACEMENT_CHARACTER))
                .collect())
        }
        MI_UTF8 | MI_UINT8 | MI_INT8 => match std::str::from_utf8(d) {
            Ok(s) => Ok(s.chars().collect()),
            // Latin-1 bytes.
            Err(_) => Ok(d.iter().map(|b| *b as char).collect()),
        },
        MI_UTF32 | MI_UINT32 | MI_INT32 => {
            if !d.len().is_multiple_of(4) {
                return Err(bad("UTF-32 (byte count not a multiple of 4)"));
            }
            Ok(d.chunks_exact(4)
                .map(|c| char::from_u32(e.u32(c)).unwrap_or(char::REPLACEMENT_CHARACTER))
                .collect())
        }
        t => Err(format!(
            "{}: char data has data type {t}",
            ctx.where_(el.offset)
        )),
    }
}

fn product(dims: &[usize], ctx: &Elements, offset: usize) -> PResult<usize> {
    dims.iter()
        .try_fold(1usize, |acc, d| acc.checked_mul(*d))
        .ok_or_else(|| format!("{}: array dimensions {dims:?} overflow", ctx.where_(offset)))
}

/// The header of a miMATRIX element: its array flags, dimensions and name (MAT-File Format,
/// MathWorks 2019, "miMATRIX Format": array flags, dimensions array, array name, in this order).
struct ArrayHeader {
    class: MatClass,
    complex: bool,
    global: bool,
    logical: bool,
    dims: Vec<usize>,
    /// Product of `dims`.
    count: usize,
    /// Offset of the dimensions element, for messages.
    dims_offset: usize,
    name: String,
}

impl ArrayHeader {
    /// `m` prefixed with the variable's name (when it has one).
    fn named(&self, m: String) -> String {
        if self.name.is_empty() {
            m
        } else {
            format!("variable '{}': {m}", self.name)
        }
    }
}

/// Read the array flags, dimensions and name elements.
fn array_header(els: &mut Elements, e: Endian) -> PResult<ArrayHeader> {
    // 1. Array flags.
    let flags_el = els.next()?;
    if flags_el.data_type != MI_UINT32 || flags_el.data.len() < 4 {
        return Err(format!(
            "{}: array flags must be a miUINT32 element of 8 bytes (type {}, {} bytes)",
            els.where_(flags_el.offset),
            flags_el.data_type,
            flags_el.data.len()
        ));
    }
    let flags = e.u32(&flags_el.data[..4]);
    // 2. Dimensions.
    let dims_el = els.next()?;
    if dims_el.data_type != MI_INT32 || dims_el.data.len() % 4 != 0 || dims_el.data.is_empty() {
        return Err(format!(
            "{}: dimensions must be a miINT32 element (type {}, {} bytes)",
            els.where_(dims_el.offset),
            dims_el.data_type,
            dims_el.data.len()
        ));
    }
    let mut dims = Vec::with_capacity(dims_el.data.len() / 4);
    for c in dims_el.data.chunks_exact(4) {
        let d = e.u32(c) as i32;
        if d < 0 {
            return Err(format!(
                "{}: negative dimension {d}",
                els.where_(dims_el.offset)
            ));
        }
        dims.push(d as usize);
    }
    let count = product(&dims, els, dims_el.offset)?;
    // 3. Name.
    let name_el = els.next()?;
    if !matches!(name_el.data_type, MI_INT8 | MI_UINT8 | MI_UTF8) {
        return Err(format!(
            "{}: array name must be a miINT8 element (type {})",
            els.where_(name_el.offset),
            name_el.data_type
        ));
    }
    Ok(ArrayHeader {
        class: MatClass::from_code((flags & 0xff) as u8),
        complex: flags & 0x0800 != 0,
        global: flags & 0x0400 != 0,
        logical: flags & 0x0200 != 0,
        dims,
        count,
        dims_offset: dims_el.offset,
        name: String::from_utf8_lossy(name_el.data)
            .trim_end_matches('\0')
            .to_string(),
    })
}

/// Parse the contents of a miMATRIX element. Returns (name, global, value).
fn parse_matrix(
    data: &[u8],
    e: Endian,
    base: usize,
    depth: usize,
) -> PResult<(String, bool, MatValue)> {
    let mut els = Elements::new(data, e, base, "miMATRIX");
    if data.is_empty() {
        // An empty miMATRIX (e.g. an empty cell) is an empty double array.
        return Ok((
            String::new(),
            false,
            MatValue::Numeric {
                class: MatClass::Double,
                dims: vec![0, 0],
                real: vec![],
                imag: None,
                logical: false,
            },
        ));
    }
    if depth > MAX_DEPTH {
        return Err(format!(
            "{}: cells/structs nested more than {MAX_DEPTH} deep",
            els.where_(0)
        ));
    }
    let h = array_header(&mut els, e)?;
    // 4. Class-specific content.
    let value = match h.class {
        c if c.is_numeric() => numeric_value(&mut els, e, &h)?,
        MatClass::Char => char_value(&mut els, e, &h)?,
        MatClass::Cell => {
            let cells = matrices(&mut els, e, base, depth, &h, h.count, |k| {
                format!("cell {}", k + 1)
            })?;
            MatValue::Cell {
                dims: h.dims.clone(),
                cells,
            }
        }
        MatClass::Struct => struct_value(&mut els, e, base, depth, &h)?,
        other => MatValue::Unsupported {
            class: other,
            dims: h.dims.clone(),
        },
    };
    Ok((h.name, h.global, value))
}

/// The real (and imaginary) data of a numeric array.
fn numeric_value(els: &mut Elements, e: Endian, h: &ArrayHeader) -> PResult<MatValue> {
    let named = |m| h.named(m);
    let (real, imag) = if els.at_end() && h.count == 0 {
        (vec![], None)
    } else {
        let re_el = els.next().map_err(named)?;
        let real = numbers(&re_el, e, "real part", els).map_err(named)?;
        let imag = if h.complex {
            let im_el = els.next().map_err(named)?;
            Some(numbers(&im_el, e, "imaginary part", els).map_err(named)?)
        } else {
            None
        };
        (real, imag)
    };
    if real.len() != h.count || imag.as_ref().is_some_and(|v| v.len() != h.count) {
        return Err(h.named(format!(
            "{}: dimensions {:?} need {} values but the data holds {}",
            els.where_(h.dims_offset),
            h.dims,
            h.count,
            real.len()
        )));
    }
    Ok(MatValue::Numeric {
        class: h.class,
        dims: h.dims.clone(),
        real,
        imag,
        logical: h.logical,
    })
}

/// The characters of a char array.
fn char_value(els: &mut Elements, e: Endian, h: &ArrayHeader) -> PResult<MatValue> {
    let chars = if els.at_end() {
        vec![]
    } else {
        let el = els.next().map_err(|m| h.named(m))?;
        characters(&el, e, els).map_err(|m| h.named(m))?
    };
    if chars.len() != h.count {
        return Err(h.named(format!(
            "{}: char array {:?} needs {} characters but holds {}",
            els.where_(h.dims_offset),
            h.dims,
            h.count,
            chars.len()
        )));
    }
    Ok(MatValue::Char {
        dims: h.dims.clone(),
        chars,
    })
}

/// `n` nested miMATRIX elements (the cells of a cell array, the fields of a struct element);
/// `what(k)` names element k in messages.
fn matrices(
    els: &mut Elements,
    e: Endian,
    base: usize,
    depth: usize,
    h: &ArrayHeader,
    n: usize,
    what: impl Fn(usize) -> String,
) -> PResult<Vec<MatValue>> {
    let mut out = Vec::with_capacity(n.min(1024));
    for k in 0..n {
        if els.at_end() {
            return Err(h.named(format!(
                "{:?} ends before {} ({} of {n})",
                h.dims,
                what(k),
                k + 1
            )));
        }
        let el = els.next().map_err(|m| h.named(m))?;
        if el.data_type != MI_MATRIX {
            return Err(h.named(format!(
                "{}: {} is data type {}, not miMATRIX",
                els.where_(el.offset),
                what(k),
                el.data_type
            )));
        }
        let (_, _, v) =
            parse_matrix(el.data, e, base + el.offset + 8, depth + 1).map_err(|m| h.named(m))?;
        out.push(v);
    }
    Ok(out)
}

/// A struct array: its field name length, field names, then each element's fields.
fn struct_value(
    els: &mut Elements,
    e: Endian,
    base: usize,
    depth: usize,
    h: &ArrayHeader,
) -> PResult<MatValue> {
    let named = |m| h.named(m);
    let len_el = els.next().map_err(named)?;
    let field_len = match numbers(&len_el, e, "field name length", els)
        .map_err(named)?
        .first()
    {
        Some(v) if *v >= 1.0 && *v <= 65536.0 => *v as usize,
        other => {
            return Err(h.named(format!(
                "{}: bad struct field name length {other:?}",
                els.where_(len_el.offset)
            )))
        }
    };
    let names_el = els.next().map_err(named)?;
    if names_el.data.len() % field_len != 0 {
        return Err(h.named(format!(
            "{}: {} bytes of field names is not a multiple of the name length {field_len}",
            els.where_(names_el.offset),
            names_el.data.len()
        )));
    }
    let field_names: Vec<String> = names_el
        .data
        .chunks_exact(field_len)
        .map(|c| {
            let end = c.iter().position(|b| *b == 0).unwrap_or(c.len());
            String::from_utf8_lossy(&c[..end]).into_owned()
        })
        .collect();
    let mut elements = Vec::new();
    for k in 0..h.count {
        let fields = matrices(els, e, base, depth, h, field_names.len(), |f| {
            format!("struct element {} field '{}'", k + 1, field_names[f])
        })?;
        elements.push(fields);
    }
    Ok(MatValue::Struct {
        dims: h.dims.clone(),
        field_names,
        elements,
    })
}

/// Inflate a miCOMPRESSED element, refusing output larger than `limit` bytes.
fn inflate(data: &[u8], limit: u64) -> PResult<Vec<u8>> {
    let mut out = Vec::new();
    let mut dec = flate2::read::ZlibDecoder::new(data).take(limit + 1);
    dec.read_to_end(&mut out)
        .map_err(|err| format!("corrupt zlib data: {err}"))?;
    if out.len() as u64 > limit {
        return Err(format!(
            "compressed element expands to more than {} MiB",
            limit >> 20
        ));
    }
    Ok(out)
}

/// Parse the top-level elements of a Level 5 MAT-file held in `bytes`.
fn parse(bytes: &[u8]) -> PResult<Vec<MatVariable>> {
    if bytes.len() < 128 {
        if bytes.len() >= 4 && bytes[..4].contains(&0) {
            return Err("a MATLAB v4 MAT-file (not supported; save with -v7 or -v6)".into());
        }
        return Err(format!(
            "only {} bytes; a MATLAB v5 MAT-file starts with a 128-byte header",
            bytes.len()
        ));
    }
    let text = String::from_utf8_lossy(&bytes[..116]);
    if text.starts_with("MATLAB 7.3") {
        return Err(
            "a MATLAB 7.3 (HDF5) MAT-file is not supported; save it with save(..., '-v7')".into(),
        );
    }
    let e = match &bytes[126..128] {
        b"IM" => Endian { big: false },
        b"MI" => Endian { big: true },
        other => {
            if bytes[..4].contains(&0) {
                return Err("a MATLAB v4 MAT-file (not supported; save with -v7 or -v6)".into());
            }
            return Err(format!("header byte 126: endian indicator is {other:?}, not 'IM' or 'MI' (not a MATLAB v5 MAT-file)"));
        }
    };
    let version = e.u16(&bytes[124..126]);
    if version != 0x0100 {
        return Err(format!(
            "header byte 124: version {version:#06x}, expected 0x0100 (MATLAB v5)"
        ));
    }
    let limit = (crate::mem::available_bytes() / 2).min(4 << 30);
    let mut vars = Vec::new();
    let body = &bytes[128..];
    let mut top = Elements::new(body, e, 128, "file");
    while !top.at_end() {
        let el = top.next()?;
        match el.data_type {
            MI_MATRIX => {
                let (name, global, value) = parse_matrix(el.data, e, 128 + el.offset + 8, 0)?;
                vars.push(MatVariable {
                    name,
                    global,
                    value,
                });
            }
            MI_COMPRESSED => {
                let inflated = inflate(el.data, limit).map_err(|m| {
                    format!("file byte {}: compressed element: {m}", 128 + el.offset)
                })?;
                let mut inner = Elements::new(&inflated, e, 0, "decompressed element");
                while !inner.at_end() {
                    let iel = inner.next().map_err(|m| {
                        format!("compressed element at file byte {}: {m}", 128 + el.offset)
                    })?;
                    if iel.data_type == MI_MATRIX {
                        let (name, global, value) = parse_matrix(iel.data, e, iel.offset + 8, 0)
                            .map_err(|m| {
                                format!("compressed element at file byte {}: {m}", 128 + el.offset)
                            })?;
                        vars.push(MatVariable {
                            name,
                            global,
                            value,
                        });
                    }
                }
            }
            // Other top-level element types carry no variable; skip them.
            _ => {}
        }
    }
    Ok(vars)
}

/// Parse MAT-file bytes; `path` names the source in errors.
pub fn parse_mat_bytes(bytes: &[u8], path: &Path) -> Result<Vec<MatVariable>> {
    parse(bytes).map_err(|m| CoreError::file(path, m))
}

/// Read every variable of a MATLAB Level 5 MAT-file (compressed or not, either byte order).
pub fn read_mat_variables(path: impl AsRef<Path>) -> Result<Vec<MatVariable>> {
    let path = path.as_ref();
    let bytes = read_limited(path)?;
    parse_mat_bytes(&bytes, path)
}

/// Write numeric matrices as an uncompressed little-endian Level 5 MAT-file (the layout of the
/// reader above): `(name, rows, cols, values column-major)` per variable, MATLAB class double.
/// For exporting spectra to ISETCam (`wavelength` n x 1, `data` n x k) and for tests.
pub fn mat_v5_doubles(vars: &[(&str, usize, usize, &[f64])]) -> Vec<u8> {
    fn element(out: &mut Vec<u8>, data_type: u32, data: &[u8]) {
        out.extend(data_type.to_le_bytes());
        out.extend((data.len() as u32).to_le_bytes());
        out.extend(data);
        out.resize(out.len().next_multiple_of(8), 0);
    }
    let mut out = vec![b' '; 116];
    out[..19].copy_from_slice(b"MATLAB 5.0 MAT-file");
    out.extend([0u8; 8]);
    out.extend([0x00, 0x01, b'I', b'M']);
    for (name, rows, cols, values) in vars {
        debug_assert_eq!(values.len(), rows * cols);
        let mut body = Vec::new();
        element(
            &mut body,
            MI_UINT32,
            &[6 /* mxDOUBLE_CLASS */, 0, 0, 0, 0, 0, 0, 0],
        );
        element(
            &mut body,
            MI_INT32,
            &[(*rows as i32).to_le_bytes(), (*cols as i32).to_le_bytes()].concat(),
        );
        element(&mut body, MI_INT8, name.as_bytes());
        element(
            &mut body,
            MI_DOUBLE,
            &values
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect::<Vec<u8>>(),
        );
        out.extend(MI_MATRIX.to_le_bytes());
        out.extend((body.len() as u32).to_le_bytes());
        out.extend(body);
    }
    out
}

/// An ISETCam spectral data file: the spectra and the file's `comment`.
#[derive(Debug, Clone, PartialEq)]
pub struct IsetcamSpectra {
    /// Wavelengths, names (from `filterNames`, else `data_1..n`) and columns of `data`.
    pub table: SpectraTable,
    /// The `comment` variable, if present.
    pub comment: Option<String>,
}

/// Build the spectra of an ISETCam data file from its variables (`wavelength`, `data`,
/// optional `filterNames` and `comment`), as ISETCam's `ieReadSpectra` reads them.
pub fn isetcam_spectra_from_variables(vars: &[MatVariable], path: &Path) -> Result<IsetcamSpectra> {
    let err = |m: String| CoreError::file(path, m);
    let find = |n: &str| vars.iter().find(|v| v.name == n);
    let wave_var = find("wavelength").ok_or_else(|| {
        let names: Vec<&str> = vars.iter().map(|v| v.name.as_str()).collect();
        err(format!(
            "no variable 'wavelength' (variables: {})",
            names.join(", ")
        ))
    })?;
    let wavelengths_nm = wave_var
        .value
        .as_f64()
        .ok_or_else(|| err("variable 'wavelength' is not numeric".into()))?
        .to_vec();
    let n = wavelengths_nm.len();
    let wd = wave_var.value.dims();
    if wd.iter().filter(|d| **d != 1).count() > 1 {
        return Err(err(format!(
            "variable 'wavelength' is a {wd:?} matrix, not a vector"
        )));
    }
    let data_var = find("data").ok_or_else(|| err("no variable 'data'".into()))?;
    let data = data_var
        .value
        .as_f64()
        .ok_or_else(|| err("variable 'data' is not numeric".into()))?;
    let dd = data_var.value.dims();
    if dd.len() > 2 && dd[2..].iter().any(|d| *d != 1) {
        return Err(err(format!(
            "variable 'data' has {} dimensions {dd:?}; expected wavelengths x spectra",
            dd.len()
        )));
    }
    let (rows, cols) = (
        dd.first().copied().unwrap_or(0),
        dd.get(1).copied().unwrap_or(1),
    );
    if rows.checked_mul(cols) != Some(data.len()) {
        return Err(err(format!(
            "variable 'data' has dimensions {dd:?} but {} values",
            data.len()
        )));
    }
    let columns: Vec<Vec<f64>> = if rows == n {
        (0..cols)
            .map(|j| data[j * rows..(j + 1) * rows].to_vec())
            .collect()
    } else if cols == n {
        // Stored as spectra x wavelengths: row k is spectrum k.
        (0..rows)
            .map(|k| (0..cols).map(|i| data[i * rows + k]).collect())
            .collect()
    } else {
        return Err(err(format!(
            "variable 'data' is {rows} x {cols} but there are {n} wavelengths"
        )));
    };
    let names = match find("filterNames") {
        Some(v) => {
            let names = v.value.as_strings().ok_or_else(|| {
                err("variable 'filterNames' is not a cell array of strings or a char array".into())
            })?;
            if names.len() != columns.len() {
                return Err(err(format!(
                    "'filterNames' has {} names for {} spectra in 'data'",
                    names.len(),
                    columns.len()
                )));
            }
            unique_names(names)
        }
        None => (1..=columns.len()).map(|j| format!("data_{j}")).collect(),
    };
    let comment = find("comment").and_then(|v| v.value.as_string());
    let table = SpectraTable {
        wavelengths_nm,
        names,
        columns,
    };
    table.validate(&path.display().to_string())?;
    Ok(IsetcamSpectra { table, comment })
}

/// Make names usable as table columns: trimmed, non-empty, unique, no commas.
fn unique_names(names: Vec<String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(names.len());
    for (j, n) in names.into_iter().enumerate() {
        let mut base = n.trim().replace([',', '\n', '\r'], "_");
        if base.is_empty() || base.starts_with('#') {
            base = format!("data_{}", j + 1);
        }
        let mut name = base.clone();
        let mut k = 2;
        while out.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        out.push(name);
    }
    out
}

/// Read an ISETCam spectral data file (`wavelength`, `data`, optional `filterNames`, `comment`).
pub fn read_isetcam_file(path: impl AsRef<Path>) -> Result<IsetcamSpectra> {
    let path = path.as_ref();
    let vars = read_mat_variables(path)?;
    isetcam_spectra_from_variables(&vars, path)
}

/// Read an ISETCam spectral data file as a [`SpectraTable`]: one column per spectrum of `data`,
/// named from `filterNames` (or `data_1..n`).
pub fn read_isetcam_spectra(path: impl AsRef<Path>) -> Result<SpectraTable> {
    read_isetcam_file(path).map(|f| f.table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_short_and_foreign_headers() {
        let p = Path::new("x.mat");
        assert!(parse_mat_bytes(b"hello", p)
            .unwrap_err()
            .to_string()
            .contains("x.mat"));
        let mut h = vec![b' '; 128];
        h[..10].copy_from_slice(b"MATLAB 7.3");
        assert!(parse_mat_bytes(&h, p)
            .unwrap_err()
            .to_string()
            .contains("HDF5"));
        let mut h = vec![b' '; 128];
        h[126] = b'X';
        assert!(parse_mat_bytes(&h, p)
            .unwrap_err()
            .to_string()
            .contains("endian"));
        let mut h = vec![b' '; 128];
        h[124..128].copy_from_slice(&[0, 1, b'I', b'M']);
        assert_eq!(parse_mat_bytes(&h, p).unwrap(), vec![]);
        h[124..126].copy_from_slice(&[0, 2]);
        assert!(parse_mat_bytes(&h, p)
            .unwrap_err()
            .to_string()
            .contains("version"));
    }

    #[test]
    fn unique_names_dedupes() {
        let n = unique_names(vec!["g".into(), "g".into(), "".into(), "a,b".into()]);
        assert_eq!(n, vec!["g", "g_2", "data_3", "a_b"]);
    }
}
