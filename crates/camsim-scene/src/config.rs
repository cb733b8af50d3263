//! Scene configuration (TOML), tagged by `kind`:
//!
//! ```toml
//! kind = "macbeth"            # uniform | macbeth | slanted_edge | file
//! mean_luminance_cd_m2 = 100
//! fov_deg = 10
//! distance_m = 1.2
//! illuminant = "D65"          # D65, A, C, F2, F11, E, blackbody-<K>, or a spectrum file (.csv, .mat)
//! patch_size_px = 16
//! border_px = 2
//! ```

use crate::geometry::MacbethLayout;
use camsim_core::error::{CoreError, Result};
use camsim_core::WavelengthGrid;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

fn default_mean_luminance() -> f64 {
    100.0
}
fn default_fov_deg() -> f64 {
    10.0
}
fn default_distance_m() -> f64 {
    1.2
}
fn default_illuminant() -> String {
    "D65".to_string()
}
fn default_uniform_size() -> usize {
    32
}
fn default_reflectance() -> Reflectance {
    Reflectance::Grey(1.0)
}
fn default_patch_size() -> usize {
    16
}
fn default_border() -> usize {
    2
}
fn default_edge_size() -> usize {
    256
}
fn default_angle() -> f64 {
    5.0
}
fn default_bright() -> f64 {
    1.0
}
fn default_dark() -> f64 {
    0.25
}

/// A surface reflectance: a grey level (the same fraction at every wavelength), a ColorChecker
/// patch (`"macbeth:<1-24 or name>"`, N. Ohta 1997), or a spectrum file (CSV or ISETCam `.mat`,
/// values as fractions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Reflectance {
    /// Spectrally flat reflectance, fraction in [0, 1].
    Grey(f64),
    /// `"macbeth:<patch>"` or a path to a spectrum file.
    Named(String),
}

/// A uniform field: illuminant x one reflectance everywhere (ISETCam `sceneCreate('uniform')`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniformScene {
    /// Mean luminance of the scene, cd/m^2 (ISETCam `sceneAdjustLuminance`). 0 gives a dark scene.
    #[serde(default = "default_mean_luminance")]
    pub mean_luminance_cd_m2: f64,
    /// Horizontal field of view, degrees, in (0, 180).
    #[serde(default = "default_fov_deg")]
    pub fov_deg: f64,
    /// Distance from the lens to the scene plane, m (ISETCam's default 1.2 m).
    #[serde(default = "default_distance_m")]
    pub distance_m: f64,
    /// Illuminant: a built-in name (D65, A, C, F2, F11, E, `blackbody-<K>`) or a spectrum file
    /// (.csv or ISETCam .mat; relative units).
    #[serde(default = "default_illuminant")]
    pub illuminant: String,
    /// Wavelength grid, nm (optional; the default is 400-700 nm every 10 nm).
    #[serde(default)]
    pub wavelengths: Option<WavelengthGrid>,
    /// Image height, pixels.
    #[serde(default = "default_uniform_size")]
    pub rows: usize,
    /// Image width, pixels.
    #[serde(default = "default_uniform_size")]
    pub cols: usize,
    /// Surface reflectance: a number (grey, fraction), `"macbeth:<patch>"` or a spectrum file.
    #[serde(default = "default_reflectance")]
    pub reflectance: Reflectance,
}

/// The Macbeth ColorChecker: 4 x 6 patches in the standard order (N. Ohta 1997 reflectances)
/// separated by borders (ISETCam `sceneCreate('macbeth')`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MacbethScene {
    /// Mean luminance of the whole chart (borders included), cd/m^2.
    #[serde(default = "default_mean_luminance")]
    pub mean_luminance_cd_m2: f64,
    /// Horizontal field of view, degrees, in (0, 180).
    #[serde(default = "default_fov_deg")]
    pub fov_deg: f64,
    /// Distance from the lens to the chart, m.
    #[serde(default = "default_distance_m")]
    pub distance_m: f64,
    /// Illuminant: a built-in name or a spectrum file (relative units).
    #[serde(default = "default_illuminant")]
    pub illuminant: String,
    /// Wavelength grid, nm (optional; the default is 400-700 nm every 10 nm).
    #[serde(default)]
    pub wavelengths: Option<WavelengthGrid>,
    /// Side of each square patch, pixels (>= 1).
    #[serde(default = "default_patch_size")]
    pub patch_size_px: usize,
    /// Width of the borders between patches and around the chart, pixels (0 = none).
    #[serde(default = "default_border")]
    pub border_px: usize,
    /// Reflectance of the borders, fraction (0 = black, as on the physical chart).
    #[serde(default)]
    pub border_reflectance: f64,
}

/// An ISO 12233 slanted edge: a straight edge through the image centre, tilted from the vertical,
/// bright (reflectance `bright_reflectance`) on the right and dark on the left, each pixel the
/// exact area-weighted mixture of the two (analytic coverage).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlantedEdgeScene {
    /// Mean luminance of the image, cd/m^2.
    #[serde(default = "default_mean_luminance")]
    pub mean_luminance_cd_m2: f64,
    /// Horizontal field of view, degrees, in (0, 180).
    #[serde(default = "default_fov_deg")]
    pub fov_deg: f64,
    /// Distance from the lens to the chart, m.
    #[serde(default = "default_distance_m")]
    pub distance_m: f64,
    /// Illuminant: a built-in name or a spectrum file (relative units).
    #[serde(default = "default_illuminant")]
    pub illuminant: String,
    /// Wavelength grid, nm (optional; the default is 400-700 nm every 10 nm).
    #[serde(default)]
    pub wavelengths: Option<WavelengthGrid>,
    /// Image height, pixels.
    #[serde(default = "default_edge_size")]
    pub rows: usize,
    /// Image width, pixels.
    #[serde(default = "default_edge_size")]
    pub cols: usize,
    /// Tilt of the edge from the vertical, degrees, in (-45, 45); the edge crosses row y at column
    /// cols/2 + (y - rows/2) tan(angle). ISO 12233 recommends about 5 degrees.
    #[serde(default = "default_angle")]
    pub angle_deg: f64,
    /// Reflectance of the bright side, fraction.
    #[serde(default = "default_bright")]
    pub bright_reflectance: f64,
    /// Reflectance of the dark side, fraction (the default 0.25 gives ISO 12233:2017's 4:1 contrast).
    #[serde(default = "default_dark")]
    pub dark_reflectance: f64,
}

/// A spectral radiance image read from a file (OpenEXR spectral layout; the caller loads it with
/// camsim-io and passes it to [`crate::from_image`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileScene {
    /// Path of the spectral radiance image.
    pub path: PathBuf,
    /// Rescale to this mean luminance, cd/m^2; absent = keep the file's absolute radiance.
    #[serde(default)]
    pub mean_luminance_cd_m2: Option<f64>,
    /// Horizontal field of view, degrees; absent = keep the file's (its sample spacing and distance).
    #[serde(default)]
    pub fov_deg: Option<f64>,
    /// Distance to the scene plane, m; absent = the file's, or 1.2 m when the file has none.
    #[serde(default)]
    pub distance_m: Option<f64>,
    /// Wavelength grid to resample the file onto, nm (optional; default: keep the file's grid).
    #[serde(default)]
    pub wavelengths: Option<WavelengthGrid>,
}

/// A 2D scene, tagged by `kind` (like ISETCam `sceneCreate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SceneConfig {
    /// `kind = "uniform"`.
    Uniform(UniformScene),
    /// `kind = "macbeth"`.
    Macbeth(MacbethScene),
    /// `kind = "slanted_edge"`.
    SlantedEdge(SlantedEdgeScene),
    /// `kind = "file"`.
    File(FileScene),
}

impl Default for UniformScene {
    fn default() -> Self {
        UniformScene {
            mean_luminance_cd_m2: default_mean_luminance(),
            fov_deg: default_fov_deg(),
            distance_m: default_distance_m(),
            illuminant: default_illuminant(),
            wavelengths: None,
            rows: default_uniform_size(),
            cols: default_uniform_size(),
            reflectance: default_reflectance(),
        }
    }
}

impl Default for MacbethScene {
    fn default() -> Self {
        MacbethScene {
            mean_luminance_cd_m2: default_mean_luminance(),
            fov_deg: default_fov_deg(),
            distance_m: default_distance_m(),
            illuminant: default_illuminant(),
            wavelengths: None,
            patch_size_px: default_patch_size(),
            border_px: default_border(),
            border_reflectance: 0.0,
        }
    }
}

impl Default for SlantedEdgeScene {
    fn default() -> Self {
        SlantedEdgeScene {
            mean_luminance_cd_m2: default_mean_luminance(),
            fov_deg: default_fov_deg(),
            distance_m: default_distance_m(),
            illuminant: default_illuminant(),
            wavelengths: None,
            rows: default_edge_size(),
            cols: default_edge_size(),
            angle_deg: default_angle(),
            bright_reflectance: default_bright(),
            dark_reflectance: default_dark(),
        }
    }
}

/// The default scene: the ColorChecker under D65 at 100 cd/m^2.
impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig::Macbeth(MacbethScene::default())
    }
}

impl MacbethScene {
    /// The chart layout in pixels.
    pub fn layout(&self) -> MacbethLayout {
        MacbethLayout { patch_px: self.patch_size_px, border_px: self.border_px }
    }
}

impl SceneConfig {
    /// Parse a TOML scene description; `what` (a file name) prefixes error messages.
    pub fn from_toml(text: &str, what: &str) -> Result<SceneConfig> {
        toml::from_str(text).map_err(|e| CoreError::invalid(what, e.to_string().trim_end().to_string()))
    }

    /// The config as TOML (for sidecars; round-trips through [`SceneConfig::from_toml`]).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// The kind name as written in TOML.
    pub fn kind(&self) -> &'static str {
        match self {
            SceneConfig::Uniform(_) => "uniform",
            SceneConfig::Macbeth(_) => "macbeth",
            SceneConfig::SlantedEdge(_) => "slanted_edge",
            SceneConfig::File(_) => "file",
        }
    }

    /// The wavelength grid the config asks for, or the default 400-700 nm every 10 nm.
    pub fn grid(&self) -> WavelengthGrid {
        let g = match self {
            SceneConfig::Uniform(c) => c.wavelengths,
            SceneConfig::Macbeth(c) => c.wavelengths,
            SceneConfig::SlantedEdge(c) => c.wavelengths,
            SceneConfig::File(c) => c.wavelengths,
        };
        g.unwrap_or_default()
    }

    /// Make relative file paths in the config (illuminant and reflectance files, the radiance
    /// file) relative to `base_dir` (the folder of the config file). Built-in names are untouched.
    pub fn resolve_paths(&mut self, base_dir: &Path) {
        let fix_string = |s: &mut String| {
            if looks_like_file(s) && Path::new(s.as_str()).is_relative() {
                *s = base_dir.join(s.as_str()).to_string_lossy().into_owned();
            }
        };
        match self {
            SceneConfig::Uniform(c) => {
                fix_string(&mut c.illuminant);
                if let Reflectance::Named(s) = &mut c.reflectance {
                    if !s.to_ascii_lowercase().starts_with("macbeth:") {
                        fix_string(s);
                    }
                }
            }
            SceneConfig::Macbeth(c) => fix_string(&mut c.illuminant),
            SceneConfig::SlantedEdge(c) => fix_string(&mut c.illuminant),
            SceneConfig::File(c) => {
                if c.path.is_relative() {
                    c.path = base_dir.join(&c.path);
                }
            }
        }
    }
}

/// A string names a spectrum file (rather than a built-in table) when it has a path separator or a
/// file extension.
pub(crate) fn looks_like_file(s: &str) -> bool {
    camsim_core::tables::illuminant(s).is_err() && (s.contains('/') || s.contains('\\') || Path::new(s).extension().is_some())
}
