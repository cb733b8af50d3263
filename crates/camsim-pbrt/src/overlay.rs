//! Scene control as ISET3d does it: a TOML overlay applied to a [`SceneDescription`] (from a
//! pbrt-v4 file or a built-in scene) that moves, removes or replaces objects, sets surface
//! reflectances and the light's spectrum and level, and changes the camera and render settings.
//!
//! ```toml
//! [camera]                       # all optional
//! position_m = [0.278, 0.274, -0.6]
//! look_at_m = [0.278, 0.274, 0.5]
//! up = [0.0, 1.0, 0.0]
//! fov_deg = 40.0                 # across the shorter image axis (pbrt-v4 "fov")
//! resolution = [640, 480]
//! focus_distance_m = 1.1
//! velocity_m_s = [0.5, 0.0, 0.0] # motion during the exposure (`overlay/motion.rs`):
//! angular_velocity_deg_s = [0.0, 30.0, 0.0]   # about the camera's x (pitch), y (yaw), z (roll)
//! trajectory = "path.csv"        # time_s, x_m, y_m, z_m + look_x_m.. or qw, qx, qy, qz
//! shake = { rms_deg_s = 2.0, seed = 1, step_ms = 1.0 }  # hand shake: random walk of rotation
//!
//! [render]                       # all optional
//! samples_per_pixel = 256
//! max_depth = 8
//! seed = 7
//! wavelengths_per_path = 4
//! sampler = "sobol"              # or "independent" (also "paddedsobol", "zsobol")
//! light_sampler = "bvh"          # or "power", "uniform" (overrides the file's lightsampler)
//! russian_roulette_depth = 5     # first bounce with Russian roulette
//! time_budget_s = 60.0
//! grid = { start_nm = 400.0, end_nm = 700.0, step_nm = 10.0 }
//! medium = { sigma_a_per_m = 0.01, sigma_s_per_m = 0.5, g = 0.3 }  # fill with fog (1/m)
//!
//! [[material]]                   # set (or create) a material's reflectance
//! name = "red"                   # a named material; `*` matches any run of characters
//! reflectance = { file = "../shared/data/isetcornellbox/cboxWalls.csv", column = "red" }
//!
//! [[object]]                     # one entry per change, applied in order
//! name = "short_block"           # shape name; `*` wildcards ("mcc_*" moves the whole chart)
//! scale = 1.0                    # number or [sx, sy, sz], about the pivot
//! rotate = { angle_deg = 15.0, axis = [0.0, 1.0, 0.0] }   # about the pivot
//! translate_m = [0.05, 0.0, 0.0]
//! pivot_m = [0.19, 0.0, 0.17]    # default: centre of the matched objects' bounding box
//! material = "white"             # assign a named material
//! velocity_m_s = [0.1, 0.0, 0.0] # moving during the exposure, m/s (from where t = 0 puts it)
//! angular_velocity_deg_s = [0.0, 90.0, 0.0]   # spinning about pivot_m, world axes, deg/s
//! # remove = true                # delete the objects
//! # replace = { file = "teapot.ply", material = "white", align = "bottom" }
//! # category = "teapot"          # semantic category in the labels and COCO
//!
//! [[object]]                     # a new object from a file (glTF, GLB, OBJ, PLY, pbrt-v4)
//! name = "duck"                  # the new instance's name
//! add = { file = "Duck.glb", at_m = [0.2, 0.0, 0.2] }   # bottom centre of its box at at_m
//! category = "duck"
//! scale = 0.1                    # transforms apply to the added object
//!
//! [[light_group]]                # lights whose radiance `simulate` can weigh as a group
//! name = "sky"
//! lights = ["infinite"]          # kinds of non-shape lights (infinite, distant, point, ...; *)
//! objects = ["sun_disk"]         # area lights by shape name (wildcards)
//!
//! [light]                        # area lights (and, without `name`, infinite lights)
//! name = "light"                 # optional filter
//! spectrum = { file = "../shared/data/isetcornellbox/cboxIlluminant.csv", column = "spd" }
//! luminance_cd_m2 = 1200.0       # or radiance_scale = 2.0
//! ```
//!
//! Spectra (`reflectance`, `spectrum`) are one of: a number (a constant); a table name --
//! `macbeth:N` or `macbeth:NAME` (Ohta 1997 ColorChecker reflectances), `cornell:white|red|green`
//! (Cornell data page), a CIE illuminant name `D65`, `A`, `C`, `F2`, `F11`, `E`, or
//! `blackbody-K` (for lights); `{ blackbody_k = 3000.0 }`; or `{ file = "...", column = "name" }`
//! for a CSV or ISETCam MATLAB v5 `.mat` file read by [`camsim_core::spectrum_csv::load_spectra`]
//! (`column` is a column name or a 1-based index; it may be left out when the file has one
//! spectrum). Relative file paths resolve against `base_dir` (the CLI passes the overlay file's
//! folder). A spectrum read from a file is zero outside the file's wavelengths (pbrt-v4
//! `PiecewiseLinearSpectrum`); numbers are constant at every wavelength.
//!
//! Order of application: `[camera]`, `[render]`, `[[material]]`, `[[object]]`, `[light]`,
//! `[[light_group]]`.
//! Object transforms apply scale, then rotation, then translation, about the pivot. Camera:
//! setting `position_m`/`look_at_m` keeps the scene's image handedness (a right-handed view stays
//! right-handed). Light: a new `spectrum` keeps the light's previous luminance unless
//! `luminance_cd_m2` is given; `radiance_scale` multiplies last.

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

use crate::builtin::{cornell_reflectance, spectrum_at_luminance};
use crate::scene::{Geometry, Light, Material, SceneDescription, Shape, Texture, Transform};
use crate::spectra::photometric;
use crate::xform::{self, det3, shape_bounds};
use camsim_core::spectrum::Extrapolation;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::{tables, Spectrum, WavelengthGrid};
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod medium;
mod motion;
pub use medium::MediumOverlay;
pub use motion::ShakeSpec;

/// An overlay error: the overlay's name and what is wrong (with the TOML position or the key).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: {message}")]
pub struct OverlayError {
    pub source_name: String,
    pub message: String,
}

/// The overlay file.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Overlay {
    /// Camera changes.
    pub camera: Option<CameraOverlay>,
    /// Render settings.
    pub render: Option<RenderOverlay>,
    /// Material reflectances, in order.
    #[serde(default)]
    pub material: Vec<MaterialOverlay>,
    /// Object changes, in order.
    #[serde(default)]
    pub object: Vec<ObjectOverlay>,
    /// Light spectrum and level: one `[light]` table, or `[[light]]` tables applied in order
    /// (each with its `name` filter: street lamps one spectrum, headlamps another).
    pub light: Option<LightOverlays>,
    /// Light groups (`camsim simulate`'s `[render] light_groups` weighs them), in order.
    #[serde(default)]
    pub light_group: Vec<LightGroupOverlay>,
}

/// `[[light_group]]`: put lights in a named group.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LightGroupOverlay {
    /// The group's name.
    pub name: String,
    /// The area lights of these shapes (names, wildcards `*`).
    #[serde(default)]
    pub objects: Vec<String>,
    /// Lights that are not shapes, by kind: `infinite` (uniform and image), `distant`, `point`,
    /// `spot`, `goniometric`, `projection`, or `*` for all of them.
    #[serde(default)]
    pub lights: Vec<String>,
}

/// `[camera]`.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraOverlay {
    /// Eye position, m (needs `look_at_m`).
    pub position_m: Option<[f64; 3]>,
    /// Point looked at, m.
    pub look_at_m: Option<[f64; 3]>,
    /// Up direction (dimensionless); default +y.
    pub up: Option<[f64; 3]>,
    /// Field of view across the shorter image axis, degrees.
    pub fov_deg: Option<f64>,
    /// Image size [width, height], pixels.
    pub resolution: Option<[usize; 2]>,
    /// Focus distance for the optics stage, m.
    pub focus_distance_m: Option<f64>,
    /// Velocity during the exposure, world frame, m/s.
    pub velocity_m_s: Option<[f64; 3]>,
    /// Angular velocity about the camera's own x, y, z axes (pitch, yaw, roll), deg/s.
    pub angular_velocity_deg_s: Option<[f64; 3]>,
    /// A CSV of poses over time (`motion::read_trajectory`), relative to the
    /// overlay.
    pub trajectory: Option<String>,
    /// Hand shake: a random walk of the camera's orientation.
    pub shake: Option<motion::ShakeSpec>,
}

/// `[render]`.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RenderOverlay {
    /// Samples per pixel.
    pub samples_per_pixel: Option<u32>,
    /// Maximum path depth (bounces).
    pub max_depth: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
    /// Wavelengths traced per path.
    pub wavelengths_per_path: Option<usize>,
    /// Sampler name (`SamplerKind::from_name`).
    pub sampler: Option<String>,
    /// How next-event estimation chooses a light: "bvh" (by importance at each point,
    /// pbrt-v4's default), "power" (by emitted power) or "uniform"; overrides the pbrt-v4
    /// file's `Integrator` `lightsampler`.
    pub light_sampler: Option<String>,
    /// First scattering vertex where Russian roulette may end a path.
    pub russian_roulette_depth: Option<u32>,
    /// Stop after this many seconds, s.
    pub time_budget_s: Option<f64>,
    /// Output wavelength grid, nm.
    pub grid: Option<GridOverlay>,
    /// Fill the scene with one homogeneous participating medium (the camera's medium; see
    /// [`MediumOverlay`]).
    pub medium: Option<MediumOverlay>,
}

/// A wavelength grid, nm.
#[derive(Debug, Clone, Copy, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GridOverlay {
    /// First wavelength, nm.
    pub start_nm: f64,
    /// Last wavelength, nm.
    pub end_nm: f64,
    /// Spacing, nm.
    pub step_nm: f64,
}

/// A spectrum given in an overlay (see the module docs).
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum SpectrumSpec {
    /// The same value at every wavelength.
    Constant(f64),
    /// A table name (`macbeth:13`, `cornell:red`, `D65`, `blackbody-3000`).
    Name(String),
    /// A blackbody of this temperature, K.
    Blackbody(BlackbodySpec),
    /// A column of a CSV or ISETCam `.mat` file.
    File(FileSpec),
}

/// `{ blackbody_k = T }`.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BlackbodySpec {
    /// Temperature, K.
    pub blackbody_k: f64,
}

/// `{ file = "...", column = ... }`.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FileSpec {
    /// CSV or ISETCam `.mat` file, relative to `base_dir`.
    pub file: String,
    /// Column name or 1-based index; optional for one-spectrum files.
    pub column: Option<ColumnSpec>,
}

/// A column by name or 1-based index.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum ColumnSpec {
    Index(usize),
    Name(String),
}

/// `[[material]]`.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MaterialOverlay {
    /// Named material (wildcards `*`); a plain name that does not exist is created.
    pub name: String,
    /// Diffuse reflectance (fraction).
    pub reflectance: SpectrumSpec,
}

/// `[[object]]`.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectOverlay {
    /// Shape name (wildcards `*`).
    pub name: String,
    /// Delete the objects.
    #[serde(default)]
    pub remove: bool,
    /// Replace the objects with a file's shapes.
    pub replace: Option<ReplaceSpec>,
    /// Add a new object (named `name`) from a file; the transform keys then move it.
    pub add: Option<AddSpec>,
    /// Semantic category of the objects (the added or replaced ones), for labels and COCO
    /// (`camsim dataset --coco-categories category`).
    pub category: Option<String>,
    /// Scale about the pivot: a number or [sx, sy, sz].
    pub scale: Option<ScaleSpec>,
    /// Rotation about the pivot.
    pub rotate: Option<RotateSpec>,
    /// Translation, m.
    pub translate_m: Option<[f64; 3]>,
    /// Pivot, m; default: centre of the matched objects' bounding box.
    pub pivot_m: Option<[f64; 3]>,
    /// Assign this named material.
    pub material: Option<String>,
    /// Velocity during the exposure, world frame, m/s (from the pose at t = 0).
    pub velocity_m_s: Option<[f64; 3]>,
    /// Angular velocity about the pivot, world axes (the axis scaled by the rate), deg/s.
    pub angular_velocity_deg_s: Option<[f64; 3]>,
}

/// Uniform or per-axis scale.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum ScaleSpec {
    Uniform(f64),
    Axes([f64; 3]),
}

/// A rotation.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RotateSpec {
    /// Angle, degrees (right-hand rule about `axis`).
    pub angle_deg: f64,
    /// Axis (dimensionless).
    pub axis: [f64; 3],
}

/// A new object from a file.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AddSpec {
    /// A glTF 2.0 / GLB or OBJ asset (read in glTF's physical units: its meshes, materials and
    /// emitters; its cameras and punctual lights are left out), a pbrt-v4 scene or a PLY mesh
    /// (m), relative to the overlay. The whole file becomes one object instance.
    pub file: String,
    /// Named material for all its shapes (default: the file's own; a PLY is grey diffuse).
    pub material: Option<String>,
    /// Put the bottom centre of its bounding box here, m (default: the file's own coordinates);
    /// the transform keys then scale and turn it about that point (`pivot_m` by default), so
    /// it stays on the floor or table it was put on.
    pub at_m: Option<[f64; 3]>,
}

/// What replaces an object.
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ReplaceSpec {
    /// A glTF 2.0 / GLB or OBJ asset, a pbrt-v4 scene (its world's shapes, materials and area
    /// lights) or a PLY mesh (m).
    pub file: String,
    /// Named material for the new shapes (default: the PLY gets the replaced object's material;
    /// a pbrt file keeps its own).
    pub material: Option<String>,
    /// `bottom` (default: bounding-box bottom centres coincide), `center`, or `none`.
    pub align: Option<String>,
}

/// `[light]`.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LightOverlay {
    /// Area-light shape name filter (wildcards); without it every emitter changes.
    pub name: Option<String>,
    /// Relative spectral shape of the emission.
    pub spectrum: Option<SpectrumSpec>,
    /// Luminance, cd/m^2 (683 lm/W * integral y_bar L dl).
    pub luminance_cd_m2: Option<f64>,
    /// Multiply the radiance by this (dimensionless).
    pub radiance_scale: Option<f64>,
}

/// `[light]` (one table) or `[[light]]` (several, applied in order).
#[derive(Debug, Clone, schemars::JsonSchema)]
#[serde(untagged)]
pub enum LightOverlays {
    One(LightOverlay),
    Many(Vec<LightOverlay>),
}

// By hand rather than `untagged`, so a bad key inside either form keeps its own message.
impl<'de> Deserialize<'de> for LightOverlays {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = LightOverlays;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a [light] table or [[light]] tables")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                a: A,
            ) -> Result<Self::Value, A::Error> {
                LightOverlay::deserialize(serde::de::value::MapAccessDeserializer::new(a))
                    .map(LightOverlays::One)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                a: A,
            ) -> Result<Self::Value, A::Error> {
                Vec::<LightOverlay>::deserialize(serde::de::value::SeqAccessDeserializer::new(a))
                    .map(LightOverlays::Many)
            }
        }
        d.deserialize_any(V)
    }
}

impl LightOverlays {
    /// The tables in the order they apply.
    pub fn list(&self) -> &[LightOverlay] {
        match self {
            LightOverlays::One(l) => std::slice::from_ref(l),
            LightOverlays::Many(v) => v,
        }
    }
}

/// `*`-wildcard match.
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let mut rest = name;
    for (i, p) in parts.iter().enumerate() {
        if i == 0 {
            match rest.strip_prefix(p) {
                Some(r) => rest = r,
                None => return false,
            }
        } else if i == parts.len() - 1 {
            return rest.ends_with(p);
        } else {
            match rest.find(p) {
                Some(k) => rest = &rest[k + p.len()..],
                None => return false,
            }
        }
    }
    true
}

/// Resolve a spectrum spec; `what` names it in errors.
pub fn resolve_spectrum(
    spec: &SpectrumSpec,
    base_dir: &Path,
    what: &str,
) -> Result<Spectrum, String> {
    match spec {
        SpectrumSpec::Constant(v) => {
            if !v.is_finite() || *v < 0.0 {
                return Err(format!("{what}: {v} must be a non-negative number"));
            }
            Ok(Spectrum::from_pairs(&[(300.0, *v), (1100.0, *v)])
                .with_extrapolation(Extrapolation::Hold))
        }
        SpectrumSpec::Blackbody(b) => tables::illuminant(&format!("blackbody-{}", b.blackbody_k))
            .map_err(|e| format!("{what}: {e}")),
        SpectrumSpec::Name(n) => {
            if let Some(p) = n.strip_prefix("macbeth:") {
                tables::macbeth_patch(p).map_err(|e| format!("{what}: {e}"))
            } else if let Some(p) = n.strip_prefix("cornell:") {
                cornell_reflectance(p).map_err(|e| format!("{what}: {e}"))
            } else {
                tables::illuminant(n).map_err(|e| {
                    format!("{what}: \"{n}\" is not a table name (macbeth:N, cornell:white|red|green, or an illuminant: {e})")
                })
            }
        }
        SpectrumSpec::File(f) => {
            let path = resolve_path(base_dir, &f.file);
            let table = camsim_core::spectrum_csv::load_spectra(&path)
                .map_err(|e| format!("{what}: {e}"))?;
            let s = match &f.column {
                None => {
                    if table.len() != 1 {
                        return Err(format!(
                            "{what}: {} has {} spectra ({}); say which with column = \"name\" or a 1-based index",
                            path.display(),
                            table.len(),
                            table.names.join(", ")
                        ));
                    }
                    table.spectrum_at(0)
                }
                Some(ColumnSpec::Name(n)) => table.spectrum(n),
                Some(ColumnSpec::Index(i)) => {
                    if *i == 0 || *i > table.len() {
                        return Err(format!("{what}: column {i} is not in 1..{}", table.len()));
                    }
                    table.spectrum_at(i - 1)
                }
            }
            .map_err(|e| format!("{what}: {e}"))?;
            s.require_non_negative(what).map_err(|e| e.to_string())?;
            // Zero outside the file's data, as pbrt-v4 and every other measured spectrum here.
            Ok(s)
        }
    }
}

fn resolve_path(base: &Path, f: &str) -> PathBuf {
    let p = Path::new(f);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// Reads an object file of a format this crate does not read (glTF, OBJ: `camsim-assets`, its
/// sibling) for `[[object]] add` and `replace`: `None` when the file is not of its formats (the
/// pbrt-v4 and PLY readers take it then), else the file as a scene or an error message. It is
/// asked first, for every file, so a caller may also serve PLY and pbrt-v4 files it has read
/// before (`camsim-compose`'s asset cache).
pub type ObjectReader<'a> = &'a dyn Fn(&Path) -> Option<Result<SceneDescription, String>>;

/// Parse and apply an overlay. `source_name` names it in errors; relative paths resolve against
/// `base_dir`. Object files are pbrt-v4 or PLY ([`apply_with`] takes other readers).
pub fn apply(
    scene: &mut SceneDescription,
    overlay_toml: &str,
    source_name: &str,
    base_dir: &Path,
) -> Result<(), OverlayError> {
    apply_with(scene, overlay_toml, source_name, base_dir, &|_| None)
}

/// [`apply`] with `reader` for object files of other formats (glTF, OBJ).
pub fn apply_with(
    scene: &mut SceneDescription,
    overlay_toml: &str,
    source_name: &str,
    base_dir: &Path,
    reader: ObjectReader<'_>,
) -> Result<(), OverlayError> {
    if overlay_toml.trim().is_empty() {
        return Err(OverlayError {
            source_name: source_name.to_string(),
            message: "the overlay is empty: it would change nothing".to_string(),
        });
    }
    let ov: Overlay = toml::from_str(overlay_toml).map_err(|e| OverlayError {
        source_name: source_name.to_string(),
        message: e.to_string().trim_end().to_string(),
    })?;
    apply_overlay_with(scene, &ov, base_dir, reader).map_err(|message| OverlayError {
        source_name: source_name.to_string(),
        message,
    })
}

/// Apply an already-parsed overlay; errors name the key.
pub fn apply_overlay(
    scene: &mut SceneDescription,
    ov: &Overlay,
    base_dir: &Path,
) -> Result<(), String> {
    apply_overlay_with(scene, ov, base_dir, &|_| None)
}

/// [`apply_overlay`] with `reader` for object files of other formats (glTF, OBJ).
pub fn apply_overlay_with(
    scene: &mut SceneDescription,
    ov: &Overlay,
    base_dir: &Path,
    reader: ObjectReader<'_>,
) -> Result<(), String> {
    if let Some(c) = &ov.camera {
        apply_camera(scene, c)?;
        motion::apply_camera_motion(scene, c, base_dir)?;
    }
    if let Some(r) = &ov.render {
        let s = &mut scene.settings;
        if let Some(v) = r.samples_per_pixel {
            if v == 0 {
                return Err("render.samples_per_pixel must be at least 1".into());
            }
            s.samples_per_pixel = v;
        }
        if let Some(v) = r.max_depth {
            s.max_depth = v;
        }
        if let Some(v) = r.seed {
            s.seed = v;
        }
        if let Some(v) = r.wavelengths_per_path {
            if v == 0 || v > 64 {
                return Err(format!("render.wavelengths_per_path {v} must be 1-64"));
            }
            s.wavelengths_per_path = v;
        }
        if let Some(v) = &r.sampler {
            s.sampler = crate::scene::SamplerKind::from_name(v).ok_or_else(|| {
                format!("render.sampler \"{v}\" is unknown: use \"sobol\", \"paddedsobol\", \"zsobol\" or \"independent\"")
            })?;
        }
        if let Some(v) = &r.light_sampler {
            s.light_sampler = crate::scene::LightSampler::from_name(v).ok_or_else(|| {
                format!("render.light_sampler \"{v}\" is unknown: use \"bvh\", \"power\" or \"uniform\"")
            })?;
        }
        if let Some(v) = r.russian_roulette_depth {
            if v == 0 {
                return Err("render.russian_roulette_depth must be at least 1".into());
            }
            s.russian_roulette_depth = v;
        }
        if let Some(v) = r.time_budget_s {
            if !(v > 0.0) {
                return Err(format!("render.time_budget_s {v} must be positive"));
            }
            s.time_budget_s = Some(v);
        }
        if let Some(g) = r.grid {
            s.grid = WavelengthGrid::new(g.start_nm, g.end_nm, g.step_nm)
                .map_err(|e| format!("render.grid: {e}"))?;
        }
        if let Some(m) = &r.medium {
            medium::fill(scene, m, base_dir)?;
        }
    }
    for (i, m) in ov.material.iter().enumerate() {
        let what = format!("material[{i}] \"{}\" reflectance", m.name);
        let s = resolve_spectrum(&m.reflectance, base_dir, &what)?;
        if s.values.iter().any(|v| *v > 1.0 + 1e-9) {
            scene.notes.push(format!(
                "{what}: values above 1 (max {:.3}); a reflectance above 1 adds energy",
                s.max_value()
            ));
        }
        let mut names: Vec<(String, usize)> = scene
            .named_materials
            .iter()
            .filter(|(k, _)| glob_match(&m.name, k))
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        names.sort();
        if names.is_empty() {
            if m.name.contains('*') {
                return Err(format!("material[{i}]: no material matches \"{}\"", m.name));
            }
            scene.materials.push(Material::Diffuse {
                reflectance: Texture::Constant(s),
            });
            scene
                .named_materials
                .insert(m.name.clone(), scene.materials.len() - 1);
            continue;
        }
        for (_, idx) in names {
            scene.materials[idx] = Material::Diffuse {
                reflectance: Texture::Constant(s.clone()),
            };
        }
    }
    for (i, o) in ov.object.iter().enumerate() {
        apply_object(scene, o, i, base_dir, reader)?;
    }
    for l in ov.light.iter().flat_map(|l| l.list()) {
        apply_light(scene, l, base_dir)?;
    }
    for (i, g) in ov.light_group.iter().enumerate() {
        apply_light_group(scene, g, i)?;
    }
    Ok(())
}

/// The kind name of a light that is not a shape, as `[[light_group]] lights` names it.
fn light_kind(l: &Light) -> &'static str {
    match l {
        Light::Infinite { .. } | Light::Environment(_) => "infinite",
        Light::Point { .. } => "point",
        Light::Spot { .. } => "spot",
        Light::Distant { .. } => "distant",
        Light::Goniometric(_) => "goniometric",
        Light::Projection(_) => "projection",
    }
}

fn apply_light_group(
    scene: &mut SceneDescription,
    g: &LightGroupOverlay,
    i: usize,
) -> Result<(), String> {
    let key = format!("light_group[{i}] (\"{}\")", g.name);
    if g.name.trim().is_empty() {
        return Err(format!("{key}: name is empty"));
    }
    if g.objects.is_empty() && g.lights.is_empty() {
        return Err(format!(
            "{key}: give objects (area-light shape names) or lights (kinds)"
        ));
    }
    for pat in &g.objects {
        let mut n = 0;
        for s in scene.shapes.iter_mut() {
            if s.area_light.is_some() && s.name.as_deref().is_some_and(|nm| glob_match(pat, nm)) {
                s.tags.light_group = Some(g.name.clone());
                n += 1;
            }
        }
        if n == 0 {
            return Err(format!("{key}: no area light on a shape named {pat:?}"));
        }
    }
    const KINDS: [&str; 6] = [
        "infinite",
        "distant",
        "point",
        "spot",
        "goniometric",
        "projection",
    ];
    for kind in &g.lights {
        if kind != "*" && !KINDS.contains(&kind.as_str()) {
            return Err(format!(
                "{key}: lights kind {kind:?} is unknown (one of {}, or *)",
                KINDS.join(", ")
            ));
        }
        scene.light_groups.resize(scene.lights.len(), None);
        let mut n = 0;
        for (l, grp) in scene.lights.iter().zip(scene.light_groups.iter_mut()) {
            if kind == "*" || light_kind(l) == kind {
                *grp = Some(g.name.clone());
                n += 1;
            }
        }
        if n == 0 {
            return Err(format!("{key}: the scene has no {kind} light"));
        }
    }
    Ok(())
}

fn apply_camera(scene: &mut SceneDescription, c: &CameraOverlay) -> Result<(), String> {
    let cam = &mut scene.camera;
    match (c.position_m, c.look_at_m) {
        (Some(p), Some(l)) => {
            let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
            let right_handed = det3(&cam.camera_to_world) < 0.0;
            cam.camera_to_world = crate::camera::look_at_camera_to_world(p, l, up, right_handed)
                .ok_or_else(|| {
                    "camera: position_m, look_at_m and up are degenerate (up parallel to the view?)"
                        .to_string()
                })?;
            if scene.settings.time.camera.take().is_some() {
                scene.notes.push(
                    "camera: position_m and look_at_m replace the scene's animated camera (it stands still unless the overlay moves it)"
                        .into(),
                );
            }
        }
        (None, None) => {
            if c.up.is_some() {
                return Err("camera.up needs position_m and look_at_m".into());
            }
        }
        _ => return Err("camera: give both position_m and look_at_m".into()),
    }
    if let Some(f) = c.fov_deg {
        if !(f > 0.0 && f < 180.0) {
            return Err(format!("camera.fov_deg {f} must be in (0, 180)"));
        }
        cam.fov_deg = f;
    }
    if let Some([w, h]) = c.resolution {
        if w == 0 || h == 0 || w > 1 << 16 || h > 1 << 16 {
            return Err(format!("camera.resolution {w} x {h} is out of range"));
        }
        cam.width = w;
        cam.height = h;
    }
    if let Some(d) = c.focus_distance_m {
        if !(d > 0.0) {
            return Err(format!("camera.focus_distance_m {d} must be positive"));
        }
        scene.focus_distance_m = Some(d);
    }
    Ok(())
}

pub(crate) fn union_bounds(shapes: &[&Shape]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for s in shapes {
        let (a, b) = shape_bounds(&s.geometry);
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    }
    (lo, hi)
}

/// The shapes of an object file, their materials (and media) appended to `scene`'s with the
/// indices moved: any file `reader` takes (glTF/OBJ; a caller's cache), else PLY as one shape
/// of `ply_material`, else pbrt-v4.
fn file_shapes(
    scene: &mut SceneDescription,
    path: &Path,
    key: &str,
    ply_material: usize,
    reader: ObjectReader<'_>,
) -> Result<Vec<Shape>, String> {
    let read = reader(path);
    if read.is_none()
        && path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("ply"))
    {
        let m = crate::ply::read_ply(path).map_err(|e| format!("{key}: {e}"))?;
        return Ok(vec![Shape {
            name: None,
            geometry: Geometry::mesh(m.positions, m.triangles, m.uvs, m.normals),
            material: ply_material,
            area_light: None,
            reverse_orientation: false,
            tags: Default::default(),
        }]);
    }
    let sub = match read {
        Some(r) => r.map_err(|e| format!("{key}: {e}"))?,
        None => {
            let asset = path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["glb", "gltf", "obj"].contains(&e.to_ascii_lowercase().as_str()));
            if asset {
                return Err(format!(
                    "{key}: {} is a glTF/OBJ asset: reading it needs the asset reader (`overlay::apply_with`, as camsim's pipeline applies overlays)",
                    path.display()
                ));
            }
            crate::parse_file(path).map_err(|e| format!("{key}: {e}"))?
        }
    };
    let offset = scene.materials.len();
    let media_offset = scene.media.list.len();
    scene.media.list.extend(sub.media.list);
    // Material and medium indices inside the inserted scene move with it.
    scene
        .materials
        .extend(sub.materials.into_iter().map(|m| match m {
            Material::Mix { materials, amount } => Material::Mix {
                materials: materials.map(|i| i + offset),
                amount,
            },
            Material::MediumInterface {
                material,
                inside,
                outside,
            } => Material::MediumInterface {
                material: material + offset,
                inside: inside.map(|i| i + media_offset),
                outside: outside.map(|i| i + media_offset),
            },
            Material::AlphaMasked { material, alpha } => Material::AlphaMasked {
                material: material + offset,
                alpha,
            },
            Material::Bumped {
                material,
                perturbation,
            } => Material::Bumped {
                material: material + offset,
                perturbation,
            },
            Material::VaryingRoughness {
                material,
                u,
                v,
                remap,
            } => Material::VaryingRoughness {
                material: material + offset,
                u,
                v,
                remap,
            },
            m => m,
        }));
    for (n, idx) in sub.named_materials {
        scene.named_materials.entry(n).or_insert(idx + offset);
    }
    if !sub.lights.is_empty() {
        scene.notes.push(format!(
            "{key}: the non-shape lights of {} were not inserted",
            path.display()
        ));
    }
    Ok(sub
        .shapes
        .into_iter()
        .map(|mut s| {
            s.material += offset;
            s
        })
        .collect())
}

fn apply_object(
    scene: &mut SceneDescription,
    o: &ObjectOverlay,
    i: usize,
    base_dir: &Path,
    reader: ObjectReader<'_>,
) -> Result<(), String> {
    let key = format!("object[{i}] \"{}\"", o.name);
    if let Some(a) = &o.add {
        if o.remove || o.replace.is_some() {
            return Err(format!(
                "{key}: add cannot be combined with remove or replace"
            ));
        }
        if o.name.contains('*') {
            return Err(format!(
                "{key}: an added object's name cannot have wildcards"
            ));
        }
        let path = resolve_path(base_dir, &a.file);
        let material_override =
            match &a.material {
                Some(m) => Some(*scene.named_materials.get(m).ok_or_else(|| {
                    format!("{key}: add.material \"{m}\" is not a named material")
                })?),
                None => None,
            };
        let grey = match material_override {
            Some(m) => m,
            None => {
                scene.materials.push(Material::Diffuse {
                    reflectance: Texture::Constant(Spectrum::from_pairs(&[
                        (300.0, 0.5),
                        (900.0, 0.5),
                    ])),
                });
                scene.materials.len() - 1
            }
        };
        let mut new_shapes = file_shapes(scene, &path, &key, grey, reader)?;
        if new_shapes.is_empty() {
            return Err(format!("{key}: {} has no shapes", path.display()));
        }
        // One instance for the whole file, after every instance the scene has.
        let next = scene
            .shapes
            .iter()
            .filter_map(|s| s.tags.instance)
            .max()
            .map_or(scene.shapes.len() as u32, |m| {
                m.max(scene.shapes.len() as u32) + 1
            });
        for s in new_shapes.iter_mut() {
            s.name = Some(o.name.clone());
            s.tags.instance = Some(next);
            s.tags.category = o.category.clone();
            if let Some(m) = material_override {
                s.material = m;
            }
        }
        if let Some(at) = a.at_m {
            let (nlo, nhi) = union_bounds(&new_shapes.iter().collect::<Vec<_>>());
            let t = Transform::translate([
                at[0] - (nlo[0] + nhi[0]) / 2.0,
                at[1] - nlo[1],
                at[2] - (nlo[2] + nhi[2]) / 2.0,
            ]);
            for s in new_shapes.iter_mut() {
                xform::transform_shape(s, &t).map_err(|e| format!("{key}: {e}"))?;
            }
        }
        // The transform keys turn and scale it about its bottom centre (it stays on what it
        // stands on).
        let (nlo, nhi) = union_bounds(&new_shapes.iter().collect::<Vec<_>>());
        let bottom = [(nlo[0] + nhi[0]) / 2.0, nlo[1], (nlo[2] + nhi[2]) / 2.0];
        let at = scene.shapes.len();
        let n = new_shapes.len();
        scene.shapes.extend(new_shapes);
        return transform_targets(scene, o, (at..at + n).collect(), &key, Some(bottom));
    }
    let matched: Vec<usize> = (0..scene.shapes.len())
        .filter(|&k| {
            scene.shapes[k]
                .name
                .as_deref()
                .is_some_and(|n| glob_match(&o.name, n))
        })
        .collect();
    if matched.is_empty() {
        let mut names: Vec<&str> = scene
            .shapes
            .iter()
            .filter_map(|s| s.name.as_deref())
            .collect();
        names.dedup();
        return Err(format!(
            "{key}: no object of that name (objects: {})",
            names.join(", ")
        ));
    }
    let refs: Vec<&Shape> = matched.iter().map(|&k| &scene.shapes[k]).collect();
    let (lo, hi) = union_bounds(&refs);
    if o.remove {
        if o.replace.is_some()
            || o.scale.is_some()
            || o.rotate.is_some()
            || o.translate_m.is_some()
            || o.material.is_some()
            || o.velocity_m_s.is_some()
            || o.angular_velocity_deg_s.is_some()
        {
            return Err(format!(
                "{key}: remove = true cannot be combined with other changes"
            ));
        }
        let mut k = 0;
        scene.shapes.retain(|_| {
            let keep = !matched.contains(&k);
            k += 1;
            keep
        });
        motion::shapes_replaced(scene, &matched, 0, 0);
        return Ok(());
    }
    let mut targets = matched.clone();
    if let Some(r) = &o.replace {
        let path = resolve_path(base_dir, &r.file);
        let first = &scene.shapes[matched[0]];
        let name = first.name.clone();
        let old_material = first.material;
        let material_override = match &r.material {
            Some(m) => Some(*scene.named_materials.get(m).ok_or_else(|| {
                format!("{key}: replace.material \"{m}\" is not a named material")
            })?),
            None => None,
        };
        let mut new_shapes = file_shapes(
            scene,
            &path,
            &key,
            material_override.unwrap_or(old_material),
            reader,
        )?;
        for s in new_shapes.iter_mut() {
            s.name = name.clone();
            if let Some(m) = material_override {
                s.material = m;
            }
        }
        if new_shapes.is_empty() {
            return Err(format!("{key}: {} has no shapes", path.display()));
        }
        let align = r.align.as_deref().unwrap_or("bottom");
        let (nlo, nhi) = union_bounds(&new_shapes.iter().collect::<Vec<_>>());
        let shift = match align {
            "bottom" => [
                (lo[0] + hi[0] - nlo[0] - nhi[0]) / 2.0,
                lo[1] - nlo[1],
                (lo[2] + hi[2] - nlo[2] - nhi[2]) / 2.0,
            ],
            "center" => [
                (lo[0] + hi[0] - nlo[0] - nhi[0]) / 2.0,
                (lo[1] + hi[1] - nlo[1] - nhi[1]) / 2.0,
                (lo[2] + hi[2] - nlo[2] - nhi[2]) / 2.0,
            ],
            "none" => [0.0; 3],
            other => {
                return Err(format!(
                    "{key}: replace.align \"{other}\" must be bottom, center or none"
                ))
            }
        };
        let t = Transform::translate(shift);
        for s in new_shapes.iter_mut() {
            xform::transform_shape(s, &t).map_err(|e| format!("{key}: {e}"))?;
        }
        // Remove the old shapes, insert the new ones at the first one's place.
        let at = matched[0];
        let n_new = new_shapes.len();
        let mut k = 0;
        scene.shapes.retain(|_| {
            let keep = !matched.contains(&k);
            k += 1;
            keep
        });
        let at = at.min(scene.shapes.len());
        scene.shapes.splice(at..at, new_shapes);
        motion::shapes_replaced(scene, &matched, at, n_new);
        targets = (at..at + n_new).collect();
    }
    transform_targets(scene, o, targets, &key, None)
}

/// An `[[object]]`'s material, category, transform and motion keys applied to the shapes
/// `targets` (matched, replacing or added) about `pivot_m`, else `default_pivot`, else the
/// centre of their bounds.
fn transform_targets(
    scene: &mut SceneDescription,
    o: &ObjectOverlay,
    targets: Vec<usize>,
    key: &str,
    default_pivot: Option<[f64; 3]>,
) -> Result<(), String> {
    if let Some(c) = &o.category {
        for &k in &targets {
            scene.shapes[k].tags.category = Some(c.clone());
        }
    }
    if let Some(m) = &o.material {
        let idx = *scene
            .named_materials
            .get(m)
            .ok_or_else(|| format!("{key}: material \"{m}\" is not a named material"))?;
        for &k in &targets {
            // A medium boundary stays one, around the new material.
            scene.shapes[k].material = match scene.materials[scene.shapes[k].material] {
                Material::MediumInterface {
                    inside, outside, ..
                } => {
                    scene.materials.push(Material::MediumInterface {
                        material: idx,
                        inside,
                        outside,
                    });
                    scene.materials.len() - 1
                }
                _ => idx,
            };
        }
    }
    if o.scale.is_some() || o.rotate.is_some() || o.translate_m.is_some() {
        let refs: Vec<&Shape> = targets.iter().map(|&k| &scene.shapes[k]).collect();
        let (lo, hi) = union_bounds(&refs);
        let pivot = o.pivot_m.or(default_pivot).unwrap_or([
            (lo[0] + hi[0]) / 2.0,
            (lo[1] + hi[1]) / 2.0,
            (lo[2] + hi[2]) / 2.0,
        ]);
        let mut t = Transform::translate([-pivot[0], -pivot[1], -pivot[2]]);
        if let Some(s) = &o.scale {
            let s = match s {
                ScaleSpec::Uniform(v) => [*v; 3],
                ScaleSpec::Axes(a) => *a,
            };
            if s.iter().any(|v| !v.is_finite() || *v == 0.0) {
                return Err(format!("{key}: scale {s:?} must be finite and non-zero"));
            }
            t = Transform::scale(s).then_apply_to(&t);
        }
        if let Some(r) = &o.rotate {
            if r.axis.iter().all(|v| *v == 0.0) || !r.angle_deg.is_finite() {
                return Err(format!(
                    "{key}: rotate needs a finite angle and a non-zero axis"
                ));
            }
            t = Transform::rotate(r.angle_deg, r.axis).then_apply_to(&t);
        }
        t = Transform::translate(pivot).then_apply_to(&t);
        if let Some(d) = o.translate_m {
            t = Transform::translate(d).then_apply_to(&t);
        }
        for &k in &targets {
            xform::transform_shape(&mut scene.shapes[k], &t).map_err(|e| format!("{key}: {e}"))?;
        }
        motion::moved_shapes(scene, &targets, &t);
    }
    motion::apply_object_motion(scene, o, &targets, key)
}

fn apply_light(
    scene: &mut SceneDescription,
    l: &LightOverlay,
    base_dir: &Path,
) -> Result<(), String> {
    let new_shape = match &l.spectrum {
        Some(s) => Some(resolve_spectrum(s, base_dir, "light.spectrum")?),
        None => None,
    };
    if let Some(s) = &new_shape {
        if !(photometric(s) > 0.0) {
            return Err("light.spectrum has no luminance (zero over 360-830 nm)".into());
        }
    }
    if let Some(v) = l.luminance_cd_m2 {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(format!(
                "light.luminance_cd_m2 {v} must be a non-negative number"
            ));
        }
    }
    if let Some(v) = l.radiance_scale {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(format!(
                "light.radiance_scale {v} must be a non-negative number"
            ));
        }
    }
    let change = |old: &Spectrum| -> Result<Spectrum, String> {
        let old_lum = LUMINOUS_EFFICACY_LM_PER_W * photometric(old);
        let relative = new_shape.clone().unwrap_or_else(|| old.clone());
        let mut out = match (l.luminance_cd_m2, &new_shape) {
            (Some(v), _) => spectrum_at_luminance(&relative, v).map_err(|e| e.to_string())?,
            (None, Some(_)) => {
                spectrum_at_luminance(&relative, old_lum).map_err(|e| e.to_string())?
            }
            (None, None) => old.clone(),
        };
        if let Some(k) = l.radiance_scale {
            out = out.scaled(k);
        }
        Ok(out)
    };
    let mut n = 0;
    for s in scene.shapes.iter_mut() {
        let matches = match &l.name {
            None => true,
            Some(p) => s.name.as_deref().is_some_and(|n| glob_match(p, n)),
        };
        if let (true, Some(a)) = (matches, s.area_light.as_mut()) {
            a.radiance = change(&a.radiance)?;
            n += 1;
        }
    }
    if l.name.is_none() {
        for li in scene.lights.iter_mut() {
            match li {
                Light::Infinite { radiance }
                | Light::Distant {
                    irradiance: radiance,
                    ..
                } => {
                    *radiance = change(radiance)?;
                    n += 1;
                }
                Light::Point { intensity, .. }
                | Light::Spot { intensity, .. }
                | Light::Goniometric(crate::scene::GoniometricLight { intensity, .. }) => {
                    *intensity = change(intensity)?;
                    n += 1;
                }
                Light::Environment(crate::scene::EnvironmentMap { illuminant, .. })
                | Light::Projection(crate::scene::ProjectionLight { illuminant, .. }) => {
                    *illuminant = change(illuminant)?;
                    n += 1;
                }
            }
        }
    }
    if n == 0 {
        return Err(format!(
            "light: no emitter matches{}",
            l.name
                .as_ref()
                .map(|n| format!(" \"{n}\""))
                .unwrap_or_default()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::glob_match;

    #[test]
    fn globs() {
        assert!(glob_match("mcc_*", "mcc_patch_01"));
        assert!(glob_match("*wall", "left_wall"));
        assert!(glob_match("a*c*e", "abcde"));
        assert!(!glob_match("mcc_*", "light"));
        assert!(glob_match("light", "light"));
        assert!(!glob_match("light", "lights"));
    }
}
