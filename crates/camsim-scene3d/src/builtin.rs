//! Built-in 3D scenes: the classic Cornell box, the paper's box with a Macbeth ColorChecker, and
//! an ISO 12233 slanted-edge target in the box.
//!
//! # Geometry (all scenes)
//! The Cornell box of the Cornell Program of Computer Graphics "Cornell Box data" page
//! (<https://www.graphics.cornell.edu/online/box/data.html>): a room of about 556 x 548.8 x
//! 559.2 mm with the published vertices (floor, ceiling, back wall, red left wall at x ~ 556 mm,
//! green right wall at x = 0), the light 130 x 105 mm at y = 548.8 mm (x 213-343 mm,
//! z 227-332 mm), the short block (165 mm tall) and the tall block (330 mm tall) with their
//! published vertices, converted to metres. The room's front (z = 0) is open. Differences from
//! the data page: the ceiling is built as four rectangles around the light's rectangle (a hole the
//! size of the light, as the paper's box has), so the light and ceiling never overlap; every
//! surface's winding faces the room's interior (block faces face outward); the light emits
//! downward only (one-sided).
//!
//! The image is right-handed (not mirrored): the red wall is on the image's left, as the
//! photographs show (pbrt files get the same view with `Scale -1 1 1` before `LookAt`).
//!
//! # Spectra
//! - Walls: the Cornell data page's measured diffuse reflectances of the white, green and red
//!   surfaces, 400-700 nm every 4 nm (embedded below from `shared/data/cornell_box_spectra.csv`,
//!   source: Cornell Program of Computer Graphics), held constant outside that range.
//! - Light: the data page's relative spectral radiance 0, 8, 15.6, 18.4 at 400, 500, 600,
//!   700 nm (linear in between, 0 below 400 nm, 18.4 held above 700 nm), scaled to an absolute
//!   luminance [`DEFAULT_LIGHT_LUMINANCE_CD_M2`] (= 683 lm/W * integral y_bar L dl over
//!   360-830 nm): L(lambda) = S(lambda) * L_v / (683 * integral y_bar S dl) W/(sr m^2 nm).
//!   1000 cd/m^2 (a lamp behind a diffuser) for `cornell-box` and `slanted-edge`: the classic
//!   view's mean luminance is then 10.8 cd/m^2 (measured: 64 x 64 pixels, 64 samples). For
//!   `cornell-box-mcc` the default is [`MCC_LIGHT_LUMINANCE_CD_M2`] = 2860 cd/m^2, which puts that
//!   view's mean luminance at the paper's 21.5 cd/m^2 (Fig. 5 caption; measured 7.52 cd/m^2 per
//!   1000 cd/m^2 of light at 128 x 96 pixels, 64 samples). Overlays or [`BuiltinOptions`] change it.
//! - ColorChecker: the 24 Macbeth reflectances of N. Ohta (1997) from
//!   [`camsim_core::tables::macbeth_reflectances`]; the black border and gaps have reflectance 0,
//!   as the paper set them.
//!
//! # Scenes
//! - `cornell-box`: the classic box; camera at (278, 273, -800) mm looking +z with a 35 mm lens
//!   on a 25 mm film (fov 2 atan(12.5/35) = 39.31 degrees), 512 x 512 pixels by default.
//! - `cornell-box-mcc`: the same box and blocks with a ColorChecker against the back wall; the
//!   pixel4a camera (focal length 4.38 mm; sensor 4032 x 3024 pixels of 1.4 um = 5.645 x
//!   4.234 mm; horizontal fov 2 atan(2.8224/4.38) = 65.64 degrees) at (278, 274.4, -600) mm looking
//!   +z, which frames the box's 548.8 mm opening with ~5 % margin. The chart is a ColorChecker
//!   scaled to fit the 0.556 m box at three distinct positions: 28 mm patches on a 33 mm pitch
//!   (5 mm black gaps) with a 6 mm black border, 205 x 139 mm overall (about 0.73 of the
//!   ColorChecker Classic's 279 x 216 mm); its centre is 0.44 m above the floor (above the tall
//!   block as seen from the camera), 2 mm in front of the back wall (the border 1 mm), at x =
//!   0.4235 m (`left`, 30 mm from the red wall), 0.278 m (`center`) or 0.1325 m (`right`, 30 mm from
//!   the green wall), or any (x, y) centre. [`mcc_layout`], [`project_to_raster`] and
//!   [`mcc_corners_px`] give its corners and patch centres in the world and in the image.
//! - `slanted-edge`: the box without blocks (so they cannot hide the target) and a 200 x 200 mm
//!   card, matte black (reflectance 0.05) left of an edge through its centre tilted 5 degrees
//!   clockwise from vertical, matte white (0.9) right of it, facing the camera at z = 0.45 m (behind
//!   the light, so the card is lit from the front), centred at (0.278, 0.30) m; the pixel4a
//!   camera stands `target_distance_m` (default 0.5 m) in front of it, looking +z;
//!   `focus_distance_m` is that distance.
//!
//! Default resolution for the pixel4a scenes: 1008 x 756 (the sensor's 4032 x 3024 / 4); any
//! resolution keeps the sensor's 65.64 degree horizontal fov.

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

use crate::camera::look_at_camera_to_world;
use crate::scene::{
    AreaLight, Camera, Geometry, Material, RenderSettings, SceneDescription, Shape, Texture,
};
use crate::spectra::photometric;
use crate::xform::{cross, dot, inverse, sub};
use camsim_core::names::{NameTable, Named};
use camsim_core::spectrum::Extrapolation;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::{tables, Spectrum, WavelengthGrid};
use std::collections::HashMap;

/// A built-in 3D scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Builtin {
    /// The Cornell box of the Cornell data page.
    CornellBox,
    /// The paper's Cornell box with the ColorChecker, seen by the Pixel 4a camera.
    CornellBoxMcc,
    /// A slanted-edge card in the box (ISO 12233), at `target_distance_m`.
    SlantedEdge,
}

/// The built-in 3D scenes by name (`camsim render --builtin`, `[render] builtin`).
pub const BUILTIN_SCENES: NameTable<Builtin> = NameTable {
    family: "built-in scene",
    entries: &[
        Named {
            name: "cornell-box",
            aliases: &[],
            about: "the Cornell box (Cornell data page geometry and camera)",
            value: Builtin::CornellBox,
        },
        Named {
            name: "cornell-box-mcc",
            aliases: &[],
            about: "the paper's Cornell box with a ColorChecker, Pixel 4a camera",
            value: Builtin::CornellBoxMcc,
        },
        Named {
            name: "slanted-edge",
            aliases: &[],
            about: "an ISO 12233 slanted-edge card in the box",
            value: Builtin::SlantedEdge,
        },
    ],
};

/// Luminance of the built-in light, cd/m^2 (see the module docs).
pub const DEFAULT_LIGHT_LUMINANCE_CD_M2: f64 = 1000.0;

/// Luminance of the `cornell-box-mcc` light, cd/m^2: gives the paper's mean image luminance of
/// 21.5 cd/m^2 (see the module docs).
pub const MCC_LIGHT_LUMINANCE_CD_M2: f64 = 2860.0;

/// Pixel 4a rear camera: focal length, m (the paper's camera).
pub const PIXEL4A_FOCAL_LENGTH_M: f64 = 4.38e-3;
/// Pixel 4a sensor (Sony IMX363): 4032 x 3024 pixels of 1.4 um, width in m.
pub const PIXEL4A_SENSOR_WIDTH_M: f64 = 4032.0 * 1.4e-6;
/// Pixel 4a sensor height, m.
pub const PIXEL4A_SENSOR_HEIGHT_M: f64 = 3024.0 * 1.4e-6;

/// ColorChecker patch side, m.
pub const MCC_PATCH_M: f64 = 0.028;
/// Black gap between patches, m.
pub const MCC_GAP_M: f64 = 0.005;
/// Black border around the patches, m.
pub const MCC_BORDER_M: f64 = 0.006;
/// Height of the chart's centre above the floor, m.
pub const MCC_CENTER_Y_M: f64 = 0.44;

/// Depth of the slanted-edge card (z of its plane), m.
pub const EDGE_TARGET_Z_M: f64 = 0.45;
/// Side of the slanted-edge card, m.
pub const EDGE_TARGET_SIZE_M: f64 = 0.2;
/// Edge angle from vertical, degrees (ISO 12233 recommends about 5).
pub const EDGE_ANGLE_DEG: f64 = 5.0;
/// Reflectance of the dark side of the card.
pub const EDGE_DARK_REFLECTANCE: f64 = 0.05;
/// Reflectance of the light side of the card.
pub const EDGE_LIGHT_REFLECTANCE: f64 = 0.9;

/// Names of the built-in scenes ([`BUILTIN_SCENES`]).
pub fn names() -> Vec<&'static str> {
    BUILTIN_SCENES.names()
}

/// Errors from the built-in scenes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what}: {message}")]
pub struct BuiltinError {
    pub what: String,
    pub message: String,
}

fn berr(what: impl Into<String>, message: impl Into<String>) -> BuiltinError {
    BuiltinError {
        what: what.into(),
        message: message.into(),
    }
}

/// Where the ColorChecker stands against the back wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MccPosition {
    /// Near the red wall (image left).
    Left,
    /// Centred on the back wall.
    Center,
    /// Near the green wall (image right).
    Right,
    /// Chart centre at world (x_m, y_m) on the back wall, m.
    At { x_m: f64, y_m: f64 },
}

impl std::str::FromStr for MccPosition {
    type Err = BuiltinError;
    /// `left`, `center` (or `centre`), `right`, or `X,Y` in metres.
    fn from_str(s: &str) -> Result<Self, BuiltinError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "left" => Ok(MccPosition::Left),
            "center" | "centre" => Ok(MccPosition::Center),
            "right" => Ok(MccPosition::Right),
            other => {
                let v: Vec<f64> = other
                    .split(',')
                    .map(|t| t.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        berr(
                            format!("ColorChecker position '{s}'"),
                            "use left, center, right or X,Y (metres)",
                        )
                    })?;
                match v.as_slice() {
                    [x, y] if x.is_finite() && y.is_finite() => {
                        Ok(MccPosition::At { x_m: *x, y_m: *y })
                    }
                    _ => Err(berr(
                        format!("ColorChecker position '{s}'"),
                        "use left, center, right or X,Y (metres)",
                    )),
                }
            }
        }
    }
}

/// Optional replacements for the box's spectra.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WallSpectra {
    /// Reflectance (fraction) of the white surfaces (walls, floor, ceiling, blocks).
    pub white: Option<Spectrum>,
    /// Reflectance of the red (left) wall.
    pub red: Option<Spectrum>,
    /// Reflectance of the green (right) wall.
    pub green: Option<Spectrum>,
}

/// Options for [`scene`].
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltinOptions {
    /// Image size (width, height) in pixels; None: the scene's default (module docs).
    pub resolution: Option<(usize, usize)>,
    /// Samples per pixel.
    pub samples_per_pixel: u32,
    /// ColorChecker position (`cornell-box-mcc`).
    pub mcc_position: MccPosition,
    /// Camera-to-target distance of `slanted-edge`, m.
    pub target_distance_m: f64,
    /// Output wavelength grid.
    pub grid: WavelengthGrid,
    /// Random seed of the render.
    pub seed: u64,
    /// Relative spectral shape of the light (scaled to `light_luminance_cd_m2`); None: the
    /// Cornell data page's light.
    pub light_spectrum: Option<Spectrum>,
    /// Luminance of the light, cd/m^2; None: [`DEFAULT_LIGHT_LUMINANCE_CD_M2`]
    /// ([`MCC_LIGHT_LUMINANCE_CD_M2`] for `cornell-box-mcc`).
    pub light_luminance_cd_m2: Option<f64>,
    /// Wall reflectance replacements.
    pub wall_spectra: WallSpectra,
}

impl Default for BuiltinOptions {
    fn default() -> Self {
        BuiltinOptions {
            resolution: None,
            samples_per_pixel: 64,
            mcc_position: MccPosition::Center,
            target_distance_m: 0.5,
            grid: WavelengthGrid::default(),
            seed: 0,
            light_spectrum: None,
            light_luminance_cd_m2: None,
            wall_spectra: WallSpectra::default(),
        }
    }
}

/// The Cornell data page's measured reflectances: wavelength (nm), white, green, red (fraction).
/// Source: Cornell University Program of Computer Graphics, "Cornell Box data" page (as in
/// `shared/data/cornell_box_spectra.csv`).
#[rustfmt::skip]
const CORNELL_REFLECTANCE: [[f64; 4]; 76] = [
    [400.0, 0.343, 0.092, 0.04], [404.0, 0.445, 0.096, 0.046], [408.0, 0.551, 0.098, 0.048], [412.0, 0.624,
    0.097, 0.053], [416.0, 0.665, 0.098, 0.049], [420.0, 0.687, 0.095, 0.05], [424.0, 0.708, 0.095, 0.053],
    [428.0, 0.723, 0.097, 0.055], [432.0, 0.715, 0.095, 0.057], [436.0, 0.71, 0.094, 0.056], [440.0, 0.745,
    0.097, 0.059], [444.0, 0.758, 0.098, 0.057], [448.0, 0.739, 0.096, 0.061], [452.0, 0.767, 0.101, 0.061],
    [456.0, 0.777, 0.103, 0.06], [460.0, 0.765, 0.104, 0.062], [464.0, 0.751, 0.107, 0.062], [468.0, 0.745,
    0.109, 0.062], [472.0, 0.748, 0.112, 0.061], [476.0, 0.729, 0.115, 0.062], [480.0, 0.745, 0.125, 0.06],
    [484.0, 0.757, 0.14, 0.059], [488.0, 0.753, 0.16, 0.057], [492.0, 0.75, 0.187, 0.058], [496.0, 0.746,
    0.229, 0.058], [500.0, 0.747, 0.285, 0.058], [504.0, 0.735, 0.343, 0.056], [508.0, 0.732, 0.39, 0.055],
    [512.0, 0.739, 0.435, 0.056], [516.0, 0.734, 0.464, 0.059], [520.0, 0.725, 0.472, 0.057], [524.0, 0.721,
    0.476, 0.055], [528.0, 0.733, 0.481, 0.059], [532.0, 0.725, 0.462, 0.059], [536.0, 0.732, 0.447, 0.058],
    [540.0, 0.743, 0.441, 0.059], [544.0, 0.744, 0.426, 0.061], [548.0, 0.748, 0.406, 0.061], [552.0, 0.728,
    0.373, 0.063], [556.0, 0.716, 0.347, 0.063], [560.0, 0.733, 0.337, 0.067], [564.0, 0.726, 0.314, 0.068],
    [568.0, 0.713, 0.285, 0.072], [572.0, 0.74, 0.277, 0.08], [576.0, 0.754, 0.266, 0.09], [580.0, 0.764,
    0.25, 0.099], [584.0, 0.752, 0.23, 0.124], [588.0, 0.736, 0.207, 0.154], [592.0, 0.734, 0.186, 0.192],
    [596.0, 0.741, 0.171, 0.255], [600.0, 0.74, 0.16, 0.287], [604.0, 0.732, 0.148, 0.349], [608.0, 0.745,
    0.141, 0.402], [612.0, 0.755, 0.136, 0.443], [616.0, 0.751, 0.13, 0.487], [620.0, 0.744, 0.126, 0.513],
    [624.0, 0.731, 0.123, 0.558], [628.0, 0.733, 0.121, 0.584], [632.0, 0.744, 0.122, 0.62], [636.0, 0.731,
    0.119, 0.606], [640.0, 0.712, 0.114, 0.609], [644.0, 0.708, 0.115, 0.651], [648.0, 0.729, 0.117, 0.612],
    [652.0, 0.73, 0.117, 0.61], [656.0, 0.727, 0.118, 0.65], [660.0, 0.707, 0.12, 0.638], [664.0, 0.703,
    0.122, 0.627], [668.0, 0.729, 0.128, 0.62], [672.0, 0.75, 0.132, 0.63], [676.0, 0.76, 0.139, 0.628],
    [680.0, 0.751, 0.144, 0.642], [684.0, 0.739, 0.146, 0.639], [688.0, 0.724, 0.15, 0.657], [692.0, 0.73,
    0.152, 0.639], [696.0, 0.74, 0.157, 0.635], [700.0, 0.737, 0.159, 0.642],
];

/// The Cornell data page's light: relative spectral radiance at 400, 500, 600, 700 nm.
pub const CORNELL_LIGHT_POINTS: [(f64, f64); 4] =
    [(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)];

/// A Cornell box reflectance by name: `white`, `green` or `red` (400-700 nm every 4 nm, held
/// outside).
pub fn cornell_reflectance(name: &str) -> Result<Spectrum, BuiltinError> {
    let col = match name {
        "white" => 1,
        "green" => 2,
        "red" => 3,
        _ => {
            return Err(berr(
                format!("Cornell box surface '{name}'"),
                "use white, green or red",
            ))
        }
    };
    let pairs: Vec<(f64, f64)> = CORNELL_REFLECTANCE.iter().map(|r| (r[0], r[col])).collect();
    Ok(Spectrum::from_pairs(&pairs).with_extrapolation(Extrapolation::Hold))
}

/// The Cornell data page's light spectrum (relative; 0 below 400 nm, 18.4 held above 700 nm).
pub fn cornell_light_relative() -> Spectrum {
    let mut pairs = vec![(300.0, 0.0)];
    pairs.extend_from_slice(&CORNELL_LIGHT_POINTS);
    Spectrum::from_pairs(&pairs).with_extrapolation(Extrapolation::Hold)
}

/// Scale a relative spectrum to spectral radiance (W/(sr m^2 nm)) of luminance `cd_m2`:
/// `L_v = 683 lm/W * integral y_bar L dl` (CIE photopic luminance; 1-nm sum over 360-830 nm).
pub fn spectrum_at_luminance(relative: &Spectrum, cd_m2: f64) -> Result<Spectrum, BuiltinError> {
    let p = photometric(relative);
    if !(p > 0.0) {
        return Err(berr(
            "light spectrum",
            "has no luminance (zero over 360-830 nm)",
        ));
    }
    if !(cd_m2 >= 0.0 && cd_m2.is_finite()) {
        return Err(berr(
            "light luminance",
            format!("{cd_m2} cd/m^2 must be a non-negative number"),
        ));
    }
    Ok(relative
        .clone()
        .scaled(cd_m2 / (LUMINOUS_EFFICACY_LM_PER_W * p)))
}

/// Luminance (cd/m^2) of a spectral radiance in W/(sr m^2 nm).
pub fn luminance_cd_m2(radiance: &Spectrum) -> f64 {
    LUMINOUS_EFFICACY_LM_PER_W * photometric(radiance)
}

const MM: f64 = 1e-3;

/// Scene under construction.
struct Builder {
    shapes: Vec<Shape>,
    materials: Vec<Material>,
    named: HashMap<String, usize>,
}

impl Builder {
    fn material(&mut self, name: &str, reflectance: Spectrum) -> usize {
        self.materials.push(Material::Diffuse {
            reflectance: Texture::Constant(reflectance),
        });
        let i = self.materials.len() - 1;
        self.named.insert(name.to_string(), i);
        i
    }
    /// A planar-ish quad (p0 p1 p2 p3 around its perimeter, metres) as two triangles, wound so
    /// its normal points toward `toward`.
    fn quad(
        &mut self,
        name: &str,
        p: [[f64; 3]; 4],
        toward: [f64; 3],
        material: usize,
        light: Option<AreaLight>,
    ) {
        let c = [
            0.25 * (p[0][0] + p[1][0] + p[2][0] + p[3][0]),
            0.25 * (p[0][1] + p[1][1] + p[2][1] + p[3][1]),
            0.25 * (p[0][2] + p[1][2] + p[2][2] + p[3][2]),
        ];
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        let mut indices = vec![[0, 1, 2], [0, 2, 3]];
        if dot(n, sub(toward, c)) < 0.0 {
            indices = vec![[0, 2, 1], [0, 3, 2]];
        }
        self.shapes.push(Shape {
            name: Some(name.to_string()),
            geometry: Geometry::mesh(p.to_vec(), indices, None, None),
            material,
            area_light: light,
            reverse_orientation: false,
            tags: Default::default(),
        });
    }
    /// Append a quad's triangles to an existing named shape (multi-part walls).
    fn extend_last(&mut self, p: [[f64; 3]; 4], toward: [f64; 3]) {
        let Some(Shape {
            geometry: Geometry::Triangles {
                positions, indices, ..
            },
            ..
        }) = self.shapes.last_mut()
        else {
            return;
        };
        let b = positions.len() as u32;
        let c = [
            0.25 * (p[0][0] + p[1][0] + p[2][0] + p[3][0]),
            0.25 * (p[0][1] + p[1][1] + p[2][1] + p[3][1]),
            0.25 * (p[0][2] + p[1][2] + p[2][2] + p[3][2]),
        ];
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        positions.extend_from_slice(&p);
        if dot(n, sub(toward, c)) < 0.0 {
            indices.extend_from_slice(&[[b, b + 2, b + 1], [b, b + 3, b + 2]]);
        } else {
            indices.extend_from_slice(&[[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
    }
}

fn mm(v: [f64; 3]) -> [f64; 3] {
    [v[0] * MM, v[1] * MM, v[2] * MM]
}

/// Room centre, m (walls face it).
const ROOM_CENTER: [f64; 3] = [0.278, 0.2744, 0.2796];

/// The light's rectangle on the ceiling, mm (x0, x1, z0, z1) (Cornell data page).
const LIGHT_MM: (f64, f64, f64, f64) = (213.0, 343.0, 227.0, 332.0);
const CEILING_Y_MM: f64 = 548.8;

/// The box shell (walls, floor, ceiling with the light's hole, light) and optionally the blocks.
fn build_box(
    b: &mut Builder,
    opts: &BuiltinOptions,
    with_blocks: bool,
    default_luminance_cd_m2: f64,
) -> Result<(), BuiltinError> {
    let white = opts
        .wall_spectra
        .white
        .clone()
        .map(Ok)
        .unwrap_or_else(|| cornell_reflectance("white"))?;
    let red = opts
        .wall_spectra
        .red
        .clone()
        .map(Ok)
        .unwrap_or_else(|| cornell_reflectance("red"))?;
    let green = opts
        .wall_spectra
        .green
        .clone()
        .map(Ok)
        .unwrap_or_else(|| cornell_reflectance("green"))?;
    for (n, s) in [("white", &white), ("red", &red), ("green", &green)] {
        s.require_non_negative(n)
            .map_err(|e| berr(format!("{n} reflectance"), e.to_string()))?;
    }
    let w = b.material("white", white);
    let r = b.material("red", red);
    let g = b.material("green", green);
    let c = ROOM_CENTER;
    // Cornell data page vertices (mm).
    b.quad(
        "floor",
        [
            mm([552.8, 0.0, 0.0]),
            mm([0.0, 0.0, 0.0]),
            mm([0.0, 0.0, 559.2]),
            mm([549.6, 0.0, 559.2]),
        ],
        c,
        w,
        None,
    );
    b.quad(
        "back_wall",
        [
            mm([549.6, 0.0, 559.2]),
            mm([0.0, 0.0, 559.2]),
            mm([0.0, 548.8, 559.2]),
            mm([556.0, 548.8, 559.2]),
        ],
        c,
        w,
        None,
    );
    b.quad(
        "right_wall",
        [
            mm([0.0, 0.0, 559.2]),
            mm([0.0, 0.0, 0.0]),
            mm([0.0, 548.8, 0.0]),
            mm([0.0, 548.8, 559.2]),
        ],
        c,
        g,
        None,
    );
    b.quad(
        "left_wall",
        [
            mm([552.8, 0.0, 0.0]),
            mm([549.6, 0.0, 559.2]),
            mm([556.0, 548.8, 559.2]),
            mm([556.0, 548.8, 0.0]),
        ],
        c,
        r,
        None,
    );
    // Ceiling (data page: 556 x 559.2 mm at y = 548.8) around the light's rectangle.
    let (x0, x1, z0, z1) = LIGHT_MM;
    let y = CEILING_Y_MM;
    b.quad(
        "ceiling",
        [
            mm([556.0, y, 0.0]),
            mm([556.0, y, z0]),
            mm([0.0, y, z0]),
            mm([0.0, y, 0.0]),
        ],
        c,
        w,
        None,
    );
    b.extend_last(
        [
            mm([556.0, y, z1]),
            mm([556.0, y, 559.2]),
            mm([0.0, y, 559.2]),
            mm([0.0, y, z1]),
        ],
        c,
    );
    b.extend_last(
        [
            mm([556.0, y, z0]),
            mm([556.0, y, z1]),
            mm([x1, y, z1]),
            mm([x1, y, z0]),
        ],
        c,
    );
    b.extend_last(
        [
            mm([x0, y, z0]),
            mm([x0, y, z1]),
            mm([0.0, y, z1]),
            mm([0.0, y, z0]),
        ],
        c,
    );
    // The light: one-sided, emitting downward.
    let relative = opts
        .light_spectrum
        .clone()
        .unwrap_or_else(cornell_light_relative);
    relative
        .require_non_negative("light spectrum")
        .map_err(|e| berr("light spectrum", e.to_string()))?;
    let radiance = spectrum_at_luminance(
        &relative,
        opts.light_luminance_cd_m2
            .unwrap_or(default_luminance_cd_m2),
    )?;
    b.quad(
        "light",
        [
            mm([x1, y, z0]),
            mm([x1, y, z1]),
            mm([x0, y, z1]),
            mm([x0, y, z0]),
        ],
        [0.278, 0.0, 0.2795],
        w,
        Some(AreaLight {
            radiance,
            two_sided: false,
            image: None,
        }),
    );
    if with_blocks {
        // Short block (data page), faces outward from its centre.
        let top = [
            [130.0, 165.0, 65.0],
            [82.0, 165.0, 225.0],
            [240.0, 165.0, 272.0],
            [290.0, 165.0, 114.0],
        ];
        block(b, "short_block", top, 165.0, w);
        let top = [
            [423.0, 330.0, 247.0],
            [265.0, 330.0, 296.0],
            [314.0, 330.0, 456.0],
            [472.0, 330.0, 406.0],
        ];
        block(b, "tall_block", top, 330.0, w);
    }
    Ok(())
}

/// A block from its top face's four corners (mm) and height: top + four sides, one shape.
fn block(b: &mut Builder, name: &str, top: [[f64; 3]; 4], height_mm: f64, material: usize) {
    let ctr = {
        let s = top
            .iter()
            .fold([0.0; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]]);
        mm([s[0] / 4.0, height_mm / 2.0, s[2] / 4.0])
    };
    let away = |p: [[f64; 3]; 4]| {
        let fc = [
            0.25 * (p[0][0] + p[1][0] + p[2][0] + p[3][0]),
            0.25 * (p[0][1] + p[1][1] + p[2][1] + p[3][1]),
            0.25 * (p[0][2] + p[1][2] + p[2][2] + p[3][2]),
        ];
        [
            2.0 * fc[0] - ctr[0],
            2.0 * fc[1] - ctr[1],
            2.0 * fc[2] - ctr[2],
        ]
    };
    let t: Vec<[f64; 3]> = top.iter().map(|p| mm(*p)).collect();
    let q = [t[0], t[1], t[2], t[3]];
    b.quad(name, q, away(q), material, None);
    for i in 0..4 {
        let a = t[i];
        let c = t[(i + 1) % 4];
        let side = [[a[0], 0.0, a[2]], a, c, [c[0], 0.0, c[2]]];
        b.extend_last(side, away(side));
    }
}

/// Camera at `from` looking +z, right-handed view, fov from the pixel4a sensor: 65.64 degrees
/// horizontally whatever the resolution's aspect.
fn pixel4a_camera(from: [f64; 3], width: usize, height: usize) -> Result<Camera, BuiltinError> {
    let c2w = look_at_camera_to_world(
        from,
        [from[0], from[1], from[2] + 1.0],
        [0.0, 1.0, 0.0],
        true,
    )
    .ok_or_else(|| berr("camera", "degenerate look-at"))?;
    let tan_h = PIXEL4A_SENSOR_WIDTH_M / (2.0 * PIXEL4A_FOCAL_LENGTH_M); // pinhole: tan(fov/2) = (w/2)/f
    let tan_short = if width >= height {
        tan_h * height as f64 / width as f64
    } else {
        tan_h
    };
    Ok(Camera {
        camera_to_world: c2w,
        fov_deg: 2.0 * tan_short.atan().to_degrees(),
        width,
        height,
        lens: None,
    })
}

fn check_resolution(r: (usize, usize)) -> Result<(usize, usize), BuiltinError> {
    if r.0 == 0 || r.1 == 0 || r.0 > 1 << 16 || r.1 > 1 << 16 {
        return Err(berr(
            "resolution",
            format!(
                "{} x {} pixels is out of range (1..65536 per side)",
                r.0, r.1
            ),
        ));
    }
    Ok(r)
}

/// The pixel4a camera position of `cornell-box-mcc`, m.
pub const MCC_CAMERA_POSITION_M: [f64; 3] = [0.278, 0.2744, -0.60];

/// Build a built-in scene by name ([`BUILTIN_SCENES`]).
pub fn scene(name: &str, opts: &BuiltinOptions) -> Result<SceneDescription, BuiltinError> {
    let which = BUILTIN_SCENES
        .get(name)
        .map_err(|e| berr("builtin", e.to_string()))?;
    opts.grid
        .validate()
        .map_err(|e| berr("wavelength grid", e.to_string()))?;
    if opts.samples_per_pixel == 0 {
        return Err(berr("samples_per_pixel", "must be at least 1"));
    }
    let mut b = Builder {
        shapes: Vec::new(),
        materials: Vec::new(),
        named: HashMap::new(),
    };
    let (camera, focus) = match which {
        Builtin::CornellBox => {
            build_box(&mut b, opts, true, DEFAULT_LIGHT_LUMINANCE_CD_M2)?;
            let (w, h) = check_resolution(opts.resolution.unwrap_or((512, 512)))?;
            // Data page camera: 35 mm lens, 25 x 25 mm film -> fov 2 atan(12.5 / 35) on the short side.
            let from = [0.278, 0.273, -0.8];
            let c2w = look_at_camera_to_world(from, [0.278, 0.273, 0.0], [0.0, 1.0, 0.0], true)
                .ok_or_else(|| berr("camera", "degenerate"))?;
            let fov_deg = 2.0 * (12.5f64 / 35.0).atan().to_degrees();
            (
                Camera {
                    camera_to_world: c2w,
                    fov_deg,
                    width: w,
                    height: h,
                    lens: None,
                },
                0.8 + 0.5592,
            )
        }
        Builtin::CornellBoxMcc => {
            build_box(&mut b, opts, true, MCC_LIGHT_LUMINANCE_CD_M2)?;
            let layout = mcc_layout(&opts.mcc_position)?;
            add_mcc(&mut b, &layout);
            let (w, h) = check_resolution(opts.resolution.unwrap_or((1008, 756)))?;
            let cam = pixel4a_camera(MCC_CAMERA_POSITION_M, w, h)?;
            (cam, layout.center[2] - MCC_CAMERA_POSITION_M[2])
        }
        Builtin::SlantedEdge => {
            let d = opts.target_distance_m;
            if !(d > 0.05 && d < 100.0) {
                return Err(berr(
                    "target_distance_m",
                    format!("{d} m must be between 0.05 and 100"),
                ));
            }
            build_box(&mut b, opts, false, DEFAULT_LIGHT_LUMINANCE_CD_M2)?;
            add_edge_target(&mut b);
            let (w, h) = check_resolution(opts.resolution.unwrap_or((1008, 756)))?;
            let cam = pixel4a_camera([0.278, 0.30, EDGE_TARGET_Z_M - d], w, h)?;
            (cam, d)
        }
    };
    Ok(SceneDescription {
        camera,
        shapes: b.shapes,
        materials: b.materials,
        named_materials: b.named,
        lights: Vec::new(),
        settings: RenderSettings {
            grid: opts.grid,
            samples_per_pixel: opts.samples_per_pixel,
            seed: opts.seed,
            max_depth: 8,
            ..RenderSettings::default()
        },
        focus_distance_m: Some(focus),
        notes: Vec::new(),
        media: Default::default(),
        light_groups: Vec::new(),
    })
}

/// Where the ColorChecker is, in world coordinates (m).
#[derive(Debug, Clone, PartialEq)]
pub struct MccLayout {
    /// Chart centre (on its patch plane).
    pub center: [f64; 3],
    /// Outer corners of the black border as seen from the camera: top-left, top-right,
    /// bottom-right, bottom-left.
    pub corners: [[f64; 3]; 4],
    /// Patch centres in chart order (1 dark skin ... 24 black; row by row from the top left).
    pub patch_centers: [[f64; 3]; 24],
    /// Patch side, m.
    pub patch_m: f64,
    /// Chart width and height, m.
    pub size_m: (f64, f64),
}

/// The ColorChecker's layout for a position (see the module docs).
pub fn mcc_layout(pos: &MccPosition) -> Result<MccLayout, BuiltinError> {
    let pitch = MCC_PATCH_M + MCC_GAP_M;
    let width = 6.0 * MCC_PATCH_M + 5.0 * MCC_GAP_M + 2.0 * MCC_BORDER_M;
    let height = 4.0 * MCC_PATCH_M + 3.0 * MCC_GAP_M + 2.0 * MCC_BORDER_M;
    let margin = 0.03;
    let (cx, cy) = match *pos {
        MccPosition::Left => (0.556 - margin - width / 2.0, MCC_CENTER_Y_M),
        MccPosition::Center => (0.278, MCC_CENTER_Y_M),
        MccPosition::Right => (margin + width / 2.0, MCC_CENTER_Y_M),
        MccPosition::At { x_m, y_m } => (x_m, y_m),
    };
    if !(cx - width / 2.0 >= 0.0
        && cx + width / 2.0 <= 0.5496
        && cy - height / 2.0 >= 0.0
        && cy + height / 2.0 <= 0.5488)
    {
        return Err(berr(
            "ColorChecker position",
            format!("a {:.3} x {:.3} m chart centred at ({cx}, {cy}) m does not fit on the back wall (x 0-0.5496, y 0-0.5488 m)", width, height),
        ));
    }
    let z = 0.5592 - 0.002;
    // Image left is world +x (right-handed view looking +z).
    let mut centers = [[0.0; 3]; 24];
    for r in 0..4 {
        for c in 0..6 {
            centers[r * 6 + c] = [
                cx + (2.5 - c as f64) * pitch,
                cy + (1.5 - r as f64) * pitch,
                z,
            ];
        }
    }
    let (hw, hh) = (width / 2.0, height / 2.0);
    Ok(MccLayout {
        center: [cx, cy, z],
        corners: [
            [cx + hw, cy + hh, z],
            [cx - hw, cy + hh, z],
            [cx - hw, cy - hh, z],
            [cx + hw, cy - hh, z],
        ],
        patch_centers: centers,
        patch_m: MCC_PATCH_M,
        size_m: (width, height),
    })
}

fn add_mcc(b: &mut Builder, l: &MccLayout) {
    let toward = [l.center[0], l.center[1], -1.0];
    let refl = tables::macbeth_reflectances();
    for (i, (c, r)) in l.patch_centers.iter().zip(refl).enumerate() {
        let m = b.material(&format!("mcc_{:02}", i + 1), r);
        let h = MCC_PATCH_M / 2.0;
        b.quad(
            &format!("mcc_patch_{:02}", i + 1),
            [
                [c[0] + h, c[1] + h, c[2]],
                [c[0] - h, c[1] + h, c[2]],
                [c[0] - h, c[1] - h, c[2]],
                [c[0] + h, c[1] - h, c[2]],
            ],
            toward,
            m,
            None,
        );
    }
    // Black border and gaps: one board 1 mm behind the patches, reflectance 0 (as the paper).
    let m = b.material(
        "mcc_black",
        Spectrum::from_pairs(&[(300.0, 0.0), (1100.0, 0.0)])
            .with_extrapolation(Extrapolation::Hold),
    );
    let z = l.center[2] + 0.001;
    let c = l.corners;
    b.quad(
        "mcc_frame",
        [
            [c[0][0], c[0][1], z],
            [c[1][0], c[1][1], z],
            [c[2][0], c[2][1], z],
            [c[3][0], c[3][1], z],
        ],
        toward,
        m,
        None,
    );
}

fn add_edge_target(b: &mut Builder) {
    let dark = b.material(
        "target_black",
        Spectrum::from_pairs(&[
            (300.0, EDGE_DARK_REFLECTANCE),
            (1100.0, EDGE_DARK_REFLECTANCE),
        ])
        .with_extrapolation(Extrapolation::Hold),
    );
    let light = b.material(
        "target_white",
        Spectrum::from_pairs(&[
            (300.0, EDGE_LIGHT_REFLECTANCE),
            (1100.0, EDGE_LIGHT_REFLECTANCE),
        ])
        .with_extrapolation(Extrapolation::Hold),
    );
    let (cx, cy, z) = (0.278, 0.30, EDGE_TARGET_Z_M);
    let h = EDGE_TARGET_SIZE_M / 2.0;
    let t = EDGE_ANGLE_DEG.to_radians().tan();
    // (u, v): image right, image up; image right is world -x.
    let p = |u: f64, v: f64| [cx - u, cy + v, z];
    let toward = [cx, cy, z - 1.0];
    // Edge from (-h t, -h) to (h t, h): tilted clockwise from vertical by EDGE_ANGLE_DEG.
    b.quad(
        "target_black",
        [p(-h, -h), p(-h * t, -h), p(h * t, h), p(-h, h)],
        toward,
        dark,
        None,
    );
    b.quad(
        "target_white",
        [p(-h * t, -h), p(h, -h), p(h, h), p(h * t, h)],
        toward,
        light,
        None,
    );
}

/// Continuous raster position (x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) of the
/// world point `p` seen by `camera` (pbrt-v4 perspective projection, fov on the shorter axis);
/// None behind the camera.
pub fn project_to_raster(camera: &Camera, p: [f64; 3]) -> Option<[f64; 2]> {
    let w2c = inverse(&camera.camera_to_world)?;
    let pc = w2c.apply_point(p);
    if !(pc[2] > 0.0) {
        return None;
    }
    let tan_half = (camera.fov_deg.to_radians() / 2.0).tan();
    let aspect = camera.width as f64 / camera.height as f64;
    let (sx, sy) = if aspect > 1.0 {
        (aspect, 1.0)
    } else {
        (1.0, 1.0 / aspect)
    };
    let x = (pc[0] / (pc[2] * tan_half * sx) + 1.0) / 2.0 * camera.width as f64;
    let y = (1.0 - pc[1] / (pc[2] * tan_half * sy)) / 2.0 * camera.height as f64;
    Some([x, y])
}

/// The ColorChecker's outer corners in the image of `cornell-box-mcc` with `opts` (top-left,
/// top-right, bottom-right, bottom-left; raster coordinates as [`project_to_raster`]).
pub fn mcc_corners_px(opts: &BuiltinOptions) -> Result<[[f64; 2]; 4], BuiltinError> {
    let s = scene("cornell-box-mcc", opts)?;
    let l = mcc_layout(&opts.mcc_position)?;
    let mut out = [[0.0; 2]; 4];
    for (o, c) in out.iter_mut().zip(l.corners) {
        *o = project_to_raster(&s.camera, c)
            .ok_or_else(|| berr("ColorChecker", "behind the camera"))?;
    }
    Ok(out)
}

/// The 24 patch centres in the image of `cornell-box-mcc` with `opts`, chart order, and the
/// patch side in pixels at the chart's distance.
pub fn mcc_patch_centers_px(opts: &BuiltinOptions) -> Result<(Vec<[f64; 2]>, f64), BuiltinError> {
    let s = scene("cornell-box-mcc", opts)?;
    mcc_patch_centers_on(&s.camera, &opts.mcc_position)
}

/// [`mcc_patch_centers_px`] seen through any `camera` (e.g. the built-in camera after the
/// pipeline matched its field of view to a sensor): the 24 patch centres in raster coordinates
/// and the patch side in pixels.
pub fn mcc_patch_centers_on(
    camera: &Camera,
    position: &MccPosition,
) -> Result<(Vec<[f64; 2]>, f64), BuiltinError> {
    let l = mcc_layout(position)?;
    let pts: Option<Vec<[f64; 2]>> = l
        .patch_centers
        .iter()
        .map(|c| project_to_raster(camera, *c))
        .collect();
    let pts = pts.ok_or_else(|| berr("ColorChecker", "behind the camera"))?;
    let c0 = l.patch_centers[0];
    let a =
        project_to_raster(camera, [c0[0] + MCC_PATCH_M / 2.0, c0[1], c0[2]]).unwrap_or([0.0; 2]);
    let bpx =
        project_to_raster(camera, [c0[0] - MCC_PATCH_M / 2.0, c0[1], c0[2]]).unwrap_or([0.0; 2]);
    Ok((pts, (bpx[0] - a[0]).abs()))
}
