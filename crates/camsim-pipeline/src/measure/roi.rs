//! Region statistics: mean and sample standard deviation per colour channel (DN above black) in
//! rectangles of one image, or of two side by side (simulated and measured: the paper's Figure
//! 6), with the temporal noise a sensor model predicts at each mean level. Raw CFA data are
//! measured on each channel's own pixels (both greens pooled); LinearRaw RGB on its planes.

use super::write_text;
use crate::{MeasuredImage, PipelineError, Result};
use camsim_analysis::roi::{roi_stats_raw, roi_stats_rgb, RegionStats};
use camsim_analysis::Rect;
use camsim_io::atomic::OutputDir;
use camsim_io::plot::{Figure, Series, Style};
use camsim_sensor::Sensor;
use std::fmt::Write as _;

/// What to measure.
#[derive(Debug, Clone, Default)]
pub struct RoiRequest {
    /// Rectangles in the first image.
    pub regions: Vec<Rect>,
    /// Rectangles in the second image when they differ (as many as `regions`; empty: the same).
    pub regions_b: Vec<Rect>,
    /// Sensor model for the predicted temporal noise of the first image (at its exposure).
    pub sensor: Option<Sensor>,
}

/// The statistics of one or two images.
#[derive(Debug, Clone, PartialEq)]
pub struct RoiReport {
    /// Per region of the first image.
    pub a: Vec<RegionStats>,
    /// Per region of the second image.
    pub b: Option<Vec<RegionStats>>,
    /// What the first image is (raw CFA or LinearRaw RGB).
    pub data_a: &'static str,
    /// What the second image is.
    pub data_b: Option<&'static str>,
    /// The model's temporal noise at each mean of the first image, DN (per region, R, G, B).
    pub predicted_std_a_dn: Option<Vec<[f64; 3]>>,
}

fn stats(img: &MeasuredImage, rects: &[Rect]) -> camsim_analysis::Result<Vec<RegionStats>> {
    match img {
        MeasuredImage::Raw(r) => roi_stats_raw(r, rects),
        MeasuredImage::Rgb { planes, .. } => roi_stats_rgb(planes, rects),
    }
}

/// Measure the regions of `a` (and `b`); `labels` name the images in errors.
pub fn measure_roi(
    a: &MeasuredImage,
    b: Option<&MeasuredImage>,
    req: &RoiRequest,
    labels: [&str; 2],
) -> Result<RoiReport> {
    if b.is_none() && !req.regions_b.is_empty() {
        return Err(PipelineError::config(
            "regions of a second image need a second image",
        ));
    }
    if !req.regions_b.is_empty() && req.regions_b.len() != req.regions.len() {
        return Err(PipelineError::config(format!(
            "give as many regions for the second image as for the first ({}), got {}",
            req.regions.len(),
            req.regions_b.len()
        )));
    }
    let rects_b: Vec<Rect> = req
        .regions
        .iter()
        .enumerate()
        .map(|(i, r)| req.regions_b.get(i).copied().unwrap_or(*r))
        .collect();
    let sa =
        stats(a, &req.regions).map_err(|e| PipelineError::Config(format!("{}: {e}", labels[0])))?;
    let sb = b
        .map(|b| {
            stats(b, &rects_b).map_err(|e| PipelineError::Config(format!("{}: {e}", labels[1])))
        })
        .transpose()?;
    let predicted = req.sensor.as_ref().map(|s| {
        sa.iter()
            .map(|r| {
                r.mean_dn
                    .map(|m| s.predicted_noise_dn(m, a.exposure_s()).total)
            })
            .collect()
    });
    Ok(RoiReport {
        a: sa,
        b: sb,
        data_a: a.kind(),
        data_b: b.map(|b| b.kind()),
        predicted_std_a_dn: predicted,
    })
}

impl RoiReport {
    /// roi.csv: one line per region and channel.
    pub fn csv(&self) -> String {
        let mut csv = String::from(
            "region,channel,mean_a_dn,std_a_dn,predicted_std_a_dn,mean_b_dn,std_b_dn\n",
        );
        for (i, sa) in self.a.iter().enumerate() {
            for c in 0..3 {
                let pa = self.predicted_std_a_dn.as_ref().map(|p| p[i][c]);
                let (mb, sb) = self
                    .b
                    .as_ref()
                    .map(|s| (s[i].mean_dn[c], s[i].std_dn[c]))
                    .unwrap_or((f64::NAN, f64::NAN));
                let _ = writeln!(
                    csv,
                    "{i},{},{:.3},{:.3},{},{:.3},{:.3}",
                    ["R", "G", "B"][c],
                    sa.mean_dn[c],
                    sa.std_dn[c],
                    pa.map(|v| format!("{v:.3}")).unwrap_or_default(),
                    mb,
                    sb
                );
            }
        }
        csv
    }

    /// roi.json: both images' statistics and what they are.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({ "a": self.a, "b": self.b, "data_a": self.data_a, "data_b": self.data_b })
    }

    /// The means and the standard deviations of the two images against each other (regions x
    /// channels), when there are two.
    pub fn figures(&self, label_a: &str, label_b: &str) -> Option<[Figure; 2]> {
        let b = self.b.as_ref()?;
        let (mut means, mut stds) = (Vec::new(), Vec::new());
        for (sa, sb) in self.a.iter().zip(b) {
            for c in 0..3 {
                means.push((sb.mean_dn[c], sa.mean_dn[c]));
                stds.push((sb.std_dn[c], sa.std_dn[c]));
            }
        }
        let fig = |title: &str, pts: Vec<(f64, f64)>| {
            let mut s = Series::new("regions x channels", pts);
            s.style = Style::Points;
            Figure::new(title, format!("{label_b} (DN)"), format!("{label_a} (DN)"))
                .with(s)
                .with_identity_line()
                .sized(700, 700)
        };
        Some([
            fig("Mean digital values", means),
            fig("Standard deviations", stds),
        ])
    }

    /// Write roi.csv, roi.json and, for two images, means.png and stds.png into `out`; returns
    /// roi.json's value.
    pub fn write_files(
        &self,
        out: &OutputDir,
        label_a: &str,
        label_b: &str,
    ) -> Result<serde_json::Value> {
        write_text(&out.join("roi.csv"), &self.csv())?;
        if let Some([m, s]) = self.figures(label_a, label_b) {
            m.write_png(&out.join("means.png"))?;
            s.write_png(&out.join("stds.png"))?;
        }
        let json = self.to_json();
        camsim_io::atomic::write_json_atomic(&out.join("roi.json"), &json)?;
        Ok(json)
    }
}
