"""Image-quality metrics (S-CIELAB, SNR, noise power spectrum, acutance) and the two-camera
comparison, each against a closed form."""

import json
import math

import camsim
import numpy as np
import pytest

D65 = (95.047, 100.0, 108.883)


def lab(xyz, white=D65):
    # CIE 015:2018 eqs. 8.11-8.13, written independently of camsim.
    def f(t):
        return np.cbrt(t) if t > (6 / 29) ** 3 else t / (3 * (6 / 29) ** 2) + 4 / 29
    fx, fy, fz = (f(v / w) for v, w in zip(xyz, white))
    return np.array([116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)])


def test_scielab_of_a_uniform_shift_is_the_cielab_difference_and_zero_for_identical_images():
    a, b = (30.0, 25.0, 12.0), (26.0, 27.0, 20.0)
    ia = np.broadcast_to(np.array(a, dtype=np.float32), (20, 24, 3))
    ib = np.broadcast_to(np.array(b, dtype=np.float32), (20, 24, 3))
    r = camsim.scielab(ia, ib, D65, 30.0)
    expect = float(np.linalg.norm(lab(a) - lab(b)))
    assert r["delta_e"].shape == (20, 24)
    assert r["mean"] == pytest.approx(expect, rel=1e-4)
    assert camsim.scielab(ia, ia, D65, 30.0)["max"] == 0.0


def test_scielab_ignores_a_grating_above_the_chromatic_cut_off():
    p, q = np.array([40.0, 30.0, 20.0]), np.array([25.0, 32.0, 24.0])
    img = np.empty((32, 48, 3), dtype=np.float32)
    img[:, 0::2] = p
    img[:, 1::2] = q
    mean = np.broadcast_to(((p + q) / 2).astype(np.float32), img.shape)
    s = camsim.scielab(img, mean, D65, 60.0)["mean"]
    pixelwise = float(np.linalg.norm(lab(p) - lab((p + q) / 2)) + np.linalg.norm(lab(q) - lab((p + q) / 2))) / 2
    assert s < 0.1 * pixelwise


def test_scielab_bad_input_raises():
    a = np.zeros((8, 8, 3), dtype=np.float32)
    with pytest.raises(camsim.CamsimError):
        camsim.scielab(a, np.zeros((8, 9, 3), dtype=np.float32), D65, 20.0)
    with pytest.raises(camsim.CamsimError):
        camsim.scielab(a, a, D65, 20.0, formula="nope")


def test_nps_of_white_noise_is_flat_and_integrates_to_the_variance():
    rng = np.random.default_rng(4)
    sigma = 2.5
    img = (100 + sigma * rng.standard_normal((384, 384))).astype(np.float32)
    r = camsim.nps(img, roi_px=64)
    assert r["nps_2d"].shape == (64, 64)
    assert r["variance"] == pytest.approx(sigma ** 2, rel=0.04)
    # Periodogram scatter: ~7 % in the lowest bin with 121 half-overlapping sub-ROIs, less beyond.
    assert abs(r["radial_nps"][1] / sigma ** 2 - 1) < 0.3
    assert np.all(np.abs(r["radial_nps"][2:] / sigma ** 2 - 1) < 0.2)
    assert float(np.mean(r["radial_nps"][1:])) == pytest.approx(sigma ** 2, rel=0.05)
    # Parseval by hand: the 2D NPS summed times du dv = (1/64)^2.
    assert float(r["nps_2d"].sum()) / 64 ** 2 == pytest.approx(r["variance"], rel=1e-9)


def test_snr_of_a_two_level_region():
    img = np.where(np.indices((10, 10)).sum(axis=0) % 2 == 0, 90.0, 110.0).astype(np.float32)
    s = camsim.snr(img)
    assert s["mean"] == pytest.approx(100.0)
    assert s["std"] == pytest.approx(10 * math.sqrt(100 / 99))
    assert s["snr_db"] == pytest.approx(20 * math.log10(s["snr"]))


def test_acutance_closed_forms():
    f = np.linspace(0, 0.5, 2001)
    assert camsim.acutance(f, np.ones_like(f), 40.0)["acutance"] == pytest.approx(1.0, abs=1e-12)
    # SFR = exp(-k nu), nu in cycles/degree: A = (b / (b + k))^(c + 1) with the CPIQ b = 0.2, c = 0.8.
    ppd, k = 400.0, 0.1
    a = camsim.acutance(f, np.exp(-k * f * ppd), ppd)["acutance"]
    assert a == pytest.approx((0.2 / 0.3) ** 1.8, rel=1e-3)


def test_compare_a_camera_with_itself_and_the_report_files(tmp_path):
    r = camsim.compare("pixel4a", "pixel4a", out=tmp_path / "cmp", size=64)
    assert r["a"]["mtf"]["mtf"] == r["b"]["mtf"]["mtf"]
    assert r["a"]["color"]["patch_delta_e2000"] == r["b"]["color"]["patch_delta_e2000"]
    assert len(r["a"]["color"]["patch_delta_e2000"]) == 24
    for name in ["report.html", "results.json", "compare_mtf.png", "compare_snr.png", "compare_nps.png", "compare_delta_e.png"]:
        assert (tmp_path / "cmp" / name).is_file()
    assert json.loads((tmp_path / "cmp" / "results.json").read_text())["a"]["label"].startswith("A:")
    with pytest.raises(camsim.CamsimError):
        camsim.compare("no-such-sensor", "pixel4a", size=64)


def srgb_encode(v):
    # IEC 61966-2-1:1999 eq. 5.5-5.6, written independently of camsim.
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def test_visual_noise_weights_a_neutral_grating_by_the_luminance_csf():
    # 8 cycles over 64 columns seen at 32 pixels per degree: 4 cycles/degree, the peak of the CPIQ
    # luminance CSF 75 nu^0.8 exp(-0.2 nu) / 34.05 (= 3.0003); a neutral stays neutral.
    rows, cols, y0, a = 16, 64, 0.2, 0.01
    s = np.sin(2 * np.pi * 8 * np.arange(cols) / cols)
    lin = np.broadcast_to((y0 + a * s)[None, :, None], (rows, cols, 3))
    img = srgb_encode(lin).astype(np.float32)
    r = camsim.visual_noise(img, (0, 0, rows, cols), pixels_per_degree=32.0)
    g = 75 * 4.0 ** 0.8 * math.exp(-0.8) / 34.05
    lstar = 116 * np.cbrt(y0 + g * a * s) - 16
    assert r["sigma_l_star"] == pytest.approx(float(lstar.std()), rel=3e-3)
    assert r["sigma_u_star"] < 1e-2 and r["sigma_v_star"] < 1e-2
    assert r["visual_noise"] == pytest.approx(
        r["sigma_l_star"] + 0.852 * r["sigma_u_star"] + 0.323 * r["sigma_v_star"], rel=1e-12)
    # The default viewing condition: the picture 0.1 m high at 0.4 m.
    d = camsim.visual_noise(img)
    assert d["pixels_per_degree"] == pytest.approx(rows / 0.1 * 2 * 0.4 * math.tan(math.radians(0.5)), rel=1e-12)
    assert d["rect"] == {"row": 4, "col": 16, "rows": 8, "cols": 32}
    with pytest.raises(camsim.CamsimError):
        camsim.visual_noise(img, encoding="gamma")
    with pytest.raises(camsim.CamsimError):
        camsim.visual_noise(img, (10, 60, 8, 8), pixels_per_degree=32.0)
