"""Iterate a camsim dataset as numpy batches, without camsim installed.

Plain Python (tarfile, json) and numpy: each shard is a WebDataset tar whose members are named
KEY.EXT (KEY = the sample index, 8 digits), and manifest.jsonl lists every sample. The
`webdataset` package reads the same shards (`wds.WebDataset("out/ds/shard-{...}.tar")`).

    python examples/datasets/load_webdataset.py out/dataset
"""

from __future__ import annotations

import io
import json
import os
import sys
import tarfile
from typing import Dict, Iterator, List

import numpy as np


def samples(folder: str) -> Iterator[Dict[str, object]]:
    """Yield one dict per sample in index order: "key", "meta" (its .json record) and "raw"
    (the uint16 mosaic from KEY.raw.npy), for the samples that succeeded."""
    with open(os.path.join(folder, "manifest.jsonl"), encoding="utf-8") as f:
        shards = sorted({json.loads(line)["shard"] for line in f if line.strip()})
    for shard in shards:
        current: Dict[str, object] = {}
        with tarfile.open(os.path.join(folder, shard)) as tar:
            for member in tar:
                key, ext = member.name.split(".", 1)
                if current and current["key"] != key:
                    yield current
                    current = {}
                current["key"] = key
                data = tar.extractfile(member).read()
                if ext == "json":
                    current["meta"] = json.loads(data)
                elif ext == "raw.npy":
                    current["raw"] = np.load(io.BytesIO(data))
        if current:
            yield current


def batches(folder: str, size: int) -> Iterator[Dict[str, object]]:
    """Stack samples into batches: "raw" (size, rows, cols) uint16, "exposure_s" and "params"
    (a list of dicts). Samples of another frame size start a new batch."""
    buf: List[Dict[str, object]] = []
    for s in samples(folder):
        if "raw" not in s:
            continue
        if buf and (len(buf) == size or buf[0]["raw"].shape != s["raw"].shape):
            yield _stack(buf)
            buf = []
        buf.append(s)
    if buf:
        yield _stack(buf)


def _stack(buf: List[Dict[str, object]]) -> Dict[str, object]:
    return {
        "keys": [s["key"] for s in buf],
        "raw": np.stack([s["raw"] for s in buf]),
        "exposure_s": np.array([s["meta"]["results"]["exposure_s"] for s in buf]),
        "params": [s["meta"]["params"] for s in buf],
    }


if __name__ == "__main__":
    folder = sys.argv[1] if len(sys.argv) > 1 else "out/dataset"
    for b in batches(folder, 8):
        raw = b["raw"]
        print(f"{b['keys'][0]}..{b['keys'][-1]}: raw {raw.shape} {raw.dtype}, mean DN {raw.mean():.1f}, "
              f"exposures {np.round(b['exposure_s'] * 1e3, 2)} ms")
