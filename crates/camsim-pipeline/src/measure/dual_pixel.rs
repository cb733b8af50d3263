//! Dual-pixel disparity ([`camsim_analysis::dual_pixel`]) of a dual-pixel sensor's two
//! photodiode raws (`raw_left.dng`, `raw_right.dng` of `camsim simulate`): on each filter's own
//! pixels (a CFA tile position's sub-grid, no demosaicking; a monochrome sensor's every pixel),
//! in sensor pixels and, where the pitch is known, micrometres on the sensor.

use crate::{PipelineError, Result};
use camsim_analysis::dual_pixel::{edge_disparity, DisparityOptions};
use camsim_analysis::{Plane, Rect};
use camsim_core::{CfaLayout, RawImage};
use serde::Serialize;

/// What to measure.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DualPixelRequest {
    /// The region holding a near-vertical edge, sensor pixels (default: the whole raw).
    pub roi: Option<Rect>,
    /// Rows of each filter's sub-grid per block (0: the analysis' default, 8).
    pub block_rows: usize,
}

/// One filter's disparity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FilterDisparity {
    /// The filter (`g`, `w`, `c`...), with its tile position `row,col` when it occurs more than
    /// once in the tile.
    pub filter: String,
    /// Left image's edge position minus the right one's, sensor pixels.
    pub disparity_px: f64,
    /// Its standard error over the blocks, sensor pixels.
    pub standard_error_px: f64,
    /// The edge's mean column, sensor pixel edges.
    pub edge_col_px: f64,
    /// The edge's slope, sensor columns per sensor row.
    pub slope_px_per_row: f64,
    /// Blocks of rows measured.
    pub blocks: usize,
}

/// The disparity of a dual-pixel capture's edge.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DualPixelReport {
    /// Per filter (tile position).
    pub filters: Vec<FilterDisparity>,
    /// The filters' disparities combined (inverse-variance weighted), sensor pixels.
    pub disparity_px: f64,
    /// Its standard error, sensor pixels.
    pub standard_error_px: f64,
    /// The pixel pitch the raws record, um (`None`: not recorded).
    pub pixel_pitch_um: Option<f64>,
    /// The disparity on the sensor, um (with the pitch).
    pub disparity_um: Option<f64>,
}

/// Measure the disparity between `left` and `right`, a dual-pixel sensor's photodiode raws.
pub fn measure_dual_pixel(
    left: &RawImage,
    right: &RawImage,
    req: &DualPixelRequest,
) -> Result<DualPixelReport> {
    if (left.rows, left.cols) != (right.rows, right.cols)
        || left.layout != right.layout
        || left.cfa != right.cfa
    {
        return Err(PipelineError::config(format!(
            "the left raw is {} x {} ({}), the right one {} x {} ({}): give the two halves of one capture",
            left.cols,
            left.rows,
            left.layout.as_ref().map_or(left.cfa.name().to_string(), |l| l.name()),
            right.cols,
            right.rows,
            right.layout.as_ref().map_or(right.cfa.name().to_string(), |l| l.name()),
        )));
    }
    let layout = left
        .layout
        .clone()
        .unwrap_or_else(|| CfaLayout::from_bayer(left.cfa));
    let (th, tw) = (layout.rows(), layout.cols());
    let roi = req.roi.unwrap_or(Rect {
        row: 0,
        col: 0,
        rows: left.rows,
        cols: left.cols,
    });
    if roi.rows == 0
        || roi.cols == 0
        || roi.row + roi.rows > left.rows
        || roi.col + roi.cols > left.cols
    {
        return Err(PipelineError::config(format!(
            "roi: {} x {} at row {}, column {} does not fit the {} x {} raw",
            roi.cols, roi.rows, roi.row, roi.col, left.cols, left.rows
        )));
    }
    // Each filter's first tile position (a monochrome tile: one).
    let mut seen: Vec<usize> = Vec::new();
    let mut positions = Vec::new();
    for i in 0..th {
        for j in 0..tw {
            let f = layout.filter_at(i, j);
            if !seen.contains(&f) {
                seen.push(f);
                positions.push((i, j, layout.filters()[f].clone()));
            }
        }
    }
    let opts = DisparityOptions {
        roi: None,
        block_rows: if req.block_rows == 0 {
            8
        } else {
            req.block_rows
        },
    };
    let mut filters = Vec::new();
    for (i, j, name) in positions {
        // The sub-grid of sensor rows i + k th, columns j + l tw inside the region.
        let first =
            |start: usize, off: usize, step: usize| (start.saturating_sub(off)).div_ceil(step);
        let (k0, l0) = (first(roi.row, i, th), first(roi.col, j, tw));
        let count = |start: usize, len: usize, off: usize, step: usize, k0: usize| {
            let end = start + len; // exclusive
            if end <= off {
                0
            } else {
                ((end - 1 - off) / step + 1).saturating_sub(k0)
            }
        };
        let (nr, nc) = (
            count(roi.row, roi.rows, i, th, k0),
            count(roi.col, roi.cols, j, tw, l0),
        );
        if nr == 0 || nc < 8 {
            return Err(PipelineError::config(format!(
                "roi: {} x {} pixels hold {nc} x {nr} pixels of filter {name}; give a region at least {} pixels wide",
                roi.cols,
                roi.rows,
                8 * tw
            )));
        }
        let plane = |raw: &RawImage| -> Result<Plane> {
            let mut data = Vec::with_capacity(nr * nc);
            for k in 0..nr {
                let r = i + (k0 + k) * th;
                for l in 0..nc {
                    let c = j + (l0 + l) * tw;
                    data.push((raw.dn[r * raw.cols + c] as f64 - raw.black_level_dn) as f32);
                }
            }
            Ok(Plane::new(nr, nc, data)?)
        };
        let d = edge_disparity(&plane(left)?, &plane(right)?, &opts)
            .map_err(|e| PipelineError::config(format!("filter {name}: {e}")))?;
        let label = if layout.pixel_counts(th, tw)[layout.filter_at(i, j)] > 1 {
            format!("{name} ({i},{j})")
        } else {
            name
        };
        // Plane pixel-edge coordinate e is sensor pixel edge j + (e - 0.5 + l0) tw + 0.5.
        filters.push(FilterDisparity {
            filter: label,
            disparity_px: d.disparity_px * tw as f64,
            standard_error_px: d.standard_error_px * tw as f64,
            edge_col_px: j as f64 + (d.edge_col - 0.5 + l0 as f64) * tw as f64 + 0.5,
            slope_px_per_row: d.slope_px_per_row * tw as f64 / th as f64,
            blocks: d.blocks,
        });
    }
    // Inverse-variance weights where every filter has an error; else the plain mean.
    let all_se = filters.iter().all(|f| f.standard_error_px > 0.0);
    let w: Vec<f64> = filters
        .iter()
        .map(|f| {
            if all_se {
                f.standard_error_px.powi(-2)
            } else {
                1.0
            }
        })
        .collect();
    let sw: f64 = w.iter().sum();
    let disparity_px = filters
        .iter()
        .zip(&w)
        .map(|(f, w)| w * f.disparity_px)
        .sum::<f64>()
        / sw;
    let standard_error_px = if all_se {
        sw.powf(-0.5)
    } else {
        (filters
            .iter()
            .map(|f| f.standard_error_px.powi(2))
            .sum::<f64>())
        .sqrt()
            / filters.len() as f64
    };
    let pitch_um = (left.pixel_pitch_m > 0.0).then_some(left.pixel_pitch_m * 1e6);
    Ok(DualPixelReport {
        filters,
        disparity_px,
        standard_error_px,
        pixel_pitch_um: pitch_um,
        disparity_um: pitch_um.map(|p| p * disparity_px),
    })
}
