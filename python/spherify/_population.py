"""Populations: many shapes registered to one and resampled on one connectivity.

``correspond(maps)`` registers every map to the reference's
(:func:`spherify.register`), then reads every shape's surface at the same
sphere points: the vertices of an icosphere (``level``), or the reference's
own vertices (``level="reference"``). Point ``j`` of every shape is then the
same place on every shape, so the shapes can be averaged and their variation
analysed: generalised Procrustes alignment (Gower 1975: every shape centred,
scaled to unit rms radius and turned onto the running mean until the mean
settles) and principal components of the aligned shapes, the
point-distribution model of SPHARM-PDM (Styner et al. 2006) and ShapeWorks.

Each registration is independent of the others and runs as one task: in
this process, or on any ``concurrent.futures`` executor or Dask client.
"""

from __future__ import annotations

import time
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _align
from ._errors import MapError, MeshError
from ._mesh import Mesh
from ._progress import as_callback
from ._register import TRANSFORMS, check_memory, register
from ._spheremap import SphereMap

__all__ = ["Population", "correspond"]

PROCRUSTES_ROUNDS = 20


class Population:
    """Shapes on one connectivity, aligned in space.

    All attributes are read-only.

    Attributes
    ----------
    points : (shapes, points, 3) float64
        Every shape at the common sphere points, centred, at unit rms radius
        and turned onto the mean (generalised Procrustes).
    faces : (m, 3) int64
        The common connectivity.
    scales : (shapes,) float64
        Each shape's rms radius before scaling.
    residuals : list of dict
        Each registration's ``residual`` (see :class:`Correspondence`).
    seconds : dict
        ``register`` (summed over shapes, as the tasks reported it),
        ``procrustes`` and ``total`` (wall time).
    reference : int
        The index of the reference shape.
    """

    def __init__(self, points: np.ndarray, faces: np.ndarray, scales: np.ndarray,
                 residuals: List[Dict[str, float]], seconds: Dict[str, float],
                 reference: int) -> None:
        for array in (points, faces, scales):
            array.flags.writeable = False
        self._points = points
        self._faces = faces
        self._scales = scales
        self._residuals = residuals
        self._seconds = seconds
        self._reference = reference

    @property
    def points(self) -> np.ndarray:
        """(shapes, points, 3) float64: every shape at the common sphere points, aligned."""
        return self._points

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64: the common connectivity."""
        return self._faces

    @property
    def scales(self) -> np.ndarray:
        """(shapes,) float64: each shape's rms radius before scaling."""
        return self._scales

    @property
    def residuals(self) -> List[Dict[str, float]]:
        """Each registration's ``residual`` (see :class:`Correspondence`)."""
        return [dict(r) for r in self._residuals]

    @property
    def seconds(self) -> Dict[str, float]:
        """``register`` (summed over shapes), ``procrustes`` and ``total`` (wall time)."""
        return dict(self._seconds)

    @property
    def reference(self) -> int:
        """The index of the reference shape."""
        return self._reference

    def __len__(self) -> int:
        return len(self._points)

    def shape(self, i: int) -> Mesh:
        """Shape ``i`` as a mesh on the common connectivity."""
        return Mesh(self._points[i], self._faces)

    def mean(self) -> Mesh:
        """The mean shape (the average of the aligned shapes)."""
        return Mesh(self._points.mean(axis=0), self._faces)

    def modes(self, k: int) -> Tuple[np.ndarray, np.ndarray]:
        """The ``k`` principal modes of variation about the mean.

        Parameters
        ----------
        k : int
            How many modes, 1..shapes-1.

        Returns
        -------
        variances : (k,) float64
            The variance along each mode, largest first.
        modes : (k, points, 3) float64
            Unit modes: ``mean + t * sqrt(variance) * mode`` is the shape ``t``
            standard deviations along it.

        Raises
        ------
        MeshError
            ``k`` outside 1..shapes-1.
        """
        shapes = len(self._points)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= shapes - 1:
            raise MeshError(f"k must be an integer in 1..{shapes - 1} (shapes - 1), got {k!r}")
        flat = self._points.reshape(shapes, -1)
        centred = flat - flat.mean(axis=0)
        # The small (shapes x shapes) Gram matrix instead of the large covariance.
        _, s, vt = np.linalg.svd(centred, full_matrices=False)
        variances = (s[:k] ** 2) / max(shapes - 1, 1)
        return variances, vt[:k].reshape(k, -1, 3)

    def __repr__(self) -> str:
        return (f"Population(shapes={len(self._points)}, points={self._points.shape[1]}, "
                f"reference={self._reference})")


def _sample_points(reference: SphereMap, level: Union[int, str]) -> Tuple[np.ndarray, np.ndarray]:
    if level == "reference":
        return reference.points, reference.mesh.faces
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= level <= 8:
        raise MeshError(f"level must be an icosphere level 0..8 or 'reference', got {level!r}")
    from .datasets import icosphere
    grid = icosphere(subdivisions=int(level))
    return grid.vertices, grid.faces


def register_task(m: SphereMap, reference: SphereMap, pairs: Optional[np.ndarray],
                  transform: str, samples: np.ndarray, is_reference: bool = False
                  ) -> Tuple[np.ndarray, Dict[str, float], float]:
    """One shape's task: register it to the reference and read its surface
    at ``samples`` (sphere points of the reference's frame). A module-level
    function, so that process executors and Dask can pickle it."""
    started = time.perf_counter()
    if is_reference:
        _, _, xyz = reference.to_surface(samples)
        return xyz, {"rms": 0.0, "max": 0.0}, time.perf_counter() - started
    c = register(m, reference, landmarks=pairs, transform=transform)
    _, _, xyz = c.map_a.to_surface(samples)
    return xyz, c.residual, time.perf_counter() - started


def _procrustes(shapes: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    centred = shapes - shapes.mean(axis=1, keepdims=True)
    scales = np.sqrt((centred ** 2).sum(axis=2).mean(axis=1))
    unit = centred / np.where(scales > 0, scales, 1.0)[:, None, None]
    mean = unit[0]
    for _ in range(PROCRUSTES_ROUNDS):
        unit = np.stack([x @ _align.kabsch(x, mean).T for x in unit])
        new = unit.mean(axis=0)
        new /= np.sqrt((new ** 2).sum(axis=1).mean()) or 1.0
        settled = np.abs(new - mean).max() < 1e-12
        mean = new
        if settled:
            break
    return unit, scales


def _landmark_table(landmarks: Any, maps: Sequence[SphereMap]) -> Optional[np.ndarray]:
    if landmarks is None:
        return None
    try:
        table = np.asarray(landmarks)
    except (TypeError, ValueError) as err:
        raise MeshError(f"landmarks must be a (shapes, k) table of vertex ids: {err}") from None
    if table.ndim != 2 or len(table) != len(maps) or table.dtype.kind not in "iu":
        raise MeshError("landmarks must be a (shapes, k) integer table, one row of vertex ids "
                        f"per shape ({len(maps)} rows), got shape {table.shape}")
    for i, (row, m) in enumerate(zip(table, maps)):
        bad = np.flatnonzero((row < 0) | (row >= len(m.points)))
        if len(bad):
            raise MeshError(f"landmarks of shape {i}: vertex {int(row[bad[0]])} is out of range "
                            f"0..{len(m.points) - 1}")
    return table.astype(np.int64)


def correspond(maps: Sequence[SphereMap], *, reference: int = 0, landmarks: Any = None,
               level: Union[int, str] = 6, transform: str = "warp", executor: Any = None,
               progress: Any = None) -> Population:
    """Register every shape to the reference and resample all on one connectivity.

    Parameters
    ----------
    maps : sequence of SphereMap
        Certified maps of the shapes, all by one method.
    reference : int
        Index of the shape the others are registered to.
    landmarks : (shapes, k) int, optional
        Row ``i`` holds shape ``i``'s vertex ids of the k landmarks, in the
        same order for every shape; with ``"warp"`` they meet exactly.
    level : int or "reference"
        The common connectivity: the icosphere of this level (0..8;
        ``10 * 4**level + 2`` points), or ``"reference"``, the reference's mesh.
    transform : str
        ``"rotation"``, ``"moebius"`` or ``"warp"`` (default), as in
        :func:`spherify.register`.
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Runs the registrations (each one task, anything with ``submit``);
        by default they run in this process, one after another (each uses
        the cores through the core's threads).
    progress : bool or callable, optional
        ``True`` draws a bar on stderr; a callable gets ``(done, total)`` per
        registered shape.

    Returns
    -------
    Population

    Raises
    ------
    MeshError
        Fewer than two maps, not SphereMaps, ``reference`` or ``level`` out of
        range, a bad landmark table, unknown ``transform``.
    MapError
        A map that is not certified, or maps by different methods.
    ResourceError
        The registrations and the population cannot fit in the memory the
        process can still get (docs/reliability.md, "Memory"); raised before
        the first registration.
    """
    started = time.perf_counter()
    maps = list(maps)
    if len(maps) < 2:
        raise MeshError(f"correspond needs at least two maps, got {len(maps)}")
    for i, m in enumerate(maps):
        if not isinstance(m, SphereMap):
            raise MeshError(f"maps[{i}] is not a SphereMap but {type(m).__name__}")
        if not m.valid:
            raise MapError(f"maps[{i}] is not a certified bijection ({m.flipped} flipped faces)")
    methods = sorted({m.method for m in maps})
    if len(methods) > 1:
        raise MapError(f"the maps come from different methods ({', '.join(methods)}); a "
                       "population is mapped with one method")
    if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) \
            or not 0 <= reference < len(maps):
        raise MeshError(f"reference must be an index in 0..{len(maps) - 1}, got {reference!r}")
    if transform not in TRANSFORMS:
        raise MeshError(f"unknown transform {transform!r}; choose one of {', '.join(TRANSFORMS)}")
    table = _landmark_table(landmarks, maps)
    ref = maps[reference]
    samples, faces = _sample_points(ref, level)
    # The largest registration to the reference, and every shape's samples
    # (the grid of level 8 is 655,362 points: small beside them).
    largest = max((m for i, m in enumerate(maps) if i != reference),
                  key=lambda m: m.mesh.n_vertices)
    check_memory("correspond", largest, ref, len(maps) * len(samples))
    report = as_callback(progress, "correspond")

    def pairs_of(i: int) -> Optional[np.ndarray]:
        if table is None:
            return None
        return np.stack([table[i], table[reference]], axis=1)

    results: List[Optional[Tuple[np.ndarray, Dict[str, float], float]]] = [None] * len(maps)
    results[reference] = register_task(ref, ref, None, transform, samples, is_reference=True)
    others = [i for i in range(len(maps)) if i != reference]
    if executor is None:
        for done, i in enumerate(others, start=1):
            results[i] = register_task(maps[i], ref, pairs_of(i), transform, samples)
            if report:
                report(done, len(others))
    else:
        futures = [executor.submit(register_task, maps[i], ref, pairs_of(i), transform, samples)
                   for i in others]
        for done, (i, future) in enumerate(zip(others, futures), start=1):
            results[i] = future.result()
            if report:
                report(done, len(others))
    finished = [r for r in results if r is not None]
    registered = sum(r[2] for r in finished)
    aligning = time.perf_counter()
    points, scales = _procrustes(np.stack([r[0] for r in finished]))
    seconds = {"register": registered, "procrustes": time.perf_counter() - aligning,
               "total": time.perf_counter() - started}
    return Population(points, np.array(faces, dtype=np.int64), scales,
                      [r[1] for r in finished], seconds, int(reference))
