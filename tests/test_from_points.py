"""SphereMap.from_points: a map made elsewhere, certified in the core."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp


def test_a_spheres_own_vertices_are_a_valid_map_with_both_directions() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    m = sp.SphereMap.from_points(mesh, mesh.vertices)
    assert type(m) is sp.SphereMap
    assert m.method == "points" and m.status == "direct" and m.iterations == 0
    assert m.valid and m.flipped == 0 and m.report.valid
    np.testing.assert_allclose(m.points, mesh.vertices, atol=1e-15)
    assert list(m.seconds) == ["normalise", "certify"]
    # h and h^-1 are the identity of the unit sphere on its own mesh.
    rng = np.random.default_rng(1)
    p = rng.normal(size=(200, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    faces, bary, xyz = m.to_surface(p)
    np.testing.assert_allclose(m.to_sphere(faces, bary), p, atol=1e-12)
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", bary, mesh.vertices[mesh.faces[faces]]),
                               xyz, atol=1e-12)


def test_a_map_on_another_radius_is_projected_and_the_projection_reported() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    m = sp.SphereMap.from_points(mesh, 100.0 * mesh.vertices)
    assert m.valid
    np.testing.assert_allclose(np.linalg.norm(m.points, axis=1), 1.0, atol=1e-15)
    assert "projected onto the unit sphere" in m.message and "9.9" in m.message


def test_the_surface_can_be_any_shape() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    blob = sp.Mesh(mesh.vertices * np.array([3.0, 1.0, 0.5]), mesh.faces)
    m = sp.SphereMap.from_points(blob, mesh.vertices)
    assert m.valid
    _, _, xyz = m.to_surface(mesh.vertices)
    np.testing.assert_allclose(xyz, blob.vertices, atol=1e-12)


def test_a_vertex_moved_across_is_not_valid_and_has_no_inverse() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    points = mesh.vertices.copy()
    points[0] = -points[0]
    m = sp.SphereMap.from_points(mesh, points)
    assert not m.valid and m.flipped > 0
    assert len(m.report.flipped_faces) == m.flipped
    with pytest.raises(sp.MapError, match="not a bijection"):
        m.to_surface(mesh.vertices[:3])
    # h itself is still a function.
    assert m.to_sphere([0], [[1.0, 0.0, 0.0]]).shape == (1, 3)


def test_a_mirrored_map_is_not_valid() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    m = sp.SphereMap.from_points(mesh, mesh.vertices * np.array([1.0, 1.0, -1.0]))
    assert not m.valid and m.report.covering_degree == -1


def test_arrays_are_read_only_and_the_verdict_cannot_be_set() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    m = sp.SphereMap.from_points(mesh, mesh.vertices)
    with pytest.raises(ValueError):
        m.points[0, 0] = 5.0
    with pytest.raises(ValueError):
        m.report.flipped_faces[:] = 0
    with pytest.raises(AttributeError):
        m.valid = False  # type: ignore[misc]


def test_an_inward_mesh_is_reoriented_and_the_points_keep_their_vertices() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    inward = sp.Mesh(mesh.vertices, mesh.faces[:, ::-1])
    m = sp.SphereMap.from_points(inward, mesh.vertices)
    assert m.valid and m.notes and "reoriented" in m.notes[0]
    np.testing.assert_allclose(m.points, mesh.vertices, atol=1e-15)


@pytest.mark.parametrize("bad, match", [
    (np.zeros((42, 2)), r"shape \(n, 3\)"),
    (np.zeros((41, 3)) + 1.0, "41 rows, but the mesh has 42 vertices"),
    ("not numbers", "must be numbers"),
])
def test_wrong_shapes_are_mesh_errors(bad: object, match: str) -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    with pytest.raises(sp.MeshError, match=match):
        sp.SphereMap.from_points(mesh, bad)  # type: ignore[arg-type]


@given(row=st.integers(0, 41), bad=st.sampled_from([np.nan, np.inf, -np.inf, 0.0]))
def test_points_without_direction_name_their_row(row: int, bad: float) -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    points = mesh.vertices.copy()
    points[row] = [bad, bad, bad] if bad == 0.0 else [bad, 0.0, 1.0]
    with pytest.raises(sp.MeshError, match=f"points row {row}: .* has no direction"):
        sp.SphereMap.from_points(mesh, points)


def test_a_mesh_that_is_not_genus_zero_is_a_topology_error() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    open_mesh = (mesh.vertices, mesh.faces[1:])
    with pytest.raises(sp.TopologyError):
        sp.SphereMap.from_points(open_mesh, mesh.vertices)


@given(seed=st.integers(0, 2**32 - 1))
def test_a_random_rotation_of_the_sphere_is_still_valid_and_agrees_with_check_sphere(
        seed: int) -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    points = mesh.vertices @ q.T
    m = sp.SphereMap.from_points(mesh, points)
    assert m.valid == sp.check_sphere(mesh, m.points).valid is True
