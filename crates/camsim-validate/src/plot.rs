//! The report's figures as data (series of points with a style), drawn to PNG by
//! plotters (embedded DejaVu Sans font).

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Dashed line (models, published curves).
    Dashed,
    /// Markers only (scatter).
    Points,
}

/// One curve or point set.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// x values.
    pub x: Vec<f64>,
    /// y values.
    pub y: Vec<f64>,
    /// Drawing style.
    pub style: Style,
    /// RGB colour.
    pub color: [u8; 3],
}

/// Colours of the R, G, B channels and of luminance.
pub const CHANNEL_COLORS: [[u8; 3]; 4] = [[210, 40, 40], [30, 150, 50], [40, 70, 210], [60, 60, 60]];

impl Series {
    /// A series.
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>, style: Style, color: [u8; 3]) -> Series {
        Series { label: label.into(), x, y, style, color }
    }
}

/// A 2D plot.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Title above the plot.
    pub title: String,
    /// x axis label.
    pub x_label: String,
    /// y axis label.
    pub y_label: String,
    /// The series.
    pub series: Vec<Series>,
    /// x range (None: from the data).
    pub x_range: Option<(f64, f64)>,
    /// y range (None: from the data).
    pub y_range: Option<(f64, f64)>,
    /// Size in pixels (width, height).
    pub size: (u32, u32),
}

impl Figure {
    /// An empty figure.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Figure {
        Figure {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            x_range: None,
            y_range: None,
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

    /// A y = x reference line over the data's range (scatter plots of predicted vs measured).
    pub fn with_identity_line(self) -> Figure {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            for v in s.x.iter().chain(s.y.iter()) {
                if v.is_finite() {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return self;
        }
        let lo = lo.min(0.0);
        self.with(Series::new("y = x", vec![lo, hi], vec![lo, hi], Style::Dashed, [120, 120, 120]))
    }

    /// Draw to PNG bytes.
    pub fn png(&self) -> crate::Result<Vec<u8>> {
        backend::draw(self)
    }
}

/// Drawing with plotters (bitmap backend, embedded DejaVu Sans font, no system fonts).
mod backend {
    use super::*;
    use plotters::prelude::*;
    use plotters::style::FontStyle;
    use std::sync::Once;

    static FONT: Once = Once::new();

    fn err(e: impl std::fmt::Display) -> crate::ValidateError {
        crate::ValidateError::invalid("plot", e.to_string())
    }

    fn range(fig: &Figure, xs: bool) -> (f64, f64) {
        let given = if xs { fig.x_range } else { fig.y_range };
        if let Some(r) = given {
            return r;
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &fig.series {
            for v in if xs { &s.x } else { &s.y } {
                if v.is_finite() {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return (0.0, 1.0);
        }
        if hi - lo < 1e-12 {
            return (lo - 0.5, hi + 0.5);
        }
        let pad = 0.04 * (hi - lo);
        (lo - pad, hi + pad)
    }

    pub fn draw(fig: &Figure) -> crate::Result<Vec<u8>> {
        FONT.call_once(|| {
            let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
        });
        let (w, h) = fig.size;
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(err)?;
            let (x0, x1) = range(fig, true);
            let (y0, y1) = range(fig, false);
            let mut chart = ChartBuilder::on(&root)
                .caption(&fig.title, ("sans-serif", 17))
                .margin(12)
                .x_label_area_size(42)
                .y_label_area_size(62)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(fig.x_label.as_str())
                .y_desc(fig.y_label.as_str())
                .label_style(("sans-serif", 13))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(err)?;
            for s in &fig.series {
                let color = RGBColor(s.color[0], s.color[1], s.color[2]);
                let pts: Vec<(f64, f64)> = s
                    .x
                    .iter()
                    .zip(&s.y)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (*x, y.clamp(y0 - (y1 - y0), y1 + (y1 - y0))))
                    .collect();
                let label = s.label.clone();
                match s.style {
                    Style::Line => {
                        chart
                            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                            .map_err(err)?
                            .label(label)
                            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
                    }
                    Style::Dashed => {
                        chart
                            .draw_series(DashedLineSeries::new(pts, 7, 5, color.stroke_width(2)))
                            .map_err(err)?
                            .label(label)
                            .legend(move |(x, y)| {
                                plotters::element::DashedPathElement::new(vec![(x, y), (x + 20, y)], 5, 3, color.stroke_width(2))
                            });
                    }
                    Style::Points => {
                        chart
                            .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                            .map_err(err)?
                            .label(label)
                            .legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
                    }
                }
            }
            chart
                .configure_series_labels()
                .label_font(("sans-serif", 12))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(err)?;
            root.present().map_err(err)?;
        }
        crate::util::encode_png_rgb8(w as usize, h as usize, &buf)
    }
}
