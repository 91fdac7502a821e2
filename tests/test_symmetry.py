"""Symmetry poles (thesis 6.2.5): the principal planes of the area-weighted
confidence ellipsoid, their scores, the near-plane band, and the fallback."""

from __future__ import annotations

import warnings
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest
from hypothesis import given, settings

import spherify as sp

pytest.importorskip("scipy", reason="the random mesh strategies use scipy.spatial.ConvexHull")

import _meshgen as mg  # noqa: E402


def oracle_planes(V: np.ndarray, F: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 6.11-6.18 written out in numpy: centre, eigenvalues (ascending),
    normals (columns) and the score max(|D| / sum|d|, |sum w d^3| / sum w |d|^3)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    y = (a + b + c) / 3.0
    w = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    m = (w[:, None] * y).sum(axis=0) / w.sum()
    X = y - m
    lam, Q = np.linalg.eigh((X * w[:, None]).T @ X / w.sum())
    d = X @ Q  # (F, 3): signed distances to the three planes
    balance = np.abs(d.sum(axis=0)) / np.abs(d).sum(axis=0)
    skew = np.abs((w[:, None] * d**3).sum(axis=0)) / (w[:, None] * np.abs(d) ** 3).sum(axis=0)
    return m, lam, Q, np.maximum(balance, skew)


# numpy and the core may round a signed distance differently in the last bit.
SLACK = 1e-12


def near(d: np.ndarray, eps: float) -> np.ndarray:
    """|d| <= eps, up to rounding."""
    return np.abs(d) <= eps * (1 + SLACK) + 1e-300


def assert_band(d: np.ndarray, eps: float, band: int) -> None:
    """The core's band count is |{v : |d_v| <= eps}| up to rounding."""
    assert int(np.sum(np.abs(d) <= eps * (1 - SLACK))) <= band <= int(np.sum(near(d, eps)))


def embed_quietly(mesh: Any, **options: Any) -> Tuple[sp.SphereMap, List[warnings.WarningMessage]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = sp.embed(mesh, method="theta_phi", poles="symmetry", **options)
    return m, list(caught)


def one_mirror_plane() -> sp.Mesh:
    """The icosphere bent so that y = 0 is its only mirror plane (y is the
    middle axis, so no rule based on the axes' order alone finds it)."""
    ico = sp.datasets.icosphere(subdivisions=3)
    x, y, z = ico.vertices.T
    V = np.stack([1.6 * x + 0.4 * z**2, y, 0.7 * z + 0.3 * x**2], axis=1)
    return sp.Mesh(V, ico.faces)


def three_bumps() -> sp.Mesh:
    """Clearly asymmetric: three bumps of different heights in general directions."""
    ico = sp.datasets.icosphere(subdivisions=3)
    V = ico.vertices
    r = np.ones(len(V))
    for direction, height in [((0.8, 0.5, 0.3), 0.9), ((-0.2, 0.9, -0.4), 0.5),
                              ((-0.6, -0.3, 0.7), 0.3)]:
        u = np.asarray(direction) / np.linalg.norm(direction)
        r += height * np.clip(V @ u, 0.0, None) ** 8
    return sp.Mesh(V * r[:, None], ico.faces)


def assert_matches_oracle(mesh: sp.Mesh, sym: Dict[str, Any]) -> None:
    m, lam, Q, score = oracle_planes(mesh.vertices, mesh.faces)
    np.testing.assert_allclose(sym["centre"], m, atol=1e-12 * np.abs(mesh.vertices).max())
    np.testing.assert_allclose(sym["variances"], lam, rtol=1e-9, atol=1e-15 * lam.max())
    # Normals are defined up to sign only where eigenvalues are well apart.
    gaps = np.diff(lam) / lam.max()
    if gaps.min() > 1e-6:
        dots = np.abs(np.sum(np.asarray(sym["normals"]) * Q.T, axis=1))
        np.testing.assert_allclose(dots, 1.0, atol=1e-8)
        np.testing.assert_allclose(sym["scores"], score, rtol=1e-6, atol=1e-12)
        # Least score, ties (1e-9) to the least variance.
        assert sym["chosen"] == int(np.flatnonzero(score <= score.min() + 1e-9)[0])


@pytest.mark.parametrize("name", ["ellipsoid", "bumpy_blob", "helix_tube", "tentacles", "urchin"])
def test_planes_and_choice_match_a_numpy_oracle(name: str) -> None:
    mesh = sp.datasets.make(name, 600)
    m, _ = embed_quietly(mesh, symmetry_max_score=1.0)
    assert_matches_oracle(mesh, m.details["symmetry"])


def test_the_only_mirror_plane_is_found_and_the_cut_lies_in_it() -> None:
    mesh = one_mirror_plane()
    m, caught = embed_quietly(mesh)
    assert not caught
    sym = m.details["symmetry"]
    assert sym["fallback"] is None
    assert abs(abs(sym["normal"][1]) - 1.0) < 1e-12 and sym["score"] < 1e-12
    assert_matches_oracle(mesh, sym)
    # The band is eq. 6.20 with the automatic eps: both ends of every edge
    # that crosses the plane, and nothing farther.
    d = (mesh.vertices - sym["centre"]) @ np.asarray(sym["normal"])
    E = np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]], mesh.faces[:, [2, 0]]])
    crossing = np.sign(d[E[:, 0]]) * np.sign(d[E[:, 1]]) < 0
    eps = np.abs(d[E[crossing]]).max() if crossing.any() else 0.0
    assert sym["eps"] == pytest.approx(eps, rel=1e-12, abs=1e-15)
    assert_band(d, sym["eps"], sym["band"])
    assert tuple(sym["symmetry_poles"]) == m.poles
    assert np.all(near(d[m.cut_path], sym["eps"]))
    assert m.tp_valid and m.valid


def test_ellipsoid_cut_runs_along_its_two_longest_axes() -> None:
    mesh = sp.datasets.ellipsoid(1500, axes=(1.0, 0.6, 0.4))
    m, caught = embed_quietly(mesh)
    assert not caught
    sym = m.details["symmetry"]
    assert abs(sym["normal"][2]) > 1 - 1e-9  # the plane z = 0 holds x and y
    north, south = mesh.vertices[list(m.poles)]
    assert abs(north[0] - south[0]) > 1.9  # the ends of the long axis


def test_explicit_eps_sets_the_band() -> None:
    mesh = one_mirror_plane()
    m, _ = embed_quietly(mesh, symmetry_eps=0.2)
    sym = m.details["symmetry"]
    d = (mesh.vertices - sym["centre"]) @ np.asarray(sym["normal"])
    assert sym["eps"] == 0.2
    assert_band(d, 0.2, sym["band"])
    assert np.all(near(d[m.cut_path], 0.2))


def test_asymmetric_mesh_falls_back_with_a_warning() -> None:
    mesh = three_bumps()
    _, _, _, score = oracle_planes(mesh.vertices, mesh.faces)
    assert score.min() > 0.05  # the oracle agrees there is no convincing plane
    with pytest.warns(sp.SpherifyWarning, match="fell back to fast_graph: no convincing symmetry"):
        m = sp.embed(mesh, method="theta_phi", poles="symmetry")
    sym = m.details["symmetry"]
    assert "no convincing symmetry plane" in sym["fallback"]
    assert sym["score"] == pytest.approx(score.min(), rel=1e-6)
    # The fallback is exactly the fast-graph result.
    fast = sp.embed(mesh, method="theta_phi", poles="fast_graph")
    assert m.poles == fast.poles
    np.testing.assert_array_equal(m.cut_path, fast.cut_path)
    # Raising the threshold accepts the best plane instead, without warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lax = sp.embed(mesh, method="theta_phi", poles="symmetry", symmetry_max_score=1.0)
    assert lax.details["symmetry"]["fallback"] is None


def test_too_thin_a_band_falls_back() -> None:
    # A plane in general position (accepted with any score) with no vertex
    # within 1e-9 of it.
    mesh = three_bumps()
    with pytest.warns(sp.SpherifyWarning, match="too few to hold a cut path"):
        m = sp.embed(mesh, method="theta_phi", poles="symmetry", symmetry_eps=1e-9,
                     symmetry_max_score=1.0)
    sym = m.details["symmetry"]
    assert sym["band"] < 4 and sym["fallback"].startswith("the vertices near the symmetry plane")
    assert m.poles == sp.embed(mesh, method="theta_phi", poles="fast_graph").poles


def test_poles_close_together_fall_back() -> None:
    # The helix's best plane (a plane of two-fold rotation symmetry, score 0)
    # meets the tube in separate small loops: poles on one of them are close.
    mesh = sp.datasets.helix_tube(1500)
    with pytest.warns(sp.SpherifyWarning, match="too close together"):
        m = sp.embed(mesh, method="theta_phi", poles="symmetry")
    sym = m.details["symmetry"]
    assert sym["score"] < 1e-6 and sym["spread"] < 0.25
    assert sym["component"] < sym["band"] / 2
    # The spread is the path length inside the band over the fast-graph
    # distance; no path between the poles is shorter than their geodesic.
    fast = sp.embed(mesh, method="theta_phi", poles="fast_graph")
    dist, _ = sp.dijkstra(mesh, fast.poles[0])
    north, south = sym["symmetry_poles"]
    d_ns, _ = sp.dijkstra(mesh, north)
    assert d_ns[south] <= sym["spread"] * dist[fast.poles[1]] * (1 + 1e-12)
    assert m.poles == fast.poles and m.tp_valid


@pytest.mark.parametrize("options, word", [({"symmetry_eps": -1.0}, "eps"),
                                           ({"symmetry_eps": float("nan")}, "eps"),
                                           ({"symmetry_max_score": 2.0}, "max_score")])
def test_bad_parameters_raise(options: Dict[str, Any], word: str) -> None:
    with pytest.raises(sp.MeshError, match=word):
        sp.embed(sp.datasets.ellipsoid(200), method="theta_phi", poles="symmetry", **options)


@settings(max_examples=30)
@given(mg.surfaces(max_vertices=200))
def test_random_meshes_give_a_valid_cut(surface: mg.Surface) -> None:
    mesh = sp.Mesh(surface.V, surface.F)
    m, caught = embed_quietly(mesh)
    sym = m.details["symmetry"]
    messages = [str(w.message) for w in caught if issubclass(w.category, sp.SpherifyWarning)]
    # A warning exactly when it fell back (or when double precision failed).
    fell_back = [s for s in messages if "fell back" in s]
    assert bool(fell_back) == (sym["fallback"] is not None)
    # Pole fans re-embedded by eq. 6.38 lie on a strictly convex arc, so a
    # free vertex whose neighbours are all pinned no longer collapses onto the
    # thesis's straight line: every one of these must be certified.
    assert m.tp_valid, m.message
    path = np.asarray(m.cut_path)
    assert len(path) >= 4 and len(set(path.tolist())) == len(path)
    assert (path[0], path[-1]) == m.poles
    edges = {tuple(sorted(e)) for f in surface.F.tolist() for e in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])]}
    assert all(tuple(sorted((int(a), int(b)))) in edges for a, b in zip(path[:-1], path[1:]))
    if sym["fallback"] is None:
        d = (surface.V - sym["centre"]) @ np.asarray(sym["normal"])
        assert np.all(near(d[list(m.poles)], sym["eps"]))


@pytest.mark.parametrize("poles", [None, "fast_graph", (0, 5)])
@pytest.mark.parametrize("option", [{"symmetry_eps": 0.1}, {"symmetry_max_score": 0.2}])
def test_symmetry_options_without_symmetry_poles_are_refused(poles: Any,
                                                              option: Dict[str, float]) -> None:
    # They would be ignored without a word: the caller meant something else.
    mesh = sp.datasets.make("ellipsoid", 200)
    extra: Dict[str, Any] = {} if poles is None else {"poles": poles}
    with pytest.raises(sp.SpherifyError, match=f"{next(iter(option))} only applies to poles"):
        sp.embed(mesh, "theta_phi", **option, **extra)
    assert sp.embed(mesh, "theta_phi", poles="symmetry", **option).method == "theta_phi"
