"""Closest points on a mesh's surface (spherify._nearest), against brute force."""

from __future__ import annotations

import numpy as np

import spherify as sp
from spherify._nearest import NearestOnSurface, closest_on_triangles


def brute_force(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The distance from each point to the nearest face, trying every face."""
    best = np.full(len(points), np.inf)
    for face in faces:
        corners = vertices[face]
        k = len(points)
        _, on = closest_on_triangles(points, np.repeat(corners[:1], k, 0),
                                     np.repeat(corners[1:2], k, 0), np.repeat(corners[2:], k, 0))
        best = np.minimum(best, np.linalg.norm(on - points, axis=1))
    return best


def test_closest_point_of_a_triangle_in_every_region() -> None:
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    points = np.array([[0.2, 0.2, 1.0],     # above the inside
                       [-1.0, -1.0, 0.0],   # beyond corner a
                       [2.0, -0.5, 0.0],    # beyond corner b
                       [-0.2, 3.0, 0.0],    # beyond corner c
                       [0.5, -1.0, 0.3],    # beyond edge ab
                       [-1.0, 0.5, 0.0],    # beyond edge ac
                       [1.0, 1.0, -2.0]])   # beyond edge bc
    k = len(points)
    w, on = closest_on_triangles(points, np.tile(a, (k, 1)), np.tile(b, (k, 1)), np.tile(c, (k, 1)))
    expected = np.array([[0.2, 0.2, 0], [0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0],
                         [0, 0.5, 0], [0.5, 0.5, 0]])
    np.testing.assert_allclose(on, expected, atol=1e-15)
    assert (w >= -1e-15).all()
    np.testing.assert_allclose(w.sum(axis=1), 1.0)


def test_nearest_on_surface_matches_brute_force() -> None:
    mesh = sp.datasets.bumpy_blob(400, bumps=4, amplitude=0.5, seed=3)
    v, f = mesh.vertices, mesh.faces
    rng = np.random.default_rng(0)
    size = float(np.linalg.norm(np.ptp(v, axis=0)))
    # Near the surface, and far from it (settled only on the coarser grids).
    points = np.vstack([v[rng.integers(0, len(v), 150)] + rng.normal(size=(150, 3)) * 0.03 * size,
                        rng.normal(size=(30, 3)) * 2.0 * size])
    nearest = NearestOnSurface(v, f)
    vertex, distance = nearest.nearest_vertices(points)
    all_distances = np.linalg.norm(points[:, None, :] - v[None, :, :], axis=2)
    np.testing.assert_allclose(distance, all_distances.min(axis=1), rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(v[vertex] - points, axis=1), distance, rtol=1e-12)
    faces, bary, on = nearest(points)
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", bary, v[f[faces]]), on, atol=1e-12 * size)
    got = np.linalg.norm(on - points, axis=1)
    best = brute_force(points, v, f)
    assert (got >= best - 1e-12 * size).all()
    # The faces around the nearest vertex hold the closest point nearly
    # always, and miss it by a fraction of an edge at worst.
    assert np.mean(got <= best + 1e-12 * size) > 0.95
    edge = np.linalg.norm(v[f[:, 1]] - v[f[:, 0]], axis=1).mean()
    assert (got - best).max() < 0.5 * edge
