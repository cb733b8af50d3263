//! `camsim isp` for frames of a general colour filter array (RGBW, Quad Bayer, `cfa_pattern`).

use anyhow::Result;
use camsim_core::RawImage;
use camsim_isp::{DemosaicMethod, RgbImage};
use camsim_sensor::Sensor;

/// RGB of any raw frame: a Bayer mosaic with `method`; a tile with r, g, b and w filters by the
/// W-guided fusion (`camsim_isp::cfa_general::rgbw_to_rgb`), W predicted from R, G, B with
/// weights fitted to `sensor`'s QE under the frame's CFA; any other tile with r, g, b filters by
/// the per-filter bilinear interpolation.
pub fn demosaic_general(
    raw: &RawImage,
    sensor: &Sensor,
    method: DemosaicMethod,
) -> Result<RgbImage> {
    let Some(layout) = raw.layout.as_ref().filter(|l| l.as_bayer().is_none()) else {
        return Ok(camsim_isp::demosaic(raw, method)?);
    };
    if method != DemosaicMethod::Bilinear {
        anyhow::bail!(
            "--demosaic {}: a {} frame takes the bilinear method only (or --bin for Quad Bayer)",
            method.name(),
            layout.name()
        );
    }
    let has = |n: &str| layout.filter_index(n).is_some();
    if has("r") && has("g") && has("b") && has("w") {
        let mut c = sensor.config().clone();
        c.cfa = String::new();
        c.cfa_pattern = Some(
            (0..layout.rows())
                .map(|r| {
                    (0..layout.cols())
                        .map(|col| layout.filters()[layout.filter_at(r, col)].clone())
                        .collect()
                })
                .collect(),
        );
        let weights = Sensor::from_config_named(
            c,
            &format!("{} with the frame's CFA {}", sensor.name(), layout.name()),
        )?
        .filter_from_rgb_weights("w")?;
        return Ok(camsim_isp::cfa_general::rgbw_to_rgb(raw, weights)?);
    }
    Ok(camsim_isp::cfa_general::demosaic_any(raw)?)
}
