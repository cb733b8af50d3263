"""Synthetic camera datasets: many captures from one spec, on this machine or a Ray cluster.

A spec is a base ``simulate`` config plus variations over any of its keys (grids and seeded
random draws); sample ``i`` is a function of (spec, i) alone, so the same spec gives the same
bytes on any machine, any number of workers and any order. See README "Datasets" and
``examples/datasets/colorchecker.toml``.

    import camsim.dataset
    summary = camsim.dataset.run("examples/datasets/colorchecker.toml", out="out/ds")
    summary = camsim.dataset.run(spec, out="out/ds", backend="ray")   # one Ray task per shard
    records = camsim.dataset.read_manifest("out/ds")                # one dict per sample

The output folder holds WebDataset tar shards (``KEY.json``, ``KEY.dng``, ``KEY.raw.npy``,
``KEY.preview.png``, ...), a JSON record per shard, and ``manifest.jsonl`` once every shard is
complete (``pandas.read_json(path, lines=True)`` reads it).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Tuple, Union

from . import _camsim
from ._checks import check_values

Spec = Union[Dict[str, Any], str, "os.PathLike[str]"]

__all__ = ["plan", "run", "run_shard", "read_manifest", "to_coco", "to_bop", "TorchDataset"]

from .torch_data import TorchDataset  # noqa: E402  (re-exported: camsim.dataset.TorchDataset)


def _spec_args(spec: Spec) -> Tuple[Union[str, Dict[str, Any]], str, str]:
    """(the spec as a dict or TOML text, its name in messages, the folder relative paths are
    resolved against)."""
    if isinstance(spec, dict):
        check_values(spec, "spec dict", _camsim.CamsimError)
        return spec, "spec dict", os.getcwd()
    s = os.fspath(spec)
    if "\n" in s or s.lstrip().startswith("["):
        return s, "spec text", os.getcwd()
    if not os.path.isfile(s):
        raise _camsim.CamsimError(f"{s}: no such spec file")
    with open(s, encoding="utf-8") as f:
        text = f.read()
    return text, s, os.path.dirname(os.path.abspath(s))


def plan(spec: Spec) -> Dict[str, Any]:
    """Check the spec completely (every key, range and file; nothing is simulated) and return its
    plan: samples, shards, shard_size, fingerprint, outputs and the first samples' parameters."""
    return _camsim.dataset_plan(*_spec_args(spec))


def run_shard(spec: Spec, out: Union[str, os.PathLike[str]], shard: int, *, workers: Optional[int] = 1,
              verify: bool = True) -> Dict[str, Any]:
    """Simulate one shard into ``out`` (skipped when already complete): the unit of work of a
    cluster task. Returns the shard's record (sha256, size, every sample's status and files)."""
    text, source, base = _spec_args(spec)
    n = plan(spec)["shards"]
    _camsim.dataset_run(text, source, base, os.fspath(out), int(shard), int(n), workers, verify)
    path = os.path.join(os.fspath(out), f"shard-{shard_stem(spec, shard)}.json")
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def shard_stem(spec: Spec, shard: int) -> str:
    """``FIRST-LAST`` (8 digits each) of shard ``shard``."""
    p = plan(spec)
    first = shard * p["shard_size"]
    last = min(first + p["shard_size"], p["samples"]) - 1
    return f"{first:08d}-{last:08d}"


def _ray_shard(spec: Union[str, Dict[str, Any]], source: str, base: str, out: str, shard: int, shards: int, workers: int,
               verify: bool) -> Dict[str, Any]:
    # Runs in a Ray worker process: part `shard` of `shards` is exactly shard `shard`.
    from camsim import _camsim as native

    return native.dataset_run(spec, source, base, out, shard, shards, workers, verify)


def run(spec: Spec, out: Union[str, os.PathLike[str]], *, backend: str = "local", shard: Optional[Tuple[int, int]] = None,
        workers: Optional[int] = None, verify: bool = True, max_retries: int = 3, cpus_per_task: int = 1,
        ray_address: Optional[str] = None) -> Dict[str, Any]:
    """Simulate the dataset (or part ``shard = (i, n)`` of it) into folder ``out``.

    backend="local": all cores of this machine (``workers`` samples at once; default one per
    core), as ``camsim dataset`` does. backend="ray": one Ray task per incomplete shard on the
    connected cluster (``ray.init(address=ray_address)`` unless Ray is already initialised), each
    with ``cpus_per_task`` CPUs and ``max_retries`` retries; camsim must be installed on the
    workers (e.g. a ``runtime_env`` with ``pip``) and ``out`` on a file system they share.

    Complete shards are kept (SHA-256 checked unless verify=False); a killed run loses only the
    shards in flight. Returns the summary (shards written and skipped, samples run and failed,
    seconds, complete) with ``manifest`` set to manifest.jsonl's path once every shard is done.
    """
    text, source, base = _spec_args(spec)
    out_s = os.path.abspath(os.fspath(out))
    i, n = shard if shard is not None else (0, 1)
    if backend == "local":
        summary = _camsim.dataset_run(text, source, base, out_s, int(i), int(n), workers, verify)
    elif backend == "ray":
        import time

        import ray

        p = plan(spec)  # the whole spec is checked before any task starts
        if not ray.is_initialized():
            ray.init(address=ray_address)
        task = ray.remote(num_cpus=cpus_per_task, max_retries=max_retries, retry_exceptions=True)(_ray_shard)
        t0 = time.perf_counter()
        shards = [s for s in range(p["shards"]) if s % n == i]
        futures = [task.remote(text, source, base, out_s, s, p["shards"], workers or cpus_per_task, verify) for s in shards]
        parts = ray.get(futures)
        summary = {
            "shards_total": p["shards"],
            "shards_written": sum(r["shards_written"] for r in parts),
            "shards_skipped": sum(r["shards_skipped"] for r in parts),
            "samples_run": sum(r["samples_run"] for r in parts),
            "samples_failed": sum(r["samples_failed"] for r in parts),
            "seconds": time.perf_counter() - t0,
            "complete": False,
        }
    else:
        raise _camsim.CamsimError(f"backend {backend!r}: use 'local' or 'ray'")
    manifest = _camsim.dataset_gather(text, source, base, out_s)
    summary["complete"] = manifest is not None
    summary["manifest"] = None if manifest is None else os.fspath(manifest)
    return summary


def read_manifest(out: Union[str, os.PathLike[str]]) -> List[Dict[str, Any]]:
    """The manifest of a complete dataset: one dict per sample (index, key, status, error, seed,
    params, files, shard, exposure_s, times_s), in index order."""
    path = os.path.join(os.fspath(out), "manifest.jsonl")
    if not os.path.isfile(path):
        raise _camsim.CamsimError(f"{path}: no manifest (the dataset is not complete: run it again to finish)")
    with open(path, encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


def to_coco(spec: Spec, out: Union[str, os.PathLike[str]], *, categories: str = "material") -> str:
    """Export the complete dataset in ``out`` as COCO (as ``camsim dataset --coco``):
    ``out/coco/annotations.json`` (instance masks as compressed RLE, boxes, areas, on the raw
    image's grid; categories from the instances' "material", "object" or "category" names) and
    ``out/coco/images/KEY.png`` (the previews). Needs the outputs preview, instances and boxes.
    Returns the annotation file's path (``pycocotools.coco.COCO(path)`` reads it)."""
    text, source, base = _spec_args(spec)
    return os.fspath(_camsim.dataset_coco(text, source, base, os.path.abspath(os.fspath(out)), categories))


def to_bop(spec: Spec, out: Union[str, os.PathLike[str]]) -> str:
    """Export the complete composed dataset in ``out`` in the BOP format (as ``camsim dataset
    --bop``): ``out/bop/models/obj_NNNNNN.ply`` (each asset of the library in mm) with
    ``models_info.json``, ``out/bop/camera.json``, and per shard ``out/bop/train_pbr/NNNNNN/``
    with ``scene_camera.json`` (``cam_K``, ``cam_R_w2c``, ``cam_t_w2c``, ``depth_scale``),
    ``scene_gt.json`` (``obj_id``, ``cam_R_m2c``, ``cam_t_m2c`` in mm, on the raw image's grid),
    ``scene_gt_info.json``, ``rgb/``, ``mask_visib/`` and, with the depth output, ``depth/``.
    Needs ``[render.compose]`` and the outputs preview, instances and boxes. Returns the folder."""
    text, source, base = _spec_args(spec)
    return os.fspath(_camsim.dataset_bop(text, source, base, os.path.abspath(os.fspath(out))))
