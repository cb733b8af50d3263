"""6D-pose labels of composed scenes (issue 40): a tabletop dataset seen by a stereo rig, exported
in the BOP format and read back by a reader written from the BOP format document (the BOP toolkit's
docs/bop_datasets_format.md: poses x_cam = R x_model + t in mm, K with pixel centres at
integers, 16-bit depth times depth_scale in mm, PLY models in mm). Each object's model projected
through its pose and K covers its visible mask's box, the masks are the instance maps' pixels,
the depth lies on the posed model, and the COCO keypoints on the raw grid are the model's own
keypoints (the manifest's, for rabbits and capsules) or its box's centre and corners through the
same pose; between the rig's cameras every keypoint's disparity is f B / Z."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import camsim
import camsim.dataset
import numpy as np
import pytest
from camsim.dataset import TorchDataset

ROOT = Path(__file__).resolve().parents[3]

SPEC = {
    "dataset": {"samples": 2, "shard_size": 2, "seed": 11, "outputs": ["preview", "instances", "boxes", "amodal", "depth"]},
    "base": {
        "wavelengths": {"start_nm": 400.0, "step_nm": 30.0, "count": 11},
        "sensor": {"preset": "pixel4a", "rows": 96, "cols": 128},
        "capture": {"auto_target_fraction": 0.8},
        # 128 x 1.4 um behind 0.4 mm: 25 degrees across.
        "optics": {"config": {"f_number": 2.8, "focal_length_mm": 0.4, "shading": "none"}},
        "render": {
            "pbrt": str(ROOT / "examples/pbrt/tabletop.pbrt"),
            "samples_per_pixel": 2,
            "compose": {
                "assets": [str(ROOT / "examples/datasets/tabletop-assets.csv")],
                "spawn": [{
                    "name": "clutter", "count": [3, 5], "scale": [0.9, 1.1], "orientation": "upright",
                    "on": {"point_m": [0.0, 0.75, 0.0], "normal": [0.0, 1.0, 0.0], "extent_m": [0.4, 0.4]},
                    "min_separation_m": 0.01,
                }],
                "environment": {"choices": [{"kind": "sky", "sun_elevation_deg": [40, 60], "illuminance_lux": [20000, 20000]}]},
                "camera": {"distance_m": [0.8, 0.9], "elevation_deg": [35, 50], "azimuth_deg": [0, 360],
                           "min_visible_objects": 2, "min_visible_fraction": 0.5},
            },
        },
    },
    # A stereo pair: the right camera BASELINE_M to the right of the sampled (left) one.
    "rig": [{"name": "left"}, {"name": "right", "offset": {"translation_m": [0.06, 0.0, 0.0]}}],
}
BASELINE_MM = 60.0
CAMERAS = ["left", "right"]
MANIFEST = ROOT / "examples/datasets/tabletop-assets.csv"


def manifest_keypoints() -> dict[str, tuple[list[str], np.ndarray]]:
    """Per category with its own keypoints: their names and points in metres (the manifest's
    files, in file units, times scale_to_m; these assets are all +y up)."""
    out = {}
    with MANIFEST.open() as f:
        for row in csv.DictReader(f):
            if row["keypoints"]:
                assert row["up_axis"] == "y"
                k = json.loads((MANIFEST.parent / row["keypoints"]).read_text())
                out[row["category"]] = (k["names"], float(row["scale_to_m"]) * np.asarray(k["points"]))
    assert sorted(out) == ["capsule", "rabbit"]
    return out


def read_ply_vertices(path: Path) -> np.ndarray:
    """The vertices of a binary little-endian PLY with float x, y, z first (BOP's models)."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert "format binary_little_endian 1.0" in header
    n = next(int(h.split()[2]) for h in header if h.startswith("element vertex"))
    props = []
    for h in header[header.index(f"element vertex {n}") + 1:]:
        if not h.startswith("property"):
            break
        props.append(h.split()[-1])
    assert props[:3] == ["x", "y", "z"] and len(props) == 3
    return np.frombuffer(data[end:end + 12 * n], dtype="<f4").reshape(n, 3).astype(np.float64)


def rotation(values) -> np.ndarray:
    r = np.asarray(values, dtype=np.float64).reshape(3, 3)
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-9) and np.linalg.det(r) == pytest.approx(1.0, abs=1e-9)
    return r


def posed_keypoints(gt: dict, info: dict, category: str, own: dict) -> np.ndarray:
    """An object's keypoints in the camera frame, mm, in COCO's order: its manifest keypoints
    (metres in the asset's frame; BOP's models are that frame in mm, x mirrored when
    models_info says so), else its model box's (models_info.json) centre and 8 corners."""
    m = info[str(gt["obj_id"])]
    if category in own:
        sx = -1.0 if m["camsim_mirrored_x"] else 1.0
        pts = 1000.0 * own[category][1] * np.array([sx, 1.0, 1.0])
    else:
        lo = np.array([m["min_x"], m["min_y"], m["min_z"]])
        hi = lo + np.array([m["size_x"], m["size_y"], m["size_z"]])
        corners = np.array([[(hi if (i >> j) & 1 else lo)[j] for j in range(3)] for i in range(8)])
        pts = np.vstack([(lo + hi) / 2, corners])
    scaled = gt.get("camsim_scale", 1.0) * pts
    return (rotation(gt["cam_R_m2c"]) @ scaled.T).T + np.asarray(gt["cam_t_m2c"])


def project(k: np.ndarray, x_cam: np.ndarray) -> np.ndarray:
    """Pixel-edge coordinates (pixel (r, c) covers [c, c + 1)) of camera points, mm."""
    u = (k @ x_cam.T).T
    return u[:, :2] / u[:, 2:] + 0.5


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("tabletop-bop")
    summary = camsim.dataset.run(SPEC, out=out, workers=2)
    assert summary["complete"] and summary["samples_failed"] == 0
    bop = Path(camsim.dataset.to_bop(SPEC, out))
    coco = camsim.dataset.to_coco(SPEC, out, categories="category")
    return out, bop, coco


def test_bop_poses_masks_and_depth(exported):
    out, bop, _ = exported
    info = json.loads((bop / "models/models_info.json").read_text())
    models = {int(k): read_ply_vertices(bop / f"models/obj_{int(k):06d}.ply") for k in info}
    # One model per asset of the manifest; models_info's extents are the models'.
    assert len(models) == 5
    for k, v in models.items():
        lo, size = v.min(axis=0), v.max(axis=0) - v.min(axis=0)
        assert np.allclose(lo, [info[str(k)][f"min_{a}"] for a in "xyz"], atol=1e-3)
        assert np.allclose(size, [info[str(k)][f"size_{a}"] for a in "xyz"], atol=1e-3)
        assert np.linalg.norm(size) >= info[str(k)]["diameter"] >= size.max() - 1e-3
    scene = bop / "train_pbr/000000"
    cams = json.loads((scene / "scene_camera.json").read_text())
    gts = json.loads((scene / "scene_gt.json").read_text())
    infos = json.loads((scene / "scene_gt_info.json").read_text())
    # Image id = sample index x 2 + camera (left 0, right 1); each camera's own instance map.
    keys = [f"{c}.instances.png" for c in CAMERAS]
    maps = {2 * int(s["__key__"]) + c: s[k] for s in TorchDataset(out, keys=keys) for c, k in enumerate(keys)}
    assert sorted(map(int, gts)) == [0, 1, 2, 3]
    assert [cams[str(i)]["camsim_camera"] for i in range(4)] == CAMERAS * 2
    checked = 0
    for im, objs in gts.items():
        cam = cams[im]
        k = np.asarray(cam["cam_K"]).reshape(3, 3)
        rotation(cam["cam_R_w2c"])
        depth_mm = np.asarray(_png(scene / f"depth/{int(im):06d}.png"), dtype=np.float64) * cam["depth_scale"]
        assert (scene / f"rgb/{int(im):06d}.png").is_file()
        inst = maps[int(im)]
        h, w = inst.shape
        for g, (gt, gi) in enumerate(zip(objs, infos[im])):
            r, t = rotation(gt["cam_R_m2c"]), np.asarray(gt["cam_t_m2c"])
            x_cam = (r @ (gt.get("camsim_scale", 1.0) * models[gt["obj_id"]]).T).T + t
            mask = _png(scene / f"mask_visib/{int(im):06d}_{g:06d}.png") > 0
            assert int(mask.sum()) == gi["px_count_visib"]
            if gi["px_count_visib"] == 0:
                assert gi["bbox_visib"] == [-1, -1, -1, -1]
                continue
            # The mask is the object's pixels of the instance map (one id, all of them).
            ids = np.unique(inst[mask])
            assert len(ids) == 1 and np.array_equal(inst == ids[0], mask)
            # Depth on the mask lies on the posed model (its nearest to farthest point).
            d = depth_mm[mask]
            assert d.min() >= x_cam[:, 2].min() - 1.0 and d.max() <= x_cam[:, 2].max() + 1.0
            uv = project(k, x_cam)
            x0, y0, bw, bh = gi["bbox_visib"]
            inside = uv[:, 0].min() > 1 and uv[:, 1].min() > 1 and uv[:, 0].max() < w - 1 and uv[:, 1].max() < h - 1
            if gi["visib_fract"] >= 0.999 and inside:
                # The whole model in view, unoccluded: its projection's box is the mask's.
                want = [uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()]
                assert np.allclose([x0, y0, x0 + bw, y0 + bh], want, atol=1.0), (gt, gi, want)
                checked += 1
    assert checked >= 2


def test_coco_keypoints_are_the_posed_models_keypoints(exported):
    _, bop, coco_path = exported
    coco = json.loads(Path(coco_path).read_text())
    own = manifest_keypoints()
    cats = {c["id"]: c for c in coco["categories"]}
    for c in cats.values():
        if c["name"] in own:
            # The manifest's names, its 0-based skeleton made 1-based.
            k = json.loads((MANIFEST.parent / f"keypoints/{c['name']}.json").read_text())
            assert c["keypoints"] == k["names"]
            assert c["skeleton"] == [[i + 1, j + 1] for i, j in k["skeleton"]]
        else:
            assert c["keypoints"][0] == "center" and len(c["keypoints"]) == 9 and len(c["skeleton"]) == 12
    info = json.loads((bop / "models/models_info.json").read_text())
    scene = bop / "train_pbr/000000"
    cams = json.loads((scene / "scene_camera.json").read_text())
    gts = json.loads((scene / "scene_gt.json").read_text())
    anns = {(a["image_id"], a["camsim"]["name"]): a for a in coco["annotations"]}
    worst, n, n_own = 0.0, 0, 0
    for im, objs in gts.items():
        k = np.asarray(cams[im]["cam_K"]).reshape(3, 3)
        for gt in objs:
            a = anns.get((int(im), gt["camsim_name"]))
            if a is None:
                continue
            cat = cats[a["category_id"]]["name"]
            uv = project(k, posed_keypoints(gt, info, cat, own))
            kp = np.asarray(a["keypoints"], dtype=np.float64).reshape(-1, 3)
            assert len(kp) == len(cats[a["category_id"]]["keypoints"]) == len(uv)
            assert a["num_keypoints"] == int((kp[:, 2] > 0).sum())
            for j, (x, y, v) in enumerate(kp):
                if v > 0:
                    # A manifest keypoint is its own point; a box corner the nearest of the
                    # model box's (the two boxes' corners are numbered on different axes).
                    d = np.hypot(uv[:, 0] - x, uv[:, 1] - y)
                    worst = max(worst, float(d[j] if cat in own else d.min()))
                    n += 1
                    n_own += cat in own
    print(f"COCO keypoints against the posed models: worst {worst:.2e} px over {n} ({n_own} the manifest's)")
    assert n >= 8 and n_own >= 2 and worst <= 0.5, (n, n_own, worst)


def test_stereo_disparity_is_f_baseline_over_depth(exported):
    _, bop, coco_path = exported
    coco = json.loads(Path(coco_path).read_text())
    scene = bop / "train_pbr/000000"
    cams = json.loads((scene / "scene_camera.json").read_text())
    gts = json.loads((scene / "scene_gt.json").read_text())
    info = json.loads((bop / "models/models_info.json").read_text())
    own = manifest_keypoints()
    anns = {(a["image_id"], a["camsim"]["name"]): a for a in coco["annotations"]}
    worst, n = 0.0, 0
    for sample in (0, 1):
        left, right = 2 * sample, 2 * sample + 1
        fx = cams[str(left)]["cam_K"][0]
        # The right camera's extrinsics: the left's moved by the baseline along its x.
        t_l, t_r = np.asarray(cams[str(left)]["cam_t_w2c"]), np.asarray(cams[str(right)]["cam_t_w2c"])
        assert np.allclose(cams[str(left)]["cam_R_w2c"], cams[str(right)]["cam_R_w2c"], atol=1e-12)
        assert np.allclose(t_l - t_r, [BASELINE_MM, 0.0, 0.0], atol=1e-3)  # 1 um
        for gt in gts[str(left)]:
            name = gt["camsim_name"]
            a_l, a_r = anns.get((left, name)), anns.get((right, name))
            if a_l is None or a_r is None:
                continue
            cat = next(c["name"] for c in coco["categories"] if c["id"] == a_l["category_id"])
            x_cam = posed_keypoints(gt, info, cat, own)
            kl = np.asarray(a_l["keypoints"], dtype=np.float64).reshape(-1, 3)
            kr = np.asarray(a_r["keypoints"], dtype=np.float64).reshape(-1, 3)
            uv = project(np.asarray(cams[str(left)]["cam_K"]).reshape(3, 3), x_cam)
            for j, (pl, pr) in enumerate(zip(kl, kr)):
                if pl[2] > 0 and pr[2] > 0:
                    # The keypoint's depth in the left camera (both share the axis), mm: its own
                    # point, or the nearest box corner (numbered on other axes).
                    near = j if cat in own else np.argmin(np.hypot(uv[:, 0] - pl[0], uv[:, 1] - pl[1]))
                    z = x_cam[near, 2]
                    worst = max(worst, abs((pl[0] - pr[0]) - fx * BASELINE_MM / z))
                    assert abs(pl[1] - pr[1]) < 1e-6
                    n += 1
    print(f"stereo disparity against f B / Z: worst {worst:.2e} px over {n} keypoints")
    assert n >= 8 and worst <= 0.5, (n, worst)


def test_full_masks_are_the_posed_models_silhouettes(exported):
    """BOP's mask/ (the amodal output): each object's whole silhouette, occluders ignored. It
    holds its visible mask, its pixel counts and visib_fract are BOP's, it is the same mask as
    boxes.json's COCO RLE read by pycocotools, and for an object inside the frame its box is the
    box of its posed model's projection within 1 px, occluded or not. The COCO export's
    amodal_segmentation, amodal_area and amodal_bbox are the same silhouette."""
    mask_utils = pytest.importorskip("pycocotools.mask")
    out, bop, coco_path = exported
    coco = json.loads(Path(coco_path).read_text())
    anns = {(a["image_id"], a["camsim"]["name"]): a for a in coco["annotations"]}
    n_coco = 0
    info = json.loads((bop / "models/models_info.json").read_text())
    models = {int(k): read_ply_vertices(bop / f"models/obj_{int(k):06d}.ply") for k in info}
    scene = bop / "train_pbr/000000"
    cams = json.loads((scene / "scene_camera.json").read_text())
    gts = json.loads((scene / "scene_gt.json").read_text())
    infos = json.loads((scene / "scene_gt_info.json").read_text())
    keys = [f"{c}.boxes.json" for c in CAMERAS]
    boxes = {2 * int(s["__key__"]) + c: s[k] for s in TorchDataset(out, keys=keys) for c, k in enumerate(keys)}
    checked = occluded = 0
    for im, objs in gts.items():
        k = np.asarray(cams[im]["cam_K"]).reshape(3, 3)
        by_name = {i["name"]: i for i in boxes[int(im)]["instances"]}
        for g, (gt, gi) in enumerate(zip(objs, infos[im])):
            full = _png(scene / f"mask/{int(im):06d}_{g:06d}.png") > 0
            visib = _png(scene / f"mask_visib/{int(im):06d}_{g:06d}.png") > 0
            h, w = full.shape
            assert not (visib & ~full).any(), "a visible pixel outside the full silhouette"
            assert gi["px_count_all"] == int(full.sum()) == gi["px_count_valid"]
            assert gi["visib_fract"] == pytest.approx(gi["px_count_visib"] / max(gi["px_count_all"], 1))
            rle = by_name[gt["camsim_name"]]["mask_all_sensor"]
            decoded = mask_utils.decode(mask_utils.frPyObjects(rle, *rle["size"])) > 0
            assert np.array_equal(decoded, full)
            a = anns.get((int(im), gt["camsim_name"]))
            if a is not None:
                amodal = mask_utils.decode(a["amodal_segmentation"]) > 0
                assert np.array_equal(amodal, full)
                assert a["amodal_area"] == int(full.sum()) >= a["area"]
                ys, xs = np.nonzero(full)
                assert a["amodal_bbox"] == [xs.min(), ys.min(), xs.max() + 1 - xs.min(), ys.max() + 1 - ys.min()]
                n_coco += 1
            if gi["px_count_all"] == 0:
                assert gi["bbox_obj"] == [-1, -1, -1, -1]
                continue
            x_cam = (rotation(gt["cam_R_m2c"]) @ (gt.get("camsim_scale", 1.0) * models[gt["obj_id"]]).T).T
            uv = project(k, x_cam + np.asarray(gt["cam_t_m2c"]))
            if uv[:, 0].min() > 1 and uv[:, 1].min() > 1 and uv[:, 0].max() < w - 1 and uv[:, 1].max() < h - 1:
                x0, y0, bw, bh = gi["bbox_obj"]
                want = [uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()]
                assert np.allclose([x0, y0, x0 + bw, y0 + bh], want, atol=1.0), (gt, gi, want)
                checked += 1
                occluded += gi["visib_fract"] < 0.99
    print(f"full silhouettes against the posed models' projections: {checked} objects, {occluded} occluded")
    assert checked >= 4 and occluded >= 1 and n_coco >= 4, (checked, occluded, n_coco)


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path))


def test_bop_export_names_what_it_needs(tmp_path):
    spec = json.loads(json.dumps(SPEC))
    spec["dataset"]["outputs"] = ["preview", "boxes"]
    with pytest.raises(camsim.CamsimError, match='"instances"'):
        camsim.dataset.to_bop(spec, tmp_path)
    assert not (tmp_path / "bop").exists()


def test_coco_gives_each_category_one_keypoint_list_by_category_and_by_material(tmp_path):
    """The capsule twice in a manifest, as two categories with different keypoint lists (2 and 3
    points). COCO gives a category one keypoint list, so every annotation's keypoints must match
    its category's list: by category (pill_a, pill_b) and by material, where the two entries'
    objects do not share a category either (each manifest entry's materials are its own: the
    second capsule's copy of material0 is listed as its own material), so both exports hold."""
    (tmp_path / "tips.json").write_text(json.dumps(
        {"names": ["top", "bottom", "middle"], "points": [[0.0, 0.0, -1.5], [0.0, 0.0, 1.5], [0.0, 0.0, 0.0]]}))
    capsule = (ROOT / "../shared/assets/trimesh/capsule.obj").resolve()
    (tmp_path / "m.csv").write_text(
        "path,category,scale_to_m,up_axis,licence,keypoints\n"
        f"{capsule},pill_a,0.03,y,MIT (trimesh test models),{ROOT / 'examples/datasets/keypoints/capsule.json'}\n"
        f"{capsule},pill_b,0.03,y,MIT (trimesh test models),{tmp_path / 'tips.json'}\n")
    spec = json.loads(json.dumps(SPEC))
    del spec["rig"]
    spec["dataset"].update({"samples": 1, "shard_size": 1, "outputs": ["preview", "instances", "boxes"]})
    spec["base"]["sensor"].update({"rows": 48, "cols": 64})
    spec["base"]["render"]["samples_per_pixel"] = 1
    compose = spec["base"]["render"]["compose"]
    compose["assets"] = [str(tmp_path / "m.csv")]
    compose["spawn"][0].update({"count": [2, 2], "replacement": False})
    out = tmp_path / "ds"
    summary = camsim.dataset.run(spec, out=out, workers=1)
    assert summary["complete"] and summary["samples_failed"] == 0
    for by in ["category", "material"]:
        coco = json.loads(Path(camsim.dataset.to_coco(spec, out, categories=by)).read_text())
        cats = {c["id"]: c for c in coco["categories"]}
        lists = {}
        for a in coco["annotations"]:
            cat = cats[a["category_id"]]
            assert len(a["keypoints"]) == 3 * len(cat["keypoints"]), (by, a["camsim"]["name"], cat)
            lists[a["camsim"]["name"]] = cat["keypoints"]
        assert lists["pill_a_0"] == ["end_a", "end_b"], (by, lists)
        assert lists["pill_b_0"] == ["top", "bottom", "middle"], (by, lists)
        (out / "coco" / "annotations.json").unlink()
