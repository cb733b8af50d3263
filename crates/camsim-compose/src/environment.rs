//! The scene's environment light (`[compose.environment]`): an equirectangular (or pbrt-v4
//! equal-area) HDR map from a file or drawn from a folder, rotated about the up axis and scaled
//! to an illuminance, or the built-in spectral sky (Preetham, Shirley and Smits 1999) with a sun.
//!
//! Units. An RGB map's texels are in pbrt-v4's convention for an `infinite` light with `scale`
//! (as `camsim-pbrt` reads one): a texel's spectrum is its RGB uplifted as an illuminant times
//! the colour space's illuminant (sRGB: CIE D65) normalised so that RGB (1, 1, 1) has a luminance
//! of 1 cd/m^2; a texel's luminance is then its Rec. 709 luminance `0.2126 R + 0.7152 G +
//! 0.0722 B` in cd/m^2, times `scale`. `illuminance_lux` replaces `scale` by the factor that
//! gives the map that illuminance on a horizontal plane facing up: `E_v = int_{upper
//! hemisphere} L_v cos(theta) d omega` (lux), the integral taken texel by texel exactly as the
//! renderer's nearest-texel lookup sees the map.
//!
//! The sky's radiance is absolute: Preetham's luminance (cd/m^2) per direction with its
//! chromaticity, each direction's spectrum the CIE daylight-basis spectrum `k (S0 + M1 S1 + M2
//! S2)` of that chromaticity and luminance (stored per texel as a basis map,
//! [`camsim_scene3d::EnvironmentMap::basis`]); the sun is a distant light whose spectral
//! irradiance is a 5778 K blackbody's radiance over the solar disc through Preetham's Rayleigh
//! and aerosol transmittances.

use crate::{stage, stream, ComposeError, Result};
use camsim_core::units::{planck_radiance_w_per_sr_m2_nm, LUMINOUS_EFFICACY_LM_PER_W};
use camsim_core::{colorimetry::Cmfs, Spectrum, WavelengthGrid};
use camsim_scene3d::{daylight, EnvMapping, EnvironmentMap, Light, SceneDescription, Transform};
use rand::Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// A number given either as a fixed value or as a `[min, max]` range drawn uniformly per sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Draw {
    /// The same value for every sample.
    Fixed(f64),
    /// Drawn uniformly in `[min, max]` per sample.
    Range([f64; 2]),
}

impl Draw {
    /// Check the value or range (finite, `min <= max`, inside `[lo, hi]`); errors name `key`.
    pub fn check(&self, key: &str, lo: f64, hi: f64) -> Result<()> {
        let (a, b) = self.bounds();
        if !(a.is_finite() && b.is_finite()) || a > b {
            return Err(ComposeError::new(
                key,
                format!("{self:?} must be a finite value or a [min, max] range with min <= max"),
            ));
        }
        if a < lo || b > hi {
            return Err(ComposeError::new(
                key,
                format!("{self:?} must lie within [{lo}, {hi}]"),
            ));
        }
        Ok(())
    }

    /// `(min, max)` (a fixed value twice).
    pub fn bounds(&self) -> (f64, f64) {
        match *self {
            Draw::Fixed(v) => (v, v),
            Draw::Range([a, b]) => (a, b),
        }
    }

    /// The value for the sample whose stream is `rng` (a fixed value draws nothing).
    pub fn draw(&self, rng: &mut impl Rng) -> f64 {
        match *self {
            Draw::Fixed(v) => v,
            Draw::Range([a, b]) if a < b => rng.gen_range(a..=b),
            Draw::Range([a, _]) => a,
        }
    }
}

/// What lights the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum EnvironmentKind {
    /// An HDR image file (`.hdr`, `.exr`, `.pfm`) or one drawn from a folder of them.
    #[default]
    Map,
    /// The built-in spectral sky (Preetham, Shirley and Smits 1999) and sun.
    Sky,
}

/// How the sky's sun is added.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SunModel {
    /// A distant light (pbrt-v4 `distant`) with the sun's spectral irradiance.
    #[default]
    Distant,
    /// The sun's power in the map's texel toward it.
    Disc,
    /// No sun.
    None,
}

/// `[compose.environment]`: the environment light of every sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// `map` (an HDR file or folder, `path`) or `sky` (the built-in spectral sky and sun).
    /// Default `map`.
    #[serde(default)]
    pub kind: EnvironmentKind,
    /// `kind = "map"`: an HDR environment map (`.hdr` Radiance RGBE, `.exr`, `.pfm`; twice as
    /// wide as high for latitude-longitude, square for pbrt-v4's equal-area octahedral
    /// mapping), or a folder whose such files are drawn from uniformly per sample; relative to
    /// the compose file's folder. No default (required for `map`).
    #[serde(default)]
    pub path: Option<PathBuf>,
    /// Rotation of the map (or of the sky's azimuth origin) about the up axis, degrees: a
    /// value or a `[min, max]` range drawn per sample. Default 0.
    #[serde(default = "zero_draw")]
    pub rotate_deg: Draw,
    /// Scale the environment so that it gives this illuminance on a horizontal plane facing
    /// up (lux, photometric: `int L_v cos(theta) d omega` over the upper hemisphere, sun
    /// included for the sky): a value or a `[min, max]` range. Default: none (the map in its
    /// own units times `scale`; the sky in its absolute units).
    #[serde(default)]
    pub illuminance_lux: Option<Draw>,
    /// Factor on a map's own units when `illuminance_lux` is not given (dimensionless; the
    /// map's RGB (1, 1, 1) is 1 cd/m^2 of D65 white, as pbrt-v4's `infinite` light with
    /// `scale`). Default 1.
    #[serde(default = "one")]
    pub scale: f64,
    /// The world's up axis (unit vector, need not be normalised): the map's pole and the
    /// sky's zenith. Default `[0, 1, 0]` (+y, glTF's and the spawned assets' convention).
    #[serde(default = "y_up")]
    pub up: [f64; 3],
    /// Remove the scene's existing infinite and environment lights first. Default true.
    #[serde(default = "yes")]
    pub replace_lights: bool,
    /// `kind = "sky"`: the sun's elevation above the horizon, degrees (0..90): a value or a
    /// range. Default 45.
    #[serde(default = "default_sun_elevation")]
    pub sun_elevation_deg: Draw,
    /// `kind = "sky"`: the sun's azimuth about the up axis, degrees, from the reference
    /// horizontal axis (world +x, or +z when up is along x; then `rotate_deg`) toward `up x`
    /// that axis: a value or a range. Default `[0, 360]`.
    #[serde(default = "default_sun_azimuth")]
    pub sun_azimuth_deg: Draw,
    /// `kind = "sky"`: atmospheric turbidity (2..10; 2 a very clear sky, 10 hazy; Preetham et
    /// al. 1999): a value or a range. Default 3.
    #[serde(default = "default_turbidity")]
    pub turbidity: Draw,
    /// `kind = "sky"`: reflectance of the ground below the horizon (0..1), a Lambertian plane
    /// lit by the sky and sun. Default 0.2.
    #[serde(default = "default_ground_albedo")]
    pub ground_albedo: f64,
    /// `kind = "sky"`: the sun as `distant` (a distant light: exact irradiance, hard shadows,
    /// not seen by camera rays), `disc` (its power in the sky map's texel toward the sun, with
    /// the daylight-basis spectrum of its chromaticity: seen by the camera as a texel-sized
    /// disc, soft shadows) or `none`. Default `distant`.
    #[serde(default)]
    pub sun: SunModel,
    /// `kind = "sky"`: height of the sky's latitude-longitude map, texels (even, 16..4096; its
    /// width is twice this). Default 256.
    #[serde(default = "default_sky_height")]
    pub sky_height_px: usize,
    /// Several environments to choose from per sample (each a full environment table, without
    /// `choices` of its own), picked with probability proportional to its `weight`. When given,
    /// the other keys of this table are ignored. Default: none.
    #[serde(default)]
    pub choices: Vec<EnvironmentSpec>,
    /// Relative probability of this entry among `choices` (> 0). Default 1.
    #[serde(default = "one")]
    pub weight: f64,
}

fn zero_draw() -> Draw {
    Draw::Fixed(0.0)
}
fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn y_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_sun_elevation() -> Draw {
    Draw::Fixed(45.0)
}
fn default_sun_azimuth() -> Draw {
    Draw::Range([0.0, 360.0])
}
fn default_turbidity() -> Draw {
    Draw::Fixed(3.0)
}
fn default_ground_albedo() -> f64 {
    0.2
}
fn default_sky_height() -> usize {
    256
}

impl Default for EnvironmentSpec {
    fn default() -> Self {
        EnvironmentSpec {
            kind: EnvironmentKind::Map,
            path: None,
            rotate_deg: zero_draw(),
            illuminance_lux: None,
            scale: 1.0,
            up: y_up(),
            replace_lights: true,
            sun_elevation_deg: default_sun_elevation(),
            sun_azimuth_deg: default_sun_azimuth(),
            turbidity: default_turbidity(),
            ground_albedo: default_ground_albedo(),
            sun: SunModel::Distant,
            sky_height_px: default_sky_height(),
            choices: Vec::new(),
            weight: 1.0,
        }
    }
}

/// What [`apply`] drew and added, for the sample's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvironmentRecord {
    /// `map` or `sky`.
    pub kind: EnvironmentKind,
    /// Index into `choices` of the entry used, if there were choices.
    pub choice: Option<usize>,
    /// The map file used (`kind = "map"`).
    pub file: Option<PathBuf>,
    /// Rotation about the up axis, degrees.
    pub rotate_deg: f64,
    /// Factor applied to the environment's own units (1 for the sky without `illuminance_lux`).
    pub scale: f64,
    /// Illuminance the environment gives a horizontal plane facing up, lux (sky and sun).
    pub illuminance_lux: f64,
    /// The sky's sun elevation, degrees.
    pub sun_elevation_deg: Option<f64>,
    /// The sky's sun azimuth (after `rotate_deg`), degrees.
    pub sun_azimuth_deg: Option<f64>,
    /// The sky's turbidity.
    pub turbidity: Option<f64>,
    /// The sky's zenith luminance (after scaling), cd/m^2.
    pub zenith_luminance_cd_m2: Option<f64>,
    /// The sun's illuminance on the horizontal plane (after scaling), lux.
    pub sun_illuminance_lux: Option<f64>,
    /// World direction toward the sun (unit).
    pub sun_direction: Option<[f64; 3]>,
    /// Sky texels whose chromaticity was moved toward the daylight locus to keep their
    /// daylight-basis spectrum non-negative (0 but for a sun near the horizon).
    pub sky_texels_desaturated: Option<usize>,
}

/// Keyed stream indices of the environment stage's draws.
mod draws {
    pub const CHOICE: u64 = 0;
    pub const FILE: u64 = 1;
    pub const ROTATE: u64 = 2;
    pub const SUN_ELEVATION: u64 = 3;
    pub const SUN_AZIMUTH: u64 = 4;
    pub const TURBIDITY: u64 = 5;
    pub const ILLUMINANCE: u64 = 6;
}

/// Light the scene as `spec` says, every draw from `seed` (the environment stage's keyed
/// streams); relative paths resolve against `base_dir`. Returns what was drawn.
pub fn apply(
    scene: &mut SceneDescription,
    spec: &EnvironmentSpec,
    seed: u64,
    base_dir: &Path,
) -> Result<EnvironmentRecord> {
    let key = "compose.environment";
    let (spec, choice, key) = if spec.choices.is_empty() {
        (spec, None, key.to_string())
    } else {
        let weights: Vec<f64> = spec.choices.iter().map(|c| c.weight).collect();
        for (i, c) in spec.choices.iter().enumerate() {
            if !(c.weight > 0.0 && c.weight.is_finite()) {
                return Err(ComposeError::new(
                    format!("{key}.choices.{i}.weight"),
                    format!("{} must be a positive number", c.weight),
                ));
            }
            if !c.choices.is_empty() {
                return Err(ComposeError::new(
                    format!("{key}.choices.{i}.choices"),
                    "a choice cannot have choices of its own",
                ));
            }
        }
        let total: f64 = weights.iter().sum();
        let u = stream(seed, stage::ENVIRONMENT, draws::CHOICE).gen::<f64>() * total;
        let mut acc = 0.0;
        let mut pick = weights.len() - 1;
        for (i, w) in weights.iter().enumerate() {
            acc += w;
            if u < acc {
                pick = i;
                break;
            }
        }
        (
            &spec.choices[pick],
            Some(pick),
            format!("{key}.choices.{pick}"),
        )
    };
    let frame = Frame::new(spec.up).ok_or_else(|| {
        ComposeError::new(
            format!("{key}.up"),
            format!("{:?} is not a usable direction", spec.up),
        )
    })?;
    spec.rotate_deg
        .check(&format!("{key}.rotate_deg"), -1e6, 1e6)?;
    if let Some(e) = &spec.illuminance_lux {
        e.check(&format!("{key}.illuminance_lux"), 1e-9, 1e7)?;
    }
    let rotate_deg = spec
        .rotate_deg
        .draw(&mut stream(seed, stage::ENVIRONMENT, draws::ROTATE));
    let target_lux = spec
        .illuminance_lux
        .map(|d| d.draw(&mut stream(seed, stage::ENVIRONMENT, draws::ILLUMINANCE)));
    if spec.replace_lights {
        remove_environment_lights(scene);
    }
    let light_to_world = frame.light_to_world(rotate_deg);
    let mut record = EnvironmentRecord {
        kind: spec.kind,
        choice,
        file: None,
        rotate_deg,
        scale: 1.0,
        illuminance_lux: 0.0,
        sun_elevation_deg: None,
        sun_azimuth_deg: None,
        turbidity: None,
        zenith_luminance_cd_m2: None,
        sun_illuminance_lux: None,
        sun_direction: None,
        sky_texels_desaturated: None,
    };
    match spec.kind {
        EnvironmentKind::Map => {
            let file = pick_map_file(spec, &key, seed, base_dir)?;
            let (width, height, rgb) = camsim_pbrt::read_linear_image(&file)
                .map_err(|e| ComposeError::new(format!("{key}.path"), e))?;
            let map_key = format!("{key}.path ({})", file.display());
            if rgb.is_empty() || rgb.iter().flatten().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(ComposeError::new(
                    map_key,
                    "the image is empty or has negative or non-finite texels",
                ));
            }
            let mapping = if width == 2 * height {
                EnvMapping::LatLong
            } else if width == height {
                EnvMapping::EqualAreaOctahedral
            } else {
                return Err(ComposeError::new(
                    map_key,
                    format!("{width} x {height}: an environment map must be twice as wide as high (equirectangular) or square (pbrt-v4 equal-area octahedral)"),
                ));
            };
            let own_lux = upper_illuminance_lux(width, height, mapping, |i| {
                let c = rgb[i];
                0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
            });
            let scale = match target_lux {
                Some(e) => {
                    if !(own_lux > 0.0) {
                        return Err(ComposeError::new(
                            map_key,
                            "illuminance_lux given but the map is black over the upper hemisphere",
                        ));
                    }
                    e / own_lux
                }
                None => {
                    if !(spec.scale >= 0.0 && spec.scale.is_finite()) {
                        return Err(ComposeError::new(
                            format!("{key}.scale"),
                            format!("{} must be a finite number >= 0", spec.scale),
                        ));
                    }
                    spec.scale
                }
            };
            let illuminant = camsim_assets::units::unit_rgb_illuminant().scaled(scale);
            scene.lights.push(Light::Environment(EnvironmentMap {
                width,
                height,
                rgb,
                mapping,
                illuminant,
                basis: None,
                light_to_world,
            }));
            scene.light_groups.resize(scene.lights.len(), None);
            record.file = Some(file);
            record.scale = scale;
            record.illuminance_lux = own_lux * scale;
        }
        EnvironmentKind::Sky => {
            spec.sun_elevation_deg
                .check(&format!("{key}.sun_elevation_deg"), 0.0, 90.0)?;
            spec.sun_azimuth_deg
                .check(&format!("{key}.sun_azimuth_deg"), -1e6, 1e6)?;
            spec.turbidity
                .check(&format!("{key}.turbidity"), 2.0, 10.0)?;
            if !(0.0..=1.0).contains(&spec.ground_albedo) {
                return Err(ComposeError::new(
                    format!("{key}.ground_albedo"),
                    format!("{} must lie within [0, 1]", spec.ground_albedo),
                ));
            }
            if !(16..=4096).contains(&spec.sky_height_px) || spec.sky_height_px % 2 != 0 {
                return Err(ComposeError::new(
                    format!("{key}.sky_height_px"),
                    format!(
                        "{} must be an even number within 16..4096 (rows meet at the horizon)",
                        spec.sky_height_px
                    ),
                ));
            }
            let elevation_deg = spec.sun_elevation_deg.draw(&mut stream(
                seed,
                stage::ENVIRONMENT,
                draws::SUN_ELEVATION,
            ));
            let azimuth_deg = spec.sun_azimuth_deg.draw(&mut stream(
                seed,
                stage::ENVIRONMENT,
                draws::SUN_AZIMUTH,
            ));
            let turbidity =
                spec.turbidity
                    .draw(&mut stream(seed, stage::ENVIRONMENT, draws::TURBIDITY));
            let sky = SkyMap::build(
                turbidity,
                elevation_deg,
                azimuth_deg,
                spec.ground_albedo,
                spec.sun,
                spec.sky_height_px,
            )
            .map_err(|m| ComposeError::new(key.clone(), m))?;
            let total = sky.sky_lux + sky.sun_lux;
            let scale = match target_lux {
                Some(e) => e / total,
                None => 1.0,
            };
            let rgb: Vec<[f32; 3]> = sky
                .coeffs
                .iter()
                .map(|c| c.map(|v| (v * scale) as f32))
                .collect();
            scene.lights.push(Light::Environment(EnvironmentMap {
                width: 2 * sky.height,
                height: sky.height,
                rgb,
                mapping: EnvMapping::LatLong,
                illuminant: Spectrum::from_pairs(&[(300.0, 1.0), (830.0, 1.0)]),
                basis: Some(std::sync::Arc::new(daylight::basis().clone())),
                light_to_world,
            }));
            let sun_dir = light_to_world.apply_vector(sky.sun_dir_light);
            if let Some(sun) = &sky.sun_irradiance {
                scene.lights.push(Light::Distant {
                    direction: [-sun_dir[0], -sun_dir[1], -sun_dir[2]],
                    irradiance: sun.clone().scaled(scale),
                });
            }
            scene.light_groups.resize(scene.lights.len(), None);
            record.scale = scale;
            record.illuminance_lux = total * scale;
            record.sun_elevation_deg = Some(elevation_deg);
            record.sun_azimuth_deg = Some(azimuth_deg + rotate_deg);
            record.turbidity = Some(turbidity);
            record.zenith_luminance_cd_m2 = Some(sky.zenith_cd_m2 * scale);
            record.sun_illuminance_lux = Some(sky.sun_lux * scale);
            record.sun_direction = Some(sun_dir);
            record.sky_texels_desaturated = Some(sky.desaturated_texels);
        }
    }
    Ok(record)
}

/// Drop the scene's infinite and environment lights (and their light-group entries).
fn remove_environment_lights(scene: &mut SceneDescription) {
    let mut groups = std::mem::take(&mut scene.light_groups);
    groups.resize(scene.lights.len(), None);
    let lights = std::mem::take(&mut scene.lights);
    for (l, g) in lights.into_iter().zip(groups) {
        if !matches!(l, Light::Infinite { .. } | Light::Environment(_)) {
            scene.lights.push(l);
            scene.light_groups.push(g);
        }
    }
}

/// The file a map environment uses: `path` itself, or one of the folder's `.hdr`, `.exr`,
/// `.pfm` files (sorted by name) drawn uniformly.
fn pick_map_file(spec: &EnvironmentSpec, key: &str, seed: u64, base_dir: &Path) -> Result<PathBuf> {
    let key = format!("{key}.path");
    let Some(p) = &spec.path else {
        return Err(ComposeError::new(
            key,
            "kind = \"map\" needs a path (an .hdr, .exr or .pfm file, or a folder of them)",
        ));
    };
    let p = if p.is_absolute() {
        p.clone()
    } else {
        base_dir.join(p)
    };
    if !p.is_dir() {
        if !p.is_file() {
            return Err(ComposeError::new(
                key,
                format!("{} does not exist", p.display()),
            ));
        }
        return Ok(p);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&p)
        .map_err(|e| ComposeError::new(&key, format!("{}: {e}", p.display())))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|f| {
            f.is_file()
                && f.extension()
                    .map(|e| {
                        matches!(
                            e.to_string_lossy().to_ascii_lowercase().as_str(),
                            "hdr" | "exr" | "pfm"
                        )
                    })
                    .unwrap_or(false)
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(ComposeError::new(
            key,
            format!("{} has no .hdr, .exr or .pfm files", p.display()),
        ));
    }
    let i = stream(seed, stage::ENVIRONMENT, draws::FILE).gen_range(0..files.len());
    Ok(files.swap_remove(i))
}

/// The world frame of the environment: the map's light space (+z the pole) in world space.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Unit up axis (light +z).
    pub up: [f64; 3],
    /// Unit reference horizontal axis (light +x before rotation): world +x made horizontal,
    /// or world +z when up is along x.
    pub reference: [f64; 3],
}

impl Frame {
    /// The frame of `up`; `None` for a zero or non-finite vector.
    pub fn new(up: [f64; 3]) -> Option<Frame> {
        let up = normalize(up)?;
        let e = if up[0].abs() > 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let d = dot(e, up);
        let reference = normalize([e[0] - d * up[0], e[1] - d * up[1], e[2] - d * up[2]])?;
        Some(Frame { up, reference })
    }

    /// Light-to-world rotation with the map turned `rotate_deg` about the up axis (light +x to
    /// `cos r reference + sin r (up x reference)`, light +y to `up x` that, light +z to up).
    pub fn light_to_world(&self, rotate_deg: f64) -> Transform {
        let (s, c) = rotate_deg.to_radians().sin_cos();
        let side = cross(self.up, self.reference);
        let x: [f64; 3] = std::array::from_fn(|i| c * self.reference[i] + s * side[i]);
        let y = cross(self.up, x);
        let z = self.up;
        let mut t = Transform::identity();
        for r in 0..3 {
            t.m[r][0] = x[r];
            t.m[r][1] = y[r];
            t.m[r][2] = z[r];
        }
        t
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = dot(a, a).sqrt();
    (l > 0.0 && l.is_finite()).then(|| [a[0] / l, a[1] / l, a[2] / l])
}

/// Illuminance on the light-space plane facing +z of a map whose texel `i` has luminance
/// `luminance(i)` (cd/m^2), lux: `sum_i L_i int_{texel, z > 0} cos(theta) d omega`, the texel's
/// cosine-weighted solid angle. Latitude-longitude rows in closed form: `(delta phi / 2)
/// (sin^2 theta_1 - sin^2 theta_0)` over the row's part above the horizon; equal-area texels
/// by 16 x 16 midpoint points each (solid angle `4 pi / n` per texel).
pub fn upper_illuminance_lux(
    width: usize,
    height: usize,
    mapping: EnvMapping,
    luminance: impl Fn(usize) -> f64,
) -> f64 {
    let mut e = 0.0;
    match mapping {
        EnvMapping::LatLong => {
            let dphi = 2.0 * PI / width as f64;
            for y in 0..height {
                let t0 = PI * y as f64 / height as f64;
                let t1 = (PI * (y + 1) as f64 / height as f64).min(PI / 2.0);
                if t0 >= PI / 2.0 {
                    break;
                }
                let w = 0.5 * dphi * (t1.sin().powi(2) - t0.sin().powi(2));
                let row: f64 = (0..width).map(|x| luminance(y * width + x)).sum();
                e += w * row;
            }
        }
        EnvMapping::EqualAreaOctahedral => {
            let q = 16;
            let d_omega = 4.0 * PI / (width * height * q * q) as f64;
            for y in 0..height {
                for x in 0..width {
                    let mut c = 0.0;
                    for b in 0..q {
                        for a in 0..q {
                            let d = camsim_scene3d::envmap::equal_area_square_to_sphere(
                                (x as f64 + (a as f64 + 0.5) / q as f64) / width as f64,
                                (y as f64 + (b as f64 + 0.5) / q as f64) / height as f64,
                            );
                            c += d[2].max(0.0);
                        }
                    }
                    if c > 0.0 {
                        e += luminance(y * width + x) * c * d_omega;
                    }
                }
            }
        }
    }
    e
}

/// The Perez et al. (1993) sky distribution with the turbidity-dependent coefficients of
/// Preetham, Shirley and Smits, "A Practical Analytic Model for Daylight", SIGGRAPH 1999,
/// Appendix A.2: `F(theta, gamma) = (1 + A e^(B / cos theta)) (1 + C e^(D gamma) + E cos^2
/// gamma)` for luminance Y and chromaticities x, y, each normalised by its zenith value:
/// `Y(theta, gamma) = Y_z F(theta, gamma) / F(0, theta_s)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreethamSky {
    /// Turbidity T.
    pub turbidity: f64,
    /// The sun's zenith angle theta_s, radians.
    pub sun_zenith_rad: f64,
    /// Perez coefficients `[A, B, C, D, E]` for Y, x, y.
    pub perez: [[f64; 5]; 3],
    /// Zenith luminance, cd/m^2, and chromaticity x, y.
    pub zenith: [f64; 3],
}

impl PreethamSky {
    /// Preetham et al. 1999, Appendix A.2: the Perez coefficients as linear functions of T
    /// and the zenith values (Y_z in kcd/m^2, converted here to cd/m^2).
    pub fn new(turbidity: f64, sun_zenith_rad: f64) -> PreethamSky {
        let t = turbidity;
        let perez = [
            [
                0.1787 * t - 1.4630,
                -0.3554 * t + 0.4275,
                -0.0227 * t + 5.3251,
                0.1206 * t - 2.5771,
                -0.0670 * t + 0.3703,
            ],
            [
                -0.0193 * t - 0.2592,
                -0.0665 * t + 0.0008,
                -0.0004 * t + 0.2125,
                -0.0641 * t - 0.8989,
                -0.0033 * t + 0.0452,
            ],
            [
                -0.0167 * t - 0.2608,
                -0.0950 * t + 0.0092,
                -0.0079 * t + 0.2102,
                -0.0441 * t - 1.6537,
                -0.0109 * t + 0.0529,
            ],
        ];
        let [yz, xz, yz_chroma] = preetham_zenith(turbidity, sun_zenith_rad);
        PreethamSky {
            turbidity,
            sun_zenith_rad,
            perez,
            zenith: [yz, xz, yz_chroma],
        }
    }

    /// `[Y (cd/m^2), x, y]` of the sky at view zenith angle `theta` (< pi/2) and angle `gamma`
    /// from the sun, radians.
    pub fn xyy(&self, theta: f64, gamma: f64) -> [f64; 3] {
        let f = |c: &[f64; 5], th: f64, g: f64| {
            (1.0 + c[0] * (c[1] / th.cos().max(1e-4)).exp())
                * (1.0 + c[2] * (c[3] * g).exp() + c[4] * g.cos().powi(2))
        };
        let ts = self.sun_zenith_rad;
        let v: [f64; 3] = std::array::from_fn(|k| {
            self.zenith[k] * f(&self.perez[k], theta, gamma) / f(&self.perez[k], 0.0, ts)
        });
        [v[0], v[1], v[2]]
    }
}

/// Preetham et al. 1999, Appendix A.2: zenith luminance `Y_z = (4.0453 T - 4.9710) tan(chi) -
/// 0.2155 T + 2.4192` kcd/m^2 with `chi = (4/9 - T/120)(pi - 2 theta_s)`, and zenith
/// chromaticities as cubics in theta_s with quadratic-in-T coefficients. Returns `[Y_z (cd/m^2),
/// x_z, y_z]`.
pub fn preetham_zenith(turbidity: f64, sun_zenith_rad: f64) -> [f64; 3] {
    let (t, ts) = (turbidity, sun_zenith_rad);
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * ts);
    let y_kcd = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let tv = [t * t, t, 1.0];
    let sv = [ts * ts * ts, ts * ts, ts, 1.0];
    let quad = |m: [[f64; 4]; 3]| -> f64 {
        (0..3)
            .map(|i| tv[i] * (0..4).map(|j| m[i][j] * sv[j]).sum::<f64>())
            .sum()
    };
    let x = quad([
        [0.00166, -0.00375, 0.00209, 0.0],
        [-0.02903, 0.06377, -0.03202, 0.00394],
        [0.11693, -0.21196, 0.06052, 0.25886],
    ]);
    let y = quad([
        [0.00275, -0.00610, 0.00317, 0.0],
        [-0.04214, 0.08970, -0.04153, 0.00516],
        [0.15346, -0.26756, 0.06670, 0.26688],
    ]);
    [1000.0 * y_kcd, x, y]
}

/// The sun's mean angular radius, degrees (a 0.533 degree disc).
pub const SUN_ANGULAR_RADIUS_DEG: f64 = 0.2666;
/// The sun's effective temperature, K (its extraterrestrial spectrum is taken as a blackbody's:
/// the solar constant follows, about 1.37 kW/m^2).
pub const SUN_TEMPERATURE_K: f64 = 5778.0;

/// The sun's spectral irradiance on a plane facing it at the ground, W/(m^2 nm), on
/// 300-830 nm every 5 nm: a 5778 K blackbody's radiance over the solar disc's solid angle
/// `2 pi (1 - cos 0.2666 deg)`, through Preetham et al.'s (1999, Appendix A.1, after Iqbal
/// 1983) Rayleigh `exp(-0.008735 lambda^-4.08 m)` and aerosol `exp(-beta lambda^-1.3 m)`
/// transmittances (lambda in um, `beta = 0.04608 T - 0.04586`), relative optical mass
/// `m = 1 / (cos theta_s + 0.15 (93.885 - theta_s,deg)^-1.253)` (Kasten 1966). Ozone, mixed
/// gases and water vapour absorption are left out.
pub fn sun_irradiance(turbidity: f64, sun_zenith_rad: f64) -> Spectrum {
    let zen_deg = sun_zenith_rad.to_degrees();
    let m = 1.0 / (sun_zenith_rad.cos() + 0.15 * (93.885 - zen_deg).powf(-1.253));
    let beta = 0.04608 * turbidity - 0.04586;
    let omega = 2.0 * PI * (1.0 - SUN_ANGULAR_RADIUS_DEG.to_radians().cos());
    let pairs: Vec<(f64, f64)> = (0..=106)
        .map(|i| {
            let l_nm = 300.0 + 5.0 * i as f64;
            let l_um = l_nm / 1000.0;
            let tau =
                (-0.008735 * l_um.powf(-4.08) * m).exp() * (-beta * l_um.powf(-1.3) * m).exp();
            (
                l_nm,
                planck_radiance_w_per_sr_m2_nm(l_nm, SUN_TEMPERATURE_K) * omega * tau,
            )
        })
        .collect();
    Spectrum::from_pairs(&pairs)
}

/// A built sky: lat-long daylight-basis coefficients (light space, +z up), its illuminance
/// and the sun's.
#[derive(Debug, Clone)]
pub struct SkyMap {
    /// Map height, texels (width `2 height`).
    pub height: usize,
    /// Per texel `(k, k M1, k M2)`: radiance `k (S0 + M1 S1 + M2 S2)` W/(sr m^2 nm).
    pub coeffs: Vec<[f64; 3]>,
    /// Unit direction toward the sun, light space.
    pub sun_dir_light: [f64; 3],
    /// The texel holding the sun (`SunModel::Disc`).
    pub sun_texel: Option<usize>,
    /// Texels whose chromaticity was moved toward the daylight locus so that their spectrum is
    /// non-negative (next to a sun on the horizon; [`daylight::m1_m2_non_negative`]).
    pub desaturated_texels: usize,
    /// Illuminance of the sky (upper hemisphere, without the sun) on the upward plane, lux.
    pub sky_lux: f64,
    /// The sun's illuminance on the upward plane, lux (0 without a sun).
    pub sun_lux: f64,
    /// The sun's spectral irradiance normal to its rays, W/(m^2 nm), for its distant light
    /// (`None` without a sun, or with the sun in the map).
    pub sun_irradiance: Option<Spectrum>,
    /// Zenith luminance, cd/m^2.
    pub zenith_cd_m2: f64,
}

impl SkyMap {
    /// The Preetham sky for `turbidity`, the sun at `elevation_deg` and `azimuth_deg` (light
    /// space: azimuth from +x toward +y), with a ground of `albedo` below the horizon.
    pub fn build(
        turbidity: f64,
        elevation_deg: f64,
        azimuth_deg: f64,
        albedo: f64,
        sun_model: SunModel,
        height: usize,
    ) -> std::result::Result<SkyMap, String> {
        let width = 2 * height;
        let ts = (90.0 - elevation_deg).to_radians();
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        let sun = [ts.sin() * ca, ts.sin() * sa, ts.cos()];
        let sky = PreethamSky::new(turbidity, ts);
        let mut coeffs = vec![[0.0; 3]; width * height];
        // Chromaticities the basis reaches only with a negative spectrum are moved toward the
        // daylight locus until it is non-negative over 380-780 nm
        // (daylight::m1_m2_non_negative; counted).
        let moved = std::cell::Cell::new(0usize);
        let per_texel = |xyy: [f64; 3]| -> std::result::Result<[f64; 3], String> {
            let [lum, x, y] = xyy;
            let (m, used) = daylight::m1_m2_non_negative(x, y).ok_or_else(|| {
                format!("the sky's chromaticity ({x:.4}, {y:.4}) has no daylight-basis spectrum")
            })?;
            if used != [x, y] {
                moved.set(moved.get() + 1);
            }
            let k = lum / (LUMINOUS_EFFICACY_LM_PER_W * daylight::y_integral(m));
            Ok([k, k * m[0], k * m[1]])
        };
        for yy in 0..height / 2 {
            let theta = PI * (yy as f64 + 0.5) / height as f64;
            for xx in 0..width {
                let phi = 2.0 * PI * (xx as f64 + 0.5) / width as f64;
                let d = [
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ];
                let gamma = dot(d, sun).clamp(-1.0, 1.0).acos();
                coeffs[yy * width + xx] = per_texel(sky.xyy(theta, gamma))?;
            }
        }
        let ybar = daylight::basis_xyz().map(|b| b[1]);
        let sky_lux = upper_illuminance_lux(width, height, EnvMapping::LatLong, |i| {
            let c = coeffs[i];
            LUMINOUS_EFFICACY_LM_PER_W * (c[0] * ybar[0] + c[1] * ybar[1] + c[2] * ybar[2])
        });
        // The sky's spectral irradiance on the ground, as basis coefficients: the cosine-
        // weighted solid angles of the upper rows (as upper_illuminance_lux) times the texels.
        let mut e_sky = [0.0; 3];
        let dphi = 2.0 * PI / width as f64;
        for yy in 0..height / 2 {
            let t0 = PI * yy as f64 / height as f64;
            let t1 = PI * (yy + 1) as f64 / height as f64;
            let w = 0.5 * dphi * (t1.sin().powi(2) - t0.sin().powi(2));
            for xx in 0..width {
                let c = coeffs[yy * width + xx];
                for k in 0..3 {
                    e_sky[k] += w * c[k];
                }
            }
        }
        let (sun_irradiance, sun_lux) = if sun_model != SunModel::None && elevation_deg > 0.0 {
            let s = sun_irradiance(turbidity, ts);
            let lux =
                LUMINOUS_EFFICACY_LM_PER_W * camsim_scene3d::spectra::photometric(&s) * ts.cos();
            (Some(s), lux)
        } else {
            (None, 0.0)
        };
        // Ground: Lambertian, radiance albedo E(lambda) / pi with E the sky's and the sun's
        // irradiance; its spectrum is the daylight-basis spectrum of E's chromaticity and
        // luminance (the sun's spectrum is not in the basis's span).
        if albedo > 0.0 {
            let grid = WavelengthGrid {
                start_nm: 360.0,
                step_nm: 1.0,
                count: 471,
            };
            let cmfs = Cmfs::on(&grid);
            let b = daylight::basis();
            let e: Vec<f64> = (0..grid.count)
                .map(|i| {
                    let l = grid.wavelength_nm(i);
                    let sky =
                        e_sky[0] * b[0].eval(l) + e_sky[1] * b[1].eval(l) + e_sky[2] * b[2].eval(l);
                    let sun = sun_irradiance
                        .as_ref()
                        .map_or(0.0, |s| s.eval(l) * ts.cos());
                    sky + sun
                })
                .collect();
            let xyz = cmfs.xyz(&e);
            let sum = xyz[0] + xyz[1] + xyz[2];
            if sum > 0.0 {
                let lum = albedo / PI * LUMINOUS_EFFICACY_LM_PER_W * xyz[1];
                let c = per_texel([lum, xyz[0] / sum, xyz[1] / sum])?;
                for t in coeffs[(height / 2) * width..].iter_mut() {
                    *t = c;
                }
            }
        }
        // The disc: the sun's luminance spread over its texel so that the texel's cosine-
        // weighted solid angle times it is the sun's illuminance (energy kept; the disc shows
        // as the texel), with the daylight-basis spectrum of the sun's chromaticity.
        let mut sun_texel = None;
        let sun_irradiance = match (sun_model, sun_irradiance) {
            (SunModel::Disc, Some(s)) => {
                let row = ((ts / PI * height as f64) as usize).min(height / 2 - 1);
                let phi = azimuth_deg.to_radians().rem_euclid(2.0 * PI);
                let col = ((phi / (2.0 * PI) * width as f64) as usize).min(width - 1);
                let t0 = PI * row as f64 / height as f64;
                let t1 = PI * (row + 1) as f64 / height as f64;
                let w = 0.5 * dphi * (t1.sin().powi(2) - t0.sin().powi(2));
                let grid = WavelengthGrid {
                    start_nm: 360.0,
                    step_nm: 1.0,
                    count: 471,
                };
                let xyz = Cmfs::on(&grid).xyz(&s.sample(&grid));
                let sum = xyz[0] + xyz[1] + xyz[2];
                let c = per_texel([sun_lux / w, xyz[0] / sum, xyz[1] / sum])?;
                let t = &mut coeffs[row * width + col];
                for k in 0..3 {
                    t[k] += c[k];
                }
                sun_texel = Some(row * width + col);
                None
            }
            (_, s) => s,
        };
        Ok(SkyMap {
            height,
            coeffs,
            desaturated_texels: moved.get(),
            sun_texel,
            sun_dir_light: sun,
            sky_lux,
            sun_lux,
            sun_irradiance,
            zenith_cd_m2: sky.zenith[0],
        })
    }
}
