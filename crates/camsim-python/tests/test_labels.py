"""Training-data labels from Python (issue 29): a 3D dataset's COCO export read by pycocotools
(mask areas = the instance maps' pixel counts, boxes = the masks' extents), the Torch loader's
order (every sample once per epoch, in index order, or a fixed permutation for a seed), and
Simulation.labels / Simulation.camera against the geometry of the camera."""

from __future__ import annotations

import camsim
import camsim.dataset
import numpy as np
import pytest
from camsim.dataset import TorchDataset

# The Cornell box seen through a 96 x 72 window of 1.4 um pixels (1.76 x 1.32 degrees behind
# the 4.38 mm lens): the camera steps back 24 m; the short block moves from sample to sample.
BASE = {
    "wavelengths": {"start_nm": 400.0, "step_nm": 30.0, "count": 11},
    "sensor": {"preset": "pixel4a", "rows": 72, "cols": 96},
    "capture": {"auto_target_fraction": 0.8},
    "render": {
        "builtin": "cornell-box",
        "samples_per_pixel": 2,
        "overlay_inline": {
            "camera": {"position_m": [0.278, 0.274, -23.5], "look_at_m": [0.278, 0.274, 0.28], "focus_distance_m": 24.0},
            "object": [{"name": "short_block", "translate_m": [0.0, 0.0, 0.0]}],
        },
    },
}

SPEC = {
    "dataset": {"samples": 5, "shard_size": 2, "seed": 5, "outputs": ["raw-npy", "preview", "instances", "boxes"]},
    "base": BASE,
    "vary": [{"key": "render.overlay_inline.object.0.translate_m.0", "uniform": [-0.06, 0.06]}],
}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("detection")
    summary = camsim.dataset.run(SPEC, out=out, workers=2)
    assert summary["complete"] and summary["samples_failed"] == 0
    return out


def test_coco_masks_match_the_instance_maps(dataset):
    coco_mod = pytest.importorskip("pycocotools.coco")
    mask_utils = pytest.importorskip("pycocotools.mask")
    path = camsim.dataset.to_coco(SPEC, dataset, categories="object")
    coco = coco_mod.COCO(path)
    assert len(coco.getImgIds()) == SPEC["dataset"]["samples"]
    names = {c["name"] for c in coco.loadCats(coco.getCatIds())}
    assert {"short_block", "tall_block", "back_wall"} <= names
    maps = {int(s["__key__"]): s["instances.png"] for s in TorchDataset(dataset, keys=["instances.png"])}
    n = 0
    for ann in coco.loadAnns(coco.getAnnIds()):
        inst = maps[ann["image_id"]]
        mask = coco.annToMask(ann)
        want = inst == ann["camsim"]["camsim_instance"]
        # pycocotools decodes camsim's RLE into exactly the instance's pixels ...
        assert mask.shape == inst.shape and np.array_equal(mask.astype(bool), want)
        # ... and its area and box are those of the map.
        assert ann["area"] == int(want.sum()) == int(mask_utils.area(ann["segmentation"]))
        rows, cols = np.nonzero(want)
        x, y = cols.min(), rows.min()
        assert ann["bbox"] == [x, y, cols.max() + 1 - x, rows.max() + 1 - y]
        n += 1
    assert n >= 5 * 5


def test_torch_loader_yields_every_sample_once_in_order(dataset):
    ds = TorchDataset(dataset, keys=["raw.npy", "preview.png"])
    keys = [s["__key__"] for s in ds]
    assert keys == [f"{i:08d}" for i in range(5)]
    first = next(iter(ds))
    assert first["raw.npy"].shape == (72, 96) and first["raw.npy"].dtype == np.uint16
    assert first["preview.png"].shape == (72, 96, 3)
    assert first["json"]["index"] == 0
    # A fixed seed: a permutation, the same on every pass of one epoch, another next epoch.
    shuffled = TorchDataset(dataset, keys=[], seed=9)
    a = [int(s["__key__"]) for s in shuffled]
    assert sorted(a) == list(range(5)) and a == [int(s["__key__"]) for s in shuffled]
    assert a == shuffled.order()
    shuffled.set_epoch(1)
    assert sorted(shuffled.order()) == list(range(5))


def test_torch_tensors_and_workers(dataset):
    torch = pytest.importorskip("torch")
    ds = TorchDataset(dataset, keys=["instances.png"], to_tensor=True)
    loader = torch.utils.data.DataLoader(ds, batch_size=None, num_workers=2)
    keys = sorted(s["__key__"] for s in loader)
    assert keys == [f"{i:08d}" for i in range(5)]
    assert all(isinstance(s["instances.png"], torch.Tensor) for s in ds)


def test_simulation_labels_and_camera():
    sim = camsim.simulate(BASE, labels=True)
    lab, cam = sim.labels, sim.camera
    assert lab["instances"].shape == sim.raw.shape[1:] and lab["instances"].max() > 0
    assert lab["normals"].shape == (72, 96, 3) and lab["albedo"].shape == (11, 72, 96)
    # K of the raw grid: the image distance over the pixel pitch (thin lens focused at 24 m),
    # the centre between the middle pixels.
    v = 1.0 / (1.0 / 4.38e-3 - 1.0 / 24.0)
    assert cam["K"][0, 0] == pytest.approx(v / 1.4e-6, rel=1e-6)
    assert cam["K"][0, 2] == 47.5 and cam["K"][1, 2] == 35.5
    # Every instance's raw-grid box is its map's extent.
    for b in lab["boxes"]:
        m = lab["instances"] == b["id"]
        if b["bbox_sensor"] is None:
            assert not m.any()
            continue
        rows, cols = np.nonzero(m)
        assert b["bbox_sensor"] == [cols.min(), rows.min(), cols.max() + 1, rows.max() + 1]
    # A 2D chart has no labels.
    assert camsim.simulate(camsim.presets.simulate(), labels=True).labels is None


def test_frame_labels_of_a_moving_scene_are_each_frames_snapshot():
    # The short block moves right at 2 m/s (about 2.6 raw pixels per 10 ms at 24 m): in a burst
    # of 3 frames 10 ms apart, frame k's labels are those of a one-frame run whose window starts
    # at 10 k ms (labels are the scene at the window's start), and they move from frame to frame.
    render = dict(BASE["render"], overlay_inline=dict(BASE["render"]["overlay_inline"], object=[{"name": "short_block", "velocity_m_s": [2.0, 0.0, 0.0]}]))
    moving = dict(BASE, render=render)
    capture = dict(BASE["capture"], exposure_ms=0.5)
    sim = camsim.simulate(dict(moving, capture=dict(capture, frames=3, frame_interval_ms=10.0)), labels=True)
    frames, cameras = sim.frame_labels, sim.frame_cameras
    assert len(frames) == len(cameras) == sim.raw.shape[0] == 3
    assert np.array_equal(frames[0]["instances"], sim.labels["instances"])
    for k in (1, 2):
        one = camsim.simulate(dict(moving, capture=dict(capture, start_ms=10.0 * k)), labels=True)
        assert np.array_equal(frames[k]["instances"], one.labels["instances"]), k
        assert np.array_equal(frames[k]["depth"], one.labels["depth"]), k
        assert [b["bbox_sensor"] for b in frames[k]["boxes"]] == [b["bbox_sensor"] for b in one.labels["boxes"]]
        assert not np.array_equal(frames[k]["instances"], frames[k - 1]["instances"]), k
        np.testing.assert_array_equal(cameras[k]["world_to_camera"], cameras[0]["world_to_camera"])
    # A static scene's frames share one set of labels.
    static = camsim.simulate(dict(BASE, capture=dict(capture, frames=2)), labels=True)
    shared = static.frame_labels
    assert len(shared) == 2 and shared[0] is shared[1]
