//! The report's figures: camsim's one plotting model (`camsim_io::plot`), drawn to PNG bytes to
//! embed in report.html.

pub use camsim_io::plot::{Canvas, Figure, Series, Style, CHANNEL_COLORS};
