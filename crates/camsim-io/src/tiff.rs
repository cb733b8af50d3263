//! A minimal TIFF structure reader and writer: enough for DNG (IFD chains, SubIFDs, EXIF IFD,
//! every TIFF 6 field type, both byte orders). Every offset and count is bounds-checked.

use std::collections::{BTreeMap, HashSet};

/// TIFF field types (TIFF 6.0 section 2; 13 = IFD from TIFF Technical Note 1).
pub mod ty {
    pub const BYTE: u16 = 1;
    pub const ASCII: u16 = 2;
    pub const SHORT: u16 = 3;
    pub const LONG: u16 = 4;
    pub const RATIONAL: u16 = 5;
    pub const SBYTE: u16 = 6;
    pub const UNDEFINED: u16 = 7;
    pub const SSHORT: u16 = 8;
    pub const SLONG: u16 = 9;
    pub const SRATIONAL: u16 = 10;
    pub const FLOAT: u16 = 11;
    pub const DOUBLE: u16 = 12;
    pub const IFD: u16 = 13;
}

fn type_size(t: u16) -> Option<usize> {
    Some(match t {
        1 | 2 | 6 | 7 => 1,
        3 | 8 => 2,
        4 | 9 | 11 | 13 => 4,
        5 | 10 | 12 => 8,
        _ => return None,
    })
}

/// One IFD entry: where its value bytes are in the file.
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    pub typ: u16,
    pub count: usize,
    pub offset: usize,
}

/// One image file directory: tag -> entry.
#[derive(Debug, Clone, Default)]
pub struct Ifd {
    pub entries: BTreeMap<u16, Entry>,
    /// Where this IFD starts in the file.
    pub position: usize,
}

/// A parsed TIFF file: the data and its IFDs (the IFD0 chain, SubIFDs and EXIF IFDs, in the
/// order found).
pub struct Tiff<'a> {
    pub data: &'a [u8],
    pub little_endian: bool,
    pub ifds: Vec<Ifd>,
    /// Index into `ifds` of each EXIF IFD found (tag 34665), for the IFD that pointed to it.
    pub exif: Vec<usize>,
}

/// Tags that point to sub-IFDs.
const SUB_IFDS: u16 = 330;
const EXIF_IFD: u16 = 34665;
const MAX_IFDS: usize = 64;

impl<'a> Tiff<'a> {
    /// Parse the header and every reachable IFD.
    pub fn parse(data: &'a [u8]) -> Result<Tiff<'a>, String> {
        if data.len() < 8 {
            return Err("file is too short to be a TIFF/DNG".into());
        }
        let little_endian = match &data[0..2] {
            b"II" => true,
            b"MM" => false,
            _ => return Err("not a TIFF/DNG file (no II or MM byte-order mark)".into()),
        };
        let mut t = Tiff {
            data,
            little_endian,
            ifds: Vec::new(),
            exif: Vec::new(),
        };
        let magic = t.u16_at(2)?;
        if magic == 43 {
            return Err("BigTIFF files are not supported".into());
        }
        if magic != 42 {
            return Err(format!("TIFF magic number is {magic}, not 42"));
        }
        let first = t.u32_at(4)? as usize;
        let mut visited = HashSet::new();
        // Depth-first over the IFD0 chain and all sub-IFDs.
        let mut queue: Vec<(usize, bool)> = vec![(first, true)];
        while let Some((off, chain)) = queue.pop() {
            if off == 0 || !visited.insert(off) {
                continue;
            }
            if t.ifds.len() >= MAX_IFDS {
                return Err(format!(
                    "more than {MAX_IFDS} IFDs (a loop or a corrupt file)"
                ));
            }
            let (ifd, next) = t.read_ifd(off)?;
            let idx = t.ifds.len();
            let subs: Vec<usize> = match ifd.entries.get(&SUB_IFDS) {
                Some(e) => t.uints(e)?.into_iter().map(|v| v as usize).collect(),
                None => Vec::new(),
            };
            let exif = match ifd.entries.get(&EXIF_IFD) {
                Some(e) => t.uints(e)?.first().map(|v| *v as usize),
                None => None,
            };
            t.ifds.push(ifd);
            if chain && next != 0 {
                queue.push((next, true));
            }
            for s in subs.into_iter().rev() {
                queue.push((s, false));
            }
            if let Some(x) = exif {
                if x != 0 && !visited.contains(&x) && x < data.len() {
                    // Parse the EXIF IFD now so we know its index.
                    if let Ok((e, _)) = t.read_ifd(x) {
                        visited.insert(x);
                        t.exif.push(t.ifds.len());
                        t.ifds.push(e);
                    }
                }
            }
            let _ = idx;
        }
        if t.ifds.is_empty() {
            return Err("no IFD in the file".into());
        }
        Ok(t)
    }

    fn bytes(&self, off: usize, n: usize) -> Result<&'a [u8], String> {
        off.checked_add(n)
            .and_then(|end| self.data.get(off..end))
            .ok_or_else(|| {
                format!(
                    "{n} bytes at offset {off} run past the end of the file ({} bytes)",
                    self.data.len()
                )
            })
    }

    fn u16_at(&self, off: usize) -> Result<u16, String> {
        let b = self.bytes(off, 2)?;
        Ok(if self.little_endian {
            u16::from_le_bytes([b[0], b[1]])
        } else {
            u16::from_be_bytes([b[0], b[1]])
        })
    }

    fn u32_at(&self, off: usize) -> Result<u32, String> {
        let b = self.bytes(off, 4)?;
        let a = [b[0], b[1], b[2], b[3]];
        Ok(if self.little_endian {
            u32::from_le_bytes(a)
        } else {
            u32::from_be_bytes(a)
        })
    }

    fn read_ifd(&self, off: usize) -> Result<(Ifd, usize), String> {
        let n = self.u16_at(off)? as usize;
        self.bytes(off + 2, n * 12 + 4).map_err(|_| {
            format!("IFD at offset {off} with {n} entries runs past the end of the file")
        })?;
        let mut ifd = Ifd {
            entries: BTreeMap::new(),
            position: off,
        };
        for i in 0..n {
            let p = off + 2 + 12 * i;
            let tag = self.u16_at(p)?;
            let typ = self.u16_at(p + 2)?;
            let count = self.u32_at(p + 4)? as usize;
            let Some(size) = type_size(typ) else { continue }; // unknown types are skipped (TIFF 6)
            let total = size
                .checked_mul(count)
                .ok_or_else(|| format!("tag {tag}: count {count} overflows"))?;
            let offset = if total <= 4 {
                p + 8
            } else {
                self.u32_at(p + 8)? as usize
            };
            self.bytes(offset, total)
                .map_err(|m| format!("tag {tag}: {m}"))?;
            ifd.entries.insert(tag, Entry { typ, count, offset });
        }
        let next = self.u32_at(off + 2 + 12 * n)? as usize;
        Ok((ifd, next))
    }

    /// Integer values of an entry (BYTE, SHORT, LONG, IFD, signed types, UNDEFINED as bytes).
    pub fn uints(&self, e: &Entry) -> Result<Vec<u64>, String> {
        let mut v = Vec::with_capacity(e.count);
        for i in 0..e.count {
            v.push(match e.typ {
                ty::BYTE | ty::UNDEFINED | ty::ASCII => self.data[e.offset + i] as u64,
                ty::SBYTE => (self.data[e.offset + i] as i8).max(0) as u64,
                ty::SHORT => self.u16_at(e.offset + 2 * i)? as u64,
                ty::SSHORT => (self.u16_at(e.offset + 2 * i)? as i16).max(0) as u64,
                ty::LONG | ty::IFD => self.u32_at(e.offset + 4 * i)? as u64,
                ty::SLONG => (self.u32_at(e.offset + 4 * i)? as i32).max(0) as u64,
                _ => return Err(format!("field type {} is not an integer type", e.typ)),
            });
        }
        Ok(v)
    }

    /// Numeric values of an entry as f64 (every numeric type, rationals divided out).
    pub fn floats(&self, e: &Entry) -> Result<Vec<f64>, String> {
        let mut v = Vec::with_capacity(e.count);
        for i in 0..e.count {
            v.push(match e.typ {
                ty::RATIONAL => {
                    let n = self.u32_at(e.offset + 8 * i)? as f64;
                    let d = self.u32_at(e.offset + 8 * i + 4)? as f64;
                    if d == 0.0 {
                        0.0
                    } else {
                        n / d
                    }
                }
                ty::SRATIONAL => {
                    let n = self.u32_at(e.offset + 8 * i)? as i32 as f64;
                    let d = self.u32_at(e.offset + 8 * i + 4)? as i32 as f64;
                    if d == 0.0 {
                        0.0
                    } else {
                        n / d
                    }
                }
                ty::SBYTE => self.data[e.offset + i] as i8 as f64,
                ty::SSHORT => self.u16_at(e.offset + 2 * i)? as i16 as f64,
                ty::SLONG => self.u32_at(e.offset + 4 * i)? as i32 as f64,
                ty::FLOAT => f32::from_bits(self.u32_at(e.offset + 4 * i)?) as f64,
                ty::DOUBLE => {
                    let hi = self.u32_at(e.offset + 8 * i)? as u64;
                    let lo = self.u32_at(e.offset + 8 * i + 4)? as u64;
                    let bits = if self.little_endian {
                        (lo << 32) | hi
                    } else {
                        (hi << 32) | lo
                    };
                    f64::from_bits(bits)
                }
                _ => self.uints(&Entry {
                    count: 1,
                    offset: e.offset + i * type_size(e.typ).unwrap_or(1),
                    ..*e
                })?[0] as f64,
            });
        }
        Ok(v)
    }

    /// Text of an ASCII (or BYTE/UNDEFINED) entry, up to the first NUL.
    pub fn ascii(&self, e: &Entry) -> String {
        let b = &self.data[e.offset..e.offset + e.count];
        let end = b.iter().position(|c| *c == 0).unwrap_or(b.len());
        String::from_utf8_lossy(&b[..end]).trim().to_string()
    }

    /// The raw value bytes of an entry.
    pub fn raw(&self, e: &Entry) -> &'a [u8] {
        let size = type_size(e.typ).unwrap_or(1);
        &self.data[e.offset..e.offset + e.count * size]
    }
}

// ---------------------------------------------------------------------------------------------
// Writer

/// A typed TIFF field value, for writing.
#[derive(Debug, Clone)]
pub enum Value {
    Byte(Vec<u8>),
    Ascii(String),
    Short(Vec<u16>),
    Long(Vec<u32>),
    Rational(Vec<(u32, u32)>),
    SRational(Vec<(i32, i32)>),
    Undefined(Vec<u8>),
}

impl Value {
    fn typ(&self) -> u16 {
        match self {
            Value::Byte(_) => ty::BYTE,
            Value::Ascii(_) => ty::ASCII,
            Value::Short(_) => ty::SHORT,
            Value::Long(_) => ty::LONG,
            Value::Rational(_) => ty::RATIONAL,
            Value::SRational(_) => ty::SRATIONAL,
            Value::Undefined(_) => ty::UNDEFINED,
        }
    }
    fn encode(&self, le: bool) -> (u32, Vec<u8>) {
        let w16 = |v: u16| if le { v.to_le_bytes() } else { v.to_be_bytes() };
        let w32 = |v: u32| if le { v.to_le_bytes() } else { v.to_be_bytes() };
        match self {
            Value::Byte(b) | Value::Undefined(b) => (b.len() as u32, b.clone()),
            Value::Ascii(s) => {
                let mut b: Vec<u8> = s
                    .bytes()
                    .map(|c| if c.is_ascii() && c != 0 { c } else { b'?' })
                    .collect();
                b.push(0);
                (b.len() as u32, b)
            }
            Value::Short(v) => (v.len() as u32, v.iter().flat_map(|x| w16(*x)).collect()),
            Value::Long(v) => (v.len() as u32, v.iter().flat_map(|x| w32(*x)).collect()),
            Value::Rational(v) => (
                v.len() as u32,
                v.iter()
                    .flat_map(|(n, d)| w32(*n).into_iter().chain(w32(*d)))
                    .collect(),
            ),
            Value::SRational(v) => (
                v.len() as u32,
                v.iter()
                    .flat_map(|(n, d)| w32(*n as u32).into_iter().chain(w32(*d as u32)))
                    .collect(),
            ),
        }
    }
}

/// One IFD to write: its tags (sorted on output), and the tags that hold the offsets and byte
/// counts of its image segments (`StripOffsets`/`StripByteCounts` or the tile pair).
pub struct IfdSpec {
    pub tags: Vec<(u16, Value)>,
    pub segment_offsets_tag: u16,
    pub segment_counts_tag: u16,
    pub segment_lens: Vec<u64>,
    /// IFDs reached through the SubIFDs tag (330) of this IFD (IFD0 only).
    pub sub_ifds: Vec<IfdSpec>,
    /// Tags of an EXIF IFD reached through tag 34665 of this IFD (IFD0 only); empty: none.
    pub exif_tags: Vec<(u16, Value)>,
}

/// Lay out a TIFF: header, IFD0 (with its SubIFDs), all value data, then every image segment
/// in order (IFD0's first, then its SubIFDs'). Returns the bytes before the first segment;
/// segments must be written right after them, in order, each padded to an even length.
pub fn layout(ifd0: &IfdSpec, little_endian: bool) -> Result<Vec<u8>, String> {
    // Flatten: IFD0, its sub-IFDs (one level; enough for DNG), then the EXIF IFD if any.
    let mut flat: Vec<&IfdSpec> = vec![ifd0];
    flat.extend(ifd0.sub_ifds.iter());
    let n_sub = ifd0.sub_ifds.len();
    let has_exif = !ifd0.exif_tags.is_empty();
    // Tag lists with placeholders for the offset arrays.
    let mut lists: Vec<Vec<(u16, Value)>> = Vec::new();
    for (k, spec) in flat.iter().enumerate() {
        let mut tags = spec.tags.clone();
        tags.push((
            spec.segment_offsets_tag,
            Value::Long(vec![0; spec.segment_lens.len()]),
        ));
        let counts: Result<Vec<u32>, String> = spec
            .segment_lens
            .iter()
            .map(|l| u32::try_from(*l).map_err(|_| "segment over 4 GiB".to_string()))
            .collect();
        tags.push((spec.segment_counts_tag, Value::Long(counts?)));
        if k == 0 && n_sub > 0 {
            tags.push((SUB_IFDS, Value::Long(vec![0; n_sub])));
        }
        if k == 0 && has_exif {
            tags.push((EXIF_IFD, Value::Long(vec![0])));
        }
        lists.push(tags);
    }
    if has_exif {
        lists.push(ifd0.exif_tags.clone());
    }
    for tags in lists.iter_mut() {
        tags.sort_by_key(|t| t.0);
        for w in tags.windows(2) {
            if w[0].0 == w[1].0 {
                return Err(format!("tag {} given twice", w[0].0));
            }
        }
    }
    // Positions: header 8, then each IFD, then value data.
    let mut ifd_pos = Vec::new();
    let mut pos = 8usize;
    for l in &lists {
        ifd_pos.push(pos);
        pos += 2 + 12 * l.len() + 4;
    }
    let value_start = pos;
    // Sizes of out-of-line values.
    let mut value_pos: Vec<Vec<Option<usize>>> = Vec::new();
    for l in &lists {
        let mut v = Vec::new();
        for (_, val) in l {
            let (_, bytes) = val.encode(little_endian);
            if bytes.len() > 4 {
                v.push(Some(pos));
                pos += bytes.len() + (bytes.len() & 1);
            } else {
                v.push(None);
            }
        }
        value_pos.push(v);
    }
    let data_start = pos;
    // Segment offsets.
    let mut seg = data_start as u64;
    for (k, spec) in flat.iter().enumerate() {
        let offs: Vec<u32> = spec
            .segment_lens
            .iter()
            .map(|l| {
                let o = seg;
                seg += l + (l & 1);
                u32::try_from(o).map_err(|_| "file over 4 GiB".to_string())
            })
            .collect::<Result<_, _>>()?;
        for t in lists[k].iter_mut() {
            if t.0 == spec.segment_offsets_tag {
                t.1 = Value::Long(offs.clone());
            }
        }
    }
    let subs: Vec<u32> = ifd_pos[1..1 + n_sub].iter().map(|p| *p as u32).collect();
    let exif_pos = *ifd_pos.last().unwrap() as u32;
    for t in lists[0].iter_mut() {
        if t.0 == SUB_IFDS {
            t.1 = Value::Long(subs.clone());
        } else if t.0 == EXIF_IFD && has_exif {
            t.1 = Value::Long(vec![exif_pos]);
        }
    }
    // Serialize.
    let w16 = |v: u16| {
        if little_endian {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        }
    };
    let w32 = |v: u32| {
        if little_endian {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        }
    };
    let mut out = Vec::with_capacity(data_start);
    out.extend_from_slice(if little_endian { b"II" } else { b"MM" });
    out.extend_from_slice(&w16(42));
    out.extend_from_slice(&w32(8));
    for (k, l) in lists.iter().enumerate() {
        debug_assert_eq!(out.len(), ifd_pos[k]);
        out.extend_from_slice(&w16(l.len() as u16));
        for (i, (tag, val)) in l.iter().enumerate() {
            let (count, bytes) = val.encode(little_endian);
            out.extend_from_slice(&w16(*tag));
            out.extend_from_slice(&w16(val.typ()));
            out.extend_from_slice(&w32(count));
            match value_pos[k][i] {
                Some(p) => out.extend_from_slice(&w32(p as u32)),
                None => {
                    let mut b = [0u8; 4];
                    b[..bytes.len()].copy_from_slice(&bytes);
                    out.extend_from_slice(&b);
                }
            }
        }
        out.extend_from_slice(&w32(0)); // no next IFD: sub-IFDs are reached through tag 330
    }
    debug_assert_eq!(out.len(), value_start);
    for l in &lists {
        for (_, val) in l {
            let (_, bytes) = val.encode(little_endian);
            if bytes.len() > 4 {
                out.extend_from_slice(&bytes);
                if bytes.len() & 1 == 1 {
                    out.push(0);
                }
            }
        }
    }
    debug_assert_eq!(out.len(), data_start);
    Ok(out)
}
