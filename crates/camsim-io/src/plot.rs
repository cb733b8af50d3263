//! camsim's one plotting model, PNG plots for people to read: [`Figure`] of [`Series`] (line
//! plots of SFR curves, spectra, photon transfer; scatter plots with a y = x reference, measured
//! vs simulated), and [`Canvas`] for marks on a preview image. Drawn with `plotters`' bitmap backend
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

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// Solid line.
    #[default]
    Line,
    /// Dashed line (models, published curves, the simulated beside the measured).
    Dashed,
    /// Markers only (a figure whose series are all markers is a scatter plot).
    Points,
}

/// One named curve or point set.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) points in the plot's units; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
    /// Colour as sRGB bytes; `None` takes the next colour of a 10-colour palette.
    pub color: Option<[u8; 3]>,
}

impl Series {
    /// A solid series with an automatic colour.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.into(),
            points,
            style: Style::Line,
            color: None,
        }
    }

    /// A series from separate x and y values, drawn in `style` and `color`.
    pub fn xy(
        name: impl Into<String>,
        x: Vec<f64>,
        y: Vec<f64>,
        style: Style,
        color: [u8; 3],
    ) -> Series {
        Series {
            name: name.into(),
            points: x.into_iter().zip(y).collect(),
            style,
            color: Some(color),
        }
    }

    /// The same series drawn dashed.
    pub fn dashed(mut self) -> Series {
        self.style = Style::Dashed;
        self
    }

    /// The same series in colour `c`.
    pub fn colored(mut self, c: [u8; 3]) -> Series {
        self.color = Some(c);
        self
    }
}

/// Colours of the R, G, B channels and of luminance in camsim's plots.
pub const CHANNEL_COLORS: [[u8; 3]; 4] =
    [[210, 40, 40], [30, 150, 50], [40, 70, 210], [60, 60, 60]];

/// A plot: several named series with a legend, axis labels (with units) and a title. A figure
/// whose series are all [`Style::Points`] is a scatter plot (one range for both axes, the
/// x range when given, and a dashed y = x line with [`Figure::with_identity_line`]); any other
/// is a line plot (every series a line, dashed or solid).
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub title: String,
    /// x axis label with its unit, e.g. "spatial frequency (cycles/pixel)".
    pub x_label: String,
    /// y axis label with its unit.
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed x range (a scatter plot's range of both axes); `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    /// A scatter plot's dashed y = x reference line.
    pub identity_line: bool,
    /// Size in pixels (width, height).
    pub size: (u32, u32),
}

impl Default for Figure {
    fn default() -> Self {
        Figure::new("", "", "")
    }
}

impl Figure {
    /// An empty figure of 640 x 440 pixels.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Figure {
        Figure {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            x_range: None,
            y_range: None,
            identity_line: false,
            size: (640, 440),
        }
    }

    /// Add a series.
    pub fn with(mut self, s: Series) -> Figure {
        self.series.push(s);
        self
    }

    /// Set the axis ranges.
    pub fn ranges(mut self, x: Option<(f64, f64)>, y: Option<(f64, f64)>) -> Figure {
        self.x_range = x;
        self.y_range = y;
        self
    }

    /// Draw the y = x reference line (scatter plots of predicted vs measured).
    pub fn with_identity_line(mut self) -> Figure {
        self.identity_line = true;
        self
    }

    /// Set the size in pixels.
    pub fn sized(mut self, width: u32, height: u32) -> Figure {
        self.size = (width, height);
        self
    }

    /// Whether it is drawn as a scatter plot (every series [`Style::Points`]).
    pub fn is_scatter(&self) -> bool {
        !self.series.is_empty() && self.series.iter().all(|s| s.style == Style::Points)
    }

    /// Render to an RGB buffer (`width * height * 3` bytes, row-major).
    pub fn render_rgb(&self) -> Result<Vec<u8>> {
        if self.is_scatter() {
            self.render_scatter()
        } else {
            self.render_lines()
        }
    }

    /// The figure as PNG bytes (to embed in a report).
    pub fn png(&self) -> Result<Vec<u8>> {
        let (w, h) = self.size;
        crate::raster::encode_png8_rgb(h as usize, w as usize, &self.render_rgb()?)
    }

    /// Write the figure as a PNG file, atomically.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        let (w, h) = self.size;
        write_rendered(path, w, h, self.render_rgb())
    }
}

/// An 8-bit RGB picture to draw marks on (boxes on a preview), interleaved, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    /// Width, pixels.
    pub w: usize,
    /// Height, pixels.
    pub h: usize,
    /// `w * h * 3` bytes.
    pub data: Vec<u8>,
}

impl Canvas {
    /// Set one pixel (outside the picture: nothing).
    pub fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            let i = (y as usize * self.w + x as usize) * 3;
            self.data[i..i + 3].copy_from_slice(&c);
        }
    }

    /// A two-pixel-wide line from `a` to `b` ([x, y] pixels).
    pub fn line(&mut self, a: [f64; 2], b: [f64; 2], c: [u8; 3]) {
        let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil() as usize).max(1);
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let (x, y) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
            for d in [-1i64, 0] {
                self.set(x.round() as i64 + d, y.round() as i64, c);
                self.set(x.round() as i64, y.round() as i64 + d, c);
            }
        }
    }

    /// The outline of the rectangle [x0, x1] x [y0, y1].
    pub fn rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: [u8; 3]) {
        self.line([x0, y0], [x1, y0], c);
        self.line([x1, y0], [x1, y1], c);
        self.line([x1, y1], [x0, y1], c);
        self.line([x0, y1], [x0, y0], c);
    }

    /// The picture as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>> {
        crate::raster::encode_png8_rgb(self.h, self.w, &self.data)
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

impl Figure {
    fn render_lines(&self) -> Result<Vec<u8>> {
        let (width, height) = self.size;
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
                let dashed = s.style == Style::Dashed;
                let anno = if dashed {
                    chart
                        .draw_series(DashedLineSeries::new(p.clone(), 10, 6, style))
                        .map_err(|x| e(x.to_string()))?
                } else {
                    chart
                        .draw_series(LineSeries::new(p.clone(), style))
                        .map_err(|x| e(x.to_string()))?
                };
                if !s.name.is_empty() {
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

    fn render_scatter(&self) -> Result<Vec<u8>> {
        let (width, height) = self.size;
        let path = Path::new("<plot>");
        check_size(path, width, height)?;
        register_font();
        let pts: Vec<Vec<(f64, f64)>> = self.series.iter().map(|s| finite(&s.points)).collect();
        let r = match self.x_range {
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

    fn demo_line() -> Figure {
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
        Figure::new(
            "Slanted-edge SFR, green channel",
            "spatial frequency (cycles/pixel)",
            "SFR",
        )
        .with(Series::new("measured", mtf(1.0)))
        .with(Series::new("simulated", mtf(1.1)).dashed())
        .with(Series::new("analytic sigma=0.8 px", mtf(0.8)).colored([0, 0, 0]))
        .ranges(Some((0.0, 0.5)), Some((0.0, 1.05)))
        .sized(800, 600)
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
        assert!(!p.is_scatter());
        let rgb = p.render_rgb().unwrap();
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
        p.write_png(&path).unwrap();
        let (rows, cols, back) = crate::raster::read_png8_rgb(&path).unwrap();
        assert_eq!((rows, cols), (600, 800));
        assert_eq!(back, rgb);
        // The embedded form decodes to the same pixels.
        let png = p.png().unwrap();
        std::fs::write(dir.path().join("embedded.png"), png).unwrap();
        let (_, _, again) = crate::raster::read_png8_rgb(&dir.path().join("embedded.png")).unwrap();
        assert_eq!(again, rgb);
        if let Ok(dir) = std::env::var("CAMSIM_PLOT_DIR") {
            p.write_png(&Path::new(&dir).join("line.png")).unwrap();
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
        let mut r = Series::new("R", sim.clone());
        r.style = Style::Points;
        let g = Series::xy(
            "G",
            sim.iter().map(|p| p.0).collect(),
            sim.iter().map(|p| p.1 * 0.97).collect(),
            Style::Points,
            [44, 160, 44],
        );
        let p = Figure::new("ColorChecker means", "simulated (DN)", "measured (DN)")
            .with(r)
            .with(g)
            .with_identity_line()
            .sized(640, 640);
        assert!(p.is_scatter());
        let rgb = p.render_rgb().unwrap();
        assert!(count(&rgb, PALETTE[0]) > 24 * 20, "markers missing");
        // The dashed grey y = x line: its pixels are the grey ones a figure without it lacks.
        let mut q = p.clone();
        q.identity_line = false;
        let without = count(&q.render_rgb().unwrap(), [90, 90, 90]);
        assert!(
            count(&rgb, [90, 90, 90]) > without + 100,
            "y = x line missing"
        );
        if let Ok(dir) = std::env::var("CAMSIM_PLOT_DIR") {
            p.write_png(&Path::new(&dir).join("scatter.png")).unwrap();
        }
    }

    #[test]
    fn canvas_draws_clipped_lines_and_boxes() {
        let mut c = Canvas {
            w: 10,
            h: 8,
            data: vec![0; 10 * 8 * 3],
        };
        c.rect(2.0, 2.0, 6.0, 5.0, [255, 0, 0]);
        c.line([-5.0, -5.0], [20.0, 20.0], [0, 255, 0]);
        let red = c.data.chunks_exact(3).filter(|p| *p == [255, 0, 0]).count();
        assert!(red >= 12, "{red}");
        assert_eq!(c.png().unwrap()[1..4], *b"PNG");
    }

    #[test]
    fn degenerate_input_is_handled() {
        // No points, a single point, NaNs: a plot is still drawn; bad ranges and sizes are errors.
        let mut p = Figure::new("empty", "", "").sized(300, 200);
        p.render_rgb().unwrap();
        p.series
            .push(Series::new("one", vec![(1.0, 2.0), (f64::NAN, 3.0)]));
        p.render_rgb().unwrap();
        p.x_range = Some((1.0, 1.0));
        let dir = tempfile::tempdir().unwrap();
        let e = p
            .write_png(&dir.path().join("bad.png"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.png") && e.contains("x range"), "{e}");
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
        assert!(Figure::default().sized(10, 10).render_rgb().is_err());
    }
}
