//! `camsim render`: a 3D scene (pbrt-v4 file or built-in) -> spectral radiance, depth, preview.

use crate::common::{self, say};
use anyhow::Result;
use camsim::pipeline::render::{render_scene, request_scene, RenderRequest, Rendered};
use camsim::scene3d::builtin::MccPosition;
use std::path::PathBuf;

/// Render a 3D scene to spectral radiance (W/(sr m^2 nm)) with a spectral path tracer.
///
/// Input: a pbrt-v4 scene file (the subset described in README.md), a glTF 2.0 / GLB or OBJ
/// asset (docs/src/assets.md), or a built-in scene
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
    after_help = "Examples:\n  camsim render --builtin cornell-box --resolution 128x128 --spp 16 --out out/render-box\n  camsim render --builtin cornell-box-mcc --mcc-position left --resolution 252x189 --out out/render-left\n  camsim render examples/pbrt/cornell-box.pbrt --resolution 160x120 --spp 16 --out out/render-pbrt\n  camsim render ../shared/scenes/gltf/room.glb --resolution 256x192 --spp 16 --out out/render-room   (glTF: its camera, cd/m^2 emitters)\n  camsim render --builtin cornell-box --overlay examples/overlays/d65-light-grey-box.toml --spp 16\n  camsim render --builtin cornell-box-mcc --overlay examples/overlays/cornell-fog.toml --resolution 160x120 --spp 8 --out out/fog   (fog: a participating medium)\n  camsim render --builtin slanted-edge --distance-m 0.5 --resolution 256x256 --spp 16 --out out/render-edge\n  camsim render --builtin cornell-box --spp 100000 --time-budget-s 2 --out out/budget   (~2 s)\n  camsim render --builtin cornell-box --resolution 64x64 --spp 512 --adaptive-error 0.05 --out out/adaptive   (each pixel's luminance to 5 %)\n  camsim render --config examples/cornell-box.toml --spp 4 --out out/box-render   (as simulate renders it)"
)]
pub struct Args {
    /// Scene file: pbrt-v4, glTF 2.0 (`.gltf` with its buffers and images, `.glb`) or OBJ/MTL;
    /// the format is read from the file's content. glTF is read in its physical units
    /// (emissive cd/m^2, lights in cd and lux) with its own camera, or camsim's framing camera
    /// when it has none (docs/src/assets.md).
    pub scene: Option<PathBuf>,
    #[arg(long, conflicts_with = "scene", help = format!("A built-in scene instead of a file: {}", camsim::scene3d::builtin::BUILTIN_SCENES.known()))]
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
    /// Adaptive sampling: each pixel stops once the standard error of its mean luminance is
    /// this fraction of the mean (0.01: 1 %), tested after every pass of 8 samples from
    /// --min-spp on; --spp is then the most a pixel takes. samples.exr holds each pixel's
    /// count, render.json the mean. Default: every pixel takes --spp. (`camsim simulate`'s
    /// `[render.adaptive]` targets the sensor's own noise instead; docs/src/adaptive.md.)
    #[arg(long, value_parser = common::positive_f64)]
    pub adaptive_error: Option<f64>,
    /// Samples every pixel takes before adaptive sampling's first test (default 32).
    #[arg(long)]
    pub min_spp: Option<u32>,
    /// Denoise the radiance with Intel Open Image Denoise, guided by the first surfaces' albedo
    /// and normals (for training data; it changes MTF, colour and noise figures:
    /// docs/src/adaptive.md). camsim opens the library at run time: set CAMSIM_OIDN_LIBRARY to
    /// libOpenImageDenoise.so.* (e.g. from `pip install oidn`). variance.exr stays the
    /// undenoised film's.
    #[arg(long)]
    pub denoise: bool,
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
    /// glTF: the scene to read, by name or index (default: the file's `scene`, else the first).
    /// A --config file says it as `[render.asset] scene`.
    #[arg(long, conflicts_with_all = ["builtin", "config"])]
    pub gltf_scene: Option<String>,
    /// glTF: the camera to look through, by node or camera name or by index (default: the
    /// first in the scene's node order; camsim's framing camera when the file has none).
    #[arg(long, conflicts_with_all = ["builtin", "config"])]
    pub gltf_camera: Option<String>,
    /// OBJ: metres per file unit, since OBJ has none (default 1: metres; 0.01 for a file in
    /// centimetres, 0.001 in millimetres).
    #[arg(long, value_parser = common::positive_f64, conflicts_with_all = ["builtin", "config"])]
    pub obj_scale_m: Option<f64>,
    /// OBJ: the file's up axis, y (the OBJ and glTF convention, default) or z (CAD and 3D-scan
    /// exports).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["y", "z"]), conflicts_with_all = ["builtin", "config"])]
    pub obj_up: Option<String>,
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

pub fn run(a: Args) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a
        .scene
        .iter()
        .chain(a.overlay.iter())
        .chain(a.config.iter())
        .map(|p| p.as_path())
        .collect();
    let staged = common::stage_out_dir_reading(&a.out, &inputs)?;
    let req = RenderRequest {
        builtin: a.builtin.clone(),
        pbrt: a.scene.clone(),
        overlay: a.overlay.clone(),
        config: a
            .config
            .as_deref()
            .map(camsim::SimulateConfig::load)
            .transpose()?,
        samples_per_pixel: a.spp,
        resolution: a.resolution,
        max_depth: a.max_depth,
        time_budget_s: a.time_budget_s,
        adaptive_error: a.adaptive_error,
        min_samples: a.min_spp,
        denoise: a.denoise,
        mcc_position: a.mcc_position.parse::<MccPosition>()?,
        distance_m: a.distance_m,
        seed: a.seed,
        asset: camsim::pipeline::AssetReadSection {
            scene: a.gltf_scene.clone(),
            camera: a.gltf_camera.clone(),
            obj_scale_m: a.obj_scale_m,
            obj_up_axis: a.obj_up.clone(),
        },
        ..RenderRequest::default()
    };
    let scene = request_scene(&req).map_err(|e| match &a.config {
        Some(p) => anyhow::anyhow!("{}: {e}", p.display()),
        None => e.into(),
    })?;
    for n in &scene.notes {
        say(format!("note: {n}"));
    }
    let pb = common::progress(1, "render");
    let output = render_scene(&scene, &|_, done, total| {
        pb.set_length(total);
        pb.set_position(done);
    })?;
    pb.finish_and_clear();
    let rendered = Rendered { scene, output };
    let name = a
        .scene
        .as_ref()
        .or(a.config.as_ref())
        .map(|p| p.display().to_string())
        .or(a.builtin.clone());
    let rec = rendered.write_files(
        &staged,
        name,
        Some(std::env::args().collect::<Vec<_>>().join(" ")),
    )?;
    say(format!(
        "rendered {}x{}, {} spp{}{} in {:.1} s ({:.2} Mrays/s) -> {}",
        rec.resolution[0],
        rec.resolution[1],
        rec.samples_per_pixel,
        if rec.adaptive.is_some() {
            format!(
                " at most, {:.1} spp on average (adaptive, of {} at most)",
                rec.samples_per_pixel_mean, rec.samples_per_pixel_requested
            )
        } else if rec.samples_per_pixel < rec.samples_per_pixel_requested {
            format!(
                " (of {} asked; the time budget stopped it)",
                rec.samples_per_pixel_requested
            )
        } else {
            String::new()
        },
        if rec.denoised_with.is_some() {
            ", denoised"
        } else {
            ""
        },
        rec.stats.seconds,
        rec.stats.rays_per_second / 1e6,
        a.out.display()
    ));
    common::commit(staged)?;
    Ok(())
}
