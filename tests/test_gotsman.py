"""Gotsman, Gu and Sheffer's spherical Tutte embedding (thesis 5.1, eq. 5.10)
through sp.embed(mesh, "gotsman").

Invariants, not snapshots: unit points, every point the projection of its
neighbours' weighted mean (eq. 5.5), ``valid`` by the exact test of 3.4,
``status`` telling the truth (converged, max_iterations, collapsed), the same
bits on every run, and a rotated mesh giving rotated points.
"""

from __future__ import annotations

import time
from typing import Callable, Dict

import numpy as np
import pytest

import spherify as sp
from _exact import exact_verdict

SHAPES: Dict[str, Callable[[], sp.Mesh]] = {
    "icosphere2": lambda: sp.datasets.icosphere(subdivisions=2),
    "ellipsoid": lambda: sp.datasets.ellipsoid(800),
    "thin_ellipsoid": lambda: sp.datasets.ellipsoid(800, axes=(1.0, 0.3, 0.2)),
    "bumpy_blob_500": lambda: sp.datasets.bumpy_blob(n_vertices=500),
    "bumpy_blob_2000": lambda: sp.datasets.bumpy_blob(n_vertices=2000),
    "very_bumpy_blob": lambda: sp.datasets.bumpy_blob(n_vertices=1000, amplitude=0.6),
    "urchin": lambda: sp.datasets.urchin(n_vertices=2000),
}


def neighbour_means(mesh: sp.Mesh, points: np.ndarray, weights: str, rho: float = 1.0) -> np.ndarray:
    """u_i = sum_j w_ij v_j with w_ij = omega_ij / sum_j omega_ij (eq. 4.46),
    omega_ij = 1 or |x_i - x_j|^rho, computed independently of the core."""
    F = mesh.faces
    E = np.unique(np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    i, j = np.concatenate([E[:, 0], E[:, 1]]), np.concatenate([E[:, 1], E[:, 0]])
    V = mesh.vertices
    omega = np.ones(len(i)) if weights == "uniform" else np.linalg.norm(V[i] - V[j], axis=1) ** rho
    u = np.zeros_like(points)
    np.add.at(u, i, omega[:, None] * points[j])
    wdeg = np.zeros(len(points))
    np.add.at(wdeg, i, omega)
    return u / wdeg[:, None]


def assert_honest(m: sp.SphereMap, mesh: sp.Mesh, max_iter: int) -> None:
    n = mesh.n_vertices
    assert m.points.shape == (n, 3) and m.points.dtype == np.float64
    # Normalised at the end (the |v_i| = 1 equations already hold to tol).
    np.testing.assert_allclose(np.linalg.norm(m.points, axis=1), 1.0, rtol=0, atol=1e-10)
    assert 0 <= m.iterations <= max_iter
    assert m.status in {"converged", "collapsed", "max_iterations"}
    assert m.converged is (m.status == "converged")
    # Held to the exact check written apart from spherify, not to check_sphere
    # (which valid is made of).
    verdict = exact_verdict(m.points, m.mesh.faces)
    assert (m.valid, m.flipped) == (verdict.valid, verdict.flipped), (verdict, m.message)
    assert m.message.startswith("gotsman: ")
    assert set(m.seconds) == {"setup", "solve", "iterate", "certify"}


@pytest.mark.parametrize("weights", ["uniform", "chord"])
@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_valid_from_the_centroid(shape: str, weights: str) -> None:
    mesh = SHAPES[shape]()
    start = time.perf_counter()
    m = sp.embed(mesh, "gotsman", weights=weights)
    seconds = time.perf_counter() - start
    print(f"gotsman {shape} ({mesh.n_vertices} vertices, {weights}): {seconds:.2f} s, "
          f"{m.iterations} iterations, valid={m.valid}")
    assert_honest(m, mesh, 50)
    assert m.converged and m.valid, m.message
    # Eq. 5.5: each point is the projection of its neighbours' weighted mean.
    u = neighbour_means(mesh, m.points, weights)
    np.testing.assert_allclose(u / np.linalg.norm(u, axis=1, keepdims=True), m.points, rtol=0, atol=1e-8)


def test_chord_rho_reaches_the_weights() -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=600, amplitude=0.4)
    m = sp.embed(mesh, "gotsman", weights="chord", rho=-1.0)
    assert m.converged and m.valid, m.message
    u = neighbour_means(mesh, m.points, "chord", rho=-1.0)
    np.testing.assert_allclose(u / np.linalg.norm(u, axis=1, keepdims=True), m.points, rtol=0, atol=1e-8)
    # Different weights, different embedding.
    other = sp.embed(mesh, "gotsman", weights="chord", rho=1.0)
    assert np.abs(other.points - m.points).max() > 1e-3


def test_ten_thousand_vertices_in_seconds() -> None:
    mesh = sp.datasets.icosphere(subdivisions=5)
    assert mesh.n_vertices == 10242
    start = time.perf_counter()
    m = sp.embed(mesh, "gotsman")
    seconds = time.perf_counter() - start
    print(f"gotsman icosphere(5): {seconds:.2f} s, {m.iterations} iterations, stages {m.seconds}")
    assert_honest(m, mesh, 50)
    assert m.converged and m.valid, m.message


def test_same_input_same_bits() -> None:
    mesh = SHAPES["bumpy_blob_500"]()
    a = sp.embed(mesh, "gotsman", weights="chord")
    b = sp.embed(mesh, "gotsman", weights="chord")
    assert np.array_equal(a.points, b.points)


def test_a_rotated_mesh_gives_rotated_points() -> None:
    # Eq. 5.10, the start 5.11 and every step are rotation-equivariant.
    mesh = SHAPES["bumpy_blob_500"]()
    c, s = np.cos(0.7), np.sin(0.7)
    about_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    about_x = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    R = about_z @ about_x
    rotated = sp.Mesh(mesh.vertices @ R.T, mesh.faces)
    a = sp.embed(mesh, "gotsman")
    b = sp.embed(rotated, "gotsman")
    np.testing.assert_allclose(b.points, a.points @ R.T, rtol=0, atol=1e-8)


def test_strict_raises_with_the_last_iterate() -> None:
    mesh = SHAPES["icosphere2"]()
    with pytest.raises(sp.ConvergenceError) as info:
        sp.embed(mesh, "gotsman", max_iter=1, strict=True)
    state = info.value.state
    assert state["status"] == "max_iterations" and state["iterations"] == 1
    assert state["points"].shape == (mesh.n_vertices, 3)
    m = sp.embed(mesh, "gotsman", max_iter=1)
    assert_honest(m, mesh, 1)
    assert m.status == "max_iterations" and not m.converged


def test_collapse_onto_the_trivial_solution_is_reported() -> None:
    mesh = SHAPES["icosphere2"]()
    rng = np.random.default_rng(1)
    clustered = np.array([0.0, 0.0, 1.0]) + 0.05 * rng.normal(size=(mesh.n_vertices, 3))
    m = sp.embed(mesh, "gotsman", initial=clustered)
    assert_honest(m, mesh, 50)
    assert m.status == "collapsed" and not m.valid, m.message
    assert "trivial" in m.message
    with pytest.raises(sp.ConvergenceError, match="collapsed"):
        sp.embed(mesh, "gotsman", initial=clustered, strict=True)


def test_a_solution_as_start_needs_no_iteration() -> None:
    mesh = SHAPES["ellipsoid"]()
    first = sp.embed(mesh, "gotsman")
    again = sp.embed(mesh, "gotsman", initial=first.points, tol=1e-9)
    assert (again.iterations, again.status) == (0, "converged")


def test_a_bad_start_is_reported_honestly() -> None:
    # The helix tube's mean vertex lies outside it (thesis 9.3.1): the
    # centroid start folds the tube over itself and Newton's method finds no
    # solution nearby. Whatever happens, a converged result must be valid.
    mesh = sp.datasets.helix_tube(n_vertices=800)
    m = sp.embed(mesh, "gotsman", max_iter=15)
    assert_honest(m, mesh, 15)
    if m.converged:
        assert m.valid, m.message
    else:
        assert m.status in {"max_iterations", "collapsed"}


@pytest.mark.parametrize("options", [
    {"weights": "mean_value"},
    {"weights": "cotangent"},
    {"weights": "nope"},
    {"weights": "chord", "rho": float("nan")},
    {"max_iter": -1},
    {"tol": float("nan")},
    {"tol": -1.0},
    {"initial": np.zeros((3, 3))},
    {"initial": np.zeros((162, 2))},
    {"initial": np.zeros((162, 3))},
    {"no_such_option": 1},
])
def test_bad_options_are_mesh_errors(options: Dict[str, object]) -> None:
    mesh = SHAPES["icosphere2"]()
    assert mesh.n_vertices == 162
    with pytest.raises(sp.MeshError):
        sp.embed(mesh, "gotsman", **options)


def test_not_genus_zero_is_a_topology_error() -> None:
    mesh = SHAPES["icosphere2"]()
    open_mesh = sp.Mesh(mesh.vertices, mesh.faces[1:])
    with pytest.raises(sp.TopologyError):
        sp.embed(open_mesh, "gotsman")
