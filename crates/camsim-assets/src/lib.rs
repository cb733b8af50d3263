//! camsim stage 1 (3D): asset readers beside the pbrt-v4 reader (`camsim-pbrt`). glTF 2.0
//! (`.gltf` with external or data-URI buffers and images, `.glb`) and Wavefront OBJ/MTL files
//! are read into the same [`camsim_scene3d::SceneDescription`] the pbrt-v4 reader fills, so the
//! renderer, labels, motion and datasets take them without knowing where they came from.
//!
//! - [`detect_format`]: the file type from its content (GLB magic, glTF JSON, OBJ statements,
//!   PLY magic), the extension only as a tie-break; pbrt-v4 text otherwise.
//! - [`read_scene`]: a whole file as a scene (its camera, or the documented framing camera
//!   [`framing_camera`] when it has none); [`gltf`] and [`obj`] hold the readers and the list
//!   of what each reads (also `docs/src/assets.md`).
//! - [`units`]: glTF's physical units (cd/m^2, cd, lux, linear Rec. 709 with a D65 white) as
//!   camsim spectra.
//!
//! Every glTF node with a mesh and every OBJ object or group becomes one object instance
//! (`ShapeTags::instance`) named after the node (or mesh) or group, so labels, boxes and COCO
//! see each one. Errors name the file and the accessor, mesh, URI, line or key at fault; a file
//! whose buffers and images would not fit the memory budget is refused before they are read.

pub mod gltf;
pub mod obj;
mod tangents;
mod texture;
pub mod units;

use camsim_scene3d::{Camera, SceneDescription, Transform};
use std::path::{Path, PathBuf};

/// An asset that cannot be read: the file and what is wrong (naming the accessor, mesh, URI,
/// line or key).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct AssetError {
    pub path: PathBuf,
    pub message: String,
}

impl AssetError {
    pub fn new(path: &Path, message: impl Into<String>) -> Self {
        AssetError {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, AssetError>;

/// The readers' material cache: (file material index, vertex-coloured) -> (camsim material
/// index, its emitter).
pub(crate) type MaterialCache =
    std::collections::HashMap<(Option<usize>, bool), (usize, Option<camsim_scene3d::AreaLight>)>;

/// What kind of scene file a path holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneFormat {
    /// Binary glTF (`glTF` magic).
    Glb,
    /// glTF JSON (a JSON object with an `asset` member).
    Gltf,
    /// Wavefront OBJ text.
    Obj,
    /// A PLY mesh (`ply` magic).
    Ply,
    /// Anything else: a pbrt-v4 scene file.
    Pbrt,
}

impl SceneFormat {
    /// Read by this crate (glTF, GLB, OBJ).
    pub fn is_asset(self) -> bool {
        matches!(
            self,
            SceneFormat::Glb | SceneFormat::Gltf | SceneFormat::Obj
        )
    }
}

/// The file's format from its first bytes (the extension decides only between OBJ and pbrt-v4
/// text when the statements could be either). A file that cannot be opened is an error naming
/// it.
pub fn detect_format(path: &Path) -> Result<SceneFormat> {
    use std::io::Read;
    let mut f = std::fs::File::open(path)
        .map_err(|e| AssetError::new(path, format!("cannot open: {e}")))?;
    let mut head = vec![0u8; 4096];
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) => return Err(AssetError::new(path, format!("cannot read: {e}"))),
        }
    }
    head.truncate(n);
    Ok(sniff(&head, path))
}

fn sniff(head: &[u8], path: &Path) -> SceneFormat {
    if head.starts_with(b"glTF") {
        return SceneFormat::Glb;
    }
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        return SceneFormat::Ply;
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let text = String::from_utf8_lossy(head);
    let trimmed = text.trim_start_matches('\u{feff}').trim_start();
    if trimmed.starts_with('{') {
        return SceneFormat::Gltf;
    }
    // OBJ: its statements (v, vt, vn, f, o, g, mtllib, usemtl, s) start every non-comment line
    // that the 4 kB head shows in full; pbrt-v4 files use capitalised directives.
    let mut obj_lines = 0usize;
    let mut other = 0usize;
    let complete = if head.len() == 4096 {
        text.rfind('\n').map_or("", |i| &text[..i])
    } else {
        &text[..]
    };
    for line in complete.lines() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let word = l.split_whitespace().next().unwrap_or("");
        if matches!(
            word,
            "v" | "vt" | "vn" | "vp" | "f" | "l" | "p" | "o" | "g" | "s" | "mtllib" | "usemtl"
        ) {
            obj_lines += 1;
        } else {
            other += 1;
        }
    }
    if obj_lines > 0 && other == 0 {
        return SceneFormat::Obj;
    }
    if obj_lines == 0 && other == 0 && ext == "obj" {
        return SceneFormat::Obj; // an empty OBJ file
    }
    SceneFormat::Pbrt
}

/// Options of [`read_scene`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// glTF: the scene to read, by name or index (default: the file's `scene`, else the first).
    pub scene: Option<String>,
    /// glTF: the camera to look through, by node or camera name or camera index (default: the
    /// first camera met in the scene's node order).
    pub camera: Option<String>,
    /// OBJ: metres per file unit (OBJ has no units; default 1: metres).
    pub obj_scale_m: f64,
    /// OBJ: which file axis is up (default `Y`, the OBJ/glTF convention); camsim's asset
    /// frame is Y-up (as glTF's), so a `Z`-up file is turned -90 degrees about x.
    pub obj_up_axis: UpAxis,
    /// Width of the image when the file gives no aspect ratio (pixels; default 640); the height
    /// follows the camera's aspect ratio (default 4:3).
    pub width: usize,
    /// A file with no light and no emitter is lit by [`DEFAULT_SKY_CD_M2`] of uniform D65 sky
    /// (default true: a bare asset is seen; false when the file is inserted as an object).
    pub default_light: bool,
}

/// Luminance of the uniform D65 sky that lights a file without lights or emitters, cd/m^2 (an
/// overcast daylight sky is a few thousand cd/m^2: CIE 110-1994's overcast zenith luminance at
/// moderate sun elevation; 1000 is a dull day, and illuminates an upward surface with
/// pi * 1000 = 3142 lux).
pub const DEFAULT_SKY_CD_M2: f64 = 1000.0;

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            scene: None,
            camera: None,
            obj_scale_m: 1.0,
            obj_up_axis: UpAxis::Y,
            width: 640,
            default_light: true,
        }
    }
}

/// A file's up axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    #[default]
    Y,
    Z,
}

impl UpAxis {
    /// `y` or `z` (any case).
    pub fn parse(s: &str) -> std::result::Result<UpAxis, String> {
        match s.to_ascii_lowercase().as_str() {
            "y" => Ok(UpAxis::Y),
            "z" => Ok(UpAxis::Z),
            o => Err(format!("up axis {o:?}: y or z")),
        }
    }

    /// The rotation from the file's frame to the Y-up asset frame.
    pub fn to_y_up(self) -> Transform {
        match self {
            UpAxis::Y => Transform::identity(),
            // +z up -> +y up: rotate -90 degrees about x (y -> -z, z -> y).
            UpAxis::Z => Transform::rotate(-90.0, [1.0, 0.0, 0.0]),
        }
    }
}

/// Read a glTF, GLB or OBJ file as a whole scene (see [`detect_format`]; PLY and pbrt-v4 files
/// are the pbrt reader's and refused here).
pub fn read_scene(path: &Path, opts: &ReadOptions) -> Result<SceneDescription> {
    let mut scene = match detect_format(path)? {
        SceneFormat::Glb | SceneFormat::Gltf => gltf::read(path, opts)?,
        SceneFormat::Obj => obj::read(path, opts)?,
        f => {
            return Err(AssetError::new(
                path,
                format!("not a glTF or OBJ file ({f:?}): read it with the pbrt-v4 reader"),
            ))
        }
    };
    if opts.default_light
        && scene.lights.is_empty()
        && scene.shapes.iter().all(|s| s.area_light.is_none())
    {
        let sky = units::photometric_spectrum([1.0; 3], DEFAULT_SKY_CD_M2).expect("white");
        scene
            .lights
            .push(camsim_scene3d::Light::Infinite { radiance: sky });
        scene.notes.push(format!(
            "the file has no lights: a uniform D65 sky of {DEFAULT_SKY_CD_M2} cd/m^2 lights it"
        ));
    }
    Ok(scene)
}

/// The camera camsim looks through when a file has none, documented for users: a 40-degree
/// vertical field of view (Blender's default 50 mm lens on its 36 mm sensor is 39.6 degrees)
/// looking along -z at the centre of the scene's bounds from the +z side (glTF's front),
/// raised by 20 degrees, at the distance where the bounding sphere just fills the vertical
/// field (`r / sin(fov / 2)`), `width` x `3/4 width` pixels. An empty scene gets a camera at
/// (0, 0, 5) looking at the origin.
pub fn framing_camera(lo: [f64; 3], hi: [f64; 3], width: usize) -> Camera {
    let fov_deg: f64 = 40.0;
    let (centre, radius) = if lo.iter().zip(&hi).all(|(a, b)| a <= b && a.is_finite()) {
        let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let r = 0.5
            * ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
        (c, r.max(1e-3))
    } else {
        ([0.0; 3], 5.0 * (fov_deg / 2.0).to_radians().sin())
    };
    let d = radius / (fov_deg / 2.0).to_radians().sin();
    let elev = 20f64.to_radians();
    let eye = [
        centre[0],
        centre[1] + d * elev.sin(),
        centre[2] + d * elev.cos(),
    ];
    let height = (width * 3 / 4).max(1);
    Camera {
        camera_to_world: camsim_scene3d::look_at_camera_to_world(
            eye,
            centre,
            [0.0, 1.0, 0.0],
            true,
        )
        .unwrap_or_default(),
        fov_deg,
        width,
        height,
        lens: None,
    }
}

/// Bounds of a scene's shapes (`[+inf; 3]`, `[-inf; 3]` when empty).
pub fn scene_bounds(scene: &SceneDescription) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for s in &scene.shapes {
        let (a, b) = camsim_scene3d::xform::shape_bounds(&s.geometry);
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    }
    (lo, hi)
}

/// A triangle mesh's total area, m^2 (half the cross products' lengths).
pub fn mesh_area(positions: &[[f64; 3]], indices: &[[u32; 3]]) -> f64 {
    indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let x = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
        })
        .sum()
}

/// An image file (PNG, JPEG, ...) as a base-colour reflectance texture: sRGB decoded
/// (IEC 61966-2-1), repeat wrap, bilinear lookups, row 0 at the top as glTF's images. For
/// material randomization (`camsim-compose`) and any caller that textures a surface with a
/// photograph.
pub fn base_color_texture(path: &Path) -> Result<camsim_scene3d::Texture> {
    let img = texture::DecodedImage::open(path).map_err(|e| AssetError::new(path, e))?;
    Ok(img.base_color(
        [1.0; 3],
        camsim_scene3d::WrapMode::Repeat,
        camsim_scene3d::TexelFilter::Bilinear,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sniffs_by_content() {
        let p = Path::new("x.bin");
        assert_eq!(sniff(b"glTF\x02\0\0\0", p), SceneFormat::Glb);
        assert_eq!(sniff(b"  {\"asset\":{}}", p), SceneFormat::Gltf);
        assert_eq!(sniff(b"ply\nformat ascii 1.0\n", p), SceneFormat::Ply);
        assert_eq!(
            sniff(b"# a cube\nmtllib box.mtl\nv 0 0 0\nf 1 2 3\n", p),
            SceneFormat::Obj
        );
        assert_eq!(
            sniff(b"LookAt 0 0 0 0 0 1 0 1 0\nCamera \"perspective\"\n", p),
            SceneFormat::Pbrt
        );
        assert_eq!(sniff(b"", Path::new("empty.obj")), SceneFormat::Obj);
        assert_eq!(sniff(b"", Path::new("empty.pbrt")), SceneFormat::Pbrt);
    }

    #[test]
    fn framing_camera_fits_the_bounding_sphere() {
        let c = framing_camera([-1.0; 3], [1.0; 3], 320);
        let eye = [
            c.camera_to_world.m[0][3],
            c.camera_to_world.m[1][3],
            c.camera_to_world.m[2][3],
        ];
        let d = (eye[0].powi(2) + eye[1].powi(2) + eye[2].powi(2)).sqrt();
        let r = 3f64.sqrt();
        assert!((r / d - 20f64.to_radians().sin()).abs() < 1e-12);
        assert_eq!((c.width, c.height), (320, 240));
    }
}
