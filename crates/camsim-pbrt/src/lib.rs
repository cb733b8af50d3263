//! pbrt-v4 scene reader: the subset of the pbrt-v4 file format
//! (<https://pbrt.org/fileformat-v4>) that a Cornell box and similar scenes use, read with
//! pbrt-v4's semantics, producing a [`SceneDescription`] (`camsim-scene3d`) for the path tracer
//! (`camsim-render`).
//!
//! Layout, split as pbrt-v4 splits its parser from its `BasicSceneBuilder`: [`tokenize`] (the
//! lexer) and the parameter lists (`params`); the reader (`reader.rs`: tokens to directives with
//! their file:line:column, `Include`/`Import` files, one-pass error recovery), which hands each
//! directive to a `ParserTarget` trait; and the scene builder implementing it (`parser.rs`,
//! `SceneBuilder`: graphics state, attribute stack, named objects, directives turned into
//! camsim-scene3d objects, one module per directive family under `parser/`: transforms, blocks,
//! options, world, shapes, materials, textures, lights, media, curves, hair, motion). Unlike
//! pbrt-v4, whose parser reads every argument and calls one typed target method per directive,
//! the target has one entry point and reads a directive's arguments (numbers, strings, the
//! parameter list) through the reader's `Args`, so it never sees a token. Then [`spectra`]
//! (spectrum-valued parameters, named spectra,
//! [`optical_constants`]), [`ply`], `images` and [`pfm`] (mesh and image files). [`overlay`] applies
//! camsim's TOML scene overlays (ISET3d-style scene control) to a scene from either source; it
//! lives here because its `replace` reads PLY and pbrt files.
//!
//! # Supported
//! - Tokens: quoted strings (escapes `\n \t \r \b \f \\ \' \"`), numbers, `[ ]`, `#` comments.
//!   A comment `#ObjectName NAME[:...]` (ISET3d's export convention) names the shapes that follow
//!   in the same attribute block, so overlays can find them.
//! - Parameter types: `integer`, `float`, `point2`, `vector2`, `point3`/`point`, `vector3`/`vector`,
//!   `normal3`/`normal`, `bool` (bare or quoted), `string`, `texture`, `rgb`/`color`, `spectrum`
//!   (inline wavelength-value pairs, a named spectrum, or a two-column file), `blackbody` (one
//!   temperature in K; normalised to peak 1 as pbrt-v4's `BlackbodySpectrum`). As in pbrt-v4 a
//!   parameter the directive does not use, or one of the wrong type, is an error.
//! - Options block: `LookAt`, `Camera "perspective"` (`fov`, `lensradius`, `focaldistance`),
//!   `Camera "realistic"` (`lensfile`, `aperturediameter`, `focusdistance`), ISET3d's
//!   `Camera "raytransfer"` (`lensfile`, and `filmdistance` in mm or `focusdistance` in m),
//!   `Film` (`rgb`, `spectral`, `gbuffer`: `xresolution`, `yresolution`), `Sampler` (any type;
//!   `pixelsamples`, or `xsamples` x `ysamples` for `stratified`; `seed`; `"independent"` selects
//!   camsim's independent sampler, every other type its padded Owen-scrambled Sobol sampler, see
//!   `camsim_render::sampler`), `Integrator` (`path`; `bdpt`, `sppm`, `lightpath`, `mlt`,
//!   `randomwalk`, `simplepath` -> camsim's path tracer with a note; `volpath`,
//!   `simplevolpath`, and any integrator when the scene has participating media -> its
//!   volumetric path tracer, with a note; `maxdepth`), `PixelFilter` (`box`, `gaussian`,
//!   `mitchell`, `sinc`/`lanczos`, `triangle` with pbrt-v4's parameters and default radii;
//!   gaussian without the directive, as pbrt-v4; see [`camsim_scene3d::scene::PixelFilter`]),
//!   `ColorSpace "srgb"` (other colour spaces, `Option`, `Accelerator` and unknown `Sampler`
//!   types are warnings in the notes).
//! - Transforms: `Identity`, `Translate`, `Scale`, `Rotate`, `LookAt`, `Transform`,
//!   `ConcatTransform` (16 numbers, column-major as pbrt-v4 reads them), `CoordinateSystem`,
//!   `CoordSysTransform` (`"camera"` is defined by `Camera`), `ReverseOrientation`,
//!   `AttributeBegin`/`AttributeEnd` (graphics state: CTM, material, area light, orientation,
//!   name), `TransformBegin`/`TransformEnd` (deprecated in v4; CTM only), `ActiveTransform`
//!   `StartTime`/`EndTime`/`All` and `TransformTimes` (options block): a shape, an object
//!   instance, a light or the camera whose start and end transforms differ moves between them
//!   (pbrt-v4's `AnimatedTransform`, [`camsim_scene3d::motion`]; the camera's `shutteropen` and
//!   `shutterclose` set the window its rays sample: motion blur). Beyond pbrt-v4, emitters and
//!   point, spot, distant, goniometric and projection lights move too (rigidly); an animated
//!   infinite light keeps its start transform, as in pbrt-v4.
//! - World: `WorldBegin`, `Shape` (`trianglemesh`: `P`, `indices`, `uv`, `N`; `bilinearmesh`:
//!   `P`, `indices`, `uv`, `N` -- each patch becomes two triangles; `plymesh`: `filename`, ASCII and
//!   binary PLY with triangles and quads; `sphere`: `radius`, centred at the CTM's origin, and
//!   `zmin`, `zmax`, `phimax` (a partial sphere, intersected exactly with pbrt-v4's clipping,
//!   area `phimax r (zmax - zmin)`, see [`camsim_scene3d::scene::Geometry::PartialSphere`]);
//!   `disk`: `height`, `radius`, `innerradius`, `phimax`; `cylinder`: `radius`, `zmin`, `zmax`,
//!   `phimax` -- both tessellated at load, area-preserving, see [`camsim_scene3d::shapes`];
//!   `loopsubdiv`: `levels`, `P`, `indices` -- Loop-subdivided at load and moved to the limit
//!   surface as pbrt-v4 does; `curve`: `P`, `basis` bezier/bspline, `degree` 2/3, `type`
//!   flat/cylinder/ribbon, `width`/`width0`/`width1`, `N` (ribbons), `splitdepth` -- cubic
//!   Bezier segments in world space, see [`camsim_scene3d::curves`] and `parser/curves.rs`; no
//!   area light on a curve, as in pbrt-v4); every shape takes `alpha` (a number or a float texture, pbrt-v4
//!   4th ed. §7.1.1: hits where it is 0 are ignored, where it is fractional a deterministic
//!   hash of the ray decides, for camera, bounce and shadow rays alike; a constant 0 drops the
//!   shape; see [`camsim_scene3d::scene::Material::AlphaMasked`]; on an area light the mask
//!   also removes its emission where it cuts, for rays and light samples alike),
//!   `Material` / `MakeNamedMaterial` / `NamedMaterial` (forward references to named materials
//!   resolve at the end) with pbrt-v4's materials, parameter names and defaults (see
//!   `parser/materials.rs`): `diffuse` (`reflectance`), `conductor` (`eta`/`k` spectra, default
//!   copper, or `reflectance`; `roughness`, `uroughness`, `vroughness`, `remaproughness`; the
//!   roughnesses may be any float texture, evaluated per hit:
//!   [`camsim_scene3d::scene::Material::VaryingRoughness`]),
//!   `dielectric` (`eta` float or spectrum, e.g. `"glass-BK7"`; roughness as conductor),
//!   `thindielectric` (`eta`), `diffusetransmission` (`reflectance`, `transmittance`, `scale`),
//!   `coateddiffuse` (`reflectance`, roughness, `thickness`, `eta`) and `coatedconductor`
//!   (`interface.roughness`/`uroughness`/`vroughness`, `interface.eta`, `thickness`,
//!   `conductor.eta`, `conductor.k` or `reflectance`, `conductor.roughness`/`uroughness`/
//!   `vroughness`, `remaproughness`), both with pbrt-v4's layered random walk and its `albedo`,
//!   `g`, `maxdepth`, `nsamples` (see `camsim_render::bsdf::layered`), `mix` (`materials` two named
//!   materials defined before, `amount`), `interface` (also `""`/`"none"`). Spectrum parameters
//!   (`reflectance`, `transmittance`) take an rgb, spectrum or blackbody value or any spectrum
//!   texture; the other float parameters (`scale`, `thickness`, `amount`) take a number or a
//!   `constant` float texture. Named spectra: every `metal-*-{eta,k}` and `glass-*` name
//!   pbrt-v4 defines, with pbrt-v4's data ([`optical_constants`]),
//!   Every material but `mix` and `interface` takes `displacement` (or pbrt-v3's `bumpmap`), a
//!   float texture, and `normalmap`, an image file (pbrt-v4 `BumpMap` / `NormalMap`, see
//!   [`camsim_scene3d::scene::Material::Bumped`]).
//!   `Texture "name" "spectrum"|"float"`: `imagemap` (every format pbrt-v4 reads, with its
//!   per-format encoding rules: PNG 8/16 bit honouring `encoding` (`sRGB` default, `linear`,
//!   `gamma G`), TGA/JPEG/BMP always sRGB, QOI by its own flag, EXR/PFM/HDR linear; `filename`,
//!   `scale`, `invert`, `wrap` (`repeat`, `clamp`, `black`, `octahedralsphere`), `uscale`,
//!   `vscale`, `udelta`, `vdelta`, `filter` (`point`, `bilinear`, `trilinear`, `ewa` with its
//!   `maxanisotropy`, each read from the MIP pyramid as pbrt-v4's `MIPMap::Filter`); float images read the mean of R, G and B when filtered `bilinear` or `trilinear`, R when `point` or `ewa`, as pbrt-v4), `constant` (`value`), `checkerboard` (`tex1`, `tex2`; `dimension` 2 on the uv
//!   mapping, 3 in texture space),
//!   `scale` (`tex`, `scale`), `mix` (`tex1`, `tex2`, `amount`), `directionmix` (`tex1`, `tex2`,
//!   `dir`), `bilerp` (`v00`, `v01`, `v10`, `v11`), `dots` (`inside`, `outside`, uv mapping),
//!   the solid noises `fbm`, `wrinkled` (`octaves`, `roughness`) and `windy` (float) and `marble`
//!   (spectrum: `octaves`, `roughness`, `scale`, `variation`), on the hit point mapped by the
//!   inverse of the texture's CTM (point-sampled with every octave: no ray differentials;
//!   `camsim_render::noise`); 2D textures take `mapping` `uv` (default), `spherical`,
//!   `cylindrical` or `planar` (`v1`, `v2`, `udelta`, `vdelta`) as pbrt-v4, the last three on the
//!   hit point in texture space; texture-valued parameters take a value or a
//!   texture name (the renderer's `texture` module compiles and evaluates them),
//!   `AreaLightSource "diffuse"` (`L`, `scale`, `twosided`, `power`; or `filename` with
//!   `encoding`: an RGB image over the uv of a triangle mesh or a (partial) sphere, each value an illuminant spectrum as
//!   pbrt-v4's `RGBIlluminantSpectrum`, `power` divided by the image's mean luminance as
//!   pbrt-v4 does; see [`camsim_scene3d::scene::AreaLight::image`]),
//!   `LightSource` `"point"` (`I`, `scale`, `power`, `from`), `"spot"` (`I`, `scale`, `power`,
//!   `from`, `to`, `coneangle`, `conedelta`; pbrt-v4's smoothstep falloff), `"goniometric"` (`I`,
//!   `scale`, `power`, `filename`: a square equal-area octahedral intensity image, RGB averaged
//!   to one channel and looked up at the nearest texel as pbrt-v4, light frame = CTM with y and z
//!   swapped; `filename` is required; `from` is a camsim extension), `"projection"` (`scale`,
//!   `power`, `fov`, `filename`: an RGB image projected along the light's +z through a frustum
//!   whose `fov` spans the shorter image side, nearest texel as an illuminant spectrum, zero
//!   outside; light frame = CTM with y flipped, as pbrt-v4), `"distant"` (`L`,
//!   `scale`, `from`, `to`, `illuminance`) and `"infinite"` (`L`, `scale`, `illuminance`; or
//!   `filename`: a square image is pbrt-v4's equal-area octahedral map, a 2:1 image a lat-long
//!   map, see [`camsim_scene3d::envmap`]; PNG, EXR or PFM as the Bitterli scenes ship them),
//!   participating media (`parser/media.rs`): `MakeNamedMedium` `homogeneous` (`sigma_a`,
//!   `sigma_s` as unbounded spectra, `scale`, `g`, `Le`, `Lescale`, `preset`: Jensen et al. 2001),
//!   `uniformgrid`, `rgbgrid`, `cloud`, and `MediumInterface` (graphics state: the shapes whose
//!   two sides differ become [`camsim_scene3d::scene::Material::MediumInterface`] boundaries,
//!   the outside medium at `Camera` is the camera's; names resolve at the end, as in pbrt-v4),
//!   `Attribute "shape"|"light"|"material"|"medium"|"texture"` (defaults for later directives
//!   of that category in the same attribute scope; a directive's own parameter wins, as pbrt-v4's
//!   `ParameterDictionary` with graphics-state attributes), `ObjectBegin`/`ObjectEnd`/
//!   `ObjectInstance`, `Include` and `Import` (relative to the including file, then to the main
//!   file's folder; cycles are errors).
//!
//! # pbrt-v4 semantics kept, and camsim's units
//! - Lights: pbrt-v4 divides a light's `scale` by `SpectrumToPhotometric(L)` (the y-bar integral
//!   of the spectrum over 360-830 nm at 1 nm; for an `rgb` L only the colour space's illuminant
//!   counts), so `scale` = 1 means a luminance of "1 nit" in pbrt's convention. `power` (area
//!   lights) multiplies by `power / (pi * area * sides)`, for point lights by `power / (4 pi)`,
//!   for spot lights by `power / (2 pi (1 - cos_start + (cos_start - cos_end) / 2))`, for
//!   goniometric lights by `power / (4 pi mean(image))`, projection lights by `power / (A
//!   mean(Y(rgb) cos^3 theta))` over the texel centres (`A` the screen window's area at unit
//!   distance; `scale` first divided by the colour space illuminant's photometric value);
//!   `illuminance` multiplies a uniform infinite light by `E / pi`, a distant light by `E`, and an
//!   image infinite light by `E / E_map` with `E_map` the map's illuminance on an upward surface
//!   (whose `scale` is first divided by the colour space illuminant's photometric value). camsim reads pbrt's normalised radiance `L_pbrt(lambda)` as photometric:
//!   `L(lambda) = L_pbrt(lambda) / 683` W/(sr m^2 nm), so that a pbrt `scale` of 1 is exactly a
//!   luminance of 1 cd/m^2 (683 lm/W * integral y_bar L dl), `power` is a luminous flux in lumens
//!   and `illuminance` is in lux. Difference: pbrt-v4's own output is in its relative units
//!   (the same numbers times 683); camsim's is absolute.
//! - `power` is applied per emitting shape as pbrt-v4 does, and in pbrt-v4 every triangle of a
//!   mesh is its own shape: a mesh light with `power` P emits P per triangle. camsim reproduces
//!   this by splitting such a mesh into one emitting shape per triangle (and notes it). A disk or
//!   cylinder is one pbrt shape: its `power` is for the whole shape.
//! - RGB: `rgb` reflectances are uplifted with Jakob & Hanika (2019) sigmoid polynomials
//!   ([`camsim_scene3d::uplift`]; pbrt-v4's method, fitted by camsim, not pbrt's tables); components
//!   above 1 are an error as in pbrt-v4. `rgb` emission is `2 m * uplift(rgb / 2m) * D65` with
//!   `m` the largest component (pbrt-v4 `RGBIlluminantSpectrum`).
//! - Named illuminants (`stdillum-*`) are scaled so their y-bar integral is `CIE_Y_integral`
//!   (106.856895), as pbrt-v4 does.
//! - Orientation: triangles are stored in world space with their winding; without shading normals
//!   `reverse_orientation` = `ReverseOrientation` XOR (CTM swaps handedness), which flips the
//!   geometric normal as pbrt-v4 does. With `N`, pbrt-v4 faces the geometric normal toward the
//!   (possibly reversed) shading normal: camsim orders each triangle's winding that way and sets
//!   `reverse_orientation` false.
//!
//! # Ignored, with a note in `SceneDescription::notes`
//! `Film` `filename`, `iso`, `exposuretime`, `whitebalance`, `sensor`, `savefp16`,
//! `maxcomponentvalue`, `diagonal` (except for `realistic` and `raytransfer` cameras, whose film it sizes), `cropwindow`, `pixelbounds`, `nbuckets`, `lambdamin`,
//! `lambdamax`, `coordinatesystem`, `writefp16`; `Camera` `lensradius` > 0 (camsim's camera is a
//! pinhole: depth of field belongs to the optics stage; `focaldistance` becomes
//! `focus_distance_m`), `frameaspectratio`; `Sampler` types other
//! than `independent`, `sobol`, `paddedsobol`, `zsobol` (approximated by Sobol) and
//! `randomization`; `Integrator` `regularize`; `Option`;
//! the parameters of integrators other than `path` that only tune their own convergence; shape
//! `faceIndices`, `S`, `emissionfilename`.
//!
//! # Unsupported, with an error naming file:line:column
//! Cameras other than `perspective`, `realistic` and `raytransfer`; `screenwindow`;
//! `Integrator "ambientocclusion"` (not radiance); materials other than those above and `hair`
//! (`sigma_a`, `color`/`reflectance`, `eumelanin`, `pheomelanin`, `eta`, `beta_m`, `beta_n`,
//! `alpha`: `parser/hair.rs`) (`measured`, `subsurface`: named in the message), varying float
//! textures as material parameters other than the roughnesses;
//! texture classes other than those above (`ptex`); shapes other than those above,
//! infinite-light `portal`s and maps that are neither square nor 2:1; `nanovdb` media and the
//! Narasimhan et al. 2006 media presets; `Attribute` categories other than the five
//! above; area lights inside object instances; `WorldEnd`
//! (pbrt-v3); unknown directives.
//!
//! # One-pass reporting
//! A directive with a problem is recorded and skipped (reading resumes at the next directive),
//! so one [`PbrtError`] lists every problem of the scene, in every included file, each with its
//! file:line:column ([`PbrtError::problems`]); reading stops after 100.

mod images;
mod lexer;
pub mod optical_constants;
mod params;
mod parser;
pub mod pfm;
pub mod ply;
mod reader;
pub mod spectra;

pub mod overlay;
pub use overlay::ShakeSpec;

// The scene-description modules the reader builds with, under the paths the reader's modules use.
use camsim_scene3d::{builtin, camera, envmap, scene, shapes, xform};

pub use lexer::{tokenize, Token, TokenKind};

use crate::scene::SceneDescription;
use std::path::{Path, PathBuf};

/// A reader error: the file, 1-based line and column (0 when the error concerns the whole file),
/// and what is wrong. The reader reports every problem of a scene at once: `self` is the first,
/// `others` the rest in reading order (Display lists them all, one `file:line:col: message`
/// per line).
#[derive(Debug, Clone, PartialEq)]
pub struct PbrtError {
    pub file: PathBuf,
    pub line: usize,
    pub column: usize,
    pub message: String,
    /// Further problems found in the same pass (empty for a single problem).
    pub others: Vec<PbrtError>,
}

impl std::fmt::Display for PbrtError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let one = |f: &mut std::fmt::Formatter<'_>, e: &PbrtError| {
            write!(
                f,
                "{}:{}:{}: {}",
                e.file.display(),
                e.line,
                e.column,
                e.message
            )
        };
        if self.others.is_empty() {
            return one(f, self);
        }
        write!(f, "{} problems in the scene:", self.others.len() + 1)?;
        for e in self.problems() {
            write!(f, "\n  ")?;
            one(f, e)?;
        }
        Ok(())
    }
}

impl std::error::Error for PbrtError {}

impl PbrtError {
    /// Error at a position.
    pub fn at(file: &Path, line: usize, column: usize, message: impl Into<String>) -> Self {
        PbrtError {
            file: file.to_path_buf(),
            line,
            column,
            message: message.into(),
            others: Vec::new(),
        }
    }

    /// Every problem, the first one included, in reading order.
    pub fn problems(&self) -> impl Iterator<Item = &PbrtError> {
        std::iter::once(self).chain(self.others.iter())
    }

    /// One error reporting all of `errors` (which must not be empty).
    pub(crate) fn combine(errors: Vec<PbrtError>) -> PbrtError {
        let mut it = errors.into_iter().flat_map(|e| {
            let others = e.others.clone();
            std::iter::once(PbrtError {
                others: Vec::new(),
                ..e
            })
            .chain(others)
        });
        let mut first = it
            .next()
            .unwrap_or_else(|| PbrtError::at(Path::new(""), 0, 0, "unknown problem"));
        first.others = it.collect();
        first
    }
}

/// A position in a scene file.
#[derive(Debug, Clone, PartialEq)]
pub struct Loc {
    pub file: PathBuf,
    pub line: usize,
    pub column: usize,
}

impl Loc {
    /// An error at this position.
    pub fn err(&self, message: impl Into<String>) -> PbrtError {
        PbrtError::at(&self.file, self.line, self.column, message)
    }
    /// "file:line:col" for notes.
    pub fn describe(&self) -> String {
        format!("{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// Read a floating-point image file (`.exr`, `.pfm`, `.hdr` Radiance RGBE; any other format
/// the image readers know, decoded by pbrt-v4's per-format rules with PNG taken as linear) as
/// `(width, height, linear RGB texels)`, row 0 at the top. Errors name the file. Used by scene
/// composition (`camsim-compose`) for environment maps.
pub fn read_linear_image(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    images::load_image(path, images::Encoding::Linear)
}

/// Read a pbrt-v4 scene file (and the files it includes).
pub fn parse_file(path: impl AsRef<Path>) -> Result<SceneDescription, PbrtError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path)
        .map_err(|e| PbrtError::at(path, 0, 0, format!("cannot read: {e}")))?;
    let scene = parse_str(&text, path)?;
    // The renderer refuses an empty scene too, but only here is the file known to name it.
    if scene.shapes.is_empty() && scene.lights.is_empty() {
        return Err(PbrtError::at(
            path,
            0,
            0,
            "the scene is empty: it has no shapes and no lights".to_string(),
        ));
    }
    Ok(scene)
}

/// Read pbrt-v4 scene text; `virtual_path` names it in errors and anchors relative file names
/// (`Include`, PLY, textures, spectrum files) at its folder.
pub fn parse_str(
    text: &str,
    virtual_path: impl AsRef<Path>,
) -> Result<SceneDescription, PbrtError> {
    parser::parse(text, virtual_path.as_ref())
}
