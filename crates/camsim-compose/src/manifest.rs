//! Asset libraries: where the objects a spawn draws come from, checked once up front.
//!
//! A source (`[render.compose] assets = [...]`) is one of
//! - a manifest file, `.csv` (a header row naming the columns `path`, `category`, `scale_to_m`,
//!   `up_axis`, `licence`, `keypoints`; only `path` is required) or `.json` (an array of objects
//!   with those fields, or `{ "assets": [...] }`); its relative paths resolve against its own
//!   folder;
//! - a folder: every glTF, GLB, OBJ, PLY and pbrt-v4 file under it (recursively);
//! - a glob: a path whose last part has `*` wildcards (`models/*.glb`), or `**/` before it for
//!   every folder below (`models/**/*.obj`);
//! - one asset file.
//!
//! Files from a folder or a glob, and manifest lines without a category, take the file's stem as
//! their category, a scale of 1 (metres) and +y up (glTF's convention). Every asset is read when
//! the library is loaded (glTF/GLB/OBJ by `camsim-assets`, PLY and pbrt-v4 by `camsim-pbrt`):
//! a file that cannot be read, or that has no triangles, is an error naming it (and its manifest
//! line) with the reason, before anything is spawned. Parsed assets stay in a process-wide cache
//! (path, scale, up axis -> the mesh), least recently used first out when it outgrows its byte
//! budget, so a dataset's samples read each file once.

use crate::{ComposeError, Result};
use camsim_assets::{SceneFormat, UpAxis};
use camsim_scene3d::{Geometry, Material, SceneDescription, Shape, Texture, Transform};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// The file extensions a folder or glob source takes (lower case).
pub const ASSET_EXTENSIONS: [&str; 5] = ["glb", "gltf", "obj", "ply", "pbrt"];

/// An asset's up axis in its file.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum UpAxisName {
    /// +y up (glTF's and most OBJ exporters' convention).
    #[default]
    Y,
    /// +z up (CAD, Blender's world, many scanned models): turned -90 degrees about x.
    Z,
}

impl UpAxisName {
    pub fn axis(self) -> UpAxis {
        match self {
            UpAxisName::Y => UpAxis::Y,
            UpAxisName::Z => UpAxis::Z,
        }
    }
}

fn one() -> f64 {
    1.0
}

/// One line of a manifest (a CSV row or a JSON object).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ManifestEntry {
    /// The asset file, relative to the manifest's folder.
    pub path: String,
    /// Semantic category (labels, COCO, spawn `weights`); default: the file's stem.
    #[serde(default)]
    pub category: Option<String>,
    /// Metres per file unit (default 1).
    #[serde(default = "one")]
    pub scale_to_m: f64,
    /// The file's up axis, `y` or `z` (default `y`).
    #[serde(default)]
    pub up_axis: UpAxisName,
    /// The asset's licence (recorded with each sample that uses it).
    #[serde(default)]
    pub licence: Option<String>,
    /// The asset's own 3D keypoints (default: labels use its 3D box's centre and corners): a
    /// JSON file (relative to the manifest's folder) or, in a JSON manifest, the object itself,
    /// `{ "names": [...], "points": [[x, y, z], ...], "skeleton": [[i, j], ...] }`, points in
    /// the file's units and axes (`scale_to_m` and `up_axis` apply to them as to the mesh),
    /// `skeleton` (optional) edges as 0-based indices into `names`. The assets of one category
    /// share one keypoint list (COCO gives a category one).
    #[serde(default)]
    pub keypoints: Option<KeypointSource>,
}

/// Where an asset's keypoints are given ([`ManifestEntry::keypoints`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum KeypointSource {
    /// A JSON file holding a [`KeypointsFile`].
    File(String),
    /// The keypoints themselves.
    Inline(KeypointsFile),
}

/// An asset's keypoints as written ([`ManifestEntry::keypoints`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KeypointsFile {
    /// One unique name per point.
    pub names: Vec<String>,
    /// The points in the asset file's units and axes.
    pub points: Vec<[f64; 3]>,
    /// Edges between points, 0-based indices into `names`.
    #[serde(default)]
    pub skeleton: Vec<[usize; 2]>,
}

/// The most keypoints an asset may have.
pub const MAX_KEYPOINTS: usize = 1024;

/// A parsed asset in its own frame: metres, +y up, as the file placed it (its meshes, materials
/// and emitters; no camera or lights of its own), and its triangles merged for collision.
#[derive(Debug)]
pub struct AssetMesh {
    /// The file as a scene, scaled to metres and turned +y up.
    pub scene: SceneDescription,
    /// Every triangle of its shapes, one vertex list (asset frame, m).
    pub positions: Vec<[f64; 3]>,
    pub indices: Vec<[u32; 3]>,
    /// Bounds of `positions`, m.
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// What the cache counts for it, bytes (geometry and image textures).
    pub bytes: usize,
    /// Its convex hull's vertices, computed on first use ([`crate::physics::hull_points`]).
    pub hull: OnceLock<std::result::Result<Vec<[f64; 3]>, String>>,
    /// Its convex decomposition's parts, computed on first use
    /// ([`crate::physics::decomposition_parts`]).
    pub parts: OnceLock<std::result::Result<Vec<Vec<[f64; 3]>>, String>>,
}

/// An asset of a library.
#[derive(Debug, Clone)]
pub struct Asset {
    pub path: PathBuf,
    pub category: String,
    pub scale_to_m: f64,
    pub up_axis: UpAxisName,
    pub licence: Option<String>,
    /// Where it was listed: `manifest.csv:4`, `assets[2]`.
    pub origin: String,
    pub mesh: Arc<AssetMesh>,
    /// Its own keypoints in its frame (metres, +y up, as [`AssetMesh::scene`]), when the
    /// manifest gives them.
    pub keypoints: Option<Arc<camsim_scene3d::ObjectKeypoints>>,
}

/// The assets of all sources, in source order (a folder's and a glob's files sorted by path).
#[derive(Debug, Clone, Default)]
pub struct Library {
    pub assets: Vec<Asset>,
}

impl Library {
    /// Read every source and every asset it lists (see the module docs); `key` names the
    /// sources' spec key in errors (`compose.assets`), relative paths resolve against
    /// `base_dir`, `cache_budget_bytes` bounds the process-wide asset cache.
    pub fn load(
        sources: &[String],
        base_dir: &Path,
        key: &str,
        cache_budget_bytes: usize,
    ) -> Result<Library> {
        let mut assets = Vec::new();
        for (i, src) in sources.iter().enumerate() {
            let skey = format!("{key}[{i}]");
            for (entry, origin, dir) in list_source(src, base_dir, &skey)? {
                assets.push(load_entry(&entry, &origin, &dir, cache_budget_bytes)?);
            }
        }
        if assets.is_empty() {
            return Err(ComposeError::new(
                key,
                "the asset sources list no asset (give a manifest, a folder, a glob or files)",
            ));
        }
        // One keypoint list per category (COCO's): the same names and edges, or none at all.
        let mut first: HashMap<&str, &Asset> = HashMap::new();
        for a in &assets {
            let f = *first.entry(a.category.as_str()).or_insert(a);
            let list = |x: &Asset| {
                x.keypoints
                    .as_ref()
                    .map(|k| (k.names.clone(), k.skeleton.clone()))
            };
            if list(f) != list(a) {
                let say = |x: &Asset| match &x.keypoints {
                    Some(k) => format!("keypoints {:?}", k.names),
                    None => "no keypoints (its box's corners)".to_string(),
                };
                return Err(ComposeError::new(
                    format!("{}: {}", a.origin, a.path.display()),
                    format!(
                        "category {:?}: this asset has {}, but {} ({}) has {}; the assets of one category share one keypoint list (names and skeleton)",
                        a.category,
                        say(a),
                        f.path.display(),
                        f.origin,
                        say(f)
                    ),
                ));
            }
        }
        Ok(Library { assets })
    }

    /// The categories of the library, sorted, once each.
    pub fn categories(&self) -> Vec<&str> {
        let mut c: Vec<&str> = self.assets.iter().map(|a| a.category.as_str()).collect();
        c.sort_unstable();
        c.dedup();
        c
    }
}

fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

fn default_entry(path: &Path) -> ManifestEntry {
    ManifestEntry {
        path: path.display().to_string(),
        category: None,
        scale_to_m: 1.0,
        up_axis: UpAxisName::Y,
        licence: None,
        keypoints: None,
    }
}

/// The entries of one source: (entry, where it was listed, the folder its path is relative to).
fn list_source(
    src: &str,
    base_dir: &Path,
    key: &str,
) -> Result<Vec<(ManifestEntry, String, PathBuf)>> {
    let err = |m: String| ComposeError::new(key, m);
    if src.contains('*') || src.contains('?') {
        let files = glob_files(src, base_dir).map_err(err)?;
        if files.is_empty() {
            return Err(ComposeError::new(
                key,
                format!("the glob {src:?} matches no file"),
            ));
        }
        return Ok(files
            .into_iter()
            .map(|f| (default_entry(&f), format!("{key} ({src})"), PathBuf::new()))
            .collect());
    }
    let path = resolve(base_dir, src);
    if path.is_dir() {
        let mut files = Vec::new();
        walk(&path, true, &mut |p| {
            if has_asset_extension(p) {
                files.push(p.to_path_buf());
            }
        })
        .map_err(err)?;
        files.sort();
        if files.is_empty() {
            return Err(ComposeError::new(
                key,
                format!(
                    "the folder {} has no asset file ({})",
                    path.display(),
                    ASSET_EXTENSIONS.join(", ")
                ),
            ));
        }
        return Ok(files
            .into_iter()
            .map(|f| (default_entry(&f), format!("{key} ({src})"), PathBuf::new()))
            .collect());
    }
    if !path.is_file() {
        return Err(ComposeError::new(
            key,
            format!("{}: no such file or folder", path.display()),
        ));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    match ext.as_str() {
        "csv" => read_csv(&path).map(|v| {
            v.into_iter()
                .map(|(e, line)| (e, format!("{}:{line}", path.display()), dir.clone()))
                .collect()
        }),
        "json" => read_json(&path).map(|v| {
            v.into_iter()
                .enumerate()
                .map(|(i, e)| (e, format!("{}: assets[{i}]", path.display()), dir.clone()))
                .collect()
        }),
        _ => Ok(vec![(
            default_entry(&path),
            key.to_string(),
            PathBuf::new(),
        )]),
    }
}

fn has_asset_extension(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ASSET_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

fn walk(dir: &Path, recursive: bool, f: &mut dyn FnMut(&Path)) -> std::result::Result<(), String> {
    let rd = std::fs::read_dir(dir).map_err(|e| format!("{}: cannot list: {e}", dir.display()))?;
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            if recursive {
                walk(&p, true, f)?;
            }
        } else {
            f(&p);
        }
    }
    Ok(())
}

/// The files a glob names: its folder part is literal, its last part a `*`/`?` pattern on file
/// names (`camsim_pbrt::overlay::glob_match` for `*`), `**/` before it for every folder below.
fn glob_files(pattern: &str, base_dir: &Path) -> std::result::Result<Vec<PathBuf>, String> {
    let (dir, name) = match pattern.rfind('/') {
        Some(k) => (&pattern[..k], &pattern[k + 1..]),
        None => ("", pattern),
    };
    let (dir, recursive) = match dir.strip_suffix("**") {
        Some(d) => (d.trim_end_matches('/'), true),
        None => (dir, false),
    };
    if dir.contains('*') || dir.contains('?') {
        return Err(format!(
            "glob {pattern:?}: wildcards only in the file name (and `**/` before it)"
        ));
    }
    let root = resolve(base_dir, if dir.is_empty() { "." } else { dir });
    if !root.is_dir() {
        return Err(format!(
            "glob {pattern:?}: the folder {} does not exist",
            root.display()
        ));
    }
    let mut out = Vec::new();
    walk(&root, recursive, &mut |p| {
        let n = p
            .file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default();
        if wildcard_match(name, &n) {
            out.push(p.to_path_buf());
        }
    })?;
    out.sort();
    Ok(out)
}

/// `*` (any run) and `?` (any one character) wildcards.
fn wildcard_match(pattern: &str, name: &str) -> bool {
    if !pattern.contains('?') {
        return camsim_pbrt::overlay::glob_match(pattern, name);
    }
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    fn rec(p: &[char], n: &[char]) -> bool {
        match p.first() {
            None => n.is_empty(),
            Some('*') => (0..=n.len()).any(|k| rec(&p[1..], &n[k..])),
            Some('?') => !n.is_empty() && rec(&p[1..], &n[1..]),
            Some(c) => n.first() == Some(c) && rec(&p[1..], &n[1..]),
        }
    }
    rec(&p, &n)
}

/// A CSV manifest: its entries with their 1-based line numbers.
fn read_csv(path: &Path) -> Result<Vec<(ManifestEntry, u64)>> {
    let name = path.display().to_string();
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .flexible(false)
        .from_path(path)
        .map_err(|e| ComposeError::new(&name, format!("cannot read: {e}")))?;
    let headers: Vec<String> = rd
        .headers()
        .map_err(|e| ComposeError::new(format!("{name}:1"), e.to_string()))?
        .iter()
        .map(|h| h.to_ascii_lowercase())
        .collect();
    const COLUMNS: [&str; 6] = [
        "path",
        "category",
        "scale_to_m",
        "up_axis",
        "licence",
        "keypoints",
    ];
    for h in &headers {
        if !COLUMNS.contains(&h.as_str()) {
            return Err(ComposeError::new(
                format!("{name}:1"),
                format!("unknown column {h:?} (columns: {})", COLUMNS.join(", ")),
            ));
        }
    }
    let col = |c: &str| headers.iter().position(|h| h == c);
    let path_col = col("path")
        .ok_or_else(|| ComposeError::new(format!("{name}:1"), "the header has no `path` column"))?;
    let mut out = Vec::new();
    for rec in rd.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            ComposeError::new(format!("{name}:{line}"), e.to_string())
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        let key = format!("{name}:{line}");
        let get = |c: &str| col(c).and_then(|k| rec.get(k)).filter(|v| !v.is_empty());
        let p = rec.get(path_col).unwrap_or("");
        if p.is_empty() {
            return Err(ComposeError::new(key, "column path is empty"));
        }
        let scale_to_m = match get("scale_to_m") {
            None => 1.0,
            Some(v) => v.parse::<f64>().map_err(|_| {
                ComposeError::new(&key, format!("column scale_to_m: {v:?} is not a number"))
            })?,
        };
        let up_axis = match get("up_axis") {
            None => UpAxisName::Y,
            Some(v) => match v.to_ascii_lowercase().as_str() {
                "y" => UpAxisName::Y,
                "z" => UpAxisName::Z,
                _ => {
                    return Err(ComposeError::new(
                        &key,
                        format!("column up_axis: {v:?} is not y or z"),
                    ))
                }
            },
        };
        out.push((
            ManifestEntry {
                path: p.to_string(),
                category: get("category").map(str::to_string),
                scale_to_m,
                up_axis,
                licence: get("licence").map(str::to_string),
                keypoints: get("keypoints").map(|v| KeypointSource::File(v.to_string())),
            },
            line,
        ));
    }
    Ok(out)
}

fn read_json(path: &Path) -> Result<Vec<ManifestEntry>> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| ComposeError::new(&name, format!("cannot read: {e}")))?;
    // Parse as a value first, so that an entry's error names its index and field.
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| ComposeError::new(format!("{name}:{}", e.line()), format!("not JSON: {e}")))?;
    let list = match &v {
        serde_json::Value::Array(a) => a.clone(),
        serde_json::Value::Object(o) => match o.get("assets") {
            Some(serde_json::Value::Array(a)) if o.len() == 1 => a.clone(),
            _ => {
                return Err(ComposeError::new(
                    &name,
                    "a JSON manifest is an array of assets or { \"assets\": [...] }",
                ))
            }
        },
        _ => {
            return Err(ComposeError::new(
                &name,
                "a JSON manifest is an array of assets or { \"assets\": [...] }",
            ))
        }
    };
    let mut out = Vec::with_capacity(list.len());
    for (i, e) in list.into_iter().enumerate() {
        let entry: ManifestEntry = serde_json::from_value(e)
            .map_err(|e| ComposeError::new(format!("{name}: assets[{i}]"), e.to_string()))?;
        out.push(entry);
    }
    Ok(out)
}

fn load_entry(e: &ManifestEntry, origin: &str, dir: &Path, budget: usize) -> Result<Asset> {
    let path = resolve(dir, &e.path);
    let key = format!("{origin}: {}", path.display());
    if !(e.scale_to_m > 0.0 && e.scale_to_m.is_finite()) {
        return Err(ComposeError::new(
            key,
            format!("scale_to_m {} must be a positive number", e.scale_to_m),
        ));
    }
    let mesh = cached_mesh(&path, e.scale_to_m, e.up_axis, budget)
        .map_err(|m| ComposeError::new(&key, m))?;
    let keypoints = match &e.keypoints {
        None => None,
        Some(src) => Some(Arc::new(read_keypoints(src, dir, e, &key)?)),
    };
    Ok(Asset {
        category: e.category.clone().unwrap_or_else(|| stem(&path)),
        path,
        scale_to_m: e.scale_to_m,
        up_axis: e.up_axis,
        licence: e.licence.clone(),
        origin: origin.to_string(),
        mesh,
        keypoints,
    })
}

/// An entry's keypoints, checked, in the asset's frame (its file's units and axes through
/// `scale_to_m` and `up_axis`, as [`read_asset`] moves the mesh).
fn read_keypoints(
    src: &KeypointSource,
    dir: &Path,
    e: &ManifestEntry,
    key: &str,
) -> Result<camsim_scene3d::ObjectKeypoints> {
    let (k, at) = match src {
        KeypointSource::Inline(k) => (k.clone(), format!("{key}: keypoints")),
        KeypointSource::File(f) => {
            let p = resolve(dir, f);
            let at = format!("{key}: keypoints {}", p.display());
            let text = std::fs::read_to_string(&p)
                .map_err(|err| ComposeError::new(&at, format!("cannot read: {err}")))?;
            let k: KeypointsFile = serde_json::from_str(&text).map_err(|err| {
                ComposeError::new(format!("{at}:{}", err.line()), err.to_string())
            })?;
            (k, at)
        }
    };
    let err = |m: String| ComposeError::new(&at, m);
    if k.names.is_empty() || k.names.len() > MAX_KEYPOINTS {
        return Err(err(format!(
            "{} names: give 1 to {MAX_KEYPOINTS} keypoints",
            k.names.len()
        )));
    }
    if k.points.len() != k.names.len() {
        return Err(err(format!(
            "{} names but {} points: give one point per name",
            k.names.len(),
            k.points.len()
        )));
    }
    let mut seen = std::collections::HashSet::new();
    for n in &k.names {
        if n.is_empty() || !seen.insert(n.as_str()) {
            return Err(err(format!("names: {n:?} is empty or given twice")));
        }
    }
    if let Some((i, _)) = k
        .points
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|v| !v.is_finite()))
    {
        return Err(err(format!("points[{i}] is not finite")));
    }
    let n = k.names.len();
    if let Some((i, s)) = k
        .skeleton
        .iter()
        .enumerate()
        .find(|(_, s)| s[0] >= n || s[1] >= n || s[0] == s[1])
    {
        return Err(err(format!(
            "skeleton[{i}] = {s:?}: an edge joins two different points, 0-based below {n}"
        )));
    }
    let t = Transform::scale([e.scale_to_m; 3]).then_apply_to(&e.up_axis.axis().to_y_up());
    Ok(camsim_scene3d::ObjectKeypoints {
        names: k.names,
        skeleton: k.skeleton,
        points_m: k.points.iter().map(|p| t.apply_point(*p)).collect(),
    })
}

/// Read an asset file into its frame (see [`AssetMesh`]).
pub fn read_asset(
    path: &Path,
    scale_to_m: f64,
    up: UpAxisName,
) -> std::result::Result<AssetMesh, String> {
    let format = camsim_assets::detect_format(path).map_err(|e| e.message)?;
    let mut scene = match format {
        SceneFormat::Glb | SceneFormat::Gltf | SceneFormat::Obj => camsim_assets::read_scene(
            path,
            &camsim_assets::ReadOptions {
                default_light: false,
                ..Default::default()
            },
        )
        .map_err(|e| e.message)?,
        SceneFormat::Ply => {
            let m = camsim_pbrt::ply::read_ply(path)?;
            let mut s = SceneDescription {
                camera: camsim_assets::framing_camera([0.0; 3], [0.0; 3], 64),
                shapes: Vec::new(),
                materials: Vec::new(),
                named_materials: HashMap::new(),
                lights: Vec::new(),
                settings: Default::default(),
                focus_distance_m: None,
                notes: Vec::new(),
                media: Default::default(),
                light_groups: Vec::new(),
            };
            // A PLY has no material: grey diffuse (reflectance 0.5), as `[[object]] add` gives it.
            s.materials.push(Material::Diffuse {
                reflectance: Texture::Constant(camsim_core::Spectrum::from_pairs(&[
                    (300.0, 0.5),
                    (900.0, 0.5),
                ])),
            });
            s.shapes.push(Shape {
                name: None,
                geometry: Geometry::mesh(m.positions, m.triangles, m.uvs, m.normals),
                material: 0,
                area_light: None,
                reverse_orientation: false,
                tags: Default::default(),
            });
            s
        }
        SceneFormat::Pbrt => camsim_pbrt::parse_file(path).map_err(|e| e.to_string())?,
    };
    let t = Transform::scale([scale_to_m; 3]).then_apply_to(&up.axis().to_y_up());
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut bytes = 0usize;
    for (k, s) in scene.shapes.iter_mut().enumerate() {
        camsim_scene3d::xform::transform_shape(s, &t).map_err(|e| format!("shape {k}: {e}"))?;
        match &s.geometry {
            Geometry::Triangles {
                positions: p,
                indices: ix,
                uvs,
                normals,
                colors,
                uvs1,
                tangents,
            } => {
                let base = positions.len() as u32;
                if p.iter().flatten().any(|v| !v.is_finite()) {
                    return Err(format!("shape {k} has a vertex that is not finite"));
                }
                for tri in ix {
                    if tri.iter().any(|&i| i as usize >= p.len()) {
                        return Err(format!(
                            "shape {k}: triangle {tri:?} indexes past its {} vertices",
                            p.len()
                        ));
                    }
                    indices.push(tri.map(|i| i + base));
                }
                positions.extend_from_slice(p);
                bytes += p.len() * 24 * 2
                    + ix.len() * 12 * 2
                    + uvs.as_ref().map_or(0, |u| u.len() * 8)
                    + normals.as_ref().map_or(0, |n| n.len() * 24)
                    + colors.as_ref().map_or(0, |c| c.len() * 16)
                    + uvs1.as_ref().map_or(0, |u| u.len() * 8)
                    + tangents.as_ref().map_or(0, |t| t.len() * 16);
            }
            other => {
                let kind = match other {
                    Geometry::Sphere { .. } | Geometry::PartialSphere { .. } => "a sphere",
                    _ => "curves",
                };
                return Err(format!(
                    "shape {k} is {kind}: a spawned asset must be made of triangle meshes"
                ));
            }
        }
    }
    if indices.is_empty() {
        return Err("the file has no triangles".into());
    }
    for m in &scene.materials {
        if let Material::Diffuse {
            reflectance: Texture::Image { rgb, .. },
        } = m
        {
            bytes += rgb.len() * 12;
        }
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    scene.lights.clear();
    scene.light_groups.clear();
    Ok(AssetMesh {
        scene,
        positions,
        indices,
        lo,
        hi,
        bytes,
        hull: OnceLock::new(),
        parts: OnceLock::new(),
    })
}

type CacheKey = (PathBuf, u64, UpAxisName);

#[derive(Default)]
struct Cache {
    entries: HashMap<CacheKey, (Arc<AssetMesh>, u64)>,
    bytes: usize,
    clock: u64,
}

fn cache() -> &'static Mutex<Cache> {
    static CACHE: OnceLock<Mutex<Cache>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(Cache::default()))
}

/// The asset at `path` from the process-wide cache, read on a miss; the least recently used
/// entries leave when the cache holds more than `budget` bytes (the newest always stays).
pub fn cached_mesh(
    path: &Path,
    scale_to_m: f64,
    up: UpAxisName,
    budget: usize,
) -> std::result::Result<Arc<AssetMesh>, String> {
    let canon = std::fs::canonicalize(path).map_err(|e| format!("cannot open: {e}"))?;
    let key = (canon, scale_to_m.to_bits(), up);
    {
        let mut c = cache().lock().unwrap_or_else(|p| p.into_inner());
        c.clock += 1;
        let now = c.clock;
        if let Some((m, used)) = c.entries.get_mut(&key) {
            *used = now;
            return Ok(m.clone());
        }
    }
    // Read outside the lock: other threads keep using the cache meanwhile.
    let mesh = Arc::new(read_asset(path, scale_to_m, up)?);
    let mut c = cache().lock().unwrap_or_else(|p| p.into_inner());
    c.clock += 1;
    let now = c.clock;
    if let Some((m, used)) = c.entries.get_mut(&key) {
        *used = now;
        return Ok(m.clone());
    }
    c.bytes += mesh.bytes;
    c.entries.insert(key.clone(), (mesh.clone(), now));
    while c.bytes > budget && c.entries.len() > 1 {
        let oldest = c
            .entries
            .iter()
            .filter(|(k, _)| **k != key)
            .min_by_key(|(_, (_, used))| *used)
            .map(|(k, _)| k.clone());
        match oldest {
            Some(k) => {
                if let Some((m, _)) = c.entries.remove(&k) {
                    c.bytes -= m.bytes;
                }
            }
            None => break,
        }
    }
    Ok(mesh)
}

/// How many assets and bytes the cache holds now.
pub fn cache_usage() -> (usize, usize) {
    let c = cache().lock().unwrap_or_else(|p| p.into_inner());
    (c.entries.len(), c.bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards() {
        assert!(wildcard_match("*.glb", "Duck.glb"));
        assert!(wildcard_match("b?x.obj", "box.obj"));
        assert!(!wildcard_match("b?x.obj", "bx.obj"));
        assert!(!wildcard_match("*.obj", "Duck.glb"));
    }

    #[test]
    fn the_cache_keeps_the_newest_within_its_budget() {
        let dir = std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/assets/trimesh"
        ));
        // Scales no other test uses, so the process-wide cache's entries are this test's.
        let a = cached_mesh(&dir.join("cube.OBJ"), 0.123, UpAxisName::Y, usize::MAX).unwrap();
        let again = cached_mesh(&dir.join("cube.OBJ"), 0.123, UpAxisName::Y, usize::MAX).unwrap();
        assert!(Arc::ptr_eq(&a, &again), "a second read missed the cache");
        assert!((a.hi[0] - 0.0615).abs() < 1e-12, "scale_to_m not applied");
        // A zero budget keeps only the newest entry.
        let b = cached_mesh(&dir.join("box.obj"), 0.123, UpAxisName::Z, 0).unwrap();
        assert_eq!(cache_usage().0, 1);
        let b2 = cached_mesh(&dir.join("box.obj"), 0.123, UpAxisName::Z, 0).unwrap();
        assert!(Arc::ptr_eq(&b, &b2));
        let a2 = cached_mesh(&dir.join("cube.OBJ"), 0.123, UpAxisName::Y, 0).unwrap();
        assert!(
            !Arc::ptr_eq(&a, &a2),
            "an evicted entry came back from the cache"
        );
    }
}
