//! ColorChecker statistics: the 24 patch regions from the chart's four outer corners (the
//! central `fraction` of each patch, as ISETCam's chartRectangles), per-channel mean and sample
//! standard deviation (DN above black) on a raw CFA mosaic (each channel on its own pixels, both
//! greens pooled) or on LinearRaw RGB, and a line profile through the gray series on the
//! demosaicked image (the paper's Figure 5). Patches are numbered 1-24 as on the chart (1 dark
//! skin, 19 white, 24 black), with their names.

use super::write_text;
use crate::{MeasuredImage, PipelineError, Result};
use camsim_analysis::chart::{self, ChartCorners, PatchStats, ProfilePoint};
use camsim_analysis::Plane;
use camsim_io::atomic::OutputDir;
use camsim_io::plot::{Figure, Series, CHANNEL_COLORS};
use std::fmt::Write as _;

/// What to measure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartRequest {
    /// The patch grid's four outer corners in the image.
    pub corners: ChartCorners,
    /// Side of each measured square as a fraction of the patch pitch, in (0, 1].
    pub fraction: f64,
}

/// The chart's statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct ChartReport {
    /// What was measured (raw CFA or LinearRaw RGB).
    pub data: &'static str,
    /// The corners used.
    pub corners: ChartCorners,
    /// The fraction used.
    pub fraction: f64,
    /// The 24 patches, 1-24 in chart order.
    pub patches: Vec<PatchStats>,
    /// The profile through the centres of the gray series (the bottom row), demosaicked.
    pub profile: Vec<ProfilePoint>,
}

/// Measure the chart in `image`; `label` names it in errors.
pub fn measure_chart(
    image: &MeasuredImage,
    req: &ChartRequest,
    label: &str,
) -> Result<ChartReport> {
    let corners = req.corners;
    let ctx = |e: camsim_analysis::AnalysisError| {
        PipelineError::Config(format!("{label}: chart with corners {corners} (x,y of the dark-skin, bluish-green, black and white corners, inside the image): {e}"))
    };
    let (patches, planes) = match image {
        MeasuredImage::Raw(raw) => {
            let patches = chart::chart_patch_stats_raw(raw, &corners, req.fraction).map_err(ctx)?;
            // Bilinear demosaic, black subtracted (camsim-isp).
            let rgb = camsim_isp::try_demosaic_bilinear(raw)?;
            let [r, g, b] = [rgb.r, rgb.g, rgb.b].map(|p| Plane::new(rgb.rows, rgb.cols, p));
            (patches, [r?, g?, b?])
        }
        MeasuredImage::Rgb { planes, .. } => (
            chart::chart_patch_stats_rgb(planes, &corners, req.fraction).map_err(ctx)?,
            (**planes).clone(),
        ),
    };
    // Gray series: the line through the centres of the bottom row.
    let (p0, p1) = corners.row_line(3);
    let n = ((p1[0] - p0[0]).hypot(p1[1] - p0[1]).ceil() as usize).max(2);
    let profile = chart::line_profile(&planes, p0, p1, n).map_err(ctx)?;
    Ok(ChartReport {
        data: image.kind(),
        corners,
        fraction: req.fraction,
        patches,
        profile,
    })
}

impl ChartReport {
    /// patches.csv: one line per patch (1-24) with its name, the means, standard deviations and
    /// pixel counts per channel.
    pub fn patches_csv(&self) -> String {
        let mut csv = String::from(
            "patch,name,mean_r_dn,mean_g_dn,mean_b_dn,std_r_dn,std_g_dn,std_b_dn,n_r,n_g,n_b\n",
        );
        for p in &self.patches {
            let _ = writeln!(
                csv,
                "{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{}",
                p.patch,
                p.name,
                p.mean[0],
                p.mean[1],
                p.mean[2],
                p.std[0],
                p.std[1],
                p.std[2],
                p.n[0],
                p.n[1],
                p.n[2]
            );
        }
        csv
    }

    /// profile.csv: distance along the line, position and R, G, B above black.
    pub fn profile_csv(&self) -> String {
        let mut csv = String::from("distance_px,x,y,r_dn,g_dn,b_dn\n");
        for p in &self.profile {
            let _ = writeln!(
                csv,
                "{:.2},{:.2},{:.2},{:.3},{:.3},{:.3}",
                p.distance_px, p.position[0], p.position[1], p.rgb[0], p.rgb[1], p.rgb[2]
            );
        }
        csv
    }

    /// chart.json: the image, what was measured, the corners, the fraction and the 24 patches.
    pub fn to_json(&self, image: &str) -> serde_json::Value {
        serde_json::json!({
            "image": image, "data": self.data, "corners": self.corners, "fraction": self.fraction,
            "patches": self.patches,
        })
    }

    /// The gray-series profile plot.
    pub fn profile_figure(&self) -> Figure {
        let ch = |k: usize, name: &str| {
            Series::new(
                name,
                self.profile
                    .iter()
                    .map(|p| (p.distance_px, p.rgb[k]))
                    .collect(),
            )
            .colored(CHANNEL_COLORS[k])
        };
        Figure::new(
            "Digital values along the gray series (DN above black)",
            "distance along the line (pixels)",
            "digital value above black (DN)",
        )
        .with(ch(0, "R"))
        .with(ch(1, "G"))
        .with(ch(2, "B"))
        .sized(900, 500)
    }

    /// Write patches.csv, profile.csv, profile.png and chart.json into `out`; returns
    /// chart.json's value.
    pub fn write_files(&self, out: &OutputDir, image: &str) -> Result<serde_json::Value> {
        write_text(&out.join("patches.csv"), &self.patches_csv())?;
        write_text(&out.join("profile.csv"), &self.profile_csv())?;
        self.profile_figure().write_png(&out.join("profile.png"))?;
        let json = self.to_json(image);
        camsim_io::atomic::write_json_atomic(&out.join("chart.json"), &json)?;
        Ok(json)
    }
}
