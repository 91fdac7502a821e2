"""sp.morph: A's vertices through A's map, a rotation of the sphere and B's
inverse map, interpolated linearly (thesis 8.4)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import spherify as sp


def rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


@pytest.fixture(scope="module")
def blob() -> sp.SphereMap:
    return sp.embed(sp.datasets.bumpy_blob(1500))


def rotated_copy(m: sp.SphereMap, q: np.ndarray) -> sp.SphereMap:
    """The same surface turned by q in space, with its map turned by q on the sphere."""
    return sp.SphereMap.from_points(sp.Mesh(m.mesh.vertices @ q.T, m.mesh.faces), m.points @ q.T)


def distance_to_triangle(x: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from each x[k] to the plane of tri[k] and how far outside the
    triangle its projection falls (in barycentric weight)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    d = x - tri[:, 0]
    a11, a12, a22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    b1, b2 = (d * e1).sum(1), (d * e2).sum(1)
    det = a11 * a22 - a12 * a12
    s, t = (a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det
    off = np.linalg.norm(d - s[:, None] * e1 - t[:, None] * e2, axis=1)
    outside = np.maximum.reduce([-s, -t, s + t - 1, np.zeros_like(s)])
    return np.maximum(off, outside * np.linalg.norm(e1, axis=1))


def test_at_zero_is_a_and_at_one_lies_on_b(blob: sp.SphereMap) -> None:
    other = sp.embed(sp.datasets.ellipsoid(800, axes=(1.5, 1.0, 0.7)))
    mo = sp.morph(blob, other, normalize=False)
    assert np.array_equal(mo.at(0).vertices, blob.mesh.vertices)
    assert np.array_equal(mo.at(0).faces, blob.mesh.faces)
    end = mo.at(1).vertices
    assert mo.correspondence is not None
    faces, _, xyz = other.to_surface(mo.correspondence.map_a.points)
    np.testing.assert_array_equal(end, xyz)
    size = np.linalg.norm(np.ptp(other.mesh.vertices, axis=0))
    d = distance_to_triangle(end, other.mesh.vertices[other.mesh.faces[faces]])
    assert d.max() < 1e-9 * size
    mid = mo.at(0.5).vertices
    np.testing.assert_allclose(mid, 0.5 * (blob.mesh.vertices + end), atol=1e-12)
    r = mo.rotation
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)


@settings(max_examples=5)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_rotated_copy_is_found_and_reached(blob: sp.SphereMap, seed: int) -> None:
    q = rotation(seed)
    copy = rotated_copy(blob, q)
    mo = sp.morph(blob, copy, align="rotation", normalize=False)
    assert np.abs(mo.rotation - q).max() < 1e-6
    size = np.linalg.norm(np.ptp(blob.mesh.vertices, axis=0))
    assert np.abs(mo.at(1).vertices - copy.mesh.vertices).max() < 1e-9 * size
    assert mo.alignment["residual"] < 1e-9
    np.testing.assert_allclose(mo.alignment["spatial_rotation"], q, atol=1e-6)


def test_landmarks_give_the_rotation_by_kabsch_on_the_sphere(blob: sp.SphereMap) -> None:
    q = rotation(7)
    copy = rotated_copy(blob, q)
    pairs = [(0, 0), (100, 100), (500, 500), (900, 900)]
    only = sp.morph(blob, copy, align="landmarks", landmarks=pairs)
    np.testing.assert_allclose(only.rotation, q, atol=1e-12)
    assert only.alignment["landmark_residual"] < 1e-12 and only.alignment["iterations"] == 0
    both = sp.morph(blob, copy, landmarks=pairs)
    assert np.abs(both.rotation - q).max() < 1e-6


def test_no_alignment_is_the_identity(blob: sp.SphereMap) -> None:
    copy = rotated_copy(blob, rotation(3))
    mo = sp.morph(blob, copy, align="none")
    assert np.array_equal(mo.rotation, np.eye(3))
    # Without the sphere turned, A's vertices land elsewhere on B.
    assert mo.alignment["residual"] > 1e-3


def test_alignment_lowers_the_residual_between_different_shapes(blob: sp.SphereMap) -> None:
    other = sp.embed(sp.datasets.ellipsoid(800, axes=(1.5, 1.0, 0.7)))
    turned = sp.SphereMap.from_points(other.mesh, other.points @ rotation(11).T)
    aligned = sp.morph(blob, turned).alignment["residual"]
    assert aligned < sp.morph(blob, turned, align="none").alignment["residual"]


def test_bad_arguments(blob: sp.SphereMap) -> None:
    with pytest.raises(sp.MeshError, match="unknown align"):
        sp.morph(blob, blob, align="affine")
    with pytest.raises(sp.MeshError, match="needs landmarks"):
        sp.morph(blob, blob, align="landmarks")
    with pytest.raises(sp.MeshError, match="at least 2"):
        sp.morph(blob, blob, landmarks=[(0, 0)])
    with pytest.raises(sp.MeshError, match="vertex 1000000 of B is out of range"):
        sp.morph(blob, blob, landmarks=[(0, 0), (1, 10**6)])
    with pytest.raises(sp.MeshError, match="t must be"):
        sp.morph(blob, blob, align="none").at(1.5)
    ico = sp.datasets.icosphere(subdivisions=2)
    points = ico.vertices.copy()
    points[0] = -points[0]
    with pytest.raises(sp.MapError):
        sp.morph(blob, sp.SphereMap.from_points(ico, points))
