//! The report's figures as data (series of points with a style), drawn to PNG by
//! `camsim_io::plot` (line and scatter plots, embedded DejaVu Sans font).

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

/// Label of the y = x reference series added by [`Figure::with_identity_line`].
pub const IDENTITY_LABEL: &str = "y = x";

/// Colours of the R, G, B channels and of luminance.
pub const CHANNEL_COLORS: [[u8; 3]; 4] =
    [[210, 40, 40], [30, 150, 50], [40, 70, 210], [60, 60, 60]];

impl Series {
    /// A series.
    pub fn new(
        label: impl Into<String>,
        x: Vec<f64>,
        y: Vec<f64>,
        style: Style,
        color: [u8; 3],
    ) -> Series {
        Series {
            label: label.into(),
            x,
            y,
            style,
            color,
        }
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
        self.with(Series::new(
            IDENTITY_LABEL,
            vec![lo, hi],
            vec![lo, hi],
            Style::Dashed,
            [120, 120, 120],
        ))
    }

    /// Draw to PNG bytes.
    pub fn png(&self) -> crate::Result<Vec<u8>> {
        backend::draw(self)
    }
}

/// Drawing with `camsim_io::plot`: figures whose series are all markers become a
/// [`camsim_io::plot::ScatterPlot`] (with its y = x line when the figure asked for one), the
/// others a [`camsim_io::plot::LinePlot`] (dashed series dashed).
mod backend {
    use super::*;
    use camsim_io::plot as p;

    fn pts(s: &Series) -> Vec<(f64, f64)> {
        s.x.iter()
            .zip(&s.y)
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .map(|(x, y)| (*x, *y))
            .collect()
    }

    pub fn draw(fig: &Figure) -> crate::Result<Vec<u8>> {
        let identity = fig.series.iter().any(|s| s.label == IDENTITY_LABEL);
        let data: Vec<&Series> = fig
            .series
            .iter()
            .filter(|s| s.label != IDENTITY_LABEL)
            .collect();
        let scatter = !data.is_empty() && data.iter().all(|s| s.style == Style::Points);
        let series: Vec<p::Series> = data
            .iter()
            .map(|s| p::Series {
                name: s.label.clone(),
                points: pts(s),
                dashed: s.style == Style::Dashed,
                color: Some(s.color),
            })
            .collect();
        let (w, h) = fig.size;
        let rgb = if scatter {
            let mut sp = p::ScatterPlot::new(&fig.title, &fig.x_label, &fig.y_label, series);
            sp.identity_line = identity;
            sp.render_rgb(w, h)?
        } else {
            let lp = p::LinePlot {
                title: fig.title.clone(),
                x_label: fig.x_label.clone(),
                y_label: fig.y_label.clone(),
                series,
                x_range: fig.x_range,
                y_range: fig.y_range,
            };
            lp.render_rgb(w, h)?
        };
        crate::util::encode_png_rgb8(w as usize, h as usize, &rgb)
    }
}
