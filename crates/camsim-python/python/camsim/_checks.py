"""The plain Python values handed to camsim as JSON (config and spec dicts), checked first so a
value JSON or camsim cannot hold is refused naming its key: NaN and infinities (JSON has none;
``json.dumps`` would write a token camsim's parser refuses at "line 1 column N"), and integers
outside 64 bits (seeds are unsigned 64-bit; a larger one reaches the parser as a float)."""

from __future__ import annotations

import math
from typing import Any, Type


def check_values(value: Any, what: str, error: Type[Exception] = ValueError) -> None:
    """Raise ``error`` naming ``what`` and the dotted key of the first value in ``value`` that is
    not a finite number or does not fit 64 bits."""

    def walk(v: Any, key: str) -> None:
        where = f"{what}: {key}" if key else what
        if isinstance(v, bool) or v is None or isinstance(v, str):
            return
        if isinstance(v, float):
            if not math.isfinite(v):
                raise error(f"{where} = {v}: not a finite number; give a finite value")
        elif isinstance(v, int):
            if not -(2**63) <= v < 2**64:
                raise error(
                    f"{where} = {v}: does not fit the 64-bit integers camsim reads "
                    f"(-2**63 .. 2**64 - 1)"
                )
        elif isinstance(v, dict):
            for k, x in v.items():
                walk(x, f"{key}.{k}" if key else str(k))
        elif isinstance(v, (list, tuple)):
            for i, x in enumerate(v):
                walk(x, f"{key}[{i}]")

    walk(value, "")
