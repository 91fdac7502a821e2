"""Argument checks shared by the shapes: each raises MeshError naming the argument."""

from __future__ import annotations

import math
import operator
from typing import Any

from .._errors import MeshError


def as_count(name: str, value: Any, minimum: int) -> int:
    """``value`` as an int of at least ``minimum``: anything with ``__index__``
    (floats and strings are refused)."""
    try:
        n = operator.index(value)
    except TypeError:
        raise MeshError(f"{name} must be an integer, got {value!r}") from None
    if n < minimum:
        raise MeshError(f"{name} must be at least {minimum}, got {n}")
    return n


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
