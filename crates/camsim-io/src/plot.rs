//! PNG plots for people to read: line plots (SFR curves, spectra, photon transfer) and scatter
//! plots with a y = x reference (measured vs simulated). Drawn with `plotters`' bitmap backend
//! and the DejaVu Sans font embedded through the `dejavu` crate, so no system fonts or
//! libraries are needed.

use crate::error::{IoError, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

const FONT: &str = "camsim-sans";
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // DejaVu Sans (Bitstream Vera licence), shipped as bytes by the `dejavu` crate.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

/// One named curve or point set.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) points in the plot's units; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw the line dashed (line plots), e.g. simulated vs measured.
    pub dashed: bool,
    /// Colour as sRGB bytes; `None` takes the next colour of a 10-colour palette.
    pub color: Option<[u8; 3]>,
}

impl Series {
    /// A solid series with an automatic colour.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.into(),
            points,
            dashed: false,
            color: None,
        }
    }
}

/// A line plot with several named series, a legend, axis labels (with units) and a title.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinePlot {
    pub title: String,
    /// x axis label with its unit, e.g. "spatial frequency (cycles/pixel)".
    pub x_label: String,
    /// y axis label with its unit.
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
}

/// A scatter plot of point sets with a dashed y = x reference line, for measured vs simulated
/// values. Both axes share one range so the reference is the diagonal.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScatterPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Range of both axes; `None` fits the data (and 0 when all values are positive and near it).
    pub range: Option<(f64, f64)>,
    /// Draw the y = x line (default true through [`ScatterPlot::new`]).
    pub identity_line: bool,
}

impl ScatterPlot {
    /// A scatter plot with the y = x reference line.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        series: Vec<Series>,
    ) -> Self {
        ScatterPlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
            range: None,
            identity_line: true,
        }
    }
}

/// Tableau 10 palette (matplotlib's default colour cycle).
const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

fn color_of(s: &Series, i: usize) -> RGBColor {
    let c = s.color.unwrap_or(PALETTE[i % PALETTE.len()]);
    RGBColor(c[0], c[1], c[2])
}

fn finite(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

fn fit_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * (hi.abs() + lo.abs()).max(1e-300) {
        let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        return (lo - d, hi + d);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

fn check_range(path: &Path, what: &str, r: (f64, f64)) -> Result<(f64, f64)> {
    if r.0.is_finite() && r.1.is_finite() && r.1 > r.0 {
        Ok(r)
    } else {
        Err(IoError::invalid(
            path,
            format!("{what} range {:?} is not an increasing pair of numbers", r),
        ))
    }
}

fn draw_err(path: &Path) -> impl Fn(String) -> IoError + '_ {
    move |m| IoError::invalid(path, format!("drawing the plot failed: {m}"))
}

fn check_size(path: &Path, width: u32, height: u32) -> Result<()> {
    if !(200..=10000).contains(&width) || !(150..=10000).contains(&height) {
        return Err(IoError::invalid(
            path,
            format!("plot size {width} x {height} is outside 200..10000 x 150..10000 pixels"),
        ));
    }
    Ok(())
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

impl LinePlot {
    /// Render to an RGB buffer (`width * height * 3` bytes, row-major).
    pub fn render_rgb(&self, width: u32, height: u32) -> Result<Vec<u8>> {
        let path = Path::new("<plot>");
        check_size(path, width, height)?;
        register_font();
        let pts: Vec<Vec<(f64, f64)>> = self.series.iter().map(|s| finite(&s.points)).collect();
        let xr = check_range(
            path,
            "x",
            self.x_range
                .unwrap_or_else(|| fit_range(pts.iter().flatten().map(|p| p.0))),
        )?;
        let yr = check_range(
            path,
            "y",
            self.y_range
                .unwrap_or_else(|| fit_range(pts.iter().flatten().map(|p| p.1))),
        )?;
        let mut buf = vec![255u8; (width * height * 3) as usize];
        {
            let root: Area =
                BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
            let e = draw_err(path);
            root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
            let mut chart =
                frame(&root, &self.title, xr, yr, &self.x_label, &self.y_label).map_err(&e)?;
            for (i, (s, p)) in self.series.iter().zip(&pts).enumerate() {
                let c = color_of(s, i);
                let style = ShapeStyle {
                    color: c.to_rgba(),
                    filled: false,
                    stroke_width: 2,
                };
                let anno = if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(p.clone(), 10, 6, style))
                        .map_err(|x| e(x.to_string()))?
                } else {
                    chart
                        .draw_series(LineSeries::new(p.clone(), style))
                        .map_err(|x| e(x.to_string()))?
                };
                if !s.name.is_empty() {
                    let dashed = s.dashed;
                    anno.label(s.name.clone()).legend(move |(x, y)| {
                        let gap = if dashed { 12 } else { 7 };
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(0, 0), (8, 0)], style)
                            + PathElement::new(vec![(gap, 0), (20, 0)], style)
                    });
                }
            }
            legend(
                &mut chart,
                self.series.iter().any(|s| !s.name.is_empty()),
                SeriesLabelPosition::UpperRight,
            )
            .map_err(&e)?;
            root.present().map_err(|x| e(x.to_string()))?;
        }
        Ok(buf)
    }

    /// Write the plot as a PNG of `width` x `height` pixels, atomically.
    pub fn write_png(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        write_rendered(path, width, height, self.render_rgb(width, height))
    }
}

impl ScatterPlot {
    /// Render to an RGB buffer (`width * height * 3` bytes, row-major).
    pub fn render_rgb(&self, width: u32, height: u32) -> Result<Vec<u8>> {
        let path = Path::new("<plot>");
        check_size(path, width, height)?;
        register_font();
        let pts: Vec<Vec<(f64, f64)>> = self.series.iter().map(|s| finite(&s.points)).collect();
        let r = match self.range {
            Some(r) => r,
            None => {
                let (lo, hi) = fit_range(pts.iter().flatten().flat_map(|p| [p.0, p.1]));
                // Start at zero when all data are non-negative and zero is close.
                let data_lo = pts
                    .iter()
                    .flatten()
                    .flat_map(|p| [p.0, p.1])
                    .fold(f64::INFINITY, f64::min);
                if data_lo >= 0.0 && data_lo < 0.25 * hi {
                    (0.0, hi)
                } else {
                    (lo, hi)
                }
            }
        };
        let r = check_range(path, "axis", r)?;
        let mut buf = vec![255u8; (width * height * 3) as usize];
        {
            let root: Area =
                BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
            let e = draw_err(path);
            root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
            let mut chart =
                frame(&root, &self.title, r, r, &self.x_label, &self.y_label).map_err(&e)?;
            if self.identity_line {
                let style = ShapeStyle {
                    color: RGBColor(90, 90, 90).to_rgba(),
                    filled: false,
                    stroke_width: 1,
                };
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(r.0, r.0), (r.1, r.1)],
                        8,
                        6,
                        style,
                    ))
                    .map_err(|x| e(x.to_string()))?
                    .label("y = x")
                    .legend(move |(x, y)| {
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(0, 0), (5, 0)], style)
                            + PathElement::new(vec![(9, 0), (14, 0)], style)
                    });
            }
            for (i, (s, p)) in self.series.iter().zip(&pts).enumerate() {
                let c = color_of(s, i);
                let anno = chart
                    .draw_series(p.iter().map(|&(x, y)| Circle::new((x, y), 4, c.filled())))
                    .map_err(|x| e(x.to_string()))?;
                if !s.name.is_empty() {
                    anno.label(s.name.clone())
                        .legend(move |(x, y)| Circle::new((x + 7, y), 4, c.filled()));
                }
            }
            // Data lie along the diagonal: the upper-left corner is the free one.
            legend(&mut chart, true, SeriesLabelPosition::UpperLeft).map_err(&e)?;
            root.present().map_err(|x| e(x.to_string()))?;
        }
        Ok(buf)
    }

    /// Write the plot as a PNG of `width` x `height` pixels, atomically.
    pub fn write_png(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        write_rendered(path, width, height, self.render_rgb(width, height))
    }
}

fn retarget(e: IoError, path: &Path) -> IoError {
    match e {
        IoError::Invalid { message, .. } => IoError::invalid(path, message),
        other => other,
    }
}

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn frame<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    xr: (f64, f64),
    yr: (f64, f64),
    x_label: &str,
    y_label: &str,
) -> std::result::Result<Chart<'a, 'b>, String> {
    let (w, h) = root.dim_in_pixel();
    let base = ((w.min(h) as f64) / 30.0).clamp(12.0, 40.0);
    let mut chart = ChartBuilder::on(root)
        .caption(
            title,
            (FONT, base * 1.35).into_font().style(FontStyle::Bold),
        )
        .margin((base * 0.8) as u32)
        .x_label_area_size((base * 2.8) as u32)
        .y_label_area_size((base * 4.2) as u32)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .axis_desc_style((FONT, base))
        .label_style((FONT, base * 0.85))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(chart)
}

/// Tick label: few significant digits, scientific only for very large or small magnitudes.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

fn legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    any: bool,
    position: SeriesLabelPosition,
) -> std::result::Result<(), String> {
    if !any {
        return Ok(());
    }
    let (w, h) = chart.plotting_area().dim_in_pixel();
    let base = ((w.min(h) as f64) / 26.0).clamp(11.0, 34.0);
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(150, 150, 150))
        .label_font((FONT, base))
        .draw()
        .map_err(|e| e.to_string())
}

/// Write a rendered plot (interleaved RGB of `width` x `height`) as a PNG, naming `path` in errors.
fn write_rendered(path: &Path, width: u32, height: u32, rgb: Result<Vec<u8>>) -> Result<()> {
    let rgb = rgb.map_err(|e| retarget(e, path))?;
    crate::raster::write_png8_rgb(path, height as usize, width as usize, &rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo_line() -> LinePlot {
        let f: Vec<f64> = (0..=50).map(|i| i as f64 * 0.01).collect();
        let mtf = |sigma: f64| {
            f.iter()
                .map(|&x| {
                    (
                        x,
                        (-2.0 * std::f64::consts::PI.powi(2) * sigma * sigma * x * x).exp(),
                    )
                })
                .collect()
        };
        LinePlot {
            title: "Slanted-edge SFR, green channel".into(),
            x_label: "spatial frequency (cycles/pixel)".into(),
            y_label: "SFR".into(),
            series: vec![
                Series::new("measured", mtf(1.0)),
                Series {
                    name: "simulated".into(),
                    points: mtf(1.1),
                    dashed: true,
                    color: None,
                },
                Series {
                    name: "analytic sigma=0.8 px".into(),
                    points: mtf(0.8),
                    dashed: false,
                    color: Some([0, 0, 0]),
                },
            ],
            x_range: Some((0.0, 0.5)),
            y_range: Some((0.0, 1.05)),
        }
    }

    /// Count pixels close to an RGB colour.
    fn count(rgb: &[u8], c: [u8; 3]) -> usize {
        rgb.chunks_exact(3)
            .filter(|p| (0..3).all(|k| (p[k] as i32 - c[k] as i32).abs() < 30))
            .count()
    }

    #[test]
    fn line_plot_draws_every_series_and_text() {
        let p = demo_line();
        let rgb = p.render_rgb(800, 600).unwrap();
        assert_eq!(rgb.len(), 800 * 600 * 3);
        // Both palette colours and the explicit black appear (curves and legend samples).
        assert!(count(&rgb, PALETTE[0]) > 200, "first series missing");
        assert!(count(&rgb, PALETTE[1]) > 100, "dashed series missing");
        // Text was rendered: dark pixels outside the plotting area (title, labels).
        let dark_top = rgb[..800 * 40 * 3]
            .chunks_exact(3)
            .filter(|p| p[0] < 100 && p[1] < 100 && p[2] < 100)
            .count();
        assert!(
            dark_top > 100,
            "no title text drawn ({dark_top} dark pixels)"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sfr.png");
        p.write_png(&path, 800, 600).unwrap();
        let (rows, cols, back) = crate::raster::read_png8_rgb(&path).unwrap();
        assert_eq!((rows, cols), (600, 800));
        assert_eq!(back, rgb);
        if let Ok(dir) = std::env::var("CAMSIM_PLOT_DIR") {
            p.write_png(&Path::new(&dir).join("line.png"), 800, 600)
                .unwrap();
        }
    }

    #[test]
    fn scatter_plot_with_identity_line() {
        let sim: Vec<(f64, f64)> = (0..24)
            .map(|i| {
                (
                    i as f64 * 40.0,
                    i as f64 * 40.0 * (1.0 + 0.05 * ((i % 5) as f64 - 2.0)),
                )
            })
            .collect();
        let mut p = ScatterPlot::new(
            "ColorChecker means",
            "simulated (DN)",
            "measured (DN)",
            vec![Series::new("R", sim.clone())],
        );
        p.series.push(Series {
            name: "G".into(),
            points: sim.iter().map(|(x, y)| (*x, y * 0.97)).collect(),
            dashed: false,
            color: Some([44, 160, 44]),
        });
        let rgb = p.render_rgb(640, 640).unwrap();
        assert!(count(&rgb, PALETTE[0]) > 24 * 20, "markers missing");
        assert!(count(&rgb, [90, 90, 90]) > 100, "y = x line missing");
        if let Ok(dir) = std::env::var("CAMSIM_PLOT_DIR") {
            p.write_png(&Path::new(&dir).join("scatter.png"), 640, 640)
                .unwrap();
        }
    }

    #[test]
    fn degenerate_input_is_handled() {
        // No points, a single point, NaNs: a plot is still drawn; bad ranges and sizes are errors.
        let mut p = LinePlot {
            title: "empty".into(),
            ..Default::default()
        };
        p.render_rgb(300, 200).unwrap();
        p.series
            .push(Series::new("one", vec![(1.0, 2.0), (f64::NAN, 3.0)]));
        p.render_rgb(300, 200).unwrap();
        p.x_range = Some((1.0, 1.0));
        let dir = tempfile::tempdir().unwrap();
        let e = p
            .write_png(&dir.path().join("bad.png"), 300, 200)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.png") && e.contains("x range"), "{e}");
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
        assert!(LinePlot::default().render_rgb(10, 10).is_err());
    }
}
