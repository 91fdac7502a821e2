"""Argument checks shared by the shapes: each raises MeshError naming the argument.
Integer arguments go through the package's one checker, ``_args.integer``."""

from __future__ import annotations

import math
from typing import Any

from .._errors import MeshError


def as_positive(name: str, value: Any, allow_zero: bool = False) -> float:
    """``value`` as a finite float above zero (or at zero, if allowed)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and (x > 0.0 or (allow_zero and x == 0.0))):
        raise MeshError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} "
                        f"finite number, got {value!r}")
    return x
