"""Closest points on a mesh's surface (spherify._nearest), against brute force."""

from __future__ import annotations

from typing import Tuple

import numpy as np

import pytest

import spherify as sp
from spherify._nearest import NearestOnSurface


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
                         ) -> Tuple[np.ndarray, np.ndarray]:
    """The closest point of triangle (a_i, b_i, c_i) to p_i, row by row.

    Returns the barycentric weights (k, 3) on (a, b, c) and the points (k, 3):
    Ericson's Voronoi-region test, vectorised (a degenerate triangle gets
    the closest of its vertices and edges through the same tests)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    k = len(p)
    w = np.zeros((k, 3))
    done = np.zeros(k, dtype=bool)

    def settle(mask: np.ndarray, weights: np.ndarray) -> None:
        mask = mask & ~done
        w[mask] = weights[mask]
        done[mask] = True

    one, zero = np.ones(k), np.zeros(k)
    with np.errstate(divide="ignore", invalid="ignore"):
        settle((d1 <= 0) & (d2 <= 0), np.stack([one, zero, zero], 1))
        settle((d3 >= 0) & (d4 <= d3), np.stack([zero, one, zero], 1))
        settle((d6 >= 0) & (d5 <= d6), np.stack([zero, zero, one], 1))
        t = d1 / (d1 - d3)
        settle((vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t, t, zero], 1))
        t = d2 / (d2 - d6)
        settle((vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t, zero, t], 1))
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        settle((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), np.stack([zero, 1 - t, t], 1))
        total = va + vb + vc
        v, u = vb / total, vc / total
        inside = np.stack([1 - v - u, v, u], 1)
    inside[~np.isfinite(inside).all(axis=1)] = 1.0 / 3.0
    settle(np.ones(k, dtype=bool), inside)
    points = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    return w, points


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
    # Near the surface, and far from it.
    points = np.vstack([v[rng.integers(0, len(v), 150)] + rng.normal(size=(150, 3)) * 0.03 * size,
                        rng.normal(size=(30, 3)) * 2.0 * size])
    nearest = NearestOnSurface(v, f)
    faces, bary, on = nearest(points)
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", bary, v[f[faces]]), on, atol=1e-12 * size)
    assert (bary >= -1e-12).all()
    got = np.linalg.norm(on - points, axis=1)
    # The exact closest point of the whole surface, not only of the faces
    # around the nearest vertex.
    np.testing.assert_allclose(got, brute_force(points, v, f), rtol=1e-10, atol=1e-12 * size)


def test_nearest_on_surface_same_bits_for_one_and_two_threads() -> None:
    mesh = sp.datasets.bumpy_blob(3000, bumps=6, amplitude=0.4, seed=5)
    points = np.random.default_rng(1).normal(size=(20000, 3))
    nearest = NearestOnSurface(mesh.vertices, mesh.faces)
    before = sp.get_num_threads()
    try:
        sp.set_num_threads(1)
        one = nearest(points)
        sp.set_num_threads(2)
        two = nearest(points)
    finally:
        sp.set_num_threads(before)
    for x, y in zip(one, two):
        assert np.array_equal(x, y)


def test_nearest_on_surface_rejects_bad_faces() -> None:
    with pytest.raises(sp.MeshError, match="out of range"):
        NearestOnSurface(np.zeros((3, 3)), np.array([[0, 1, 3]]))
