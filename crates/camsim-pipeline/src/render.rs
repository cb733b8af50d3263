//! 3D scenes in the pipeline: load (built-in or pbrt-v4, plus overlay), match the camera to the
//! sensor, render.
//!
//! A pinhole camera renders scene radiance, which the optics stage turns into sensor irradiance.
//! A lens camera (pbrt-v4 `Camera "realistic"`, ISET3d `"raytransfer"`) already renders the
//! film irradiance behind its lens, blur, vignetting and distortion included: `simulate` puts its
//! film on the sensor window ([`fit_lens_film_to_sensor`]) and hands the irradiance straight to
//! the sensor, skipping the optics stage (which would blur a second time).

use crate::records::RenderRecord;
use crate::{PipelineError, Progress, RenderSection, Result, SimulateConfig};
use camsim_core::{SpectralImage, WavelengthGrid};
use camsim_io::atomic::OutputDir;
use camsim_optics::Optics;
use camsim_render::RenderOutput;
use camsim_scene3d::builtin::{self, BuiltinOptions, MccPosition};
use camsim_scene3d::SceneDescription;
use camsim_sensor::Sensor;
use std::path::{Path, PathBuf};

/// A 3D scene to render on its own (`camsim render`, Python's `camsim.render`).
#[derive(Debug, Clone)]
pub struct RenderRequest {
    /// A built-in scene by name (`camsim_scene3d::builtin::BUILTIN_SCENES`).
    pub builtin: Option<String>,
    /// Or a pbrt-v4 scene file.
    pub pbrt: Option<PathBuf>,
    /// An overlay TOML applied to it (moves objects, sets spectra).
    pub overlay: Option<PathBuf>,
    /// Or a simulate config with a `[render]` table: its scene exactly as `camsim simulate`
    /// renders it (resolution, samples, seed, wavelengths, the sensor window's field of view).
    pub config: Option<SimulateConfig>,
    /// Samples per pixel (wins over the file's, the overlay's and the built-in's).
    pub samples_per_pixel: Option<u32>,
    /// Image (width, height) (wins over the file's and the overlay's).
    pub resolution: Option<(usize, usize)>,
    /// Maximum path depth.
    pub max_depth: Option<u32>,
    /// Opt-in wall-clock limit, s.
    pub time_budget_s: Option<f64>,
    /// Adaptive sampling to a relative standard error of each pixel's luminance (0.01: 1 %);
    /// `samples_per_pixel` is then the most a pixel takes.
    pub adaptive_error: Option<f64>,
    /// Samples before adaptive sampling's first test (default 32).
    pub min_samples: Option<u32>,
    /// Denoise the film with Intel Open Image Denoise (`camsim_render::denoise`; the library
    /// from `$CAMSIM_OIDN_LIBRARY`).
    pub denoise: bool,
    /// ColorChecker position of `cornell-box-mcc`.
    pub mcc_position: MccPosition,
    /// Target distance of `slanted-edge`, m.
    pub distance_m: f64,
    /// Render seed (default 1, or the config's).
    pub seed: Option<u64>,
    /// Wavelength grid (a config has its own).
    pub grid: WavelengthGrid,
    /// How a glTF or OBJ `pbrt` file is read (its scene and camera, the OBJ's unit and up axis).
    pub asset: crate::config::AssetReadSection,
}

impl Default for RenderRequest {
    fn default() -> Self {
        RenderRequest {
            builtin: None,
            pbrt: None,
            overlay: None,
            config: None,
            samples_per_pixel: None,
            resolution: None,
            max_depth: None,
            time_budget_s: None,
            adaptive_error: None,
            min_samples: None,
            denoise: false,
            mcc_position: MccPosition::Center,
            distance_m: 0.5,
            seed: None,
            grid: WavelengthGrid::default(),
            asset: Default::default(),
        }
    }
}

/// The scene of `req`, set up to render: loaded (built-in, pbrt-v4 file and overlay, or a
/// config's `[render]`), then the request's explicit settings win over the file's and the
/// overlay's. Its `notes` say what the reader ignored or approximated.
pub fn request_scene(req: &RenderRequest) -> Result<SceneDescription> {
    let mut scene = match &req.config {
        Some(cfg) => {
            let mut cfg = cfg.clone();
            if let Some(seed) = req.seed {
                cfg.seed = seed;
            }
            let section = cfg.render.clone().ok_or_else(|| {
                PipelineError::config("the config has no [render] table to render")
            })?;
            let (sensor, optics) = (cfg.sensor()?, cfg.optics()?);
            let mut scene = render_section_scene(&section, &cfg, &sensor, &optics)?;
            // `[render.adaptive]` as simulate sets it (a metering preview when auto-exposed).
            crate::sequence::set_adaptive_target(
                &mut scene,
                &section,
                &optics,
                &sensor,
                &cfg.capture_request()?,
                &|_, _, _| {},
            )?;
            scene
        }
        None => {
            let mut opts = BuiltinOptions {
                resolution: req.resolution,
                mcc_position: req.mcc_position,
                target_distance_m: req.distance_m,
                grid: req.grid,
                seed: req.seed.unwrap_or(1),
                ..BuiltinOptions::default()
            };
            if let Some(spp) = req.samples_per_pixel {
                opts.samples_per_pixel = spp;
            }
            load_scene_with(
                req.builtin.as_deref(),
                req.pbrt.as_deref(),
                req.overlay.as_deref(),
                &opts,
                &req.asset,
            )?
        }
    };
    // Explicit settings win over the file's and the overlay's.
    if let Some(spp) = req.samples_per_pixel {
        scene.settings.samples_per_pixel = spp;
    }
    if let Some((w, h)) = req.resolution {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(d) = req.max_depth {
        scene.settings.max_depth = d;
    }
    if req.time_budget_s.is_some() {
        scene.settings.time_budget_s = req.time_budget_s;
    }
    if req.denoise && scene.settings.denoise.is_none() {
        scene.settings.denoise = Some(Default::default());
    }
    if let Some(rel) = req.adaptive_error {
        scene.settings.adaptive = Some(crate::adaptive::relative_target(
            rel,
            0.0,
            req.min_samples
                .unwrap_or(crate::config::AdaptiveSection::default().min_samples),
        )?);
    } else if let Some(n) = req.min_samples {
        match &mut scene.settings.adaptive {
            Some(a) => a.min_samples = n,
            None => {
                return Err(PipelineError::config(
                    "min_samples (--min-spp) sets adaptive sampling's first test: give adaptive_error (--adaptive-error) too, or a config with [render.adaptive]",
                ))
            }
        }
    }
    Ok(scene)
}

/// A render and the scene it came from.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The scene as rendered.
    pub scene: SceneDescription,
    /// The render.
    pub output: RenderOutput,
}

impl Rendered {
    /// The render's record (render.json).
    pub fn record(&self, scene_name: Option<String>, command: Option<String>) -> RenderRecord {
        RenderRecord::new(&self.scene, &self.output, scene_name, command)
    }

    /// Write radiance.exr (spectral, depth as channel Z), depth.exr, variance.exr,
    /// object_id.png, material_id.png, ids.json, preview.png and render.json into `out` (and,
    /// with adaptive sampling, samples.exr: each pixel's sample count); returns the record.
    pub fn write_files(
        &self,
        out: &OutputDir,
        scene_name: Option<String>,
        command: Option<String>,
    ) -> Result<RenderRecord> {
        let r = &self.output;
        let (rows, cols) = (r.radiance.rows, r.radiance.cols);
        camsim_io::exr::write_spectral_exr(&out.join("radiance.exr"), &r.radiance, "render")?;
        camsim_io::exr::write_gray_exr(&out.join("depth.exr"), rows, cols, "Z", &r.depth_m)?;
        camsim_io::exr::write_gray_exr(&out.join("variance.exr"), rows, cols, "Y", &r.variance)?;
        if self.scene.settings.adaptive.is_some() {
            let n: Vec<f32> = r.samples_per_pixel.iter().map(|n| *n as f32).collect();
            camsim_io::exr::write_gray_exr(&out.join("samples.exr"), rows, cols, "Y", &n)?;
        }
        crate::write_id_maps(out.path(), &r.ids)?;
        let srgb = camsim_isp::preview::radiance_srgb8(&r.radiance);
        camsim_io::raster::write_png8_rgb(&out.join("preview.png"), rows, cols, &srgb)?;
        let record = self.record(scene_name, command);
        record
            .write(&out.join("render.json"))
            .map_err(|e| PipelineError::config(format!("render.json: {e}")))?;
        Ok(record)
    }
}

/// Load a scene description: a built-in by name or a pbrt-v4 file, then the overlay. Returns the
/// scene and the notes the reader made (ignored or approximated parameters).
pub fn load_scene(
    builtin_name: Option<&str>,
    pbrt: Option<&Path>,
    overlay: Option<&Path>,
    opts: &BuiltinOptions,
) -> Result<SceneDescription> {
    load_scene_with(builtin_name, pbrt, overlay, opts, &Default::default())
}

/// [`load_scene`] with the glTF / OBJ readers' choices (`[render.asset]`), which a built-in or
/// a pbrt-v4 file refuses.
pub fn load_scene_with(
    builtin_name: Option<&str>,
    pbrt: Option<&Path>,
    overlay: Option<&Path>,
    opts: &BuiltinOptions,
    asset: &crate::config::AssetReadSection,
) -> Result<SceneDescription> {
    if builtin_name.is_some() && *asset != Default::default() {
        return Err(PipelineError::config(
            "render.asset (glTF scene and camera, OBJ unit and up axis) is for a glTF or OBJ file, not a built-in scene",
        ));
    }
    let mut scene = match (builtin_name, pbrt) {
        (Some(name), None) => {
            builtin::scene(name, opts).map_err(|e| PipelineError::Scene(e.to_string()))?
        }
        (None, Some(path)) => {
            let mut s = read_scene_file_with(path, opts, asset)?;
            s.settings.grid = opts.grid;
            s.settings.seed = opts.seed;
            if let Some((w, h)) = opts.resolution {
                s.camera.width = w;
                s.camera.height = h;
            }
            s
        }
        (Some(_), Some(_)) => {
            return Err(PipelineError::config(
                "give a pbrt file or a built-in scene, not both",
            ))
        }
        (None, None) => {
            return Err(PipelineError::config(format!(
                "give a pbrt-v4 scene file or a built-in scene (one of {})",
                builtin::names().join(", ")
            )))
        }
    };
    if let Some(o) = overlay {
        let text = std::fs::read_to_string(o)
            .map_err(|e| PipelineError::file(o, format!("cannot read: {e}")))?;
        let base = o.parent().unwrap_or(Path::new("."));
        camsim_pbrt::overlay::apply_with(
            &mut scene,
            &text,
            &o.display().to_string(),
            base,
            &asset_object_reader,
        )
        .map_err(|e| PipelineError::Scene(e.to_string()))?;
    }
    Ok(scene)
}

/// A scene file of any format camsim reads, told apart by its content
/// ([`camsim_assets::detect_format`]): glTF 2.0 / GLB and OBJ by `camsim-assets` (the image
/// width of `opts.resolution` when given), pbrt-v4 (and anything else) by `camsim-pbrt`.
pub fn read_scene_file(path: &Path, opts: &BuiltinOptions) -> Result<SceneDescription> {
    read_scene_file_with(path, opts, &Default::default())
}

/// [`read_scene_file`] with the glTF / OBJ readers' choices; a pbrt-v4 file given any of them
/// is refused (they would be silently unused).
pub fn read_scene_file_with(
    path: &Path,
    opts: &BuiltinOptions,
    asset: &crate::config::AssetReadSection,
) -> Result<SceneDescription> {
    let scene_err = |e: String| PipelineError::Scene(e);
    let format = camsim_assets::detect_format(path).map_err(|e| scene_err(e.to_string()))?;
    if format.is_asset() {
        let ro = asset.read_options(opts.resolution.map_or(640, |r| r.0))?;
        camsim_assets::read_scene(path, &ro).map_err(|e| scene_err(e.to_string()))
    } else if *asset != Default::default() {
        Err(PipelineError::config(format!(
            "render.asset (glTF scene and camera, OBJ unit and up axis) is for a glTF or OBJ file; {} is a pbrt-v4 file",
            path.display()
        )))
    } else {
        camsim_pbrt::parse_file(path).map_err(|e| scene_err(e.to_string()))
    }
}

/// The overlays' reader of glTF / GLB / OBJ object files (`[[object]] add` and `replace`):
/// `None` for other files (the pbrt-v4 and PLY readers take them).
pub fn asset_object_reader(path: &Path) -> Option<std::result::Result<SceneDescription, String>> {
    match camsim_assets::detect_format(path) {
        Ok(f) if f.is_asset() => Some(
            camsim_assets::read_scene(
                path,
                &camsim_assets::ReadOptions {
                    default_light: false,
                    ..Default::default()
                },
            )
            .map_err(|e| e.to_string()),
        ),
        Ok(_) => None,
        Err(e) => Some(Err(e.to_string())),
    }
}

/// Render, reporting progress as ("render", tiles done, tiles in all).
pub fn render_scene(scene: &SceneDescription, progress: &Progress<'_>) -> Result<RenderOutput> {
    Ok(camsim_render::render(scene, &|done, total| {
        progress("render", done, total)
    })?)
}

/// The distance from the lens to the sensor, m, as the optics stage places it
/// ([`camsim_optics::Optics::compute`]): the thin-lens image distance of the lens's
/// `focus_distance_m`, else of the scene's own focus distance, else of infinity (the focal
/// length). The one rule for every field of view matched to a sensor window.
pub fn sensor_image_distance_m(
    optics: &camsim_optics::OpticsConfig,
    scene_focus_distance_m: Option<f64>,
) -> Result<f64> {
    let f_m = optics.focal_length_mm * 1e-3;
    let focus = optics
        .focus_distance_m
        .or(scene_focus_distance_m.filter(|d| *d > 0.0 && d.is_finite()))
        .unwrap_or(f64::INFINITY);
    camsim_optics::lens::image_distance_m(f_m, focus).ok_or_else(|| {
        PipelineError::config(format!(
            "focus distance {focus} m is inside the focal length ({f_m} m): no real image"
        ))
    })
}

/// The full angle, degrees, that `extent_m` of the sensor plane spans seen from the lens at
/// `image_distance_m`: 2 atan(extent / (2 v)).
pub fn field_of_view_deg(extent_m: f64, image_distance_m: f64) -> f64 {
    2.0 * (extent_m / 2.0 / image_distance_m).atan().to_degrees()
}

/// Set the camera's field of view to what the sensor window sees through the lens (from the lens
/// at [`sensor_image_distance_m`], so one render pixel lands on the sensor exactly as the optics
/// stage scales it), for an image of `width` x `height` pixels.
pub fn match_camera_to_sensor(
    scene: &mut SceneDescription,
    sensor: &Sensor,
    optics: &camsim_optics::OpticsConfig,
    width: usize,
    height: usize,
) -> Result<()> {
    let v_m = sensor_image_distance_m(optics, scene.focus_distance_m)?;
    let sensor_w_m = sensor.cols() as f64 * sensor.pixel_pitch_m();
    let sensor_h_m = sensor.rows() as f64 * sensor.pixel_pitch_m();
    // pbrt's fov spans the shorter image axis; the render's aspect ratio may differ from the sensor's.
    let short_m = if width >= height {
        sensor_h_m.min(sensor_w_m * height as f64 / width as f64)
    } else {
        sensor_w_m.min(sensor_h_m * width as f64 / height as f64)
    };
    scene.camera.fov_deg = field_of_view_deg(short_m, v_m);
    scene.camera.width = width;
    scene.camera.height = height;
    Ok(())
}

/// The scene of a `[render]` section, set up as `simulate` renders it: its resolution (default:
/// the sensor window's size), samples and seed, and the camera's field of view set to the sensor
/// window seen through the lens, so the radiance covers exactly the sensor. `camsim render
/// --config` uses this too, so `render -> optics -> sensor` reproduces `simulate`.
pub fn render_section_scene(
    r: &RenderSection,
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
) -> Result<SceneDescription> {
    render_section_scene_with_record(r, cfg, sensor, optics).map(|(scene, _)| scene)
}

/// [`render_section_scene`] and what `[render.compose]` drew (`None` without one): the assets,
/// categories, scales and final poses, for the sample's record.
pub fn render_section_scene_with_record(
    r: &RenderSection,
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
) -> Result<(SceneDescription, Option<camsim_compose::ComposeRecord>)> {
    let (w, h) = match r.resolution {
        Some([w, h]) => (w, h),
        None => (sensor.cols(), sensor.rows()),
    };
    let mut opts = BuiltinOptions {
        grid: cfg.wavelengths,
        seed: cfg.seed,
        resolution: Some((w, h)),
        ..BuiltinOptions::default()
    };
    if let Some(spp) = r.samples_per_pixel {
        opts.samples_per_pixel = spp;
    }
    let mut scene = load_scene_with(
        r.builtin.as_deref(),
        r.pbrt.as_deref(),
        r.overlay.as_deref(),
        &opts,
        &r.asset,
    )?;
    if let Some(t) = &r.overlay_inline {
        let text = toml::to_string(t)
            .map_err(|e| PipelineError::config(format!("render.overlay_inline: {e}")))?;
        let base = r.overlay_inline_base.as_deref().unwrap_or(Path::new("."));
        camsim_pbrt::overlay::apply_with(
            &mut scene,
            &text,
            "render.overlay_inline",
            base,
            &asset_object_reader,
        )
        .map_err(|e| PipelineError::Scene(e.to_string()))?;
    }
    // Composition after the overlays (it may stand objects on what they added), with the
    // config's seed: a dataset's samples each compose their own scene.
    // The camera's field of view is the sensor window's through the lens before composing, so
    // a camera sampler's view validation sees the frame the capture will have.
    let fit_camera = |scene: &mut SceneDescription| {
        if scene.camera.lens.is_some() {
            fit_lens_film_to_sensor(scene, sensor, w, h)
        } else {
            match_camera_to_sensor(scene, sensor, optics.config(), w, h)
        }
    };
    let record = match &r.compose {
        Some(spec) => {
            fit_camera(&mut scene)?;
            let base = r.overlay_inline_base.as_deref().unwrap_or(Path::new("."));
            Some(
                camsim_compose::compose(&mut scene, spec, r.compose_seed.unwrap_or(cfg.seed), base)
                    .map_err(|e| PipelineError::Scene(format!("render.{e}")))?,
            )
        }
        None => None,
    };
    if let Some(o) = &r.camera_offset {
        o.check("render.camera_offset")?;
        // A moving camera carries its offset cameras with it (a rig on one body).
        scene.move_camera_in_own_frame(o.translation_m, o.yaw_deg, o.pitch_deg, o.roll_deg);
    }
    if let Some(spp) = r.samples_per_pixel {
        scene.settings.samples_per_pixel = spp;
    }
    if let Some(d) = &r.denoise {
        scene.settings.denoise = Some(d.settings());
    }
    fit_camera(&mut scene)?;
    Ok((scene, record))
}

/// A lens camera's film set to the sensor window: the film diagonal becomes the window's
/// (cols x rows x pixel pitch), the lens keeps its film distance (its focus) and recomputes its
/// exit-pupil bounds (realistic) or checks the new film against its field heights (ray
/// transfer). The render (`width` x `height`) must have the window's aspect ratio (within 1 %),
/// so that each render pixel is a patch of the film of one size; it need not have its pixel count
/// (the sensor resamples the irradiance at its pitch).
pub fn fit_lens_film_to_sensor(
    scene: &mut SceneDescription,
    sensor: &Sensor,
    width: usize,
    height: usize,
) -> Result<()> {
    use camsim_scene3d::scene::CameraLens;
    let (cols, rows) = (sensor.cols() as f64, sensor.rows() as f64);
    if ((width as f64 / height as f64) / (cols / rows) - 1.0).abs() > 0.01 {
        return Err(PipelineError::config(format!(
            "render.resolution = [{width}, {height}]: a lens camera renders the film on the sensor window ({} x {} pixels), so the resolution must have its aspect ratio",
            sensor.cols(),
            sensor.rows()
        )));
    }
    let diagonal_mm = cols.hypot(rows) * sensor.pixel_pitch_m() * 1e3;
    let lens_err = |e: String| {
        PipelineError::Scene(format!(
            "the scene's lens camera on the {diagonal_mm:.3} mm diagonal of the sensor window: {e} (simulate puts the film on the sensor window: a smaller window, [sensor] rows and cols, is a smaller film)"
        ))
    };
    let (lens, fov_deg) = match scene.camera.lens.take() {
        Some(CameraLens::Realistic(l)) => {
            let camera = camsim_lens::LensCamera::new(
                l.camera.lens.clone(),
                l.camera.film_distance_mm,
                diagonal_mm,
            )
            .map_err(|e| lens_err(e.to_string()))?;
            let realistic =
                camsim_scene3d::camera::realistic_lens_with_pinhole(camera, diagonal_mm);
            let fov_deg = realistic.fov_deg(width, height);
            (CameraLens::Realistic(realistic), fov_deg)
        }
        Some(CameraLens::RayTransfer(l)) => {
            let (rt, fov_deg) = camsim_scene3d::camera::ray_transfer_lens(
                (*l.rtf).clone(),
                camsim_scene3d::camera::RtfFilm::DistanceMm(
                    l.rtf.plane_offset_input_mm + l.film_offset_mm,
                ),
                diagonal_mm,
                width,
                height,
            )
            .map_err(lens_err)?;
            (CameraLens::RayTransfer(rt), fov_deg)
        }
        None => return Ok(()),
    };
    scene.camera.lens = Some(lens);
    scene.camera.fov_deg = fov_deg;
    scene.camera.width = width;
    scene.camera.height = height;
    Ok(())
}

/// The film of a lens camera's render as what it is: sensor-plane spectral irradiance, W/(m^2
/// nm), sampled at the film's pixel pitch (the realistic camera's weight cos^4(theta) A / D^2 is a
/// projected solid angle, so its pixel values are E = L x sr; pbrt-v4 4th ed. sec. 5.3.5).
pub(crate) fn film_as_irradiance(scene: &SceneDescription, img: &mut SpectralImage) {
    use camsim_scene3d::scene::CameraLens;
    let diagonal_mm = match &scene.camera.lens {
        Some(CameraLens::Realistic(l)) => l.film_diagonal_mm,
        Some(CameraLens::RayTransfer(l)) => l.film_diagonal_mm,
        None => return,
    };
    let half = camsim_scene3d::camera::film_half_extent_mm(diagonal_mm, img.cols, img.rows);
    img.quantity = camsim_core::Quantity::Irradiance;
    img.sample_spacing_m = 2.0 * half[0] * 1e-3 / img.cols as f64;
}

/// `simulate` with a `[render]` section: render [`render_section_scene`]. A lens camera's image
/// comes back as sensor-plane irradiance (its quantity says so), the others' as scene radiance.
pub fn render_section(
    r: &RenderSection,
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    progress: &Progress<'_>,
) -> Result<(SpectralImage, camsim_render::IdMaps)> {
    let out = render_section_with(
        r,
        cfg,
        sensor,
        optics,
        &camsim_render::RenderRequest::default(),
        progress,
    )?;
    Ok((out.radiance, out.ids))
}

/// [`render_section`] with the renderer's extra outputs (`request`: labels), the whole
/// [`RenderOutput`] (a lens camera's `radiance` is its film irradiance).
pub fn render_section_with(
    r: &RenderSection,
    cfg: &SimulateConfig,
    sensor: &Sensor,
    optics: &Optics,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<RenderOutput> {
    let scene = render_section_scene(r, cfg, sensor, optics)?;
    render_scene_with(&scene, request, progress)
}

/// Render a scene set up by [`render_section_scene`] with `request`'s extra outputs; a lens
/// camera's film comes back as sensor-plane irradiance.
pub fn render_scene_with(
    scene: &SceneDescription,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<RenderOutput> {
    let mut out = camsim_render::render_with(scene, request, &|done, total| {
        progress("render", done, total)
    })?;
    film_as_irradiance(scene, &mut out.radiance);
    Ok(out)
}

/// The scene stage's render of a `[render]` section's scene: [`render_scene_with`] with the
/// section's light groups split out and weighed into the radiance (`[render] light_groups`).
pub(crate) fn render_stage(
    scene: &SceneDescription,
    r: &RenderSection,
    request: &camsim_render::RenderRequest,
    progress: &Progress<'_>,
) -> Result<RenderOutput> {
    let mut request = *request;
    request.light_groups |= r.light_groups.is_some();
    let mut out = render_scene_with(scene, &request, progress)?;
    if let Some(w) = &r.light_groups {
        crate::light_groups::weigh(&mut out.radiance, &out.light_groups, w)?;
    }
    Ok(out)
}
