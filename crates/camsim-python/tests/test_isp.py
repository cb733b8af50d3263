"""The ISP functions of the Python package: demosaicking methods, white balance and the
colour-correction matrix fit, each against a closed form."""

import camsim
import numpy as np
import pytest

CFA_OFFSETS = {"RGGB": {(0, 0): 0, (0, 1): 1, (1, 0): 1, (1, 1): 2},
               "BGGR": {(0, 0): 2, (0, 1): 1, (1, 0): 1, (1, 1): 0},
               "GRBG": {(0, 0): 1, (0, 1): 0, (1, 0): 2, (1, 1): 1},
               "GBRG": {(0, 0): 1, (0, 1): 2, (1, 0): 0, (1, 1): 1}}


def mosaic_of(planes, cfa):
    rows, cols = planes.shape[1:]
    raw = np.zeros((rows, cols), dtype=np.uint16)
    for (dy, dx), ch in CFA_OFFSETS[cfa].items():
        raw[dy::2, dx::2] = planes[ch, dy::2, dx::2]
    return raw


@pytest.mark.parametrize("method", ["bilinear", "malvar", "adaptive-laplacian"])
@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
def test_demosaic_methods_are_exact_on_linear_ramps(method, cfa):
    # Each channel a + b row + c col: every method reproduces it exactly three pixels from the
    # border, and keeps the sampled values everywhere.
    rows, cols = 16, 20
    y, x = np.mgrid[0:rows, 0:cols]
    planes = np.stack([100 + 3 * y + 5 * x, 200 + 7 * y + 2 * x, 50 + y + 11 * x]).astype(np.float64)
    raw = mosaic_of(planes, cfa)
    rgb = camsim.demosaic(raw, cfa, bits=16, method=method)
    assert rgb.shape == (rows, cols, 3) and rgb.dtype == np.float32
    np.testing.assert_allclose(rgb[3:-3, 3:-3].transpose(2, 0, 1), planes[:, 3:-3, 3:-3], atol=1e-3)
    for (dy, dx), ch in CFA_OFFSETS[cfa].items():
        np.testing.assert_array_equal(rgb[dy::2, dx::2, ch], raw[dy::2, dx::2])


def test_unknown_demosaic_method_is_an_error():
    with pytest.raises(camsim.CamsimError, match="ahd2"):
        camsim.demosaic(np.zeros((8, 8), dtype=np.uint16), method="ahd2")


def test_white_balance_closed_forms():
    # A gray 0.2 and a white 0.9 seen through channel sensitivities (2, 1, 0.5): gray world and
    # white patch both give gains (0.5, 1, 2) exactly, and the balanced image is neutral.
    k = np.array([2.0, 1.0, 0.5], dtype=np.float32)
    rho = np.full((8, 8), 0.2, dtype=np.float32)
    rho[::2, ::2] = 0.9
    img = rho[:, :, None] * k
    for method in ["gray-world", "white-patch"]:
        out, gains = camsim.white_balance(img, method, percentile=90)
        np.testing.assert_allclose(gains, [0.5, 1.0, 2.0], rtol=1e-6)
        np.testing.assert_allclose(out[..., 0], out[..., 1], rtol=1e-6)
        np.testing.assert_allclose(out[..., 2], out[..., 1], rtol=1e-6)
    # From the illuminant: green gain 1, the others positive; unknown methods are errors.
    _, gains = camsim.white_balance(img, "illuminant", illuminant="A", sensor="pixel4a")
    assert gains[1] == 1.0 and min(gains) > 0
    with pytest.raises(camsim.CamsimError, match="auto"):
        camsim.white_balance(img, "auto")


@pytest.mark.parametrize("objective", ["xyz", "linear-srgb", "cielab"])
def test_fit_ccm_recovers_a_known_matrix(objective):
    xyz, white = camsim.macbeth_xyz("D65")
    assert xyz.shape == (24, 3) and abs(white[1] - 1.0) < 1e-12
    truth = np.array([[1.6, -0.4, 0.1], [-0.3, 1.5, -0.2], [0.05, -0.35, 1.9]])
    camera = xyz @ np.linalg.inv(truth).T
    m, de = camsim.fit_ccm(camera, xyz, white, objective=objective)
    np.testing.assert_allclose(m, truth, atol=1e-6)
    assert de.shape == (24,) and de.max() < 1e-4


def test_demosaic_zone_plate_ordering():
    # Malvar and Hamilton-Adams are sharper than bilinear and have far less false colour in the
    # band the red/blue samples can carry (measured: MTF50 0.28 / > 0.5 / 0.45 cycles/pixel).
    q = camsim.demosaic_zone_plate(256, 0.5, "BGGR")
    assert set(q) == {"bilinear", "malvar", "adaptive-laplacian"}
    mtf50 = {k: (v["mtf50_cy_per_px"] or 0.5) for k, v in q.items()}
    assert mtf50["malvar"] > mtf50["bilinear"] + 0.03 and mtf50["adaptive-laplacian"] > mtf50["bilinear"] + 0.03
    fc = {k: v["false_colour_low_rms"] for k, v in q.items()}
    assert fc["malvar"] < 0.7 * fc["bilinear"] and fc["adaptive-laplacian"] < 0.7 * fc["bilinear"]
    with pytest.raises(camsim.CamsimError, match="f_max"):
        camsim.demosaic_zone_plate(64, 0.7)


def test_unprocess_gives_the_inverse_means_and_renders_back():
    # A flat sRGB field unprocessed to a pixel4a raw: each channel's mean DN is the closed-form
    # inverse (IEC 61966-2-1 decoding, then M^-1 of the matrix the ISP reports, illuminant white
    # balance included, over the scale),
    # and the ISP at the reported scale gives the photo's codes back.
    code = np.array([150, 120, 90], dtype=np.uint8)
    photo = np.broadcast_to(code, (48, 48, 3)).copy()
    out = camsim.unprocess(photo, sensor="pixel4a", seed=3)
    raw, scale = out["raw"], out["exposure_scale"]
    assert raw.shape == (48, 48) and raw.dtype == np.uint16
    preview, report = camsim.isp(raw, out["cfa"], sensor="pixel4a", bits=out["bits"],
                                 black_level=out["black_level"], exposure_scale=scale)
    assert report["exposure_scale"] == pytest.approx(scale, rel=1e-9)
    v = code / 255.0
    linear = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    cam = np.linalg.solve(np.asarray(report["camera_to_linear_srgb"]), linear)
    want = cam / scale
    offsets = CFA_OFFSETS[out["cfa"]]
    for ch in range(3):
        samples = np.concatenate([raw[dy::2, dx::2].ravel() for (dy, dx), c in offsets.items() if c == ch])
        x = samples.astype(np.float64) - out["black_level"]
        se = x.std(ddof=1) / np.sqrt(x.size)
        assert abs(x.mean() - want[ch]) < 4 * se + 0.1, (ch, x.mean(), want[ch])
    np.testing.assert_allclose(preview[4:-4, 4:-4].reshape(-1, 3).mean(axis=0), code, atol=1.5)
    again = camsim.unprocess(photo, sensor="pixel4a", seed=3)["raw"]
    np.testing.assert_array_equal(raw, again)
    with pytest.raises(camsim.CamsimError, match="gray-world"):
        camsim.unprocess(photo, white_balance="gray-world")
