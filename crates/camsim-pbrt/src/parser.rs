//! The scene builder (pbrt-v4 `BasicSceneBuilder`): the [`ParserTarget`] that `reader.rs` hands
//! each directive to. It keeps the graphics state and the attribute stack and turns directives
//! into camsim-scene3d objects (transforms, shapes, materials, textures, lights, media). See the
//! module docs of [`crate`] for what is supported.

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

use super::images::{self, load_image, parse_encoding, Encoding};
use super::params::{Param, ParamList};
use super::reader::{resolve_path, Args, ParserTarget, Reader, MAX_ERRORS};
use super::spectra::{param_spectrum, ParsedSpectrum, SpectrumUse};
use super::xform::{self, inverse};
use super::{Loc, PbrtError};
use crate::scene::{
    AreaLight, Camera, CameraLens, EmissionImage, FloatTexture, Geometry, Light, Material,
    RenderSettings, SceneDescription, Shape, Texture, Transform,
};
use crate::scene::{LightSampler, SamplerKind};
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::Spectrum;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

mod curves;
mod hair;
mod lights;
mod materials;
mod media;
mod textures;

// The directive families, dispatched by `ParserTarget::directive` of `SceneBuilder`.
mod blocks;
mod motion;
use motion::flush_motion;
mod options;
mod shapes;
mod transforms;
mod world;

#[derive(Debug, Clone)]
enum MatRef {
    Index(usize),
    Named(String, Loc),
}

#[derive(Debug, Clone)]
struct AreaLightSpec {
    spectrum: ParsedSpectrum,
    scale: f64,
    two_sided: bool,
    power: Option<f64>,
    /// `filename`: the emission image and its mean luminance `Y(rgb)` (Rec. 709 weights, the
    /// sRGB colour space's luminance vector), pbrt-v4's `k_e` factor for `power`.
    image: Option<(std::sync::Arc<EmissionImage>, f64)>,
    /// camsim's `"string lightgroup"`: the light group of the emitter's radiance.
    group: Option<String>,
}

#[derive(Debug, Clone)]
struct GraphicsState {
    ctm: Transform,
    /// The CTM at the end time (pbrt-v4 keeps a pair; they differ for animated transforms,
    /// `parser/motion.rs`).
    ctm_end: Transform,
    /// False after `ActiveTransform EndTime`: transforms then only affect the end time.
    start_active: bool,
    /// False after `ActiveTransform StartTime`.
    end_active: bool,
    reverse_orientation: bool,
    material: MatRef,
    area_light: Option<AreaLightSpec>,
    name: Option<String>,
    /// `Attribute "category" ...` defaults (pbrt-v4 graphics-state shape/light/material/
    /// medium/texture attributes): `(category, parameter)`, scoped like the rest of the state.
    attributes: Vec<(&'static str, Param)>,
    /// The media selected by `MediumInterface` (none: vacuum on both sides).
    medium: Option<media::MediumNames>,
}

#[derive(Debug, Clone)]
struct PendingShape {
    shape: Shape,
    mat: MatRef,
    /// Area light still to be turned into radiance (needs the world-space area for `power`).
    light: Option<AreaLightSpec>,
    /// One pbrt shape tessellated into triangles (disk, cylinder): `power` applies to the whole
    /// mesh, not per triangle as for a pbrt triangle mesh.
    single: bool,
    /// The shape's `alpha` when it varies or is fractional (a constant 1 is `None`, a constant
    /// 0 drops the shape), keyed by its parameter text so shapes sharing one material and one
    /// alpha share one [`Material::AlphaMasked`].
    alpha: Option<(String, FloatTexture)>,
    /// The media on the shape's two sides (`MediumInterface` current at the shape).
    medium: Option<media::MediumNames>,
    /// An animated CTM (`parser/motion.rs`): the shape is stored at the start transform.
    motion: Option<camsim_scene3d::motion::Motion>,
}

enum Block {
    Attribute,
    Transform,
}

struct SceneBuilder {
    main_dir: PathBuf,
    in_world: bool,
    gs: GraphicsState,
    stack: Vec<(GraphicsState, Block, Loc)>,
    named_coords: HashMap<String, Transform>,
    /// The end-time transforms of `named_coords`.
    named_coords_end: HashMap<String, Transform>,
    /// pbrt-v4 `TransformTimes` (options block), s.
    transform_times: (f64, f64),
    materials: Vec<Material>,
    named_materials: HashMap<String, usize>,
    /// Roughness textures read by the material being built (see `parser/materials.rs`).
    varying: Option<(FloatTexture, FloatTexture, bool)>,
    textures: HashMap<String, Texture>,
    float_textures: HashMap<String, FloatTexture>,
    /// Normal map images by resolved path (pbrt-v4 reads each file once).
    normal_maps: HashMap<PathBuf, std::sync::Arc<crate::scene::NormalMapImage>>,
    shapes: Vec<PendingShape>,
    lights: Vec<Light>,
    /// Light group of each entry of `lights` (`"string lightgroup"`).
    light_groups: Vec<Option<String>>,
    /// Object instances numbered so far (`ShapeTags::instance`).
    instances: u32,
    objects: HashMap<String, Vec<PendingShape>>,
    current_object: Option<(String, Vec<PendingShape>, Loc)>,
    camera_from_world: Transform,
    fov_deg: f64,
    width: usize,
    height: usize,
    /// A `Camera "realistic"`: set up once the film is known (the `Film` may follow it).
    realistic: Option<PendingRealistic>,
    /// A `Camera "raytransfer"`: its RTF, set up once the film is known.
    ray_transfer: Option<(camsim_lens::Rtf, camsim_scene3d::camera::RtfFilm, Loc)>,
    /// `Film` `diagonal`, mm (pbrt-v4 default 35).
    film_diagonal_mm: f64,
    settings: RenderSettings,
    focus_distance_m: Option<f64>,
    notes: Vec<String>,
    /// Problems found so far (reported together at the end).
    errors: Vec<PbrtError>,
    /// Participating media and what selects them (`parser/media.rs`).
    media: media::ParsedMedia,
}

/// Parse a whole scene.
pub fn parse(text: &str, path: &Path) -> Result<SceneDescription, PbrtError> {
    let main_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let default_material = Material::Diffuse {
        reflectance: Texture::Constant(
            Spectrum::from_pairs(&[(360.0, 0.5), (830.0, 0.5)])
                .with_extrapolation(camsim_core::spectrum::Extrapolation::Hold),
        ),
    };
    let mut p = SceneBuilder {
        main_dir,
        in_world: false,
        gs: GraphicsState {
            ctm: Transform::identity(),
            ctm_end: Transform::identity(),
            start_active: true,
            end_active: true,
            reverse_orientation: false,
            material: MatRef::Index(0),
            area_light: None,
            name: None,
            attributes: Vec::new(),
            medium: None,
        },
        stack: Vec::new(),
        named_coords: HashMap::new(),
        named_coords_end: HashMap::new(),
        transform_times: (0.0, 1.0),
        materials: vec![default_material],
        named_materials: HashMap::new(),
        varying: None,
        textures: HashMap::new(),
        float_textures: HashMap::new(),
        normal_maps: HashMap::new(),
        shapes: Vec::new(),
        lights: Vec::new(),
        light_groups: Vec::new(),
        instances: 0,
        objects: HashMap::new(),
        current_object: None,
        camera_from_world: Transform::identity(),
        fov_deg: 90.0,
        width: 1280,
        height: 720,
        realistic: None,
        ray_transfer: None,
        film_diagonal_mm: 35.0,
        settings: RenderSettings {
            samples_per_pixel: 16,
            max_depth: 5,
            // pbrt-v4's default `PixelFilter` (BasicSceneBuilder): gaussian, radius 1.5, sigma 0.5.
            filter: crate::scene::PixelFilter::Gaussian {
                radius: [1.5, 1.5],
                sigma: 0.5,
            },
            ..RenderSettings::default()
        },
        focus_distance_m: None,
        notes: Vec::new(),
        errors: Vec::new(),
        media: Default::default(),
    };
    // An `Err` here means reading stopped early (too many problems); they are all in `errors`.
    let mut reader = Reader::new(path);
    let _ = reader.read_text(text, path, &mut p);
    p.errors = reader.errors;
    if reader.aborted {
        p.notes
            .push(format!("reading stopped after {MAX_ERRORS} problems"));
    }
    let eof = Loc {
        file: path.to_path_buf(),
        line: text.lines().count().max(1),
        column: 1,
    };
    if !p.stack.is_empty() {
        p.notes.push(format!(
            "{}: {} AttributeBegin/TransformBegin without an end (pbrt-v4 warns too)",
            eof.describe(),
            p.stack.len()
        ));
    }
    if let Some((name, _, loc)) = &p.current_object {
        let e = loc.err(format!("ObjectBegin \"{name}\" has no ObjectEnd"));
        p.errors.push(e);
    }
    if !p.in_world {
        p.notes.push(format!(
            "{}: no WorldBegin: the scene has no objects",
            path.display()
        ));
    }
    p.finish()
}

/// The scene builder as the reader's target (pbrt-v4's `BasicSceneBuilder` as a
/// `ParserTarget`): each directive family is handled in its own module under `parser/`.
impl ParserTarget for SceneBuilder {
    type Saved = (GraphicsState, usize);

    fn directive(&mut self, d: &str, args: &mut Args, loc: &Loc) -> Result<(), PbrtError> {
        match d {
            "Identity" | "Translate" | "Scale" | "Rotate" | "LookAt" | "Transform"
            | "ConcatTransform" | "CoordinateSystem" | "CoordSysTransform" | "ActiveTransform"
            | "TransformTimes" | "ReverseOrientation" => self.transform_directive(d, args, loc),
            "AttributeBegin" | "TransformBegin" | "AttributeEnd" | "TransformEnd"
            | "WorldBegin" | "WorldEnd" | "ObjectBegin" | "ObjectEnd" | "ObjectInstance"
            | "Attribute" => self.block_directive(d, args, loc),
            "Camera" | "Film" | "Sampler" | "Integrator" | "PixelFilter" | "Accelerator"
            | "ColorSpace" | "Option" => self.option_directive(d, args, loc),
            "Material" | "MakeNamedMaterial" | "NamedMaterial" | "Texture" | "AreaLightSource"
            | "LightSource" | "Shape" | "MakeNamedMedium" | "MediumInterface" => {
                self.world_directive(d, args, loc)
            }
            other => Err(loc.err(format!("unknown directive \"{other}\""))),
        }
    }

    fn object_name(&mut self, name: String) {
        self.gs.name = Some(name);
    }

    /// Import: the imported file cannot change the includer's graphics state.
    fn begin_import(&mut self, loc: &Loc) -> Result<Self::Saved, PbrtError> {
        if !self.in_world {
            return Err(loc.err("Import is only allowed after WorldBegin"));
        }
        Ok((self.gs.clone(), self.stack.len()))
    }

    fn end_import(&mut self, saved: Self::Saved) {
        self.stack.truncate(saved.1);
        self.gs = saved.0;
    }
}

impl SceneBuilder {
    fn resolve(&self, including_file: &Path, name: &str) -> PathBuf {
        resolve_path(&self.main_dir, including_file, name)
    }

    fn note(&mut self, loc: &Loc, msg: impl AsRef<str>) {
        self.notes
            .push(format!("{}: {}", loc.describe(), msg.as_ref()));
    }

    fn ignore_params(&mut self, params: &ParamList, names: &[&str], what: &str) {
        for n in names {
            if let Some(loc) = params.ignore(n) {
                self.note(&loc, format!("{what}: parameter \"{n}\" ignored"));
            }
        }
    }

    fn apply_transform(&mut self, t: Transform) {
        if self.gs.start_active {
            self.gs.ctm = self.gs.ctm.then_apply_to(&t);
        }
        if self.gs.end_active {
            self.gs.ctm_end = self.gs.ctm_end.then_apply_to(&t);
        }
    }

    fn require_world(&self, loc: &Loc, d: &str, world: bool) -> Result<(), PbrtError> {
        if world && !self.in_world {
            return Err(loc.err(format!("{d} is only allowed after WorldBegin")));
        }
        if !world && self.in_world {
            return Err(loc.err(format!(
                "{d} is only allowed before WorldBegin (in the options block)"
            )));
        }
        Ok(())
    }

    fn camera_world_check(&mut self) {}

    /// pbrt-v4 `ParameterDictionary(params, attributes)`: a directive's own parameters first,
    /// then the `Attribute` defaults of its category that it does not give. Defaults are marked
    /// used up front: as in pbrt-v4, an attribute a directive does not read is not an error.
    fn with_attributes(&self, category: &str, mut params: ParamList) -> ParamList {
        for (c, p) in &self.gs.attributes {
            if *c == category && !params.params.iter().any(|q| q.name == p.name) {
                let q = p.clone();
                q.used.set(true);
                params.params.push(q);
            }
        }
        params
    }

    fn spectrum_param(
        &self,
        params: &ParamList,
        name: &str,
        usage: SpectrumUse,
        file: &Path,
    ) -> Result<Option<ParsedSpectrum>, PbrtError> {
        match params.get(name, &["rgb", "spectrum", "blackbody"])? {
            None => Ok(None),
            Some(p) => {
                let resolve = |n: &str| self.resolve(file, n);
                Ok(Some(param_spectrum(p, usage, &resolve)?))
            }
        }
    }

    fn camera(&mut self, ty: &str, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        if ty == "realistic" {
            return self.realistic_camera(params, loc);
        }
        if ty == "raytransfer" {
            return self.ray_transfer_camera(params, loc);
        }
        if ty != "perspective" {
            return Err(loc.err(format!(
                "Camera \"{ty}\" is not supported (\"perspective\", \"realistic\", \"raytransfer\")"
            )));
        }
        self.realistic = None;
        self.ray_transfer = None;
        let fov = params.float("fov", 90.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(loc.err(format!(
                "Camera: fov {fov} must be between 0 and 180 degrees"
            )));
        }
        let lens_radius = params.float("lensradius", 0.0)?;
        let focal = params.float_opt("focaldistance")?;
        if params.get("screenwindow", &["float"])?.is_some() {
            return Err(loc.err("Camera: \"screenwindow\" is not supported"));
        }
        self.ignore_params(params, &["frameaspectratio"], "Camera");
        self.camera_time(params, loc)?;
        params.check_unused("Camera \"perspective\"")?;
        if lens_radius > 0.0 {
            self.note(loc, format!(
                "Camera: lensradius {lens_radius} ignored: camsim renders a pinhole camera; depth of field is applied by the optics stage{}",
                focal.map(|f| format!(" (focus distance {f} m)")).unwrap_or_default()
            ));
        }
        if let Some(fd) = focal {
            if fd > 0.0 {
                self.focus_distance_m = Some(fd);
            }
        }
        self.fov_deg = fov;
        self.camera_from_world = self.gs.ctm;
        let world_from_camera = inverse(&self.gs.ctm)
            .ok_or_else(|| loc.err("Camera: the camera transform is singular"))?;
        self.named_coords.insert("camera".into(), world_from_camera);
        Ok(())
    }

    /// pbrt-v4 `Camera "realistic"`: `lensfile` (pbrt-v4 lens text or ISET3d JSON, relative to
    /// the scene file), `aperturediameter` (mm, default 1), `focusdistance` (m, default 10).
    fn realistic_camera(&mut self, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        let name = params
            .string("lensfile")?
            .ok_or_else(|| loc.err("Camera \"realistic\": \"lensfile\" is required"))?;
        let path = self.resolve(&loc.file, &name);
        let lens = camsim_lens::Lens::from_file(&path)
            .map_err(|e| loc.err(format!("Camera \"realistic\": lens file: {e}")))?;
        let aperture_diameter_mm = params.float("aperturediameter", 1.0)?;
        let focus_distance_m = params.float("focusdistance", 10.0)?;
        self.camera_time(params, loc)?;
        params.check_unused("Camera \"realistic\"")?;
        // Focused (and checked) at the end of the file, when the film's size is known; errors
        // name this directive.
        self.focus_distance_m = Some(focus_distance_m);
        self.realistic = Some(PendingRealistic {
            lens,
            aperture_diameter_mm,
            focus_distance_m,
            loc: loc.clone(),
        });
        self.camera_from_world = self.gs.ctm;
        let world_from_camera = inverse(&self.gs.ctm)
            .ok_or_else(|| loc.err("Camera: the camera transform is singular"))?;
        self.named_coords.insert("camera".into(), world_from_camera);
        Ok(())
    }

    /// ISET3d's `Camera "raytransfer"`: `lensfile` names a ray-transfer-function JSON (ISET/isetrtf
    /// layout, relative to the scene file); `filmdistance` (mm, film to the lens's sensor-side
    /// vertex, as ISET3d) places the film, or else `focusdistance` (m from the film, default
    /// infinity) focuses it by the RTF's autofocus.
    fn ray_transfer_camera(&mut self, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        use camsim_scene3d::camera::RtfFilm;
        let name = params
            .string("lensfile")?
            .ok_or_else(|| loc.err("Camera \"raytransfer\": \"lensfile\" is required"))?;
        let path = self.resolve(&loc.file, &name);
        let rtf = camsim_lens::Rtf::from_file(&path)
            .map_err(|e| loc.err(format!("Camera \"raytransfer\": lens file: {e}")))?;
        let film = match (
            params.float_opt("filmdistance")?,
            params.float_opt("focusdistance")?,
        ) {
            (Some(_), Some(_)) => {
                return Err(loc.err(
                    "Camera \"raytransfer\": give \"filmdistance\" or \"focusdistance\", not both",
                ));
            }
            (Some(d), None) => RtfFilm::DistanceMm(d),
            (None, Some(m)) => {
                self.focus_distance_m = Some(m);
                RtfFilm::FocusM(m)
            }
            (None, None) => RtfFilm::FocusM(f64::INFINITY),
        };
        self.camera_time(params, loc)?;
        params.check_unused("Camera \"raytransfer\"")?;
        self.realistic = None;
        self.ray_transfer = Some((rtf, film, loc.clone()));
        self.camera_from_world = self.gs.ctm;
        let world_from_camera = inverse(&self.gs.ctm)
            .ok_or_else(|| loc.err("Camera: the camera transform is singular"))?;
        self.named_coords.insert("camera".into(), world_from_camera);
        Ok(())
    }

    fn film(&mut self, ty: &str, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        if !matches!(ty, "rgb" | "spectral" | "gbuffer") {
            return Err(loc.err(format!(
                "Film \"{ty}\" is not supported (rgb, spectral, gbuffer)"
            )));
        }
        let w = params.int("xresolution", 1280)?;
        let h = params.int("yresolution", 720)?;
        for (v, n) in [(w, "xresolution"), (h, "yresolution")] {
            if !(1..=1_000_000).contains(&v) {
                return Err(loc.err(format!("Film: {n} {v} must be between 1 and 1000000")));
            }
        }
        self.width = w as usize;
        self.height = h as usize;
        let diagonal_mm = params.float("diagonal", 35.0)?;
        if !(diagonal_mm > 0.0 && diagonal_mm.is_finite()) {
            return Err(loc.err(format!("Film: diagonal {diagonal_mm} mm must be > 0")));
        }
        self.film_diagonal_mm = diagonal_mm;
        if let Some(l) = params.ignore("filename") {
            self.note(&l, "Film: filename ignored (camsim writes spectral radiance where the command line says)");
        }
        self.ignore_params(
            params,
            &[
                "iso", "exposuretime", "whitebalance", "sensor", "savefp16", "writefp16", "maxcomponentvalue",
                "cropwindow", "pixelbounds", "nbuckets", "lambdamin", "lambdamax", "coordinatesystem",
            ],
            "Film (camsim outputs spectral radiance; sensor, crop and bucket settings do not apply)",
        );
        params.check_unused(&format!("Film \"{ty}\""))?;
        if ty != "spectral" {
            self.note(
                loc,
                format!("Film \"{ty}\": camsim renders spectral radiance on its wavelength grid"),
            );
        }
        Ok(())
    }

    fn sampler(&mut self, ty: &str, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        let known = [
            "halton",
            "independent",
            "pmj02bn",
            "paddedsobol",
            "sobol",
            "zsobol",
            "stratified",
        ];
        if !known.contains(&ty) {
            self.note(
                loc,
                format!("warning: unknown Sampler \"{ty}\" (camsim uses its own sampler)"),
            );
        }
        let spp = if ty == "stratified" {
            let x = params.int("xsamples", 4)?;
            let y = params.int("ysamples", 4)?;
            params.bool("jitter", true)?;
            x.saturating_mul(y)
        } else {
            params.int("pixelsamples", 16)?
        };
        if !(1..=(1 << 24)).contains(&spp) {
            return Err(loc.err(format!("Sampler: {spp} samples per pixel is out of range")));
        }
        if let Some(seed) = params.int("seed", -1).ok().filter(|s| *s >= 0) {
            self.settings.seed = seed as u64;
        }
        self.ignore_params(params, &["randomization"], "Sampler");
        params.check_unused(&format!("Sampler \"{ty}\""))?;
        self.settings.samples_per_pixel = spp as u32;
        // pbrt-v4 "independent" keeps independent numbers; "sobol", "paddedsobol" and "zsobol"
        // get camsim's padded Owen-scrambled Sobol sampler, and so do the other
        // stratified types, approximated by it (camsim_render::sampler).
        match SamplerKind::from_name(ty) {
            Some(kind) => {
                self.settings.sampler = kind;
                self.note(
                    loc,
                    format!(
                        "Sampler \"{ty}\": camsim's {} sampler; {spp} samples per pixel",
                        kind.name()
                    ),
                );
            }
            None => {
                self.settings.sampler = SamplerKind::Sobol;
                self.note(
                    loc,
                    format!("Sampler \"{ty}\": approximated by camsim's padded Owen-scrambled Sobol sampler; {spp} samples per pixel"),
                );
            }
        }
        Ok(())
    }

    /// pbrt-v4 `Integrator`: every type that converges to the radiance a path tracer computes
    /// is rendered by camsim's path tracer, with a note naming the substitution; `volpath`,
    /// `simplevolpath` and every file with participating media by the volumetric path tracer
    /// (noted by `media::ParsedMedia::finish`); `ambientocclusion` is refused (it is not radiance).
    fn integrator(&mut self, ty: &str, params: &ParamList, loc: &Loc) -> Result<(), PbrtError> {
        // pbrt-v4's parameters of each type beyond `maxdepth` (camsim's path tracer has no use
        // for them: they tune the other algorithms' convergence, not the converged image).
        let extra: &[&str] = match ty {
            "path" | "volpath" => &["regularize"],
            "simplepath" => &["samplelights", "samplebsdf"],
            "simplevolpath" | "lightpath" | "randomwalk" => &[],
            "bdpt" => &[
                "regularize",
                "visualizestrategies",
                "visualizeweights",
            ],
            "mlt" => &[
                "bootstrapsamples",
                "chains",
                "mutationsperpixel",
                "largestepprobability",
                "sigma",
                "regularize",
            ],
            "sppm" => &["photonsperiteration", "radius", "seed", "iterations"],
            "ambientocclusion" => {
                return Err(loc.err(
                    "Integrator \"ambientocclusion\" is not supported: it computes ambient occlusion, not radiance, and camsim simulates a camera from radiance (use \"path\")",
                ))
            }
            _ => return Err(loc.err(format!(
                "Integrator \"{ty}\" is not supported (path, volpath, simplepath, simplevolpath, bdpt, lightpath, mlt, randomwalk, sppm: rendered by camsim's path tracer, or its volumetric one with media)"
            ))),
        };
        let d = params.int("maxdepth", 5)?;
        if !(0..=100_000).contains(&d) {
            return Err(loc.err(format!("Integrator: maxdepth {d} is out of range")));
        }
        self.settings.max_depth = d as u32;
        // pbrt-v4's `lightsampler` (path and volpath; camsim's path tracer also takes it from
        // bdpt files, which it renders): how next-event estimation chooses a light.
        if matches!(ty, "path" | "volpath" | "bdpt") {
            if let Some(name) = params.string("lightsampler")? {
                self.settings.light_sampler = match name.as_str() {
                    // pbrt-v4's `exhaustive` weighs every light by the importance the `bvh`
                    // sampler bounds; camsim's tree gives the same choice up to its bounds.
                    "exhaustive" => {
                        self.note(
                            loc,
                            "Integrator: lightsampler \"exhaustive\" approximated by \"bvh\"",
                        );
                        LightSampler::Bvh
                    }
                    n => LightSampler::from_name(n).ok_or_else(|| {
                        loc.err(format!(
                            "Integrator \"{ty}\": lightsampler \"{n}\" is unknown (use \"bvh\", \"power\", \"uniform\" or \"exhaustive\")"
                        ))
                    })?,
                };
            }
        }
        self.ignore_params(params, extra, &format!("Integrator \"{ty}\""));
        params.check_unused(&format!("Integrator \"{ty}\""))?;
        // How "volpath" (and any integrator with media) is rendered is noted at the end.
        self.media.integrator = Some((ty.to_string(), loc.clone()));
        if !matches!(ty, "path" | "volpath" | "simplevolpath") {
            self.note(
                loc,
                format!("Integrator \"{ty}\" rendered with camsim's path tracer (it converges to the same radiance)"),
            );
        }
        Ok(())
    }

    fn finish(self) -> Result<SceneDescription, PbrtError> {
        let mut shapes = Vec::with_capacity(self.shapes.len());
        let mut notes = self.notes;
        let mut errors = self.errors;
        let mut materials = self.materials;
        let mut media = self.media;
        let mut instances = self.instances;
        // (base material, alpha parameter text) -> its `AlphaMasked` material.
        let mut masked: HashMap<(usize, String), usize> = HashMap::new();
        let mut settings = self.settings;
        // Every shape made from one pending shape (an area light may split into triangles)
        // moves with it: (its first shape's index, motion), assigned when the next one starts.
        let mut moving: Option<(usize, camsim_scene3d::motion::Motion)> = None;
        for ps in self.shapes {
            flush_motion(&mut moving, shapes.len(), &mut settings);
            moving = ps.motion.clone().map(|m| (shapes.len(), m));
            let material = match &ps.mat {
                MatRef::Index(i) => *i,
                MatRef::Named(n, loc) => match self.named_materials.get(n) {
                    Some(i) => *i,
                    None => {
                        let e = loc.err(format!(
                            "NamedMaterial \"{n}\": no material of that name was defined"
                        ));
                        // One report per NamedMaterial directive, not per shape using it.
                        if !errors.contains(&e) {
                            errors.push(e);
                        }
                        continue;
                    }
                },
            };
            // A medium boundary wraps the material; an alpha mask wraps that.
            let material = match media.wrap(material, ps.medium.as_ref(), &mut materials) {
                Ok(m) => m,
                Err(e) => {
                    if !errors.contains(&e) {
                        errors.push(e);
                    }
                    continue;
                }
            };
            let material = match ps.alpha {
                None => material,
                Some((key, alpha)) => *masked.entry((material, key)).or_insert_with(|| {
                    materials.push(Material::AlphaMasked { material, alpha });
                    materials.len() - 1
                }),
            };
            let mut shape = ps.shape;
            shape.material = material;
            shape.tags.light_group = ps.light.as_ref().and_then(|l| l.group.clone());
            match ps.light {
                None => shapes.push(shape),
                Some(l) => emitting_shapes(
                    shape,
                    &l,
                    material,
                    ps.single,
                    &mut instances,
                    &mut notes,
                    &mut shapes,
                ),
            }
        }
        let media = media.finish(&mut notes);
        if let Err(e) = &media {
            errors.push(e.clone());
        }
        flush_motion(&mut moving, shapes.len(), &mut settings);
        if !errors.is_empty() {
            return Err(PbrtError::combine(errors));
        }
        let media = media?;
        let camera_to_world = inverse(&self.camera_from_world).unwrap_or_default();
        let (fov_deg, lens) = camera_lens(
            self.fov_deg,
            self.realistic,
            self.ray_transfer,
            self.film_diagonal_mm,
            self.width,
            self.height,
        )?;
        Ok(SceneDescription {
            camera: Camera {
                camera_to_world,
                fov_deg,
                width: self.width,
                height: self.height,
                lens,
            },
            shapes,
            materials,
            named_materials: self.named_materials,
            lights: self.lights,
            settings,
            focus_distance_m: self.focus_distance_m,
            notes,
            media,
            light_groups: self.light_groups,
        })
    }
}

/// The camera's horizontal field of view and lens: the pinhole's `fov_deg`, or those of a
/// `realistic` or `raytransfer` camera, set up now that the film (`film_diagonal_mm`, the
/// resolution) is known.
fn camera_lens(
    fov_deg: f64,
    realistic: Option<PendingRealistic>,
    ray_transfer: Option<(camsim_lens::Rtf, camsim_scene3d::camera::RtfFilm, Loc)>,
    film_diagonal_mm: f64,
    width: usize,
    height: usize,
) -> Result<(f64, Option<CameraLens>), PbrtError> {
    let (mut fov_deg, mut lens) = (fov_deg, None);
    if let Some(r) = realistic {
        let (l, f) = crate::camera::realistic_lens(
            r.lens,
            r.aperture_diameter_mm,
            r.focus_distance_m,
            film_diagonal_mm,
            width,
            height,
        )
        .map_err(|e| r.loc.err(format!("Camera \"realistic\": {e}")))?;
        (fov_deg, lens) = (f, Some(CameraLens::Realistic(l)));
    }
    if let Some((rtf, film, loc)) = ray_transfer {
        let (l, f) = crate::camera::ray_transfer_lens(rtf, film, film_diagonal_mm, width, height)
            .map_err(|e| loc.err(format!("Camera \"raytransfer\": {e}")))?;
        (fov_deg, lens) = (f, Some(CameraLens::RayTransfer(l)));
    }
    Ok((fov_deg, lens))
}

/// pbrt-v4 `DiffuseAreaLight::Create` with `power`: `scale *= power / (pi * area * sides)` (0
/// for a shape without area or sides).
fn power_scale(base: f64, power: f64, area: f64, sides: f64) -> f64 {
    if area > 0.0 {
        if sides > 0.0 {
            base * power / (std::f64::consts::PI * area * sides)
        } else {
            0.0
        }
    } else {
        0.0
    }
}

/// The scene shapes of a pending `shape` with area light `l` (material index `material`): one
/// emitting shape, or with `power` on a mesh that is not one pbrt shape (`single`), one per
/// triangle as pbrt-v4 makes them, each given that power (numbered as one object instance).
fn emitting_shapes(
    mut shape: Shape,
    l: &AreaLightSpec,
    material: usize,
    single: bool,
    instances: &mut u32,
    notes: &mut Vec<String>,
    shapes: &mut Vec<Shape>,
) {
    // pbrt-v4 DiffuseAreaLight::Create: scale /= SpectrumToPhotometric(L);
    // with power: scale *= power / (pi * area * sides), per pbrt shape (triangle).
    let base = l.scale / l.spectrum.photometric;
    // pbrt-v4: with an image, k_e also holds the image's mean luminance (so
    // "sides" here is sides times that mean).
    let sides = (if l.two_sided { 2.0 } else { 1.0 }) * l.image.as_ref().map_or(1.0, |(_, y)| *y);
    let to_light = |scale: f64| AreaLight {
        radiance: l
            .spectrum
            .spectrum
            .clone()
            .scaled(scale / LUMINOUS_EFFICACY_LM_PER_W),
        two_sided: l.two_sided,
        image: l.image.as_ref().map(|(im, _)| im.clone()),
    };
    match (l.power, &shape.geometry) {
        (
            Some(power),
            Geometry::Triangles {
                positions,
                indices,
                uvs,
                normals,
                colors,
                uvs1,
                tangents,
            },
        ) if indices.len() > 1 && !single => {
            notes.push(format!(
                    "area light with power {power} on a {}-triangle mesh: pbrt-v4 gives each triangle that power; split into one light per triangle",
                    indices.len()
                ));
            // The triangles stay one object instance.
            let mut tags = shape.tags.clone();
            if tags.instance.is_none() {
                tags.instance = Some(*instances);
                *instances += 1;
            }
            for t in indices {
                let g = Geometry::Triangles {
                    positions: t.iter().map(|&i| positions[i as usize]).collect(),
                    indices: vec![[0, 1, 2]],
                    uvs: uvs
                        .as_ref()
                        .map(|u| t.iter().map(|&i| u[i as usize]).collect()),
                    normals: normals
                        .as_ref()
                        .map(|n| t.iter().map(|&i| n[i as usize]).collect()),
                    // Every per-vertex array follows its vertex.
                    colors: colors
                        .as_ref()
                        .map(|c| t.iter().map(|&i| c[i as usize]).collect()),
                    uvs1: uvs1
                        .as_ref()
                        .map(|u| t.iter().map(|&i| u[i as usize]).collect()),
                    tangents: tangents
                        .as_ref()
                        .map(|v| t.iter().map(|&i| v[i as usize]).collect()),
                };
                let area = xform::shape_area(&g);
                let scale = power_scale(base, power, area, sides);
                shapes.push(Shape {
                    name: shape.name.clone(),
                    geometry: g,
                    material,
                    area_light: Some(to_light(scale)),
                    reverse_orientation: shape.reverse_orientation,
                    tags: tags.clone(),
                });
            }
        }
        (power, g) => {
            let mut scale = base;
            if let Some(power) = power {
                let area = xform::shape_area(g);
                scale = power_scale(base, power, area, sides);
            }
            shape.area_light = Some(to_light(scale));
            shapes.push(shape);
        }
    }
}

/// pbrt-v4's default area/infinite light spectrum: the colour space's illuminant (D65).
/// Luminance Y of a linear sRGB / Rec. 709 colour (ITU-R BT.709 weights; pbrt-v4
/// `RGBColorSpace::LuminanceVector` of sRGB), relative to white = 1.
fn luminance_709(c: [f32; 3]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

fn default_illuminant() -> ParsedSpectrum {
    let s = super::spectra::srgb_illuminant().clone();
    let p = super::spectra::photometric(&s);
    ParsedSpectrum {
        spectrum: s,
        photometric: p,
    }
}

impl SceneBuilder {
    /// A light's image (`filename` of `infinite`, `goniometric`, `projection` lights and of
    /// `AreaLightSource "diffuse"`): resolved against the scene file, decoded with the
    /// `encoding` parameter (pbrt-v4 default: sRGB for PNG, linear otherwise), as linear RGB.
    /// Refused, naming `what`, when it cannot be read, is empty, or has a negative or non-finite
    /// texel.
    pub(super) fn light_image(
        &mut self,
        fname: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
        what: &str,
    ) -> Result<(usize, usize, Vec<[f32; 3]>), PbrtError> {
        let encoding = self.image_encoding(fname, params, loc, what)?;
        let (width, height, rgb) = load_image(&self.resolve(file, fname), encoding)
            .map_err(|e| loc.err(format!("{what}: {e}")))?;
        if rgb.is_empty() || rgb.iter().flatten().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(loc.err(format!(
                "{what}: {fname} is empty or has negative or non-finite texels"
            )));
        }
        Ok((width, height, rgb))
    }

    /// The `encoding` parameter of an image file parameter `fname` (pbrt-v4 default: sRGB for
    /// PNG, linear otherwise); a note when the file's format fixes its own encoding
    /// ([`images::fixed_encoding`]) and the parameter is given anyway.
    pub(super) fn image_encoding(
        &mut self,
        fname: &str,
        params: &ParamList,
        loc: &Loc,
        what: &str,
    ) -> Result<Encoding, PbrtError> {
        let given = params.string("encoding")?;
        let enc = given
            .clone()
            .unwrap_or_else(|| images::default_encoding(fname).to_string());
        let encoding = parse_encoding(&enc).ok_or_else(|| {
            loc.err(format!(
                "{what}: unknown encoding \"{enc}\" (sRGB, linear, gamma G)"
            ))
        })?;
        if let (Some(g), Some(fixed)) = (given, images::fixed_encoding(fname)) {
            self.note(
                loc,
                format!("{what}: encoding \"{g}\" ignored for {fname}: pbrt-v4 decodes it {fixed}"),
            );
        }
        Ok(encoding)
    }
}

/// A `Camera "realistic"` read but not yet set up (it needs the film's size).
#[derive(Debug)]
struct PendingRealistic {
    lens: camsim_lens::Lens,
    aperture_diameter_mm: f64,
    focus_distance_m: f64,
    loc: Loc,
}

#[cfg(test)]
mod image_map_tests {
    use super::*;
    use exr::prelude::WritableImage;

    /// Issue 25 item 7: a truncated EXR as an environment map said "no layer ... matched your
    /// specified requirements"; an EXR without colour channels said the same.
    #[test]
    fn a_damaged_or_colourless_exr_image_map_is_named_and_explained() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("env.exr");
        exr::prelude::write_rgb_file(&good, 64, 32, |x, y| (x as f32, y as f32, 1.0)).unwrap();
        let (w, h, px) = load_image(&good, Encoding::Linear).unwrap();
        assert_eq!((w, h, px[65]), (64, 32, [1.0, 1.0, 1.0]));
        let bytes = std::fs::read(&good).unwrap();
        let cut = dir.path().join("cut.exr");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let e = load_image(&cut, Encoding::Linear).unwrap_err();
        assert!(
            e.contains("cut.exr") && e.contains("damaged or truncated"),
            "{e}"
        );
        let gray = dir.path().join("gray.exr");
        let ch = exr::prelude::SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|_| (0.5f32,));
        exr::prelude::Image::from_channels((4, 4), ch)
            .write()
            .to_file(&gray)
            .unwrap();
        let e = load_image(&gray, Encoding::Linear).unwrap_err();
        assert!(
            e.contains("gray.exr") && e.contains("no R, G and B channels"),
            "{e}"
        );
    }
}
