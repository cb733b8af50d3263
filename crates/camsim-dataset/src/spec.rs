//! The dataset spec: a base `simulate` config plus variations over any of its keys, and the rule
//! that turns (spec, sample index) into one effective config.
//!
//! ```toml
//! [dataset]
//! samples = 96            # N; sample i is determined by (spec, i) alone
//! shard_size = 16         # samples per tar shard
//! seed = 7                # master seed of every random draw and of each sample's noise
//! outputs = ["raw", "preview", "noise-free"]
//!
//! [base]                  # a whole `camsim simulate` config (or base_config = "file.toml")
//! scene = { kind = "macbeth", illuminant = "D65" }
//! sensor = { preset = "pixel4a", rows = 480, cols = 640 }
//!
//! [[vary]]                # a grid: samples cycle through the values
//! key = "optics.config.f_number"
//! values = [1.73, 2.8, 4.0]
//!
//! [[vary]]                # a seeded random draw per sample
//! key = "capture.exposure_ms"
//! log_uniform = [2.0, 30.0]
//! ```

use crate::{DatasetError, Result};
use camsim_core::names::{NameTable, Named};
use camsim_pipeline::{OutputSet, SimulateConfig};
use rand::{Rng, SeedableRng};
use rand_distr::Distribution;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The spec file as written.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpecFile {
    /// Size, sharding, seed and outputs.
    pub dataset: DatasetSection,
    /// The base `simulate` config, inline (the same tables as a simulate config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Map<String, serde_json::Value>>")]
    pub base: Option<toml::Table>,
    /// Or the base config in its own file, relative to the spec.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_config: Option<PathBuf>,
    /// The variations, applied in order.
    #[serde(default)]
    pub vary: Vec<VariationSpec>,
    /// A camera rig (`[[rig]]`, 3D scenes): every sample is captured by each camera, all seeing
    /// the sample's one composed scene, each with its own noise; files `KEY.NAME.*`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rig: Vec<RigCameraSpec>,
}

/// One `[[rig]]` camera: its name and pose relative to the rig (the scene's camera, or the one
/// a composition's camera sampler drew), and optionally a sensor and optics of its own.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RigCameraSpec {
    /// The camera's name in file names (`KEY.NAME.dng`, `KEY.NAME.preview.png`, ...): letters,
    /// digits, `_` and `-`.
    pub name: String,
    /// Its pose in the rig's frame (x right, y up, z forward, m and degrees), as
    /// `[render.camera_offset]` takes it: a stereo pair's right camera is
    /// `{ translation_m = [0.12, 0, 0] }` (its baseline to the right).
    #[serde(default)]
    pub offset: camsim_pipeline::config::CameraOffset,
    /// Its own `[sensor]` table, replacing the sample's (variations of sensor keys then do not
    /// reach it) [default: the sample's].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Map<String, serde_json::Value>>")]
    pub sensor: Option<toml::Table>,
    /// Its own `[optics]` table, replacing the sample's [default: the sample's].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<serde_json::Map<String, serde_json::Value>>")]
    pub optics: Option<toml::Table>,
}

/// The most cameras a rig has.
pub const MAX_RIG_CAMERAS: usize = 16;

/// `[dataset]`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DatasetSection {
    /// Number of samples N (indices 0 .. N-1).
    pub samples: u64,
    /// Samples per shard (one tar file each); default 64.
    #[serde(default = "default_shard_size")]
    pub shard_size: u64,
    /// Master seed: every random draw and each sample's sensor-noise/render seed derive from
    /// (seed, sample index); default 1.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Files per sample besides its `.json` record, by name: a run's outputs and the dataset's
    /// own (`camsim presets` lists them); default raw and preview.
    #[serde(default = "default_outputs")]
    pub outputs: Vec<String>,
}

fn default_shard_size() -> u64 {
    64
}
fn default_seed() -> u64 {
    1
}
fn default_outputs() -> Vec<String> {
    vec!["raw".into(), "preview".into()]
}

/// The built-in example spec (`examples/datasets/colorchecker.toml`).
pub const DEFAULT_SPEC: &str = include_str!("../../../examples/datasets/colorchecker.toml");

/// A dataset's own outputs, beside those of a run (`camsim_pipeline::outputs::OUTPUTS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DatasetOutput {
    /// `KEY.raw.npy`: the first frame as a uint16 numpy array.
    RawNpy,
    /// `KEY.xyz.exr`: the scene's CIE 1931 XYZ ground truth.
    Xyz,
}

/// The outputs a dataset has besides a run's (`dataset.outputs` takes these and every name of
/// `camsim_pipeline::outputs::OUTPUTS`).
pub const DATASET_OUTPUTS: NameTable<DatasetOutput> = NameTable {
    family: "dataset output",
    entries: &[
        Named {
            name: "raw-npy",
            aliases: &[],
            about: "KEY.raw.npy: the first frame as a uint16 numpy array",
            value: DatasetOutput::RawNpy,
        },
        Named {
            name: "xyz",
            aliases: &[],
            about: "KEY.xyz.exr: the scene's CIE 1931 XYZ ground truth (Y in cd/m^2)",
            value: DatasetOutput::Xyz,
        },
    ],
};

/// One `[[vary]]` entry as written: a key and exactly one way to choose its value.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VariationSpec {
    /// A dotted config key, e.g. `optics.config.f_number`, `capture.exposure_ms`,
    /// `sensor.preset`, `scene.illuminant`, `render.overlay`.
    pub key: String,
    /// Grid: the samples cycle through these values (several grids form their product, the
    /// first varying fastest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<Vec<serde_json::Value>>")]
    pub values: Option<Vec<toml::Value>>,
    /// Uniform draw in [min, max).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uniform: Option<[f64; 2]>,
    /// Log-uniform draw in [min, max), min > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_uniform: Option<[f64; 2]>,
    /// One of these values, each equally likely.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(with = "Option<Vec<serde_json::Value>>")]
    pub choice: Option<Vec<toml::Value>>,
    /// Normal draw, redrawn until inside [min, max].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<NormalSpec>,
    /// Round a drawn number to an integer.
    #[serde(default)]
    pub integer: bool,
}

/// `normal = { mean, std, min, max }`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NormalSpec {
    /// Mean of the normal distribution, in the key's own unit.
    pub mean: f64,
    /// Standard deviation, in the key's own unit; > 0.
    pub std: f64,
    /// Smallest value kept (draws below are redrawn), in the key's own unit.
    pub min: f64,
    /// Largest value kept (draws above are redrawn), in the key's own unit.
    pub max: f64,
}

/// How a variation picks its value.
#[derive(Debug, Clone)]
pub enum Draw {
    Grid(Vec<toml::Value>),
    Uniform(f64, f64),
    LogUniform(f64, f64),
    Choice(Vec<toml::Value>),
    Normal(NormalSpec),
}

/// A checked variation.
#[derive(Debug, Clone)]
pub struct Variation {
    pub key: String,
    pub draw: Draw,
    pub integer: bool,
}

/// A checked spec, ready to produce samples.
#[derive(Debug, Clone)]
pub struct DatasetSpec {
    /// Where it came from (for messages).
    pub source: String,
    /// Folder relative paths in the base config are resolved against.
    pub base_dir: PathBuf,
    pub samples: u64,
    pub shard_size: u64,
    pub seed: u64,
    /// Outputs of the pipeline (EXR, DNG, PNG).
    pub outputs: OutputSet,
    /// Also the first frame as a uint16 .npy array.
    pub raw_npy: bool,
    /// Also the scene's CIE 1931 XYZ ground truth (EXR, Y in cd/m^2).
    pub xyz: bool,
    /// The output names as the spec lists them.
    pub output_names: Vec<String>,
    /// The base config table (presets expanded inline where a variation reaches into them).
    pub base: toml::Table,
    pub vary: Vec<Variation>,
    /// The rig's cameras (empty: one camera, the scene's).
    pub rig: Vec<RigCameraSpec>,
    /// SHA-256 of the canonical spec (base inlined): a dataset folder belongs to one spec.
    pub fingerprint: String,
}

/// One sample's effective config and the values its variations took.
#[derive(Debug, Clone)]
pub struct Sample {
    pub index: u64,
    /// The sample's own seed (render and sensor noise).
    pub seed: u64,
    /// The varied keys and the values they took, in spec order.
    pub params: Vec<(String, toml::Value)>,
    pub config: SimulateConfig,
    /// With a rig: each camera's name and config (the sample's, moved by the camera's offset,
    /// with its own sensor and optics, its own seed and the sample's seed as `compose_seed`).
    pub rig: Vec<(String, SimulateConfig)>,
}

impl DatasetSpec {
    /// Read a spec file (TOML).
    pub fn from_file(path: &Path) -> Result<DatasetSpec> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| DatasetError::spec(path.display(), format!("cannot read: {e}")))?;
        let base_dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Self::from_toml_str(&text, &path.display().to_string(), &base_dir)
    }

    /// The built-in example (`camsim dataset` with no spec, Python's `camsim.dataset.run()` with
    /// none): `examples/datasets/colorchecker.toml`, 24 ColorChecker captures.
    pub fn builtin_default() -> Result<DatasetSpec> {
        DatasetSpec::from_toml_str(
            DEFAULT_SPEC,
            "built-in spec (examples/datasets/colorchecker.toml)",
            Path::new("."),
        )
    }

    /// Parse spec text: TOML, or JSON when it starts with `{` (what the Python package sends for
    /// a dict). `source` names it in messages; relative paths are resolved against `base_dir`.
    pub fn from_toml_str(text: &str, source: &str, base_dir: &Path) -> Result<DatasetSpec> {
        let file: SpecFile = if text.trim_start().starts_with('{') {
            serde_json::from_str(text).map_err(|e| DatasetError::spec(source, e.to_string()))?
        } else {
            toml::from_str(text)
                .map_err(|e| DatasetError::spec(source, e.to_string().trim_end().to_string()))?
        };
        Self::from_spec_file(file, source, base_dir)
    }

    /// Check a parsed spec: sizes, outputs, every variation's range, and that the base config and
    /// the configs the variations produce are valid (before any work starts).
    pub fn from_spec_file(file: SpecFile, source: &str, base_dir: &Path) -> Result<DatasetSpec> {
        let err = |m: String| DatasetError::spec(source, m);
        let d = &file.dataset;
        if d.samples == 0 {
            return Err(err("dataset.samples must be at least 1".into()));
        }
        if d.shard_size == 0 {
            return Err(err("dataset.shard_size must be at least 1".into()));
        }
        let mut names = Vec::new();
        let (mut raw_npy, mut xyz) = (false, false);
        for o in &d.outputs {
            match DATASET_OUTPUTS.entry(o).map(|e| e.value) {
                Some(DatasetOutput::RawNpy) => raw_npy = true,
                Some(DatasetOutput::Xyz) => xyz = true,
                None => names.push(o.as_str()),
            }
        }
        let outputs = if names.is_empty() {
            Ok(OutputSet::none())
        } else {
            OutputSet::parse(&names.join(","))
        }
        .map_err(|e| {
            let run_outputs = &camsim_pipeline::outputs::OUTPUTS;
            let unknown = names
                .iter()
                .find(|n| run_outputs.entry(n).is_none() && !matches!(n.trim(), "all" | "default"));
            match unknown {
                // Every name `dataset.outputs` takes: a run's and the dataset's own.
                Some(name) if !e.to_string().contains("not available yet") => err(format!(
                    "dataset.outputs: unknown output '{}'; known: {}, {} (or all, default)",
                    name.trim(),
                    run_outputs.known(),
                    DATASET_OUTPUTS.known()
                )),
                _ => err(format!(
                    "dataset.outputs: {}",
                    e.to_string().trim_start_matches("--save: ")
                )),
            }
        })?;

        let (mut base, base_dir) = match (&file.base, &file.base_config) {
            (Some(_), Some(_)) => return Err(err("give [base] or base_config, not both".into())),
            (None, None) => {
                return Err(err(
                    "the spec needs a [base] table or base_config = \"simulate.toml\"".into(),
                ))
            }
            (Some(t), None) => (t.clone(), base_dir.to_path_buf()),
            (None, Some(p)) => {
                let path = base_dir.join(p);
                let text = std::fs::read_to_string(&path).map_err(|e| {
                    err(format!("base_config {}: cannot read: {e}", path.display()))
                })?;
                let t: toml::Table = toml::from_str(&text)
                    .map_err(|e| err(format!("base_config {}: {e}", path.display())))?;
                (t, path.parent().map(Path::to_path_buf).unwrap_or_default())
            }
        };
        if base.contains_key("seed") {
            return Err(err("[base] seed: each sample's seed derives from dataset.seed and its index; remove it".into()));
        }

        let mut vary = Vec::new();
        for (n, v) in file.vary.iter().enumerate() {
            let at = format!("vary[{n}] (key {:?})", v.key);
            let kinds = [
                v.values.is_some(),
                v.uniform.is_some(),
                v.log_uniform.is_some(),
                v.choice.is_some(),
                v.normal.is_some(),
            ];
            if kinds.iter().filter(|k| **k).count() != 1 {
                return Err(err(format!(
                    "{at}: give exactly one of values, uniform, log_uniform, choice, normal"
                )));
            }
            if v.key.is_empty() || v.key.split('.').any(str::is_empty) || v.key == "seed" {
                return Err(err(format!("{at}: not a config key (dotted, e.g. optics.config.f_number; seed is the dataset's)")));
            }
            let range = |r: [f64; 2], what: &str, positive: bool| -> Result<(f64, f64)> {
                let ok = r[0].is_finite()
                    && r[1].is_finite()
                    && r[0] < r[1]
                    && (!positive || r[0] > 0.0);
                if ok {
                    Ok((r[0], r[1]))
                } else {
                    Err(err(format!(
                        "{at}: {what} = [{}, {}] must be [min, max] with min < max{}",
                        r[0],
                        r[1],
                        if positive { " and min > 0" } else { "" }
                    )))
                }
            };
            let draw = if let Some(vals) = &v.values {
                if vals.is_empty() {
                    return Err(err(format!("{at}: values is empty")));
                }
                Draw::Grid(vals.clone())
            } else if let Some(r) = v.uniform {
                let (a, b) = range(r, "uniform", false)?;
                Draw::Uniform(a, b)
            } else if let Some(r) = v.log_uniform {
                let (a, b) = range(r, "log_uniform", true)?;
                Draw::LogUniform(a, b)
            } else if let Some(vals) = &v.choice {
                if vals.is_empty() {
                    return Err(err(format!("{at}: choice is empty")));
                }
                Draw::Choice(vals.clone())
            } else {
                let s = v.normal.unwrap_or(NormalSpec {
                    mean: 0.0,
                    std: 0.0,
                    min: 0.0,
                    max: 0.0,
                });
                let ok = [s.mean, s.std, s.min, s.max].iter().all(|x| x.is_finite())
                    && s.std > 0.0
                    && s.min < s.max;
                // The truncation window must hold some probability, or the redraw never ends.
                if !ok || s.max < s.mean - 6.0 * s.std || s.min > s.mean + 6.0 * s.std {
                    return Err(err(format!(
                        "{at}: normal needs std > 0 and min < max overlapping mean +- 6 std"
                    )));
                }
                Draw::Normal(s)
            };
            vary.push(Variation {
                key: v.key.clone(),
                draw,
                integer: v.integer,
            });
        }
        expand_presets(&mut base, &vary).map_err(err)?;
        if file.rig.len() > MAX_RIG_CAMERAS {
            return Err(err(format!(
                "rig: {} cameras; at most {MAX_RIG_CAMERAS}",
                file.rig.len()
            )));
        }
        for (c, cam) in file.rig.iter().enumerate() {
            let at = format!("rig[{c}]");
            let ok = !cam.name.is_empty()
                && cam
                    .name
                    .chars()
                    .all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-');
            if !ok {
                return Err(err(format!(
                    "{at}: name {:?}: letters, digits, _ and - only (it goes into file names)",
                    cam.name
                )));
            }
            if file.rig[..c].iter().any(|o| o.name == cam.name) {
                return Err(err(format!("{at}: a second camera named {:?}", cam.name)));
            }
            cam.offset
                .check(&format!("{at}.offset"))
                .map_err(|e| err(e.to_string()))?;
        }
        if !file.rig.is_empty() && !base.contains_key("render") {
            return Err(err(
                "rig: a camera rig needs a 3D scene ([base.render]); a 2D chart has no camera to move".into(),
            ));
        }

        let mut canonical = serde_json::json!({
            "dataset": file.dataset,
            "base": base,
            "vary": file.vary,
        });
        // Only a rig joins the fingerprint: specs without one keep the fingerprints (and the
        // dataset folders) they had.
        if !file.rig.is_empty() {
            canonical["rig"] = serde_json::to_value(&file.rig).map_err(|e| err(e.to_string()))?;
        }
        let fingerprint = format!("{:x}", Sha256::digest(canonical.to_string().as_bytes()));
        let spec = DatasetSpec {
            source: source.to_string(),
            base_dir,
            samples: d.samples,
            shard_size: d.shard_size,
            seed: d.seed,
            outputs,
            raw_npy,
            xyz,
            output_names: d.outputs.clone(),
            base,
            vary,
            rig: file.rig.clone(),
            fingerprint,
        };
        spec.check()?;
        Ok(spec)
    }

    /// Fail before any work: the base alone, then every grid point and every choice value of
    /// each random variation (with the other variations at their first value) must make a valid
    /// config whose files exist.
    fn check(&self) -> Result<()> {
        let base = self
            .config_of(&[], 0)
            .map_err(|e| DatasetError::spec(&self.source, format!("[base]: {e}")))?;
        check_config(&base)
            .map_err(|e| DatasetError::spec(&self.source, format!("[base]: {e}")))?;
        for c in 0..self.rig.len() {
            self.camera_config_of(&[], 0, c)
                .and_then(|cfg| check_config(&cfg))
                .map_err(|e| {
                    DatasetError::spec(
                        &self.source,
                        format!("rig[{c}] ({:?}): {e}", self.rig[c].name),
                    )
                })?;
        }
        for (n, v) in self.vary.iter().enumerate() {
            let candidates: Vec<toml::Value> = match &v.draw {
                Draw::Grid(vals) | Draw::Choice(vals) => vals.clone(),
                Draw::Uniform(a, b) | Draw::LogUniform(a, b) => {
                    vec![number(*a, v.integer), number(*b, v.integer)]
                }
                Draw::Normal(s) => vec![number(s.min, v.integer), number(s.max, v.integer)],
            };
            for c in candidates {
                self.config_of(&[(v.key.clone(), c.clone())], 0)
                    .and_then(|cfg| check_config(&cfg))
                    .map_err(|e| {
                        DatasetError::spec(
                            &self.source,
                            format!("vary[{n}] (key {:?}) = {c}: {e}", v.key),
                        )
                    })?;
            }
        }
        Ok(())
    }

    /// Number of shards.
    pub fn shards(&self) -> u64 {
        self.samples.div_ceil(self.shard_size)
    }

    /// The index range of shard `s`.
    pub fn shard_range(&self, s: u64) -> std::ops::Range<u64> {
        let first = s * self.shard_size;
        first..(first + self.shard_size).min(self.samples)
    }

    /// Sample `i`: its variations' values and effective config. A function of (spec, i) only.
    pub fn sample(&self, i: u64) -> Result<Sample> {
        if i >= self.samples {
            return Err(DatasetError::spec(
                &self.source,
                format!(
                    "sample {i} is out of range (the dataset has {})",
                    self.samples
                ),
            ));
        }
        let mut params = Vec::with_capacity(self.vary.len());
        let mut grid_index = i;
        for (n, v) in self.vary.iter().enumerate() {
            let value = match &v.draw {
                Draw::Grid(vals) => {
                    let len = vals.len() as u64;
                    let pick = grid_index % len;
                    grid_index /= len;
                    vals[pick as usize].clone()
                }
                draw => {
                    // One generator per (master seed, sample, variation): the draw never depends
                    // on which other samples or variations were drawn, nor on the thread.
                    let mut rng = Pcg64::seed_from_u64(mix(&[self.seed, i, n as u64 + 1]));
                    match draw {
                        Draw::Uniform(a, b) => number(rng.gen_range(*a..*b), v.integer),
                        // exp of a uniform in [ln a, ln b): density proportional to 1/x.
                        Draw::LogUniform(a, b) => {
                            number(rng.gen_range(a.ln()..b.ln()).exp(), v.integer)
                        }
                        Draw::Choice(vals) => vals[rng.gen_range(0..vals.len())].clone(),
                        Draw::Normal(s) => {
                            let nd = rand_distr::Normal::new(s.mean, s.std)
                                .map_err(|e| DatasetError::spec(&self.source, e.to_string()))?;
                            let x = loop {
                                let x = nd.sample(&mut rng);
                                if (s.min..=s.max).contains(&x) {
                                    break x;
                                }
                            };
                            number(x, v.integer)
                        }
                        Draw::Grid(_) => unreachable!(),
                    }
                }
            };
            params.push((v.key.clone(), value));
        }
        // 53 bits: exact as a JSON number (pandas, JavaScript) and as a TOML integer.
        let seed = mix(&[self.seed, i, 0]) >> 11;
        let config = self
            .config_of(&params, seed)
            .map_err(|e| DatasetError::spec(&self.source, format!("sample {i}: {e}")))?;
        let rig = (0..self.rig.len())
            .map(|c| {
                self.camera_config_of(&params, seed, c)
                    .map(|cfg| (self.rig[c].name.clone(), cfg))
                    .map_err(|e| {
                        DatasetError::spec(
                            &self.source,
                            format!("sample {i}, rig camera {:?}: {e}", self.rig[c].name),
                        )
                    })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Sample {
            index: i,
            seed,
            params,
            config,
            rig,
        })
    }

    /// Rig camera `c`'s config of the sample with `params` and `seed`: the sample's table with
    /// the camera's sensor and optics, `[render.camera_offset]` its offset, the sample's seed as
    /// `render.compose_seed` (one composition for every camera) and a seed of its own.
    fn camera_config_of(
        &self,
        params: &[(String, toml::Value)],
        seed: u64,
        c: usize,
    ) -> std::result::Result<SimulateConfig, String> {
        let cam = &self.rig[c];
        let mut t = self.base.clone();
        for (k, v) in params {
            set_key(&mut t, k, v.clone())?;
        }
        if let Some(s) = &cam.sensor {
            t.insert("sensor".into(), toml::Value::Table(s.clone()));
        }
        if let Some(o) = &cam.optics {
            t.insert("optics".into(), toml::Value::Table(o.clone()));
        }
        let offset = toml::Value::try_from(cam.offset).map_err(|e| e.to_string())?;
        let render = t
            .get_mut("render")
            .and_then(|r| r.as_table_mut())
            .ok_or("a camera rig needs a 3D scene ([render])")?;
        render.insert("camera_offset".into(), offset);
        render.insert("compose_seed".into(), toml::Value::Integer(seed as i64));
        let own = mix(&[seed, c as u64 + 1]) >> 11;
        t.insert("seed".into(), toml::Value::Integer(own as i64));
        SimulateConfig::from_value(toml::Value::Table(t), &self.base_dir).map_err(|e| e.to_string())
    }

    /// The base with `params` set, as a checked [`SimulateConfig`] with `seed`.
    fn config_of(
        &self,
        params: &[(String, toml::Value)],
        seed: u64,
    ) -> std::result::Result<SimulateConfig, String> {
        let mut t = self.base.clone();
        for (k, v) in params {
            set_key(&mut t, k, v.clone())?;
        }
        t.insert("seed".into(), toml::Value::Integer(seed as i64));
        // The one config door (checks and relative paths against the spec's folder).
        SimulateConfig::from_value(toml::Value::Table(t), &self.base_dir).map_err(|e| e.to_string())
    }
}

/// A config that can run: its lens, sensor and capture build, its wavelength grid is valid and
/// every file it names exists.
fn check_config(cfg: &SimulateConfig) -> std::result::Result<(), String> {
    cfg.wavelengths.validate().map_err(|e| e.to_string())?;
    cfg.optics().map_err(|e| e.to_string())?;
    cfg.sensor().map_err(|e| e.to_string())?;
    cfg.capture().map_err(|e| e.to_string())?;
    let mut files: Vec<&Path> = Vec::new();
    if let Some(r) = &cfg.render {
        files.extend(r.pbrt.as_deref());
        files.extend(r.overlay.as_deref());
    }
    match &cfg.scene {
        Some(camsim_scene::SceneConfig::File(f)) => files.push(&f.path),
        Some(camsim_scene::SceneConfig::Rgb(f)) => files.push(&f.path),
        _ => {}
    }
    for f in files {
        if !f.is_file() {
            return Err(format!("{}: no such file", f.display()));
        }
    }
    Ok(())
}

fn number(x: f64, integer: bool) -> toml::Value {
    if integer {
        toml::Value::Integer(x.round() as i64)
    } else {
        toml::Value::Float(x)
    }
}

/// Set a dotted key in a TOML table, creating missing tables on its way; a number indexes an
/// existing array (`render.overlay_inline.object.0.translate_m.1`).
fn set_key(t: &mut toml::Table, key: &str, value: toml::Value) -> std::result::Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let mut cur: &mut toml::Value = t
        .entry(parts[0].to_string())
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if parts.len() == 1 {
        *cur = value;
        return Ok(());
    }
    for (n, p) in parts.iter().enumerate().skip(1) {
        let here = parts[..n].join(".");
        cur = match cur {
            toml::Value::Table(tt) => {
                if n + 1 == parts.len() {
                    tt.insert(p.to_string(), value);
                    return Ok(());
                }
                tt.entry(p.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            }
            toml::Value::Array(a) => {
                let len = a.len();
                let i: usize = p.parse().map_err(|_| {
                    format!("{here} is an array: index it with a number, not {p:?}")
                })?;
                let slot = a
                    .get_mut(i)
                    .ok_or_else(|| format!("{here} has {len} entries: no index {i}"))?;
                if n + 1 == parts.len() {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => return Err(format!("{here} is a value, not a table: cannot set {key}")),
        };
    }
    unreachable!("the loop returns at the last part")
}

/// A variation into `optics.config.*` or `sensor.config.*` over a base that names only a preset:
/// write the preset's whole config inline first, so the variation edits one field of it.
fn expand_presets(base: &mut toml::Table, vary: &[Variation]) -> std::result::Result<(), String> {
    for section in ["optics", "sensor"] {
        let prefix = format!("{section}.config.");
        if !vary.iter().any(|v| v.key.starts_with(&prefix)) {
            continue;
        }
        let sec = base
            .entry(section)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let Some(sec) = sec.as_table_mut() else {
            return Err(format!("[base] {section} must be a table"));
        };
        if sec.contains_key("config") {
            continue;
        }
        if sec.contains_key("file") {
            return Err(format!("a variation over {prefix}* needs [base] {section}.config inline or a preset, not {section}.file"));
        }
        let name = match sec.remove("preset") {
            Some(toml::Value::String(s)) => s,
            Some(v) => return Err(format!("[base] {section}.preset = {v}: must be a name")),
            None => "pixel4a".to_string(),
        };
        let value = match section {
            "optics" => toml::Value::try_from(
                camsim_optics::OpticsConfig::preset(&name).map_err(|e| e.to_string())?,
            ),
            _ => toml::Value::try_from(
                camsim_sensor::Sensor::preset(&name)
                    .map_err(|e| e.to_string())?
                    .config(),
            ),
        }
        .map_err(|e| format!("{section} preset {name}: {e}"))?;
        sec.insert("config".into(), value);
    }
    Ok(())
}

/// SplitMix64 finalizer over a list of words (Steele, Lea & Flood 2014): a well-mixed 64-bit
/// seed from (master seed, sample index, variation).
pub fn mix(words: &[u64]) -> u64 {
    let mut h = 0x9E37_79B9_7F4A_7C15u64;
    for w in words {
        h ^= *w;
        h = h.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = h;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h = z ^ (z >> 31);
    }
    h
}
