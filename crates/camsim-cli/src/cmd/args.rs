//! Argument types and value parsers several subcommands share.

use camsim::analysis::chart::ChartCorners;
use camsim::analysis::Rect;
use camsim::core::CfaPattern;
use camsim::pipeline::MosaicFormat;

/// Where a raw file's CFA and levels come from when the file does not say (PNG/TIFF mosaics).
#[derive(clap::Args, Clone)]
pub struct RawInput {
    /// CFA pattern of a PNG/TIFF mosaic (DNG files carry their own).
    #[arg(long, value_parser = parse_cfa)]
    pub cfa: Option<CfaPattern>,
    /// Black level of a PNG/TIFF mosaic, DN.
    #[arg(long, default_value_t = 0.0, value_parser = crate::common::non_negative_f64)]
    pub black_dn: f64,
    /// ADC bits of a PNG/TIFF mosaic.
    #[arg(long, default_value_t = 16)]
    pub bits: u32,
}

impl RawInput {
    /// How to read a PNG/TIFF mosaic.
    pub fn format(&self) -> MosaicFormat {
        MosaicFormat {
            cfa: self.cfa,
            black_dn: self.black_dn,
            bits: self.bits,
        }
    }
}

pub fn parse_cfa(s: &str) -> std::result::Result<CfaPattern, String> {
    CfaPattern::parse(s).map_err(|e| e.to_string())
}

/// `row,col,rows,cols` in pixels.
pub fn parse_rect(s: &str) -> std::result::Result<Rect, String> {
    let v: Vec<usize> = s
        .split(',')
        .map(|t| t.trim().parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}': use ROW,COL,ROWS,COLS (whole pixels)"))?;
    match v.as_slice() {
        [r, c, h, w] if *h > 0 && *w > 0 => Ok(Rect::new(*r, *c, *h, *w)),
        _ => Err(format!("'{s}': use ROW,COL,ROWS,COLS with ROWS, COLS > 0")),
    }
}

fn parse_points(s: &str) -> std::result::Result<Vec<f64>, String> {
    s.split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{s}': not a list of numbers"))
        })
        .collect()
}

/// `X,Y,X,Y,X,Y,X,Y`: the chart's four corners in pixels.
pub fn parse_corners(s: &str) -> std::result::Result<ChartCorners, String> {
    let v = parse_points(s)?;
    if v.len() != 8 || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("'{s}': give 8 finite numbers X,Y of the top-left, top-right, bottom-right and bottom-left corners, got {}", v.len()));
    }
    Ok(ChartCorners {
        top_left: [v[0], v[1]],
        top_right: [v[2], v[3]],
        bottom_right: [v[4], v[5]],
        bottom_left: [v[6], v[7]],
    })
}
