//! Raw sensor mosaics: the Bayer colour filter array pattern and a frame of digital values.

use crate::cfa::CfaLayout;
use crate::error::{CoreError, Result};
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

    pub fn parse(s: &str) -> Result<CfaPattern> {
        match s.to_ascii_uppercase().as_str() {
            "RGGB" => Ok(CfaPattern::Rggb),
            "GRBG" => Ok(CfaPattern::Grbg),
            "GBRG" => Ok(CfaPattern::Gbrg),
            "BGGR" => Ok(CfaPattern::Bggr),
            _ => Err(CoreError::invalid(
                "cfa pattern",
                format!("'{s}' is not one of RGGB, GRBG, GBRG, BGGR"),
            )),
        }
    }
}

/// One raw frame: digital values (DN) on a Bayer mosaic, row-major, with the levels needed to
/// interpret them.
#[derive(Debug, Clone, PartialEq)]
pub struct RawImage {
    pub rows: usize,
    pub cols: usize,
    pub cfa: CfaPattern,
    /// A non-Bayer colour filter array (RGBW, Quad Bayer, any N x M); `None` for the Bayer
    /// pattern `cfa`. Bayer-only code must refuse a frame that has one ([`RawImage::require_bayer`]).
    pub layout: Option<CfaLayout>,
    /// Digital values, row-major, `rows * cols`.
    pub dn: Vec<u16>,
    /// DN of zero light (analog offset after quantization).
    pub black_level_dn: f64,
    /// Largest DN the ADC produces (2^bits - 1, or the saturation level).
    pub white_level_dn: f64,
    /// ADC bits.
    pub bits: u32,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Pixel pitch, m.
    pub pixel_pitch_m: f64,
}

impl RawImage {
    pub fn new(rows: usize, cols: usize, cfa: CfaPattern, bits: u32) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(CoreError::invalid(
                "raw image size",
                format!("{rows} x {cols} has no pixels"),
            ));
        }
        crate::mem::check_alloc((rows * cols * 2) as u64, "a raw frame")?;
        Ok(RawImage {
            rows,
            cols,
            cfa,
            layout: None,
            dn: vec![0; rows * cols],
            black_level_dn: 0.0,
            white_level_dn: ((1u64 << bits) - 1) as f64,
            bits,
            exposure_s: 0.0,
            pixel_pitch_m: 0.0,
        })
    }

    #[inline]
    pub fn at(&self, row: usize, col: usize) -> u16 {
        self.dn[row * self.cols + col]
    }

    pub fn channel_at(&self, row: usize, col: usize) -> CfaChannel {
        self.cfa.channel_at(row, col)
    }

    /// The colour filter array: `layout`, or the Bayer `cfa` as a layout.
    pub fn cfa_layout(&self) -> CfaLayout {
        self.layout
            .clone()
            .unwrap_or_else(|| CfaLayout::from_bayer(self.cfa))
    }

    /// An error naming `what` when this frame is not a Bayer mosaic.
    pub fn require_bayer(&self, what: &str) -> Result<()> {
        match &self.layout {
            Some(l) if l.as_bayer().is_none() => Err(CoreError::invalid(
                what,
                format!("needs a Bayer mosaic; this frame's CFA is {} (bin or demosaic it with the general-CFA tools first)", l.name()),
            )),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
