"""A PyTorch loader over camsim's WebDataset shards: ``camsim.dataset.TorchDataset``.

An ``IterableDataset`` (a plain iterable when torch is not installed) that reads the shards of a
complete dataset folder in index order and yields one dict per sample with webdataset's keys:
``"__key__"`` (the 8-digit index), ``"json"`` (the sample's record) and one entry per file asked
for, named by its extension as in the tar (``"raw.npy"``, ``"preview.png"``, ``"instances.png"``,
``"boxes.json"``, ``"normals.exr"``, ...), decoded to numpy arrays (PNG through Pillow, EXR as a
dict of channels through camsim) or dicts, and turned into torch tensors with ``to_tensor=True``.
A fixed ``seed`` shuffles the sample order per epoch (``set_epoch``), the same on every run; with
several DataLoader workers each reads its own shards.

    from torch.utils.data import DataLoader
    ds = camsim.dataset.TorchDataset("out/detection", keys=["preview.png", "instances.png", "boxes.json"])
    for batch in DataLoader(ds, batch_size=4, collate_fn=list): ...
"""

from __future__ import annotations

import io
import json
import os
import tarfile
import tempfile
from typing import Any, Dict, Iterator, List, Optional, Sequence

import numpy as np

try:  # torch is optional: without it the dataset is a plain iterable of numpy arrays.
    import torch
    from torch.utils.data import IterableDataset as _Base
except ImportError:  # pragma: no cover - exercised where torch is absent
    torch = None
    _Base = object

__all__ = ["TorchDataset", "decode"]


def decode(ext: str, data: bytes) -> Any:
    """A tar member's bytes decoded by its extension: .npy -> array, .png -> array ((rows, cols)
    or (rows, cols, 3); 16-bit kept), .json -> dict, .exr -> {channel: (rows, cols) float32},
    anything else -> bytes."""
    kind = ext.rsplit(".", 1)[-1]
    if kind == "npy":
        return np.load(io.BytesIO(data))
    if kind == "json":
        return json.loads(data)
    if kind == "png":
        from PIL import Image

        with Image.open(io.BytesIO(data)) as im:
            a = np.array(im)
        # Pillow reads 16-bit greyscale as int32 ("I;16" -> "I"): back to uint16.
        return a.astype(np.uint16) if a.dtype == np.int32 else a
    if kind == "exr":
        from . import _camsim

        with tempfile.NamedTemporaryFile(suffix=".exr", delete=False) as f:
            f.write(data)
            name = f.name
        try:
            return _camsim.read_exr_channels(name)
        finally:
            os.unlink(name)
    return data


class TorchDataset(_Base):  # type: ignore[misc, valid-type]
    """Samples of a complete camsim dataset folder ``out`` (see the module docs). ``keys``: the
    file extensions to load (default: every file of each sample); ``seed``: shuffle the order
    (None: index order); ``to_tensor``: numpy arrays become torch tensors (needs torch)."""

    def __init__(self, out: os.PathLike[str] | str, keys: Optional[Sequence[str]] = None, *,
                 seed: Optional[int] = None, to_tensor: bool = False) -> None:
        super().__init__()
        self.out = os.fspath(out)
        manifest = os.path.join(self.out, "manifest.jsonl")
        if not os.path.isfile(manifest):
            raise FileNotFoundError(f"{manifest}: no manifest (the dataset is not complete)")
        with open(manifest, encoding="utf-8") as f:
            self.records: List[Dict[str, Any]] = [json.loads(line) for line in f if line.strip()]
        self.records = [r for r in self.records if r["status"] == "ok"]
        self.keys = None if keys is None else list(keys)
        self.seed = seed
        self.epoch = 0
        if to_tensor and torch is None:
            raise ImportError("to_tensor=True needs torch")
        self.to_tensor = to_tensor

    def __len__(self) -> int:
        return len(self.records)

    def set_epoch(self, epoch: int) -> None:
        """Use epoch ``epoch``'s order (with a seed: another permutation per epoch)."""
        self.epoch = int(epoch)

    def order(self) -> List[int]:
        """The sample indices of this epoch, in the order they are yielded (all workers)."""
        idx = [r["index"] for r in self.records]
        if self.seed is not None:
            rng = np.random.default_rng([int(self.seed), self.epoch])
            idx = [idx[i] for i in rng.permutation(len(idx))]
        return idx

    def _worker_share(self, idx: List[int]) -> List[int]:
        info = None if torch is None else torch.utils.data.get_worker_info()
        if info is None:
            return idx
        return idx[info.id::info.num_workers]

    def __iter__(self) -> Iterator[Dict[str, Any]]:
        wanted = self._worker_share(self.order())
        by_index = {r["index"]: r for r in self.records}
        # Read each shard once, keeping the members of the samples this worker yields.
        cache: Dict[str, Dict[int, Dict[str, Any]]] = {}
        for i in wanted:
            rec = by_index[i]
            shard = rec["shard"]
            if shard not in cache:
                cache.clear()  # one shard in memory at a time (in index order, shards change once)
                cache[shard] = self._read_shard(shard)
            sample = cache[shard].get(i)
            if sample is not None:
                yield sample

    def _read_shard(self, shard: str) -> Dict[int, Dict[str, Any]]:
        samples: Dict[int, Dict[str, Any]] = {}
        with tarfile.open(os.path.join(self.out, shard)) as tar:
            for member in tar:
                key, ext = member.name.split(".", 1)
                if ext != "json" and self.keys is not None and ext not in self.keys:
                    continue
                data = tar.extractfile(member).read()
                s = samples.setdefault(int(key), {"__key__": key})
                v = decode(ext, data)
                if self.to_tensor and isinstance(v, np.ndarray):
                    v = torch.from_numpy(v.astype(np.int32) if v.dtype == np.uint16 else v)
                s[ext] = v
        return samples
