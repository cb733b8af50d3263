"""camsim: a digital camera simulated end to end, on numpy arrays.

The scene's spectral radiance (2D charts or path-traced 3D scenes) -> the optics (sensor-plane
spectral irradiance) -> the image sensor (raw ADC values, with its noise) -> an ISP preview, plus
the analyses that compare a simulation with a real camera (SFR/MTF, chart and ROI statistics,
QE fits). The computing is done by camsim's Rust library with the GIL released.

    import camsim
    sim = camsim.simulate()                                  # the built-in default
    sim.raw.shape, sim.cfa, sim.black_level                  # (frames, rows, cols) uint16
    sim.irradiance.shape, sim.wavelengths_nm                 # (bands, rows, cols) float32

Configs are plain dicts (as in camsim's TOML files; see README "Config reference"), TOML text, or
a path to a TOML file or a run.json. Errors raise camsim.CamsimError with camsim's message.

This package is a door to camsim's application layer: each function converts its arguments,
calls one Rust function and returns numpy arrays, a Simulation or dicts built in Rust.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _camsim, dataset, presets
from ._camsim import CamsimError, Simulation
from ._checks import check_values as _check_values

__version__ = _camsim.__version__

__all__ = [
    "CamsimError",
    "Simulation",
    "simulate",
    "scene",
    "render",
    "optics",
    "sensor",
    "demosaic",
    "white_balance",
    "isp",
    "unprocess",
    "fit_ccm",
    "macbeth_xyz",
    "demosaic_zone_plate",
    "sfr",
    "roi",
    "chart",
    "fit_qe",
    "emva",
    "emva_series",
    "emva_simulate",
    "read_dng",
    "load_config",
    "presets",
    "dataset",
    "scielab",
    "visual_noise",
    "snr",
    "nps",
    "acutance",
    "compare",
]

Config = Union[Dict[str, Any], str, "os.PathLike[str]"]


def load_config(config: Optional[Config] = None) -> Dict[str, Any]:
    """A simulate config as a dict, from a dict (checked and completed with every default), TOML
    text, or the path of a TOML file or a run.json (its relative paths resolved); None: the
    built-in default."""
    if isinstance(config, dict):
        _check_values(config, "config", CamsimError)
    return _camsim.load_config(config)


def simulate(
    config: Optional[Config] = None,
    *,
    noise_free: bool = False,
    seed: Optional[int] = None,
    labels: bool = False,
    flow: bool = False,
) -> Simulation:
    """Run the whole pipeline in memory; with no config, the built-in default (as `camsim
    simulate` with none: a Macbeth chart under D65, the Pixel 4a camera). Returns a Simulation
    with numpy arrays: radiance (None when the scene's camera is a lens, whose render is the
    irradiance), irradiance ((bands, rows, cols) float32, with wavelengths_nm), raw ((frames,
    rows, cols) uint16, with cfa, black_level, white_level), frame_times_s ((frames, 2): each
    frame's start and duration in the scene's time, s; a moving 3D scene is rendered at each
    frame's own time), preview ((rows, cols, 3) uint8), depth, noise_free (the first frame's)
    and noise_free_frames ((frames, rows, cols), each frame's; with noise_free=True), flow and flow_next (with flow=True on a 3D scene: (frames, rows, cols, 2)
    and (frames - 1, rows, cols, 2) optical flow in sensor pixels, aligned with raw) and metadata
    (a dict). Same config and seed as
    `camsim simulate` give the same raw values, bit for bit. A [render] pbrt scene with a lens
    camera (realistic, raytransfer) renders sensor-plane irradiance and skips [optics]
    (metadata["results"]["lens_camera"] is True). labels=True (3D scenes): Simulation.labels
    (instance, id, depth, normal and albedo maps on the raw image's grid, boxes) and
    Simulation.camera (K, world_to_camera); a moving 3D scene's are the first frame's, a sharp
    snapshot at its window's start (the files of `camsim simulate --save` hold every frame's)."""
    if isinstance(config, dict):
        _check_values(config, "config", CamsimError)
    if seed is not None:
        _check_values({"seed": int(seed)}, "config", CamsimError)
    return _camsim.simulate(config, noise_free, None if seed is None else int(seed), labels, flow)


def _path_or(x: Any) -> Any:
    """A path-like as a string; anything else (a preset name, a dict) as it is."""
    return os.fspath(x) if isinstance(x, os.PathLike) else x


def _grid(wavelengths_nm: Optional[Sequence[float]]) -> Tuple[float, float, int]:
    if wavelengths_nm is None:
        return 400.0, 10.0, 31
    w = np.asarray(wavelengths_nm, dtype=float)
    if w.ndim != 1 or len(w) == 0:
        raise CamsimError("wavelengths_nm must be a non-empty 1-D sequence")
    step = float(w[1] - w[0]) if len(w) > 1 else 10.0
    return float(w[0]), step, len(w)


def scene(config: Union[Dict[str, Any], str], wavelengths_nm: Optional[Sequence[float]] = None) -> Dict[str, Any]:
    """Stage 1, a 2D scene: a [scene] table as a dict (kind = "macbeth", "uniform",
    "slanted_edge", "file" (a spectral EXR), "rgb" (a PNG/JPEG/TIFF/EXR photograph on a display
    model: path, display, transfer, white_luminance_cd_m2), a test pattern such as "zone_plate" or
    "dead_leaves") or a kind name alone (with defaults). Returns a dict:
    radiance (bands, rows, cols) float32 W/(sr m^2 nm), wavelengths_nm, spacing_m, fov_deg,
    distance_m, depth_m (None), units."""
    start, step, count = _grid(wavelengths_nm)
    if isinstance(config, dict):
        _check_values(config, "scene", CamsimError)
    return _camsim.scene(config, start, step, count)


def render(builtin: Optional[str] = None, pbrt: Optional[str] = None, *, resolution: Optional[Tuple[int, int]] = None,
           samples_per_pixel: Optional[int] = None, seed: int = 1,
           wavelengths_nm: Optional[Sequence[float]] = None, adaptive_error: Optional[float] = None,
           min_samples: Optional[int] = None, denoise: bool = False) -> Dict[str, Any]:
    """Stage 1, a 3D scene: path-trace a built-in scene ("cornell-box", "cornell-box-mcc",
    "slanted-edge") or a scene file given as pbrt: pbrt-v4, glTF 2.0 (.gltf, .glb) or OBJ, told
    apart by its content (glTF in its physical units, docs/src/assets.md). resolution = (width, height). Returns a dict like scene()'s,
    with depth_m (rows, cols) float32 m, and segmentation: object_id and material_id (rows, cols)
    uint32 (1 + index of the shape and of its material met first through each pixel centre, 0 =
    none) with ids_legend {"objects": {1: name, ...}, "materials": {...}}.
    adaptive_error (e.g. 0.05): adaptive sampling, each pixel stops once the relative standard
    error of its luminance is below it, after at least min_samples (default 32) and at most
    samples_per_pixel; the dict then has samples_per_pixel (rows, cols) uint32, the samples each
    pixel took (docs/src/adaptive.md). denoise=True: the radiance through Intel Open Image Denoise
    (the library named by the environment variable CAMSIM_OIDN_LIBRARY, e.g. from `pip install
    oidn`), for training data only: it changes MTF, colour and noise figures."""
    start, step, count = _grid(wavelengths_nm)
    return _camsim.render(builtin, None if pbrt is None else os.fspath(pbrt), resolution, samples_per_pixel, seed, start, step, count,
                          adaptive_error, min_samples, denoise)


def optics(radiance: np.ndarray, wavelengths_nm: Sequence[float], *, lens: Union[str, Dict[str, Any]] = "pixel4a",
           spacing_m: float = 0.0, distance_m: float = 0.0, fov_deg: float = 0.0,
           depth_m: Optional[np.ndarray] = None) -> Dict[str, Any]:
    """Stage 2: spectral radiance (bands, rows, cols) -> sensor-plane irradiance. lens: a preset
    name ("pixel4a", "pixel4a-measured", "diffraction-limited"), a lens TOML path, or a dict (camsim.presets.lens()).
    The scene's scale: spacing_m (scene sample spacing at distance_m), or fov_deg for a scene at
    infinity (distance_m = 0). Returns a dict: irradiance (bands, rows', cols') float32 W/(m^2 nm),
    wavelengths_nm, spacing_m (in the sensor plane), ..."""
    r = np.ascontiguousarray(radiance, dtype=np.float32)
    d = None if depth_m is None else np.ascontiguousarray(depth_m, dtype=np.float32)
    return _camsim.optics(r, [float(w) for w in wavelengths_nm], lens, float(spacing_m), float(distance_m), float(fov_deg), d)


def sensor(irradiance: np.ndarray, wavelengths_nm: Sequence[float], spacing_m: float, *,
           sensor: Union[str, Dict[str, Any]] = "pixel4a", exposure_s: Union[None, float, Sequence[float]] = None, seed: int = 1,
           frames: int = 1, rows: Optional[int] = None, cols: Optional[int] = None,
           iso: Optional[float] = None, cfa: Optional[str] = None, noise: bool = True) -> Dict[str, Any]:
    """Stage 3: sensor-plane irradiance (bands, rows, cols) at spacing_m -> raw frames. sensor: a
    preset ("pixel4a", "pixel4a-raw10", "imx363"), a sensor TOML path, or a dict (camsim.presets.sensor()).
    exposure_s None: auto-exposure; a list of times: an exposure bracket / burst (ISETCam's vector
    exposure time), `frames` raws per time in list order, each with its own temporal noise.
    iso: sensitivity (analog gain = base_iso / iso; the sensor needs base_iso). rows/cols: a centred
    window of the sensor. cfa: a colour filter array by name in place of the sensor's ("RGGB",
    "RGBW", "quad-bayer", ...). noise=False: the mean signal only. (The overrides of `camsim
    sensor --rows --cols --iso --cfa --no-noise`, applied in that order.) Returns a dict: raw (frames, rows, cols) uint16, cfa (a Bayer name, "RGBW",
    "quad-bayer" or the tile's filter names), filters (the CFA's filter names), black_level,
    white_level, bits, exposure_s (the first raw's), exposures_s (per raw), mean_electrons_rgb,
    mean_electrons_by_filter (noise-free means in the order of filters). A sensor with an [hdr]
    table (dual conversion gain or split pixel) returns raw (the high readout), raw_low, merged_e
    ((frames, rows, cols) float32, electrons of the high readout, black removed), hdr_mode,
    dynamic_range_db, cfa, filters, black_level, white_level, bits and exposure_s."""
    e = np.ascontiguousarray(irradiance, dtype=np.float32)
    bracket = None
    if exposure_s is not None and not isinstance(exposure_s, (int, float)):
        bracket = [float(t) for t in exposure_s]
        exposure_s = None
    return _camsim.sensor(e, [float(w) for w in wavelengths_nm], float(spacing_m), _path_or(sensor), exposure_s, seed, frames, rows, cols,
                          bracket, iso, cfa, noise)


def demosaic(raw: np.ndarray, cfa: str = "RGGB", *, bits: int = 12, black_level: float = 0.0,
             method: str = "bilinear") -> np.ndarray:
    """Demosaic a raw mosaic (rows, cols) -> (rows, cols, 3) float32, black level subtracted.

    method (ISETCam's 'demosaic method'): "bilinear" (the paper's), "malvar" (Malvar, He & Cutler
    2004 gradient-corrected linear, ISETCam "laplacian") or "adaptive-laplacian" (Hamilton & Adams
    1997, directional). All four Bayer phases (cfa "RGGB", "BGGR", "GRBG", "GBRG")."""
    return _camsim.demosaic(np.ascontiguousarray(raw, dtype=np.uint16), cfa, bits, black_level, method)


def white_balance(rgb: np.ndarray, method: str = "gray-world", *, percentile: float = 99.0,
                  saturation: Optional[float] = None, illuminant: str = "D65",
                  sensor: Union[str, Dict[str, Any]] = "pixel4a") -> Tuple[np.ndarray, List[float]]:
    """White-balance a linear RGB image (rows, cols, 3); returns (balanced image, gains), gains
    with green = 1 (ISETCam 'illuminant correction method').

    method: "gray-world" (gain_c = mean G / mean c), "white-patch" (the same over the pixels whose
    R+G+B is at or above `percentile`, leaving out any with a channel >= `saturation`; ISETCam
    "white world"), "illuminant" (from the camera response of `sensor` to a perfect white under
    the built-in `illuminant`: a gray surface under it comes out neutral exactly) or "none"."""
    a = np.ascontiguousarray(rgb, dtype=np.float32)
    gains = _camsim.white_balance_gains(a, method, float(percentile), saturation, illuminant, _path_or(sensor))
    return a * np.asarray(gains, dtype=np.float32), list(gains)


def isp(raw: np.ndarray, cfa: str = "RGGB", *, sensor: Union[str, Dict[str, Any]] = "pixel4a", bits: int = 12,
        black_level: float = 0.0, illuminant: str = "D65", demosaic: str = "bilinear",
        white_balance: str = "illuminant", steps: Optional[Dict[str, Any]] = None,
        exposure_scale: Optional[float] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
    """The whole ISP, as `camsim isp` and the preview of `camsim simulate` run it (ISETCam's ip):
    demosaic, white balance (from the scene `illuminant` and the sensor's QE, or gray-world,
    white-patch, none), the colour matrix fitted on the ColorChecker from the QE, sRGB. `steps`
    takes the keys of a simulate config's `[isp]` table (e.g. {"defect_correction": "detect",
    "column_correction": "sensor", "denoise": "nlm", "denoise_strength": 1.5,
    "lens_shading": "shading.toml", "sharpen":
    {"radius_px": 1.2, "amount": 0.6}, "tone_map": "reinhard"}; unknown keys are refused).
    `exposure_scale` fixes the exposure (linear sRGB = scale x matrix x camera DN above black, as
    the report gives it; default automatic). Returns (preview (rows, cols, 3) uint8, report:
    white_balance_gains, camera_to_linear_srgb, exposure_scale, ...)."""
    r = np.ascontiguousarray(raw, dtype=np.uint16)
    steps_json = None if steps is None else json.dumps(steps)
    return _camsim.isp(r, _path_or(sensor), cfa, bits, black_level, illuminant, demosaic, white_balance, steps_json,
                       None if exposure_scale is None else float(exposure_scale))


def unprocess(photo: np.ndarray, *, sensor: Union[str, Dict[str, Any]] = "pixel4a", illuminant: str = "D65",
              white_balance: str = "illuminant", tone_map: str = "clip", exposure_scale: Optional[float] = None,
              exposure_s: float = 0.01, seed: int = 0) -> Dict[str, Any]:
    """The inverse ISP (Brooks et al. 2019), as `camsim unprocess` runs it: an 8-bit sRGB photo
    (rows, cols, 3) uint8 -> a training raw of `sensor` (its r, g, b CFA, QE colour matrix under
    `illuminant`, conversion gain, read noise, levels), with Poisson shot noise and read noise drawn
    from `seed`. `white_balance` "illuminant" or "none", `tone_map` "clip" or "filmic" (the
    preview's); `exposure_scale` default: the photo's white at the sensor's saturation. Returns
    {"raw": (rows, cols) uint16, "cfa", "black_level", "white_level", "bits", "exposure_scale"}:
    `isp(raw, cfa, bits=..., black_level=..., exposure_scale=...)` renders the photo back."""
    a = np.ascontiguousarray(photo, dtype=np.uint8)
    if a.ndim != 3:
        raise CamsimError(f"photo: shape {a.shape}; give (rows, cols, 3) uint8 sRGB")
    return _camsim.unprocess(a, _path_or(sensor), illuminant, white_balance, tone_map,
                             None if exposure_scale is None else float(exposure_scale), float(exposure_s), int(seed))


def fit_ccm(camera_rgb: np.ndarray, target_xyz: np.ndarray, white_xyz: Sequence[float], *,
            objective: str = "linear-srgb") -> Tuple[np.ndarray, np.ndarray]:
    """Fit a 3x3 colour-correction matrix M (camera RGB -> CIE XYZ, `xyz = M @ rgb`) on n patch
    pairs (n, 3), by least squares in "xyz", in "linear-srgb" (IEC 61966-2-1), or minimising the
    CIELAB error ("cielab": Gauss-Newton from the linear-sRGB fit) relative to `white_xyz`.
    Returns (M as a (3, 3) array, CIEDE2000 of each patch). Targets for the ColorChecker:
    `macbeth_xyz()`."""
    cam = [tuple(float(v) for v in row) for row in np.asarray(camera_rgb, dtype=np.float64).reshape(-1, 3)]
    tgt = [tuple(float(v) for v in row) for row in np.asarray(target_xyz, dtype=np.float64).reshape(-1, 3)]
    m, de = _camsim.fit_ccm(cam, tgt, tuple(float(v) for v in white_xyz), objective)
    return np.asarray(m, dtype=np.float64), np.asarray(de, dtype=np.float64)


def demosaic_zone_plate(size: int = 512, f_max: float = 0.5, cfa: str = "RGGB") -> Dict[str, Any]:
    """Every demosaicking method on a gray zone plate (a circular chirp whose local frequency rises
    linearly from 0 at the centre to `f_max` cycles/pixel at the edge) sampled by a `cfa` mosaic.
    Returns {method: {"frequency_cy_per_px", "mtf" (luminance, in-phase amplitude / true),
    "mtf50_cy_per_px" (None: not reached), "false_colour_low_rms" (chroma error / amplitude below
    0.25 cycles/pixel), "false_colour_rms"}} (same as `camsim analyze demosaic`)."""
    return _camsim.demosaic_zone_plate(int(size), float(f_max), cfa)


def macbeth_xyz(illuminant: str = "D65") -> Tuple[np.ndarray, np.ndarray]:
    """CIE XYZ of the 24 ColorChecker patches (standard order; Ohta 1997 reflectances) under a
    built-in illuminant, scaled so a perfect white has Y = 1; returns (xyz (24, 3), white xyz)."""
    xyz, white = _camsim.macbeth_xyz(illuminant)
    return np.asarray(xyz, dtype=np.float64), np.asarray(white, dtype=np.float64)


def sfr(raw: np.ndarray, cfa: str = "RGGB", *, channel: str = "G", roi: Optional[Tuple[int, int, int, int]] = None,
        pitch_um: Optional[float] = None, bits: int = 12, black_level: float = 0.0) -> Dict[str, Any]:
    """ISO 12233 slanted-edge SFR of a raw capture's channel ("R", "G", "B") or of its
    demosaicked luminance ("luminance", Rec. 709 weights), measured as `camsim analyze sfr`
    measures it: roi = (row, col, rows, cols), default the region around the slanted edge of
    largest contrast found once on the whole mosaic. Frequencies in cycles per sensor pixel (and
    cycles/mm with pitch_um)."""
    return _camsim.sfr(np.ascontiguousarray(raw, dtype=np.uint16), cfa, channel, roi, pitch_um, bits, black_level)


def roi(raw: np.ndarray, rects: Sequence[Tuple[int, int, int, int]], cfa: str = "RGGB", *, bits: int = 12,
        black_level: float = 0.0) -> List[Dict[str, Any]]:
    """Per-channel mean, standard deviation and counts of raw regions (row, col, rows, cols)."""
    return _camsim.roi(np.ascontiguousarray(raw, dtype=np.uint16), list(rects), cfa, bits, black_level)


def chart(raw: np.ndarray, corners: Sequence[Tuple[float, float]], cfa: str = "RGGB", *, fraction: float = 0.5,
          bits: int = 12, black_level: float = 0.0) -> List[Dict[str, Any]]:
    """ColorChecker patch statistics of a raw capture, one dict per patch numbered 1-24 as on the
    chart (``patch``, ``name``: 1 "dark skin" ... 19 "white" ... 24 "black"); corners [x, y] in
    pixels: top-left (dark skin), top-right, bottom-right, bottom-left; fraction: the central part
    of each patch used."""
    c = [(float(x), float(y)) for x, y in corners]
    return _camsim.chart(np.ascontiguousarray(raw, dtype=np.uint16), c, cfa, fraction, bits, black_level)


def fit_qe(measured: np.ndarray, predicted: np.ndarray, form: str = "unconstrained") -> Dict[str, Any]:
    """The 3 x 3 QE correction matrix M (the paper's eq. 2) from measured and predicted channel
    responses, (n, 3) each: measured ~ predicted @ M (m[i][j] takes input channel i into output
    channel j). form: "unconstrained", "diagonal" or "paper_lower_non_negative". Returns a dict with
    m, rms_before, rms_after, relative_rms_before/after, residuals_before/after."""
    m = [tuple(map(float, r)) for r in np.asarray(measured, dtype=float)]
    p = [tuple(map(float, r)) for r in np.asarray(predicted, dtype=float)]
    return _camsim.fit_qe(m, p, form)


def emva(bright: np.ndarray, dark: np.ndarray, exposures_s: Sequence[float], *, photons_per_pixel: Optional[Sequence[float]] = None,
         cfa: str = "RGGB", bits: int = 12, black_level: float = 0.0, fit_max_fraction: float = 0.7) -> List[Dict[str, Any]]:
    """EMVA 1288 per colour channel of a raw series: bright and dark frames, (levels, frames,
    rows, cols) uint16 with at least 2 frames per level, the exposure of each level and optionally
    its mean photons per pixel (for QE). Returns one dict per channel (R, G, B): system gain K
    (DN/e-), dark noise, saturation capacity, dynamic range, SNR, the photon-transfer points, ..."""
    b = np.ascontiguousarray(bright, dtype=np.uint16)
    d = np.ascontiguousarray(dark, dtype=np.uint16)
    p = None if photons_per_pixel is None else [float(x) for x in photons_per_pixel]
    return _camsim.emva(b, d, [float(t) for t in exposures_s], p, cfa, bits, black_level, fit_max_fraction)


def emva_series(csv: Union[str, os.PathLike[str]], *, out: Optional[Union[str, os.PathLike[str]]] = None,
                cfa: Optional[str] = None, bits: int = 16, black_level: float = 0.0) -> Dict[str, Any]:
    """EMVA 1288 of a measurement series on disk, as ``camsim analyze emva`` runs it: the series
    CSV (columns exposure_s, optional photons_per_pixel, then bright*/dark* frame files: DNG, or
    PNG/TIFF mosaics described by cfa, bits and black_level). Returns the emva.json record (dict
    with "channels", one per CFA colour). With ``out`` (an existing folder) also writes
    emva.json, ptc.png (photon transfer) and snr.png there."""
    o = None if out is None else os.fspath(out)
    return _camsim.emva_series(os.fspath(csv), o, cfa, bits, black_level)


def emva_simulate(sensor: Union[str, Dict[str, Any]] = "pixel4a", *, levels: int = 24, frames_per_level: int = 8,
                  rows: Optional[int] = None, cols: Optional[int] = None, analog_offset_mv: Optional[float] = None,
                  seed: int = 1) -> Dict[str, Any]:
    """Simulate an EMVA 1288 photon-transfer series, as ``camsim sensor --emva-series`` does: flat
    fields balanced so every colour channel collects 1e5 e-/s, ``levels`` exposures from dark to
    1.3 x saturation, ``frames_per_level`` bright and dark frames each, on a centred rows x cols
    window (default 128 x 128, at most the sensor). sensor: a preset, a sensor TOML path or a dict.
    A sensor whose analog offset is below 5 x its read noise gets 8 x its read noise (dark frames
    must not clip at 0) unless analog_offset_mv is given. Returns a dict: bright and dark (levels,
    frames, rows, cols) uint16, exposures_s and photons_per_pixel per level, cfa, bits,
    black_level and analog_offset_mv, ready for ``emva``."""
    return _camsim.emva_simulate(_path_or(sensor), levels, frames_per_level, rows, cols, analog_offset_mv, seed)


def read_dng(path: Union[str, os.PathLike[str]]) -> Dict[str, Any]:
    """Read a raw DNG: raw (rows, cols) uint16, cfa, black_level, white_level, bits."""
    return _camsim.read_dng(os.fspath(path))


# --- Image-quality metrics and the two-camera comparison -----------------------------------------

def scielab(a_xyz: np.ndarray, b_xyz: np.ndarray, white_xyz: Sequence[float], samples_per_deg: float, *,
            formula: str = "cie76") -> Dict[str, Any]:
    """S-CIELAB (Zhang & Wandell 1997) difference of two (rows, cols, 3) CIE XYZ images viewed at
    samples_per_deg samples per degree; white_xyz is CIELAB's reference white (same units).
    formula: "cie76" (the original), "ciede2000", "cie94" or "cieuv" (CIE 1976 u*v*).
    Returns delta_e (rows, cols), mean, p95, max."""
    a = np.ascontiguousarray(a_xyz, dtype=np.float32)
    b = np.ascontiguousarray(b_xyz, dtype=np.float32)
    w = tuple(float(v) for v in white_xyz)
    return _camsim.scielab(a, b, w, float(samples_per_deg), formula)


def visual_noise(rgb: np.ndarray, region: Optional[Tuple[int, int, int, int]] = None, *,
                 pixels_per_degree: Optional[float] = None, display_height_m: float = 0.1,
                 viewing_distance_m: float = 0.4, encoding: str = "srgb") -> Dict[str, Any]:
    """ISO 15739 visual noise of a uniform patch of a (rows, cols, 3) sRGB picture (code values in
    [0, 1]; encoding="linear" for linear sRGB, white = 1), as ``camsim analyze visual-noise``:
    the patch's opponent channels filtered by the eye's contrast sensitivity at the viewing
    condition (pixels_per_degree, or the whole picture display_height_m high seen from
    viewing_distance_m), then VN = sigma(L*) + 0.852 sigma(u*) + 0.323 sigma(v*).
    region = (row, col, rows, cols); None: the central half in each direction. Returns
    visual_noise, sigma_l_star, sigma_u_star, sigma_v_star, unfiltered_sigma_luv, mean_luv,
    pixels_per_degree, rect, clipped_pixels."""
    img = np.ascontiguousarray(rgb, dtype=np.float32)
    return _camsim.visual_noise(img, region, pixels_per_degree, float(display_height_m), float(viewing_distance_m),
                                encoding)


def snr(image: np.ndarray, roi: Optional[Tuple[int, int, int, int]] = None) -> Dict[str, Any]:
    """SNR of a uniform region of a 2D image: mean, std (n - 1), snr = mean / std, snr_db, n.
    roi = (row, col, rows, cols); None: the whole image."""
    return _camsim.snr(np.ascontiguousarray(image, dtype=np.float32), roi)


def nps(image: np.ndarray, roi: Optional[Tuple[int, int, int, int]] = None, *, roi_px: int = 64, overlap: float = 0.5,
        detrend: str = "mean") -> Dict[str, Any]:
    """Noise power spectrum of a 2D image region: NPS(u, v) = <|DFT(sub-ROI - trend)|^2> / (n n)
    over overlapping roi_px square sub-ROIs (unit: image unit^2 x pixel^2). detrend: "mean" or
    "plane". Returns nps_2d (zero frequency at [n/2, n/2]), freq_cy_per_px, radial_freq_cy_per_px,
    radial_nps, variance (the NPS integral), mean, rois."""
    return _camsim.nps(np.ascontiguousarray(image, dtype=np.float32), roi, roi_px, overlap, detrend)


def acutance(freq_cy_per_px: Sequence[float], sfr: Sequence[float], pixels_per_degree: float) -> Dict[str, Any]:
    """CPIQ acutance of an SFR (frequencies in cycles/pixel) viewed at pixels_per_degree: the SFR
    weighted by the CPIQ contrast sensitivity up to Nyquist. Returns acutance, pixels_per_degree,
    upper_cpd."""
    f = [float(v) for v in np.asarray(freq_cy_per_px, dtype=np.float64).ravel()]
    s = [float(v) for v in np.asarray(sfr, dtype=np.float64).ravel()]
    return _camsim.acutance(f, s, float(pixels_per_degree))


def compare(a: str = "pixel4a", b: str = "imx363", out: Optional[Union[str, os.PathLike[str]]] = None, *,
            lens_a: str = "pixel4a", lens_b: str = "pixel4a", pitch_a_um: Optional[float] = None,
            pitch_b_um: Optional[float] = None, size: int = 128, seed: int = 1) -> Dict[str, Any]:
    """Two cameras side by side (as `camsim compare`): MTF, acutance, SNR, NPS and CIEDE2000 per
    ColorChecker patch of each; a and b are sensor presets or sensor TOML files. With out, also
    writes report.html, results.json and the plots there. Returns results.json as a dict."""
    o = None if out is None else os.fspath(out)
    return _camsim.compare(a, b, o, lens_a, lens_b, pitch_a_um, pitch_b_um, size, seed)
