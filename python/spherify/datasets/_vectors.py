"""The array types and small vector helpers the shapes share."""

from __future__ import annotations

from typing import Tuple

import numpy as np
import numpy.typing as npt

Floats = npt.NDArray[np.float64]
Ints = npt.NDArray[np.int64]
Arrays = Tuple[Floats, Ints]     # vertices (n, 3), faces (m, 3)


def unit(x: Floats) -> Floats:
    """The rows of ``x`` scaled to length 1."""
    out: Floats = x / np.linalg.norm(x, axis=-1, keepdims=True)
    return out


def perpendicular(d: Floats) -> Floats:
    """A unit vector perpendicular to the unit vector ``d``."""
    helper = np.eye(3)[np.argmin(np.abs(d))]
    return unit(np.cross(d, helper))
