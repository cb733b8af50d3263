//! camsim stage 1 (2D): test charts -> spectral radiance, like ISETCam's `sceneCreate`.
//!
//! A scene is a flat chart at `distance_m` from the lens that spans a horizontal field of view of
//! `fov_deg`. Its spectral radiance, in W/(sr m^2 nm), is the illuminant (relative SPD) times the
//! surface reflectance, scaled so that the mean luminance over all pixels equals the requested
//! value (ISETCam `sceneAdjustLuminance`):
//!
//! `L_v = 683 lm/W * sum_lambda y_bar(lambda) L(lambda) d_lambda`, averaged over pixels.
//!
//! Kinds ([`SceneConfig`]): `uniform`, `macbeth` (ColorChecker, N. Ohta's reflectances or any set
//! of 24 from a file), `slanted_edge` (ISO 12233), `file` (a spectral radiance OpenEXR, see
//! [`from_image`]), `rgb` (a photograph on a display model, [`rgb`] and [`display`]) and the
//! ISETCam test patterns of [`patterns`] (`harmonic`, `zone_plate`, `sweep_frequency`, `star`,
//! `checkerboard`, `grid_lines`, `point_array`, `ramp`, `dead_leaves`) and `glare_target` (the
//! ISO 18844 veiling glare target), `hdr_chart` and `hdr_lights` (ISETCam's HDR chart and lights).

#![warn(missing_docs)]
// `!(x > 0.0)` is used on purpose: it rejects NaN along with the out-of-range values.

pub mod config;
pub mod display;
pub mod geometry;
pub mod patterns;
pub mod rgb;

pub use config::{
    FileScene, FileUnits, MacbethScene, Reflectance, SceneConfig, SlantedEdgeScene, UniformScene,
};
pub use display::{Display, Transfer};
pub use geometry::{Edge, MacbethLayout, Rect};
pub use patterns::{
    CheckerboardScene, DeadLeavesScene, GlareTargetScene, GridLinesScene, HarmonicScene,
    HdrChartScene, HdrLightsScene, PointArrayScene, RampScene, StarScene, SweepFrequencyScene,
    ZonePlateScene,
};
pub use rgb::RgbScene;

use camsim_core::colorimetry::Cmfs;
use camsim_core::error::{CoreError, Result};
use camsim_core::spectrum::Extrapolation;
use camsim_core::{tables, Quantity, SpectralImage, Spectrum, WavelengthGrid};
use rayon::prelude::*;
use std::path::Path;

/// A string names a spectrum file (rather than a built-in table) when it has a path separator or a
/// file extension.
pub(crate) fn looks_like_file(s: &str) -> bool {
    camsim_core::tables::illuminant(s).is_err()
        && (s.contains('/') || s.contains('\\') || std::path::Path::new(s).extension().is_some())
}

/// Build the spectral radiance image of a scene on `grid`. `file` scenes read their OpenEXR
/// ([`from_image`]) and `rgb` scenes their photograph through camsim-io.
///
/// The result has `quantity = Radiance` (W/(sr m^2 nm)), `sample_spacing_m = 2 d tan(fov/2) / cols`
/// (ISETCam `sceneGet(scene, 'sample spacing')`), and `geometry.fov_deg` / `distance_m` set.
pub fn create(cfg: &SceneConfig, grid: &WavelengthGrid) -> Result<SpectralImage> {
    grid.validate()?;
    match cfg {
        SceneConfig::Uniform(c) => create_uniform(c, grid),
        SceneConfig::Macbeth(c) => create_macbeth(c, grid),
        SceneConfig::SlantedEdge(c) => create_slanted_edge(c, grid),
        SceneConfig::File(c) => {
            use camsim_io::exr::SourceUnits;
            let units = match c.units {
                config::FileUnits::Auto => SourceUnits::Auto,
                config::FileUnits::PbrtV4 => SourceUnits::PbrtV4,
                config::FileUnits::Absolute => SourceUnits::Absolute,
            };
            let (img, info) = camsim_io::exr::read_spectral_exr_as(&c.path, units)
                .map_err(|e| CoreError::invalid("scene.path", e.to_string()))?;
            let mut c = c.clone();
            if c.fov_deg.is_none() && !info.sample_spacing_known {
                // A file without camsim's geometry (pbrt-v4's, another renderer's): its field of
                // view comes from pbrt-v4's camera matrices, or must be given.
                if img.geometry.fov_deg > 0.0 {
                    c.fov_deg = Some(img.geometry.fov_deg);
                } else {
                    return Err(CoreError::invalid(
                        "scene.fov_deg",
                        format!(
                            "{} carries no field of view (no camsimSampleSpacingM, no pbrt-v4 worldToCamera and worldToNDC): set scene.fov_deg (horizontal, degrees)",
                            c.path.display()
                        ),
                    ));
                }
            }
            from_image(&c, img)
        }
        SceneConfig::Rgb(c) => rgb::create_rgb(c, grid),
        c => match c.pattern() {
            Some(p) => patterns::create_pattern(p, grid),
            None => unreachable!("every other kind is a pattern"),
        },
    }
}

/// The 24 patch rectangles of a ColorChecker scene in chart order (pixels of the scene image).
pub fn macbeth_patch_rects(cfg: &MacbethScene) -> Vec<Rect> {
    cfg.layout().patch_rects()
}

/// The illuminant of a scene config (relative SPD), or `None` for `file` scenes.
pub fn scene_illuminant(cfg: &SceneConfig) -> Option<Result<Spectrum>> {
    match cfg {
        SceneConfig::Uniform(c) => Some(load_illuminant(&c.illuminant, "scene.illuminant")),
        SceneConfig::Macbeth(c) => Some(load_illuminant(&c.illuminant, "scene.illuminant")),
        SceneConfig::SlantedEdge(c) => Some(load_illuminant(&c.illuminant, "scene.illuminant")),
        SceneConfig::File(_) | SceneConfig::Rgb(_) => None,
        c => c
            .pattern()
            .map(|p| load_illuminant(p.header().illuminant, "scene.illuminant")),
    }
}

/// An illuminant by built-in name ([`camsim_core::tables::illuminant`]: D65, A, C, F2, F11, E,
/// `blackbody-<K>`) or from a spectrum file (`.csv` or ISETCam `.mat`). `key` names the config key
/// in errors. Relative units.
pub fn load_illuminant(name: &str, key: &str) -> Result<Spectrum> {
    if looks_like_file(name) {
        let s = load_spectrum_file(Path::new(name), key)?;
        s.require_non_negative(&format!("{key} = '{name}'"))?;
        return Ok(s);
    }
    tables::illuminant(name).map_err(|e| CoreError::invalid(key, e.to_string()))
}

/// Read one spectrum from a spectrum file: CSV or ISETCam MATLAB v5 `.mat` (by extension,
/// [`camsim_core::spectrum_csv::load_spectra`]). `spec` is a path, optionally followed by
/// `#<column name>` to pick a column; without it the file's first spectrum is used. `key` names
/// the config key in errors.
pub fn load_spectrum_file(spec: &Path, key: &str) -> Result<Spectrum> {
    let text = spec.to_string_lossy();
    let (path, column) = match text.rsplit_once('#') {
        Some((p, c)) if !c.contains('/') && !c.contains('\\') => (Path::new(p), Some(c)),
        _ => (spec, None),
    };
    let table = camsim_core::spectrum_csv::load_spectra(path)
        .map_err(|e| CoreError::invalid(key, e.to_string()))?;
    let s = match column {
        Some(c) => table.spectrum(c),
        None => table.spectrum_at(0),
    };
    s.map_err(|e| CoreError::invalid(key, format!("{}: {e}", path.display())))
}

/// A reflectance spec on `grid` (fractions). `key` names the config key in errors.
pub fn reflectance_on(r: &Reflectance, grid: &WavelengthGrid, key: &str) -> Result<Vec<f64>> {
    match r {
        Reflectance::Grey(v) => {
            check_fraction(*v, key)?;
            Ok(vec![*v; grid.len()])
        }
        Reflectance::Named(s) => {
            let lower = s.trim().to_ascii_lowercase();
            let spectrum = if let Some(patch) = lower.strip_prefix("macbeth:") {
                tables::macbeth_patch(patch).map_err(|e| CoreError::invalid(key, e.to_string()))?
            } else if looks_like_file(s) {
                // A measured reflectance may stop short of the grid: hold its end values.
                load_spectrum_file(Path::new(s), key)?.with_extrapolation(Extrapolation::Hold)
            } else {
                return Err(CoreError::invalid(
                    key,
                    format!("'{s}' is neither a number, 'macbeth:<patch>' nor a spectrum file (.csv, .mat)"),
                ));
            };
            let v = spectrum.sample(grid);
            if let Some((i, x)) = v
                .iter()
                .enumerate()
                .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
            {
                return Err(CoreError::invalid(
                    key,
                    format!(
                        "'{s}': reflectance {x} at {} nm is not a non-negative number",
                        grid.wavelength_nm(i)
                    ),
                ));
            }
            Ok(v)
        }
    }
}

/// Mean luminance of a radiance image, cd/m^2: the pixel mean of `683 sum y_bar L d_lambda`
/// (CIE 015:2018; ISETCam `sceneGet(scene, 'mean luminance')`).
pub fn mean_luminance_cd_m2(img: &SpectralImage) -> f64 {
    let cmfs = Cmfs::on(&img.grid);
    let k = camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
    let weights: Vec<f64> = cmfs.y.iter().map(|y| k * y).collect();
    img.mean_weighted_integral(&weights)
}

/// Scale a radiance image so its mean luminance is `cd_m2` (ISETCam `sceneAdjustLuminance`).
/// Returns the factor applied. Errors when the image has no luminance to scale (and a non-zero
/// target) or the target is negative / not finite.
pub fn scale_to_luminance(img: &mut SpectralImage, cd_m2: f64) -> Result<f64> {
    check_luminance(cd_m2, "scene.mean_luminance_cd_m2")?;
    let current = mean_luminance_cd_m2(img);
    let factor = if cd_m2 == 0.0 {
        0.0
    } else if current > 0.0 && current.is_finite() {
        cd_m2 / current
    } else {
        return Err(CoreError::invalid(
            "scene.mean_luminance_cd_m2",
            format!("the image has mean luminance {current} cd/m^2 (no light between {} and {} nm), so it cannot be scaled to {cd_m2} cd/m^2", img.grid.start_nm, img.grid.end_nm()),
        ));
    };
    let f = factor as f32;
    img.data
        .par_chunks_mut(1 << 16)
        .for_each(|c| c.iter_mut().for_each(|v| *v *= f));
    Ok(factor)
}

/// Prepare a spectral radiance image read from a file (`kind = "file"`): check its values,
/// resample it onto the config's wavelength grid (linear in wavelength, zero outside the file's
/// range), set the field of view / distance and rescale to the requested mean luminance.
pub fn from_image(cfg: &FileScene, mut img: SpectralImage) -> Result<SpectralImage> {
    let what = cfg.path.display().to_string();
    if img.quantity != Quantity::Radiance {
        return Err(CoreError::invalid(
            what,
            format!(
                "holds {} ({}), not spectral radiance",
                img.quantity.name(),
                img.quantity.unit()
            ),
        ));
    }
    img.validate_values(&what)?;
    if let Some(g) = cfg.wavelengths {
        g.validate()?;
        if !g.same_as(&img.grid) {
            let held = (img.data.len() + img.depth_m.as_ref().map_or(0, Vec::len)) as u64 * 4;
            check_memory(img.rows, img.cols, g.len(), &[("the file's image", held)])?;
            img = resample_bands(&img, &g)?;
        }
    }
    let distance_m = match cfg.distance_m {
        Some(d) => {
            check_distance(d, "scene.distance_m")?;
            d
        }
        None if img.geometry.distance_m > 0.0 => img.geometry.distance_m,
        None => 1.2,
    };
    img.geometry.distance_m = distance_m;
    match cfg.fov_deg {
        Some(fov) => {
            check_fov(fov, "scene.fov_deg")?;
            img.geometry.fov_deg = fov;
            img.sample_spacing_m = sample_spacing_m(fov, distance_m, img.cols);
        }
        None => {
            // Keep the file's sample spacing; derive the field of view it implies.
            img.geometry.fov_deg = 2.0 * (0.5 * img.width_m() / distance_m).atan().to_degrees();
        }
    }
    if let Some(l) = cfg.mean_luminance_cd_m2 {
        scale_to_luminance(&mut img, l)?;
    }
    Ok(img)
}

/// Resample a spectral image onto another wavelength grid by linear interpolation between bands
/// (zero outside the image's range, ISETCam `interp1(..., 'linear', 0)`).
pub fn resample_bands(img: &SpectralImage, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let mut out = SpectralImage::zeros(
        img.rows,
        img.cols,
        *grid,
        img.sample_spacing_m,
        img.quantity,
    )?;
    out.geometry = img.geometry;
    out.depth_m = img.depth_m.clone();
    let src = img.grid;
    let n = img.pixels();
    out.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| {
            let w = grid.wavelength_nm(b);
            let x = (w - src.start_nm) / src.step_nm;
            let last = src.len() - 1;
            if x < -1e-9 || x > last as f64 + 1e-9 {
                return; // outside: zero
            }
            let i0 = (x.floor().max(0.0) as usize).min(last);
            let t = (x - i0 as f64).clamp(0.0, 1.0) as f32;
            let a = img.band(i0);
            if t < 1e-7 || i0 == last {
                plane.copy_from_slice(a);
            } else {
                let bb = img.band(i0 + 1);
                for ((o, va), vb) in plane.iter_mut().zip(a).zip(bb) {
                    *o = va * (1.0 - t) + vb * t;
                }
            }
        });
    Ok(out)
}

/// Object-plane sample spacing, m: the scene width `2 d tan(fov / 2)` over `cols` (ISETCam
/// `sceneGet(scene, 'width') / cols`).
pub fn sample_spacing_m(fov_deg: f64, distance_m: f64, cols: usize) -> f64 {
    2.0 * distance_m * (0.5 * fov_deg).to_radians().tan() / cols as f64
}

fn check_fov(fov: f64, key: &str) -> Result<()> {
    if !(fov > 0.0 && fov < 180.0) {
        return Err(CoreError::invalid(
            key,
            format!("{fov} degrees is not in (0, 180)"),
        ));
    }
    Ok(())
}

fn check_distance(d: f64, key: &str) -> Result<()> {
    if !(d > 0.0 && d.is_finite()) {
        return Err(CoreError::invalid(
            key,
            format!("{d} m is not a positive distance"),
        ));
    }
    Ok(())
}

/// The brightest scene accepted, cd/m^2: about a million times the Sun's disc seen at noon
/// (~1.6e9 cd/m^2); anything brighter is a typing mistake, not a scene.
pub const MAX_LUMINANCE_CD_M2: f64 = 1e15;

fn check_luminance(l: f64, key: &str) -> Result<()> {
    if !(0.0..=MAX_LUMINANCE_CD_M2).contains(&l) {
        return Err(CoreError::invalid(
            key,
            format!("{l} cd/m^2 is outside [0, {MAX_LUMINANCE_CD_M2:e}] cd/m^2 (a million times the Sun's disc)"),
        ));
    }
    Ok(())
}

fn check_fraction(v: f64, key: &str) -> Result<()> {
    if !(0.0..=1.0).contains(&v) {
        return Err(CoreError::invalid(
            key,
            format!("reflectance {v} is not a fraction in [0, 1]"),
        ));
    }
    Ok(())
}

fn check_size(rows: usize, cols: usize, min: usize) -> Result<()> {
    if rows < min {
        return Err(CoreError::invalid(
            "scene.rows",
            format!("{rows} rows; need at least {min}"),
        ));
    }
    if cols < min {
        return Err(CoreError::invalid(
            "scene.cols",
            format!("{cols} columns; need at least {min}"),
        ));
    }
    Ok(())
}

/// The 2D scene stage's peak memory for a `rows x cols` radiance image of `bands` bands, summed
/// before any of it is allocated: the radiance cube (f32), then the larger of what the chart
/// holds beside it while it is made (`aux`: a pattern's reflectance map, a slanted edge's coverage
/// map, an RGB photo's pixels and levels, a scene file's image being resampled; dropped when the
/// scene is made) and the OpenEXR writer's blocks in flight when the image is written (at most
/// two batches of [`camsim_core::mem::WRITE_BATCH_BYTES`], never more than the image).
pub fn memory_budget(
    rows: usize,
    cols: usize,
    bands: usize,
    aux: &[(&str, u64)],
) -> camsim_core::mem::MemoryBudget {
    let cube = (rows as u64)
        .saturating_mul(cols as u64)
        .saturating_mul(bands as u64)
        .saturating_mul(4);
    let writing = 2 * cube.min(camsim_core::mem::WRITE_BATCH_BYTES as u64);
    let aux_bytes = aux.iter().fold(0u64, |a, (_, b)| a.saturating_add(*b));
    let b = camsim_core::mem::MemoryBudget::new(format!(
        "the 2D scene stage ({rows} x {cols} pixels, {bands} bands)"
    ))
    .bytes("radiance cube", cube);
    if aux_bytes > writing {
        aux.iter()
            .fold(b, |b, (name, bytes)| b.bytes(*name, *bytes))
    } else {
        b.bytes("EXR writing blocks", writing)
    }
}

/// Refuse a scene whose [`memory_budget`] exceeds the memory limit, before allocating it.
pub(crate) fn check_memory(
    rows: usize,
    cols: usize,
    bands: usize,
    aux: &[(&str, u64)],
) -> Result<()> {
    memory_budget(rows, cols, bands, aux).check(
        "use a smaller scene (scene.rows and scene.cols, or scene.size_px) or fewer wavelengths",
    )
}

/// What every chart scene shares: the illuminant on the grid and the viewing geometry.
struct Common {
    illuminant: Vec<f64>,
    fov_deg: f64,
    distance_m: f64,
    mean_luminance_cd_m2: f64,
}

fn common(
    illuminant: &str,
    fov_deg: f64,
    distance_m: f64,
    lum: f64,
    grid: &WavelengthGrid,
) -> Result<Common> {
    check_fov(fov_deg, "scene.fov_deg")?;
    check_distance(distance_m, "scene.distance_m")?;
    check_luminance(lum, "scene.mean_luminance_cd_m2")?;
    let illum = load_illuminant(illuminant, "scene.illuminant")?.sample(grid);
    if illum.iter().all(|v| *v == 0.0) {
        return Err(CoreError::invalid(
            "scene.illuminant",
            format!(
                "'{illuminant}' has no power between {} and {} nm",
                grid.start_nm,
                grid.end_nm()
            ),
        ));
    }
    Ok(Common {
        illuminant: illum,
        fov_deg,
        distance_m,
        mean_luminance_cd_m2: lum,
    })
}

impl Common {
    /// Radiance per unit reflectance per band: `k * illuminant`, with `k` chosen so that a scene whose
    /// pixel-mean reflectance per band is `mean_reflectance` has the requested mean luminance.
    fn scaled_illuminant(
        &self,
        mean_reflectance: &[f64],
        grid: &WavelengthGrid,
    ) -> Result<Vec<f64>> {
        let cmfs = Cmfs::on(grid);
        let mean_radiance: Vec<f64> = self
            .illuminant
            .iter()
            .zip(mean_reflectance)
            .map(|(e, r)| e * r)
            .collect();
        let unit = cmfs.luminance_cd_m2(&mean_radiance);
        let k = if self.mean_luminance_cd_m2 == 0.0 {
            0.0
        } else if unit > 0.0 {
            self.mean_luminance_cd_m2 / unit
        } else {
            return Err(CoreError::invalid(
                "scene.mean_luminance_cd_m2",
                format!(
                    "the scene reflects no visible light under its illuminant, so it cannot have {} cd/m^2",
                    self.mean_luminance_cd_m2
                ),
            ));
        };
        Ok(self.illuminant.iter().map(|e| k * e).collect())
    }

    fn image(&self, rows: usize, cols: usize, grid: &WavelengthGrid) -> Result<SpectralImage> {
        blank_radiance(self.fov_deg, self.distance_m, rows, cols, grid)
    }
}

/// A zero radiance image of a flat scene `distance_m` away spanning `fov_deg` horizontally.
pub(crate) fn blank_radiance(
    fov_deg: f64,
    distance_m: f64,
    rows: usize,
    cols: usize,
    grid: &WavelengthGrid,
) -> Result<SpectralImage> {
    check_fov(fov_deg, "scene.fov_deg")?;
    check_distance(distance_m, "scene.distance_m")?;
    let mut img = SpectralImage::zeros(
        rows,
        cols,
        *grid,
        sample_spacing_m(fov_deg, distance_m, cols),
        Quantity::Radiance,
    )?;
    img.geometry.fov_deg = fov_deg;
    img.geometry.distance_m = distance_m;
    Ok(img)
}

fn create_uniform(c: &UniformScene, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let com = common(
        &c.illuminant,
        c.fov_deg,
        c.distance_m,
        c.mean_luminance_cd_m2,
        grid,
    )?;
    check_size(c.rows, c.cols, 1)?;
    check_memory(c.rows, c.cols, grid.len(), &[])?;
    let refl = reflectance_on(&c.reflectance, grid, "scene.reflectance")?;
    let k_illum = com.scaled_illuminant(&refl, grid)?;
    let mut img = com.image(c.rows, c.cols, grid)?;
    let n = img.pixels();
    img.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| plane.fill((k_illum[b] * refl[b]) as f32));
    Ok(img)
}

fn create_macbeth(c: &MacbethScene, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let com = common(
        &c.illuminant,
        c.fov_deg,
        c.distance_m,
        c.mean_luminance_cd_m2,
        grid,
    )?;
    if c.patch_size_px == 0 {
        return Err(CoreError::invalid(
            "scene.patch_size_px",
            "must be at least 1 pixel",
        ));
    }
    check_fraction(c.border_reflectance, "scene.border_reflectance")?;
    let layout = c.layout();
    let (rows, cols) = (layout.rows(), layout.cols());
    check_memory(rows, cols, grid.len(), &[])?;
    // Reflectance of patch i on the grid; index 24 = the border.
    let mut refl: Vec<Vec<f64>> = macbeth_reflectances(c)?
        .iter()
        .map(|s| s.sample(grid))
        .collect();
    refl.push(vec![c.border_reflectance; grid.len()]);
    // Pixel-mean reflectance per band, from the areas: 24 patches of p^2 pixels, the rest border.
    let patch_area = (c.patch_size_px * c.patch_size_px) as f64;
    let total = (rows * cols) as f64;
    let border_area = total - 24.0 * patch_area;
    let mean_refl: Vec<f64> = (0..grid.len())
        .map(|b| {
            (patch_area * refl[..24].iter().map(|r| r[b]).sum::<f64>() + border_area * refl[24][b])
                / total
        })
        .collect();
    let k_illum = com.scaled_illuminant(&mean_refl, grid)?;
    let mut img = com.image(rows, cols, grid)?;
    let n = img.pixels();
    // Each row is a border row or a sequence of border and patch runs: fill runs, not pixels.
    let pitch = c.patch_size_px + c.border_px;
    img.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| {
            let values: Vec<f32> = refl.iter().map(|r| (k_illum[b] * r[b]) as f32).collect();
            for (row, line) in plane.chunks_exact_mut(cols).enumerate() {
                // Patch row of this image row, if it crosses patches (any column inside a patch).
                let patch_row = layout
                    .patch_at(row, c.border_px)
                    .map(|i| i / MacbethLayout::PATCH_COLS);
                match patch_row {
                    None => line.fill(values[24]),
                    Some(pr) => {
                        line[..c.border_px].fill(values[24]);
                        for pc in 0..MacbethLayout::PATCH_COLS {
                            let x0 = c.border_px + pc * pitch;
                            line[x0..x0 + c.patch_size_px]
                                .fill(values[pr * MacbethLayout::PATCH_COLS + pc]);
                            line[x0 + c.patch_size_px..x0 + pitch].fill(values[24]);
                        }
                    }
                }
            }
        });
    Ok(img)
}

/// The chart's 24 patch reflectances: the config's file, or N. Ohta's.
pub fn macbeth_reflectances(c: &MacbethScene) -> Result<Vec<Spectrum>> {
    match &c.reflectances {
        None => Ok(tables::macbeth_reflectances()),
        Some(file) => load_chart_reflectances(Path::new(file), "scene.reflectances"),
    }
}

/// Read a ColorChecker reflectance set: 24 spectra in chart order, fractions in [0, 1], from a
/// CSV (`wavelength_nm` + 24 columns) or an ISETCam `.mat` (`macbethChart.mat` layout). End values
/// are held beyond the file's wavelengths. `key` names the config key or flag in errors.
pub fn load_chart_reflectances(path: &Path, key: &str) -> Result<Vec<Spectrum>> {
    let file = path.display();
    let table = camsim_core::spectrum_csv::load_spectra(path)
        .map_err(|e| CoreError::invalid(key, e.to_string()))?;
    if table.len() != 24 {
        return Err(CoreError::invalid(
            key,
            format!(
                "{file} has {} spectra; a ColorChecker needs 24, in chart order",
                table.len()
            ),
        ));
    }
    let spectra = table
        .spectra()
        .map_err(|e| CoreError::invalid(key, format!("{file}: {e}")))?;
    for (i, s) in spectra.iter().enumerate() {
        if let Some(v) = s
            .values
            .iter()
            .find(|v| !(v.is_finite() && (0.0..=1.0).contains(*v)))
        {
            return Err(CoreError::invalid(
                key,
                format!(
                    "{file}: patch {} has reflectance {v}, not a fraction in [0, 1]",
                    i + 1
                ),
            ));
        }
    }
    Ok(spectra
        .into_iter()
        .map(|s| s.with_extrapolation(Extrapolation::Hold))
        .collect())
}

fn create_slanted_edge(c: &SlantedEdgeScene, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let com = common(
        &c.illuminant,
        c.fov_deg,
        c.distance_m,
        c.mean_luminance_cd_m2,
        grid,
    )?;
    check_size(c.rows, c.cols, 2)?;
    if !(c.angle_deg.abs() < 45.0) {
        return Err(CoreError::invalid(
            "scene.angle_deg",
            format!("{} degrees is not in (-45, 45)", c.angle_deg),
        ));
    }
    check_fraction(c.bright_reflectance, "scene.bright_reflectance")?;
    check_fraction(c.dark_reflectance, "scene.dark_reflectance")?;
    let edge = slanted_edge_geometry(c);
    check_memory(
        c.rows,
        c.cols,
        grid.len(),
        &[
            (
                "coverage map",
                (c.rows as u64)
                    .saturating_mul(c.cols as u64)
                    .saturating_mul(4),
            ),
            ("row spans", (c.rows as u64).saturating_mul(16)),
        ],
    )?;
    let mut coverage = vec![0.0f32; c.rows * c.cols];
    coverage
        .par_chunks_mut(c.cols)
        .enumerate()
        .for_each(|(row, line)| {
            // The edge crosses this row strip between columns xa and xb: pixels wholly left of it are
            // dark (0), wholly right bright (1); only the few in between need the exact area.
            let (x_top, x_bottom) = (edge.x_at(row as f64), edge.x_at(row as f64 + 1.0));
            let (xa, xb) = (x_top.min(x_bottom), x_top.max(x_bottom));
            let first = (xa.floor() - 1.0).clamp(0.0, c.cols as f64) as usize;
            let last = (xb.ceil() + 1.0).clamp(0.0, c.cols as f64) as usize;
            line[..first].fill(0.0);
            for (col, v) in line.iter_mut().enumerate().take(last).skip(first) {
                *v = edge.coverage(row, col) as f32;
            }
            line[last..].fill(1.0);
        });
    let mean_cov = coverage.iter().map(|v| *v as f64).sum::<f64>() / coverage.len() as f64;
    // Coverage grows along each row (bright side on the right, |angle| < 45 deg): per row, the
    // columns before `first` are fully dark and those from `full` on fully bright.
    let spans: Vec<(usize, usize)> = coverage
        .chunks_exact(c.cols)
        .map(|line| {
            (
                line.partition_point(|a| *a <= 0.0),
                line.partition_point(|a| *a < 1.0),
            )
        })
        .collect();
    let (dark, bright) = (c.dark_reflectance, c.bright_reflectance);
    let mean_refl = vec![dark + (bright - dark) * mean_cov; grid.len()];
    let k_illum = com.scaled_illuminant(&mean_refl, grid)?;
    let mut img = com.image(c.rows, c.cols, grid)?;
    let n = img.pixels();
    img.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| {
            let (lo, hi) = ((k_illum[b] * dark) as f32, (k_illum[b] * bright) as f32);
            for ((line, cov), (first, full)) in plane
                .chunks_exact_mut(c.cols)
                .zip(coverage.chunks_exact(c.cols))
                .zip(&spans)
            {
                line[..*first].fill(lo);
                for (v, a) in line[*first..*full].iter_mut().zip(&cov[*first..*full]) {
                    *v = lo + (hi - lo) * a;
                }
                line[*full..].fill(hi);
            }
        });
    Ok(img)
}

/// The edge of a slanted-edge scene in pixel coordinates: through the image centre
/// (cols/2, rows/2), tilted `angle_deg` from the vertical, bright side on the right.
pub fn slanted_edge_geometry(c: &SlantedEdgeScene) -> Edge {
    Edge {
        x0: 0.5 * c.cols as f64,
        y0: 0.5 * c.rows as f64,
        angle_deg: c.angle_deg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stage's budget is the radiance cube plus the larger of the chart's own maps and the
    /// EXR writer's two batches, for closed-form sizes.
    #[test]
    fn the_scene_budget_is_the_cube_plus_the_larger_of_its_maps_and_the_writer() {
        let batch = camsim_core::mem::WRITE_BATCH_BYTES as u64;
        assert_eq!(batch, 64 << 20);
        // Small: the writer's batches are capped by the image itself (2 x the cube).
        let cube = 100 * 200 * 31 * 4;
        let small = memory_budget(100, 200, 31, &[("coverage map", 100 * 200 * 4)]);
        assert_eq!(small.total_bytes(), cube + 2 * cube);
        // 3000 x 4000 x 31: the writer's two batches beat the 48 MB coverage map.
        let cube = 3000 * 4000 * 31 * 4;
        let edge = [("coverage map", 3000 * 4000 * 4), ("row spans", 3000 * 16)];
        assert_eq!(
            memory_budget(3000, 4000, 31, &edge).total_bytes(),
            cube + 2 * batch
        );
        // 8000 x 8000: the 256 MB coverage map and its spans beat the writer.
        let cube = 8000 * 8000 * 31 * 4;
        let edge = [("coverage map", 8000 * 8000 * 4), ("row spans", 8000 * 16)];
        assert_eq!(
            memory_budget(8000, 8000, 31, &edge).total_bytes(),
            cube + 8000 * 8000 * 4 + 8000 * 16
        );
        // No overflow for absurd sizes: saturates, so it is refused.
        assert_eq!(
            memory_budget(usize::MAX, 2, 31, &[]).total_bytes(),
            u64::MAX
        );
    }
}
