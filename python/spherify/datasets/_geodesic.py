"""The geodesic unit sphere every round shape starts from: an icosahedron whose
faces are cut by a flat triangular lattice, projected onto the sphere."""

from __future__ import annotations

import math

import numpy as np

from ._vectors import Arrays, unit

EDGE = 1.2046   # mean edge of the frequency-nu geodesic unit sphere, times nu


def _icosahedron() -> Arrays:
    """The regular icosahedron on the unit sphere, faces counter-clockwise from outside."""
    g = (1.0 + math.sqrt(5.0)) / 2.0
    V = np.array([(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0),
                  (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
                  (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)], dtype=np.float64)
    F = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
                  (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
                  (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
                  (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)], dtype=np.int64)
    return unit(V), F


def geodesic(nu: int) -> Arrays:
    """Unit geodesic sphere of frequency ``nu``: every icosahedron face cut into
    ``nu**2`` triangles by a flat lattice, then projected onto the sphere.
    10 nu^2 + 2 vertices, 20 nu^2 faces, smallest angle about 50 degrees.

    Points on an icosahedron edge are numbered once per edge (from its lower
    corner), so faces sharing the edge agree without any merging by position.
    """
    C, T = _icosahedron()
    # the 30 edges, each once, numbered by the 20 x 3 face slots (a->b, b->c, c->a)
    start, end = T, np.roll(T, -1, axis=1)
    keys, slot_edge = np.unique(np.minimum(start, end) * 12 + np.maximum(start, end),
                                return_inverse=True)
    slot_edge = slot_edge.reshape(20, 3)
    forward = start < end                       # slot runs from the edge's lower corner
    # lattice of one face: point (i, j) = a + i/nu (b - a) + j/nu (c - a)
    i, j = np.nonzero(np.tri(nu + 1, dtype=bool)[::-1])          # i + j <= nu
    k = nu - i - j
    local = np.full((nu + 2, nu + 2), -1, dtype=np.int64)
    local[i, j] = np.arange(i.size)
    # global id of every lattice point of every face
    gid = np.empty((20, i.size), dtype=np.int64)
    first_inner = 12 + 30 * (nu - 1)
    inner = (i > 0) & (j > 0) & (k > 0)
    n_inner = int(inner.sum())
    gid[:, inner] = first_inner + np.arange(20)[:, None] * n_inner + np.arange(n_inner)
    for corner, at in enumerate([(i == 0) & (j == 0), i == nu, j == nu]):
        gid[:, at] = T[:, corner, None]
    # slot s holds the points where the weight of the opposite corner is zero;
    # p counts lattice steps from the slot's start corner
    for s, (on, p) in enumerate([((j == 0) & (i > 0) & (i < nu), i),
                                 ((k == 0) & (j > 0) & (j < nu), j),
                                 ((i == 0) & (j > 0) & (j < nu), nu - j)]):
        t = np.where(forward[:, s, None], p[on], nu - p[on])
        gid[:, on] = 12 + slot_edge[:, s, None] * (nu - 1) + t - 1
    # positions: corners, edge points, then inner points, in id order
    w = np.arange(1, nu) / nu
    a, b = C[keys // 12], C[keys % 12]
    on_edges = (1 - w)[None, :, None] * a[:, None] + w[None, :, None] * b[:, None]
    wi = np.stack([k[inner], i[inner], j[inner]], axis=1) / nu
    on_faces = wi @ C[T]                                           # (20, inner, 3)
    V = unit(np.concatenate([C, on_edges.reshape(-1, 3), on_faces.reshape(-1, 3)]))
    # triangles pointing like the face, then those pointing the other way
    up = i + j <= nu - 1
    down = i + j <= nu - 2
    tri = np.concatenate([
        np.stack([local[i[up], j[up]], local[i[up] + 1, j[up]], local[i[up], j[up] + 1]], 1),
        np.stack([local[i[down] + 1, j[down]], local[i[down] + 1, j[down] + 1],
                  local[i[down], j[down] + 1]], 1)])
    F = gid[:, tri].reshape(-1, 3)
    return V, F


def nearest_frequency(n_vertices: int) -> int:
    """The frequency whose geodesic sphere (10 nu^2 + 2 vertices) comes nearest
    ``n_vertices``."""
    nu = max(1, round(math.sqrt(max(n_vertices - 2, 0) / 10.0)))
    return min((q for q in (nu - 1, nu, nu + 1) if q >= 1),
               key=lambda q: abs(10 * q * q + 2 - n_vertices))
