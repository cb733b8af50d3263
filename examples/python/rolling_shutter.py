"""Global against rolling shutter: a spinning fan, its optical flow, and the skew a rolling
readout gives it.

The fan of examples/pbrt/fan.pbrt turns 10 times a second (examples/fan-rolling-shutter.toml).
The same 1 ms exposure is taken with a global shutter (every row at once: straight blades) and
with a rolling shutter reading rows 100 us apart (the rows take 24 ms, while the fan turns 86
degrees: bent blades). Prints each frame's window (Simulation.frame_times_s), the mean optical
flow speed on the fan (Simulation.flow, sensor pixels) and how much the two pictures differ;
writes rolling_shutter.png (previews side by side and the global frame's flow magnitude).

    pip install ./crates/camsim-python matplotlib
    python examples/python/rolling_shutter.py [--small] [OUT.png]
"""

import sys
from pathlib import Path

import camsim
import numpy as np

out = next((a for a in sys.argv[1:] if a.endswith(".png")), "rolling_shutter.png")
small = "--small" in sys.argv

cfg = camsim.load_config(Path(__file__).resolve().parent.parent / "fan-rolling-shutter.toml")
if small:  # a quick run (the tests): a quarter of the pixels, fewer samples
    cfg["sensor"]["rows"], cfg["sensor"]["cols"] = 120, 160
    cfg["render"]["samples_per_pixel"] = 4
    cfg["capture"]["shutter"] = {"rolling": {"line_time_us": 200.0, "direction": "bottom-up"}}

sims = {}
for label, shutter in [("global", "global"), ("rolling", cfg["capture"]["shutter"])]:
    c = dict(cfg, capture=dict(cfg["capture"], shutter=shutter))
    sim = camsim.simulate(c, flow=True)
    sims[label] = sim
    start_s, duration_s = sim.frame_times_s[0]
    speed = np.hypot(sim.flow[0, ..., 0], sim.flow[0, ..., 1])
    moving = speed > 0
    print(f"{label}: window {start_s * 1e3:.3f} ms + {duration_s * 1e3:.3f} ms, "
          f"flow on the fan {speed[moving].mean():.3f} px over the exposure ({moving.mean() * 100:.1f} % of pixels move)")

a = sims["global"].preview.astype(np.float64)
b = sims["rolling"].preview.astype(np.float64)
print(f"mean |global - rolling| preview difference {np.abs(a - b).mean():.2f} (8-bit levels)")

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot (pip install matplotlib)")
    sys.exit(0)

fig, ax = plt.subplots(1, 3, figsize=(13, 3.6))
ax[0].imshow(sims["global"].preview)
ax[0].set_title("global shutter")
ax[1].imshow(sims["rolling"].preview)
ax[1].set_title("rolling shutter")
f = sims["global"].flow[0]
im = ax[2].imshow(np.hypot(f[..., 0], f[..., 1]), cmap="magma")
ax[2].set_title("optical flow over the exposure, sensor px")
fig.colorbar(im, ax=ax[2])
for x in ax:
    x.axis("off")
fig.tight_layout()
fig.savefig(out, dpi=100)
print(f"wrote {out}")
