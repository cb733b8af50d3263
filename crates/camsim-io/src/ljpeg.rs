//! Lossless JPEG decoder (ITU-T T.81 Annex H, "process 14": Huffman-coded, predictive, SOF3),
//! the compression DNG uses for raw data (Compression = 7). Handles 2..16-bit precision, any
//! number of interleaved components with 1x1 sampling, predictors 1-7, point transform, restart
//! markers. Every read is bounds-checked: malformed streams give an error, never a panic.

use std::fmt;

/// A decode failure, with what was wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LjpegError(pub String);

impl fmt::Display for LjpegError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "lossless JPEG: {}", self.0)
    }
}

impl std::error::Error for LjpegError {}

fn err<T>(m: impl Into<String>) -> Result<T, LjpegError> {
    Err(LjpegError(m.into()))
}

/// A decoded lossless JPEG frame: samples interleaved by component, row-major
/// (`samples[(row * width + col) * components + c]`).
#[derive(Debug, Clone, PartialEq)]
pub struct LjpegImage {
    /// Frame width (X in SOF3), in samples per component.
    pub width: usize,
    /// Frame height (Y in SOF3).
    pub height: usize,
    /// Number of components (Nf).
    pub components: usize,
    /// Sample precision, bits (P).
    pub precision: u8,
    /// Decoded samples.
    pub samples: Vec<u16>,
}

/// A Huffman table as a 16-bit lookup: entry = (code length, symbol); length 0 = invalid code.
struct Huffman {
    lut: Vec<(u8, u8)>,
}

impl Huffman {
    /// Build from the DHT counts (codes of length 1..=16) and symbols (T.81 Annex C).
    fn new(counts: &[u8; 16], symbols: &[u8]) -> Result<Huffman, LjpegError> {
        let mut lut = vec![(0u8, 0u8); 1 << 16];
        let mut code: u32 = 0;
        let mut k = 0usize;
        for (i, &n) in counts.iter().enumerate() {
            let len = i as u32 + 1;
            for _ in 0..n {
                if code >= (1 << len) {
                    return err("Huffman table has more codes than its lengths allow");
                }
                let sym = *symbols
                    .get(k)
                    .ok_or_else(|| LjpegError("Huffman table is short of symbols".into()))?;
                let shift = 16 - len;
                let start = (code << shift) as usize;
                let end = ((code + 1) << shift) as usize;
                for e in &mut lut[start..end] {
                    *e = (len as u8, sym);
                }
                code += 1;
                k += 1;
            }
            code <<= 1;
        }
        Ok(Huffman { lut })
    }
}

/// MSB-first bit reader over entropy-coded data: removes stuffed zero bytes after 0xFF and
/// stops at a marker (feeding zeros after it, which the caller detects by position).
struct BitReader<'a> {
    data: &'a [u8],
    pos: usize,
    acc: u64,
    bits: u32,
    /// A marker (0xFF followed by a non-zero byte) was reached.
    hit_marker: bool,
    /// Zero bits fed past the end of the data or a marker.
    overrun_bits: u32,
}

impl<'a> BitReader<'a> {
    fn new(data: &'a [u8], pos: usize) -> Self {
        BitReader {
            data,
            pos,
            acc: 0,
            bits: 0,
            hit_marker: false,
            overrun_bits: 0,
        }
    }

    #[inline]
    fn fill(&mut self) {
        while self.bits <= 56 {
            let mut byte = 0u8;
            if !self.hit_marker && self.pos < self.data.len() {
                let b = self.data[self.pos];
                if b == 0xFF {
                    match self.data.get(self.pos + 1) {
                        Some(0x00) => {
                            byte = 0xFF;
                            self.pos += 2;
                        }
                        _ => {
                            self.hit_marker = true;
                            self.overrun_bits += 8;
                        }
                    }
                } else {
                    byte = b;
                    self.pos += 1;
                }
            } else {
                self.overrun_bits += 8;
            }
            self.acc |= (byte as u64) << (56 - self.bits);
            self.bits += 8;
        }
    }

    #[inline]
    fn peek16(&mut self) -> u32 {
        if self.bits < 16 {
            self.fill();
        }
        (self.acc >> 48) as u32
    }

    #[inline]
    fn consume(&mut self, n: u32) {
        self.acc <<= n;
        self.bits -= n;
    }

    #[inline]
    fn get(&mut self, n: u32) -> u32 {
        if n == 0 {
            return 0;
        }
        if self.bits < n {
            self.fill();
        }
        let v = (self.acc >> (64 - n)) as u32;
        self.consume(n);
        v
    }

    /// Bits consumed beyond the real data (zeros fed after a marker or the end).
    fn overrun(&self) -> bool {
        // `bits` still buffered may include fed zeros; only consumed ones count.
        self.overrun_bits > self.bits
    }

    /// Discard buffered bits and position just after the next RSTn marker.
    fn restart(&mut self, expected: u8) -> Result<(), LjpegError> {
        // Un-buffer: find the marker in the byte stream from the current position.
        self.acc = 0;
        self.bits = 0;
        self.overrun_bits = 0;
        self.hit_marker = false;
        let mut p = self.pos;
        while p + 1 < self.data.len() {
            if self.data[p] == 0xFF && self.data[p + 1] != 0x00 && self.data[p + 1] != 0xFF {
                let m = self.data[p + 1];
                if (0xD0..=0xD7).contains(&m) {
                    if m != 0xD0 + expected {
                        return err(format!(
                            "restart marker RST{} where RST{expected} was expected",
                            m - 0xD0
                        ));
                    }
                    self.pos = p + 2;
                    return Ok(());
                }
                return err(format!(
                    "marker 0xFF{m:02X} where a restart marker was expected"
                ));
            }
            p += 1;
        }
        err("stream ends where a restart marker was expected")
    }
}

#[inline]
fn decode_diff(br: &mut BitReader, h: &Huffman) -> Result<i32, LjpegError> {
    let peek = br.peek16() as usize;
    let (len, ssss) = h.lut[peek];
    if len == 0 {
        return err("invalid Huffman code in the entropy-coded data");
    }
    br.consume(len as u32);
    Ok(match ssss {
        0 => 0,
        16 => 32768, // T.81 H.1.2.2: SSSS = 16 means difference 32768, no extra bits
        s if s < 16 => {
            let v = br.get(s as u32) as i32;
            // T.81 F.2.2.1 EXTEND: values below 2^(s-1) are negative.
            if v < (1 << (s - 1)) {
                v - (1 << s) + 1
            } else {
                v
            }
        }
        s => return err(format!("difference category {s} is above 16")),
    })
}

fn be16(d: &[u8], p: usize) -> Result<usize, LjpegError> {
    match d.get(p..p + 2) {
        Some(b) => Ok(u16::from_be_bytes([b[0], b[1]]) as usize),
        None => err("stream ends inside a marker segment"),
    }
}

struct Frame {
    precision: u8,
    height: usize,
    width: usize,
    comp_ids: Vec<u8>,
}

/// Decode a complete lossless JPEG stream (SOI ... EOI). `max_samples` bounds the frame size
/// (width x height x components) so a corrupt header cannot request a huge allocation.
pub fn decode(data: &[u8], max_samples: usize) -> Result<LjpegImage, LjpegError> {
    if data.len() < 4 || data[0] != 0xFF || data[1] != 0xD8 {
        return err("no SOI marker at the start");
    }
    let mut pos = 2;
    let mut tables: [Option<Huffman>; 4] = [None, None, None, None];
    let mut frame: Option<Frame> = None;
    let mut restart_interval = 0usize;
    loop {
        // Find the next marker (skip fill bytes 0xFF).
        if pos >= data.len() {
            return err("stream ends before a scan (SOS)");
        }
        if data[pos] != 0xFF {
            return err(format!("expected a marker at byte {pos}"));
        }
        while pos < data.len() && data[pos] == 0xFF {
            pos += 1;
        }
        let marker = *data
            .get(pos)
            .ok_or_else(|| LjpegError("stream ends inside a marker".into()))?;
        pos += 1;
        match marker {
            0xD8 | 0x01 | 0xD0..=0xD7 => continue, // standalone markers
            0xD9 => return err("EOI before any scan"),
            _ => {}
        }
        let len = be16(data, pos)?;
        if len < 2 || pos + len > data.len() {
            return err(format!(
                "marker 0xFF{marker:02X} segment length {len} runs past the end"
            ));
        }
        let seg = &data[pos + 2..pos + len];
        match marker {
            0xC3 => {
                if seg.len() < 6 {
                    return err("SOF3 segment too short");
                }
                let precision = seg[0];
                let height = u16::from_be_bytes([seg[1], seg[2]]) as usize;
                let width = u16::from_be_bytes([seg[3], seg[4]]) as usize;
                let nf = seg[5] as usize;
                if !(2..=16).contains(&precision) {
                    return err(format!("sample precision {precision} is outside 2..16"));
                }
                if width == 0 || height == 0 || nf == 0 || nf > 4 {
                    return err(format!(
                        "frame {width} x {height} with {nf} components is not decodable"
                    ));
                }
                if seg.len() < 6 + 3 * nf {
                    return err("SOF3 segment too short for its components");
                }
                let mut comp_ids = Vec::with_capacity(nf);
                for c in 0..nf {
                    let id = seg[6 + 3 * c];
                    let hv = seg[7 + 3 * c];
                    if hv != 0x11 {
                        return err(format!(
                            "component {id} has sampling factors {}x{}; only 1x1 is supported",
                            hv >> 4,
                            hv & 15
                        ));
                    }
                    comp_ids.push(id);
                }
                width
                    .checked_mul(height)
                    .and_then(|p| p.checked_mul(nf))
                    // Each sample costs at least one bit of entropy-coded data.
                    .filter(|t| *t <= max_samples && *t <= 8 * data.len() + 64)
                    .ok_or_else(|| {
                        LjpegError(format!(
                            "frame {width} x {height} x {nf} is larger than the tile it belongs to"
                        ))
                    })?;
                frame = Some(Frame {
                    precision,
                    height,
                    width,
                    comp_ids,
                });
            }
            0xC0..=0xC2 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => {
                return err(format!(
                    "frame type SOF{} is not lossless Huffman JPEG (SOF3)",
                    marker - 0xC0
                ));
            }
            0xC4 => {
                let mut p = 0;
                while p < seg.len() {
                    let tc_th = seg[p];
                    let th = (tc_th & 15) as usize;
                    if tc_th >> 4 != 0 || th > 3 {
                        return err(format!(
                            "DHT table class/id {tc_th:#04x} is not a DC table 0..3"
                        ));
                    }
                    let counts: [u8; 16] =
                        seg.get(p + 1..p + 17)
                            .and_then(|s| s.try_into().ok())
                            .ok_or_else(|| LjpegError("DHT segment too short".into()))?;
                    let n: usize = counts.iter().map(|c| *c as usize).sum();
                    let syms = seg.get(p + 17..p + 17 + n).ok_or_else(|| {
                        LjpegError("DHT segment too short for its symbols".into())
                    })?;
                    tables[th] = Some(Huffman::new(&counts, syms)?);
                    p += 17 + n;
                }
            }
            0xDD => {
                if seg.len() < 2 {
                    return err("DRI segment too short");
                }
                restart_interval = u16::from_be_bytes([seg[0], seg[1]]) as usize;
            }
            0xDA => {
                let f = frame
                    .as_ref()
                    .ok_or_else(|| LjpegError("SOS before SOF3".into()))?;
                let ns = *seg
                    .first()
                    .ok_or_else(|| LjpegError("SOS segment empty".into()))?
                    as usize;
                if ns != f.comp_ids.len() {
                    return err(format!("scan has {ns} of the frame's {} components; only single interleaved scans are supported", f.comp_ids.len()));
                }
                if seg.len() < 1 + 2 * ns + 3 {
                    return err("SOS segment too short");
                }
                let mut comp_tables = Vec::with_capacity(ns);
                for i in 0..ns {
                    let cs = seg[1 + 2 * i];
                    if f.comp_ids.get(i) != Some(&cs) {
                        return err(format!("scan component {cs} is not frame component {i}"));
                    }
                    let td = (seg[2 + 2 * i] >> 4) as usize;
                    if td > 3 || tables[td].is_none() {
                        return err(format!(
                            "scan component {cs} uses Huffman table {td}, which is not defined"
                        ));
                    }
                    comp_tables.push(td);
                }
                let predictor = seg[1 + 2 * ns];
                let pt = seg[3 + 2 * ns] & 15;
                if !(1..=7).contains(&predictor) {
                    return err(format!("predictor {predictor} is not 1..7"));
                }
                if pt >= f.precision {
                    return err(format!(
                        "point transform {pt} is not below the precision {}",
                        f.precision
                    ));
                }
                let start = pos + len;
                let samples = decode_scan(
                    data,
                    start,
                    f,
                    &tables,
                    &comp_tables,
                    predictor,
                    pt,
                    restart_interval,
                )?;
                return Ok(LjpegImage {
                    width: f.width,
                    height: f.height,
                    components: f.comp_ids.len(),
                    precision: f.precision,
                    samples,
                });
            }
            _ => {} // APPn, COM, DQT, DNL...: skip
        }
        pos += len;
    }
}

#[allow(clippy::too_many_arguments)]
fn decode_scan(
    data: &[u8],
    start: usize,
    f: &Frame,
    tables: &[Option<Huffman>; 4],
    comp_tables: &[usize],
    predictor: u8,
    pt: u8,
    restart_interval: usize,
) -> Result<Vec<u16>, LjpegError> {
    let nc = f.comp_ids.len();
    let (w, h) = (f.width, f.height);
    let row_len = w * nc;
    let mut out = vec![0u16; row_len * h];
    let mut br = BitReader::new(data, start);
    let hufs: Vec<&Huffman> = comp_tables
        .iter()
        .map(|t| tables[*t].as_ref().unwrap())
        .collect();
    let initial = 1i32 << (f.precision - pt - 1); // T.81 H.1.2.1: 2^(P - Pt - 1)
    let mask = 0xFFFFi32; // differences and predictions are modulo 2^16 (T.81 H.1.2.1)
    let mut mcus_left = restart_interval;
    let mut next_rst = 0u8;
    // `reset_row`: the row after a restart behaves as the first row of the image.
    let mut reset_row: Option<usize> = Some(0);
    let mut reset_col = 0usize;
    for row in 0..h {
        let (prev_rows, cur_rows) = out.split_at_mut(row * row_len);
        let cur = &mut cur_rows[..row_len];
        let above = if row > 0 {
            Some(&prev_rows[(row - 1) * row_len..])
        } else {
            None
        };
        for col in 0..w {
            if restart_interval > 0 {
                if mcus_left == 0 {
                    br.restart(next_rst)?;
                    next_rst = (next_rst + 1) & 7;
                    mcus_left = restart_interval;
                    reset_row = Some(row);
                    reset_col = col;
                }
                mcus_left -= 1;
            }
            let first_row = reset_row == Some(row);
            for (c, huf) in hufs.iter().enumerate() {
                let diff = decode_diff(&mut br, huf)?;
                let i = col * nc + c;
                let pred = if first_row {
                    if col == reset_col {
                        initial
                    } else {
                        cur[i - nc] as i32 // predictor 1 on the first line
                    }
                } else if col == 0 {
                    above.map_or(initial, |a| a[i] as i32) // predictor 2 at the line start
                } else {
                    let ra = cur[i - nc] as i32;
                    let a = above.unwrap();
                    let rb = a[i] as i32;
                    let rc = a[i - nc] as i32;
                    match predictor {
                        1 => ra,
                        2 => rb,
                        3 => rc,
                        4 => ra + rb - rc,
                        5 => ra + ((rb - rc) >> 1),
                        6 => rb + ((ra - rc) >> 1),
                        _ => (ra + rb) >> 1,
                    }
                };
                cur[i] = ((pred + diff) & mask) as u16;
            }
        }
        if br.overrun() {
            return err(format!(
                "entropy-coded data ends early (in row {row} of {h})"
            ));
        }
    }
    if pt > 0 {
        for v in &mut out {
            *v <<= pt;
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A test encoder for lossless JPEG (mirror of the decoder, written from T.81 Annex H):
    /// any predictor 1-7, `nc` interleaved components, optional restart interval, one Huffman
    /// table with deliberately mixed code lengths.
    pub fn encode(
        width: usize,
        height: usize,
        nc: usize,
        precision: u8,
        predictor: u8,
        restart: usize,
        samples: &[u16],
    ) -> Vec<u8> {
        assert_eq!(samples.len(), width * height * nc);
        // Code lengths for the 17 categories: Kraft sum < 1 (no all-ones code).
        let counts: [u8; 16] = [0, 1, 2, 3, 4, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        let symbols: Vec<u8> = vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16];
        let mut codes = [(0u32, 0u32); 17];
        let mut code = 0u32;
        let mut k = 0;
        for (i, &n) in counts.iter().enumerate() {
            for _ in 0..n {
                codes[symbols[k] as usize] = (code, i as u32 + 1);
                code += 1;
                k += 1;
            }
            code <<= 1;
        }
        let mut out = vec![0xFF, 0xD8];
        // SOF3
        out.extend_from_slice(&[0xFF, 0xC3]);
        out.extend_from_slice(&((8 + 3 * nc) as u16).to_be_bytes());
        out.push(precision);
        out.extend_from_slice(&(height as u16).to_be_bytes());
        out.extend_from_slice(&(width as u16).to_be_bytes());
        out.push(nc as u8);
        for c in 0..nc {
            out.extend_from_slice(&[c as u8 + 1, 0x11, 0]);
        }
        // DHT
        out.extend_from_slice(&[0xFF, 0xC4]);
        out.extend_from_slice(&((2 + 17 + symbols.len()) as u16).to_be_bytes());
        out.push(0x00);
        out.extend_from_slice(&counts);
        out.extend_from_slice(&symbols);
        if restart > 0 {
            out.extend_from_slice(&[0xFF, 0xDD, 0, 4]);
            out.extend_from_slice(&(restart as u16).to_be_bytes());
        }
        // SOS
        out.extend_from_slice(&[0xFF, 0xDA]);
        out.extend_from_slice(&((6 + 2 * nc) as u16).to_be_bytes());
        out.push(nc as u8);
        for c in 0..nc {
            out.extend_from_slice(&[c as u8 + 1, 0x00]);
        }
        out.extend_from_slice(&[predictor, 0, 0]);

        struct W {
            out: Vec<u8>,
            acc: u32,
            n: u32,
        }
        impl W {
            fn put(&mut self, v: u32, len: u32) {
                for i in (0..len).rev() {
                    self.acc = (self.acc << 1) | ((v >> i) & 1);
                    self.n += 1;
                    if self.n == 8 {
                        let b = self.acc as u8;
                        self.out.push(b);
                        if b == 0xFF {
                            self.out.push(0);
                        }
                        self.acc = 0;
                        self.n = 0;
                    }
                }
            }
            fn flush(&mut self) {
                while self.n != 0 {
                    self.put(1, 1);
                }
            }
        }
        let mut w = W { out, acc: 0, n: 0 };
        let row_len = width * nc;
        let initial = 1i32 << (precision - 1);
        let mut reset_row = 0usize;
        let mut reset_col = 0usize;
        let mut count = 0usize;
        let mut rst = 0u8;
        for row in 0..height {
            for col in 0..width {
                if restart > 0 && count == restart {
                    count = 0;
                    w.flush();
                    w.out.extend_from_slice(&[0xFF, 0xD0 + rst]);
                    rst = (rst + 1) & 7;
                    reset_row = row;
                    reset_col = col;
                }
                count += 1;
                for c in 0..nc {
                    let i = row * row_len + col * nc + c;
                    let x = samples[i] as i32;
                    let pred = if row == reset_row {
                        if col == reset_col {
                            initial
                        } else {
                            samples[i - nc] as i32
                        }
                    } else if col == 0 {
                        samples[i - row_len] as i32
                    } else {
                        let ra = samples[i - nc] as i32;
                        let rb = samples[i - row_len] as i32;
                        let rc = samples[i - row_len - nc] as i32;
                        match predictor {
                            1 => ra,
                            2 => rb,
                            3 => rc,
                            4 => ra + rb - rc,
                            5 => ra + ((rb - rc) >> 1),
                            6 => rb + ((ra - rc) >> 1),
                            _ => (ra + rb) >> 1,
                        }
                    };
                    // Difference modulo 2^16, taken into -32767..=32768 (T.81 H.1.2.2).
                    let mut d = (x - pred) & 0xFFFF;
                    if d > 32768 {
                        d -= 65536;
                    }
                    let ssss = if d == 0 {
                        0
                    } else {
                        32 - (d.unsigned_abs()).leading_zeros()
                    };
                    let (code, len) = codes[ssss as usize];
                    w.put(code, len);
                    if ssss > 0 && ssss < 16 {
                        let bits = if d < 0 {
                            (d - 1) as u32 & ((1 << ssss) - 1)
                        } else {
                            d as u32
                        };
                        w.put(bits, ssss);
                    }
                }
            }
        }
        w.flush();
        let mut out = w.out;
        out.extend_from_slice(&[0xFF, 0xD9]);
        out
    }

    fn test_image(width: usize, height: usize, nc: usize, bits: u32, seed: u64) -> Vec<u16> {
        // Smooth ramp plus pseudo-random noise (a small LCG), so all categories occur.
        let mut s = seed;
        (0..width * height * nc)
            .map(|i| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = (s >> 33) as u32 % 64;
                let ramp = ((i / nc) % width) as u32 * 37 + (i / (width * nc)) as u32 * 11;
                ((ramp + noise + (i % nc) as u32 * 1000) % (1 << bits)) as u16
            })
            .collect()
    }

    #[test]
    fn round_trip_all_predictors() {
        for predictor in 1..=7u8 {
            let img = test_image(23, 17, 1, 12, predictor as u64);
            let enc = encode(23, 17, 1, 12, predictor, 0, &img);
            let dec = decode(&enc, 1 << 20).unwrap();
            assert_eq!((dec.width, dec.height, dec.components), (23, 17, 1));
            assert_eq!(dec.samples, img, "predictor {predictor}");
        }
    }

    #[test]
    fn round_trip_two_components_and_restarts() {
        for (nc, restart) in [(2usize, 0usize), (2, 16), (4, 7), (1, 5)] {
            let img = test_image(16, 9, nc, 14, 99);
            let enc = encode(16, 9, nc, 14, 1, restart, &img);
            let dec = decode(&enc, 1 << 20).unwrap();
            assert_eq!(dec.samples, img, "nc {nc} restart {restart}");
        }
    }

    #[test]
    fn round_trip_16_bit_extremes() {
        // Jumps of 65535 need category 16 (difference 32768 after the modulo) and 15.
        let img: Vec<u16> = (0..64)
            .map(|i| {
                if i % 3 == 0 {
                    65535
                } else if i % 3 == 1 {
                    0
                } else {
                    32768
                }
            })
            .collect();
        let enc = encode(8, 8, 1, 16, 1, 0, &img);
        assert_eq!(decode(&enc, 1 << 20).unwrap().samples, img);
    }

    #[test]
    fn truncated_and_garbage_streams_are_errors() {
        let img = test_image(32, 32, 2, 12, 3);
        let enc = encode(32, 32, 2, 12, 1, 0, &img);
        for cut in [0, 1, 3, 10, 40, enc.len() / 2, enc.len() - 3] {
            assert!(decode(&enc[..cut], 1 << 20).is_err(), "cut at {cut}");
        }
        assert!(decode(&[0xFF, 0xD8, 0xFF, 0xC3, 0, 2], 1 << 20).is_err());
        assert!(decode(&enc, 100).is_err(), "frame larger than allowed");
    }

    #[test]
    fn decodes_a_hand_made_vector() {
        // 2x2, 8-bit, 1 component, predictor 1; one table: symbol 0 -> '0', symbol 1 -> '10',
        // symbol 2 -> '110'. Samples 128, 129 / 127, 127:
        // (0,0): pred 128, diff 0 -> '0'; (0,1): pred 128 (Ra), diff +1 -> '10' '1';
        // (1,0): pred Rb = 128, diff -1 -> '10' '0'; (1,1): pred Ra = 127, diff 0 -> '0'.
        // Bits: 0 10 1 10 0 0 -> 0101 1000, padded with ones -> 0x58? no padding needed past 8 bits:
        // 0,1,0,1,1,0,0,0 = 0x58.
        let mut s = vec![0xFF, 0xD8, 0xFF, 0xC3, 0, 11, 8, 0, 2, 0, 2, 1, 1, 0x11, 0];
        s.extend_from_slice(&[
            0xFF, 0xC4, 0, 22, 0x00, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2,
        ]);
        s.extend_from_slice(&[0xFF, 0xDA, 0, 8, 1, 1, 0x00, 1, 0, 0]);
        s.extend_from_slice(&[0x58, 0xFF, 0xD9]);
        let d = decode(&s, 100).unwrap();
        assert_eq!(d.samples, vec![128, 129, 127, 127]);
    }
}
