"""camsim.dataset: local and Ray backends give the CLI's bytes; the manifest and the plain
loader example read the result; bad specs fail before any file is written."""

from __future__ import annotations

import importlib.util
import os
import pathlib
import subprocess

import camsim
import camsim.dataset
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]

SPEC = {
    "dataset": {"samples": 6, "shard_size": 2, "seed": 3, "outputs": ["raw", "raw-npy", "preview"]},
    "base": {
        "wavelengths": {"start_nm": 400.0, "step_nm": 20.0, "count": 16},
        "scene": {"kind": "macbeth", "illuminant": "D65"},
        "sensor": {"preset": "pixel4a", "rows": 24, "cols": 32},
    },
    "vary": [
        {"key": "optics.config.f_number", "values": [2.0, 4.0]},
        {"key": "capture.exposure_ms", "uniform": [1.0, 5.0]},
    ],
}

SPEC_TOML = """
[dataset]
samples = 6
shard_size = 2
seed = 3
outputs = ["raw", "raw-npy", "preview"]

[base]
wavelengths = { start_nm = 400.0, step_nm = 20.0, count = 16 }
scene = { kind = "macbeth", illuminant = "D65" }
sensor = { preset = "pixel4a", rows = 24, cols = 32 }

[[vary]]
key = "optics.config.f_number"
values = [2.0, 4.0]

[[vary]]
key = "capture.exposure_ms"
uniform = [1.0, 5.0]
"""


def tars(folder):
    return {p.name: p.read_bytes() for p in sorted(pathlib.Path(folder).glob("shard-*.tar"))}


def test_local_run_matches_the_cli_byte_for_byte_and_the_loader_reads_it(tmp_path):
    summary = camsim.dataset.run(SPEC, out=tmp_path / "py", workers=2)
    assert summary["complete"] and summary["samples_run"] == 6 and summary["samples_failed"] == 0, summary
    recs = camsim.dataset.read_manifest(tmp_path / "py")
    assert [r["index"] for r in recs] == list(range(6))
    assert [r["params"]["optics.config.f_number"] for r in recs] == [2.0, 4.0] * 3
    # The same spec as a TOML file through the binary: the same shard bytes.
    spec_file = tmp_path / "spec.toml"
    spec_file.write_text(SPEC_TOML)
    cli = subprocess.run([os.environ["CAMSIM_BIN"], "dataset", str(spec_file), "--out", str(tmp_path / "cli"), "--workers", "1", "-q"],
                         capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    a, b = tars(tmp_path / "py"), tars(tmp_path / "cli")
    assert len(a) == 3 and a == b
    # The plain loader (no camsim import) gives the DNG's values.
    spec = importlib.util.spec_from_file_location("loader", ROOT / "examples" / "datasets" / "load_webdataset.py")
    loader = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loader)
    batches = list(loader.batches(str(tmp_path / "py"), 4))
    assert [b["raw"].shape for b in batches] == [(4, 24, 32), (2, 24, 32)]
    import tarfile

    with tarfile.open(tmp_path / "py" / "shard-00000000-00000001.tar") as t:
        dng = t.extractfile("00000001.dng").read()
    (tmp_path / "s1.dng").write_bytes(dng)
    np.testing.assert_array_equal(batches[0]["raw"][1], camsim.read_dng(tmp_path / "s1.dng")["raw"])
    assert batches[0]["exposure_s"][1] == pytest.approx(recs[1]["params"]["capture.exposure_ms"] * 1e-3)


def test_ray_backend_runs_one_task_per_shard_and_gives_the_same_bytes(tmp_path):
    import ray

    camsim.dataset.run(SPEC, out=tmp_path / "local")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        # Part 1 of 2 first (shard 1), then everything: the second call runs shards 0 and 2 only.
        part = camsim.dataset.run(SPEC, out=tmp_path / "ray", backend="ray", shard=(1, 2))
        assert part["shards_written"] == 1 and not part["complete"], part
        rest = camsim.dataset.run(SPEC, out=tmp_path / "ray", backend="ray")
        assert rest["shards_written"] == 2 and rest["shards_skipped"] == 1 and rest["complete"], rest
    finally:
        ray.shutdown()
    assert tars(tmp_path / "ray") == tars(tmp_path / "local")
    assert len(camsim.dataset.read_manifest(tmp_path / "ray")) == 6


def test_run_shard_writes_one_shard_with_the_local_runs_bytes(tmp_path):
    camsim.dataset.run(SPEC, out=tmp_path / "all")
    rec = camsim.dataset.run_shard(SPEC, tmp_path / "one", 1)
    assert rec["tar"] == "shard-00000002-00000003.tar" and [s["index"] for s in rec["samples"]] == [2, 3]
    assert tars(tmp_path / "one") == {rec["tar"]: (tmp_path / "all" / rec["tar"]).read_bytes()}
    assert camsim.dataset.shard_stem(SPEC, 2) == "00000004-00000005"


def test_bad_specs_fail_before_any_work(tmp_path):
    bad = {**SPEC, "vary": [{"key": "optics.config.f_numbr", "values": [2.0]}]}
    with pytest.raises(camsim.CamsimError, match="f_numbr"):
        camsim.dataset.run(bad, out=tmp_path / "bad")
    assert not (tmp_path / "bad").exists()
    with pytest.raises(camsim.CamsimError, match="min < max"):
        camsim.dataset.plan({**SPEC, "vary": [{"key": "capture.exposure_ms", "uniform": [5.0, 1.0]}]})
    with pytest.raises(camsim.CamsimError, match="backend"):
        camsim.dataset.run(SPEC, out=tmp_path / "x", backend="slurm")
    p = camsim.dataset.plan(SPEC)
    assert (p["samples"], p["shards"]) == (6, 3)
