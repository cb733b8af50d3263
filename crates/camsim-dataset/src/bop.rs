//! BOP export of a complete composed dataset (`camsim dataset --bop`): 6D object poses of the
//! spawned assets, camera matrices and visible masks in the BOP format (Hodaň et al., "BOP:
//! Benchmark for 6D Object Pose Estimation", ECCV 2018; the format document of the BOP toolkit,
//! `docs/bop_datasets_format.md`), on the raw image's pixel grid.
//!
//! Layout (`OUT/bop/`):
//! - `camera.json`: the first sample's intrinsics (`fx fy cx cy width height depth_scale`);
//! - `models/obj_NNNNNN.ply` (mm, binary PLY) and `models/models_info.json` (`diameter`,
//!   `min_x/y/z`, `size_x/y/z`, mm): one model per asset of the library (in its order, ids from 1),
//!   the asset in its frame (metres times 1000, +y up, as composed);
//! - `train_pbr/SSSSSS/` per shard S: `scene_camera.json` (`cam_K`, `cam_R_w2c`, `cam_t_w2c`,
//!   `depth_scale`), `scene_gt.json` (per spawned object `obj_id`, `cam_R_m2c`, `cam_t_m2c` mm),
//!   `scene_gt_info.json` (`bbox_visib` `[x, y, w, h]`, `px_count_visib`, `visib_fract`; with
//!   the `amodal` output also `bbox_obj`, `px_count_all`, `px_count_valid` (with `depth`) and
//!   `visib_fract` as BOP's visible / all), `rgb/IIIIII.png` (the preview),
//!   `mask_visib/IIIIII_GGGGGG.png` (0/255), with `amodal` `mask/IIIIII_GGGGGG.png` (the full
//!   silhouette, occluders ignored) and, with the `depth` output, `depth/IIIIII.png` (16-bit,
//!   depth along the axis times `depth_scale` in mm); the
//!   image id is the sample index (with a rig, sample index x cameras + camera, each camera's
//!   image with its own `scene_camera` entry).
//!
//! Two things BOP cannot say are written beside its keys: a drawn scale other than 1 (BOP's
//! models are rigid: x_cam = R (s x_model) + t, `camsim_scale` s) and a lens's distortion (BOP's
//! K is a pinhole: `camsim_dist_coeffs`, OpenCV's, with the sample's fit). A pbrt-v4 world is
//! left-handed (its cameras' world-to-camera has determinant -1 in OpenCV's frame), while BOP's
//! rotations are proper: the export then mirrors the models' x (`models_info.json` says so) and
//! the world's x, so that every `cam_R` is a rotation and the models project onto the images.

use crate::spec::DatasetSpec;
use crate::{DatasetError, Result};
use camsim_compose::manifest::{Asset, Library};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

type Mat3 = [[f64; 3]; 3];

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn det(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Mirror of x: right-multiplied onto a left-handed frame's matrices.
const MIRROR_X: Mat3 = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn flat(m: &Mat3) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

fn mat3(v: &serde_json::Value) -> Option<Mat3> {
    let rows = v.as_array()?;
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = rows.get(i)?.get(j)?.as_f64()?;
        }
    }
    Some(m)
}

/// The models of the export: one per asset (canonical file, scale to metres, up axis).
#[derive(Default)]
struct Models {
    keys: Vec<(PathBuf, u64, String)>,
    assets: Vec<Asset>,
    /// Libraries loaded, by (asset sources, base folder).
    libraries: BTreeMap<(Vec<String>, PathBuf), Arc<Library>>,
}

impl Models {
    fn key(a: &Asset) -> (PathBuf, u64, String) {
        (
            std::fs::canonicalize(&a.path).unwrap_or_else(|_| a.path.clone()),
            a.scale_to_m.to_bits(),
            format!("{:?}", a.up_axis),
        )
    }

    /// The library of sample `i`'s composition, its assets given ids.
    fn library(&mut self, spec: &DatasetSpec, i: u64) -> Result<Option<Arc<Library>>> {
        let sample = spec.sample(i)?;
        let Some(r) = sample.config.render.as_ref() else {
            return Ok(None);
        };
        let Some(c) = r.compose.as_ref() else {
            return Ok(None);
        };
        let base = r
            .overlay_inline_base
            .clone()
            .unwrap_or_else(|| PathBuf::from("."));
        let lib_key = (c.assets.clone(), base.clone());
        if let Some(l) = self.libraries.get(&lib_key) {
            return Ok(Some(l.clone()));
        }
        let lib = Library::load(
            &c.assets,
            &base,
            "render.compose.assets",
            (c.asset_cache_mib * 1048576.0) as usize,
        )
        .map_err(|e| DatasetError::spec(&spec.source, format!("BOP export: render.{e}")))?;
        for a in &lib.assets {
            let k = Self::key(a);
            if !self.keys.contains(&k) {
                self.keys.push(k);
                self.assets.push(a.clone());
            }
        }
        let lib = Arc::new(lib);
        self.libraries.insert(lib_key, lib.clone());
        Ok(Some(lib))
    }

    /// The BOP id (1..) of the asset a record names (`asset`: its path as composed).
    fn id_of(&self, lib: &Library, asset: &str, scale_to_m: f64) -> Option<usize> {
        let a = lib
            .assets
            .iter()
            .find(|a| a.path.display().to_string() == asset && a.scale_to_m == scale_to_m)?;
        let k = Self::key(a);
        self.keys.iter().position(|x| *x == k).map(|p| p + 1)
    }
}

/// Write `OUT/bop/` for the complete dataset in `out` (see the module docs); returns the folder.
pub fn export_bop(spec: &DatasetSpec, out: &Path) -> Result<PathBuf> {
    crate::run::require_labelled_and_complete(spec, out, "BOP", "; depth for BOP's depth images")?;
    let mut models = Models::default();
    if models.library(spec, 0)?.is_none() {
        return Err(DatasetError::spec(
            &spec.source,
            "BOP export needs composed objects ([render.compose] with assets): BOP's poses are of object models",
        ));
    }
    // Staged beside OUT/bop and swapped in whole when complete: an error leaves the previous
    // export (or none), never a part of one.
    let target = out.join("bop");
    let staged = camsim_io::atomic::OutputDir::create(&target)?;
    let bop = staged.path().to_path_buf();
    let scratch = bop.join(".scratch");
    std::fs::create_dir_all(&scratch).map_err(|e| DatasetError::io(&scratch, e))?;
    let result = export_into(spec, out, &bop, &scratch, &mut models);
    let _ = std::fs::remove_dir_all(&scratch);
    let (mirror, camera) = result?;
    write_models(&bop.join("models"), &models, mirror.unwrap_or(false))?;
    if let Some(c) = camera {
        camsim_io::atomic::write_json_atomic(&bop.join("camera.json"), &c)?;
    }
    staged.commit()?;
    Ok(target)
}

fn create(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| DatasetError::io(dir, e))
}

/// The scenes (one per shard); returns whether the models are mirrored (`None`: no object) and
/// the dataset's `camera.json`.
fn export_into(
    spec: &DatasetSpec,
    out: &Path,
    bop: &Path,
    scratch: &Path,
    models: &mut Models,
) -> Result<(Option<bool>, Option<serde_json::Value>)> {
    let mut mirror: Option<bool> = None;
    let mut camera = None;
    for s in 0..spec.shards() {
        let (tar_path, views) = crate::run::shard_views(
            spec,
            out,
            s,
            &[
                "preview.png",
                "instances.png",
                "boxes.json",
                "json",
                "depth.sensor.exr",
            ],
        )?;
        let scene_dir = bop.join("train_pbr").join(format!("{s:06}"));
        for sub in ["rgb", "mask_visib"] {
            create(&scene_dir.join(sub))?;
        }
        let (mut scene_camera, mut scene_gt, mut scene_gt_info) = (
            serde_json::Map::new(),
            serde_json::Map::new(),
            serde_json::Map::new(),
        );
        for view in views {
            let (key, im_id, mut f) = (view.stem, view.image_id, view.files);
            let (Some(preview), Some(inst_png), Some(boxes), Some(record)) = (
                f.remove("preview.png"),
                f.remove("instances.png"),
                f.remove("boxes.json"),
                f.remove("json"),
            ) else {
                continue; // a failed sample
            };
            let index: u64 = view.key.parse().unwrap_or_default();
            let bad = |what: &str| DatasetError::file(&tar_path, format!("{key}: {what}"));
            let boxes: serde_json::Value =
                serde_json::from_slice(&boxes).map_err(|e| bad(&format!("boxes.json: {e}")))?;
            let record: serde_json::Value =
                serde_json::from_slice(&record).map_err(|e| bad(&format!("json: {e}")))?;
            camsim_io::atomic::write_atomic(&scene_dir.join(format!("rgb/{im_id:06}.png")), |w| {
                Ok(w.write_all(&preview)?)
            })?;
            let tmp = scratch.join(format!("{key}.instances.png"));
            std::fs::write(&tmp, &inst_png).map_err(|e| DatasetError::io(&tmp, e))?;
            let (rows, cols, map) = camsim_io::raster::read_mosaic_16(&tmp)?;
            let _ = std::fs::remove_file(&tmp);

            let cam = &boxes["cameras"]["sensor"];
            let k = mat3(&cam["k"]).ok_or_else(|| bad("boxes.json: cameras.sensor.k"))?;
            let w2c = cam["world_to_camera"]
                .as_array()
                .filter(|m| m.len() >= 3)
                .ok_or_else(|| bad("boxes.json: cameras.sensor.world_to_camera"))?;
            let rw = mat3(&serde_json::Value::Array(
                w2c[..3]
                    .iter()
                    .map(|row| serde_json::json!([row[0], row[1], row[2]]))
                    .collect(),
            ))
            .ok_or_else(|| bad("boxes.json: world_to_camera"))?;
            let tw: [f64; 3] = std::array::from_fn(|i| w2c[i][3].as_f64().unwrap_or(f64::NAN));
            let left_handed = det(&rw) < 0.0;
            let rw_out = if left_handed { mul(&rw, &MIRROR_X) } else { rw };

            // Depth (BOP: uint16, value x depth_scale = mm; 0 where unknown).
            let mut depth_scale_mm = 1.0;
            let mut depth_valid: Option<Vec<bool>> = None;
            if let Some(exr) = f.remove("depth.sensor.exr") {
                let tmp = scratch.join(format!("{key}.depth.exr"));
                std::fs::write(&tmp, &exr).map_err(|e| DatasetError::io(&tmp, e))?;
                let (dr, dc, z_m) = camsim_io::exr::read_gray_exr(&tmp, Some("Z"))?;
                let _ = std::fs::remove_file(&tmp);
                let max_mm = z_m
                    .iter()
                    .filter(|z| z.is_finite() && **z > 0.0)
                    .fold(0.0f64, |m, &z| m.max(z as f64 * 1e3));
                // The finest of 0.1, 1 and 10 mm steps that holds the farthest point.
                depth_scale_mm = [0.1, 1.0, 10.0]
                    .into_iter()
                    .find(|ds| max_mm / ds <= 65535.0)
                    .unwrap_or(10.0);
                let v: Vec<u16> = z_m
                    .iter()
                    .map(|&z| {
                        let q = z as f64 * 1e3 / depth_scale_mm;
                        if z.is_finite() && z > 0.0 && q <= 65535.0 {
                            q.round() as u16
                        } else {
                            0
                        }
                    })
                    .collect();
                depth_valid = Some(v.iter().map(|&d| d > 0).collect());
                create(&scene_dir.join("depth"))?;
                camsim_io::raster::write_png16_gray(
                    &scene_dir.join(format!("depth/{im_id:06}.png")),
                    dr,
                    dc,
                    &v,
                )?;
            }
            let mut cam_entry = serde_json::json!({
                "cam_K": flat(&k),
                "cam_R_w2c": flat(&rw_out),
                "cam_t_w2c": tw.map(|t| t * 1e3),
                "depth_scale": depth_scale_mm,
            });
            if let Some(c) = &view.camera {
                cam_entry["camsim_camera"] = c.as_str().into();
                cam_entry["camsim_sample"] = view.key.as_str().into();
            }
            if let Some(d) = boxes["cameras"]["sensor_distortion_opencv"].as_object() {
                cam_entry["camsim_dist_coeffs"] = d
                    .get("dist_coeffs")
                    .cloned()
                    .unwrap_or(serde_json::Value::Null);
            }
            if camera.is_none() {
                camera = Some(serde_json::json!({
                    "fx": k[0][0], "fy": k[1][1], "cx": k[0][2], "cy": k[1][2],
                    "width": cols, "height": rows, "depth_scale": depth_scale_mm,
                }));
            }
            scene_camera.insert(im_id.to_string(), cam_entry);

            // Instances by name (a composed object is the instance of its name).
            let mut by_name = BTreeMap::new();
            for inst in boxes["instances"].as_array().into_iter().flatten() {
                if let (Some(n), Some(id)) = (inst["name"].as_str(), inst["id"].as_u64()) {
                    let bbox: Option<[u64; 4]> =
                        serde_json::from_value(inst["bbox_sensor"].clone()).ok();
                    let pixels = inst["pixels_sensor"].as_u64().unwrap_or(0);
                    let all = match inst.get("mask_all_sensor") {
                        Some(m) => Some(decode_rle(m, rows, cols).ok_or_else(|| {
                            bad(&format!(
                                "instance {n}: mask_all_sensor is not a {cols} x {rows} COCO RLE"
                            ))
                        })?),
                        None => None,
                    };
                    by_name.insert(
                        n.to_string(),
                        (id, inst["visible_fraction"].as_f64(), bbox, pixels, all),
                    );
                }
            }
            let lib = models.library(spec, index)?.ok_or_else(|| {
                bad("the sample has no [render.compose] (every sample needs composed objects)")
            })?;
            let (mut gts, mut infos) = (Vec::new(), Vec::new());
            let objects = record["compose"]["objects"].as_array().cloned();
            for (g, obj) in objects.into_iter().flatten().enumerate() {
                let name = obj["name"].as_str().unwrap_or_default();
                let asset = obj["asset"].as_str().unwrap_or_default();
                let obj_id = models
                    .id_of(&lib, asset, obj["scale_to_m"].as_f64().unwrap_or(f64::NAN))
                    .ok_or_else(|| {
                        bad(&format!(
                            "object {name}: asset {asset:?} is not in the spec's asset library (run the export from the folder the dataset was run from)"
                        ))
                    })?;
                let q: Vec<f64> = obj["rotation_wxyz"]
                    .as_array()
                    .map(|v| v.iter().filter_map(|x| x.as_f64()).collect())
                    .unwrap_or_default();
                let t: Vec<f64> = obj["translation_m"]
                    .as_array()
                    .map(|v| v.iter().filter_map(|x| x.as_f64()).collect())
                    .unwrap_or_default();
                if q.len() != 4 || t.len() != 3 {
                    return Err(bad(&format!("object {name}: its pose in the record")));
                }
                // x_cam = Rw (R s x_asset + t) + tw: BOP's model-to-camera (mm).
                let r_m2c = mul(
                    &rw,
                    &camsim_scene3d::motion::quat_to_matrix(&[q[0], q[1], q[2], q[3]]),
                );
                let mirrored = det(&r_m2c) < 0.0;
                match mirror {
                    None => mirror = Some(mirrored),
                    Some(m) if m != mirrored => {
                        return Err(bad(&format!(
                            "object {name}: the samples' frames differ in handedness (BOP's models are one set)"
                        )))
                    }
                    _ => {}
                }
                let r_m2c = if mirrored {
                    mul(&r_m2c, &MIRROR_X)
                } else {
                    r_m2c
                };
                let t_m2c: [f64; 3] = std::array::from_fn(|i| {
                    1e3 * ((0..3).map(|j| rw[i][j] * t[j]).sum::<f64>() + tw[i])
                });
                let mut gt = serde_json::json!({
                    "obj_id": obj_id,
                    "cam_R_m2c": flat(&r_m2c),
                    "cam_t_m2c": t_m2c,
                    "camsim_name": name,
                });
                let scale = obj["scale"].as_f64().unwrap_or(1.0);
                if scale != 1.0 {
                    gt["camsim_scale"] = scale.into();
                }
                gts.push(gt);
                // The visible mask on the raw grid; its box and pixel count are boxes.json's
                // (the labels' own `boxes_2d` of the same map).
                let (id, visib, bbox, n, all) = by_name.remove(name).unwrap_or_default();
                let mask: Vec<u8> = map
                    .iter()
                    .map(|&v| if id > 0 && v as u64 == id { 255 } else { 0 })
                    .collect();
                let bbox_visib = match bbox {
                    Some([x0, y0, x1, y1]) if n > 0 => {
                        serde_json::json!([x0, y0, x1 - x0, y1 - y0])
                    }
                    _ => serde_json::json!([-1, -1, -1, -1]),
                };
                let mut info = serde_json::json!({
                    "bbox_visib": bbox_visib,
                    "px_count_visib": n,
                    "visib_fract": if n > 0 { visib.unwrap_or(0.0) } else { 0.0 },
                });
                // With the amodal silhouettes: BOP's full mask, its box and counts, and
                // visib_fract as BOP defines it (visible over all pixels of the silhouette).
                if let Some(all) = all {
                    let n_all = all.iter().filter(|&&m| m).count();
                    let mut b = [usize::MAX, usize::MAX, 0, 0];
                    for (p, _) in all.iter().enumerate().filter(|(_, &m)| m) {
                        let (y, x) = (p / cols, p % cols);
                        b = [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)];
                    }
                    info["bbox_obj"] = if n_all > 0 {
                        serde_json::json!([b[0], b[1], b[2] - b[0], b[3] - b[1]])
                    } else {
                        serde_json::json!([-1, -1, -1, -1])
                    };
                    info["px_count_all"] = n_all.into();
                    if let Some(valid) = &depth_valid {
                        info["px_count_valid"] = all
                            .iter()
                            .zip(valid)
                            .filter(|(&m, &v)| m && v)
                            .count()
                            .into();
                    }
                    info["visib_fract"] = if n_all > 0 {
                        (n as f64 / n_all as f64).into()
                    } else {
                        0.0.into()
                    };
                    let mask: Vec<u8> = all.iter().map(|&m| if m { 255 } else { 0 }).collect();
                    create(&scene_dir.join("mask"))?;
                    camsim_io::raster::write_png8_gray(
                        &scene_dir.join(format!("mask/{im_id:06}_{g:06}.png")),
                        rows,
                        cols,
                        &mask,
                    )?;
                }
                infos.push(info);
                camsim_io::raster::write_png8_gray(
                    &scene_dir.join(format!("mask_visib/{im_id:06}_{g:06}.png")),
                    rows,
                    cols,
                    &mask,
                )?;
            }
            scene_gt.insert(im_id.to_string(), gts.into());
            scene_gt_info.insert(im_id.to_string(), infos.into());
        }
        for (name, doc) in [
            ("scene_camera.json", scene_camera),
            ("scene_gt.json", scene_gt),
            ("scene_gt_info.json", scene_gt_info),
        ] {
            camsim_io::atomic::write_json_atomic(
                &scene_dir.join(name),
                &serde_json::Value::Object(doc),
            )?;
        }
    }
    Ok((mirror, camera))
}

/// A COCO uncompressed RLE (`{ "size": [h, w], "counts": [...] }`: column-major runs, first
/// outside) as a row-major mask; `None` when it is not one of a `rows` x `cols` grid.
fn decode_rle(m: &serde_json::Value, rows: usize, cols: usize) -> Option<Vec<bool>> {
    if m["size"] != serde_json::json!([rows, cols]) {
        return None;
    }
    let mut mask = vec![false; rows * cols];
    let (mut at, mut inside) = (0usize, false);
    for c in m["counts"].as_array()? {
        let n = c.as_u64()? as usize;
        let end = at.checked_add(n).filter(|&e| e <= rows * cols)?;
        if inside {
            for k in at..end {
                // Column-major k: column k / rows, row k % rows.
                mask[(k % rows) * cols + k / rows] = true;
            }
        }
        at = end;
        inside = !inside;
    }
    (at == rows * cols).then_some(mask)
}

/// `models/obj_NNNNNN.ply` and `models_info.json`: each asset in mm, x mirrored with `mirror`
/// (faces turned so they still face outward).
fn write_models(dir: &Path, models: &Models, mirror: bool) -> Result<()> {
    create(dir)?;
    let mut info = serde_json::Map::new();
    for (i, a) in models.assets.iter().enumerate() {
        let id = i + 1;
        let sx = if mirror { -1.0 } else { 1.0 };
        let mm = |p: &[f64; 3]| {
            [
                (sx * p[0] * 1e3) as f32,
                (p[1] * 1e3) as f32,
                (p[2] * 1e3) as f32,
            ]
        };
        let positions: Vec<[f32; 3]> = a.mesh.positions.iter().map(mm).collect();
        let faces: Vec<[u32; 3]> = a
            .mesh
            .indices
            .iter()
            .map(|f| if mirror { [f[0], f[2], f[1]] } else { *f })
            .collect();
        camsim_io::ply::write_ply_mesh(
            &dir.join(format!("obj_{id:06}.ply")),
            &positions,
            &faces,
            &format!("camsim BOP model of {} (mm)", a.path.display()),
        )?;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
        // The diameter: the largest distance between two vertices, over the convex hull's.
        let hull: Vec<[f64; 3]> = match camsim_compose::physics::hull_points(&a.mesh) {
            Ok(h) => h.iter().map(|p| p.map(|c| c * 1e3)).collect(),
            Err(_) => positions.iter().map(|p| p.map(|c| c as f64)).collect(),
        };
        let mut diameter = 0.0f64;
        for (j, p) in hull.iter().enumerate() {
            for q in &hull[j + 1..] {
                diameter = diameter.max(
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt(),
                );
            }
        }
        info.insert(
            id.to_string(),
            serde_json::json!({
                "diameter": diameter,
                "min_x": lo[0], "min_y": lo[1], "min_z": lo[2],
                "size_x": hi[0] - lo[0], "size_y": hi[1] - lo[1], "size_z": hi[2] - lo[2],
                "camsim_asset": a.path.display().to_string(),
                "camsim_category": a.category,
                "camsim_mirrored_x": mirror,
            }),
        );
    }
    camsim_io::atomic::write_json_atomic(
        &dir.join("models_info.json"),
        &serde_json::Value::Object(info),
    )?;
    Ok(())
}
