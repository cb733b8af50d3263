//! `camsim render`: a 3D scene (pbrt-v4 file or built-in) -> spectral radiance, depth, preview.

use crate::common::{self, say};
use anyhow::{Context, Result};
use camsim_core::WavelengthGrid;
use camsim_pipeline::render::{load_scene, render_scene};
use camsim_render::RenderOutput;
use camsim_scene3d::builtin::{BuiltinOptions, MccPosition};
use camsim_scene3d::SceneDescription;
use std::path::PathBuf;

/// Render a 3D scene to spectral radiance (W/(sr m^2 nm)) with a spectral path tracer.
///
/// Input: a pbrt-v4 scene file (the subset described in README.md) or a built-in scene
/// (cornell-box, cornell-box-mcc, slanted-edge). An overlay TOML moves or replaces objects and
/// sets reflectances and the light's spectrum, as ISET3d does. Writes radiance.exr (spectral
/// OpenEXR with the depth as channel Z), depth.exr (m), variance.exr, preview.png (sRGB),
/// object_id.png and material_id.png (16-bit: 1 + index of the shape and of its material met
/// first through each pixel centre, 0 = none) with their legend ids.json, and render.json (settings, the samples per pixel actually taken, and ray statistics) in --out.
///
/// Command-line options win over the scene file and the overlay: an explicit --resolution, --spp
/// or --max-depth replaces what the pbrt file or the overlay says.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim render --builtin cornell-box --resolution 128x128 --spp 16 --out out/render-box\n  camsim render --builtin cornell-box-mcc --mcc-position left --resolution 252x189 --out out/render-left\n  camsim render examples/pbrt/cornell-box.pbrt --resolution 160x120 --spp 16 --out out/render-pbrt\n  camsim render --builtin cornell-box --overlay examples/overlays/d65-light-grey-box.toml --spp 16\n  camsim render --builtin cornell-box-mcc --overlay examples/overlays/cornell-fog.toml --resolution 160x120 --spp 8 --out out/fog   (fog: a participating medium)\n  camsim render --builtin slanted-edge --distance-m 0.5 --resolution 256x256 --spp 16 --out out/render-edge\n  camsim render --builtin cornell-box --spp 100000 --time-budget-s 2 --out out/budget   (~2 s)\n  camsim render --config examples/cornell-box.toml --spp 4 --out out/box-render   (as simulate renders it)"
)]
pub struct Args {
    /// pbrt-v4 scene file.
    pub scene: Option<PathBuf>,
    /// A built-in scene instead of a file: cornell-box, cornell-box-mcc, slanted-edge.
    #[arg(long, conflicts_with = "scene")]
    pub builtin: Option<String>,
    /// A simulate config with a `[render]` table: render its scene exactly as `camsim simulate`
    /// does (its resolution, samples, seed, wavelengths, and the field of view of the sensor
    /// window through the lens), so `render -> optics -> sensor` reproduces `simulate`.
    #[arg(long, conflicts_with_all = ["scene", "builtin", "overlay", "mcc_position", "distance_m"])]
    pub config: Option<PathBuf>,
    /// Overlay TOML (scene control: move objects, set spectra).
    #[arg(long)]
    pub overlay: Option<PathBuf>,
    /// Samples per pixel (default: the file's Sampler or the built-in's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Opt-in wall-clock limit, s: stop after the first whole pass of 8 samples per pixel that
    /// ends past it (the result then depends on the machine's speed; render.json reports the
    /// samples taken). Default: no limit, all --spp samples.
    #[arg(long, value_parser = common::positive_f64)]
    pub time_budget_s: Option<f64>,
    /// Image size WIDTHxHEIGHT (default: the pbrt file's Film, the overlay's [camera]
    /// resolution, or the built-in's). Given here, it wins over both.
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(usize, usize)>,
    /// Maximum path depth (bounces).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// ColorChecker position in cornell-box-mcc: left, center, right, or X,Y in metres.
    #[arg(long, default_value = "center")]
    pub mcc_position: String,
    /// Target distance of the slanted-edge scene, m.
    #[arg(long, default_value_t = 0.5, value_parser = common::positive_f64)]
    pub distance_m: f64,
    /// Render seed (default 1, or the --config file's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder.
    #[arg(long, default_value = "out/render")]
    pub out: PathBuf,
}

pub fn parse_resolution(s: &str) -> std::result::Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}': use WIDTHxHEIGHT, e.g. 640x480"))?;
    let w: usize = w
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': width is not a whole number"))?;
    let h: usize = h
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': height is not a whole number"))?;
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(format!("'{s}': width and height must be 1..65536"));
    }
    Ok((w, h))
}

/// Render with a progress bar.
fn render_with_progress(scene: &SceneDescription) -> Result<RenderOutput> {
    let pb = common::progress(1, "render");
    let out = render_scene(scene, &|_, done, total| {
        pb.set_length(total);
        pb.set_position(done);
    })?;
    pb.finish_and_clear();
    Ok(out)
}

pub fn run(a: Args) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a
        .scene
        .iter()
        .chain(a.overlay.iter())
        .chain(a.config.iter())
        .map(|p| p.as_path())
        .collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let out = staged.path().to_path_buf();
    let mcc: MccPosition = a.mcc_position.parse()?;
    let mut opts = BuiltinOptions {
        resolution: a.resolution,
        mcc_position: mcc,
        target_distance_m: a.distance_m,
        grid: WavelengthGrid::default(),
        seed: a.seed.unwrap_or(1),
        ..BuiltinOptions::default()
    };
    if let Some(spp) = a.spp {
        opts.samples_per_pixel = spp;
    }
    let mut scene = match &a.config {
        Some(path) => {
            let mut cfg = camsim_pipeline::SimulateConfig::load(path)?;
            if let Some(seed) = a.seed {
                cfg.seed = seed;
            }
            let section = cfg.render.clone().ok_or_else(|| {
                anyhow::anyhow!("{}: has no [render] table to render", path.display())
            })?;
            camsim_pipeline::render::render_section_scene(
                &section,
                &cfg,
                &cfg.sensor()?,
                &cfg.optics()?,
            )?
        }
        None => load_scene(
            a.builtin.as_deref(),
            a.scene.as_deref(),
            a.overlay.as_deref(),
            &opts,
        )?,
    };
    for n in &scene.notes {
        say(format!("note: {n}"));
    }
    // Explicit command-line settings win over the file's and the overlay's.
    if let Some(spp) = a.spp {
        scene.settings.samples_per_pixel = spp;
    }
    if let Some((w, h)) = a.resolution {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    if let Some(d) = a.max_depth {
        scene.settings.max_depth = d;
    }
    if a.time_budget_s.is_some() {
        scene.settings.time_budget_s = a.time_budget_s;
    }
    let r = render_with_progress(&scene)?;
    let (rows, cols) = (r.radiance.rows, r.radiance.cols);
    let samples_taken = r.samples_per_pixel.iter().copied().max().unwrap_or(0);
    camsim_io::exr::write_spectral_exr(&out.join("radiance.exr"), &r.radiance, "render")?;
    camsim_io::exr::write_gray_exr(&out.join("depth.exr"), rows, cols, "Z", &r.depth_m)?;
    camsim_io::exr::write_gray_exr(&out.join("variance.exr"), rows, cols, "Y", &r.variance)?;
    camsim_pipeline::write_id_maps(&out, &r.ids)?;
    let srgb = camsim_isp::preview::radiance_srgb8(&r.radiance);
    camsim_io::raster::write_png8_rgb(&out.join("preview.png"), rows, cols, &srgb)?;
    let info = serde_json::json!({
        "camsim_version": env!("CARGO_PKG_VERSION"),
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "scene": a.scene.as_ref().or(a.config.as_ref()).map(|p| p.display().to_string()).or(a.builtin.clone()),
        "resolution": [cols, rows],
        // The samples actually taken (fewer than asked when a time budget stopped the render).
        "samples_per_pixel": samples_taken,
        "samples_per_pixel_requested": scene.settings.samples_per_pixel,
        "time_budget_s": scene.settings.time_budget_s,
        "max_depth": scene.settings.max_depth,
        "wavelengths_per_path": scene.settings.wavelengths_per_path,
        "seed": scene.settings.seed,
        "horizontal_fov_deg": scene.camera.horizontal_fov_deg(),
        "stats": {
            "camera_rays": r.stats.camera_rays, "bounce_rays": r.stats.bounce_rays,
            "shadow_rays": r.stats.shadow_rays, "seconds": r.stats.seconds,
            "samples_per_second": r.stats.samples_per_second, "rays_per_second": r.stats.rays_per_second,
        },
        "notes": scene.notes,
    });
    camsim_io::atomic::write_json_atomic(&out.join("render.json"), &info).context("render.json")?;
    say(format!(
        "rendered {cols}x{rows}, {samples_taken} spp{} in {:.1} s ({:.2} Mrays/s) -> {}",
        if samples_taken < scene.settings.samples_per_pixel {
            format!(
                " (of {} asked; the time budget stopped it)",
                scene.settings.samples_per_pixel
            )
        } else {
            String::new()
        },
        r.stats.seconds,
        r.stats.rays_per_second / 1e6,
        a.out.display()
    ));
    common::commit(staged)?;
    Ok(())
}
