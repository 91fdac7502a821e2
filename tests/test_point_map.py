"""SphereMap.to_sphere / to_surface: the map h of thesis 6.6 (theta-phi) and the
barycentric map of 3.3 (GC-embeddings), and their inverses."""

from __future__ import annotations

import itertools
import warnings
from contextlib import nullcontext

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp

from _meshgen import Surface, surfaces

TOL = 1e-9


def fold(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)


def surface_samples(mesh: sp.Mesh, rng: np.random.Generator, k: int):
    """Random faces with random weights, plus every corner and edge midpoint."""
    F = mesh.faces
    faces = [rng.integers(0, len(F), k)]
    bary = [rng.dirichlet([1.0, 1.0, 1.0], size=k)]
    for w in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]):
        faces.append(np.arange(len(F)))
        bary.append(np.tile(w, (len(F), 1)).astype(float))
    return np.concatenate(faces), np.concatenate(bary)


def sphere_samples(m: sp.SphereMap, rng: np.random.Generator, k: int) -> np.ndarray:
    """Random unit vectors, the poles, and points on the seam meridian phi = 0
    (where the cut path was folded shut) and on the vertices' images."""
    p = rng.normal(size=(k, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    seam = fold(rng.uniform(0, np.pi, k), np.zeros(k))
    return np.concatenate([p, [[0, 0, 1.0], [0, 0, -1.0]], seam, m.points])


def assert_round_trips(m: sp.SphereMap, mesh: sp.Mesh, seed: int) -> None:
    rng = np.random.default_rng(seed)
    V, F = mesh.vertices, mesh.faces
    scale = max(float(np.ptp(V, axis=0).max()), 1e-300)
    # Surface -> sphere -> surface: the same surface point (the face may differ
    # on shared edges and corners, so compare positions).
    faces, bary = surface_samples(mesh, rng, 300)
    on_sphere = m.to_sphere(faces, bary)
    np.testing.assert_allclose(np.linalg.norm(on_sphere, axis=1), 1.0, atol=1e-14)
    f2, b2, xyz = m.to_surface(on_sphere)
    want = np.einsum("kj,kjd->kd", bary, V[F[faces]])
    err = np.abs(xyz - want).max() / scale
    assert err < TOL, f"surface round trip off by {err:.2e} of the mesh size"
    assert np.all(b2 >= 0) and np.allclose(b2.sum(1), 1.0)
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", b2, V[F[f2]]), xyz, atol=1e-12 * scale)
    # Sphere -> surface -> sphere: the same sphere point.
    points = sphere_samples(m, rng, 300)
    f3, b3, _ = m.to_surface(points)
    back = m.to_sphere(f3, b3)
    err = np.abs(back - points).max()
    assert err < TOL, f"sphere round trip off by {err:.2e}"
    # h maps each vertex to its point of the map.
    corners = np.eye(3)[np.zeros(len(F), dtype=int)]
    np.testing.assert_allclose(m.to_sphere(np.arange(len(F)), corners), m.points[F[:, 0]],
                               atol=1e-14)


def assert_h_round_trips_or_fan_not_monotone(m: sp.SphereMap, mesh: sp.Mesh, seed: int) -> None:
    """h is the thesis's bijection whenever both pole fans are monotone in phi
    (6.5.1); when a fan is not (tiny meshes, a caller's poles) and cannot be
    made so, to_surface must refuse with MapError rather than answer wrongly."""
    assert m.tp_valid, m.message
    try:
        assert_round_trips(m, mesh, seed)
    except sp.MapError as err:
        assert "monotonically in phi" in str(err)
        assert not all(m.details["fans_monotone"]), "refused although both fans are monotone"


@given(surfaces(max_vertices=200), st.integers(0, 2**16))
def test_theta_phi_h_round_trips_on_random_meshes(surface: Surface, seed: int) -> None:
    mesh = sp.Mesh(surface.V, surface.F)
    m = sp.embed(mesh, method="theta_phi")
    if mesh.n_vertices >= 30:
        # Fast-graph poles on a mesh of this size are far apart: the fans are
        # monotone after 6.36-6.38, and h must hold.
        assert all(m.details["fans_monotone"])
    assert_h_round_trips_or_fan_not_monotone(m, mesh, seed)


@given(surfaces(max_vertices=120), st.data())
def test_theta_phi_h_round_trips_with_any_explicit_poles(surface: Surface, data) -> None:
    """A caller's poles may be adjacent: then a face holds both poles and h2
    splits it (the case the thesis leaves open)."""
    mesh = sp.Mesh(surface.V, surface.F)
    n = data.draw(st.integers(0, mesh.n_vertices - 1))
    neighbours = np.unique(mesh.faces[(mesh.faces == n).any(1)])
    s = data.draw(st.sampled_from([int(v) for v in neighbours if v != n]
                                  + [(n + 1) % mesh.n_vertices]))
    m = sp.embed(mesh, method="theta_phi", poles=(n, s))
    # Adjacent poles split a face into thin pieces, where a sphere point's
    # surface point can have no finite error bound: to_surface then warns
    # (issue 13, item 7), as it should. The round trip must hold all the same
    # (CI's derandomized draw: 91 vertices, seed 115, poles 18 and 46).
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "[0-9]+ of [0-9]+ points lie where the map's triangles "
                                "are nearly flat", sp.SpherifyWarning)
        assert_h_round_trips_or_fan_not_monotone(m, mesh, n)


@pytest.mark.parametrize("name", ["tetrahedron", "octahedron"])
def test_every_pole_pair_of_the_smallest_solids(name: str) -> None:
    """Every vertex of these is on or next to the cut, so the pole fans run
    along the rectangle's sides (straight-angle cells) and, for adjacent poles,
    a face holds both poles."""
    if name == "tetrahedron":
        V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
        F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    else:
        V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
                     dtype=float)
        F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                      [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    mesh = sp.Mesh(V, F)
    for n, s in itertools.permutations(range(len(V)), 2):
        m = sp.embed(mesh, method="theta_phi", poles=(n, s))
        assert m.tp_valid
        assert_round_trips(m, mesh, 7 * n + s)


@pytest.mark.parametrize("name,size", [("bumpy_blob", 3000), ("helix_tube", 3000),
                                       ("tentacles", 1500)])
def test_theta_phi_h_on_dataset_shapes(name: str, size: int) -> None:
    mesh = sp.datasets.make(name, size)
    m = sp.embed(mesh, method="theta_phi")
    assert m.tp_valid
    rng = np.random.default_rng(1)
    # The sphere round trip holds to rounding however thin the triangles are.
    points = sphere_samples(m, rng, 20000)
    # The tentacles' thinnest triangles (margin 3e-15) cannot place every
    # sphere point on the surface to 1e-9 of its size: to_surface says so
    # (issue 13, item 7).
    thin = name == "tentacles"
    with pytest.warns(sp.SpherifyWarning, match="nearly flat") if thin else nullcontext():
        f, b, _ = m.to_surface(points)
    assert np.abs(m.to_sphere(f, b) - points).max() < TOL
    if name != "tentacles":
        assert_round_trips(m, mesh, 2)


def test_h_is_a_bijection_even_where_the_gc_drawing_is_not() -> None:
    """On the helix the folded vertices with minor-arc edges are not a valid
    GC-embedding (thesis 6.7), but h (rectangle, stretch, fold) still is."""
    mesh = sp.datasets.helix_tube(n_vertices=1500)
    m = sp.embed(mesh, method="theta_phi")
    assert m.tp_valid and not m.valid
    assert_round_trips(m, mesh, 3)


@pytest.mark.parametrize("method,options", [("radial", {"center": "kernel"}),
                                            ("relaxation", {}), ("alexa", {})])
def test_gc_maps_round_trip(method: str, options: dict) -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=2000)
    m = sp.embed(mesh, method, **options)
    assert m.valid
    assert_round_trips(m, mesh, 4)


def test_gc_to_sphere_is_the_projected_barycentric_map() -> None:
    mesh = sp.datasets.ellipsoid(n_vertices=500)
    m = sp.embed(mesh, "radial", center="centroid")
    rng = np.random.default_rng(0)
    faces = rng.integers(0, mesh.n_faces, 100)
    bary = rng.dirichlet([1, 1, 1], 100)
    flat = np.einsum("kj,kjd->kd", bary, m.points[mesh.faces[faces]])
    np.testing.assert_allclose(m.to_sphere(faces, bary),
                               flat / np.linalg.norm(flat, axis=1)[:, None], atol=1e-15)


def test_to_surface_refuses_maps_that_are_not_bijections() -> None:
    mesh = sp.datasets.helix_tube(n_vertices=1500)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = sp.embed(mesh, "relaxation", max_iter=3)
    assert not m.valid
    with pytest.raises(sp.MapError, match="not a valid GC-embedding"):
        m.to_surface([[0.0, 0.0, 1.0]])
    # h itself is still a function.
    assert m.to_sphere([0], [[0.2, 0.3, 0.5]]).shape == (1, 3)


def test_to_surface_refuses_an_uncertified_rectangle() -> None:
    mesh = sp.datasets.tentacles(n_vertices=5000)
    with pytest.warns(sp.SpherifyWarning):
        m = sp.embed(mesh, method="theta_phi")
    assert not m.tp_valid
    with pytest.raises(sp.MapError, match="tp_valid"):
        m.to_surface([[1.0, 0.0, 0.0]])


def test_bad_input_names_the_row() -> None:
    mesh = sp.datasets.make("icosphere", 162)
    m = sp.embed(mesh)
    with pytest.raises(sp.MeshError, match="row 1: face id 9999"):
        m.to_sphere([0, 9999], [[1, 0, 0], [1, 0, 0]])
    with pytest.raises(sp.MeshError, match="row 0: barycentric"):
        m.to_sphere([0], [[0.5, 0.6, 0.0]])
    with pytest.raises(sp.MeshError, match="row 0: barycentric"):
        m.to_sphere([0], [[np.nan, 0.5, 0.5]])
    with pytest.raises(sp.MeshError, match="shape"):
        m.to_sphere([0], [[1, 0]])
    with pytest.raises(sp.MeshError, match="rows"):
        m.to_sphere([0, 1], [[1, 0, 0]])
    with pytest.raises(sp.MeshError, match="integers"):
        m.to_sphere([0.5], [[1, 0, 0]])
    with pytest.raises(sp.MeshError, match="row 1: .* not a unit vector"):
        m.to_surface([[0, 0, 1.0], [0, 0, 2.0]])
    with pytest.raises(sp.MeshError, match="row 0: .* not a unit vector"):
        m.to_surface([[np.nan, 0, 1.0]])
    with pytest.raises(sp.MeshError, match="shape"):
        m.to_surface([1.0, 0.0, 0.0])
