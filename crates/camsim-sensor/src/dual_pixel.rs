//! Dual-pixel sensors ([`crate::SensorConfig::dual_pixel`]): each pixel is two photodiodes under
//! one microlens, which images the lens pupil onto them, so each photodiode collects the light
//! through one half of the pupil. A defocused point's two half-pupil images are displaced in
//! opposite directions along the split; their separation is the phase-detection disparity an
//! autofocus reads (Canon's Dual Pixel CMOS AF; Wadhwa et al., "Synthetic depth-of-field with a
//! single-camera mobile phone", SIGGRAPH 2018, sec. 4, for the Pixel phones' dual pixels).
//!
//! The optics stage images each half pupil apart (`camsim_optics`' `aperture.half`); each
//! photodiode is then a sensor of its own ([`crate::Sensor::dual_pixel_photodiodes`]) and the
//! pixel's raw is the digital sum of the two reads ([`dual_pixel_sum`]).

use crate::error::{Result, SensorError};
use camsim_core::RawImage;

/// The pixel's raw from its photodiodes' raws: `DN = L + R - black` (each read carries the
/// black level once), rounded values kept, clipped to `[0, white level]`. Both halves hold
/// half the well, so the sum reaches the ADC's full scale where the pixel's well is full.
pub fn dual_pixel_sum(left: &RawImage, right: &RawImage) -> Result<RawImage> {
    if (left.rows, left.cols) != (right.rows, right.cols)
        || left.black_level_dn != right.black_level_dn
        || left.white_level_dn != right.white_level_dn
    {
        return Err(SensorError::Input {
            what: "dual-pixel raws".into(),
            message: format!(
                "the halves differ: {} x {} (black {}, white {}) and {} x {} (black {}, white {})",
                left.cols,
                left.rows,
                left.black_level_dn,
                left.white_level_dn,
                right.cols,
                right.rows,
                right.black_level_dn,
                right.white_level_dn
            ),
        });
    }
    let black = left.black_level_dn;
    let white = left.white_level_dn;
    let mut sum = left.clone();
    for (s, (&l, &r)) in sum.dn.iter_mut().zip(left.dn.iter().zip(&right.dn)) {
        *s = (l as f64 + r as f64 - black).round().clamp(0.0, white) as u16;
    }
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::CfaPattern;

    #[test]
    fn the_sum_carries_the_black_level_once_and_clips_at_white() {
        let mut l = RawImage::new(1, 3, CfaPattern::Rggb, 10).unwrap();
        l.black_level_dn = 64.0;
        l.white_level_dn = 1023.0;
        let mut r = l.clone();
        l.dn = vec![64, 100, 900];
        r.dn = vec![64, 200, 900];
        let s = dual_pixel_sum(&l, &r).unwrap();
        assert_eq!(s.dn, [64, 236, 1023]);
        r.rows = 3;
        r.cols = 1;
        assert!(dual_pixel_sum(&l, &r).is_err());
    }
}
