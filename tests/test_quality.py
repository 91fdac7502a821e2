"""sp.quality: angle, conformal, area and stretch distortion, edge-length spread.

Checked against maps whose distortion is known in closed form: similarities
(no distortion), and the linear map diag(2, 1, 1), whose singular values on a
face with unit normal n are fixed by sigma1 sigma2 = sqrt(4 - 3 n_x^2) and
sigma1^2 + sigma2^2 = 5 - 3 n_x^2.
"""

from __future__ import annotations

from typing import Any, Dict

import numpy as np
import pytest

import spherify as sp

KEYS = {"angle_mean_deg", "angle_max_deg", "conformal_mean", "conformal_max", "area_log_mean",
        "area_log_std", "area_log_max_abs", "area_ratio_min", "area_ratio_max", "stretch_l2",
        "stretch_linf", "edge_length_cv", "degenerate_faces", "n_faces"}


def grid(k: int) -> sp.Mesh:
    """A k x k grid of unit squares in the plane z = 0, two triangles each."""
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1))
    V = np.column_stack([i.ravel(), j.ravel(), np.zeros(i.size)]).astype(float)
    at = lambda a, b: b * (k + 1) + a  # noqa: E731
    F = [f for b in range(k) for a in range(k)
         for f in ([at(a, b), at(a + 1, b), at(a + 1, b + 1)], [at(a, b), at(a + 1, b + 1), at(a, b + 1)])]
    return sp.Mesh(V, np.array(F))


def assert_finite(q: Dict[str, Any]) -> None:
    assert set(q) == KEYS
    for name, value in q.items():
        assert np.isfinite(value), f"{name} = {value}"
    assert isinstance(q["degenerate_faces"], int) and isinstance(q["n_faces"], int)


def test_a_similarity_has_no_distortion() -> None:
    # The icosphere's own directions against the icosphere moved, turned and
    # scaled: angles, shapes and area shares are all kept.
    sphere = sp.datasets.icosphere(subdivisions=3)
    points = sphere.vertices / np.linalg.norm(sphere.vertices, axis=1, keepdims=True)
    c, s = np.cos(1.1), np.sin(1.1)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    mesh = sp.Mesh(2.5 * sphere.vertices @ R.T + [1.0, -2.0, 3.0], sphere.faces)
    q = sp.quality(mesh, points)
    assert_finite(q)
    assert q["angle_max_deg"] < 1e-10 and q["angle_mean_deg"] < 1e-10
    assert q["conformal_max"] == pytest.approx(1.0, abs=1e-12)
    assert q["area_log_max_abs"] < 1e-12 and abs(q["area_log_mean"]) < 1e-12
    assert q["stretch_l2"] == pytest.approx(1.0, abs=1e-12)
    assert q["stretch_linf"] == pytest.approx(1.0, abs=1e-12)
    assert 0.0 < q["edge_length_cv"] < 0.1
    assert (q["degenerate_faces"], q["n_faces"]) == (0, sphere.n_faces)


def test_a_flat_stretch_by_two() -> None:
    # Mesh = grid stretched by diag(2, 1, 1), points = the grid: T = diag(2, 1)
    # on every face. Areas double everywhere, so their shares are kept; the
    # normalisation s^2 = 2 gives Gamma = sqrt 2, gamma = 1 / sqrt 2.
    plain = grid(4)
    mesh = sp.Mesh(plain.vertices * [2.0, 1.0, 1.0], plain.faces)
    q = sp.quality(mesh, plain.vertices)
    assert_finite(q)
    assert q["conformal_mean"] == pytest.approx(2.0, abs=1e-12)
    assert q["conformal_max"] == pytest.approx(2.0, abs=1e-12)
    assert q["stretch_l2"] == pytest.approx(np.sqrt((2.0 + 0.5) / 2.0), abs=1e-12)
    assert q["stretch_linf"] == pytest.approx(np.sqrt(2.0), abs=1e-12)
    assert q["area_log_max_abs"] < 1e-12
    # The 45-degree corner between a side and the diagonal becomes atan(1/2).
    assert q["angle_max_deg"] == pytest.approx(45.0 - np.degrees(np.arctan(0.5)), abs=1e-10)


def test_the_sphere_stretched_into_an_ellipsoid() -> None:
    sphere = sp.datasets.icosphere(subdivisions=3)
    V, F = sphere.vertices, sphere.faces
    mesh = sp.Mesh(V * [2.0, 1.0, 1.0], F)
    q = sp.quality(mesh, V)
    assert_finite(q)
    # Expected values from each face's unit normal (see the module docstring).
    cross = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area_p = np.linalg.norm(cross, axis=1) / 2
    nx2 = (cross[:, 0] / (2 * area_p)) ** 2
    product, squares = np.sqrt(4 - 3 * nx2), 5 - 3 * nx2
    root = np.sqrt(np.maximum(squares ** 2 - 4 * product ** 2, 0.0))
    sigma1 = np.sqrt((squares + root) / 2)
    sigma2 = product / sigma1
    area_q = product * area_p
    ratio = sigma1 / sigma2
    assert q["conformal_mean"] == pytest.approx(ratio.mean(), rel=1e-6)
    assert q["conformal_max"] == pytest.approx(ratio.max(), rel=1e-6)
    assert 1.0 < q["conformal_mean"] < q["conformal_max"] <= 2.0 + 1e-12
    s2 = area_q.sum() / area_p.sum()
    l2 = np.sqrt(np.sum(squares / 2 * area_q) / area_q.sum() / s2)
    assert q["stretch_l2"] == pytest.approx(l2, rel=1e-9)
    assert q["stretch_linf"] == pytest.approx(sigma1.max() / np.sqrt(s2), rel=1e-9)
    logs = np.log(area_p / area_p.sum()) - np.log(area_q / area_q.sum())
    assert q["area_log_mean"] == pytest.approx(logs.mean(), abs=1e-9)
    assert q["area_log_std"] == pytest.approx(logs.std(), rel=1e-6)
    assert q["area_log_max_abs"] == pytest.approx(np.abs(logs).max(), rel=1e-9)
    assert q["area_ratio_min"] == pytest.approx(np.exp(logs.min()), rel=1e-9)


def test_edge_length_cv() -> None:
    mesh = grid(3)
    q = sp.quality(mesh, mesh.vertices)
    # 24 sides of length 1 and 9 diagonals of length sqrt 2.
    lengths = np.array([1.0] * 24 + [np.sqrt(2.0)] * 9)
    assert q["edge_length_cv"] == pytest.approx(lengths.std() / lengths.mean(), rel=1e-12)


def test_degenerate_faces_are_counted_not_nan() -> None:
    mesh = grid(2)
    points = mesh.vertices.copy()
    points[4] = points[0]  # the centre onto a corner: the two faces using both collapse
    q = sp.quality(mesh, points)
    assert_finite(q)
    assert q["degenerate_faces"] == 2 and q["n_faces"] == 8
    # Degenerate on the mesh side counts too.
    V = mesh.vertices.copy()
    V[4] = V[0]
    q = sp.quality(sp.Mesh(V, mesh.faces), mesh.vertices)
    assert_finite(q)
    assert q["degenerate_faces"] == 2
    # Nothing left to measure is an error, not a dict of NaN.
    with pytest.raises(sp.MeshError, match="degenerate"):
        sp.quality(mesh, np.ones((mesh.n_vertices, 3)))


@pytest.mark.parametrize("points", [
    np.zeros((9, 2)),
    np.zeros((8, 3)),
    np.zeros(27),
    np.full((9, 3), np.nan),
    [["a", "b", "c"]] * 9,
])
def test_wrong_points_are_mesh_errors(points: Any) -> None:
    with pytest.raises(sp.MeshError):
        sp.quality(grid(2), points)


def test_a_spherical_map_has_finite_sensible_measures() -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=1000)
    m = sp.embed(mesh, "gotsman")
    assert m.valid
    q = sp.quality((mesh.vertices, mesh.faces), m.points)
    assert_finite(q)
    assert q["degenerate_faces"] == 0
    assert q["stretch_l2"] >= 1.0 and q["stretch_linf"] >= q["stretch_l2"]
    assert 1.0 <= q["conformal_mean"] <= q["conformal_max"]
    assert 0.0 <= q["angle_mean_deg"] <= q["angle_max_deg"] < 180.0
    assert q["area_ratio_min"] <= 1.0 <= q["area_ratio_max"]
