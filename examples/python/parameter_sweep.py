"""A parameter sweep as a small dataset: f-number x exposure, one raw frame each.

For every (f-number, exposure) pair the built-in ColorChecker scene is imaged with the Pixel 4a
lens at that f-number; the raw frames are stacked into one array of shape
(f-numbers, exposures, rows, cols) uint16 with the parameters and each frame's noise-free mean
alongside, and saved as sweep.npz (numpy). The mean signal grows as exposure / N^2, which the script checks and prints.

    pip install ./crates/camsim-python
    python examples/python/parameter_sweep.py [OUT.npz]
"""

import sys

import camsim
import numpy as np

small = "--small" in sys.argv
out = next((a for a in sys.argv[1:] if a.endswith(".npz")), "sweep.npz")

f_numbers = [1.73, 2.8, 4.0]
exposures_ms = [2.0, 4.0, 8.0]
cfg = camsim.presets.simulate()
if small:
    cfg["sensor"]["rows"], cfg["sensor"]["cols"] = 120, 160
lens = camsim.presets.lens("pixel4a")

frames, means = [], np.zeros((len(f_numbers), len(exposures_ms)))
for i, n in enumerate(f_numbers):
    row = []
    for j, t in enumerate(exposures_ms):
        c = dict(cfg)
        c["optics"] = {"config": dict(lens, f_number=n)}
        c["capture"] = dict(cfg["capture"], exposure_ms=t)
        c["seed"] = 100 * i + j  # a seed per sample: reproducible, independent noise
        sim = camsim.simulate(c, noise_free=True)
        row.append(sim.raw[0])
        # The noise-free mean: the raw mean of dark pixels is biased by the ADC clipping their
        # read noise at 0 (the pixel4a preset has no black-level offset).
        means[i, j] = sim.noise_free.mean() - sim.black_level
    frames.append(row)
data = np.array(frames)
np.savez_compressed(out, raw=data, f_numbers=np.array(f_numbers), exposures_ms=np.array(exposures_ms), mean_dn_noise_free=means)
print(f"dataset {data.shape} {data.dtype} -> {out}")
# Photometry: signal ~ t / (1 + 4 N^2) (camera equation), as long as nothing clips.
expected = np.array([[t / (1 + 4 * n * n) for t in exposures_ms] for n in f_numbers])
ratio = means / expected
print("mean DN / (t / (1 + 4 N^2)), relative to the first:")
print(np.round(ratio / ratio[0, 0], 3))
