"""Two sensors, one scene: SNR and colour error of each ColorChecker patch, plotted.

The same Macbeth chart under D65 is imaged by the Pixel 4a lens onto (a) the pixel4a sensor
(IMX363, 1.4 um pixels) and (b) a copy of it with pixels twice as large (2.8 um: four times the
area, so four times the light per pixel at the same exposure, and a well four times as deep).
For each patch (its central half, from the chart's corners on the sensor): SNR = mean / standard
deviation of the green pixels above black, and the colour error = the angle between the patch's
mean camera RGB and that of the noise-free image (how far noise and fixed-pattern noise move the
colour). Writes sensor_comparison.png.

    pip install ./crates/camsim-python matplotlib
    python examples/python/sensor_comparison.py [OUT.png]
"""

import sys

import camsim
import numpy as np

out = next((a for a in sys.argv[1:] if a.endswith(".png")), "sensor_comparison.png")

cfg = camsim.presets.simulate()
cfg["capture"]["exposure_ms"] = 2.0  # dim: where pixel size matters

big = camsim.presets.sensor("pixel4a")
big["name"] = "pixel4a, 2.8 um"
big["pixel_pitch_um"] *= 2
big["voltage_swing_v"] *= 4  # a well four times as deep at the same conversion gain
big.pop("well_capacity_e", None)
big["rows"] //= 2
big["cols"] //= 2

results = {}
for label, sensor in [("1.4 um (pixel4a)", None), ("2.8 um", big)]:
    c = dict(cfg)
    if sensor is not None:
        # Same field of view: half as many pixels of twice the pitch.
        c["sensor"] = {"config": sensor, "rows": cfg["sensor"]["rows"] // 2, "cols": cfg["sensor"]["cols"] // 2}
    sim = camsim.simulate(c, noise_free=True)
    # Patch statistics inside the chart (its corners are known from the scene geometry).
    noisy = camsim.chart(sim.raw[0], sim.chart_corners, sim.cfa, bits=sim.bits, black_level=sim.black_level)
    free_raw = np.clip(np.rint(sim.noise_free), 0, 65535).astype(np.uint16)
    free = camsim.chart(free_raw, sim.chart_corners, sim.cfa, bits=sim.bits, black_level=sim.black_level)
    snr = np.array([p["mean"][1] / max(p["std"][1], 1e-9) for p in noisy])
    err = []
    for p, q in zip(noisy, free):
        m, mf = np.array(p["mean"]), np.array(q["mean"])
        cosang = np.dot(m, mf) / max(np.linalg.norm(m) * np.linalg.norm(mf), 1e-12)
        err.append(np.degrees(np.arccos(np.clip(cosang, -1, 1))))
    patches = [p["patch"] for p in noisy]  # 1-24, as on the chart
    results[label] = (patches, snr, np.array(err))
    print(f"{label}: median SNR {np.median(snr):.1f}, median colour error {np.median(err):.3f} deg")

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot (pip install matplotlib)")
    sys.exit(0)

fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for label, (patches, snr, err) in results.items():
    ax[0].plot(patches, snr, "o-", label=label)
    ax[1].plot(patches, err, "o-", label=label)
ax[0].set(xlabel="ColorChecker patch", ylabel="SNR, green (mean / std)", yscale="log", title="SNR per patch")
ax[1].set(xlabel="ColorChecker patch", ylabel="colour error, degrees", title="RGB angle to the noise-free mean")
for a in ax:
    a.grid(alpha=0.3)
    a.legend()
fig.tight_layout()
fig.savefig(out, dpi=100)
print(f"wrote {out}")
