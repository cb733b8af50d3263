"""Presets as plain dicts (edit them and pass them back to simulate, optics, sensor), and every
name camsim knows (the catalogue `camsim presets` lists)."""

from typing import Any, Dict, List

from . import _camsim


def simulate() -> Dict[str, Any]:
    """The built-in default simulate config (a Macbeth chart under D65, the Pixel 4a camera)."""
    return _camsim.preset("simulate")


def sensor(name: str = "pixel4a") -> Dict[str, Any]:
    """A sensor preset (names()["sensor presets"]: "pixel4a", "imx363", ...) as a dict (every
    field of a sensor TOML)."""
    return _camsim.preset("sensor", name)


def lens(name: str = "pixel4a") -> Dict[str, Any]:
    """A lens preset (names()["lens presets"]: "pixel4a", "pixel4a-measured",
    "diffraction-limited") as a dict (every field of a lens TOML)."""
    return _camsim.preset("lens", name)


def names() -> Dict[str, List[str]]:
    """Every family of names camsim takes (sensor and lens presets, 3D scenes, 2D scene kinds,
    demosaic and white-balance methods, colour filter arrays, outputs, dataset outputs): {family:
    [names]}, from the tables camsim dispatches on."""
    return _camsim.names()
