//! PLY mesh reader (Turk 1994 format as pbrt-v4's `plymesh` uses it): `ascii`,
//! `binary_little_endian` and `binary_big_endian`; vertex `x y z`, optional `nx ny nz` and
//! texture coordinates (`u v`, `s t`, `texture_u texture_v`, `texture_s texture_t`); faces as a
//! `vertex_indices` (or `vertex_index`) list of 3 or 4 entries (quads become two triangles).
//! Other elements and properties are skipped. Malformed files give an error, never a panic, and
//! counts in the header are checked against the file size before anything is allocated.

/// A mesh read from a PLY file (object space).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlyMesh {
    pub positions: Vec<[f64; 3]>,
    pub normals: Option<Vec<[f64; 3]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub triangles: Vec<[u32; 3]>,
    /// Number of quads that were split into two triangles.
    pub quads: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug, Clone)]
enum Prop {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Le,
    Be,
}

/// Source of values: ASCII tokens or binary bytes.
struct Reader<'a> {
    fmt: Format,
    bytes: &'a [u8],
    pos: usize,
    tokens: Option<std::str::SplitAsciiWhitespace<'a>>,
}

impl<'a> Reader<'a> {
    /// A reader of `data` in format `fmt` (an ASCII body must be text).
    fn new(fmt: Format, data: &'a [u8]) -> Result<Reader<'a>, String> {
        Ok(Reader {
            fmt,
            bytes: data,
            pos: 0,
            tokens: if fmt == Format::Ascii {
                Some(
                    std::str::from_utf8(data)
                        .map_err(|_| "ASCII PLY body is not text")?
                        .split_ascii_whitespace(),
                )
            } else {
                None
            },
        })
    }

    fn read(&mut self, t: Scalar) -> Result<f64, String> {
        if self.fmt == Format::Ascii {
            let tok = self
                .tokens
                .as_mut()
                .and_then(|t| t.next())
                .ok_or("unexpected end of data")?;
            return tok
                .parse::<f64>()
                .map_err(|_| format!("\"{tok}\" is not a number"));
        }
        let n = t.size();
        let end = self.pos.checked_add(n).ok_or("file too short")?;
        let b = self
            .bytes
            .get(self.pos..end)
            .ok_or("unexpected end of binary data")?;
        self.pos = end;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.fmt == Format::Be {
            a[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => a[0] as i8 as f64,
            Scalar::U8 => a[0] as f64,
            Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }
}

/// Read a PLY file.
pub fn read_ply(path: &std::path::Path) -> Result<PlyMesh, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_ply(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Parse PLY bytes: the header, then each element's data in order (vertices, faces, others
/// skipped), then a check that every face index names a vertex.
pub fn parse_ply(bytes: &[u8]) -> Result<PlyMesh, String> {
    let (header, body) = split_header(bytes)?;
    let (fmt, elements) = parse_header(header)?;
    let data = &bytes[body..];
    check_data_size(fmt, &elements, data.len())?;
    let mut r = Reader::new(fmt, data)?;
    let mut mesh = PlyMesh::default();
    for e in &elements {
        match e.name.as_str() {
            "vertex" => read_vertices(e, &mut r, &mut mesh)?,
            "face" => read_faces(e, &mut r, &mut mesh)?,
            _ => skip_element(e, &mut r)?,
        }
    }
    check_indices(&mesh)?;
    Ok(mesh)
}

/// The header text (up to `end_header`) and the offset of the body (after the end_header line).
fn split_header(bytes: &[u8]) -> Result<(&str, usize), String> {
    // Header: lines up to "end_header\n".
    let marker = b"end_header";
    let hdr_end = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .ok_or("no end_header in PLY header")?;
    let mut body = hdr_end + marker.len();
    // Skip the rest of the end_header line.
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body = (body + 1).min(bytes.len());
    let header = std::str::from_utf8(&bytes[..hdr_end]).map_err(|_| "PLY header is not text")?;
    Ok((header, body))
}

/// The format line and the element declarations (with their properties) of a header.
fn parse_header(header: &str) -> Result<(Format, Vec<Element>), String> {
    let mut lines = header.lines();
    if lines.next().map(|l| l.trim()) != Some("ply") {
        return Err("not a PLY file (first line is not \"ply\")".into());
    }
    let mut fmt = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, line) in lines.enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let lno = i + 2;
        match w.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                fmt = Some(match w.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Le,
                    Some("binary_big_endian") => Format::Be,
                    other => return Err(format!("header line {lno}: unknown format {other:?}")),
                })
            }
            Some("element") => {
                let (Some(name), Some(count)) = (w.get(1), w.get(2)) else {
                    return Err(format!(
                        "header line {lno}: element needs a name and a count"
                    ));
                };
                let count: usize = count
                    .parse()
                    .map_err(|_| format!("header line {lno}: bad element count \"{count}\""))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or(format!("header line {lno}: property before any element"))?;
                el.props.push(parse_property(&w, lno)?);
            }
            Some(other) => return Err(format!("header line {lno}: unknown keyword \"{other}\"")),
        }
    }
    let fmt = fmt.ok_or("PLY header has no format line")?;
    Ok((fmt, elements))
}

/// A `property` line split in words (`w[0]` is "property"), at header line `lno`.
fn parse_property(w: &[&str], lno: usize) -> Result<Prop, String> {
    if w.get(1) == Some(&"list") {
        let (Some(ct), Some(it), Some(name)) = (w.get(2), w.get(3), w.get(4)) else {
            return Err(format!(
                "header line {lno}: list property needs count type, item type, name"
            ));
        };
        let ct = Scalar::parse(ct).ok_or(format!("header line {lno}: unknown type {ct}"))?;
        let it = Scalar::parse(it).ok_or(format!("header line {lno}: unknown type {it}"))?;
        Ok(Prop::List(name.to_string(), ct, it))
    } else {
        let (Some(t), Some(name)) = (w.get(1), w.get(2)) else {
            return Err(format!(
                "header line {lno}: property needs a type and a name"
            ));
        };
        let t = Scalar::parse(t).ok_or(format!("header line {lno}: unknown type {t}"))?;
        Ok(Prop::Scalar(name.to_string(), t))
    }
}

/// Each element needs at least one byte (binary) or two characters (ASCII) per value: refuse
/// counts the file cannot hold before allocating.
fn check_data_size(fmt: Format, elements: &[Element], data_len: usize) -> Result<(), String> {
    let mut min_bytes: u128 = 0;
    for e in elements {
        let per: usize = e
            .props
            .iter()
            .map(|p| match p {
                Prop::Scalar(_, t) => {
                    if fmt == Format::Ascii {
                        2
                    } else {
                        t.size()
                    }
                }
                Prop::List(_, c, _) => {
                    if fmt == Format::Ascii {
                        2
                    } else {
                        c.size()
                    }
                }
            })
            .sum();
        min_bytes += e.count as u128 * per as u128;
    }
    if min_bytes > data_len as u128 + 1 {
        return Err(format!(
            "header declares more data than the file holds ({} bytes needed, {} present)",
            min_bytes, data_len
        ));
    }
    Ok(())
}

/// The `vertex` element: positions, and normals and uv when the element has them.
fn read_vertices(e: &Element, r: &mut Reader, mesh: &mut PlyMesh) -> Result<(), String> {
    let idx = |n: &str| {
        e.props
            .iter()
            .position(|p| matches!(p, Prop::Scalar(m, _) if m == n))
    };
    let (Some(ix), Some(iy), Some(iz)) = (idx("x"), idx("y"), idx("z")) else {
        return Err("vertex element lacks x, y or z".into());
    };
    let normal = match (idx("nx"), idx("ny"), idx("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let uv = [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ]
    .iter()
    .find_map(|(a, b)| Some([idx(a)?, idx(b)?]));
    camsim_core::mem::check_alloc(e.count as u64 * 64, "PLY vertices")
        .map_err(|x| x.to_string())?;
    mesh.positions.reserve(e.count);
    let mut ns = Vec::new();
    let mut uvs = Vec::new();
    let mut vals = vec![0.0; e.props.len()];
    for _ in 0..e.count {
        for (k, p) in e.props.iter().enumerate() {
            match p {
                Prop::Scalar(_, t) => vals[k] = r.read(*t)?,
                Prop::List(_, c, it) => {
                    let n = r.read(*c)?;
                    for _ in 0..(n.max(0.0) as usize).min(1 << 20) {
                        r.read(*it)?;
                    }
                }
            }
        }
        mesh.positions.push([vals[ix], vals[iy], vals[iz]]);
        if let Some([a, b, c]) = normal {
            ns.push([vals[a], vals[b], vals[c]]);
        }
        if let Some([a, b]) = uv {
            uvs.push([vals[a] as f32, vals[b] as f32]);
        }
    }
    if normal.is_some() {
        mesh.normals = Some(ns);
    }
    if uv.is_some() {
        mesh.uvs = Some(uvs);
    }
    Ok(())
}

/// The `face` element: each face's `vertex_indices` list, triangulated ([`triangulate`]).
fn read_faces(e: &Element, r: &mut Reader, mesh: &mut PlyMesh) -> Result<(), String> {
    let li = e
        .props
        .iter()
        .position(
            |p| matches!(p, Prop::List(m, _, _) if m == "vertex_indices" || m == "vertex_index"),
        )
        .ok_or("face element lacks a vertex_indices list")?;
    camsim_core::mem::check_alloc(e.count as u64 * 24, "PLY faces").map_err(|x| x.to_string())?;
    mesh.triangles.reserve(e.count);
    let mut idx = Vec::with_capacity(4);
    for f in 0..e.count {
        for (k, p) in e.props.iter().enumerate() {
            match p {
                Prop::Scalar(_, t) => {
                    r.read(*t)?;
                }
                Prop::List(_, c, it) => {
                    let n = list_len(r, *c, || format!("face {f}"))?;
                    if k == li {
                        idx.clear();
                        for _ in 0..n {
                            let v = r.read(*it)?;
                            if v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
                                return Err(format!(
                                    "face {f}: vertex index {v} is not a valid index"
                                ));
                            }
                            idx.push(v as u32);
                        }
                    } else {
                        for _ in 0..n {
                            r.read(*it)?;
                        }
                    }
                }
            }
        }
        triangulate(f, &idx, mesh)?;
    }
    Ok(())
}

/// Face `f` with vertex indices `idx` as triangles: a quad `0 1 2 3` becomes `0 1 2` and `0 2 3`.
fn triangulate(f: usize, idx: &[u32], mesh: &mut PlyMesh) -> Result<(), String> {
    match idx.len() {
        3 => mesh.triangles.push([idx[0], idx[1], idx[2]]),
        4 => {
            mesh.triangles.push([idx[0], idx[1], idx[2]]);
            mesh.triangles.push([idx[0], idx[2], idx[3]]);
            mesh.quads += 1;
        }
        n => {
            return Err(format!(
                "face {f} has {n} vertices; only triangles and quads are supported"
            ))
        }
    }
    Ok(())
}

/// A list's length (count type `c`), refused beyond 2^20 entries; `what` names the list.
fn list_len(r: &mut Reader, c: Scalar, what: impl FnOnce() -> String) -> Result<usize, String> {
    let n = r.read(c)?;
    if !(0.0..=(1u32 << 20) as f64).contains(&n) {
        return Err(format!("{}: list length {n} is out of range", what()));
    }
    Ok(n as usize)
}

/// Read past an element camsim does not use.
fn skip_element(e: &Element, r: &mut Reader) -> Result<(), String> {
    for _ in 0..e.count {
        for p in &e.props {
            match p {
                Prop::Scalar(_, t) => {
                    r.read(*t)?;
                }
                Prop::List(_, c, it) => {
                    let n = list_len(r, *c, || format!("element {}", e.name))?;
                    for _ in 0..n {
                        r.read(*it)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Every face index names a vertex.
fn check_indices(mesh: &PlyMesh) -> Result<(), String> {
    let nv = mesh.positions.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return Err(format!(
            "face {:?} refers to a vertex beyond the {nv} vertices",
            t
        ));
    }
    Ok(())
}
