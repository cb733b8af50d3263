"""Dataset throughput (BENCHMARKS.md): samples/s with 1 and 2 local workers, and the Ray backend
against the local one on the same machine.

    python examples/datasets/benchmark.py examples/datasets/bench-colorchecker-640.toml

Each run writes a fresh folder under a temporary directory; times are wall-clock, best of
`--repeat` runs.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time

import camsim.dataset


def timed(spec: str, repeat: int, **kw) -> float:
    best = float("inf")
    for _ in range(repeat):
        d = tempfile.mkdtemp(prefix="camsim-bench-")
        try:
            t = time.perf_counter()
            s = camsim.dataset.run(spec, out=d, **kw)
            best = min(best, time.perf_counter() - t)
            assert s["complete"] and s["samples_failed"] == 0, s
        finally:
            shutil.rmtree(d, ignore_errors=True)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("spec")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-ray", action="store_true")
    a = ap.parse_args()
    n = camsim.dataset.plan(a.spec)["samples"]
    t1 = timed(a.spec, a.repeat, workers=1)
    t2 = timed(a.spec, a.repeat, workers=2)
    print(f"{a.spec}: {n} samples")
    print(f"  local, 1 worker : {t1:7.2f} s  {n / t1:6.2f} samples/s")
    print(f"  local, 2 workers: {t2:7.2f} s  {n / t2:6.2f} samples/s  scaling {t1 / t2:.2f}x")
    if not a.no_ray:
        import ray

        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        timed(a.spec, 1, backend="ray")  # warm the workers (process start, imports)
        tr = timed(a.spec, a.repeat, backend="ray")
        ray.shutdown()
        print(f"  ray, 2 CPUs     : {tr:7.2f} s  {n / tr:6.2f} samples/s  overhead vs local {100 * (tr / t2 - 1):+.1f} %")


if __name__ == "__main__":
    main()
