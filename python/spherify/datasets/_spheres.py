"""Round shapes made from one geodesic sphere: the icosphere, the ellipsoid and
the bumpy blob."""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .._errors import MeshError
from .._mesh import Mesh
from .._args import integer
from ._checks import as_positive, shape_size
from ._geodesic import geodesic, nearest_frequency
from ._guarantees import shape
from ._vectors import unit


@shape
def icosphere(n_vertices: Optional[int] = None, *, subdivisions: Optional[int] = None) -> Mesh:
    """The geodesic unit sphere: about ``n_vertices`` vertices, like every other
    shape, or exactly the icosahedron subdivided ``subdivisions`` times.

    Parameters
    ----------
    n_vertices : int, optional
        Target vertex count (at least 1): the geodesic sphere of the nearest
        frequency ``nu``, ``10 nu**2 + 2`` vertices. With neither argument,
        642 vertices (``subdivisions=3``).
    subdivisions : int, optional, keyword only
        ``k`` in 0..10 instead of ``n_vertices``: the frequency ``2**k``,
        ``10 * 4**k + 2`` vertices, the connectivity of ``k`` rounds of
        midpoint subdivision of the icosahedron.

    Returns
    -------
    Mesh
        ``vertices`` (10 nu**2 + 2, 3) float64, all on the unit sphere;
        ``faces`` (20 nu**2, 3) int64. Smallest triangle angle about 50 degrees.

    Raises
    ------
    MeshError
        Both arguments given, ``n_vertices`` below 1, or ``subdivisions`` not
        an integer in 0..10.

    Notes
    -----
    Each face of the icosahedron is cut by a flat lattice of frequency ``nu``
    and its points are projected onto the sphere (a class-I geodesic sphere).
    Cost O(n).
    """
    if n_vertices is not None and subdivisions is not None:
        raise MeshError("icosphere takes n_vertices or subdivisions, not both")
    if n_vertices is not None:
        return Mesh(*geodesic(nearest_frequency(shape_size(n_vertices, "icosphere"))))
    k = 3 if subdivisions is None else integer(subdivisions, "subdivisions", 0)
    if k > 10:
        raise MeshError(f"subdivisions must be at most 10 (10 * 4**10 + 2 vertices), got {k}")
    shape_size(10 * 4**k + 2, "icosphere")
    return Mesh(*geodesic(2 ** k))


@shape
def ellipsoid(n_vertices: int = 2000, axes: Sequence[float] = (1.0, 0.6, 0.4)) -> Mesh:
    """An ellipsoid centred at the origin with semi-axes ``axes`` along x, y, z.

    Parameters
    ----------
    n_vertices : int, default 2000
        Target vertex count (at least 1).
    axes : sequence of 3 positive floats, default (1.0, 0.6, 0.4)

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64, where
        ``n = 10 nu**2 + 2`` for the frequency ``nu`` that comes nearest the
        target: within 9% of it for targets of 1,000 or more, 21% from 140, 28%
        from 100. Smallest angle about 26 degrees for the default axes (lower
        for longer, thinner ellipsoids: 4 degrees for axes (3, 0.2, 0.2)).

    Raises
    ------
    MeshError
        ``n_vertices`` below 1 or not an integer; ``axes`` not three positive numbers.

    Notes
    -----
    A geodesic unit sphere scaled by ``axes``. Cost O(n).
    """
    n = shape_size(n_vertices, "ellipsoid")
    if len(axes) != 3:
        raise MeshError(f"axes must hold three semi-axis lengths, got {axes!r}")
    scale = np.array([as_positive("axes", x) for x in axes])
    V, F = geodesic(nearest_frequency(n))
    return Mesh(V * scale, F)


@shape
def bumpy_blob(n_vertices: int = 5000, bumps: int = 12, amplitude: float = 0.25,
               seed: int = 0) -> Mesh:
    """A lumpy sphere, star-shaped from the origin.

    Parameters
    ----------
    n_vertices : int, default 5000
        Target vertex count (at least 1); met as for :func:`ellipsoid`.
    bumps : int, default 12
        Number of smooth bumps (and a few dents) at random places.
    amplitude : float, default 0.25
        Height of the largest bump, relative to the unit radius.
    seed : int, default 0
        Seed of the random bump placement, height and width.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64 with
        ``n = 10 nu**2 + 2`` as for :func:`ellipsoid`. Smallest angle above 35
        degrees for the defaults (any seed).

    Raises
    ------
    MeshError
        A count below its minimum or not an integer; ``amplitude`` negative or so
        large that dents reach the centre.

    Notes
    -----
    Each vertex of a geodesic unit sphere moves along its ray to radius
    ``1 + amplitude * sum_i a_i exp(k_i (x . c_i - 1))``. A radial move keeps
    every triangle facing the origin, so the result is embedded and every ray
    from the origin crosses it once. Cost O(n * bumps).
    """
    n = shape_size(n_vertices, "bumpy_blob")
    n_bumps = integer(bumps, "bumps", 0)
    height = as_positive("amplitude", amplitude, allow_zero=True)
    V, F = geodesic(nearest_frequency(n))
    rng = np.random.default_rng(seed)
    centres = unit(rng.normal(size=(n_bumps, 3)))
    # about a quarter dents (60% as deep), the rest bumps
    heights = rng.uniform(0.5, 1.0, n_bumps) * np.where(rng.random(n_bumps) < 0.25, -0.6, 1.0)
    sharpness = rng.uniform(15.0, 40.0, n_bumps)    # von Mises-Fisher: width ~ 1/sqrt(k) rad
    r = np.ones(len(V))
    for c, a, kappa in zip(centres, heights, sharpness):   # one pass per bump: no n x bumps array
        r += height * a * np.exp(kappa * (V @ c - 1.0))
    if r.min() < 0.1:
        raise MeshError(f"amplitude {height} pushes dents through the centre; use a smaller one")
    # scaling each vertex along its own ray keeps every triangle's orientation as
    # seen from the origin, so the surface stays embedded and star-shaped
    return Mesh(V * r[:, None], F)
