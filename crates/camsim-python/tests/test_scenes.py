"""Scenes users make from their own data (a photograph on a display model, ISETCam
sceneFromFile; the dead-leaves target; a ColorChecker from another reflectance set) and a
non-Bayer sensor driven from Python."""

import json
import pathlib

import camsim
import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]
CARD = REPO / "examples" / "rgb-test-card.png"

# IEC 61966-2-1: CIE 1931 XYZ (white Y = 1) -> linear sRGB.
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])


def test_an_srgb_photograph_keeps_its_colours_on_the_srgb_display():
    s = camsim.scene({"kind": "rgb", "path": str(CARD), "white_luminance_cd_m2": 80.0})
    L = s["radiance"]
    assert L.shape == (31, 64, 96) and L.dtype == np.float32 and (L >= 0).all()
    # The top-left bar is sRGB code (235, 235, 235): a neutral at 80 cd/m^2 x decode(235/255).
    # CIE 1931 y-bar at 400..700 nm every 10 nm (the tabulated values).
    ybar = np.array([0.000396, 0.00121, 0.004, 0.0116, 0.023, 0.038, 0.06, 0.09098, 0.13902, 0.20802, 0.323, 0.503, 0.71,
                     0.862, 0.954, 0.99495, 0.995, 0.952, 0.87, 0.757, 0.631, 0.503, 0.381, 0.265, 0.175, 0.107, 0.061,
                     0.032, 0.017, 0.00821, 0.004102])
    lum = 683.0 * 10.0 * np.tensordot(ybar, L[:, 4, 4], axes=1)
    v = 235 / 255
    decoded = ((v + 0.055) / 1.055) ** 2.4
    assert abs(lum - 80.0 * decoded) < 0.01 * 80.0 * decoded, lum


def test_dead_leaves_is_reproducible_and_spans_its_grey_levels():
    cfg = {"kind": "dead_leaves", "size_px": 64, "r_max_px": 16.0, "seed": 5, "mean_luminance_cd_m2": 50.0}
    a = camsim.scene(cfg)["radiance"]
    b = camsim.scene(cfg)["radiance"]
    assert np.array_equal(a, b)
    c = camsim.scene(dict(cfg, seed=6))["radiance"]
    assert not np.array_equal(a, c)
    band = a[15]
    # Grey levels in [0.05, 0.95]: the ratio of any two pixels is at most 19.
    assert band.min() > 0 and band.max() / band.min() <= 19.0 + 1e-3


def test_macbeth_from_an_isetcam_style_reflectance_csv(tmp_path):
    wl = np.arange(400, 701, 10)
    refl = np.tile(np.arange(1, 25) / 25.0, (len(wl), 1))
    csv = tmp_path / "chart.csv"
    header = "wavelength_nm," + ",".join(f"p{k}" for k in range(1, 25))
    np.savetxt(csv, np.column_stack([wl, refl]), delimiter=",", header=header, comments="")
    s = camsim.scene({"kind": "macbeth", "patch_size_px": 4, "border_px": 1, "reflectances": str(csv)})
    L = s["radiance"][15]
    # Patch k (row-major 4 x 6) reflects k/25: patch 24 is 24 times patch 1.
    p1, p24 = L[2, 2], L[1 + 3 * 5 + 1, 1 + 5 * 5 + 1]
    assert abs(p24 / p1 - 24.0) < 1e-3


def test_an_rgbw_sensor_reports_its_layout_and_per_filter_electrons():
    # A flat field through the pixel4a with an RGBW array (R G / W B): the raw's W and G pixels
    # stand in the ratio of the noise-free per-filter electrons the sensor reports, and W (the
    # bare pixel, no colour filter) collects the most.
    wl = np.arange(400.0, 701.0, 10.0)
    flat = np.full((31, 96, 96), 3e-4, np.float32)  # W/(m^2 nm): about 850 e- in green at 10 ms
    sens = camsim.presets.sensor("pixel4a")
    sens["cfa"] = "RGBW"
    r = camsim.sensor(flat, wl, 1.4e-6, sensor=sens, exposure_s=0.01, rows=64, cols=64, seed=4)
    assert r["cfa"] == "RGBW" and r["filters"] == ["r", "g", "b", "w"]
    e = dict(zip(r["filters"], r["mean_electrons_by_filter"]))
    assert e["w"] > max(e["r"], e["g"], e["b"])
    raw = r["raw"][0].astype(float) - r["black_level"]
    g, w = raw[0::2, 1::2].mean(), raw[1::2, 0::2].mean()
    assert w / g == pytest.approx(e["w"] / e["g"], rel=0.02)


def test_an_rgbw_simulation_writes_a_dng_that_reads_back_as_rgbw(tmp_path):
    sens = camsim.presets.sensor("pixel4a")
    sens["cfa"] = "RGBW"
    cfg = {"seed": 2, "scene": {"kind": "uniform", "rows": 16, "cols": 16},
           "sensor": {"config": sens, "rows": 32, "cols": 48}, "capture": {"exposure_ms": 5.0}}
    sim = camsim.simulate(cfg)
    assert sim.cfa == "RGBW"
    sim.write(tmp_path / "run", save="raw")
    back = camsim.read_dng(tmp_path / "run" / "raw.dng")
    assert back["cfa"] == "RGBW"
    assert np.array_equal(back["raw"], sim.raw[0])


def test_a_dual_conversion_gain_sensor_returns_both_readouts_and_a_linear_merge(tmp_path):
    """An [hdr] sensor (examples/sensor-dcg.toml, noise off) on a horizontal irradiance ramp that
    runs from 1/20 of the HCG range to 6x past it: the high readout saturates on the bright side,
    and the merged frame (HCG electrons below the switch, LCG x gain ratio above) stays
    proportional to the irradiance everywhere (within the ADC step of each readout)."""
    cfg = tmp_path / "dcg-quiet.toml"
    quiet = "\n[noise]\nshot = false\nread = false\ndsnu = false\nprnu = false\ndark = false\nquantization = true\n"
    cfg.write_text((REPO / "examples" / "sensor-dcg.toml").read_text() + quiet)
    cfg = str(cfg)
    rows, cols = 8, 64
    level = np.geomspace(0.05, 6.0, cols // 2).repeat(2)  # pairs of columns: every Bayer colour
    irr = np.ones((31, rows, cols), np.float32) * level[None, None, :].astype(np.float32)
    wl = np.arange(400.0, 701.0, 10.0)
    # A short probe (the brightest column well inside the HCG range) gives the green electrons per
    # unit level; then level 1 is exposed to the HCG range (6250 e-).
    probe = camsim.sensor(irr, wl, 3e-6, sensor=cfg, exposure_s=1e-7, rows=rows, cols=cols)
    assert probe["raw"][0].max() < 0.5 * probe["white_level"]
    g_per_level = probe["merged_e"][0][0, -1] / level[-1]
    t = 1e-7 * 6250.0 / g_per_level
    out = camsim.sensor(irr, wl, 3e-6, sensor=cfg, exposure_s=t, rows=rows, cols=cols)
    assert out["hdr_mode"] == "dcg"
    assert out["raw"].shape == out["raw_low"].shape == out["merged_e"].shape == (1, rows, cols)
    high = out["raw"][0].astype(float)
    assert high[:, -2:].min() == out["white_level"], "the high readout should saturate at 6x its range"
    merged = out["merged_e"][0]
    for r0, c0 in ((0, 0), (0, 1), (1, 0), (1, 1)):
        per_level = merged[r0::2, c0::2].mean(axis=0) / level[c0::2]
        k = per_level[len(per_level) // 2]
        assert np.all(np.abs(per_level / k - 1.0) < 0.02), (r0, c0, per_level / k)
    # Dynamic range of the example: full well 40000 e- over 2 e- read noise, ~86 dB.
    assert 80.0 < out["dynamic_range_db"] < 90.0


def test_simulate_with_an_hdr_sensor_returns_both_readouts_and_its_merge(tmp_path):
    """The same DCG sensor through the whole pipeline (issue 41 item 4): simulate hands back the
    high readout as `raw`, the low one as `raw_low` and the merged electrons, which follow the
    documented merge rule (HCG below the switch, LCG scaled by the gain ratio above), and run.json
    carries the merge's figures."""
    cfg = tmp_path / "hdr.toml"
    cfg.write_text(
        f"""
seed = 2
[scene]
kind = "uniform"
mean_luminance_cd_m2 = 2000.0
rows = 16
cols = 16
[optics]
preset = "diffraction-limited"
[sensor]
file = "{(REPO / 'examples' / 'sensor-dcg.toml').as_posix()}"
rows = 32
cols = 32
[capture]
exposure_ms = 10.0
frames = 2
"""
    )
    sim = camsim.simulate(str(cfg))
    assert sim.raw.shape == sim.raw_low.shape == sim.merged_e.shape == (2, 32, 32)
    h = sim.hdr
    assert h["mode"] == "dcg" and 80.0 < h["dynamic_range_db"] < 90.0
    # The merge rule from the raw values alone: K_HCG = 80 uV/e- x 2^12 DN / 0.5 V (camsim's
    # ADC, as ISETCam's, maps the swing to 2^bits codes), and the LCG gain 10 uV/e-
    # (examples/sensor-dcg.toml).
    black = sim.black_level
    k_high, k_low = 80e-6 * 4096 / 0.5, 10e-6 * 4096 / 0.5
    e_high = (sim.raw.astype(np.float64) - black) / k_high
    e_low = (sim.raw_low.astype(np.float64) - black) / k_low
    expect = np.where(e_high < h["switch_e"], e_high, e_low)
    assert np.allclose(sim.merged_e, expect, rtol=1e-5, atol=1e-2)
    assert (e_high >= h["switch_e"]).mean() > 0.5, "2000 cd/m^2 for 10 ms is past the switch"
    sim.write(str(tmp_path / "run"))
    for f in ("raw.dng", "raw_low.dng", "raw_low_0001.dng", "merged.exr", "merged_0001.exr", "run.json"):
        assert (tmp_path / "run" / f).is_file(), f
    rec = json.loads((tmp_path / "run" / "run.json").read_text())
    assert rec["results"]["hdr"]["dynamic_range_db"] == h["dynamic_range_db"]


def test_simulate_with_a_dual_pixel_sensor_returns_both_photodiodes(tmp_path):
    """A dual-pixel sensor (issue 42 item 5, examples/dual-pixel.toml): simulate hands back
    each photodiode's raw beside `raw`, which is their digital sum (the black level once), the
    halves have independent noise, and the run writes raw_left.dng and raw_right.dng."""
    sim = camsim.simulate(str(REPO / "examples" / "dual-pixel.toml"))
    left, right, raw = (a.astype(np.int64) for a in (sim.raw_left, sim.raw_right, sim.raw))
    assert left.shape == right.shape == raw.shape == (1, 96, 128)
    black = round(sim.black_level)
    assert np.array_equal(raw, np.clip(left + right - black, 0, round(sim.white_level)))
    # One CFA colour's pixels on the bright side, far from the edge: both halves see the same
    # light, each with its own noise (shot, read, fixed pattern).
    lh, rh = left[0, 0::2, 96::2].astype(np.float64), right[0, 0::2, 96::2].astype(np.float64)
    assert abs(lh.mean() / rh.mean() - 1.0) < 0.02
    assert abs(np.corrcoef((lh - lh.mean()).ravel(), (rh - rh.mean()).ravel())[0, 1]) < 0.15
    sim.write(str(tmp_path / "run"))
    for f in ("raw.dng", "raw_left.dng", "raw_right.dng", "run.json"):
        assert (tmp_path / "run" / f).is_file(), f


def test_simulate_with_sensor_defects_lists_them_and_writes_defects_json(tmp_path):
    """[defects] over a preset (issue 42 item 3): `Simulation.defects` lists the faulty pixels
    on the raw's grid, dead pixels read black in a bright field, stuck ones their stuck_dn, and
    defects.json written with the raw holds the same list."""
    cfg = tmp_path / "defects.toml"
    cfg.write_text(
        """
seed = 2
[scene]
kind = "uniform"
mean_luminance_cd_m2 = 200.0
rows = 16
cols = 16
[optics]
preset = "diffraction-limited"
[sensor]
preset = "pixel4a"
rows = 64
cols = 64
[sensor.config.defects]
dead_fraction = 0.01
stuck_fraction = 0.01
stuck_dn = 900.0
[capture]
exposure_ms = 10.0
"""
    )
    sim = camsim.simulate(str(cfg))
    d = sim.defects
    assert 10 < len(d) < 200 and {k for _, _, k in d} <= {"dead", "stuck"}
    raw = sim.raw[0].astype(np.float64)
    # A dead pixel keeps its dark signal and read noise: pixel4a's 5 mV at 2^12 DN / 0.4591 V is
    # 44.6 DN rms, so it reads within 4 sigma of black while the field is hundreds of DN.
    read_dn = 5e-3 * 4096 / 0.4591
    for r, c, kind in d:
        if kind == "stuck":
            assert raw[r, c] == 900.0
        else:
            assert raw[r, c] < sim.black_level + 4 * read_dn, (r, c, raw[r, c])
    assert np.median(raw) > sim.black_level + 100, "the field is bright"
    sim.write(str(tmp_path / "run"))
    rec = json.loads((tmp_path / "run" / "defects.json").read_text())
    assert [(x["row"], x["col"], x["kind"]) for x in rec["defects"]] == [tuple(x) for x in d]
    assert rec["counts"]["dead"] + rec["counts"]["stuck"] == len(d)


def test_simulate_with_the_noise_free_pass_reports_psnr_and_ssim():
    """Issue 42 item 7: the noise-free pass gives the raw's and preview's PSNR and SSIM; the raw's
    MSE recomputed from the arrays Python receives matches the reported PSNR."""
    cfg = {
        "seed": 1,
        "scene": {"kind": "macbeth", "patch_size_px": 8, "border_px": 2},
        "optics": {"preset": "diffraction-limited"},
        "sensor": {"preset": "pixel4a", "rows": 64, "cols": 96},
    }
    sim = camsim.simulate(cfg, noise_free=True)
    q = sim.quality
    assert 0.0 < q["raw"]["ssim"] < 1.0 and 0.0 < q["preview"]["ssim"] < 1.0
    raw = sim.raw[0].astype(np.float64)
    nf = sim.noise_free.astype(np.float64)
    peak = sim.white_level - sim.black_level
    mse = np.mean((raw - nf) ** 2)
    assert abs(10 * np.log10(peak**2 / mse) - q["raw"]["psnr_db"]) < 1e-3
    assert camsim.simulate(cfg).quality is None
