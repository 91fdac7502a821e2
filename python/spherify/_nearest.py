"""Closest points on a triangle mesh's surface (registration's ICP).

:class:`NearestOnSurface` answers "which point of this surface is nearest to
each query point?" through the core's tree of the triangles' boxes
(``crates/mesh/src/closest_point.rs``: branch and bound over a median-split
box tree, Ericson's closest point of a triangle). The answer is the exact
closest point of the whole surface. It replaced a numpy search (a grid for the
nearest vertex, then the faces around it) that was a third of the warp's
time and could miss the closest face by a fraction of an edge.
"""

from __future__ import annotations

import threading
from typing import Callable, Optional, Tuple

import numpy as np

from . import _core

__all__ = ["NearestOnSurface", "OnDemand"]


class NearestOnSurface:
    """Closest points of one triangle mesh's surface to many query points.

    Build once per mesh (O(m log m) for m faces); each :meth:`__call__` is
    about O(q log m) for q queries near the surface, in parallel.

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        self._tree = _core.CoreClosestPoints(self.vertices, self.faces)

    def __call__(self, queries: np.ndarray, hints: Optional[np.ndarray] = None
                 ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest surface points: (face ids (q,), barycentric weights (q, 3),
        points (q, 3)). ``hints`` (q,) int64, if given, are faces an earlier
        call answered for nearby queries (an ICP's previous iteration): the
        search starts from a bound just above their distances, which only
        makes it faster (the same answers, ``closest_point.rs``)."""
        points = np.ascontiguousarray(queries, dtype=np.float64)
        if hints is None:
            return self._tree.closest(points)
        return self._tree.closest(points, np.ascontiguousarray(hints, dtype=np.int64))


class OnDemand:
    """A :class:`NearestOnSurface` built at most once, by whichever caller
    asks first (later callers, on any thread, get the same tree).

    Registration searches B's surface, centred and scaled to unit rms
    radius, in the rotation's check in space (:mod:`spherify._rigid_icp`)
    and again in the warp (:mod:`spherify._warp`): one tree serves both.

    Parameters
    ----------
    vertices : callable returning (n, 3) float64
        Called once, when the tree is first asked for.
    faces : (m, 3) int64
    """

    def __init__(self, vertices: Callable[[], np.ndarray], faces: np.ndarray) -> None:
        self._vertices = vertices
        self._faces = faces
        self._lock = threading.Lock()
        self._tree: Optional[NearestOnSurface] = None

    def __call__(self) -> NearestOnSurface:
        with self._lock:
            if self._tree is None:
                self._tree = NearestOnSurface(self._vertices(), self._faces)
            return self._tree
