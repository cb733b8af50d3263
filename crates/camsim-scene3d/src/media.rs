//! Participating media (pbrt-v4, Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th
//! ed., ch. 11): the media of a scene, what a shape's boundary separates, and the medium the
//! camera sits in. What the pbrt-v4 reader (`MakeNamedMedium`, `MediumInterface`) and the TOML
//! overlay (`[render] medium`) produce and what the renderer's volumetric path tracer reads.
//!
//! Units: lengths in metres (world space), so the coefficients are per metre. pbrt-v4 reads
//! them per scene unit; camsim's scene unit is the metre. A medium absorbs with `sigma_a`,
//! scatters with `sigma_s` by the Henyey-Greenstein phase function of asymmetry `g`, and emits:
//! along a path `dL/ds = -(sigma_a + sigma_s) L + sigma_a Le + sigma_s (phase-weighted
//! in-scattered radiance)` (4th ed. eq. 11.13), with `Le` a spectral radiance W/(sr m^2 nm).

use crate::transform::Transform;
use camsim_core::Spectrum;

/// The scene's media and the camera's.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Media {
    /// Every medium, referred to by index ([`crate::scene::Material::MediumInterface`]).
    pub list: Vec<Medium>,
    /// The medium the camera's rays start in (pbrt-v4: the outside medium current at
    /// `Camera`); `None` is vacuum.
    pub camera: Option<usize>,
}

impl Media {
    /// A medium that fills the scene: the camera's medium, which every surface without a
    /// medium boundary leaves unchanged (the `[render] medium` overlay key).
    pub fn fill(&mut self, medium: Medium) {
        self.list.push(medium);
        self.camera = Some(self.list.len() - 1);
    }
}

/// One medium.
#[derive(Debug, Clone, PartialEq)]
pub struct Medium {
    /// The name it was defined with (pbrt-v4 `MakeNamedMedium`), for messages.
    pub name: String,
    /// Henyey-Greenstein asymmetry in (-1, 1): 0 isotropic, > 0 forward scattering.
    pub g: f64,
    pub kind: MediumKind,
}

/// The medium types of pbrt-v4 (4th ed. sec. 11.4).
#[derive(Debug, Clone, PartialEq)]
pub enum MediumKind {
    /// The same coefficients everywhere (pbrt-v4 `homogeneous`), unbounded.
    Homogeneous(Coefficients),
    /// A density grid times spectral coefficients inside a box (pbrt-v4 `uniformgrid`).
    UniformGrid(Box<GridMedium>),
    /// RGB coefficients per grid sample inside a box (pbrt-v4 `rgbgrid`).
    RgbGrid(Box<RgbGridMedium>),
    /// pbrt-v4's procedural `cloud` inside a box.
    Cloud(Box<CloudMedium>),
}

/// Spectral coefficients of a medium: absorption and scattering, 1/m (every `scale` applied),
/// and the emitted radiance `le`, W/(sr m^2 nm), `None` without emission.
#[derive(Debug, Clone, PartialEq)]
pub struct Coefficients {
    pub sigma_a_per_m: Spectrum,
    pub sigma_s_per_m: Spectrum,
    pub le: Option<Spectrum>,
}

/// The box a bounded medium fills: `[p0, p1]` in the medium's own frame, which is the world
/// mapped by `medium_from_world` (the inverse of the CTM at its definition).
#[derive(Debug, Clone, PartialEq)]
pub struct MediumBox {
    pub p0: [f64; 3],
    pub p1: [f64; 3],
    pub medium_from_world: Transform,
}

/// A regular grid of `nx x ny x nz` samples over a [`MediumBox`], x fastest (pbrt-v4
/// `SampledGrid`: sample `(i, j, k)` sits at `((i + 1/2)/nx, (j + 1/2)/ny, (k + 1/2)/nz)` of
/// the box, trilinear in between, zero beyond the outer samples' neighbours).
#[derive(Debug, Clone, PartialEq)]
pub struct GridSize {
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
}

impl GridSize {
    /// Number of samples.
    pub fn count(&self) -> usize {
        self.nx * self.ny * self.nz
    }
}

/// pbrt-v4 `uniformgrid` (`GridMedium`): `sigma = coefficients * density(p)`; the emission is
/// `le * le_scale(p)` (or a blackbody of the temperature grid).
#[derive(Debug, Clone, PartialEq)]
pub struct GridMedium {
    pub bounds: MediumBox,
    pub size: GridSize,
    /// Coefficients per unit density; `le` per unit `le_scale`.
    pub coefficients: Coefficients,
    /// Density samples (dimensionless, >= 0).
    pub density: Vec<f32>,
    /// Emission scale: one value everywhere, or one per sample.
    pub le_scale: Vec<f32>,
    /// `Some`: the emission is `le_scale(p) * B(T(p))` with `B` Planck's law normalised to 1
    /// at its peak (pbrt-v4 `BlackbodySpectrum`), already in W/(sr m^2 nm) per unit scale
    /// (camsim's photometric unit: pbrt-v4's value / 683), and `T = (t - offset) * scale`;
    /// nothing below 100 K.
    pub temperature: Option<TemperatureGrid>,
}

/// A temperature grid (pbrt-v4 `temperature`, `temperatureoffset`, `temperaturescale`).
#[derive(Debug, Clone, PartialEq)]
pub struct TemperatureGrid {
    pub values: Vec<f32>,
    pub offset_k: f64,
    pub scale: f64,
}

/// pbrt-v4 `rgbgrid` (`RGBGridMedium`): linear-sRGB coefficients per sample, each uplifted as
/// an unbounded spectrum (`2m S(rgb / 2m)`, `m` the largest component; pbrt-v4
/// `RGBUnboundedSpectrum`) and interpolated trilinearly; absent grids are 1 everywhere.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbGridMedium {
    pub bounds: MediumBox,
    pub size: GridSize,
    pub sigma_a: Option<Vec<[f32; 3]>>,
    pub sigma_s: Option<Vec<[f32; 3]>>,
    /// Multiplies both grids, 1/m.
    pub sigma_scale_per_m: f64,
    /// Emission per sample as an RGB illuminant (`2m S(rgb / 2m)` times `illuminant`).
    pub le: Option<Vec<[f32; 3]>>,
    /// The colour space's illuminant with every scale applied, W/(sr m^2 nm) per unit RGB.
    pub illuminant: Spectrum,
}

/// pbrt-v4 `cloud` (`CloudMedium`): `sigma = coefficients * d(p)`, with `d` built from
/// `frequency`, `wispiness` and `density` by fractional Brownian motion of Perlin noise in the
/// medium's frame (see `camsim_render`'s media module); no emission.
#[derive(Debug, Clone, PartialEq)]
pub struct CloudMedium {
    pub bounds: MediumBox,
    pub sigma_a_per_m: Spectrum,
    pub sigma_s_per_m: Spectrum,
    pub density: f64,
    pub wispiness: f64,
    pub frequency: f64,
}

/// Measured scattering of a material, per millimetre, in the linear-sRGB channels the
/// publication reports (R, G, B): reduced scattering `sigma_s' = sigma_s (1 - g)` and
/// absorption. pbrt-v4's `preset`s take `sigma_s = sigma_s'` with an isotropic phase function
/// (similarity theory).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScatteringPreset {
    pub name: &'static str,
    pub sigma_s_prime_per_mm: [f64; 3],
    pub sigma_a_per_mm: [f64; 3],
}

/// Jensen, Marschner, Levoy & Hanrahan 2001, "A Practical Model for Subsurface Light
/// Transport", SIGGRAPH 2001, Table 1 ("measured parameters for several materials"): sigma_s'
/// and sigma_a in mm^-1 for the red, green and blue channels, as printed there.
pub const JENSEN_2001: &[ScatteringPreset] = &[
    p("Apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    p("Chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    p("Chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    p("Cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    p("Ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    p("Marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    p("Potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    p("Skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    p("Skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    p("Skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
    p("Spectralon", [11.6, 20.4, 14.9], [0.00, 0.00, 0.00]),
    p("Wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
];

const fn p(name: &'static str, s: [f64; 3], a: [f64; 3]) -> ScatteringPreset {
    ScatteringPreset {
        name,
        sigma_s_prime_per_mm: s,
        sigma_a_per_mm: a,
    }
}

/// The names pbrt-v4 accepts as `preset` that come from Narasimhan, Gupta, Donner,
/// Ramamoorthi, Nayar & Jensen 2006, "Acquiring Scattering Properties of Participating Media by
/// Dilution" (SIGGRAPH 2006, Table 1). camsim does not carry their values (see
/// [`preset`]): these names get a message saying so instead of "unknown".
pub const NARASIMHAN_2006_NAMES: &[&str] = &[
    "Lowfat Milk",
    "Reduced Milk",
    "Regular Milk",
    "Espresso",
    "Mint Mocha Coffee",
    "Lowfat Soy Milk",
    "Regular Soy Milk",
    "Lowfat Chocolate Milk",
    "Regular Chocolate Milk",
    "Coke",
    "Pepsi",
    "Sprite",
    "Gatorade",
    "Chardonnay",
    "White Zinfandel",
    "Merlot",
    "Budweiser Beer",
    "Coors Light Beer",
    "Clorox",
    "Apple Juice",
    "Cranberry Juice",
    "Grape Juice",
    "Ruby Grapefruit Juice",
    "White Grapefruit Juice",
    "Shampoo",
    "Strawberry Shampoo",
    "Head & Shoulders Shampoo",
    "Lemon Tea Powder",
    "Orange Powder",
    "Pink Lemonade Powder",
    "Cappuccino Powder",
    "Salt Powder",
    "Sugar Powder",
    "Suisse Mocha Powder",
    "Pacific Ocean Surface Water",
];

/// A named measured medium: `Ok` with its table entry ([`JENSEN_2001`]), `Err` with the reason
/// for a name pbrt-v4 knows from Narasimhan et al. 2006 (camsim carries only values transcribed
/// from the publication itself, and that table has not been), `None` for an unknown name.
pub fn preset(name: &str) -> Option<Result<&'static ScatteringPreset, String>> {
    if let Some(p) = JENSEN_2001.iter().find(|p| p.name == name) {
        return Some(Ok(p));
    }
    if NARASIMHAN_2006_NAMES.contains(&name) {
        return Some(Err(format!(
            "preset \"{name}\" (Narasimhan et al. 2006) is not carried by camsim: give \"sigma_a\" and \"sigma_s\" instead; camsim's presets are Jensen et al. 2001's: {}",
            preset_names()
        )));
    }
    None
}

/// The preset names camsim carries, comma-separated.
pub fn preset_names() -> String {
    JENSEN_2001
        .iter()
        .map(|p| p.name)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jensen et al. 2001 fitted sigma_s' and sigma_a to measured diffuse reflectance with
    /// their dipole model; the table's values must give back the reflectances the paper's
    /// figures show, i.e. lie in the model's range: 0 <= Rd <= 1 and a white Spectralon
    /// (no absorption) reflects everything. Here: every entry is finite, non-negative, and the
    /// total diffuse reflectance of the dipole (Jensen et al. 2001 eq. for Rd, eta = 1.3) is
    /// ordered as the materials look (ketchup's green and blue far below its red; milk and
    /// marble bright).
    #[test]
    fn jensen_table_is_physical_and_ordered_as_the_materials_look() {
        let eta: f64 = 1.3;
        let fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        let a = (1.0 + fdr) / (1.0 - fdr);
        let rd = |s: f64, k: f64| {
            let alpha = s / (s + k);
            let t = (3.0 * (1.0 - alpha)).sqrt();
            alpha / 2.0 * (1.0 + (-4.0 / 3.0 * a * t).exp()) * (-t).exp()
        };
        for p in JENSEN_2001 {
            for c in 0..3 {
                assert!(p.sigma_s_prime_per_mm[c] > 0.0 && p.sigma_a_per_mm[c] >= 0.0);
            }
        }
        let get = |n: &str| preset(n).unwrap().unwrap();
        let k = get("Ketchup");
        let rk: Vec<f64> = (0..3)
            .map(|c| rd(k.sigma_s_prime_per_mm[c], k.sigma_a_per_mm[c]))
            .collect();
        assert!(rk[0] > 10.0 * rk[1] && rk[1] > rk[2], "{rk:?}");
        let w = get("Wholemilk");
        assert!((0..3).all(|c| rd(w.sigma_s_prime_per_mm[c], w.sigma_a_per_mm[c]) > 0.7));
        let s = get("Spectralon");
        assert!((0..3).all(|c| rd(s.sigma_s_prime_per_mm[c], s.sigma_a_per_mm[c]) > 0.999));
        assert!(preset("Espresso").unwrap().is_err());
        assert!(preset("Tea").is_none());
    }
}
