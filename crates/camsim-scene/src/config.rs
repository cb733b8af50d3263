//! Scene configuration (TOML), tagged by `kind`:
//!
//! ```toml
//! kind = "macbeth"            # uniform | macbeth | slanted_edge | file | rgb | harmonic | zone_plate
//!                             # | sweep_frequency | star | checkerboard | grid_lines | point_array | ramp
//!                             # | dead_leaves | glare_target | hdr_chart | hdr_lights
//! mean_luminance_cd_m2 = 100
//! fov_deg = 10
//! distance_m = 1.2
//! illuminant = "D65"          # D65, A, C, F2, F11, E, blackbody-<K>, or a spectrum file (.csv, .mat)
//! patch_size_px = 16
//! border_px = 2
//! ```

use crate::geometry::MacbethLayout;
pub use crate::patterns::{
    CheckerboardScene, DeadLeavesScene, GlareTargetScene, GridLinesScene, HarmonicScene,
    HdrChartScene, HdrLightsScene, PointArrayScene, RampScene, StarScene, SweepFrequencyScene,
    ZonePlateScene,
};
pub use crate::rgb::RgbScene;
use camsim_core::error::{CoreError, Result};
use camsim_core::names::{NameTable, Named};
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Reflectance {
    /// Spectrally flat reflectance, fraction in [0, 1].
    Grey(f64),
    /// `"macbeth:<patch>"` or a path to a spectrum file.
    Named(String),
}

/// A uniform field: illuminant x one reflectance everywhere (ISETCam `sceneCreate('uniform')`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// Illuminant: a built-in name (D65, A, C, F2, F11, E, `blackbody-<K>`, the CIE 015:2018 lamps HP1-HP5 and LED-B1-B5, LED-BH1, LED-RGB1, LED-V1, LED-V2; `LPS`, a low-pressure sodium lamp) or a spectrum file
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// The 24 patch reflectances, in chart order (optional; default N. Ohta's 1997 measurements):
    /// a CSV (`wavelength_nm` and 24 columns) or an ISETCam `.mat` in `macbethChart.mat`'s layout
    /// (`wavelength`, `data` with 24 columns), fractions. ISETCam's own chart differs from Ohta's
    /// by up to 19 % per patch: give its file to compare results with ISETCam.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reflectances: Option<String>,
}

/// An ISO 12233 slanted edge: a straight edge through the image centre, tilted from the vertical,
/// bright (reflectance `bright_reflectance`) on the right and dark on the left, each pixel the
/// exact area-weighted mixture of the two (analytic coverage).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// The units of the file's values: `auto` (default: pbrt-v4's own spectral output, known
    /// by its header, is converted from pbrt-v4's units, 683 x 106.857 times W/(sr m^2 nm), and
    /// gives its field of view from its camera matrices; any other file is W/(sr m^2 nm)),
    /// `pbrt-v4` (convert), or `absolute` (never convert).
    #[serde(default)]
    pub units: FileUnits,
}

/// What the values of a `file` scene are (see [`FileScene::units`]).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum FileUnits {
    /// pbrt-v4's files converted, others as they are.
    #[default]
    Auto,
    /// pbrt-v4's units: divided by 683 x 106.856895.
    PbrtV4,
    /// W/(sr m^2 nm): no conversion.
    Absolute,
}

/// The 2D scene kinds by name: the `kind` of a `[scene]` table (as written there, with `_`),
/// `camsim scene --kind`. Each name is a variant of [`SceneConfig`] (tested).
pub const SCENE_KINDS: NameTable<()> = NameTable {
    family: "scene kind",
    entries: &[
        kind("uniform", "illuminant x one reflectance everywhere"),
        kind(
            "macbeth",
            "the Macbeth ColorChecker (Ohta 1997 reflectances)",
        ),
        kind("slanted_edge", "an ISO 12233 slanted edge"),
        kind("file", "a spectral OpenEXR radiance file"),
        kind(
            "rgb",
            "a photograph (PNG, JPEG, TIFF, EXR) on a display model",
        ),
        kind("harmonic", "a sinusoidal grating (ISETCam 'harmonic')"),
        kind("zone_plate", "a circular chirp (ISETCam 'zone plate')"),
        kind(
            "sweep_frequency",
            "frequency rising along the rows (ISETCam 'sweep frequency')",
        ),
        kind("star", "a Siemens star"),
        kind(
            "checkerboard",
            "black and white squares (ISETCam 'checkerboard')",
        ),
        kind("grid_lines", "thin lines on a grid (ISETCam 'grid lines')"),
        kind("point_array", "points on a grid (ISETCam 'point array')"),
        kind(
            "ramp",
            "a linear intensity ramp (ISETCam 'linear intensity ramp')",
        ),
        kind(
            "dead_leaves",
            "the ISO 19567-2 texture-loss target (ISETCam 'dead leaves')",
        ),
        kind(
            "glare_target",
            "the ISO 18844 veiling glare target: black holes in a bright surround",
        ),
        kind(
            "hdr_chart",
            "log-spaced strips over a dynamic range (ISETCam 'hdr chart')",
        ),
        kind(
            "hdr_lights",
            "bright discs and bars on a dark ground (ISETCam 'hdr lights')",
        ),
    ],
};

const fn kind(name: &'static str, about: &'static str) -> Named<()> {
    Named {
        name,
        aliases: &[],
        about,
        value: (),
    }
}

/// A 2D scene, tagged by `kind` (like ISETCam `sceneCreate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// `kind = "rgb"`: an RGB image on a display model (ISETCam `sceneFromFile`).
    Rgb(RgbScene),
    /// `kind = "harmonic"` (ISETCam 'harmonic').
    Harmonic(HarmonicScene),
    /// `kind = "zone_plate"` (ISETCam 'zone plate').
    ZonePlate(ZonePlateScene),
    /// `kind = "sweep_frequency"` (ISETCam 'sweep frequency').
    SweepFrequency(SweepFrequencyScene),
    /// `kind = "star"` (Siemens star).
    Star(StarScene),
    /// `kind = "checkerboard"` (ISETCam 'checkerboard').
    Checkerboard(CheckerboardScene),
    /// `kind = "grid_lines"` (ISETCam 'grid lines').
    GridLines(GridLinesScene),
    /// `kind = "point_array"` (ISETCam 'point array').
    PointArray(PointArrayScene),
    /// `kind = "ramp"` (ISETCam 'linear intensity ramp').
    Ramp(RampScene),
    /// `kind = "dead_leaves"` (ISO 19567-2 texture-loss target; ISETCam 'dead leaves').
    DeadLeaves(DeadLeavesScene),
    /// `kind = "glare_target"` (ISO 18844 veiling glare target).
    GlareTarget(GlareTargetScene),
    /// `kind = "hdr_chart"` (ISETCam `sceneHDRChart`).
    HdrChart(HdrChartScene),
    /// `kind = "hdr_lights"` (ISETCam `sceneHDRLights`).
    HdrLights(HdrLightsScene),
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
            reflectances: None,
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
        MacbethLayout {
            patch_px: self.patch_size_px,
            border_px: self.border_px,
        }
    }
}

impl SceneConfig {
    /// Parse a TOML scene description; `what` (a file name) prefixes error messages.
    ///
    /// Errors point at the offending key's own line and column (an unknown key, a value of the
    /// wrong type), not at the top of the table: see [`locate_scene_error`].
    pub fn from_toml(text: &str, what: &str) -> Result<SceneConfig> {
        toml::from_str(text).map_err(|e| {
            let msg = locate_scene_error(text, None).unwrap_or_else(|| e.to_string());
            CoreError::invalid(what, msg.trim_end().to_string())
        })
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
            SceneConfig::Rgb(_) => "rgb",
            SceneConfig::Harmonic(_) => "harmonic",
            SceneConfig::ZonePlate(_) => "zone_plate",
            SceneConfig::SweepFrequency(_) => "sweep_frequency",
            SceneConfig::Star(_) => "star",
            SceneConfig::Checkerboard(_) => "checkerboard",
            SceneConfig::GridLines(_) => "grid_lines",
            SceneConfig::PointArray(_) => "point_array",
            SceneConfig::Ramp(_) => "ramp",
            SceneConfig::DeadLeaves(_) => "dead_leaves",
            SceneConfig::GlareTarget(_) => "glare_target",
            SceneConfig::HdrChart(_) => "hdr_chart",
            SceneConfig::HdrLights(_) => "hdr_lights",
        }
    }

    /// The pattern scene behind a test-pattern kind (harmonic, zone_plate, ...), if it is one.
    pub(crate) fn pattern(&self) -> Option<&dyn crate::patterns::Pattern> {
        Some(match self {
            SceneConfig::Harmonic(c) => c,
            SceneConfig::ZonePlate(c) => c,
            SceneConfig::SweepFrequency(c) => c,
            SceneConfig::Star(c) => c,
            SceneConfig::Checkerboard(c) => c,
            SceneConfig::GridLines(c) => c,
            SceneConfig::PointArray(c) => c,
            SceneConfig::Ramp(c) => c,
            SceneConfig::DeadLeaves(c) => c,
            SceneConfig::GlareTarget(c) => c,
            SceneConfig::HdrChart(c) => c,
            SceneConfig::HdrLights(c) => c,
            SceneConfig::Uniform(_)
            | SceneConfig::Macbeth(_)
            | SceneConfig::SlantedEdge(_)
            | SceneConfig::File(_)
            | SceneConfig::Rgb(_) => return None,
        })
    }

    /// The wavelength grid the config asks for, or the default 400-700 nm every 10 nm.
    pub fn grid(&self) -> WavelengthGrid {
        let g = match self {
            SceneConfig::Uniform(c) => c.wavelengths,
            SceneConfig::Macbeth(c) => c.wavelengths,
            SceneConfig::SlantedEdge(c) => c.wavelengths,
            SceneConfig::File(c) => c.wavelengths,
            SceneConfig::Rgb(c) => c.wavelengths,
            SceneConfig::Harmonic(c) => c.wavelengths,
            SceneConfig::ZonePlate(c) => c.wavelengths,
            SceneConfig::SweepFrequency(c) => c.wavelengths,
            SceneConfig::Star(c) => c.wavelengths,
            SceneConfig::Checkerboard(c) => c.wavelengths,
            SceneConfig::GridLines(c) => c.wavelengths,
            SceneConfig::PointArray(c) => c.wavelengths,
            SceneConfig::Ramp(c) => c.wavelengths,
            SceneConfig::DeadLeaves(c) => c.wavelengths,
            SceneConfig::GlareTarget(c) => c.wavelengths,
            SceneConfig::HdrChart(c) => c.wavelengths,
            SceneConfig::HdrLights(c) => c.wavelengths,
        };
        g.unwrap_or_default()
    }

    /// Make relative file paths in the config (illuminant and reflectance files, the radiance
    /// file) relative to `base_dir` (the folder of the config file). Built-in names are untouched.
    pub fn resolve_paths(&mut self, base_dir: &Path) {
        let fix_string = |s: &mut String| {
            if crate::looks_like_file(s) && Path::new(s.as_str()).is_relative() {
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
            SceneConfig::Macbeth(c) => {
                fix_string(&mut c.illuminant);
                if let Some(r) = &mut c.reflectances {
                    fix_string(r);
                }
            }
            SceneConfig::SlantedEdge(c) => fix_string(&mut c.illuminant),
            SceneConfig::File(c) => {
                if c.path.is_relative() {
                    c.path = base_dir.join(&c.path);
                }
            }
            SceneConfig::Rgb(c) => {
                if c.path.is_relative() {
                    c.path = base_dir.join(&c.path);
                }
                fix_string(&mut c.display);
            }
            SceneConfig::Harmonic(c) => fix_string(&mut c.illuminant),
            SceneConfig::ZonePlate(c) => fix_string(&mut c.illuminant),
            SceneConfig::SweepFrequency(c) => fix_string(&mut c.illuminant),
            SceneConfig::Star(c) => fix_string(&mut c.illuminant),
            SceneConfig::Checkerboard(c) => fix_string(&mut c.illuminant),
            SceneConfig::GridLines(c) => fix_string(&mut c.illuminant),
            SceneConfig::PointArray(c) => fix_string(&mut c.illuminant),
            SceneConfig::Ramp(c) => fix_string(&mut c.illuminant),
            SceneConfig::DeadLeaves(c) => fix_string(&mut c.illuminant),
            SceneConfig::GlareTarget(c) => fix_string(&mut c.illuminant),
            SceneConfig::HdrChart(c) => fix_string(&mut c.illuminant),
            SceneConfig::HdrLights(c) => fix_string(&mut c.illuminant),
        }
    }
}

/// Find where a scene table in TOML `text` is wrong, with the offending key's line and column.
///
/// `SceneConfig` is tagged by `kind`, and serde reads a tagged table into a buffer first, which
/// loses the positions: toml then reports an unknown key or a value of the wrong type at the
/// table's header (line 1 for a scene file). This reads the table a second time straight into
/// the struct of its `kind` (skipping the `kind` key), so toml can point at the key itself.
/// `table` is the scene table's key in `text` (`Some("scene")` in a simulate config, `None` for a
/// scene file). Returns toml's message ("TOML parse error at line L, column C ..."), or None when
/// that table has no such error (or no valid `kind`: the first pass's message is then right).
pub fn locate_scene_error(text: &str, table: Option<&str>) -> Option<String> {
    let doc: toml::Table = toml::from_str(text).ok()?;
    let t = match table {
        None => &doc,
        Some(k) => doc.get(k)?.as_table()?,
    };
    let kind = t.get("kind")?.as_str()?;
    fn run<T: serde::de::DeserializeOwned>(text: &str, table: Option<&str>) -> Option<String> {
        let r = match table {
            None => toml::from_str::<diag::KindStripped<T>>(text).map(|_| ()),
            Some(k) => toml::from_str::<diag::InTable<T>>(text).map(|w| {
                debug_assert!(w.key == k);
            }),
        };
        r.err().map(|e| e.to_string())
    }
    match (kind, table) {
        ("uniform", t) => run::<UniformScene>(text, t),
        ("macbeth", t) => run::<MacbethScene>(text, t),
        ("slanted_edge", t) => run::<SlantedEdgeScene>(text, t),
        ("file", t) => run::<FileScene>(text, t),
        ("rgb", t) => run::<RgbScene>(text, t),
        ("dead_leaves", t) => run::<DeadLeavesScene>(text, t),
        ("glare_target", t) => run::<GlareTargetScene>(text, t),
        ("hdr_chart", t) => run::<HdrChartScene>(text, t),
        ("hdr_lights", t) => run::<HdrLightsScene>(text, t),
        ("harmonic", t) => run::<HarmonicScene>(text, t),
        ("zone_plate", t) => run::<ZonePlateScene>(text, t),
        ("sweep_frequency", t) => run::<SweepFrequencyScene>(text, t),
        ("star", t) => run::<StarScene>(text, t),
        ("checkerboard", t) => run::<CheckerboardScene>(text, t),
        ("grid_lines", t) => run::<GridLinesScene>(text, t),
        ("point_array", t) => run::<PointArrayScene>(text, t),
        ("ramp", t) => run::<RampScene>(text, t),
        (k, _) if SCENE_KINDS.entry(k).is_none() => Some(SCENE_KINDS.unknown(k).to_string()),
        _ => None,
    }
}

/// Deserializers for [`locate_scene_error`]: read a table into `T` with its `kind` key skipped,
/// straight from toml's map (so errors keep the key's position).
mod diag {
    use serde::de::{
        self, DeserializeSeed, Deserializer, IgnoredAny, IntoDeserializer, MapAccess, Visitor,
    };
    use serde::Deserialize;
    use std::marker::PhantomData;

    /// `T` read from a table whose `kind` key is skipped.
    pub struct KindStripped<T>(#[allow(dead_code)] pub T);

    impl<'de, T: Deserialize<'de>> Deserialize<'de> for KindStripped<T> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V<T>(PhantomData<T>);
            impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
                type Value = T;
                fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                    f.write_str("a scene table")
                }
                fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
                    T::deserialize(de::value::MapAccessDeserializer::new(SkipKind(map)))
                }
            }
            d.deserialize_map(V(PhantomData)).map(KindStripped)
        }
    }

    /// The scene table under one key of the document (`[scene]`); other keys are ignored.
    pub struct InTable<T> {
        pub key: String,
        #[allow(dead_code)]
        pub value: T,
    }

    impl<'de, T: Deserialize<'de>> Deserialize<'de> for InTable<T> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V<T>(PhantomData<T>);
            impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
                type Value = InTable<T>;
                fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                    f.write_str("a config with a scene table")
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<InTable<T>, A::Error> {
                    let mut found = None;
                    while let Some(k) = map.next_key::<String>()? {
                        if k == "scene" && found.is_none() {
                            let v: KindStripped<T> = map.next_value()?;
                            found = Some(InTable { key: k, value: v.0 });
                        } else {
                            map.next_value::<IgnoredAny>()?;
                        }
                    }
                    found.ok_or_else(|| de::Error::missing_field("scene"))
                }
            }
            d.deserialize_map(V(PhantomData))
        }
    }

    struct SkipKind<A>(A);

    impl<'de, A: MapAccess<'de>> MapAccess<'de> for SkipKind<A> {
        type Error = A::Error;
        fn next_key_seed<K: DeserializeSeed<'de>>(
            &mut self,
            seed: K,
        ) -> Result<Option<K::Value>, A::Error> {
            let mut seed = seed;
            loop {
                match self.0.next_key_seed(KeySeed(seed))? {
                    None => return Ok(None),
                    Some(Ok(v)) => return Ok(Some(v)),
                    Some(Err(back)) => {
                        self.0.next_value::<IgnoredAny>()?;
                        seed = back;
                    }
                }
            }
        }
        fn next_value_seed<S: DeserializeSeed<'de>>(
            &mut self,
            seed: S,
        ) -> Result<S::Value, A::Error> {
            self.0.next_value_seed(seed)
        }
    }

    /// A key seed that hands its inner seed back for the key `kind`.
    struct KeySeed<K>(K);

    impl<'de, K: DeserializeSeed<'de>> DeserializeSeed<'de> for KeySeed<K> {
        type Value = Result<K::Value, K>;
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
            let key = String::deserialize(d)?;
            if key == "kind" {
                return Ok(Err(self.0));
            }
            self.0
                .deserialize(IntoDeserializer::<D::Error>::into_deserializer(key))
                .map(Ok)
        }
    }
}

#[cfg(test)]
mod error_position_tests {
    use super::*;

    /// The line and column toml reports, parsed from its message.
    fn line_col(msg: &str) -> (usize, usize) {
        let i = msg
            .find("line ")
            .unwrap_or_else(|| panic!("no line in: {msg}"));
        let rest = &msg[i + 5..];
        let line: usize = rest.split(',').next().unwrap().trim().parse().unwrap();
        let j = rest.find("column ").unwrap();
        let col: usize = rest[j + 7..]
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap();
        (line, col)
    }

    #[test]
    fn wrong_type_and_unknown_key_point_at_the_key_itself() {
        // Line 4, column 17 is where "big" starts.
        let text = "kind = \"macbeth\"\nfov_deg = 2.0\nborder_px = 2\npatch_size_px = \"big\"\n";
        let e = SceneConfig::from_toml(text, "chart.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("chart.toml"), "{e}");
        assert_eq!(line_col(&e), (4, 17), "{e}");
        // An unknown key on line 3, column 1.
        let text = "fov_deg = 2.0\nkind = \"uniform\"\nreflectanse = 0.5\n";
        let e = SceneConfig::from_toml(text, "u.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("reflectanse"), "{e}");
        assert_eq!(line_col(&e), (3, 1), "{e}");
        // Inside a simulate config's [scene] table (kind after the bad key).
        let text =
            "seed = 3\n[sensor]\nrows = 4\n[scene]\npatch_size_px = -1\nkind = \"macbeth\"\n";
        let msg = locate_scene_error(text, Some("scene")).unwrap();
        assert_eq!(line_col(&msg), (5, 17), "{msg}");
        // No error in the scene table: nothing to report.
        assert_eq!(
            locate_scene_error("[scene]\nkind = \"macbeth\"\n", Some("scene")),
            None
        );
        assert!(SceneConfig::from_toml("kind = \"macbeth\"\npatch_size_px = 8\n", "ok").is_ok());
    }

    #[test]
    fn the_scene_kind_table_is_the_config_enum() {
        assert_eq!(SCENE_KINDS.entries.len(), 17);
        for e in SCENE_KINDS.entries {
            let text = format!("kind = \"{}\"", e.name);
            match SceneConfig::from_toml(&text, "t") {
                Ok(c) => assert_eq!(c.kind(), e.name),
                // Kinds that need a file say so, never that the kind is unknown.
                Err(err) => {
                    let m = err.to_string();
                    assert!(
                        !m.contains("unknown variant") && !m.contains("unknown scene kind"),
                        "{}: {m}",
                        e.name
                    );
                }
            }
        }
        // The case rule of the table: `Slanted-Edge` is `slanted_edge`; an unknown kind lists them.
        assert_eq!(
            SCENE_KINDS.canonical("Slanted-Edge").unwrap(),
            "slanted_edge"
        );
        let m = locate_scene_error("kind = \"zone-plates\"\n", None).unwrap();
        assert!(
            m.contains("unknown scene kind 'zone-plates'; known: uniform, macbeth"),
            "{m}"
        );
    }
}
