//! Stage 1 of a config: the scene's spectral radiance (a 2D chart, or a 3D scene rendered by
//! [`crate::render`]), and where a chart lands on the sensor.

use crate::{PipelineError, Progress, Result, SimulateConfig};
use camsim_core::{SpectralImage, WavelengthGrid};
use camsim_optics::{Optics, OpticsConfig};
use camsim_scene::SceneConfig;
use camsim_sensor::Sensor;
use std::path::Path;

/// A 2D scene's config and wavelength grid from a file (`camsim scene CONFIG`): a scene TOML (a
/// `[scene]` table on its own, relative paths against its folder), or a whole simulate config
/// whose `[scene]` is used (through the config door).
pub fn load_scene_config(path: &Path) -> Result<(SceneConfig, WavelengthGrid)> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| PipelineError::file(path, format!("cannot read: {e}")))?;
    let v: toml::Value = toml::from_str(&text).map_err(|e| PipelineError::file(path, e))?;
    if v.get("scene").is_some() {
        let c = SimulateConfig::load(path)?;
        let s = c
            .scene
            .ok_or_else(|| PipelineError::file(path, "[scene] is missing"))?;
        return Ok((s, c.wavelengths));
    }
    let mut s = SceneConfig::from_toml(&text, &path.display().to_string())?;
    s.resolve_paths(path.parent().unwrap_or(Path::new(".")));
    let grid = s.grid();
    Ok((s, grid))
}

/// A 2D scene of `kind` (a name of `camsim_scene::config::SCENE_KINDS`, any case) with every
/// default, on the default wavelength grid (`camsim scene --kind`, Python's `camsim.scene(kind)`).
pub fn default_scene(kind: &str) -> Result<(SceneConfig, WavelengthGrid)> {
    let kind = camsim_scene::config::SCENE_KINDS.canonical(kind)?;
    Ok((
        SceneConfig::from_toml(&format!("kind = \"{kind}\""), "kind")?,
        WavelengthGrid::default(),
    ))
}

/// Stage 1: the scene radiance (2D chart or 3D render).
/// `progress(stage, done, total)` is called as long steps advance.
pub fn scene_radiance(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<SpectralImage> {
    Ok(scene_stage(cfg, sensor, optics, progress)?.0)
}

/// [`scene_radiance`] with the object and material id maps of a rendered 3D scene (None for 2D
/// charts and scene files).
pub fn scene_stage(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<(SpectralImage, Option<camsim_render::IdMaps>)> {
    let s = scene_stage_with(
        cfg,
        sensor,
        optics,
        &camsim_render::RenderRequest::default(),
        progress,
    )?;
    Ok((s.image, s.ids))
}

/// What the scene stage made: the image, and for a rendered 3D scene its ids and the labels
/// `request` asked for.
#[derive(Debug, Clone)]
pub struct SceneStage {
    /// Scene radiance, or a lens camera's film irradiance.
    pub image: SpectralImage,
    pub ids: Option<camsim_render::IdMaps>,
    pub labels: Option<camsim_render::Labels>,
    /// The rendered scene, kept when labels were asked for (their sensor-grid version traces it
    /// again once the optics' map is known).
    pub scene: Option<camsim_scene3d::SceneDescription>,
}

/// [`scene_stage`] with the renderer's extra outputs (`request`; ignored for 2D scenes).
pub fn scene_stage_with(
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<SceneStage> {
    cfg.wavelengths.validate()?;
    cfg.check_scene_source()?;
    match (&cfg.scene, &cfg.render) {
        (Some(_), Some(_)) | (None, None) => unreachable!("checked by check_scene_source"),
        (Some(s), None) => Ok(SceneStage {
            image: camsim_scene::create(s, &cfg.wavelengths)
                .map_err(|e| PipelineError::Scene(e.to_string()))?,
            ids: None,
            labels: None,
            scene: None,
        }),
        (None, Some(r)) => {
            let scene = crate::render::render_section_scene(r, cfg, sensor, optics)?;
            let out = crate::render::render_stage(&scene, r, request, progress)?;
            Ok(SceneStage {
                image: out.radiance,
                ids: Some(out.ids),
                scene: out.labels.is_some().then_some(scene),
                labels: out.labels,
            })
        }
    }
}

/// Where the patch grid of a `macbeth` scene lands on the sensor: its outer corners `[x, y]` in
/// sensor pixels (pixel (r, c) covers [c, c + 1) x [r, r + 1)), in the order top-left (dark
/// skin), top-right (bluish green), bottom-right (black), bottom-left (white). The grid is taken
/// through the middle of the chart's outer border, so it spans 6 x 4 equal patch pitches and its
/// cells are centred on the patches. `Ok(None)` when the config's scene is not a Macbeth chart.
///
/// The mapping is the pipeline's own: scene samples of 2 d tan(fov / 2) / cols_scene
/// (`camsim_scene::sample_spacing_m`), scaled onto the sensor plane by v / d with v the thin-lens
/// image distance of the focus distance (as `Optics::compute`: no inversion, centred on the
/// axis), and a `rows x cols` sensor window of `pixel_pitch_m` centred on the axis (as
/// `Sensor::compute`).
pub fn macbeth_chart_corners_px(
    cfg: &SimulateConfig,
    optics: &OpticsConfig,
    pixel_pitch_m: f64,
    rows: usize,
    cols: usize,
) -> Result<Option<[[f64; 2]; 4]>> {
    let Some(SceneConfig::Macbeth(m)) = &cfg.scene else {
        return Ok(None);
    };
    if !(pixel_pitch_m > 0.0 && pixel_pitch_m.is_finite()) {
        return Err(PipelineError::config(format!(
            "pixel pitch {pixel_pitch_m} m is not a positive number"
        )));
    }
    let layout = camsim_scene::MacbethLayout {
        patch_px: m.patch_size_px,
        border_px: m.border_px,
    };
    let (scene_rows, scene_cols) = (layout.rows() as f64, layout.cols() as f64);
    let f_m = optics.focal_length_mm * 1e-3;
    let d_m = m.distance_m;
    let Some(v_m) =
        camsim_optics::lens::image_distance_m(f_m, optics.focus_distance_m.unwrap_or(d_m))
    else {
        return Err(PipelineError::config(format!(
            "focus distance inside the focal length ({f_m} m): no real image"
        )));
    };
    let spacing_img_m = camsim_scene::sample_spacing_m(m.fov_deg, d_m, layout.cols()) * v_m / d_m;
    let k = spacing_img_m / pixel_pitch_m; // sensor pixels per scene sample
    if !(k > 0.0 && k.is_finite()) {
        return Err(PipelineError::config(
            "scene.fov_deg / distance_m give no finite image scale",
        ));
    }
    let to_sensor = |x: f64, y: f64| {
        [
            cols as f64 / 2.0 + (x - scene_cols / 2.0) * k,
            rows as f64 / 2.0 + (y - scene_rows / 2.0) * k,
        ]
    };
    let h = m.border_px as f64 / 2.0;
    Ok(Some([
        to_sensor(h, h),
        to_sensor(scene_cols - h, h),
        to_sensor(scene_cols - h, scene_rows - h),
        to_sensor(h, scene_rows - h),
    ]))
}

/// Mean luminance of a radiance image, cd/m^2: 683 lm/W x sum over bands of ybar L d(lambda)
/// (CIE 1931 photopic luminous efficiency).
pub fn mean_luminance_cd_m2(radiance: &SpectralImage) -> f64 {
    let cmfs = camsim_core::colorimetry::Cmfs::on(&radiance.grid);
    // 683 lm/W sum_b y_bar_b L_b dl, averaged over the pixels (CIE 015:2018 eq. 7.1). Each band
    // summed in a fixed order (blocks in parallel), the bands added in band order: the same bits
    // for any thread or worker count (it is written to run.json and a dataset's KEY.json).
    let total: f64 = (0..radiance.bands())
        .map(|b| camsim_core::math::fixed_order_sum(radiance.band(b)) * cmfs.y[b])
        .sum();
    total * camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W * radiance.grid.step_nm
        / radiance.pixels() as f64
}
