"""Farthest-point sampling: k well-spread vertices, for landmarks in tests,
benches and examples (and for users who pick landmarks the same way)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._args import integer
from .._errors import MeshError

__all__ = ["farthest_points"]


def farthest_points(points: npt.ArrayLike, k: int) -> np.ndarray:
    """``k`` indices into ``points``, each the farthest (in straight-line
    distance) from those already chosen, starting at index 0.

    On unit vectors (a sphere map's points) the straight-line distance orders
    points as the angle does, so this is farthest-point sampling on the
    sphere too. O(k n).

    Parameters
    ----------
    points : (n, 3) float
        Surface vertices or sphere points.
    k : int
        How many, 1..n.

    Returns
    -------
    (k,) int64

    Raises
    ------
    MeshError
        ``points`` not (n, 3) finite numbers, or ``k`` outside 1..n.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0 or not np.isfinite(p).all():
        raise MeshError(f"points must be (n, 3) finite numbers, got shape {p.shape}")
    k = integer(k, "k", 1, len(p))
    chosen = [0]
    distance = np.linalg.norm(p - p[0], axis=1)
    for _ in range(k - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(p - p[chosen[-1]], axis=1))
    return np.array(chosen, dtype=np.int64)
