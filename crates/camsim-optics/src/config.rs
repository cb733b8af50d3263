//! The optics configuration (TOML), as the CLI and presets write it.

use crate::error::{OpticsError, Result};
use crate::shading::ShadingChannel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Optics stage configuration. Example (the `pixel4a` preset):
/// ```toml
/// f_number = 1.73
/// focal_length_mm = 4.38
/// shading = "cos4"
/// [wavefront]
/// measurement_pupil_mm = 8.0
/// zernike_um = [{ j = 4, c = 1.225 }]
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OpticsConfig {
    /// f-number N = focal length / entrance pupil diameter (dimensionless, > 0).
    pub f_number: f64,
    /// Focal length, mm (> 0).
    pub focal_length_mm: f64,
    /// Lens transmittance, fraction in [0, 1]: a number, or a spectrum
    /// `{ wavelengths_nm = [...], values = [...] }` (linear interpolation, end values held). Default 1.
    #[serde(default)]
    pub transmittance: Transmittance,
    /// Wavefront aberration (Zernike terms). Default: none (diffraction-limited).
    #[serde(default)]
    pub wavefront: WavefrontConfig,
    /// Distance the lens is focused at, m (> focal length; `inf` allowed). Unset: focused on the
    /// scene plane (2D scenes) -- no focus error. Set: a 2D scene at `distance_m` gets the
    /// thin-lens defocus of that distance; a scene with a depth map gets depth-layered defocus.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub focus_distance_m: Option<f64>,
    /// Depth layering tolerance on the defocus coefficient c4 over the lens pupil, um (> 0,
    /// default 0.02): depths whose c4 round to the same multiple of this share one PSF.
    #[serde(default = "default_defocus_tolerance_um")]
    pub defocus_tolerance_um: f64,
    /// Most depth layers (default 64); beyond it the layer width grows to fit.
    #[serde(default = "default_max_depth_layers")]
    pub max_depth_layers: usize,
    /// Lens shading: `"cos4"` (default), `"none"`, `{ relative_illumination = { ... } }` or
    /// `{ file = "shading.toml", channel = "mean" }`.
    #[serde(default)]
    pub shading: ShadingConfig,
    /// PSF sampling options.
    #[serde(default)]
    pub psf: PsfOptions,
    /// Border handling: `"psf"` (default: the irradiance image grows by the PSF half-width on
    /// every side, so light blurred past the scene edge is kept), `"isetcam"` (grows by 1/8 of the
    /// size on every side, as ISETCam `oiCompute` pads), `"none"` (same size as the scene; light
    /// blurred past the edge is lost).
    #[serde(default)]
    pub padding: Padding,
    /// Pixel crosstalk blur: standard deviation of a Gaussian in the sensor plane, um (>= 0,
    /// default 0 = none). Carrier diffusion and optical crosstalk between photodiodes blur the
    /// image like a shift-invariant Gaussian, MTF factor exp(-2 pi^2 sigma^2 f^2); the optics stage
    /// applies it with the lens PSF (linear shift-invariant stages commute). `camsim fit mtf`
    /// fits it with the defocus to a measured MTF (the `pixel4a-measured` preset).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub crosstalk_sigma_um: f64,
    /// How the PSF varies over the image (unset: one PSF, shift-invariant). Example:
    /// `blur = { method = "shift-variant", field_heights = 12, lens_file = "dgauss.json" }`;
    /// see [`BlurConfig`] and [`crate::shift_variant`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blur: Option<BlurConfig>,
    /// The pupil's shape (unset: the circle of diameter focal length / f-number). Example:
    /// `aperture = { blades = 6, rotation_deg = 0, curvature = 0.2 }`; see [`ApertureConfig`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aperture: Option<ApertureConfig>,
    /// A birefringent optical low-pass filter in front of the sensor (unset: none). Example:
    /// `olpf = { spots = 4, displacement_um = 1.4 }`: every point images as four spots
    /// 1.4 um apart, MTF |cos(pi f d)| per axis; see [`crate::olpf`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub olpf: Option<crate::olpf::OlpfConfig>,
    /// Scattering flare from contamination of the pupil (unset: a clean pupil). Example:
    /// `flare = { seed = 7, dust_coverage = 0.01, dust_radius_um = [5, 40], scratch_count = 3 }`;
    /// see [`FlareConfig`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flare: Option<FlareConfig>,
    /// Veiling glare: a glare spread function added as a far tail (unset: none). Example:
    /// `glare = { fraction = 0.02, exponent = 1.5, core_radius_um = 50 }`; see [`GlareConfig`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glare: Option<GlareConfig>,
}

/// `[flare]`: dust, scratches, smudges and file-given patterns on the lens pupil of the wavefront
/// PSF (Wu et al., ICCV 2021, make their flare this way; see [`crate::flare`]). Sizes are on the
/// pupil (diameter focal length / f-number); coordinates as `[aperture]`'s (x along image
/// columns, y along image rows, angles from +x towards +y). The irradiance is scaled by the
/// transmitted fraction. Not with `blur.method = "shift-variant"` yet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FlareConfig {
    /// Seed of the random dust, scratches and smudge (default 0): the same seed gives the same
    /// pattern.
    #[serde(default, skip_serializing_if = "is_zero_u64")]
    pub seed: u64,
    /// Number of dust particles (give this or `dust_coverage`; default none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dust_count: Option<usize>,
    /// Fraction of the pupil area covered by dust, (0, 0.3] (particles are added until it is
    /// reached; they do not overlap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dust_coverage: Option<f64>,
    /// Range of dust particle radii, um, `[min, max]` (log-uniform; default [5, 50]).
    #[serde(default = "default_dust_radius_um")]
    pub dust_radius_um: [f64; 2],
    /// Fraction of the light a dust particle absorbs, [0, 1] (default 1: opaque).
    #[serde(default = "one_f64")]
    pub dust_opacity: f64,
    /// Number of straight scratches (default 0).
    #[serde(default, skip_serializing_if = "is_zero_usize")]
    pub scratch_count: usize,
    /// Scratch width, um (default 10).
    #[serde(default = "default_scratch_width_um")]
    pub scratch_width_um: f64,
    /// Scratch length, mm (default: the pupil diameter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scratch_length_mm: Option<f64>,
    /// Direction of every scratch from +x, degrees (default: uniform at random per scratch).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scratch_angle_deg: Option<f64>,
    /// Fraction of the light a scratch absorbs or scatters out of the lens, [0, 1] (default 1).
    #[serde(default = "one_f64")]
    pub scratch_opacity: f64,
    /// RMS of the smudge phase error over the pupil, waves (default 0: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub smudge_rms_waves: f64,
    /// Correlation length of the smudge phase (1/e distance of its correlation), mm (default:
    /// a tenth of the pupil diameter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub smudge_correlation_mm: Option<f64>,
    /// An intensity transmission image (grey PNG/TIFF/OpenEXR, values in [0, 1], read as
    /// `[aperture] mask`) over the pupil's bounding square; the amplitude is its square root.
    /// Relative to the config file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask: Option<PathBuf>,
    /// A phase image (grey, values in [0, 1], read as `mask`) over the pupil's bounding square:
    /// the phase is its value times `phase_mask_waves`. Relative to the config file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_mask: Option<PathBuf>,
    /// Phase of a `phase_mask` value of 1, waves (default 1).
    #[serde(default = "one_f64")]
    pub phase_mask_waves: f64,
}

/// `[glare]`: veiling glare as a glare spread function g(r) = G (p - 1) r0^(2p - 2) /
/// (pi (r^2 + r0^2)^p) (a Moffat profile of total energy G), added to the blurred irradiance as
/// E' = (1 - G) E + g * E on a coarse grid ([`crate::glare`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GlareConfig {
    /// Fraction G of each point's energy moved into the glare tail, [0, 1).
    pub fraction: f64,
    /// Exponent p of the tail, > 1 (default 1.5: g falls as r^-3 far out).
    #[serde(default = "default_glare_exponent")]
    pub exponent: f64,
    /// Core radius r0 in the sensor plane, um (> 0).
    pub core_radius_um: f64,
}

/// The defaults of every key (an empty `[flare]` table): a clean pupil.
impl Default for FlareConfig {
    fn default() -> Self {
        FlareConfig {
            seed: 0,
            dust_count: None,
            dust_coverage: None,
            dust_radius_um: default_dust_radius_um(),
            dust_opacity: 1.0,
            scratch_count: 0,
            scratch_width_um: default_scratch_width_um(),
            scratch_length_mm: None,
            scratch_angle_deg: None,
            scratch_opacity: 1.0,
            smudge_rms_waves: 0.0,
            smudge_correlation_mm: None,
            mask: None,
            phase_mask: None,
            phase_mask_waves: 1.0,
        }
    }
}

fn default_glare_exponent() -> f64 {
    1.5
}
fn default_dust_radius_um() -> [f64; 2] {
    [5.0, 50.0]
}
fn default_scratch_width_um() -> f64 {
    10.0
}
fn one_f64() -> f64 {
    1.0
}
fn is_zero_u64(v: &u64) -> bool {
    *v == 0
}

/// `[aperture]`: the shape of the lens pupil in the wavefront PSF. The iris is inscribed in the
/// lens pupil (its vertices on the circle of diameter D = focal length / f-number), so `f_number`
/// keeps meaning the circumscribed diameter, as a lens's stop scale does; the open area is smaller
/// (6 straight blades: 0.827 of the circle) and the irradiance is scaled by the transmitted area
/// fraction (obstruction, vanes and mask included). Coordinates: x along image columns, y along
/// image rows, angles from +x towards +y. Not with `blur.method = "shift-variant"` yet.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ApertureConfig {
    /// Iris blade count (3..=64); unset: no iris (the circle).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blades: Option<usize>,
    /// Angle of the first blade vertex from +x, degrees (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rotation_deg: f64,
    /// Blade curvature in [0, 1]: 0 straight blades (a regular polygon), 1 the circle; each blade
    /// is an arc through its two vertices with sagitta `curvature` times the circle's (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub curvature: f64,
    /// Central obstruction diameter as a fraction of the pupil diameter, [0, 1) (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub obstruction: f64,
    /// Spider vane count (0..=64, default 0), from the centre to the rim, equally spaced.
    #[serde(default, skip_serializing_if = "is_zero_usize")]
    pub vanes: usize,
    /// Width of each vane as a fraction of the pupil diameter, [0, 0.5) (needed with `vanes`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub vane_width: f64,
    /// Angle of the first vane from +x, degrees (default 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub vane_rotation_deg: f64,
    /// A grey intensity-transmission mask (PNG/TIFF code values / full scale, or a one-channel or
    /// grey OpenEXR; values in [0, 1]; the pupil amplitude is its square root) stretched over the
    /// pupil's bounding square (row 0 at -y), multiplying the shape; sampled bilinearly at the
    /// pupil samples. Relative to the config file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask: Option<PathBuf>,
    /// Only one half of the pupil open: `"left"` (x < 0) or `"right"` (x > 0), the straight
    /// edge through the pupil's centre along y (unset: the whole pupil). What a half-shielded
    /// phase-detection pixel sees, or one photodiode of a dual-pixel sensor (a sensor with
    /// `dual_pixel = true` sets it itself for each of its halves; not with it). The irradiance
    /// halves with the area.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half: Option<PupilHalf>,
}

/// One half of the pupil ([`ApertureConfig::half`]): pupil x along image columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PupilHalf {
    /// x < 0.
    Left,
    /// x > 0.
    Right,
}

impl PupilHalf {
    /// `"left"` or `"right"`.
    pub fn name(self) -> &'static str {
        match self {
            PupilHalf::Left => "left",
            PupilHalf::Right => "right",
        }
    }
}

fn is_zero_usize(v: &usize) -> bool {
    *v == 0
}

/// `blur = { ... }`: shift-invariant (the default) or shift-variant ("ray-trace") optics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BlurConfig {
    /// `"shift-invariant"` (one PSF per wavelength for the whole image, as without `blur`) or
    /// `"shift-variant"` (PSFs per field height and wavelength, rotated to each block's azimuth
    /// and interpolated between field heights; ISETCam's ray-trace optics).
    pub method: BlurKind,
    /// Field heights at which PSFs are computed, from the axis to the image corner, equally
    /// spaced (2..=64, default 12).
    #[serde(default = "default_field_heights")]
    pub field_heights: usize,
    /// Block side, image samples: each block is blurred with one PSF (at its centre's field
    /// height and azimuth). Default: the FFT tile that is cheapest for the kernel size (~230 for
    /// kernels of 30 samples). 8..=4096.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block_px: Option<usize>,
    /// Oversampling of the stored PSFs for the rotation (odd, 1..=9, default 3): each rotated
    /// fine sample is binned into the image sample cell it falls in.
    #[serde(default = "default_rotation_oversampling")]
    pub rotation_oversampling: usize,
    /// A lens prescription (ISET3d lens JSON or pbrt-v4 `realistic` lens file; relative to the
    /// config file): PSFs from its traced wavefront (optical path difference fitted with Zernike
    /// terms per field height and wavelength), distortion from its chief rays and relative
    /// illumination from its traced pupil. The stop is scaled to `f_number`; the lens's focal
    /// length must be within 2 % of `focal_length_mm`; `shading` must be `"none"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lens_file: Option<PathBuf>,
    /// Or a ray-transfer function (ISET3d/isetrtf JSON, relative to the config file): PSFs from
    /// rays traced through it (geometric spot convolved with the diffraction of its pass ellipse),
    /// distortion from its chief rays and relative illumination from its pass regions
    /// ([`crate::rtf_psf`]). Its focal length must be within 2 % of `focal_length_mm` and its
    /// on-axis f-number within 2 % of `f_number`; `shading` must be `"none"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rtf_file: Option<PathBuf>,
    /// Or a table of Zernike terms per field height (added to `[wavefront]`'s terms).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_zernike: Option<FieldZernikeConfig>,
    /// Or measured PSFs, one spectral OpenEXR per field height ([`MeasuredPsfConfig`],
    /// [`crate::measured_psf`]): a lab's measurement in place of the lens model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured_psf: Option<MeasuredPsfConfig>,
    /// With `lens_file`: the lens's two-bounce ghosts (reflections between pairs of surfaces) of
    /// the image's brightest sources, or of explicit sources, added to the irradiance; see
    /// [`GhostConfig`] and [`crate::traced::Ghosts`]. Unset: no ghosts (nothing is computed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ghosts: Option<GhostConfig>,
}

/// `measured_psf = { files = [{ field_height_mm = 0.0, file = "psf_0.exr" }, ...] }` under
/// `blur` (shift-variant): measured PSFs per field height and wavelength
/// ([`crate::measured_psf`] for the file layout and how they are interpolated).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeasuredPsfConfig {
    /// Sample spacing of the files' PSFs in the sensor plane, um (default: each file's own
    /// `camsimSampleSpacingM`; required for files without it; not used by `.csv` MTF tables).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing_um: Option<f64>,
    /// One file per field height, heights increasing from the axis (one file: the same PSF
    /// everywhere, a shift-invariant measurement).
    pub files: Vec<MeasuredPsfFile>,
}

/// One measured field height of [`MeasuredPsfConfig`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeasuredPsfFile {
    /// The height in the sensor plane where the PSF was measured (along +x), mm.
    pub field_height_mm: f64,
    /// A spectral OpenEXR (`S0.<wavelength>nm` channels), relative to the config file: the PSF,
    /// columns along the radius, rows along the tangent, centred on the ideal image point. Or a
    /// `.csv` lens MTF table at that height (columns frequency in cycles/mm, tangential and
    /// sagittal MTF, optionally wavelength_nm and the tangential and sagittal phase (PTF)): the
    /// separable PSF with those OTFs (zero phase without PTF columns).
    pub file: PathBuf,
}

/// `ghosts = { coating = "uncoated", threshold = 0.5 }` under `blur` (with `lens_file`): lens
/// ghosts by real ray tracing of every two-bounce path of the prescription (Hullin et al.,
/// SIGGRAPH 2011). Sources: the connected regions of the irradiance image (summed over bands)
/// above `threshold` times its maximum, brightest first, each taken as a point at infinity in the
/// direction whose chief ray lands on the region's centroid and with the region's power per band;
/// or, when `sources` is given, those sources instead (their own image is not added: put a source
/// that is in the frame into the scene).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GhostConfig {
    /// Reflectance of every refracting surface at normal incidence: `"uncoated"` (Fresnel from
    /// the two media's indices at each wavelength), `{ quarter_wave_nm = 550, layer_index = 1.38 }`
    /// (one quarter-wave layer on each air-glass surface; cemented surfaces stay uncoated) or
    /// `{ reflectance = 0.005 }` (the same fraction everywhere). Default: a quarter-wave MgF2
    /// layer (1.38) at 550 nm.
    #[serde(default)]
    pub coating: CoatingConfig,
    /// Reflectance of each surface of the lens file, object side first, one number in [0, 1) per
    /// surface (the stop's entry is ignored); replaces `coating` when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface_reflectance: Option<Vec<f64>>,
    /// Source detection threshold, fraction of the image's largest band-summed irradiance,
    /// (0, 1] (default 0.5).
    #[serde(default = "default_ghost_threshold")]
    pub threshold: f64,
    /// Most detected sources, the brightest regions first (1..=64, default 4).
    #[serde(default = "default_ghost_sources")]
    pub max_sources: usize,
    /// Explicit sources at infinity (replace the detection).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sources: Option<Vec<GhostSourceConfig>>,
    /// Rays across the front element's diameter per ghost, source and band (8..=512, default
    /// 48).
    #[serde(default = "default_ghost_rays")]
    pub rays: usize,
    /// Samples of the ghost raster along the image's longer side (16..=16384, default 512): the
    /// ghosts are splatted on a grid this many times coarser than the image where the image is
    /// larger, then added with bilinear interpolation (ghosts are smooth; the cost follows the
    /// ghosts' area in raster samples).
    #[serde(default = "default_ghost_raster")]
    pub raster_px: usize,
}

impl Default for GhostConfig {
    fn default() -> Self {
        GhostConfig {
            coating: CoatingConfig::default(),
            surface_reflectance: None,
            threshold: default_ghost_threshold(),
            max_sources: default_ghost_sources(),
            sources: None,
            rays: default_ghost_rays(),
            raster_px: default_ghost_raster(),
        }
    }
}

fn default_ghost_threshold() -> f64 {
    0.5
}
fn default_ghost_sources() -> usize {
    4
}
fn default_ghost_rays() -> usize {
    48
}
fn default_ghost_raster() -> usize {
    512
}

/// A surface reflectance model (`ghosts.coating`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum CoatingConfig {
    /// `"uncoated"`.
    Named(CoatingName),
    /// `{ quarter_wave_nm = 550, layer_index = 1.38 }`.
    QuarterWave(QuarterWaveConfig),
    /// `{ reflectance = 0.005 }`.
    Constant(ConstantReflectance),
}

impl Default for CoatingConfig {
    fn default() -> Self {
        CoatingConfig::QuarterWave(QuarterWaveConfig {
            quarter_wave_nm: 550.0,
            layer_index: default_layer_index(),
        })
    }
}

/// Named coating models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CoatingName {
    /// Bare surfaces: Fresnel reflectance at normal incidence.
    Uncoated,
}

/// One quarter-wave anti-reflection layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct QuarterWaveConfig {
    /// Design wavelength, nm: the layer's optical thickness is a quarter of it (> 0).
    pub quarter_wave_nm: f64,
    /// Index of the layer (>= 1, default 1.38: MgF2).
    #[serde(default = "default_layer_index")]
    pub layer_index: f64,
}

fn default_layer_index() -> f64 {
    1.38
}

/// The same reflectance on every surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ConstantReflectance {
    /// Reflectance, fraction in [0, 1).
    pub reflectance: f64,
}

/// An explicit ghost source at infinity (`ghosts.sources = [{ field_deg = [10, 0], irradiance_w_m2_nm = 1.0 }]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GhostSourceConfig {
    /// Direction of the light, degrees from the axis along image columns (x) and rows (y): the
    /// light travels along (tan x, tan y, 1), and its (ideal) image lies near
    /// (f tan x, f tan y) from the image centre (each |value| < 89).
    pub field_deg: [f64; 2],
    /// Spectral irradiance of the beam at the lens, normal to the beam, W/(m^2 nm) (>= 0; the same
    /// in every band).
    pub irradiance_w_m2_nm: f64,
}

/// Shift-invariant or shift-variant blur.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum BlurKind {
    /// One PSF per wavelength.
    ShiftInvariant,
    /// PSFs per field height and wavelength.
    ShiftVariant,
}

/// `field_zernike = { field_height_normalized = [0, 0.5, 1], zernike_um = [[...], [...], [...]] }`:
/// Zernike coefficients (um, OSA index j, unit RMS, over the measurement pupil as `[wavefront]`)
/// at each field height, in the frame where the field point lies on the +x axis (x radial, y
/// tangential); linear interpolation between heights, end values held. Give exactly one of
/// `field_height_mm` or `field_height_normalized` (1 = the image's corner).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FieldZernikeConfig {
    /// Field heights in the sensor plane, mm, increasing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_height_mm: Option<Vec<f64>>,
    /// Field heights normalized to the image half-diagonal, increasing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_height_normalized: Option<Vec<f64>>,
    /// One list of coefficients per field height, indexed by OSA j (um).
    pub zernike_um: Vec<Vec<f64>>,
}

fn default_field_heights() -> usize {
    12
}
fn default_rotation_oversampling() -> usize {
    3
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn default_defocus_tolerance_um() -> f64 {
    0.02
}
fn default_max_depth_layers() -> usize {
    64
}
fn default_reference_wavelength_nm() -> f64 {
    550.0
}

/// Lens transmittance: one number for all wavelengths, or a spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Transmittance {
    /// The same fraction at every wavelength.
    Scalar(f64),
    /// A sampled spectrum (fraction).
    Spectrum(TransmittanceSpectrum),
}

impl Default for Transmittance {
    fn default() -> Self {
        Transmittance::Scalar(1.0)
    }
}

/// A transmittance spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TransmittanceSpectrum {
    /// Wavelengths, nm, increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Transmittance at each wavelength, fraction in [0, 1].
    pub values: Vec<f64>,
}

/// Wavefront aberration configuration (ISETCam wvf parameters).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WavefrontConfig {
    /// Zernike coefficients, um of optical path, OSA/ANSI single index j, unit-RMS normalized:
    /// either a list of `{ j = 4, c = 1.225 }` terms or a plain list indexed by j (`[0, 0, 0, 0, 1.225]`).
    #[serde(default)]
    pub zernike_um: ZernikeTerms,
    /// Diameter of the pupil over which the coefficients are defined, mm (default: the lens pupil,
    /// focal length / f-number). Must be >= the lens pupil.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measurement_pupil_mm: Option<f64>,
    /// Wavelength at which the coefficients were measured, nm (default 550).
    #[serde(default = "default_reference_wavelength_nm")]
    pub reference_wavelength_nm: f64,
    /// Optional chromatic defocus: c4 (um, over the measurement pupil) against wavelength; added to
    /// j = 4 relative to its value at the reference wavelength.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chromatic_defocus: Option<ChromaticDefocus>,
}

impl Default for WavefrontConfig {
    fn default() -> Self {
        WavefrontConfig {
            zernike_um: ZernikeTerms::default(),
            measurement_pupil_mm: None,
            reference_wavelength_nm: 550.0,
            chromatic_defocus: None,
        }
    }
}

/// Zernike coefficients in one of two forms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum ZernikeTerms {
    /// Coefficients indexed by OSA j (um).
    Indexed(Vec<f64>),
    /// Sparse terms.
    Terms(Vec<ZernikeTerm>),
}

impl Default for ZernikeTerms {
    fn default() -> Self {
        ZernikeTerms::Indexed(Vec::new())
    }
}

/// One Zernike term.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ZernikeTerm {
    /// OSA/ANSI single index (0 piston, 4 defocus, 12 spherical, ...).
    pub j: usize,
    /// Coefficient, um.
    pub c: f64,
}

impl ZernikeTerms {
    /// Dense coefficients indexed by j; error on a repeated j.
    pub fn to_dense(&self) -> Result<Vec<f64>> {
        match self {
            ZernikeTerms::Indexed(v) => Ok(v.clone()),
            ZernikeTerms::Terms(t) => {
                let n = t.iter().map(|z| z.j + 1).max().unwrap_or(0);
                if n > 231 {
                    return Err(OpticsError::config(
                        "wavefront.zernike_um",
                        format!("j = {} is beyond 230 (radial order 20)", n - 1),
                    ));
                }
                let mut v = vec![0.0; n];
                let mut seen = vec![false; n];
                for z in t {
                    if seen[z.j] {
                        return Err(OpticsError::config(
                            "wavefront.zernike_um",
                            format!("j = {} is given twice", z.j),
                        ));
                    }
                    seen[z.j] = true;
                    v[z.j] = z.c;
                }
                Ok(v)
            }
        }
    }
}

/// A chromatic defocus curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ChromaticDefocus {
    /// Wavelengths, nm, increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Defocus c4 at each wavelength, um over the measurement pupil.
    pub c4_um: Vec<f64>,
}

/// Lens shading model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum ShadingConfig {
    /// `"cos4"` or `"none"`.
    Named(ShadingName),
    /// A relative-illumination table.
    Table(ShadingTable),
    /// A fitted shading file.
    File(ShadingFile),
}

impl Default for ShadingConfig {
    fn default() -> Self {
        ShadingConfig::Named(ShadingName::Cos4)
    }
}

/// Named shading models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ShadingName {
    /// cos^4 of the field angle seen from the exit pupil (ISETCam `opticsCos4`).
    Cos4,
    /// No shading.
    None,
}

/// `shading = { relative_illumination = { field_height_mm = [...], ri = [...] } }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShadingTable {
    /// The table.
    pub relative_illumination: RelativeIllumination,
}

/// Relative illumination against field height, as lens design programs export it. Give exactly
/// one of `field_height_mm` (sensor plane) or `field_height_normalized` (0 at the centre, 1 at
/// the image's corner). Linear interpolation; the last value is held beyond the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RelativeIllumination {
    /// Field heights in the sensor plane, mm, increasing from 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_height_mm: Option<Vec<f64>>,
    /// Field heights normalized to the half-diagonal of the image, increasing from 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_height_normalized: Option<Vec<f64>>,
    /// Relative illumination at each height (fraction, 1 on axis typically).
    pub ri: Vec<f64>,
}

/// `shading = { file = "shading.toml" }`: a fit written by `camsim fit-shading`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShadingFile {
    /// Path of the shading TOML (relative paths: to the config file's folder).
    pub file: PathBuf,
    /// Which channel's fit to apply to the spectral irradiance: `"mean"` (default: mean of the
    /// R, G, B polynomials), `"r"`, `"g"` or `"b"`. The irradiance is spectral, so per-channel
    /// shading cannot be applied exactly before the colour filters.
    #[serde(default)]
    pub channel: ShadingChannel,
}

/// PSF sampling options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PsfOptions {
    /// Minimum oversampling of the PSF relative to the image spacing (odd; default 1 = automatic:
    /// 1 when the image samples lambda N / 2 or finer, else enough that the PSF does not alias;
    /// the oversampled PSF is integrated over each image sample cell).
    #[serde(default = "one")]
    pub oversampling: usize,
    /// Fraction of the PSF energy outside the kernel (default 0.01; sets the kernel size with the
    /// geometric blur). With `far_tail` that energy is added as the diffraction far tail; without
    /// it, it is folded back into the kernel.
    #[serde(default = "default_tail_energy")]
    pub tail_energy: f64,
    /// Largest kernel side, samples (default 1025); larger blurs are truncated to it and renormalized.
    #[serde(default = "default_max_kernel")]
    pub max_kernel_size: usize,
    /// Minimum pupil samples across the lens pupil diameter (default 64).
    #[serde(default = "default_min_pupil")]
    pub min_pupil_samples: usize,
    /// With kernels: add the diffraction far tail beyond the kernel window (default true): the
    /// Airy asymptote lambda N / (pi^3 r^3) convolved on a coarse grid, the kernel carrying the
    /// rest of the energy. Without it a trimmed kernel is renormalized, which moves the tail light
    /// that dark patches get from bright neighbours onto the bright ones (3 % on a dark chart patch
    /// next to a white border; 0.05 % with the tail).
    #[serde(default = "yes")]
    pub far_tail: bool,
    /// How the blur is applied: `"auto"` (default: the whole-image OTF for images without depth
    /// layers whose oversampled PSF grid is small enough, else kernels), `"otf"` (always the
    /// whole-image OTF, ISETCam `opticsOTF`; not with depth layers) or `"kernel"` (always tiled
    /// kernels trimmed at `tail_energy`).
    #[serde(default)]
    pub method: BlurMethod,
}

/// How [`crate::Optics::compute`] applies the PSF.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum BlurMethod {
    /// Whole-image OTF when affordable, else kernels.
    #[default]
    Auto,
    /// Whole-image OTF (the padded image's spectrum times the OTF at its frequencies).
    Otf,
    /// Tiled FFT convolution with kernels trimmed at `psf.tail_energy` (plus the far tail,
    /// `psf.far_tail`).
    Kernel,
}

fn yes() -> bool {
    true
}
fn one() -> usize {
    1
}
fn default_tail_energy() -> f64 {
    0.01
}
fn default_max_kernel() -> usize {
    1025
}
fn default_min_pupil() -> usize {
    64
}

impl Default for PsfOptions {
    fn default() -> Self {
        PsfOptions {
            oversampling: 1,
            tail_energy: 0.01,
            max_kernel_size: 1025,
            min_pupil_samples: 64,
            far_tail: true,
            method: BlurMethod::Auto,
        }
    }
}

/// Border handling of the blurred image.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Padding {
    /// Grow by the PSF half-width (default).
    #[default]
    Psf,
    /// Grow by 1/8 of the rows / columns on each side (ISETCam oiCompute).
    Isetcam,
    /// Keep the scene's size.
    None,
}

impl OpticsConfig {
    /// Parse TOML text; `what` (file or preset name) names it in errors.
    pub fn from_toml_str(text: &str, what: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| OpticsError::Parse {
            what: what.to_string(),
            message: e.to_string(),
        })
    }

    /// Read a TOML file; a relative shading file path is resolved against the file's folder.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| OpticsError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let mut c = Self::from_toml_str(&text, &path.display().to_string())?;
        if let ShadingConfig::File(f) = &mut c.shading {
            if f.file.is_relative() {
                if let Some(dir) = path.parent() {
                    f.file = dir.join(&f.file);
                }
            }
        }
        let flare_files = c
            .flare
            .as_mut()
            .into_iter()
            .flat_map(|f| [f.mask.as_mut(), f.phase_mask.as_mut()]);
        for m in c
            .aperture
            .as_mut()
            .and_then(|a| a.mask.as_mut())
            .into_iter()
            .chain(flare_files.flatten())
        {
            if m.is_relative() {
                if let Some(dir) = path.parent() {
                    *m = dir.join(&*m);
                }
            }
        }
        for l in c
            .blur
            .as_mut()
            .into_iter()
            .flat_map(|b| [b.lens_file.as_mut(), b.rtf_file.as_mut()])
            .flatten()
        {
            if l.is_relative() {
                if let Some(dir) = path.parent() {
                    *l = dir.join(&*l);
                }
            }
        }
        Ok(c)
    }

    /// TOML text of this config.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// A built-in preset's config (see [`crate::presets::LENS_PRESETS`]; any case).
    pub fn preset(name: &str) -> Result<Self> {
        let text = crate::presets::toml(name)?;
        Self::from_toml_str(text, &format!("optics preset {name}"))
    }
}
