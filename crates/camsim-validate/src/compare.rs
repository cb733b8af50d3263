//! Region-by-region comparison of a user's measured raw images with simulated ones (the paper's
//! Figure 6 method for any camera).
//!
//! Config (TOML; relative paths are relative to the config file's folder; unknown keys are
//! errors). Every key:
//! ```toml
//! simulated = "out/sim"                 # required: a raw DNG, or a `camsim simulate` folder (its raw.dng)
//! measured = ["IMG_0001.dng", "IMG_0002.dng"]   # required: one DNG (a string) or a list of DNGs of the same scene
//! sensor = "pixel4a"                    # optional: preset name or sensor TOML file; absent = no noise prediction
//! exposure_s = 0.01                     # optional: exposure for the noise prediction (dark current), s;
//!                                       #           default: the simulated frame's exposure
//!
//! # one or more regions (required); each has all three keys:
//! [[region]]
//! name = "gray patch"                   # shown in the report
//! measured = [1510, 2010, 40, 40]       # row, col, rows, cols (pixels, top-left corner) in the measured image
//! simulated = [1500, 2000, 40, 40]      # the corresponding region in the simulated image (rows, cols >= 1)
//! ```
//! For every region and CFA channel: mean and standard deviation (DN above black) in both
//! images, and the standard deviation the sensor model predicts at each mean
//! (`Sensor::predicted_noise_dn`, at the simulated frame's exposure). With several measured
//! frames the statistics are averaged over the frames. Writes `report.html`, `results.json` and
//! the scatter plots of means and standard deviations (`compare_means.png`, `compare_std.png`).

use crate::plot::{Figure, Series, Style, CHANNEL_COLORS};
use crate::report::Html;
use crate::util::{f, save_png, FigurePng};
use crate::{Result, ValidateError};
use camsim_analysis::roi::{add_predicted_std, compare_regions_raw, RegionPair};
use camsim_analysis::Rect;
use camsim_core::RawImage;
use camsim_sensor::Sensor;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One region: where it is in each image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionConfig {
    /// Name shown in the report.
    pub name: String,
    /// [row, col, rows, cols] in the measured image, pixels.
    pub measured: [usize; 4],
    /// [row, col, rows, cols] in the simulated image, pixels.
    pub simulated: [usize; 4],
}

/// The comparison config (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareConfig {
    /// The simulated raw DNG, or a `camsim simulate` output folder (its `raw.dng`).
    pub simulated: PathBuf,
    /// The measured DNG(s): one path or a list.
    pub measured: OneOrMany,
    /// Sensor for the noise prediction: a preset name (`imx363`, `pixel4a`, ...) or a sensor TOML
    /// file. None: no prediction.
    #[serde(default)]
    pub sensor: Option<String>,
    /// Exposure time for the noise prediction (dark current), s; default: the simulated frame's.
    #[serde(default)]
    pub exposure_s: Option<f64>,
    /// The regions.
    #[serde(rename = "region")]
    pub regions: Vec<RegionConfig>,
    /// Folder that relative paths are resolved against (the config file's folder; not in the file).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// One path or several.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany {
    /// One file.
    One(PathBuf),
    /// Several files.
    Many(Vec<PathBuf>),
}

impl OneOrMany {
    fn paths(&self) -> Vec<PathBuf> {
        match self {
            OneOrMany::One(p) => vec![p.clone()],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

impl CompareConfig {
    /// Parse TOML text; `base_dir` resolves relative paths, `what` names the text in errors.
    pub fn from_toml_str(text: &str, base_dir: &Path, what: &Path) -> Result<CompareConfig> {
        let mut c: CompareConfig =
            toml::from_str(text).map_err(|e| ValidateError::file(what, e.to_string()))?;
        c.base_dir = base_dir.to_path_buf();
        if c.regions.is_empty() {
            return Err(ValidateError::file(what, "no [[region]] given"));
        }
        if c.measured.paths().is_empty() {
            return Err(ValidateError::file(what, "measured: give at least one DNG"));
        }
        for r in &c.regions {
            for (k, v) in [("measured", r.measured), ("simulated", r.simulated)] {
                if v[2] == 0 || v[3] == 0 {
                    return Err(ValidateError::file(
                        what,
                        format!("region '{}': {k} = {v:?} has no pixels", r.name),
                    ));
                }
            }
        }
        if let Some(t) = c.exposure_s {
            if !(t.is_finite() && t >= 0.0) {
                return Err(ValidateError::file(
                    what,
                    format!("exposure_s = {t} is not a time >= 0"),
                ));
            }
        }
        Ok(c)
    }

    /// Read a TOML file.
    pub fn from_file(path: &Path) -> Result<CompareConfig> {
        let text =
            std::fs::read_to_string(path).map_err(|e| ValidateError::file(path, e.to_string()))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        CompareConfig::from_toml_str(&text, &dir, path)
    }

    fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }
}

/// One region compared.
#[derive(Debug, Clone, Serialize)]
pub struct RegionComparison {
    /// Region name.
    pub name: String,
    /// Simulated (a) and measured (b) statistics, with the predicted std at each mean.
    pub pair: RegionPair,
}

/// The comparison's results (also `results.json`).
#[derive(Debug, Clone, Serialize)]
pub struct CompareResults {
    /// The simulated DNG.
    pub simulated: String,
    /// The measured DNGs.
    pub measured: Vec<String>,
    /// Sensor used for the prediction.
    pub sensor: Option<String>,
    /// Exposure used for the prediction, s.
    pub exposure_s: f64,
    /// Per region.
    pub regions: Vec<RegionComparison>,
    /// Largest |measured mean - simulated mean|, DN.
    pub max_mean_difference_dn: f64,
    /// Largest |measured std - simulated std|, DN.
    pub max_std_difference_dn: f64,
    /// Largest |measured std - predicted std at the measured mean|, DN (when a sensor is given).
    pub max_measured_vs_predicted_std_dn: Option<f64>,
    /// Figures.
    pub figures: Vec<FigurePng>,
}

fn read_raw(path: &Path) -> Result<RawImage> {
    let p = if path.is_dir() {
        let cand = path.join("raw.dng");
        if cand.is_file() {
            cand
        } else {
            return Err(ValidateError::file(
                path,
                "a folder without raw.dng (give the DNG itself)",
            ));
        }
    } else {
        path.to_path_buf()
    };
    let (raw, _info) = camsim_io::dng::read_dng(&p)?;
    Ok(raw)
}

fn rect(v: [usize; 4]) -> Rect {
    Rect::new(v[0], v[1], v[2], v[3])
}

/// Compare measured and simulated raw images region by region and write the report into `out_dir`.
pub fn compare(cfg: &CompareConfig, out_dir: &Path) -> Result<CompareResults> {
    std::fs::create_dir_all(out_dir).map_err(|e| {
        ValidateError::file(out_dir, format!("cannot create the output folder: {e}"))
    })?;
    let sim_path = cfg.resolve(&cfg.simulated);
    let sim = read_raw(&sim_path)?;
    let sensor = match &cfg.sensor {
        None => None,
        Some(s) => {
            let p = cfg.resolve(Path::new(s));
            Some(if p.is_file() {
                Sensor::from_file(&p)?
            } else {
                Sensor::preset(s)?
            })
        }
    };
    let exposure_s = cfg.exposure_s.unwrap_or(sim.exposure_s);
    let regions: Vec<(Rect, Rect)> = cfg
        .regions
        .iter()
        .map(|r| (rect(r.simulated), rect(r.measured)))
        .collect();
    let measured_paths: Vec<PathBuf> = cfg
        .measured
        .paths()
        .iter()
        .map(|p| cfg.resolve(p))
        .collect();
    // Statistics per measured frame, averaged over frames.
    let mut pairs: Option<Vec<RegionPair>> = None;
    for mp in &measured_paths {
        let meas = read_raw(mp)?;
        let pr = compare_regions_raw(&sim, &meas, &regions)
            .map_err(|e| ValidateError::file(mp, e.to_string()))?;
        pairs = Some(match pairs {
            None => pr,
            Some(mut acc) => {
                for (a, b) in acc.iter_mut().zip(&pr) {
                    for c in 0..3 {
                        a.b.mean_dn[c] += b.b.mean_dn[c];
                        a.b.std_dn[c] += b.b.std_dn[c];
                    }
                }
                acc
            }
        });
    }
    let mut pairs = pairs.unwrap_or_default();
    let nf = measured_paths.len() as f64;
    for p in pairs.iter_mut() {
        for c in 0..3 {
            p.b.mean_dn[c] /= nf;
            p.b.std_dn[c] /= nf;
            p.mean_difference_dn[c] = p.b.mean_dn[c] - p.a.mean_dn[c];
            p.std_difference_dn[c] = p.b.std_dn[c] - p.a.std_dn[c];
        }
    }
    if let Some(s) = &sensor {
        add_predicted_std(&mut pairs, |m| s.predicted_noise_dn(m, exposure_s).total)?;
    }
    let mut max_mean: f64 = 0.0;
    let mut max_std: f64 = 0.0;
    let mut max_pred: Option<f64> = None;
    for p in &pairs {
        for c in 0..3 {
            max_mean = max_mean.max(p.mean_difference_dn[c].abs());
            max_std = max_std.max(p.std_difference_dn[c].abs());
            if let Some(pb) = p.predicted_std_dn_b {
                let d = (p.b.std_dn[c] - pb[c]).abs();
                max_pred = Some(max_pred.unwrap_or(0.0).max(d));
            }
        }
    }
    let mut res = CompareResults {
        simulated: sim_path.display().to_string(),
        measured: measured_paths
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        sensor: sensor.as_ref().map(|s| s.name().to_string()),
        exposure_s,
        regions: cfg
            .regions
            .iter()
            .zip(pairs)
            .map(|(r, p)| RegionComparison {
                name: r.name.clone(),
                pair: p,
            })
            .collect(),
        max_mean_difference_dn: max_mean,
        max_std_difference_dn: max_std,
        max_measured_vs_predicted_std_dn: max_pred,
        figures: Vec::new(),
    };
    res.figures = figures(out_dir, &res)?;
    let html = report(&res);
    camsim_io::atomic::write_bytes_atomic(&out_dir.join("report.html"), html.as_bytes())?;
    camsim_io::atomic::write_json_atomic(&out_dir.join("results.json"), &res)?;
    Ok(res)
}

fn figures(out_dir: &Path, r: &CompareResults) -> Result<Vec<FigurePng>> {
    let names = ["R", "G", "B"];
    let mut means = Figure::new(
        "mean digital values",
        "measured mean (DN above black)",
        "simulated mean (DN above black)",
    );
    let mut stds = Figure::new(
        "standard deviations",
        "measured std (DN)",
        "simulated std (DN)",
    );
    for c in 0..3 {
        let mx: Vec<f64> = r.regions.iter().map(|g| g.pair.b.mean_dn[c]).collect();
        let my: Vec<f64> = r.regions.iter().map(|g| g.pair.a.mean_dn[c]).collect();
        means = means.with(Series::xy(
            names[c],
            mx,
            my,
            Style::Points,
            CHANNEL_COLORS[c],
        ));
        let sx: Vec<f64> = r.regions.iter().map(|g| g.pair.b.std_dn[c]).collect();
        let sy: Vec<f64> = r.regions.iter().map(|g| g.pair.a.std_dn[c]).collect();
        stds = stds.with(Series::xy(
            names[c],
            sx.clone(),
            sy,
            Style::Points,
            CHANNEL_COLORS[c],
        ));
        if r.regions
            .iter()
            .all(|g| g.pair.predicted_std_dn_b.is_some())
        {
            let py: Vec<f64> = r
                .regions
                .iter()
                .map(|g| g.pair.predicted_std_dn_b.unwrap()[c])
                .collect();
            let light = CHANNEL_COLORS[c].map(|v| ((v as u32 + 255) / 2) as u8);
            stds = stds.with(Series::xy(
                format!("{} model at measured mean", names[c]),
                sx,
                py,
                Style::Points,
                light,
            ));
        }
    }
    Ok(vec![
        save_png(out_dir, "compare_means.png", "Mean DN per region and channel: simulated against measured (dashed y = x).", means.with_identity_line().png()?)?,
        save_png(
            out_dir,
            "compare_std.png",
            "Standard deviation per region and channel: simulated (dark) and the noise model at the measured mean (light) against measured (dashed y = x).",
            stds.with_identity_line().png()?,
        )?,
    ])
}

fn report(r: &CompareResults) -> String {
    let mut h = Html::new("camsim validate: measured against simulated, region by region");
    h.p(&format!(
        "Simulated: {}. Measured: {}.",
        r.simulated,
        r.measured.join(", ")
    ));
    if let Some(s) = &r.sensor {
        h.p(&format!("Noise prediction: sensor '{s}' at {:.4} ms exposure (shot + read + DSNU + PRNU + quantization).", r.exposure_s * 1e3));
    }
    for fg in &r.figures {
        h.figure(&fg.png, &fg.caption);
    }
    let mut rows = Vec::new();
    for g in &r.regions {
        for c in 0..3 {
            let p = &g.pair;
            rows.push(vec![
                g.name.clone(),
                ["R", "G", "B"][c].to_string(),
                f(p.b.mean_dn[c], 1),
                f(p.a.mean_dn[c], 1),
                f(p.b.std_dn[c], 2),
                f(p.a.std_dn[c], 2),
                p.predicted_std_dn_b
                    .map(|v| f(v[c], 2))
                    .unwrap_or_else(|| "-".into()),
            ]);
        }
    }
    h.table(
        &[
            "region",
            "channel",
            "measured mean",
            "simulated mean",
            "measured std",
            "simulated std",
            "predicted std (at measured mean)",
        ],
        &rows,
    );
    h.p(&format!(
        "Largest differences: mean {:.2} DN, std {:.2} DN{}.",
        r.max_mean_difference_dn,
        r.max_std_difference_dn,
        r.max_measured_vs_predicted_std_dn
            .map(|v| format!(", measured std vs model {v:.2} DN"))
            .unwrap_or_default()
    ));
    h.finish()
}
