//! Visual noise ([`camsim_analysis::visual_noise`], ISO 15739 Annex B) of uniform patches of a
//! display image: an sRGB picture (PNG, JPEG or TIFF code values, as `camsim simulate` writes its
//! preview and real cameras their JPEGs) or a linear-sRGB OpenEXR (white = 1), at a viewing
//! condition (pixels per degree, or the picture's height and the viewing distance).

use crate::{PipelineError, Result};
use camsim_analysis::acutance::ViewingCondition;
use camsim_analysis::visual_noise::{srgb_to_xyz, visual_noise, VisualNoise};
use camsim_analysis::{Plane, Rect};
use camsim_io::atomic::OutputDir;
use camsim_io::rgb_image::{read_rgb_image, RgbEncoding};
use serde::Serialize;
use std::path::Path;

/// How the picture is viewed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Viewing {
    /// Pixels per degree of visual angle, given directly.
    PixelsPerDegree(f64),
    /// The whole picture shown `display_height_m` high at `viewing_distance_m`.
    Picture {
        /// Height of the shown picture, m.
        display_height_m: f64,
        /// Viewing distance, m.
        viewing_distance_m: f64,
    },
}

impl Default for Viewing {
    /// `camsim compare`'s viewing condition: the picture 10 cm high at 40 cm.
    fn default() -> Self {
        Viewing::Picture {
            display_height_m: 0.1,
            viewing_distance_m: 0.4,
        }
    }
}

impl Viewing {
    /// Pixels per degree for a picture `image_rows` pixels high.
    pub fn pixels_per_degree(&self, image_rows: usize) -> Result<f64> {
        Ok(match *self {
            Viewing::PixelsPerDegree(p) => p,
            Viewing::Picture {
                display_height_m,
                viewing_distance_m,
            } => ViewingCondition {
                image_height_px: image_rows,
                display_height_m,
                viewing_distance_m,
            }
            .pixels_per_degree()?,
        })
    }
}

/// What to measure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VisualNoiseRequest {
    /// Uniform patches, pixels (empty: the central half of the image in each direction).
    pub regions: Vec<Rect>,
    /// The viewing condition.
    pub viewing: Viewing,
}

/// A display image: three planes of sRGB code values in [0, 1], or of linear sRGB.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayImage {
    /// R, G, B planes.
    pub planes: [Plane; 3],
    /// `true`: sRGB code values (decoded with the sRGB transfer function); `false`: linear.
    pub code_values: bool,
}

impl DisplayImage {
    /// Read a PNG, JPEG or TIFF (code values) or an OpenEXR (linear) picture.
    pub fn load(path: &Path) -> Result<DisplayImage> {
        let f = read_rgb_image(path)?;
        let plane = |k: usize| {
            Plane::new(
                f.rows,
                f.cols,
                (0..f.rows * f.cols).map(|i| f.rgb[i * 3 + k]).collect(),
            )
        };
        Ok(DisplayImage {
            planes: [plane(0)?, plane(1)?, plane(2)?],
            code_values: f.encoding == RgbEncoding::CodeValues,
        })
    }
}

/// The visual noise of each patch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VisualNoiseReport {
    /// `srgb` (code values) or `linear_srgb`.
    pub encoding: &'static str,
    /// The viewing condition as given.
    pub viewing: Viewing,
    /// Pixels per degree it gives for this picture.
    pub pixels_per_degree: f64,
    /// Image size, pixels (rows, cols).
    pub image_rows: usize,
    /// Image width, pixels.
    pub image_cols: usize,
    /// One result per patch, in the order asked.
    pub patches: Vec<VisualNoise>,
}

/// Measure the visual noise of `image`'s patches.
pub fn measure_visual_noise(
    image: &DisplayImage,
    req: &VisualNoiseRequest,
) -> Result<VisualNoiseReport> {
    let (rows, cols) = (image.planes[0].rows, image.planes[0].cols);
    let ppd = req.viewing.pixels_per_degree(rows)?;
    let regions = if req.regions.is_empty() {
        vec![Rect::new(
            rows / 4,
            cols / 4,
            rows - rows / 2,
            cols - cols / 2,
        )]
    } else {
        req.regions.clone()
    };
    let (xyz, white) = srgb_to_xyz(&image.planes, image.code_values)?;
    let patches = regions
        .iter()
        .enumerate()
        .map(|(i, r)| {
            visual_noise(&xyz, Some(*r), white, ppd)
                .map_err(|e| PipelineError::config(format!("region {} ({r}): {e}", i + 1)))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(VisualNoiseReport {
        encoding: if image.code_values {
            "srgb"
        } else {
            "linear_srgb"
        },
        viewing: req.viewing,
        pixels_per_degree: ppd,
        image_rows: rows,
        image_cols: cols,
        patches,
    })
}

impl VisualNoiseReport {
    /// One CSV row per patch.
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "row,col,rows,cols,visual_noise,sigma_l_star,sigma_u_star,sigma_v_star,mean_l_star,mean_u_star,mean_v_star,unfiltered_sigma_l_star,unfiltered_sigma_u_star,unfiltered_sigma_v_star,pixels_per_degree,clipped_pixels\n",
        );
        for p in &self.patches {
            let r = p.rect;
            s.push_str(&format!(
                "{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.4},{}\n",
                r.row,
                r.col,
                r.rows,
                r.cols,
                p.visual_noise,
                p.sigma_l_star,
                p.sigma_u_star,
                p.sigma_v_star,
                p.mean_luv[0],
                p.mean_luv[1],
                p.mean_luv[2],
                p.unfiltered_sigma_luv[0],
                p.unfiltered_sigma_luv[1],
                p.unfiltered_sigma_luv[2],
                p.pixels_per_degree,
                p.clipped_pixels
            ));
        }
        s
    }

    /// Write `visual_noise.json` (with `label`, the image's name) and `visual_noise.csv` in
    /// `out`; returns the JSON.
    pub fn write_files(&self, out: &OutputDir, label: &str) -> Result<serde_json::Value> {
        let mut json = serde_json::to_value(self)
            .map_err(|e| PipelineError::config(format!("visual noise report: {e}")))?;
        json["image"] = label.into();
        json["method"] = "ISO 15739:2013 Annex B: XYZ adapted to E (Bradford), A C1 C2 opponent channels filtered by their CSFs at the viewing condition, CIE L*u*v* against the sRGB white; VN = sigma(L*) + 0.852 sigma(u*) + 0.323 sigma(v*)".into();
        super::write_text(
            &out.join("visual_noise.json"),
            &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
        )?;
        super::write_text(&out.join("visual_noise.csv"), &self.csv())?;
        Ok(json)
    }
}
