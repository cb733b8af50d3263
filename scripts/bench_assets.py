#!/usr/bin/env python3
"""Asset load time and peak memory, camsim against trimesh (BENCHMARKS.md).

Writes a 1M-triangle GLB (a 708 x 708 grid of quads with normals and uvs) and 100 small GLBs
(a 2,000-triangle grid each) into a temporary folder, then loads them with camsim's reader
(`cargo run --release -p camsim-assets --example load_assets`) and with trimesh
(`trimesh.load(..., process=False)`), each in its own process, and prints a Markdown table of
wall seconds and peak resident memory (VmHWM / ru_maxrss).

Needs numpy and trimesh (`pip install numpy trimesh`); outside the default test command.
"""

import json
import os
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np


def write_grid_glb(path, n):
    """An n x n grid of quads (2 n^2 triangles) with normals and uvs as a GLB."""
    xs = np.linspace(0.0, 1.0, n + 1, dtype=np.float32)
    gx, gy = np.meshgrid(xs, xs)
    pos = np.stack([gx.ravel(), np.zeros(gx.size, np.float32), gy.ravel()], 1).astype(np.float32)
    nrm = np.tile(np.array([0, 1, 0], np.float32), (pos.shape[0], 1))
    uv = np.stack([gx.ravel(), gy.ravel()], 1).astype(np.float32)
    i = np.arange(n)
    a = (i[:, None] * (n + 1) + i[None, :]).ravel()
    quads = np.stack([a, a + n + 1, a + 1, a + 1, a + n + 1, a + n + 2], 1).astype(np.uint32)
    idx = quads.ravel()
    blobs = [pos.tobytes(), nrm.tobytes(), uv.tobytes(), idx.tobytes()]
    offs = np.cumsum([0] + [len(b) for b in blobs])
    bin_ = b"".join(blobs)
    doc = {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "grid"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}]}],
        "buffers": [{"byteLength": len(bin_)}],
        "bufferViews": [{"buffer": 0, "byteOffset": int(offs[k]), "byteLength": len(blobs[k])} for k in range(4)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
             "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": len(pos), "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
    }
    js = json.dumps(doc).encode()
    js += b" " * ((4 - len(js) % 4) % 4)
    bin_ += b"\0" * ((4 - len(bin_) % 4) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(bin_), b"BIN\0") + bin_)


TRIMESH = """
import resource, sys, time, json, trimesh
t0 = time.perf_counter(); faces = 0
for f in sys.argv[1:]:
    s = trimesh.load(f, process=False, force="scene")
    faces += sum(len(g.faces) for g in s.geometry.values())
dt = time.perf_counter() - t0
print(json.dumps({"triangles": faces, "seconds": dt,
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(["cargo", "build", "-q", "--release", "-p", "camsim-assets", "--example", "load_assets"],
                   cwd=root, check=True)
    exe = os.path.join(root, "target", "release", "examples", "load_assets")
    with tempfile.TemporaryDirectory() as d:
        big = os.path.join(d, "grid-1m.glb")
        write_grid_glb(big, 708)
        small = []
        for k in range(100):
            p = os.path.join(d, f"small-{k:03}.glb")
            write_grid_glb(p, 32)
            small.append(p)
        print("| load | camsim s | camsim peak MiB | trimesh s | trimesh peak MiB | triangles |")
        print("|---|---|---|---|---|---|")
        for name, files in [("1 GLB, 1.0 M triangles", [big]), ("100 GLBs, 2,048 triangles each", small)]:
            best = {}
            for tool, cmd in [("camsim", [exe] + files), ("trimesh", [sys.executable, "-c", TRIMESH] + files)]:
                runs = []
                for _ in range(3):
                    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
                    runs.append(json.loads(out.strip().splitlines()[-1]))
                best[tool] = min(runs, key=lambda r: r["seconds"])
            c, t = best["camsim"], best["trimesh"]
            print(f"| {name} | {c['seconds']:.3f} | {c['peak_rss_mib']:.0f} | {t['seconds']:.3f} | "
                  f"{t['peak_rss_mib']:.0f} | {c['triangles']} / {t['triangles']} |")


if __name__ == "__main__":
    main()
