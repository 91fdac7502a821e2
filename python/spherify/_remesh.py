"""Remeshing through a sphere map (thesis 8.1): a semi-regular mesh with the
connectivity of a subdivided icosahedron, each vertex placed where the map
sends the icosphere's vertex; and the distance between two surfaces that
share the sphere.

    r = sp.remesh(m, "icosphere", level=5)     # Mesh: 10 * 4**5 + 2 vertices
    sp.surface_distance(m, sp.remesh_map(m, level=5))
"""

from __future__ import annotations

from typing import Any, Dict

import numpy as np

from . import _args, _core, datasets
from ._limits import DISTANCE_SAMPLES_MAX, REMESH_LEVEL_MAX
from ._errors import MeshError
from ._mesh import Mesh
from ._progress import to_surface_in_chunks
from ._spheremap import SphereMap

__all__ = ["remesh", "remesh_map", "surface_distance"]

KINDS = ("icosphere",)

#: Random points per chunk of :func:`surface_distance`.
_CHUNK = 1 << 20


def _level(level: object) -> int:
    return _args.integer(level, "level", 0, REMESH_LEVEL_MAX)


def remesh_map(m: SphereMap, kind: str = "icosphere", *, level: int = 4,
               progress: Any = None) -> SphereMap:
    """The remeshed surface with its own map: the icosphere's vertices.

    Each vertex of ``sp.datasets.icosphere(subdivisions=level)`` (a point of the unit
    sphere) is sent to the surface by ``m.to_surface``; the result keeps the
    icosphere's faces, and its map is certified in the core
    (:meth:`SphereMap.from_points` of the icosphere's own vertices, always
    valid). O(4**level log F).

    Parameters
    ----------
    m : SphereMap
        A certified map (``valid``, or ``tp_valid`` for theta-phi).
    kind : str
        ``"icosphere"`` (the subdivided icosahedron of 8.1).
    level : int
        Subdivisions of the icosahedron, 0..9 (``10 * 4**level + 2`` vertices;
        the bound is :data:`spherify._limits.REMESH_LEVEL_MAX`).
    progress : bool or callable, optional
        ``True`` draws a bar on stderr, a callable receives ``(done, total)``
        (points located so far), as for :func:`spherify.embed`.

    Returns
    -------
    SphereMap
        The remeshed surface (``.mesh``) and its map.

    Raises
    ------
    MapError
        ``m`` is not a certified bijection.
    MeshError
        Unknown ``kind`` or a bad ``level``.
    ResourceError
        The remeshed surface cannot fit in the memory the process can still
        get (docs/reliability.md, "Memory"); raised before it is made.
    """
    if kind not in KINDS:
        raise MeshError(f"unknown remesh kind {kind!r}; available: {', '.join(KINDS)}")
    level = _level(level)
    # The memory policy before the icosphere is made: its vertices, their
    # located surface points and the new map's certificate, per output vertex.
    _core.check_application("remesh", m.mesh.n_vertices, m.mesh.n_faces, 10 * 4 ** level + 2)
    ico = datasets.icosphere(subdivisions=level)
    _, _, xyz = to_surface_in_chunks(m, ico.vertices, progress, "remesh")
    return SphereMap.from_points(Mesh(xyz, ico.faces), ico.vertices)


def remesh(m: SphereMap, kind: str = "icosphere", *, level: int = 4,
           progress: Any = None) -> Mesh:
    """A semi-regular mesh of ``m``'s surface (thesis 8.1): the connectivity
    of ``sp.datasets.icosphere(subdivisions=level)``, each vertex at ``m.to_surface`` of the
    icosphere's vertex. See :func:`remesh_map` (which also returns its map).

    Parameters
    ----------
    m : SphereMap
        A certified map (``valid``, or ``tp_valid`` for theta-phi).
    kind : str
        ``"icosphere"`` (the subdivided icosahedron of 8.1).
    level : int
        Subdivisions of the icosahedron, 0..10.
    progress : bool or callable, optional
        ``True`` draws a bar on stderr, a callable receives ``(done, total)``
        (points located so far), as for :func:`spherify.embed`.

    Returns
    -------
    Mesh
        ``vertices`` (10 * 4**level + 2, 3) float64, ``faces`` (20 * 4**level, 3),
        counter-clockwise seen from outside when ``m``'s surface is.
    """
    return remesh_map(m, kind, level=level, progress=progress).mesh


def surface_distance(a: SphereMap, b: SphereMap, *, samples: int = 100_000,
                     seed: int = 0) -> Dict[str, float]:
    """How far apart two surfaces mapped onto the same sphere are.

    At ``samples`` uniformly random sphere points, and at the images of both
    meshes' vertices, both surfaces are read through their maps
    (``to_surface``); the distances between the pairs are reported relative
    to the diagonal of ``a``'s bounding box. Since every pair is one point of
    each surface, ``max`` bounds the two-sided (Hausdorff) distance from above;
    it is the distance of the correspondence the maps define. O(k log F).

    Returns
    -------
    dict
        ``max``, ``rms`` (relative), ``diagonal`` (the length they are relative
        to) and ``samples`` (pairs compared).

    Raises
    ------
    MapError
        Either map is not a certified bijection.
    """
    samples = _args.integer(samples, "samples", 0, DISTANCE_SAMPLES_MAX)
    rng = np.random.default_rng(seed)
    diagonal = float(np.linalg.norm(np.ptp(a.mesh.vertices, axis=0)))
    largest, squares = 0.0, 0.0

    def compare(points: np.ndarray) -> None:
        nonlocal largest, squares
        _, _, xa = a.to_surface(points)
        _, _, xb = b.to_surface(points)
        d = np.linalg.norm(xa - xb, axis=1) / diagonal
        if len(d):
            largest = max(largest, float(d.max()))
            squares += float(np.dot(d, d))

    # The random points in chunks (the same stream as one draw): memory stays
    # bounded at any ``samples``, and Ctrl-C is answered between chunks.
    left = int(samples)
    while left > 0:
        p = rng.normal(size=(min(left, _CHUNK), 3))
        p /= np.linalg.norm(p, axis=1)[:, None]
        compare(p)
        left -= len(p)
    compare(np.asarray(a.points, dtype=np.float64))
    compare(np.asarray(b.points, dtype=np.float64))
    count = int(samples) + len(a.points) + len(b.points)
    return {"max": largest, "rms": float(np.sqrt(squares / count)),
            "diagonal": diagonal, "samples": float(count)}
