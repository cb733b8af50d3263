//! glTF 2.0 (`.gltf` + `.bin` + images, data URIs, `.glb`) -> [`SceneDescription`], read to the
//! glTF 2.0 specification (Khronos, 2.0.1) through the `gltf` crate's document model; buffers,
//! images and accessors are resolved here so that every failure names its file, URI, mesh and
//! accessor.
//!
//! What is read (the table in `docs/src/assets.md` is this list):
//! - The default scene (or `ReadOptions::scene` by name or index) and its node hierarchy (TRS
//!   or matrices; a mirroring transform reverses the winding, sec. 3.7.4).
//! - Meshes: TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN (POINTS and LINES* refused naming the
//!   mesh), indexed or not, every accessor component type with `normalized`, byte strides,
//!   sparse accessors, `KHR_mesh_quantization` (integer positions, normals, uvs);
//!   `NORMAL` (absent: flat normals, as the specification says); `TEXCOORD_n`: each texture
//!   slot reads the set its `texCoord` names (sec. 3.9.2), the base colour's set as the mesh's
//!   `uvs`, one other set as `uvs1` (three sets, or a set the primitive lacks: an error naming
//!   the material and mesh); `COLOR_0` (VEC3/VEC4, float or normalized u8/u16) per vertex,
//!   multiplying the base colour factor x texture ([`Texture::VertexColored`]), its alpha the
//!   material's alpha before MASK's cutoff (`FloatTexture::VertexAlpha`). Normal-mapped
//!   primitives carry tangents: `TANGENT` (xyz, w the handedness) where given, else
//!   MikkTSpace's on the normal texture's uvs (sec. 3.7.2.1, `crate::tangents`); the
//!   renderer's normal-map frame is `(t, w n x t, n)`.
//! - Cameras: perspective (`yfov`, `aspectRatio`); the first met, or `ReadOptions::camera`.
//!   Orthographic cameras are refused (camsim's camera is a pinhole). No camera: the framing
//!   camera of [`crate::framing_camera`].
//! - Materials: the metallic-roughness model of Appendix B as [`GltfPbr`] (base colour factor x
//!   texture decoded from sRGB, metallic from B and roughness from G of their texture, the
//!   normal texture with its `scale`, `alphaMode` MASK (cutoff) and BLEND (stochastic, as
//!   alpha-tested transparency), `doubleSided` for emitters; `occlusionTexture` is ignored with
//!   a note (a path tracer computes occlusion); emissive factor x texture x
//!   `KHR_materials_emissive_strength` as an area light in cd/m^2.
//! - Samplers: REPEAT, CLAMP_TO_EDGE (MIRRORED_REPEAT reads as repeat, noted); NEAREST
//!   magnification reads the nearest texel, others bilinear.
//! - Extensions: `KHR_materials_emissive_strength`, `KHR_lights_punctual` (point and spot in
//!   cd with the extension's cone falloff, directional in lux; `range` noted: camsim keeps the
//!   inverse-square law), `KHR_materials_specular`, `KHR_materials_ior`,
//!   `KHR_materials_transmission` (a thin dielectric wall, or with `KHR_materials_volume`'s
//!   thickness a smooth or rough dielectric of the file's `ior` whose inside absorbs by
//!   Beer-Lambert: `sigma_a = -ln(attenuationColor) / attenuationDistance`), `KHR_texture_transform`
//!   (baked into the uv set its texture reads, normal textures' too, before their MikkTSpace
//!   tangents), `KHR_materials_unlit` (read as a
//!   diffuse surface with a note), `KHR_materials_clearcoat` (noted, the base is read),
//!   `KHR_mesh_quantization`. An extension in `extensionsRequired` that is not in that list
//!   (Draco, meshopt, KTX2/Basis) refuses the file naming it; others in `extensionsUsed` are
//!   ignored with a note.
//! - Animations: node translation, rotation and scale channels (LINEAR, STEP, CUBICSPLINE) as
//!   [`Motion`] keys of each moving mesh's, light's and camera's world transform (STEP as held
//!   keys, CUBICSPLINE sampled at 8 keys per interval); times are the file's seconds, so a
//!   shutter window in those seconds gives motion blur, rolling shutter and flow. Skins and
//!   morph targets are refused with a message when the file animates them.

use crate::texture::DecodedImage;
use crate::units::{
    photometric_spectrum, reflectance, srgb_to_linear, unbounded, unit_rgb_illuminant,
};
use crate::{AssetError, ReadOptions, Result};
use camsim_core::mem::MemoryBudget;
use camsim_core::Spectrum;
use camsim_scene3d::motion::{Keyframe, Motion, MotionPart};
use camsim_scene3d::{
    AreaLight, Camera, EmissionImage, FloatTexture, Geometry, GltfPbr, Light, Material,
    NormalPerturbation, SceneDescription, Shape, ShapeTags, SpotFalloff, TexelFilter, Texture,
    Transform, WrapMode,
};
use gltf::accessor::{DataType, Dimensions};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Extensions camsim reads (see the module docs).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_lights_punctual",
    "KHR_materials_specular",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
    "KHR_materials_unlit",
    "KHR_materials_clearcoat",
    "KHR_mesh_quantization",
];

/// Read a glTF or GLB file as a scene.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<SceneDescription> {
    let doc = Doc::open(path)?;
    doc.scene(opts)
}

/// An opened glTF document with its buffers.
struct Doc {
    path: PathBuf,
    dir: PathBuf,
    gltf: gltf::Document,
    buffers: Vec<Vec<u8>>,
    notes: Vec<String>,
}

fn err(path: &Path, m: impl Into<String>) -> AssetError {
    AssetError::new(path, m)
}

/// Decode a data URI's payload (`data:[mime];base64,...`).
fn data_uri(uri: &str) -> Option<std::result::Result<Vec<u8>, String>> {
    use base64::Engine;
    let rest = uri.strip_prefix("data:")?;
    let (head, payload) = match rest.split_once(',') {
        Some(p) => p,
        None => return Some(Err("a data URI without ','".into())),
    };
    if !head.ends_with(";base64") {
        return Some(Err("only base64 data URIs are read".into()));
    }
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("bad base64 in a data URI: {e}")),
    )
}

/// Percent-decode a relative URI into a path (RFC 3986; glTF URIs are relative to the file).
fn uri_path(dir: &Path, uri: &str) -> PathBuf {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let Ok(v) = u8::from_str_radix(&uri[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    dir.join(String::from_utf8_lossy(&out).as_ref())
}

impl Doc {
    fn open(path: &Path) -> Result<Doc> {
        let size = std::fs::metadata(path)
            .map_err(|e| err(path, format!("cannot open: {e}")))?
            .len();
        MemoryBudget::new(format!("reading {}", path.display()))
            .bytes("the file", size)
            .check("split the asset")
            .map_err(|e| err(path, e.to_string()))?;
        let bytes = std::fs::read(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
        let g = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| match e {
            gltf::Error::Deserialize(e) => err(
                path,
                format!(
                    "malformed glTF JSON at line {}, column {}: {e}",
                    e.line(),
                    e.column()
                ),
            ),
            e => err(path, format!("not a readable glTF file: {e}")),
        })?;
        let mut notes = Vec::new();
        // Required extensions first: a file that needs one camsim cannot honour is refused
        // whole, naming it (the gltf crate's own list is shorter than camsim's).
        for ext in g.document.extensions_required() {
            if !SUPPORTED_EXTENSIONS.contains(&ext) {
                return Err(err(
                    path,
                    format!(
                        "extensionsRequired names {ext:?}, which camsim cannot read (it reads {})",
                        SUPPORTED_EXTENSIONS.join(", ")
                    ),
                ));
            }
        }
        for ext in g.document.extensions_used() {
            if !SUPPORTED_EXTENSIONS.contains(&ext) {
                notes.push(format!(
                    "glTF: extension {ext} (in extensionsUsed) is ignored"
                ));
            }
        }
        {
            use gltf::json::validation::Validate;
            let root = g.document.as_json();
            let mut bad: Vec<String> = Vec::new();
            root.validate(root, gltf::json::Path::new, &mut |path, e| {
                let p = path();
                if !p.as_str().starts_with("extensionsRequired") {
                    bad.push(format!("{}: {e}", p.as_str()));
                }
            });
            if !bad.is_empty() {
                return Err(err(path, format!("invalid glTF: {}", bad.join("; "))));
            }
        }
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        // The memory budget: every buffer and every decoded image, before reading any.
        let mut budget = MemoryBudget::new(format!("reading {}", path.display()));
        for b in g.document.buffers() {
            budget = budget.bytes(format!("buffer {}", b.index()), b.length() as u64);
        }
        budget = budget.bytes("the file", size);
        for img in g.document.images() {
            if let gltf::image::Source::Uri { uri, .. } = img.source() {
                if data_uri(uri).is_none() {
                    let p = uri_path(&dir, uri);
                    if let Ok((w, h)) = image::image_dimensions(&p) {
                        // Decoded RGBA f32 plus the per-use copies (about 3).
                        budget = budget.bytes(
                            format!("image {} ({uri})", img.index()),
                            w as u64 * h as u64 * 16 * 3,
                        );
                    }
                }
            }
        }
        budget
            .check("split the asset or decimate its meshes")
            .map_err(|e| err(path, e.to_string()))?;
        let mut buffers = Vec::new();
        let mut blob = g.blob;
        for b in g.document.buffers() {
            let data = match b.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    err(
                        path,
                        format!(
                            "buffer {} is the GLB binary chunk, which the file lacks",
                            b.index()
                        ),
                    )
                })?,
                gltf::buffer::Source::Uri(uri) => match data_uri(uri) {
                    Some(d) => d.map_err(|m| err(path, format!("buffer {}: {m}", b.index())))?,
                    None => {
                        let p = uri_path(&dir, uri);
                        std::fs::read(&p).map_err(|e| {
                            err(
                                path,
                                format!(
                                    "buffer {} wants {} (uri {uri:?}), which cannot be read: {e}",
                                    b.index(),
                                    p.display()
                                ),
                            )
                        })?
                    }
                },
            };
            if data.len() < b.length() {
                return Err(err(
                    path,
                    format!(
                        "buffer {} holds {} bytes but its byteLength is {}",
                        b.index(),
                        data.len(),
                        b.length()
                    ),
                ));
            }
            buffers.push(data);
        }
        Ok(Doc {
            path: path.to_path_buf(),
            dir,
            gltf: g.document,
            buffers,
            notes,
        })
    }

    fn err(&self, m: impl Into<String>) -> AssetError {
        err(&self.path, m)
    }

    /// The bytes of buffer view `view` (bounds-checked).
    fn view_bytes(&self, view: &gltf::buffer::View, what: &str) -> Result<&[u8]> {
        let buf = &self.buffers[view.buffer().index()];
        let (o, l) = (view.offset(), view.length());
        buf.get(o..o.saturating_add(l)).ok_or_else(|| {
            self.err(format!(
                "{what}: bufferView {} (offset {o}, length {l}) runs past buffer {} ({} bytes)",
                view.index(),
                view.buffer().index(),
                buf.len()
            ))
        })
    }

    /// Read accessor `a` as `count` rows of its components in f64 (normalized integers mapped
    /// to [0, 1] or [-1, 1] as sec. 3.11 says), with sparse substitution. `what` names the mesh
    /// or animation and the attribute for errors.
    fn read_accessor(&self, a: &gltf::Accessor, what: &str) -> Result<(usize, Vec<f64>)> {
        let ncomp = a.dimensions().multiplicity();
        let count = a.count();
        let ctx = || format!("{what} (accessor {})", a.index());
        let csize = a.data_type().size();
        let elem = csize * ncomp;
        let total = count
            .checked_mul(ncomp)
            .ok_or_else(|| self.err(format!("{}: count {count} is too large", ctx())))?;
        let mut out = vec![0.0f64; total];
        if let Some(view) = a.view() {
            let bytes = self.view_bytes(&view, &ctx())?;
            let stride = view.stride().unwrap_or(elem);
            if count > 0 {
                let last = a.offset() + stride * (count - 1) + elem;
                if last > bytes.len() {
                    return Err(self.err(format!(
                        "{}: {count} elements of {elem} bytes (stride {stride}, offset {}) run past the end of bufferView {} ({} bytes)",
                        ctx(),
                        a.offset(),
                        view.index(),
                        bytes.len()
                    )));
                }
            }
            for i in 0..count {
                let base = a.offset() + i * stride;
                for c in 0..ncomp {
                    out[i * ncomp + c] =
                        component(&bytes[base + c * csize..], a.data_type(), a.normalized());
                }
            }
        }
        if let Some(sp) = a.sparse() {
            let n = sp.count();
            let iv = sp.indices();
            let ibytes = self.view_bytes(&iv.view(), &format!("{} sparse indices", ctx()))?;
            let isize = match iv.index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let vv = sp.values();
            let vbytes = self.view_bytes(&vv.view(), &format!("{} sparse values", ctx()))?;
            if iv.offset() + n * isize > ibytes.len() || vv.offset() + n * elem > vbytes.len() {
                return Err(self.err(format!(
                    "{}: its {n} sparse entries run past their bufferViews",
                    ctx()
                )));
            }
            for k in 0..n {
                let o = iv.offset() + k * isize;
                let idx = match isize {
                    1 => ibytes[o] as usize,
                    2 => u16::from_le_bytes([ibytes[o], ibytes[o + 1]]) as usize,
                    _ => {
                        u32::from_le_bytes([ibytes[o], ibytes[o + 1], ibytes[o + 2], ibytes[o + 3]])
                            as usize
                    }
                };
                if idx >= count {
                    return Err(self.err(format!(
                        "{}: sparse index {idx} is past its {count} elements",
                        ctx()
                    )));
                }
                let base = vv.offset() + k * elem;
                for c in 0..ncomp {
                    out[idx * ncomp + c] =
                        component(&vbytes[base + c * csize..], a.data_type(), a.normalized());
                }
            }
        }
        Ok((ncomp, out))
    }

    /// Read a float attribute of `n` components, refusing non-finite values.
    fn read_floats<const K: usize>(&self, a: &gltf::Accessor, what: &str) -> Result<Vec<[f64; K]>> {
        let (ncomp, v) = self.read_accessor(a, what)?;
        if ncomp < K {
            return Err(self.err(format!(
                "{what} (accessor {}): {:?} has {ncomp} components, {K} needed",
                a.index(),
                a.dimensions()
            )));
        }
        let rows: Vec<[f64; K]> = v
            .chunks_exact(ncomp)
            .map(|c| std::array::from_fn(|k| c[k]))
            .collect();
        if let Some(i) = rows.iter().position(|r| r.iter().any(|x| !x.is_finite())) {
            return Err(self.err(format!(
                "{what} (accessor {}): element {i} is not finite ({:?})",
                a.index(),
                rows[i]
            )));
        }
        Ok(rows)
    }

    fn scene(mut self, opts: &ReadOptions) -> Result<SceneDescription> {
        let scene = match &opts.scene {
            None => self
                .gltf
                .default_scene()
                .or_else(|| self.gltf.scenes().next()),
            Some(want) => self
                .gltf
                .scenes()
                .find(|s| s.name() == Some(want.as_str()) || s.index().to_string() == *want)
                .or_else(|| {
                    None::<gltf::Scene>.or({
                        let names: Vec<String> = self
                            .gltf
                            .scenes()
                            .map(|s| s.name().map_or(s.index().to_string(), str::to_string))
                            .collect();
                        self.notes.push(format!("scenes: {}", names.join(", ")));
                        None
                    })
                }),
        };
        if opts.scene.is_some() && scene.is_none() {
            let names = self.notes.pop().unwrap_or_default();
            return Err(self.err(format!(
                "no scene {:?} ({names})",
                opts.scene.as_deref().unwrap_or("")
            )));
        }
        let mut b = Builder::new(&self);
        let gltf = self.gltf.clone();
        // Animated nodes are placed at their pose at t = 0 (the motions' reference).
        let anim = Animations::read(&self)?;
        if let Some(scene) = scene {
            let mut stack: Vec<(gltf::Node, Transform, Vec<usize>)> = scene
                .nodes()
                .map(|n| (n, Transform::identity(), Vec::new()))
                .collect();
            stack.reverse();
            while let Some((node, parent, mut chain)) = stack.pop() {
                if chain.len() > 256 || chain.contains(&node.index()) {
                    return Err(self.err(format!(
                        "node {} is its own ancestor (or nested deeper than 256)",
                        node.index()
                    )));
                }
                let local = anim.local_at(&node, 0.0);
                let world = parent.then_apply_to(&local);
                chain.push(node.index());
                b.visit(&self, &node, &world, &chain)?;
                let mut kids: Vec<_> = node.children().map(|c| (c, world, chain.clone())).collect();
                kids.reverse();
                stack.extend(kids);
            }
        }
        let _ = gltf;
        b.finish(&mut self, opts, &anim)
    }
}

/// One component at the start of `b` (little-endian), normalized per glTF sec. 3.11.
#[inline]
fn component(b: &[u8], t: DataType, normalized: bool) -> f64 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        DataType::U8 => {
            let v = b[0] as f64;
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I8 => {
            let v = b[0] as i8 as f64;
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// A node's local matrix (column-major in glTF) as camsim's row-major transform.
fn node_matrix(node: &gltf::Node) -> Transform {
    let c = node.transform().matrix();
    let mut t = Transform::identity();
    for (r, row) in t.m.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = c[k][r] as f64;
        }
    }
    t
}

/// glTF TRS (translation, rotation quaternion `[x, y, z, w]`, scale) as a matrix `T R S`.
fn trs_matrix(t: [f64; 3], q: [f64; 4], s: [f64; 3]) -> Transform {
    let n = (q.iter().map(|v| v * v).sum::<f64>()).sqrt().max(1e-300);
    let r = camsim_scene3d::motion::quat_to_matrix(&[q[3] / n, q[0] / n, q[1] / n, q[2] / n]);
    let mut m = Transform::identity();
    for i in 0..3 {
        for j in 0..3 {
            m.m[i][j] = r[i][j] * s[j];
        }
        m.m[i][3] = t[i];
    }
    m
}

/// Scene under construction.
struct Builder {
    shapes: Vec<Shape>,
    materials: Vec<Material>,
    named: HashMap<String, usize>,
    /// (glTF material index (None: the default material), the primitive has COLOR_0) -> camsim
    /// material and its emitter.
    mat_cache: crate::MaterialCache,
    images: HashMap<usize, Arc<DecodedImage>>,
    lights: Vec<Light>,
    cameras: Vec<(Option<String>, Option<String>, usize, Camera)>,
    instance: u32,
    /// Media of `KHR_materials_volume` (Beer-Lambert absorbers inside transmissive meshes).
    media: Vec<camsim_scene3d::media::Medium>,
    notes: BTreeSet<String>,
    /// (shape index, the chain of node indices from the root) of moving shapes.
    shape_chains: Vec<(usize, Vec<usize>)>,
    light_chains: Vec<(usize, Vec<usize>)>,
    camera_chain: Option<Vec<usize>>,
}

impl Builder {
    fn new(doc: &Doc) -> Builder {
        Builder {
            shapes: Vec::new(),
            materials: Vec::new(),
            named: HashMap::new(),
            mat_cache: HashMap::new(),
            images: HashMap::new(),
            lights: Vec::new(),
            cameras: Vec::new(),
            instance: 0,
            media: Vec::new(),
            notes: doc.notes.iter().cloned().collect(),
            shape_chains: Vec::new(),
            light_chains: Vec::new(),
            camera_chain: None,
        }
    }

    fn visit(
        &mut self,
        doc: &Doc,
        node: &gltf::Node,
        world: &Transform,
        chain: &[usize],
    ) -> Result<()> {
        if let Some(mesh) = node.mesh() {
            let name = node
                .name()
                .or(mesh.name())
                .map(str::to_string)
                .unwrap_or_else(|| format!("node{}", node.index()));
            if node.skin().is_some() {
                self.notes.insert(format!(
                    "glTF: node {name:?} is skinned; its mesh is read in its bind pose"
                ));
            }
            if mesh.weights().is_some_and(|w| w.iter().any(|v| *v != 0.0)) {
                return Err(doc.err(format!(
                    "mesh {:?}: morph target weights are not supported (camsim would render the base shape)",
                    mesh.name().unwrap_or("")
                )));
            }
            let inst = self.instance;
            self.instance += 1;
            let before = self.shapes.len();
            for (pi, prim) in mesh.primitives().enumerate() {
                self.primitive(doc, &mesh, pi, &prim, world, &name, inst)?;
            }
            for k in before..self.shapes.len() {
                self.shape_chains.push((k, chain.to_vec()));
            }
        }
        if let Some(cam) = node.camera() {
            let cam_name = cam.name().map(str::to_string);
            let c = self.camera(doc, &cam, world)?;
            self.cameras
                .push((node.name().map(str::to_string), cam_name, cam.index(), c));
            if self.cameras.len() == 1 {
                self.camera_chain = Some(chain.to_vec());
            }
        }
        if let Some(light) = node.light() {
            let li = self.lights.len();
            if let Some(l) = self.light(doc, &light, world)? {
                self.lights.push(l);
                self.light_chains.push((li, chain.to_vec()));
            }
        }
        Ok(())
    }

    fn camera(&mut self, doc: &Doc, cam: &gltf::Camera, world: &Transform) -> Result<Camera> {
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov_deg = (p.yfov() as f64).to_degrees();
                if !(yfov_deg > 0.0 && yfov_deg < 180.0) {
                    return Err(doc.err(format!(
                        "camera {}: yfov {} rad must lie in (0, pi)",
                        cam.index(),
                        p.yfov()
                    )));
                }
                let aspect = p.aspect_ratio().map(|a| a as f64).unwrap_or(4.0 / 3.0);
                // camsim's camera looks along +z (left-handed, pbrt-v4), glTF's along -z:
                // camera_to_world = world * Scale(1, 1, -1).
                let c2w = world.then_apply_to(&Transform::scale([1.0, 1.0, -1.0]));
                Ok(Camera {
                    camera_to_world: orthonormal(&c2w),
                    fov_deg: yfov_deg,
                    width: 0,
                    height: 0,
                    lens: None,
                }
                .with_aspect(aspect))
            }
            gltf::camera::Projection::Orthographic(_) => Err(doc.err(format!(
                "camera {} is orthographic: camsim renders through a pinhole or a lens (remove the camera to use the framing camera)",
                cam.index()
            ))),
        }
    }

    fn light(
        &mut self,
        doc: &Doc,
        l: &gltf::khr_lights_punctual::Light,
        world: &Transform,
    ) -> Result<Option<Light>> {
        use gltf::khr_lights_punctual::Kind;
        let c = l.color().map(|v| v as f64);
        let i = l.intensity() as f64;
        if !(i >= 0.0 && i.is_finite()) || c.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(doc.err(format!(
                "light {}: intensity {i} and color {c:?} must be finite and >= 0",
                l.index()
            )));
        }
        if l.range().is_some() {
            self.notes.insert(
                "KHR_lights_punctual: range is ignored (camsim keeps the inverse-square law at every distance)".into(),
            );
        }
        let Some(s) = photometric_spectrum(c, i) else {
            return Ok(None); // a black light
        };
        let pos = world.apply_point([0.0; 3]);
        let dir = normalize(world.apply_vector([0.0, 0.0, -1.0]));
        Ok(Some(match l.kind() {
            Kind::Point => Light::Point {
                position_m: pos,
                intensity: s,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let outer = (outer_cone_angle as f64).to_degrees();
                let inner = (inner_cone_angle as f64).to_degrees().min(outer);
                Light::Spot {
                    position_m: pos,
                    direction: dir,
                    intensity: s,
                    cone_angle_deg: outer.max(1e-6),
                    cone_delta_deg: (outer - inner).max(0.0),
                    falloff: SpotFalloff::GltfSquared,
                }
            }
            Kind::Directional => Light::Distant {
                direction: dir,
                irradiance: s,
            },
        }))
    }

    #[allow(clippy::too_many_arguments)]
    fn primitive(
        &mut self,
        doc: &Doc,
        mesh: &gltf::Mesh,
        pi: usize,
        prim: &gltf::Primitive,
        world: &Transform,
        name: &str,
        inst: u32,
    ) -> Result<()> {
        use gltf::mesh::Mode;
        let mname = mesh
            .name()
            .map_or(format!("mesh {}", mesh.index()), |n| format!("mesh {n:?}"));
        let what = |attr: &str| format!("{mname} primitive {pi} {attr}");
        match prim.mode() {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {}
            m => {
                return Err(doc.err(format!(
                    "{mname} primitive {pi}: mode {m:?} is not a surface (camsim renders triangles; remove the points or lines)"
                )))
            }
        }
        if prim.morph_targets().next().is_some() {
            self.notes.insert(format!(
                "glTF: {mname} has morph targets; the base shape is read"
            ));
        }
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| doc.err(format!("{} is missing", what("POSITION"))))?;
        let local = doc.read_floats::<3>(&pos_acc, &what("POSITION"))?;
        let nv = local.len();
        // Indices (or 0..n), then the triangle list of the mode.
        let raw: Vec<u32> = match prim.indices() {
            Some(a) => {
                if !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
                    || a.dimensions() != Dimensions::Scalar
                {
                    return Err(doc.err(format!(
                        "{} (accessor {}): indices must be unsigned scalars, not {:?} {:?}",
                        what("indices"),
                        a.index(),
                        a.data_type(),
                        a.dimensions()
                    )));
                }
                let (_, v) = doc.read_accessor(&a, &what("indices"))?;
                let v: Vec<u32> = v.into_iter().map(|x| x as u32).collect();
                if let Some(bad) = v.iter().find(|&&i| i as usize >= nv) {
                    return Err(doc.err(format!(
                        "{} (accessor {}): index {bad} is past the {nv} vertices",
                        what("indices"),
                        a.index()
                    )));
                }
                v
            }
            None => (0..nv as u32).collect(),
        };
        let mut tris: Vec<[u32; 3]> = match prim.mode() {
            Mode::Triangles => raw.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => (2..raw.len())
                .map(|i| {
                    if i % 2 == 0 {
                        [raw[i - 2], raw[i - 1], raw[i]]
                    } else {
                        [raw[i - 1], raw[i - 2], raw[i]]
                    }
                })
                .collect(),
            _ => (2..raw.len())
                .map(|i| [raw[0], raw[i - 1], raw[i]])
                .collect(),
        };
        tris.retain(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
        if tris.is_empty() {
            return Ok(());
        }
        // A mirroring node transform makes the winding clockwise (sec. 3.7.4): reverse it so
        // the geometric normal stays the front face's.
        if camsim_scene3d::xform::det3(world) < 0.0 {
            for t in tris.iter_mut() {
                t.swap(1, 2);
            }
        }
        let positions: Vec<[f64; 3]> = local.iter().map(|p| world.apply_point(*p)).collect();
        let normals = match prim.get(&gltf::Semantic::Normals) {
            Some(a) => {
                let n = doc.read_floats::<3>(&a, &what("NORMAL"))?;
                if n.len() != nv {
                    return Err(doc.err(format!(
                        "{} (accessor {}): {} normals for {nv} positions",
                        what("NORMAL"),
                        a.index(),
                        n.len()
                    )));
                }
                let inv_t = normal_matrix(world);
                Some(
                    n.iter()
                        .map(|v| {
                            let w = mul3(&inv_t, *v);
                            let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
                            if l > 0.0 {
                                w.map(|x| x / l)
                            } else {
                                [0.0, 0.0, 1.0]
                            }
                        })
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        let mat = prim.material();
        let label = material_label(&mat);
        // Which uv set each texture slot reads (sec. 3.9.2 `texCoord`): the base colour's set is
        // the mesh's `uvs`; one other set, read by the slots that name it, is `uvs1`.
        let sets = UvSets::of(&mat);
        if let Some(others) = sets.too_many() {
            return Err(doc.err(format!(
                "material {label:?} on {mname} primitive {pi}: its textures read uv sets {others:?}; camsim reads at most two sets per primitive"
            )));
        }
        let base_info = mat.pbr_metallic_roughness().base_color_texture();
        let uv_set = sets.base;
        let read_uvs = |set: u32| -> Result<Option<Vec<[f64; 2]>>> {
            match prim.get(&gltf::Semantic::TexCoords(set)) {
                Some(a) => {
                    let t = doc.read_floats::<2>(&a, &what(&format!("TEXCOORD_{set}")))?;
                    if t.len() != nv {
                        return Err(doc.err(format!(
                            "{} (accessor {}): {} uvs for {nv} positions",
                            what(&format!("TEXCOORD_{set}")),
                            a.index(),
                            t.len()
                        )));
                    }
                    Ok(Some(t))
                }
                None => Ok(None),
            }
        };
        // KHR_texture_transform is baked into the uvs: each set takes the transform of the first
        // texture that reads it (base colour, metallic-roughness, emissive, specular, normal); a
        // texture on the same set with another transform is noted (a set holds one transform).
        // MikkTSpace tangents are computed afterwards on the moved uvs, so a normal map's frame
        // follows its transform.
        let pbr = mat.pbr_metallic_roughness();
        let xf_of = |i: &gltf::texture::Info| {
            i.texture_transform()
                .map(|t| (t.offset(), t.rotation(), t.scale()))
        };
        let mut slots: Vec<(&str, u32, Option<UvTransform>)> = [
            ("baseColorTexture", base_info.clone()),
            ("metallicRoughnessTexture", pbr.metallic_roughness_texture()),
            ("emissiveTexture", mat.emissive_texture()),
            (
                "specularTexture",
                mat.specular().and_then(|s| s.specular_texture()),
            ),
        ]
        .into_iter()
        .filter_map(|(n, i)| i.map(|i| (n, set_of(&i), xf_of(&i))))
        .collect();
        if let Some(nt) = mat.normal_texture() {
            let (set, xf) = normal_uv(&nt).map_err(|e| {
                doc.err(format!(
                    "material {label:?}: normalTexture's KHR_texture_transform: {e}"
                ))
            })?;
            slots.push(("normalTexture", set, xf));
        }
        let mut transform_on = |set: u32| {
            let mut on = slots.iter().filter(|s| s.1 == set);
            let &(first, _, xf) = on.next()?;
            if let Some((other, ..)) = on.find(|s| s.2 != xf) {
                self.notes.insert(format!(
                    "glTF: material {label:?}: {other} and {first} read TEXCOORD_{set} with different KHR_texture_transforms; {first}'s is applied to both"
                ));
            }
            xf
        };
        let (xf0, xf1) = (
            transform_on(uv_set),
            sets.second.and_then(&mut transform_on),
        );
        let to_camsim = |t: Vec<[f64; 2]>, xf: Option<([f32; 2], f32, [f32; 2])>| {
            t.iter()
                .map(|uv| {
                    let (mut u, mut v) = (uv[0], uv[1]);
                    if let Some((o, r, s)) = xf {
                        // KHR_texture_transform: T * R * S, rotation about the origin.
                        let (su, sv) = (u * s[0] as f64, v * s[1] as f64);
                        let (c, sn) = ((r as f64).cos(), (r as f64).sin());
                        u = c * su + sn * sv + o[0] as f64;
                        v = -sn * su + c * sv + o[1] as f64;
                    }
                    // glTF's v runs down the image, camsim's (pbrt's) up.
                    [u as f32, (1.0 - v) as f32]
                })
                .collect::<Vec<_>>()
        };
        let uvs = read_uvs(uv_set)?.map(|t| to_camsim(t, xf0));
        let uvs1 = match sets.second {
            Some(set) => read_uvs(set)?.map(|t| to_camsim(t, xf1)),
            None => None,
        };
        // COLOR_0 (sec. 3.7.2.1: VEC3 or VEC4, float or normalized u8/u16): linear RGB per
        // vertex, multiplying the base colour (sec. 3.9.2).
        let colors = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(a) => {
                let (nc, v) = doc.read_accessor(&a, &what("COLOR_0"))?;
                if !(nc == 3 || nc == 4) {
                    return Err(doc.err(format!(
                        "{} (accessor {}): {:?}, VEC3 or VEC4 needed",
                        what("COLOR_0"),
                        a.index(),
                        a.dimensions()
                    )));
                }
                if v.len() / nc != nv {
                    return Err(doc.err(format!(
                        "{} (accessor {}): {} colours for {nv} positions",
                        what("COLOR_0"),
                        a.index(),
                        v.len() / nc
                    )));
                }
                if v.iter().any(|x| !x.is_finite()) {
                    self.notes.insert(format!(
                        "glTF: {mname}: COLOR_0 has non-finite values, read as 1"
                    ));
                }
                // RGBA; a VEC3's alpha is 1.
                Some(
                    v.chunks_exact(nc)
                        .map(|c| {
                            std::array::from_fn(|k| match c.get(k) {
                                Some(x) if x.is_finite() => x.clamp(0.0, 1.0) as f32,
                                _ => 1.0,
                            })
                        })
                        .collect::<Vec<[f32; 4]>>(),
                )
            }
            None => None,
        };
        let has_colors = colors.is_some();
        let mut geometry = Geometry::Triangles {
            positions,
            indices: tris,
            uvs,
            normals,
            colors,
            uvs1,
            tangents: None,
        };
        // Tangents of a normal-mapped primitive (sec. 3.7.2.1): TANGENT where given, else
        // MikkTSpace on the normal texture's uvs, as the specification recommends.
        if let Some(nt) = mat.normal_texture() {
            let on_second = sets.second == Some(normal_set(&nt));
            match prim.get(&gltf::Semantic::Tangents) {
                Some(a) => {
                    let t = doc.read_floats::<4>(&a, &what("TANGENT"))?;
                    let turned = normal_uv(&nt)
                        .ok()
                        .and_then(|(_, xf)| xf)
                        .is_some_and(|(_, r, sc)| r != 0.0 || sc[0] != sc[1] || sc[0] < 0.0);
                    if turned {
                        self.notes.insert(format!(
                            "glTF: {mname}: TANGENT is used as the file gives it, in the frame of the uvs before the normalTexture's KHR_texture_transform, which rotates, stretches or mirrors them"
                        ));
                    }
                    if t.len() != nv {
                        return Err(doc.err(format!(
                            "{} (accessor {}): {} tangents for {nv} positions",
                            what("TANGENT"),
                            a.index(),
                            t.len()
                        )));
                    }
                    // Directions move with the node (vectors); a mirror flips the bitangent
                    // `w n x t`'s side, so `w` flips with it.
                    let flip = camsim_scene3d::xform::det3(world) < 0.0;
                    let ts = t
                        .iter()
                        .map(|v| {
                            let d = normalize(world.apply_vector([v[0], v[1], v[2]]));
                            let w = if (v[3] < 0.0) != flip { -1.0 } else { 1.0 };
                            [d[0] as f32, d[1] as f32, d[2] as f32, w]
                        })
                        .collect();
                    if let Geometry::Triangles { tangents, .. } = &mut geometry {
                        *tangents = Some(ts);
                    }
                }
                None => {
                    if !crate::tangents::mikktspace(&mut geometry, on_second) {
                        self.notes.insert(format!(
                            "glTF: {mname}: MikkTSpace found no tangents (no uvs?); the normal map's frame is dp/du"
                        ));
                    }
                }
            }
        }
        let (material, area_light) = self.material(doc, &mat, has_colors, &sets)?;
        // After the material, so that its missing images are named first.
        for (slot, set) in sets.slots.iter() {
            if prim.get(&gltf::Semantic::TexCoords(*set)).is_none() {
                return Err(doc.err(format!(
                    "material {label:?} on {mname} primitive {pi}: its {slot} reads TEXCOORD_{set}, which the primitive does not have"
                )));
            }
        }
        self.shapes.push(Shape {
            name: Some(name.to_string()),
            geometry,
            material,
            area_light,
            reverse_orientation: false,
            tags: ShapeTags {
                category: None,
                instance: Some(inst),
                object_to_world: Some(*world),
                light_group: None,
                keypoints: None,
            },
        });
        Ok(())
    }

    /// Decode image `index` (cached).
    fn image(&mut self, doc: &Doc, img: &gltf::Image) -> Result<Arc<DecodedImage>> {
        if let Some(d) = self.images.get(&img.index()) {
            return Ok(d.clone());
        }
        let (bytes, origin): (Vec<u8>, String) = match img.source() {
            gltf::image::Source::View { view, .. } => (
                doc.view_bytes(&view, &format!("image {}", img.index()))?
                    .to_vec(),
                format!("image {} (bufferView {})", img.index(), view.index()),
            ),
            gltf::image::Source::Uri { uri, .. } => match data_uri(uri) {
                Some(d) => (
                    d.map_err(|m| doc.err(format!("image {}: {m}", img.index())))?,
                    format!("image {} (data URI)", img.index()),
                ),
                None => {
                    let p = uri_path(&doc.dir, uri);
                    let b = std::fs::read(&p).map_err(|e| {
                        doc.err(format!(
                            "image {} wants {} (uri {uri:?}), which cannot be read: {e}",
                            img.index(),
                            p.display()
                        ))
                    })?;
                    (b, format!("image {} ({uri})", img.index()))
                }
            },
        };
        let d = Arc::new(
            DecodedImage::decode(&bytes)
                .map_err(|e| doc.err(format!("{origin}: cannot decode: {e}")))?,
        );
        self.images.insert(img.index(), d.clone());
        Ok(d)
    }

    /// The texture's wrap mode and filter (sec. 3.8.4 samplers; one mode for both axes).
    fn sampler(&mut self, tex: &gltf::Texture) -> (WrapMode, TexelFilter) {
        use gltf::texture::{MagFilter, WrappingMode};
        let s = tex.sampler();
        let wrap = match (s.wrap_s(), s.wrap_t()) {
            (WrappingMode::ClampToEdge, WrappingMode::ClampToEdge) => WrapMode::Clamp,
            (a, b) => {
                if a == WrappingMode::MirroredRepeat || b == WrappingMode::MirroredRepeat {
                    self.notes
                        .insert("glTF: MIRRORED_REPEAT samplers read as REPEAT".to_string());
                }
                if a != b {
                    self.notes.insert(
                        "glTF: a sampler with different wrapS and wrapT reads both as REPEAT"
                            .to_string(),
                    );
                }
                WrapMode::Repeat
            }
        };
        let filter = match s.mag_filter() {
            Some(MagFilter::Nearest) => TexelFilter::Point,
            _ => TexelFilter::Bilinear,
        };
        (wrap, filter)
    }

    /// A float texture from one channel (`ch`, 0..4) of a texture times `factor`.
    fn float_texture(
        &mut self,
        doc: &Doc,
        tex: &gltf::Texture,
        ch: usize,
        factor: f64,
        map: impl Fn(f32) -> f32,
    ) -> Result<FloatTexture> {
        let img = self.image(doc, &tex.source())?;
        let (wrap, filter) = self.sampler(tex);
        Ok(img.channel(ch, factor, map, wrap, filter))
    }

    /// Material `mat` (cached); `vertex_colored`: its primitive has `COLOR_0`, which multiplies
    /// the base colour; `sets`: the uv set of each texture slot.
    fn material(
        &mut self,
        doc: &Doc,
        mat: &gltf::Material,
        vertex_colored: bool,
        sets: &UvSets,
    ) -> Result<(usize, Option<AreaLight>)> {
        let key = (mat.index(), vertex_colored);
        if let Some(v) = self.mat_cache.get(&key) {
            return Ok(v.clone());
        }
        let label = material_label(mat);
        let pbr = mat.pbr_metallic_roughness();
        let bf = pbr.base_color_factor().map(|v| v as f64);
        let base_rgb = [bf[0], bf[1], bf[2]];
        let image = match pbr.base_color_texture() {
            Some(info) => {
                let tex = info.texture();
                let img = self.image(doc, &tex.source())?;
                let (wrap, filter) = self.sampler(&tex);
                Some(img.base_color(base_rgb, wrap, filter))
            }
            None => None,
        };
        // sec. 3.9.2: base colour = factor x texture x COLOR_0.
        let base_color = crate::texture::base_color(image, base_rgb, vertex_colored);
        let (mf, rf) = (pbr.metallic_factor() as f64, pbr.roughness_factor() as f64);
        let (metallic, roughness) = match pbr.metallic_roughness_texture() {
            Some(info) => {
                let t = info.texture();
                let second = sets.second == Some(set_of(&info));
                (
                    on_set(self.float_texture(doc, &t, 2, mf, |v| v)?, second),
                    on_set(self.float_texture(doc, &t, 1, rf, |v| v)?, second),
                )
            }
            None => (FloatTexture::Constant(mf), FloatTexture::Constant(rf)),
        };
        let (mut specular, mut specular_color) = (
            FloatTexture::Constant(1.0),
            Texture::Constant(Spectrum::from_pairs(&[(300.0, 1.0), (900.0, 1.0)])),
        );
        if let Some(s) = mat.specular() {
            specular = match s.specular_texture() {
                Some(info) => on_set(
                    self.float_texture(doc, &info.texture(), 3, s.specular_factor() as f64, |v| v)?,
                    sets.second == Some(set_of(&info)),
                ),
                None => FloatTexture::Constant(s.specular_factor() as f64),
            };
            let c = s.specular_color_factor().map(|v| v as f64);
            if s.specular_color_texture().is_some() {
                self.notes.insert(format!(
                    "glTF: material {label:?}: specularColorTexture is not read (its factor is)"
                ));
            }
            specular_color = Texture::Constant(unbounded(c));
        }
        let ior = mat.ior().map(|v| v as f64).unwrap_or(1.5);
        if mat.occlusion_texture().is_some() {
            self.notes.insert(
                "glTF: occlusionTexture is ignored (the path tracer computes occlusion)".into(),
            );
        }
        if mat.unlit() {
            self.notes.insert(format!(
                "glTF: material {label:?} is KHR_materials_unlit: read as a lit diffuse surface of its base colour"
            ));
        }
        if mat.extension_value("KHR_materials_clearcoat").is_some() {
            self.notes.insert(format!(
                "glTF: material {label:?}: KHR_materials_clearcoat is not rendered (the base layer is)"
            ));
        }
        let transmission = mat
            .transmission()
            .map(|t| t.transmission_factor() as f64)
            .unwrap_or(0.0);
        let mut m = if mat.unlit() {
            Material::Diffuse {
                reflectance: base_color,
            }
        } else if transmission > 0.5 {
            let r = match &roughness {
                FloatTexture::Constant(r) => *r,
                _ => 0.0,
            };
            let eta = Spectrum::from_pairs(&[(300.0, ior), (900.0, ior)]);
            let volume = mat.volume().filter(|v| v.thickness_factor() > 0.0);
            match volume {
                // KHR_materials_volume thickness 0 (or no volume): a thin wall.
                None => Material::ThinDielectric { eta },
                Some(v) => {
                    let dielectric = Material::Dielectric {
                        eta,
                        // glTF alpha = roughness^2; pbrt's unremapped roughness is alpha.
                        roughness: camsim_scene3d::Roughness {
                            u: r * r,
                            v: r * r,
                            remap: false,
                        },
                    };
                    let d = v.attenuation_distance() as f64;
                    let c = v.attenuation_color().map(|x| x as f64);
                    if d.is_finite() && d > 0.0 && c.iter().any(|x| *x < 1.0) {
                        // Beer-Lambert (KHR_materials_volume): the attenuation colour is the
                        // transmittance after attenuationDistance, sigma_a = -ln(c) / d.
                        let t = reflectance(c);
                        let sigma: Vec<(f64, f64)> = t
                            .wavelengths_nm
                            .iter()
                            .zip(&t.values)
                            .map(|(&l, &v)| (l, -v.max(1e-12).ln() / d))
                            .collect();
                        self.media.push(camsim_scene3d::media::Medium {
                            name: format!("{label} volume"),
                            g: 0.0,
                            kind: camsim_scene3d::media::MediumKind::Homogeneous(
                                camsim_scene3d::media::Coefficients {
                                    sigma_a_per_m: Spectrum::from_pairs(&sigma),
                                    sigma_s_per_m: Spectrum::from_pairs(&[
                                        (300.0, 0.0),
                                        (900.0, 0.0),
                                    ]),
                                    le: None,
                                },
                            ),
                        });
                        self.materials.push(dielectric);
                        Material::MediumInterface {
                            material: self.materials.len() - 1,
                            inside: Some(self.media.len() - 1),
                            outside: None,
                        }
                    } else {
                        dielectric
                    }
                }
            }
        } else {
            if transmission > 0.0 {
                self.notes.insert(format!(
                    "glTF: material {label:?}: transmission {transmission} <= 0.5 is read as opaque"
                ));
            }
            Material::GltfPbr(Box::new(GltfPbr {
                base_color,
                metallic,
                roughness,
                specular,
                specular_color,
                ior,
            }))
        };
        // Normal map (sec. 3.9.3): tangent-space normals scaled in x, y by `scale`.
        if let Some(nt) = mat.normal_texture() {
            let img = self.image(doc, &nt.texture().source())?;
            let mut normals = img.normal_map(nt.scale());
            normals.uv1 = sets.second == Some(normal_set(&nt));
            self.materials.push(m);
            let inner = self.materials.len() - 1;
            m = Material::Bumped {
                material: inner,
                perturbation: NormalPerturbation::NormalMap(Arc::new(normals)),
            };
        }
        // Alpha (sec. 3.9.4): MASK keeps texels at or above the cutoff, BLEND is stochastic.
        let alpha_factor = pbr.base_color_factor()[3] as f64;
        let alpha = match mat.alpha_mode() {
            gltf::material::AlphaMode::Opaque => None,
            mode => {
                let cutoff = mat.alpha_cutoff().unwrap_or(0.5) as f64;
                let mask = mode == gltf::material::AlphaMode::Mask;
                let cut = move |a: f32| -> f32 {
                    if mask {
                        if a as f64 >= cutoff {
                            1.0
                        } else {
                            0.0
                        }
                    } else {
                        a
                    }
                };
                match (pbr.base_color_texture(), vertex_colored) {
                    (Some(info), false) => {
                        Some(self.float_texture(doc, &info.texture(), 3, alpha_factor, cut)?)
                    }
                    (None, false) => {
                        let a = cut(alpha_factor as f32) as f64;
                        (a < 1.0).then_some(FloatTexture::Constant(a))
                    }
                    // COLOR_0's alpha multiplies factor x texture (sec. 3.9.4), the cutoff
                    // after the product.
                    (info, true) => {
                        let tex = match info {
                            Some(info) => {
                                self.float_texture(doc, &info.texture(), 3, alpha_factor, |v| v)?
                            }
                            None => FloatTexture::Constant(alpha_factor),
                        };
                        Some(FloatTexture::VertexAlpha {
                            tex: Box::new(tex),
                            cutoff: mask.then_some(cutoff),
                        })
                    }
                }
            }
        };
        self.materials.push(m);
        let mut idx = self.materials.len() - 1;
        if let Some(alpha) = alpha {
            self.materials.push(Material::AlphaMasked {
                material: idx,
                alpha,
            });
            idx = self.materials.len() - 1;
        }
        if let Some(n) = mat.name() {
            self.named.entry(n.to_string()).or_insert(idx);
        }
        // Emission: factor x texture x strength, cd/m^2.
        let strength = mat.emissive_strength().unwrap_or(1.0) as f64;
        let ef = mat.emissive_factor().map(|v| v as f64 * strength);
        let area = if ef.iter().any(|v| *v > 0.0) {
            match mat.emissive_texture() {
                Some(info) => {
                    let img = self.image(doc, &info.texture().source())?;
                    let rgb: Vec<[f32; 3]> = img
                        .rgba
                        .iter()
                        .map(|p| {
                            std::array::from_fn(|k| (srgb_to_linear(p[k]) as f64 * ef[k]) as f32)
                        })
                        .collect();
                    Some(AreaLight {
                        radiance: unit_rgb_illuminant(),
                        two_sided: mat.double_sided(),
                        image: Some(Arc::new(EmissionImage {
                            width: img.width,
                            height: img.height,
                            rgb: rgb.into(),
                            uv1: sets.second == Some(set_of(&info)),
                        })),
                    })
                }
                None => photometric_spectrum(ef, 1.0).map(|radiance| AreaLight {
                    radiance,
                    two_sided: mat.double_sided(),
                    image: None,
                }),
            }
        } else {
            None
        };
        self.mat_cache.insert(key, (idx, area.clone()));
        Ok((idx, area))
    }

    fn finish(
        mut self,
        doc: &mut Doc,
        opts: &ReadOptions,
        anim: &Animations,
    ) -> Result<SceneDescription> {
        let mut time = camsim_scene3d::motion::TimeSettings::default();
        // The camera.
        let cam_pick = match &opts.camera {
            None => (!self.cameras.is_empty()).then_some(0),
            Some(want) => {
                let i = self.cameras.iter().position(|(node, cam, idx, _)| {
                    node.as_deref() == Some(want.as_str())
                        || cam.as_deref() == Some(want.as_str())
                        || idx.to_string() == *want
                });
                if i.is_none() {
                    let names: Vec<String> = self
                        .cameras
                        .iter()
                        .map(|(n, c, i, _)| {
                            n.clone().or(c.clone()).unwrap_or_else(|| i.to_string())
                        })
                        .collect();
                    return Err(doc.err(format!(
                        "no camera {want:?} (cameras: {})",
                        if names.is_empty() {
                            "none".into()
                        } else {
                            names.join(", ")
                        }
                    )));
                }
                i
            }
        };
        let mut scene_camera = None;
        if let Some(i) = cam_pick {
            scene_camera = Some(self.cameras[i].3.clone());
        }
        if !anim.is_empty() {
            for (k, chain) in &self.shape_chains {
                if let Some(m) = anim.motion(doc, chain, None)? {
                    time.shapes.push((*k, m));
                }
            }
            for (k, chain) in &self.light_chains {
                if let Some(m) = anim.motion(doc, chain, None)? {
                    time.lights.push((*k, m));
                }
            }
            if cam_pick == Some(0) {
                if let Some(chain) = &self.camera_chain {
                    let flip = Transform::scale([1.0, 1.0, -1.0]);
                    time.camera = anim.motion(doc, chain, Some(&flip))?;
                }
            }
            if let Some(t_end) = anim.end_s() {
                self.notes.insert(format!(
                    "glTF: animations run from 0 to {t_end} s (the render's shutter window selects the time)"
                ));
            }
        }
        // A still at t = 0 by default: the file's first frame.
        time.shutter.open_s = 0.0;
        time.shutter.close_s = 0.0;
        let mut scene = SceneDescription {
            camera: Camera {
                camera_to_world: Transform::identity(),
                fov_deg: 40.0,
                width: opts.width,
                height: opts.width * 3 / 4,
                lens: None,
            },
            shapes: std::mem::take(&mut self.shapes),
            materials: std::mem::take(&mut self.materials),
            named_materials: std::mem::take(&mut self.named),
            lights: std::mem::take(&mut self.lights),
            settings: Default::default(),
            focus_distance_m: None,
            notes: Vec::new(),
            media: camsim_scene3d::media::Media {
                list: std::mem::take(&mut self.media),
                camera: None,
            },
            light_groups: Vec::new(),
        };
        scene.settings.time = time;
        scene.camera = match scene_camera {
            Some(mut c) => {
                let aspect = c.width as f64 / c.height as f64;
                c.width = opts.width;
                c.height = ((opts.width as f64 / aspect).round() as usize).max(1);
                c
            }
            None => {
                let (lo, hi) = crate::scene_bounds(&scene);
                self.notes.insert(
                    "glTF: the file has no camera; camsim's framing camera looks at the scene (40 deg vertical field from +z, raised 20 deg)".into(),
                );
                crate::framing_camera(lo, hi, opts.width)
            }
        };
        // pbrt's fov spans the shorter side; a glTF yfov spans the height.
        if scene.camera.height > scene.camera.width {
            let t = (scene.camera.fov_deg.to_radians() / 2.0).tan() * scene.camera.width as f64
                / scene.camera.height as f64;
            scene.camera.fov_deg = 2.0 * t.atan().to_degrees();
        }
        scene.notes = self.notes.into_iter().collect();
        Ok(scene)
    }
}

trait WithAspect {
    fn with_aspect(self, aspect: f64) -> Self;
}

impl WithAspect for Camera {
    /// Remember the aspect ratio as a 10000-pixel-wide size (the final size is set later).
    fn with_aspect(mut self, aspect: f64) -> Camera {
        let a = if aspect > 0.0 && aspect.is_finite() {
            aspect
        } else {
            4.0 / 3.0
        };
        self.width = 10_000;
        self.height = ((10_000.0 / a).round() as usize).max(1);
        self
    }
}

/// The rotation part of a camera transform with its columns normalised (a scaled camera node
/// must not scale camera rays).
fn orthonormal(t: &Transform) -> Transform {
    let mut out = *t;
    for j in 0..3 {
        let l = (0..3).map(|i| t.m[i][j] * t.m[i][j]).sum::<f64>().sqrt();
        if l > 0.0 {
            for i in 0..3 {
                out.m[i][j] = t.m[i][j] / l;
            }
        }
    }
    out
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        v.map(|x| x / l)
    } else {
        [0.0, 0.0, -1.0]
    }
}

/// The inverse transpose of a transform's linear part (normals transform by it).
fn normal_matrix(t: &Transform) -> [[f64; 3]; 3] {
    let a: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| t.m[i][j]));
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    let d = if det != 0.0 { 1.0 / det } else { 1.0 };
    // Cofactor matrix / det = (A^-1)^T.
    [
        [
            (a[1][1] * a[2][2] - a[1][2] * a[2][1]) * d,
            (a[1][2] * a[2][0] - a[1][0] * a[2][2]) * d,
            (a[1][0] * a[2][1] - a[1][1] * a[2][0]) * d,
        ],
        [
            (a[0][2] * a[2][1] - a[0][1] * a[2][2]) * d,
            (a[0][0] * a[2][2] - a[0][2] * a[2][0]) * d,
            (a[0][1] * a[2][0] - a[0][0] * a[2][1]) * d,
        ],
        [
            (a[0][1] * a[1][2] - a[0][2] * a[1][1]) * d,
            (a[0][2] * a[1][0] - a[0][0] * a[1][2]) * d,
            (a[0][0] * a[1][1] - a[0][1] * a[1][0]) * d,
        ],
    ]
}

fn mul3(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// One animated node property: key times and values (`n` components per key; for
/// CUBICSPLINE the in-tangent, value, out-tangent triples).
struct Channel {
    times_s: Vec<f64>,
    values: Vec<f64>,
    n: usize,
    interp: gltf::animation::Interpolation,
}

impl Channel {
    /// The property at `t` (held before the first and after the last key).
    fn at(&self, t: f64) -> Vec<f64> {
        use gltf::animation::Interpolation::*;
        let n = self.n;
        let cubic = self.interp == CubicSpline;
        let value = |k: usize| -> &[f64] {
            let stride = if cubic { 3 * n } else { n };
            let o = k * stride + if cubic { n } else { 0 };
            &self.values[o..o + n]
        };
        let last = self.times_s.len() - 1;
        if t <= self.times_s[0] {
            return value(0).to_vec();
        }
        if t >= self.times_s[last] {
            return value(last).to_vec();
        }
        let k = self.times_s.partition_point(|x| *x <= t) - 1;
        let (t0, t1) = (self.times_s[k], self.times_s[k + 1]);
        let dt = t1 - t0;
        let u = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
        let (a, b) = (value(k), value(k + 1));
        match self.interp {
            Step => a.to_vec(),
            Linear => {
                if n == 4 {
                    slerp_xyzw(a, b, u)
                } else {
                    (0..n).map(|i| a[i] + (b[i] - a[i]) * u).collect()
                }
            }
            CubicSpline => {
                // glTF Appendix C: Hermite with out-tangent b_k and in-tangent a_{k+1}, times dt.
                let stride = 3 * n;
                let out_t = &self.values[k * stride + 2 * n..k * stride + 3 * n];
                let in_t = &self.values[(k + 1) * stride..(k + 1) * stride + n];
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                let mut v: Vec<f64> = (0..n)
                    .map(|i| h00 * a[i] + h10 * dt * out_t[i] + h01 * b[i] + h11 * dt * in_t[i])
                    .collect();
                if n == 4 {
                    let l = v.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
                    v.iter_mut().for_each(|x| *x /= l);
                }
                v
            }
        }
    }
}

/// Slerp of quaternions stored `[x, y, z, w]`, along the shorter arc.
fn slerp_xyzw(a: &[f64], b: &[f64], u: f64) -> Vec<f64> {
    let qa = [a[3], a[0], a[1], a[2]];
    let qb = [b[3], b[0], b[1], b[2]];
    let q = camsim_scene3d::motion::slerp(&qa, &qb, u);
    vec![q[1], q[2], q[3], q[0]]
}

/// Every node's animated TRS channels.
struct Animations {
    /// node index -> [translation, rotation, scale] channels.
    nodes: HashMap<usize, [Option<Channel>; 3]>,
}

impl Animations {
    fn read(doc: &Doc) -> Result<Animations> {
        use gltf::animation::Property;
        let mut nodes: HashMap<usize, [Option<Channel>; 3]> = HashMap::new();
        // Only the first animation plays (glTF has no notion of which; camsim's choice).
        let mut anims = doc.gltf.animations();
        let Some(a) = anims.next() else {
            return Ok(Animations { nodes });
        };
        for ch in a.channels() {
            let node = ch.target().node();
            let slot = match ch.target().property() {
                Property::Translation => 0,
                Property::Rotation => 1,
                Property::Scale => 2,
                Property::MorphTargetWeights => {
                    return Err(doc.err(format!(
                        "animation {}: node {} animates morph target weights, which camsim does not evaluate",
                        a.index(),
                        node.index()
                    )))
                }
            };
            if node.skin().is_some() {
                return Err(doc.err(format!(
                    "animation {}: node {} is skinned; skinning is not evaluated (remove the skin or bake the animation)",
                    a.index(),
                    node.index()
                )));
            }
            let s = ch.sampler();
            let what = format!("animation {} channel on node {}", a.index(), node.index());
            let times = doc.read_floats::<1>(&s.input(), &format!("{what} input"))?;
            let times_s: Vec<f64> = times.into_iter().map(|t| t[0]).collect();
            if times_s.is_empty() || times_s.windows(2).any(|w| !(w[1] >= w[0])) {
                return Err(doc.err(format!(
                    "{what}: key times must be increasing and at least one"
                )));
            }
            let (n, values) = doc.read_accessor(&s.output(), &format!("{what} output"))?;
            let per = if s.interpolation() == gltf::animation::Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if values.len() != times_s.len() * n * per || values.iter().any(|v| !v.is_finite()) {
                return Err(doc.err(format!(
                    "{what}: {} output values for {} keys of {n} components",
                    values.len(),
                    times_s.len()
                )));
            }
            nodes.entry(node.index()).or_default()[slot] = Some(Channel {
                times_s,
                values,
                n,
                interp: s.interpolation(),
            });
        }
        Ok(Animations { nodes })
    }

    fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    fn end_s(&self) -> Option<f64> {
        self.nodes
            .values()
            .flatten()
            .flatten()
            .filter_map(|c| c.times_s.last().copied())
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.max(t))))
    }

    /// A node's local transform at time `t` (its static matrix when nothing animates it).
    fn local_at(&self, node: &gltf::Node, t: f64) -> Transform {
        match self.nodes.get(&node.index()) {
            None => node_matrix(node),
            Some(ch) => {
                let (t0, r0, s0) = node.transform().decomposed();
                let tr = ch[0]
                    .as_ref()
                    .map_or(t0.map(|v| v as f64).to_vec(), |c| c.at(t));
                let ro = ch[1]
                    .as_ref()
                    .map_or(r0.map(|v| v as f64).to_vec(), |c| c.at(t));
                let sc = ch[2]
                    .as_ref()
                    .map_or(s0.map(|v| v as f64).to_vec(), |c| c.at(t));
                trs_matrix(
                    [tr[0], tr[1], tr[2]],
                    [ro[0], ro[1], ro[2], ro[3]],
                    [sc[0], sc[1], sc[2]],
                )
            }
        }
    }

    /// The world transform of the node at the end of `chain` at time `t`.
    fn world_at(&self, doc: &Doc, chain: &[usize], t: f64) -> Transform {
        let mut w = Transform::identity();
        for &ni in chain {
            let node = doc.gltf.nodes().nth(ni).expect("a node of the chain");
            w = w.then_apply_to(&self.local_at(&node, t));
        }
        w
    }

    /// The motion of the node at the end of `chain` (None when nothing on the chain moves):
    /// keys of its world transform at every key time of the chain (STEP keys doubled just
    /// before the step, CUBICSPLINE intervals split in 8), relative to the pose at t = 0
    /// (where the reader placed the geometry). `post` multiplies each key on the right (the
    /// camera's z flip).
    fn motion(
        &self,
        doc: &Doc,
        chain: &[usize],
        post: Option<&Transform>,
    ) -> Result<Option<Motion>> {
        let mut times: Vec<f64> = Vec::new();
        for ni in chain {
            if let Some(chs) = self.nodes.get(ni) {
                for c in chs.iter().flatten() {
                    for (k, &t) in c.times_s.iter().enumerate() {
                        times.push(t);
                        match c.interp {
                            gltf::animation::Interpolation::Step if k > 0 => {
                                times.push(t - 1e-9 * t.abs().max(1.0));
                            }
                            gltf::animation::Interpolation::CubicSpline
                                if k + 1 < c.times_s.len() =>
                            {
                                let t1 = c.times_s[k + 1];
                                times.extend((1..8).map(|j| t + (t1 - t) * j as f64 / 8.0));
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        if times.is_empty() {
            return Ok(None);
        }
        times.push(0.0);
        times.sort_by(|a, b| a.total_cmp(b));
        times.dedup();
        let post = post.copied().unwrap_or_else(Transform::identity);
        let mut keys = Vec::with_capacity(times.len());
        for &t in &times {
            let w = self.world_at(doc, chain, t).then_apply_to(&post);
            let k = Keyframe::from_transform(t, &w).ok_or_else(|| {
                doc.err(format!(
                    "the animated transform of node {} at t = {t} s is singular",
                    chain.last().copied().unwrap_or(0)
                ))
            })?;
            keys.push(k);
        }
        // The first key is t = 0, where the reader placed the geometry (the reference pose).
        let m = Motion::single(MotionPart::Keys(keys));
        if m.is_static() {
            return Ok(None);
        }
        Ok(Some(m))
    }
}

/// A material's name for messages.
fn material_label(mat: &gltf::Material) -> String {
    mat.name()
        .map(str::to_string)
        .or(mat.index().map(|i| format!("material{i}")))
        .unwrap_or_else(|| "default".to_string())
}

/// The uv set a texture reads: `KHR_texture_transform`'s `texCoord` where it gives one (the
/// extension overrides the texture's), else `textureInfo.texCoord`.
fn set_of(i: &gltf::texture::Info) -> u32 {
    i.texture_transform()
        .and_then(|t| t.tex_coord())
        .unwrap_or_else(|| i.tex_coord())
}

/// A `KHR_texture_transform`: offset, rotation (radians, about the uv origin), scale.
type UvTransform = ([f32; 2], f32, [f32; 2]);

/// The uv set a normal texture reads and its `KHR_texture_transform`, from the extension's JSON
/// (the `gltf` crate gives `normalTextureInfo` no typed accessor): `offset` [0, 0], `rotation` 0,
/// `scale` [1, 1] where absent, its `texCoord` overriding the texture's.
fn normal_uv(
    nt: &gltf::material::NormalTexture,
) -> std::result::Result<(u32, Option<UvTransform>), String> {
    let Some(x) = nt.extension_value("KHR_texture_transform") else {
        return Ok((nt.tex_coord(), None));
    };
    let pair = |key: &str, default: [f32; 2]| -> std::result::Result<[f32; 2], String> {
        match x.get(key) {
            None => Ok(default),
            Some(v) => match v.as_array().map(|a| a.as_slice()) {
                Some([a, b]) => match (a.as_f64(), b.as_f64()) {
                    (Some(a), Some(b)) if a.is_finite() && b.is_finite() => {
                        Ok([a as f32, b as f32])
                    }
                    _ => Err(format!("{key} {v} is not two finite numbers")),
                },
                _ => Err(format!("{key} {v} is not two numbers")),
            },
        }
    };
    let rotation = match x.get("rotation") {
        None => 0.0,
        Some(v) => match v.as_f64() {
            Some(r) if r.is_finite() => r as f32,
            _ => return Err(format!("rotation {v} is not a finite number")),
        },
    };
    let set = match x.get("texCoord") {
        None => nt.tex_coord(),
        Some(v) => match v.as_u64() {
            Some(t) if t <= u32::MAX as u64 => t as u32,
            _ => return Err(format!("texCoord {v} is not a uv set index")),
        },
    };
    Ok((
        set,
        Some((
            pair("offset", [0.0; 2])?,
            rotation,
            pair("scale", [1.0; 2])?,
        )),
    ))
}

/// The uv set a normal texture reads (its transform's `texCoord` where valid, else its own).
fn normal_set(nt: &gltf::material::NormalTexture) -> u32 {
    normal_uv(nt).map_or_else(|_| nt.tex_coord(), |(set, _)| set)
}

/// The uv sets a material's texture slots read (sec. 3.9.2 `textureInfo.texCoord`): `base` is
/// the base colour texture's (else the first slot's, else 0), the mesh's `uvs`; `second` the one
/// other set some slot names, the mesh's `uvs1`.
struct UvSets {
    base: u32,
    second: Option<u32>,
    /// (slot, set) of every texture camsim reads (occlusion is not read).
    slots: Vec<(&'static str, u32)>,
}

impl UvSets {
    fn of(mat: &gltf::Material) -> UvSets {
        let pbr = mat.pbr_metallic_roughness();
        let mut slots = Vec::new();
        if let Some(i) = pbr.base_color_texture() {
            slots.push(("baseColorTexture", set_of(&i)));
        }
        if let Some(i) = pbr.metallic_roughness_texture() {
            slots.push(("metallicRoughnessTexture", set_of(&i)));
        }
        if let Some(i) = mat.normal_texture() {
            slots.push(("normalTexture", normal_set(&i)));
        }
        if let Some(i) = mat.emissive_texture() {
            slots.push(("emissiveTexture", set_of(&i)));
        }
        if let Some(i) = mat.specular().and_then(|s| s.specular_texture()) {
            slots.push(("specularTexture", set_of(&i)));
        }
        let base = slots.first().map_or(0, |s| s.1);
        let second = slots.iter().map(|s| s.1).find(|&s| s != base);
        UvSets {
            base,
            second,
            slots,
        }
    }

    /// The sets named, where there are more than two.
    fn too_many(&self) -> Option<Vec<u32>> {
        let sets: BTreeSet<u32> = self.slots.iter().map(|s| s.1).collect();
        (sets.len() > 2).then(|| sets.into_iter().collect())
    }
}

/// A float image texture read at the second uv set where `second`.
fn on_set(mut t: FloatTexture, second: bool) -> FloatTexture {
    if let (true, FloatTexture::Image { mapping, .. }) = (second, &mut t) {
        mapping.kind = camsim_scene3d::MappingKind::Uv1;
    }
    t
}
