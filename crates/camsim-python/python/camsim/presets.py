"""Presets as plain dicts: edit them and pass them back (to simulate, optics, sensor)."""

import json
from typing import Any, Dict

from . import _camsim


def simulate() -> Dict[str, Any]:
    """The built-in default simulate config (a Macbeth chart under D65, the Pixel 4a camera)."""
    return json.loads(_camsim.preset_json("simulate"))


def sensor(name: str = "pixel4a") -> Dict[str, Any]:
    """A sensor preset ("pixel4a", "imx363", ...) as a dict (every field of a sensor TOML)."""
    return json.loads(_camsim.preset_json("sensor", name))


def lens(name: str = "pixel4a") -> Dict[str, Any]:
    """A lens preset ("pixel4a", "pixel4a-measured", "diffraction-limited") as a dict (every field of a lens TOML)."""
    return json.loads(_camsim.preset_json("lens", name))
