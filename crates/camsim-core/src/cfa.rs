//! General colour filter arrays: a repeating tile of N x M cells (N, M <= 8), each naming one
//! filter (ISETCam `sensorSet(sensor, 'pattern', P)` with `filterNames`: P holds indices into the
//! filter list). Bayer patterns are the 2x2 case with filters r, g, b ([`CfaLayout::from_bayer`]);
//! RGBW and Quad Bayer are presets ([`CfaLayout::parse`]).

use crate::error::{CoreError, Result};
use crate::names::{NameTable, Named};
use serde::{Deserialize, Serialize};

/// A colour channel of the CFA. Index 0, 1, 2 = red, green, blue (as in DNG's CFAPattern codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CfaChannel {
    R = 0,
    G = 1,
    B = 2,
}

impl CfaChannel {
    pub fn index(self) -> usize {
        self as usize
    }
    pub fn from_index(i: usize) -> Option<CfaChannel> {
        match i {
            0 => Some(CfaChannel::R),
            1 => Some(CfaChannel::G),
            2 => Some(CfaChannel::B),
            _ => None,
        }
    }
    pub fn letter(self) -> char {
        ['R', 'G', 'B'][self.index()]
    }
}

/// A 2x2 Bayer pattern, named by its top-left, top-right, bottom-left, bottom-right colours.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "UPPERCASE")]
pub enum CfaPattern {
    #[default]
    Rggb,
    Grbg,
    Gbrg,
    Bggr,
}

impl CfaPattern {
    /// Channels in the order top-left, top-right, bottom-left, bottom-right.
    pub fn channels(self) -> [CfaChannel; 4] {
        use CfaChannel::*;
        match self {
            CfaPattern::Rggb => [R, G, G, B],
            CfaPattern::Grbg => [G, R, B, G],
            CfaPattern::Gbrg => [G, B, R, G],
            CfaPattern::Bggr => [B, G, G, R],
        }
    }

    /// The channel at pixel (row, col).
    #[inline]
    pub fn channel_at(self, row: usize, col: usize) -> CfaChannel {
        self.channels()[(row & 1) * 2 + (col & 1)]
    }

    /// DNG CFAPattern tag bytes (0 = red, 1 = green, 2 = blue).
    pub fn dng_codes(self) -> [u8; 4] {
        self.channels().map(|c| c as u8)
    }

    pub fn from_dng_codes(codes: &[u8]) -> Option<CfaPattern> {
        [
            CfaPattern::Rggb,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
            CfaPattern::Bggr,
        ]
        .into_iter()
        .find(|p| p.dng_codes()[..] == *codes)
    }

    pub fn name(self) -> &'static str {
        match self {
            CfaPattern::Rggb => "RGGB",
            CfaPattern::Grbg => "GRBG",
            CfaPattern::Gbrg => "GBRG",
            CfaPattern::Bggr => "BGGR",
        }
    }

    /// A Bayer name from [`CFA_NAMES`] (RGGB, GRBG, GBRG, BGGR; any case).
    pub fn parse(s: &str) -> Result<CfaPattern> {
        match CFA_NAMES.entry(s).map(|e| e.value) {
            Some(Cfa::Bayer(p)) => Ok(p),
            _ => Err(CoreError::UnknownName {
                family: "Bayer pattern".into(),
                name: s.trim().to_string(),
                known: CFA_NAMES
                    .entries
                    .iter()
                    .filter(|e| matches!(e.value, Cfa::Bayer(_)))
                    .map(|e| e.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }
}

/// A colour filter array by name: a Bayer phase or one of the preset tiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cfa {
    /// A 2x2 Bayer pattern.
    Bayer(CfaPattern),
    /// 2x2 R G / W B: one green of RGGB replaced by a panchromatic pixel.
    Rgbw,
    /// 4x4, each RGGB colour on a 2x2 block of pixels (Sony "Quad Bayer", Samsung "Tetracell").
    QuadBayer,
}

/// The colour filter arrays camsim knows by name (`--cfa`, a sensor TOML's `cfa`, Python's
/// `cfa=`); any other tile is given cell by cell (`cfa_pattern`).
pub const CFA_NAMES: NameTable<Cfa> = NameTable {
    family: "CFA",
    entries: &[
        Named {
            name: "RGGB",
            aliases: &[],
            about: "Bayer, red at the top-left",
            value: Cfa::Bayer(CfaPattern::Rggb),
        },
        Named {
            name: "GRBG",
            aliases: &[],
            about: "Bayer, green then red on the first row",
            value: Cfa::Bayer(CfaPattern::Grbg),
        },
        Named {
            name: "GBRG",
            aliases: &[],
            about: "Bayer, green then blue on the first row",
            value: Cfa::Bayer(CfaPattern::Gbrg),
        },
        Named {
            name: "BGGR",
            aliases: &[],
            about: "Bayer, blue at the top-left",
            value: Cfa::Bayer(CfaPattern::Bggr),
        },
        Named {
            name: "RGBW",
            aliases: &[],
            about: "2x2 R G / W B (W: no colour filter)",
            value: Cfa::Rgbw,
        },
        Named {
            name: "quad-bayer",
            aliases: &["quadbayer", "tetracell"],
            about: "4x4, each Bayer colour on 2x2 pixels",
            value: Cfa::QuadBayer,
        },
    ],
};

/// Largest tile side, cells.
pub const MAX_CFA_SIDE: usize = 8;

/// A repeating CFA tile: `rows` x `cols` cells, row-major, each an index into `filters`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CfaLayout {
    rows: usize,
    cols: usize,
    cells: Vec<u8>,
    filters: Vec<String>,
}

/// Canonical (lower-case) filter name of a colour alias: `red` -> `r`, `white`/`pan`/`clear` -> `w`...
pub fn canonical_filter_name(name: &str) -> String {
    let n = name.trim().to_ascii_lowercase();
    match n.as_str() {
        "r" | "red" => "r".into(),
        "g" | "green" => "g".into(),
        "b" | "blue" => "b".into(),
        "w" | "white" | "pan" | "panchromatic" | "clear" => "w".into(),
        "c" | "cyan" => "c".into(),
        "m" | "magenta" => "m".into(),
        "y" | "yellow" => "y".into(),
        _ => n,
    }
}

/// TIFF/EP CFAPattern colour codes (TIFF/EP ISO 12234-2 §5.2.4; DNG 1.4 CFAPlaneColor):
/// 0 red, 1 green, 2 blue, 3 cyan, 4 magenta, 5 yellow, 6 white.
const DNG_CODES: [&str; 7] = ["r", "g", "b", "c", "m", "y", "w"];

impl CfaLayout {
    /// A layout from rows of filter names (aliases as [`canonical_filter_name`]). Filters are
    /// numbered r, g, b first (those present), then the others in order of first appearance.
    pub fn from_names(pattern: &[Vec<String>]) -> Result<CfaLayout> {
        let bad = |m: String| CoreError::invalid("cfa pattern", m);
        let rows = pattern.len();
        let cols = pattern.first().map_or(0, |r| r.len());
        if rows == 0 || cols == 0 {
            return Err(bad(
                "is empty; give rows of filter names, e.g. [[\"r\", \"g\"], [\"g\", \"b\"]]".into(),
            ));
        }
        if rows > MAX_CFA_SIDE || cols > MAX_CFA_SIDE {
            return Err(bad(format!(
                "{rows} x {cols} cells; at most {MAX_CFA_SIDE} x {MAX_CFA_SIDE}"
            )));
        }
        if let Some(i) = pattern.iter().position(|r| r.len() != cols) {
            return Err(bad(format!(
                "row {i} has {} cells, row 0 has {cols}",
                pattern[i].len()
            )));
        }
        let names: Vec<String> = pattern
            .iter()
            .flatten()
            .map(|s| canonical_filter_name(s))
            .collect();
        if let Some(n) = names.iter().find(|n| n.is_empty()) {
            return Err(bad(format!("empty filter name '{n}'")));
        }
        let mut filters: Vec<String> = ["r", "g", "b"]
            .iter()
            .filter(|c| names.iter().any(|n| n == *c))
            .map(|c| c.to_string())
            .collect();
        for n in &names {
            if !filters.contains(n) {
                filters.push(n.clone());
            }
        }
        let cells = names
            .iter()
            .map(|n| filters.iter().position(|f| f == n).unwrap_or(0) as u8)
            .collect();
        Ok(CfaLayout {
            rows,
            cols,
            cells,
            filters,
        })
    }

    /// A 2x2 Bayer pattern (filters r, g, b).
    pub fn from_bayer(p: CfaPattern) -> CfaLayout {
        CfaLayout {
            rows: 2,
            cols: 2,
            cells: p.channels().map(|c| c as u8).to_vec(),
            filters: vec!["r".into(), "g".into(), "b".into()],
        }
    }

    /// A Bayer name (`RGGB`, `GRBG`, `GBRG`, `BGGR`) or a preset: `RGBW` (2x2, R G / W B: one green
    /// of RGGB replaced by a panchromatic pixel), `quad-bayer`
    /// (4x4, each RGGB colour on a 2x2 block of pixels: Sony "Quad Bayer", also called Tetracell).
    pub fn parse(name: &str) -> Result<CfaLayout> {
        let s = |v: &[&[&str]]| {
            v.iter()
                .map(|r| r.iter().map(|c| c.to_string()).collect())
                .collect::<Vec<Vec<String>>>()
        };
        match CFA_NAMES.get(name)? {
            Cfa::Bayer(p) => Ok(CfaLayout::from_bayer(p)),
            Cfa::Rgbw => CfaLayout::from_names(&s(&[&["r", "g"], &["w", "b"]])),
            Cfa::QuadBayer => CfaLayout::from_names(&s(&[
                &["r", "r", "g", "g"],
                &["r", "r", "g", "g"],
                &["g", "g", "b", "b"],
                &["g", "g", "b", "b"],
            ])),
        }
    }

    /// The tile of the grid this CFA gives when every k x k block of pixels is read as one pixel
    /// (binning): each block, over the tile repeated to a common period (lcm(tile, k) / k blocks
    /// a side), must hold one filter, which names the binned pixel. Quad Bayer at k = 2 gives
    /// Bayer, a one-filter tile itself; an error names the first block that mixes filters.
    pub fn binned(&self, k: usize) -> Result<CfaLayout> {
        if k == 0 {
            return Err(CoreError::invalid("binning", "a block of 0 pixels"));
        }
        let lcm = |a: usize| a / gcd(a, k) * k;
        let (pr, pc) = (lcm(self.rows) / k, lcm(self.cols) / k);
        let mut names = Vec::with_capacity(pr);
        for i in 0..pr {
            let mut row = Vec::with_capacity(pc);
            for j in 0..pc {
                let f = self.filter_at(i * k, j * k);
                for r in i * k..(i + 1) * k {
                    for c in j * k..(j + 1) * k {
                        let g = self.filter_at(r, c);
                        if g != f {
                            return Err(CoreError::invalid(
                                "binning",
                                format!(
                                    "the {k} x {k} block at row {}, column {} of the CFA {} holds filters {} and {}: each block must hold one filter (Quad Bayer bins 2 x 2; a one-filter CFA any k)",
                                    i * k,
                                    j * k,
                                    self.name(),
                                    self.filters[f],
                                    self.filters[g]
                                ),
                            ));
                        }
                    }
                }
                row.push(self.filters[f].clone());
            }
            names.push(row);
        }
        CfaLayout::from_names(&names)
    }

    /// Tile rows (N).
    pub fn rows(&self) -> usize {
        self.rows
    }
    /// Tile columns (M).
    pub fn cols(&self) -> usize {
        self.cols
    }
    /// Filter names (canonical, lower case); cells index this list.
    pub fn filters(&self) -> &[String] {
        &self.filters
    }
    /// Index of filter `name` (any alias), if the layout has it.
    pub fn filter_index(&self, name: &str) -> Option<usize> {
        let n = canonical_filter_name(name);
        self.filters.iter().position(|f| *f == n)
    }

    /// Filter index at pixel (row, col) of the image (the tile repeats from the top-left pixel).
    #[inline]
    pub fn filter_at(&self, row: usize, col: usize) -> usize {
        self.cells[(row % self.rows) * self.cols + col % self.cols] as usize
    }

    /// The Bayer pattern this layout is, if it is one (2x2, filters r, g, b, two greens on a diagonal).
    pub fn as_bayer(&self) -> Option<CfaPattern> {
        if self.rows != 2
            || self.cols != 2
            || self.filters.len() != 3
            || self.filters != ["r", "g", "b"]
        {
            return None;
        }
        CfaPattern::from_dng_codes(&self.cells)
    }

    /// Short name: the Bayer name, `RGBW`/`quad-bayer` for the presets, else the rows of filter
    /// names joined by `/` (e.g. `r c/y b`).
    pub fn name(&self) -> String {
        if let Some(p) = self.as_bayer() {
            return p.name().to_string();
        }
        for preset in ["RGBW", "quad-bayer"] {
            if CfaLayout::parse(preset).is_ok_and(|l| l == *self) {
                return preset.to_string();
            }
        }
        (0..self.rows)
            .map(|r| {
                (0..self.cols)
                    .map(|c| self.filters[self.filter_at(r, c)].as_str())
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect::<Vec<_>>()
            .join("/")
    }

    /// Number of pixels of each filter in a `rows` x `cols` image.
    pub fn pixel_counts(&self, rows: usize, cols: usize) -> Vec<usize> {
        let mut n = vec![0usize; self.filters.len()];
        for tr in 0..self.rows.min(rows) {
            for tc in 0..self.cols.min(cols) {
                n[self.filter_at(tr, tc)] +=
                    (rows - tr).div_ceil(self.rows) * (cols - tc).div_ceil(self.cols);
            }
        }
        n
    }

    /// DNG CFAPattern codes, row-major (TIFF/EP: 0 red ... 6 white); an error names a filter
    /// (e.g. `ir`) that TIFF/EP has no code for.
    pub fn dng_codes(&self) -> Result<Vec<u8>> {
        let codes: Vec<u8> = self
            .filters
            .iter()
            .map(|f| {
                DNG_CODES.iter().position(|c| c == f).map(|i| i as u8).ok_or_else(|| {
                    CoreError::invalid("cfa pattern", format!("filter '{f}' has no DNG CFAPattern code (DNG knows r, g, b, c, m, y, w)"))
                })
            })
            .collect::<Result<_>>()?;
        Ok(self.cells.iter().map(|&i| codes[i as usize]).collect())
    }

    /// The layout of a DNG CFARepeatPatternDim (`rows`, `cols`) and CFAPattern `codes` (already
    /// mapped through CFAPlaneColor to TIFF/EP colours 0..=6).
    pub fn from_dng_codes(rows: usize, cols: usize, codes: &[u8]) -> Result<CfaLayout> {
        if rows * cols != codes.len() {
            return Err(CoreError::invalid(
                "CFAPattern",
                format!("{} codes for a {rows} x {cols} pattern", codes.len()),
            ));
        }
        let mut names = Vec::with_capacity(rows);
        for r in 0..rows {
            let mut row = Vec::with_capacity(cols);
            for &c in &codes[r * cols..(r + 1) * cols] {
                let n = DNG_CODES.get(c as usize).ok_or_else(|| {
                    CoreError::invalid("CFAPattern", format!("colour code {c} is not 0..=6"))
                })?;
                row.push(n.to_string());
            }
            names.push(row);
        }
        CfaLayout::from_names(&names)
    }
}

/// Greatest common divisor (Euclid).
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_and_bayer() {
        for p in [
            CfaPattern::Rggb,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
            CfaPattern::Bggr,
        ] {
            let l = CfaLayout::from_bayer(p);
            assert_eq!(l.as_bayer(), Some(p));
            assert_eq!(CfaLayout::parse(p.name()).unwrap(), l);
            for (r, c) in [(0, 0), (3, 5), (6, 1)] {
                assert_eq!(l.filter_at(r, c), p.channel_at(r, c).index());
            }
        }
        let w = CfaLayout::parse("RGBW").unwrap();
        assert_eq!(w.filters(), ["r", "g", "b", "w"]);
        assert_eq!(w.filter_at(1, 0), 3);
        assert_eq!(w.as_bayer(), None);
        assert_eq!(w.name(), "RGBW");
        let q = CfaLayout::parse("quad_bayer").unwrap();
        assert_eq!((q.rows(), q.cols()), (4, 4));
        assert_eq!(q.pixel_counts(8, 8), vec![16, 32, 16]);
        // 5 x 6 image: rows 0,1,4 x cols 0,1,4,5 are red = 3 x 4.
        assert_eq!(q.pixel_counts(5, 6)[0], 12);
        assert_eq!(q.name(), "quad-bayer");
        assert!(CfaLayout::parse("RGBX").is_err());
    }

    #[test]
    fn dng_codes_round_trip_and_reject_ir() {
        let l = CfaLayout::from_names(&[
            vec!["cyan".into(), "Yellow".into()],
            vec!["w".into(), "magenta".into()],
        ])
        .unwrap();
        let codes = l.dng_codes().unwrap();
        assert_eq!(codes, vec![3, 5, 6, 4]);
        assert_eq!(CfaLayout::from_dng_codes(2, 2, &codes).unwrap(), l);
        let ir =
            CfaLayout::from_names(&[vec!["r".into(), "ir".into()], vec!["g".into(), "b".into()]])
                .unwrap();
        assert!(ir.dng_codes().unwrap_err().to_string().contains("'ir'"));
        assert!(CfaLayout::from_names(&[vec!["r".into(); 9]]).is_err());
        assert!(CfaLayout::from_names(&[vec!["r".into(), "g".into()], vec!["b".into()]]).is_err());
    }

    #[test]
    fn patterns_round_trip_dng_codes() {
        for p in [
            CfaPattern::Rggb,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
            CfaPattern::Bggr,
        ] {
            assert_eq!(CfaPattern::from_dng_codes(&p.dng_codes()), Some(p));
            assert_eq!(CfaPattern::parse(p.name()).unwrap(), p);
            // Every 2x2 block has two greens, one red, one blue.
            let ch = p.channels();
            assert_eq!(ch.iter().filter(|c| **c == CfaChannel::G).count(), 2);
        }
        assert_eq!(CfaPattern::Grbg.channel_at(0, 1), CfaChannel::R);
        assert_eq!(CfaPattern::Bggr.channel_at(3, 3), CfaChannel::R);
    }
}
