//! COCO export of a complete dataset (`camsim dataset --coco`): one detection / instance
//! segmentation annotation file for the whole dataset, on the raw image's pixel grid.
//!
//! Layout: `coco/images/KEY.png` (the sensor previews, copied out of the shards; a rig's
//! cameras `KEY.CAMERA.png`, image id = sample index x cameras + camera) and
//! `coco/annotations.json` (COCO's object-detection format: `images`, `annotations`,
//! `categories`). Each annotation is one object instance of one sample: its mask as COCO's
//! compressed RLE (column-major runs, from the sample's sensor-geometry `instances.png`), its
//! pixel count as `area`, its tight box `[x, y, width, height]` (pixel edges), `iscrowd` 0, and
//! camsim's `visible_fraction`, `truncation` and `box_3d` (camera frame, boxes.json), and its
//! keypoints (an asset's own keypoints, else its 3D box's centre and corners, on the raw grid:
//! COCO's `keypoints` and `num_keypoints`; each category names them, with their edges as its
//! `skeleton`). With the `amodal` output, each annotation also has the instance's full silhouette
//! on the raw grid, occluders ignored, as `amodal_segmentation` (compressed RLE), `amodal_area`
//! and `amodal_bbox` (the fields of the COCO-style amodal sets, e.g. Zhu et al. 2017's COCOA);
//! an instance hidden entirely has no annotation, as in COCO. Categories are the instances' material names or object names ([`CategoryBy`]),
//! numbered 1.. in sorted order. The dataset must have the outputs `preview`, `instances` and `boxes`.

use crate::spec::DatasetSpec;
use crate::{DatasetError, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Where COCO category names come from (`--coco-categories material|object|category`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CategoryBy {
    /// The material of the instance's first shape (default: "red", "white", ...).
    #[default]
    Material,
    /// The instance's name (its shapes' name, a pbrt `ObjectInstance`'s object).
    Object,
    /// The instance's semantic category (`[[object]] category` in an overlay), else its name.
    Category,
}

impl CategoryBy {
    /// `material` or `object`.
    pub fn parse(text: &str) -> std::result::Result<CategoryBy, String> {
        match text {
            "material" => Ok(CategoryBy::Material),
            "object" => Ok(CategoryBy::Object),
            "category" => Ok(CategoryBy::Category),
            o => Err(format!(
                "--coco-categories {o:?}: material, object or category"
            )),
        }
    }
}

/// COCO's compressed RLE string of a binary mask given as `(rows, cols)` and a predicate on the
/// row-major pixel index: runs of 0s and 1s in column-major order starting with a (possibly
/// empty) run of 0s, each count after the second stored as the difference to the count two
/// before, written 5 bits per character (+48) with a continuation bit (pycocotools maskApi.c
/// `rleToString`, the format COCO's files use).
pub fn rle_string(rows: usize, cols: usize, inside: impl Fn(usize) -> bool) -> String {
    let mut counts: Vec<i64> = Vec::new();
    let (mut cur, mut run) = (false, 0i64);
    for c in 0..cols {
        for r in 0..rows {
            let v = inside(r * cols + c);
            if v != cur {
                counts.push(run);
                run = 0;
                cur = v;
            }
            run += 1;
        }
    }
    counts.push(run);
    rle_counts_string(&counts)
}

/// COCO's compressed RLE string of uncompressed RLE `counts` (column-major runs, first outside),
/// encoded as [`rle_string`] does.
pub fn rle_counts_string(counts: &[i64]) -> String {
    let mut s = String::new();
    for i in 0..counts.len() {
        let mut x = counts[i];
        if i > 2 {
            x -= counts[i - 2];
        }
        loop {
            let mut c = x & 0x1f;
            x >>= 5;
            let more = if c & 0x10 != 0 { x != -1 } else { x != 0 };
            if more {
                c |= 0x20;
            }
            s.push((c as u8 + 48) as char);
            if !more {
                break;
            }
        }
    }
    s
}

/// Write `coco/annotations.json` and `coco/images/` for the complete dataset in `out` (see the
/// module docs); returns the annotation file's path.
pub fn export_coco(spec: &DatasetSpec, out: &Path, by: CategoryBy) -> Result<PathBuf> {
    crate::run::require_labelled_and_complete(spec, out, "COCO", "")?;
    let coco = out.join("coco");
    let images_dir = coco.join("images");
    std::fs::create_dir_all(&images_dir).map_err(|e| DatasetError::io(&images_dir, e))?;
    let scratch = coco.join(format!(".scratch-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).map_err(|e| DatasetError::io(&scratch, e))?;
    let result = export_into(spec, out, by, &images_dir, &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let doc = result?;
    let path = coco.join("annotations.json");
    camsim_io::atomic::write_json_atomic(&path, &doc)?;
    Ok(path)
}

fn export_into(
    spec: &DatasetSpec,
    out: &Path,
    by: CategoryBy,
    images_dir: &Path,
    scratch: &Path,
) -> Result<serde_json::Value> {
    let mut images = Vec::new();
    // (image id, its instances' [(instance json, rle, area, bbox)]) gathered first, then the
    // categories numbered in sorted order.
    let mut pending: Vec<(u64, serde_json::Value, String, u64, [u64; 4])> = Vec::new();
    let mut categories = BTreeSet::new();
    let mut sizes: BTreeMap<u64, (usize, usize)> = BTreeMap::new();
    // Per category its keypoints' names and skeleton (an instance's `keypoints_3d`, else
    // boxes.json's `keypoints`: the box's), with the instance that set them.
    let mut keypoint_names: BTreeMap<String, (serde_json::Value, serde_json::Value, String)> =
        BTreeMap::new();
    for s in 0..spec.shards() {
        let (tar_path, views) = crate::run::shard_views(
            spec,
            out,
            s,
            &["preview.png", "instances.png", "boxes.json"],
        )?;
        for view in views {
            let (key, image_id, mut f) = (view.stem, view.image_id, view.files);
            // Failed samples have no files; 2D scenes have no instances (images without
            // annotations).
            let Some(preview) = f.remove("preview.png") else {
                continue;
            };
            let file_name = format!("{key}.png");
            let img_path = images_dir.join(&file_name);
            camsim_io::atomic::write_atomic(&img_path, |w| Ok(w.write_all(&preview)?))?;
            let (rows, cols, _) = camsim_io::raster::read_png8_rgb(&img_path)?;
            sizes.insert(image_id, (rows, cols));
            let mut image = serde_json::json!({
                "id": image_id,
                "file_name": file_name,
                "width": cols,
                "height": rows,
            });
            if let Some(c) = &view.camera {
                image["camsim_camera"] = c.as_str().into();
                image["camsim_sample"] = view.key.as_str().into();
            }
            images.push(image);
            let (Some(inst_png), Some(boxes)) = (f.remove("instances.png"), f.remove("boxes.json"))
            else {
                continue;
            };
            let tmp = scratch.join(format!("{key}.instances.png"));
            std::fs::write(&tmp, &inst_png).map_err(|e| DatasetError::io(&tmp, e))?;
            let (ir, ic, map) = camsim_io::raster::read_mosaic_16(&tmp)?;
            let _ = std::fs::remove_file(&tmp);
            if (ir, ic) != (rows, cols) {
                return Err(DatasetError::file(
                    &tar_path,
                    format!("{key}: instances.png is {ic} x {ir}, the preview {cols} x {rows}"),
                ));
            }
            let boxes: serde_json::Value = serde_json::from_slice(&boxes)
                .map_err(|e| DatasetError::file(&tar_path, format!("{key}.boxes.json: {e}")))?;
            for inst in boxes["instances"].as_array().into_iter().flatten() {
                let id = inst["id"].as_u64().unwrap_or(0);
                let Some(b) = inst["bbox_sensor"].as_array() else {
                    continue; // not seen on the raw grid
                };
                let b: Vec<u64> = b.iter().filter_map(|v| v.as_u64()).collect();
                if id == 0 || b.len() != 4 || id > u16::MAX as u64 {
                    continue;
                }
                let area = map.iter().filter(|&&v| v as u64 == id).count() as u64;
                if area == 0 {
                    continue;
                }
                let rle = rle_string(rows, cols, |k| map[k] as u64 == id);
                let cat = match by {
                    CategoryBy::Material => inst["material"].as_str(),
                    CategoryBy::Object => inst["name"].as_str(),
                    CategoryBy::Category => inst["category"].as_str().or(inst["name"].as_str()),
                }
                .unwrap_or("")
                .to_string();
                categories.insert(cat.clone());
                let mut extra = serde_json::json!({
                    "camsim_instance": id,
                    "category": cat,
                    "visible_fraction": inst["visible_fraction"],
                    "truncation": inst["truncation"],
                    "box_3d": inst["box_3d"],
                });
                extra["name"] = inst["name"].clone();
                if let Some(kp) = inst["keypoints_sensor"].as_array() {
                    // COCO's flat [x, y, v, ...] in pixel edges, x = y = 0 where v = 0.
                    let mut flat = Vec::with_capacity(3 * kp.len());
                    for t in kp {
                        let v = t[2].as_u64().unwrap_or(0);
                        let (x, y) = if v == 0 {
                            (0.0, 0.0)
                        } else {
                            (t[0].as_f64().unwrap_or(0.0), t[1].as_f64().unwrap_or(0.0))
                        };
                        flat.extend([serde_json::json!(x), serde_json::json!(y), v.into()]);
                    }
                    extra["keypoints"] = flat.into();
                    let own = &inst["keypoints_3d"];
                    let set = if own.is_object() {
                        own
                    } else {
                        &boxes["keypoints"]
                    };
                    let (names, skeleton) = (set["names"].clone(), set["skeleton"].clone());
                    let here = format!("{key} instance {id}");
                    match keypoint_names.get(&cat) {
                        None => {
                            keypoint_names.insert(cat.clone(), (names, skeleton, here));
                        }
                        Some((n, sk, first)) if *n != names || *sk != skeleton => {
                            return Err(DatasetError::file(
                                &tar_path,
                                format!(
                                    "{here}: its keypoints {names} differ from those of {first} ({n}), of the same category {cat:?}; COCO gives a category one keypoint list (give the assets of one category the same manifest keypoints, or export by category)"
                                ),
                            ));
                        }
                        Some(_) => {}
                    }
                }
                if let Some(all) = inst.get("mask_all_sensor") {
                    // The amodal output: the full silhouette, occluders ignored.
                    let size_ok = all["size"].as_array().is_some_and(|s| {
                        s.len() == 2
                            && s[0].as_u64() == Some(rows as u64)
                            && s[1].as_u64() == Some(cols as u64)
                    });
                    let counts: Option<Vec<i64>> = all["counts"]
                        .as_array()
                        .and_then(|c| c.iter().map(|v| v.as_i64()).collect());
                    let (true, Some(counts)) = (size_ok, counts) else {
                        return Err(DatasetError::file(
                            &tar_path,
                            format!(
                                "{key}.boxes.json instance {id}: mask_all_sensor is not a {cols} x {rows} COCO RLE"
                            ),
                        ));
                    };
                    extra["amodal_segmentation"] = serde_json::json!({
                        "size": [rows, cols],
                        "counts": rle_counts_string(&counts),
                    });
                    extra["amodal_area"] = inst["pixels_sensor_all"].clone();
                    extra["amodal_bbox"] = match inst["bbox_sensor_all"].as_array() {
                        Some(a) if a.len() == 4 => {
                            let v: Vec<u64> = a.iter().filter_map(|x| x.as_u64()).collect();
                            if v.len() == 4 {
                                serde_json::json!([v[0], v[1], v[2] - v[0], v[3] - v[1]])
                            } else {
                                serde_json::Value::Null
                            }
                        }
                        _ => serde_json::Value::Null,
                    };
                }
                pending.push((image_id, extra, rle, area, [b[0], b[1], b[2], b[3]]));
            }
        }
    }
    let categories: Vec<String> = categories.into_iter().collect();
    let annotations: Vec<serde_json::Value> = pending
        .into_iter()
        .enumerate()
        .map(|(k, (image_id, extra, rle, area, b))| {
            let cat = extra["category"].as_str().unwrap_or("");
            let category_id = categories.iter().position(|c| c == cat).unwrap_or(0) + 1;
            let (h, w) = sizes.get(&image_id).copied().unwrap_or_default();
            let mut extra = extra;
            let keypoints = extra.as_object_mut().and_then(|o| o.remove("keypoints"));
            let amodal: Vec<(&str, serde_json::Value)> =
                ["amodal_segmentation", "amodal_area", "amodal_bbox"]
                    .into_iter()
                    .filter_map(|k| Some((k, extra.as_object_mut()?.remove(k)?)))
                    .collect();
            let mut a = serde_json::json!({
                "id": k + 1,
                "image_id": image_id,
                "category_id": category_id,
                "segmentation": { "size": [h, w], "counts": rle },
                "area": area,
                "bbox": [b[0], b[1], b[2] - b[0], b[3] - b[1]],
                "iscrowd": 0,
                "camsim": extra,
            });
            if let Some(kp) = keypoints {
                let n = kp.as_array().map_or(0, |v| {
                    v.chunks(3).filter(|t| t[2].as_u64() != Some(0)).count()
                });
                a["keypoints"] = kp;
                a["num_keypoints"] = n.into();
            }
            for (k, v) in amodal {
                a[k] = v;
            }
            a
        })
        .collect();
    Ok(serde_json::json!({
        "info": {
            "description": format!("camsim dataset {}", spec.source),
            "version": env!("CARGO_PKG_VERSION"),
            "note": "Images are the sensor previews; masks, boxes and areas are on the raw image's pixel grid (camsim's sensor-geometry labels): pixel (r, c) covers [c, c+1) x [r, r+1).",
        },
        "images": images,
        "annotations": annotations,
        "categories": categories
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let mut cat = serde_json::json!({ "id": i + 1, "name": c, "supercategory": "" });
                if let Some((names, skeleton, _)) = keypoint_names.get(c) {
                    // COCO's skeleton is 1-based.
                    let skeleton: Vec<[u64; 2]> = skeleton
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|e| Some([e[0].as_u64()? + 1, e[1].as_u64()? + 1]))
                        .collect();
                    cat["keypoints"] = names.clone();
                    cat["skeleton"] = serde_json::json!(skeleton);
                }
                cat
            })
            .collect::<Vec<_>>(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs in column-major order starting with zeros; counts after the second as differences
    /// to the count two before; 5 bits per character plus 48 (a continuation bit for more).
    #[test]
    fn rle_strings_follow_cocos_encoding() {
        // [[0, 0], [1, 1]]: columns (0, 1), (0, 1): runs 1, 1, 1, 1 -> 1, 1, 1, 1 - 1 = 0.
        let m = [0u8, 0, 1, 1];
        assert_eq!(rle_string(2, 2, |k| m[k] == 1), "1110");
        // All ones, 2 x 3: a zero-length first run, then 6 -> "06".
        assert_eq!(rle_string(2, 3, |_| true), "06");
        // One long run of 100 zeros: 100 = 3 * 32 + 4 -> '4' + 32 (continue), then 3 -> "T3".
        assert_eq!(rle_string(10, 10, |_| false), "T3");
    }
}
