"""Procedural genus-0 shapes for tests, docs, benches and the demo.

Every shape is a closed, connected, manifold triangle mesh of genus 0, faces
counter-clockwise seen from outside (positive signed volume), free of
self-intersections, degenerate triangles and coincident vertices, at every size.
The same arguments give the same arrays, bit for bit. Only numpy is used and
all the work is vectorised; 2,000,000 vertices take a second or two.

The modules hold, in order of dependence: ``_geodesic`` (the geodesic unit
sphere), ``_spheres`` (icosphere, ellipsoid, bumpy blob), ``_tubes`` (rings,
bands, caps and tube sizing), ``_helix`` (helix tube), ``_arms`` (a body with
holes and the arms joined to them), ``_urchin`` and ``_tentacles``;
``_pairs`` makes a deformed copy of a mapped shape with the true
correspondence, to measure registration.
"""

from __future__ import annotations

from typing import Any, Callable, Dict, List

from .._errors import MeshError
from .._mesh import Mesh
from ._helix import helix_tube
from ._pairs import DeformedCopy, deformed_copy
from ._sampling import farthest_points
from ._spheres import bumpy_blob, ellipsoid, icosphere
from ._tentacles import tentacles
from ._textures import checkerboard, lat_long_grid
from ._urchin import urchin

__all__ = ["DeformedCopy", "bumpy_blob", "checkerboard", "deformed_copy", "ellipsoid", "farthest_points", "helix_tube", "icosphere", "lat_long_grid",
           "make", "names", "tentacles", "urchin"]

# make's shapes, simplest first
_SHAPES: Dict[str, Callable[..., Mesh]] = {
    "icosphere": icosphere,
    "ellipsoid": ellipsoid,
    "bumpy_blob": bumpy_blob,
    "helix_tube": helix_tube,
    "urchin": urchin,
    "tentacles": tentacles,
}


def names() -> List[str]:
    """Names of the shapes :func:`make` knows, in a fixed order (simplest first).

    Returns
    -------
    list of str
    """
    return list(_SHAPES)


def make(name: str, n_vertices: int, **kwargs: Any) -> Mesh:
    """Make the shape ``name`` with about ``n_vertices`` vertices.

    Parameters
    ----------
    name : str
        One of :func:`names`.
    n_vertices : int
        Target vertex count, passed on to the shape (``"icosphere"``: the
        geodesic unit sphere of the nearest frequency ``nu``, ``10 nu**2 + 2``
        vertices).
    **kwargs
        The shape's other keyword arguments.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64, ``faces`` (2n - 4, 3) int64.

    Raises
    ------
    MeshError
        Unknown ``name``, or arguments the shape rejects.
    TypeError
        A keyword argument the shape does not take.

    Examples
    --------
    >>> import spherify as sp
    >>> meshes = [sp.datasets.make(name, 1000) for name in sp.datasets.names()]
    """
    try:
        build = _SHAPES[name]
    except (KeyError, TypeError):
        raise MeshError(f"unknown dataset {name!r}; choose one of {', '.join(_SHAPES)}") from None
    return build(n_vertices, **kwargs)


def __dir__() -> List[str]:
    """Only the public names (PEP 562): dir() lists what __all__ does."""
    return sorted(__all__)
