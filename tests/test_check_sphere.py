"""Validity tests of thesis 3.4: the orientation test and the area test agree."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import spherify as sp


def unit(points: np.ndarray) -> np.ndarray:
    return points / np.linalg.norm(points, axis=1)[:, None]


@pytest.fixture(scope="module")
def sphere_mesh() -> sp.Mesh:
    return sp.datasets.icosphere(subdivisions=3)


def test_projected_icosphere_is_valid(sphere_mesh: sp.Mesh) -> None:
    report = sp.check_sphere(sphere_mesh, unit(sphere_mesh.vertices))
    assert report.valid
    assert report.n_positive == sphere_mesh.n_faces
    assert report.area_error < 1e-10
    assert report.covering_degree == 1
    assert len(report.flipped_faces) == 0


@settings(max_examples=25)
@given(st.data())
def test_one_swapped_pair_is_caught(sphere_mesh: sp.Mesh, data: st.DataObject) -> None:
    points = unit(sphere_mesh.vertices)
    i = data.draw(st.integers(0, sphere_mesh.n_vertices - 1))
    j = data.draw(st.integers(0, sphere_mesh.n_vertices - 1).filter(lambda k: k != i))
    points[[i, j]] = points[[j, i]]
    report = sp.check_sphere(sphere_mesh, points)
    assert not report.valid
    assert report.n_negative > 0
    bad = set(report.flipped_faces.tolist())
    touched = {f for f, face in enumerate(sphere_mesh.faces) if i in face or j in face}
    assert bad <= touched


@settings(max_examples=25)
@given(st.floats(0.05, 0.9), st.integers(0, 2**31 - 1))
def test_orientation_and_area_tests_agree(sphere_mesh: sp.Mesh, strength: float, seed: int) -> None:
    # Random smooth twists keep the map valid; strong random jitter breaks it.
    rng = np.random.default_rng(seed)
    points = unit(sphere_mesh.vertices) + strength * rng.normal(size=(sphere_mesh.n_vertices, 3))
    report = sp.check_sphere(sphere_mesh, points)
    all_positive = report.n_negative == 0 and report.n_zero == 0
    # With every face positive, the areas add up to a whole number of spheres;
    # one sphere exactly when valid.
    if all_positive:
        assert report.covering_degree >= 1
        assert report.valid == (report.covering_degree == 1)
        assert abs(report.area_sum - 4 * np.pi * report.covering_degree) < 1e-8
    else:
        assert not report.valid


def test_inward_faces_cover_minus_once(sphere_mesh: sp.Mesh) -> None:
    inward = sp.Mesh(sphere_mesh.vertices, sphere_mesh.faces[:, ::-1])
    report = sp.check_sphere(inward, unit(inward.vertices))
    assert report.n_negative == inward.n_faces
    assert report.covering_degree == -1
    assert not report.valid


def test_bad_points(sphere_mesh: sp.Mesh) -> None:
    points = unit(sphere_mesh.vertices)
    points[5] = np.nan
    points[7] = 0.0
    report = sp.check_sphere(sphere_mesh, points)
    assert not report.valid
    assert report.bad_points == [5, 7]
    with pytest.raises(sp.MeshError, match="rows"):
        sp.check_sphere(sphere_mesh, points[:-1])
