"""2D Tutte embedding of disks (thesis ch. 4): flip-free for positive weights."""

from __future__ import annotations

import warnings
from typing import Tuple

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import spherify as sp

from _meshgen import Surface, surfaces

POSITIVE_WEIGHTS = [("uniform", 1.0), ("chord", -1.0), ("chord", 1.0), ("mean_value", 1.0)]


def compact(V: np.ndarray, F: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Drop unused vertices, renumbering the faces."""
    used = np.unique(F)
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return V[used], remap[F]


def patch(F: np.ndarray, seed_face: int, size: int) -> np.ndarray:
    """A connected set of ``size`` faces grown breadth-first from ``seed_face``."""
    owner = {}
    for f, face in enumerate(F):
        for k in range(3):
            owner.setdefault(frozenset((face[k], face[(k + 1) % 3])), []).append(f)
    chosen, frontier = [seed_face], [seed_face]
    taken = {seed_face}
    while frontier and len(chosen) < size:
        f = frontier.pop(0)
        for k in range(3):
            for g in owner[frozenset((F[f][k], F[f][(k + 1) % 3]))]:
                if g not in taken and len(chosen) < size:
                    taken.add(g)
                    chosen.append(g)
                    frontier.append(g)
    return np.array(sorted(taken))


@st.composite
def disks(draw: st.DrawFn) -> sp.Mesh:
    """Random disks: a genus-0 surface (often not star-shaped, stretched, bent)
    minus one vertex star or minus a connected patch of faces."""
    surface: Surface = draw(surfaces(min_vertices=6, max_vertices=250))
    V, F = surface.V, surface.F
    if draw(st.booleans()):
        v = draw(st.integers(0, len(V) - 1))
        removed = np.nonzero((F == v).any(axis=1))[0]
    else:
        seed = draw(st.integers(0, len(F) - 1))
        removed = patch(F, seed, draw(st.integers(1, max(1, len(F) // 3))))
    keep = np.ones(len(F), dtype=bool)
    keep[removed] = False
    V2, F2 = compact(V, F[keep])
    mesh = sp.Mesh(V2, F2)
    report = sp.check(mesh)
    # A grown patch can pinch the rest or wrap around a region: keep only disks.
    assume(report.manifold and report.connected and report.n_boundary_loops == 1
           and report.euler_characteristic == 1)
    return mesh


@settings(max_examples=40)
@given(disks(), st.sampled_from(POSITIVE_WEIGHTS), st.sampled_from(["circle", "circle_length"]))
def test_positive_weights_give_flip_free_embeddings(mesh: sp.Mesh, weights: Tuple[str, float],
                                                    boundary: str) -> None:
    name, rho = weights
    uv, info = sp.tutte(mesh, weights=name, rho=rho, boundary=boundary, return_info=True)
    assert uv.shape == (mesh.n_vertices, 2) and uv.dtype == np.float64
    assert info.valid, f"flipped {info.flipped_faces}, degenerate {info.degenerate_faces}"
    loop = sp.boundary_loop(mesh)
    np.testing.assert_array_equal(info.boundary, loop)
    points = uv[loop]
    if boundary == "circle":
        angles = 2 * np.pi * np.arange(len(loop)) / len(loop)
        np.testing.assert_allclose(points, np.stack([np.cos(angles), np.sin(angles)], axis=1),
                                   rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.hypot(points[:, 0], points[:, 1]), 1.0, rtol=0, atol=1e-15)
    interior = np.setdiff1d(np.arange(mesh.n_vertices), loop)
    assert np.all(np.hypot(uv[interior, 0], uv[interior, 1]) < 1.0)


@settings(max_examples=25)
@given(disks())
def test_uniform_weights_put_vertices_at_neighbour_centroids(mesh: sp.Mesh) -> None:
    uv = sp.tutte(mesh, weights="uniform", solver="direct")
    loop = set(sp.boundary_loop(mesh).tolist())
    neighbours = {v: set() for v in range(mesh.n_vertices)}
    for a, b, c in mesh.faces:
        neighbours[a] |= {b, c}
        neighbours[b] |= {a, c}
        neighbours[c] |= {a, b}
    for v, ring in neighbours.items():
        if v not in loop:
            centroid = uv[sorted(ring)].mean(axis=0)
            np.testing.assert_allclose(uv[v], centroid, atol=1e-10)


@settings(max_examples=20)
@given(disks(), st.sampled_from([("uniform", 1.0), ("chord", -1.0)]))
def test_solvers_agree(mesh: sp.Mesh, weights: Tuple[str, float]) -> None:
    name, rho = weights
    reference = sp.tutte(mesh, weights=name, rho=rho, solver="direct")
    for solver in ["auto", "cg", "cg_jacobi", "gauss_seidel"]:
        uv = sp.tutte(mesh, weights=name, rho=rho, solver=solver, tol=1e-13, max_iter=200_000)
        np.testing.assert_allclose(uv, reference, rtol=0, atol=1e-8, err_msg=solver)


@settings(max_examples=10)
@given(disks())
def test_mean_value_weights_with_gauss_seidel(mesh: sp.Mesh) -> None:
    reference = sp.tutte(mesh, weights="mean_value")
    uv = sp.tutte(mesh, weights="mean_value", solver="gauss_seidel", tol=1e-13, max_iter=200_000)
    np.testing.assert_allclose(uv, reference, rtol=0, atol=1e-8)
    with pytest.raises(sp.MeshError, match="symmetric"):
        sp.tutte(mesh, weights="mean_value", solver="cg")


@pytest.fixture(scope="module")
def square_grid() -> sp.Mesh:
    n = 6
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), 0.3 * np.sin(3 * x.ravel()) * y.ravel()], axis=1)
    at = lambda i, j: i * (n + 1) + j  # noqa: E731
    F = []
    for i in range(n):
        for j in range(n):
            F += [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]]
    return sp.Mesh(V, np.array(F))


def test_user_polygon(square_grid: sp.Mesh) -> None:
    loop = sp.boundary_loop(square_grid)
    m = len(loop)
    # A square with the boundary vertices spread along its sides (collinear points allowed).
    t = np.arange(m) / m * 4
    side, s = np.floor(t).astype(int), t - np.floor(t)
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], dtype=float)
    polygon = corners[side] + (corners[side + 1] - corners[side]) * s[:, None]
    uv, info = sp.tutte(square_grid, boundary=polygon, return_info=True)
    assert info.valid
    np.testing.assert_array_equal(uv[loop], polygon)
    dented = polygon.copy()
    dented[m // 8] = [0.5, 0.3]
    with pytest.raises(sp.MeshError, match="convex"):
        sp.tutte(square_grid, boundary=dented)
    with pytest.raises(sp.MeshError, match="convex"):
        sp.tutte(square_grid, boundary=polygon[::-1])
    with pytest.raises(sp.MeshError, match="points"):
        sp.tutte(square_grid, boundary=polygon[:-1])


def test_non_disks_raise_topology_error(square_grid: sp.Mesh) -> None:
    closed = sp.datasets.icosphere(subdivisions=1)
    with pytest.raises(sp.TopologyError) as err:
        sp.tutte(closed)
    assert err.value.report.closed
    with pytest.raises(sp.TopologyError):
        sp.boundary_loop(closed)
    F = closed.faces
    two_holes = sp.Mesh(closed.vertices, F[2:-2][np.r_[0:10, 11:len(F) - 4]])
    with pytest.raises(sp.TopologyError):
        sp.tutte(two_holes)


def test_cotangent_weights_warn_when_negative(square_grid: sp.Mesh) -> None:
    # Skew the grid so some triangles are obtuse enough for negative weights.
    V = square_grid.vertices.copy()
    V[:, 0] += 2.5 * V[:, 1] ** 2
    skewed = sp.Mesh(V, square_grid.faces)
    with pytest.warns(sp.SpherifyWarning, match="negative"):
        _, info = sp.tutte(skewed, weights="cotangent", return_info=True)
    assert info.negative_weights > 0
    # An equilateral lattice has only 60-degree angles: all cotangent weights positive.
    n = 5
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    V = np.stack([i.ravel() + 0.5 * j.ravel(), np.sqrt(3) / 2 * j.ravel(), 0 * i.ravel()], axis=1)
    at = lambda a, b: a * (n + 1) + b  # noqa: E731
    F = [[at(a, b), at(a + 1, b), at(a, b + 1)] for a in range(n) for b in range(n)]
    F += [[at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)] for a in range(n) for b in range(n)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        uv, info = sp.tutte(sp.Mesh(V, np.array(F)), weights="cotangent", return_info=True)
    assert info.negative_weights == 0 and info.valid


def test_gauss_seidel_out_of_iterations_raises_with_last_iterate(square_grid: sp.Mesh) -> None:
    with pytest.raises(sp.ConvergenceError) as err:
        sp.tutte(square_grid, solver="gauss_seidel", max_iter=1)
    state = err.value.state
    assert state["points"].shape == (square_grid.n_vertices, 2)
    assert state["status"] == "max_iterations" and state["iterations"] == 1
    assert state["residual"] > 1e-10
    assert isinstance(err.value, RuntimeError)


def test_bad_arguments(square_grid: sp.Mesh) -> None:
    with pytest.raises(sp.MeshError, match="weights"):
        sp.tutte(square_grid, weights="harmonic")
    with pytest.raises(sp.MeshError, match="solver"):
        sp.tutte(square_grid, solver="magic")
    with pytest.raises(sp.MeshError, match="boundary"):
        sp.tutte(square_grid, boundary="square")
    with pytest.raises(sp.MeshError, match="rho"):
        sp.tutte(square_grid, weights="chord", rho=float("nan"))
