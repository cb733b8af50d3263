//! Raw sensor mosaics: a frame of digital values on a colour filter array ([`crate::cfa`]).

use crate::cfa::CfaLayout;
pub use crate::cfa::{CfaChannel, CfaPattern};
use crate::error::{CoreError, Result};

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
    /// A linear signal (`values`, e.g. a merged HDR frame in electrons, `rows x cols` of
    /// `like`'s geometry) as a 16-bit mosaic with `like`'s CFA, size, exposure and pitch:
    /// DN = (v + pedestal) x s with s = 65535 / (max + pedestal) DN per unit, so the black level
    /// is pedestal x s and the white level (65535) is `max`. Returns the mosaic and s. The ISP
    /// takes it as any raw; quantization adds 1/sqrt(12) of 1 / s units.
    pub fn linear_mosaic16(
        values: &[f32],
        like: &RawImage,
        max: f64,
        pedestal: f64,
    ) -> Result<(RawImage, f64)> {
        if values.len() != like.rows * like.cols {
            return Err(CoreError::invalid(
                "linear mosaic",
                format!(
                    "{} values for {} x {} pixels",
                    values.len(),
                    like.rows,
                    like.cols
                ),
            ));
        }
        if !(max > 0.0 && pedestal >= 0.0 && (max + pedestal).is_finite()) {
            return Err(CoreError::invalid(
                "linear mosaic",
                format!("maximum {max} and pedestal {pedestal}: need max > 0, pedestal >= 0"),
            ));
        }
        let white = u16::MAX as f64;
        let s = white / (max + pedestal);
        let mut raw = like.clone();
        raw.bits = 16;
        raw.black_level_dn = pedestal * s;
        raw.white_level_dn = white;
        for (d, v) in raw.dn.iter_mut().zip(values) {
            *d = ((*v as f64 + pedestal) * s).clamp(0.0, white).round() as u16;
        }
        Ok((raw, s))
    }

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
