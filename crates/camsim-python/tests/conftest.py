"""Helpers the Python tests share."""

import os
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[3]


def camsim_binary():
    """The CLI built by `cargo test`/`cargo build` (CAMSIM_BIN overrides)."""
    path = os.environ.get("CAMSIM_BIN")
    if path:
        return path
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "camsim"
        if p.is_file():
            return str(p)
    raise AssertionError("no camsim binary: run `cargo build` first or set CAMSIM_BIN")
