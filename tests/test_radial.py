"""Radial projection (thesis 3.5, eq. 3.17) from a point, the vertex mean, or the
deepest point of the kernel (found by a linear program, which settles the choice
of m left open in 9.3.1)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Sequence, Tuple

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import spherify as sp

Arrays = Tuple[np.ndarray, np.ndarray]


def on_unit_sphere(points: np.ndarray) -> bool:
    return bool(np.abs(np.linalg.norm(points, axis=1) - 1.0).max() <= 1e-12)


def uv_sphere(n_lat: int, n_lon: int) -> Arrays:
    """Latitude-longitude unit sphere with its poles on the x axis (vertices
    crowd round the poles), faces counter-clockwise seen from outside."""
    theta = np.pi * np.arange(1, n_lat) / n_lat
    phi = 2 * np.pi * np.arange(n_lon) / n_lon
    T, P = np.meshgrid(theta, phi, indexing="ij")
    ring = np.column_stack([np.cos(T).ravel(), (np.sin(T) * np.cos(P)).ravel(),
                            (np.sin(T) * np.sin(P)).ravel()])
    V = np.vstack([[1.0, 0.0, 0.0], ring, [-1.0, 0.0, 0.0]])
    south = len(V) - 1

    def at(i: int, j: int) -> int:
        return 1 + (i - 1) * n_lon + j % n_lon

    F = []
    for j in range(n_lon):
        F += [[0, at(1, j), at(1, j + 1)], [south, at(n_lat - 1, j + 1), at(n_lat - 1, j)]]
        for i in range(1, n_lat - 1):
            F += [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]]
    return V, np.array(F, dtype=np.int64)


def spike(U: np.ndarray, axis: Sequence[float], height: float, width: float) -> np.ndarray:
    c = U @ np.asarray(axis, dtype=float)
    w = np.cos(width)
    return np.where(c > w, height * ((np.maximum(c, w) - w) / (1 - w)) ** 2, 0.0)


def star_not_from_centroid(shift: Sequence[float] = (3.0, -2.0, 50.0)) -> sp.Mesh:
    """Star-shaped from its origin (a radial graph over a convex triangulation),
    but a long +x spike that is dense in vertices (the grid's pole) drags the
    vertex mean far along +x, where the flanks of four side spikes hide faces."""
    U, F = uv_sphere(60, 80)
    side = sum(spike(U, axis, 4.0, 0.3) for axis in ([0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]))
    r = 1.0 + spike(U, [1, 0, 0], 30.0, 0.35) + side
    return sp.Mesh(U * r[:, None] + np.asarray(shift), F)


# --------------------------------------------------------------------------
# Star-shaped meshes map validly from the kernel
# --------------------------------------------------------------------------

@given(seed=st.integers(0, 2**31 - 1), amplitude=st.floats(0.0, 0.6), bumps=st.integers(1, 20),
       n=st.integers(50, 3000), shift=st.tuples(*[st.floats(-1e3, 1e3)] * 3),
       log_scale=st.floats(-3.0, 3.0))
def test_bumpy_blob_maps_validly_from_the_kernel(seed: int, amplitude: float, bumps: int, n: int,
                                                 shift: Tuple[float, float, float],
                                                 log_scale: float) -> None:
    blob = sp.datasets.bumpy_blob(n_vertices=n, bumps=bumps, amplitude=amplitude, seed=seed)
    scale = 10.0 ** log_scale
    mesh = sp.Mesh(blob.vertices * scale + np.asarray(shift) * scale, blob.faces)
    m = sp.embed(mesh, "radial", center="kernel")
    assert m.valid and m.flipped == 0, m.message
    assert on_unit_sphere(m.points)
    assert (m.method, m.status, m.iterations, m.converged) == ("radial", "direct", 0, True)
    assert set(m.seconds) == {"center", "project", "certify"}
    assert "kernel" in m.message


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(4, 300), axes=st.tuples(*[st.floats(0.05, 5.0)] * 3),
       shift=st.tuples(*[st.floats(-100.0, 100.0)] * 3))
def test_convex_hulls_map_validly_from_the_kernel(seed: int, n: int, axes: Tuple[float, float, float],
                                                  shift: Tuple[float, float, float]) -> None:
    mg = pytest.importorskip("_meshgen")
    pytest.importorskip("scipy")
    V, F = mg._hull(np.random.default_rng(seed), n)
    # An affine image of a convex polyhedron is convex.
    m = sp.embed((V * np.asarray(axes) + np.asarray(shift), F), "radial")
    assert m.valid, m.message
    assert on_unit_sphere(m.points)


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(4, 400), spread=st.floats(0.0, 0.99))
def test_random_radial_graphs_map_validly_from_the_kernel(seed: int, n: int, spread: float) -> None:
    """Each vertex of a convex hull round the origin moved along its ray by a
    random factor: star-shaped from the origin, often not from the vertex mean."""
    mg = pytest.importorskip("_meshgen")
    pytest.importorskip("scipy")
    rng = np.random.default_rng(seed)
    V, F = mg._hull(rng, n)
    # Star-shaped from the origin only if the hull holds it: every face sees
    # it from inside (a few points may all lie in one hemisphere).
    assume(bool((np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])) > 1e-9).all()))
    V = V * rng.uniform(1.0 - spread, 1.0 + spread, size=(n, 1)) + rng.uniform(-10, 10, size=3)
    m = sp.embed((V, F), "radial", center="kernel")
    assert m.valid, m.message
    assert on_unit_sphere(m.points)


def test_the_centroid_fails_where_the_kernel_succeeds() -> None:
    mesh = star_not_from_centroid()
    from_centroid = sp.embed(mesh, "radial", center="centroid")
    assert not from_centroid.valid and from_centroid.flipped > 0
    assert "vertex mean" in from_centroid.message
    from_kernel = sp.embed(mesh, "radial", center="kernel")
    assert from_kernel.valid and from_kernel.flipped == 0, from_kernel.message
    assert on_unit_sphere(from_kernel.points)
    # The default is the kernel.
    default = sp.embed(mesh, "radial")
    np.testing.assert_array_equal(default.points, from_kernel.points)


def test_kernel_point_and_depth_are_reported() -> None:
    blob = sp.datasets.bumpy_blob(n_vertices=500, seed=1)
    m = sp.embed(blob, "radial", center="kernel")
    points, info = m.points, m.details
    assert info["kernel_depth"] > 0 and info["lp_pivots"] >= 0
    centre = np.asarray(info["center"])
    # The projection is exactly from the reported centre.
    d = blob.vertices - centre
    np.testing.assert_allclose(points, d / np.linalg.norm(d, axis=1)[:, None], rtol=0, atol=1e-15)
    # Moving the mesh moves the centre with it.
    moved = sp.embed(sp.Mesh(blob.vertices + [7.0, 0.0, -2.0], blob.faces), "radial").details
    np.testing.assert_allclose(np.asarray(moved["center"]) - centre, [7.0, 0.0, -2.0], atol=1e-9)
    assert moved["kernel_depth"] == pytest.approx(info["kernel_depth"], rel=1e-9)


def test_same_input_same_output() -> None:
    mesh = star_not_from_centroid()
    a = sp.embed(mesh, "radial").points
    b = sp.embed(mesh, "radial").points
    assert a.tobytes() == b.tobytes()


# --------------------------------------------------------------------------
# Explicit centres
# --------------------------------------------------------------------------

def test_a_point_centre_inside_and_outside() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    inside = sp.embed(mesh, "radial", center=(0.1, -0.2, 0.05))
    assert inside.valid and on_unit_sphere(inside.points)
    assert "given point" in inside.message
    # Outside the mesh: points come back, but the map is not valid (no error).
    outside = sp.embed(mesh, "radial", center=np.array([3.0, 0.5, 0.25]))
    assert not outside.valid and outside.flipped > 0
    assert on_unit_sphere(outside.points)
    from_list = sp.embed(mesh, "radial", center=[3, 0.5, 0.25])
    np.testing.assert_array_equal(from_list.points, outside.points)


@pytest.mark.parametrize("center", [
    "middle", "", "Kernel", (1.0, 2.0), [0.0, 0.0, 0.0, 0.0], (float("nan"), 0.0, 0.0),
    (0.0, float("inf"), 0.0), ("a", "b", "c"), b"abc", 5, 2.5, np.zeros((1, 3)), {"x": 1.0},
])
def test_bad_centres_raise_mesh_error(center: Any) -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    with pytest.raises(sp.MeshError, match="center"):
        sp.embed(mesh, "radial", center=center)


def test_a_centre_on_a_vertex_raises_mesh_error() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    with pytest.raises(sp.MeshError, match="vertex 3"):
        sp.embed(mesh, "radial", center=tuple(mesh.vertices[3]))


def test_unknown_option_raises_mesh_error() -> None:
    with pytest.raises(sp.MeshError):
        sp.embed(sp.datasets.icosphere(subdivisions=1), "radial", centre="kernel")


# --------------------------------------------------------------------------
# Meshes that are not star-shaped
# --------------------------------------------------------------------------

@pytest.mark.parametrize("make", [
    lambda: sp.datasets.helix_tube(n_vertices=2000),
    lambda: sp.datasets.tentacles(n_vertices=2000),
    lambda: sp.datasets.tentacles(n_vertices=2000, curl=0.0, seed=3),
])
def test_non_star_shaped_meshes_raise(make: Any) -> None:
    mesh = make()
    with pytest.raises(sp.MeshError, match="not star-shaped") as err:
        sp.embed(mesh, "radial", center="kernel")
    assert isinstance(err.value, sp.SpherifyError)
    assert "face away from the vertex mean" in str(err.value)
    # The other centres still give points, which the exact test rejects.
    m = sp.embed(mesh, "radial", center="centroid")
    assert not m.valid and on_unit_sphere(m.points)


# --------------------------------------------------------------------------
# The real-mesh corpus
# --------------------------------------------------------------------------

def corpus_entries(root: Path) -> Any:
    with open(root / "MANIFEST.json", encoding="utf-8") as f:
        return [e for e in json.load(f) if not e["path"].startswith("invalid/")]


@pytest.mark.corpus
def test_corpus_star_shaped_meshes_map_validly_and_the_rest_raise(shared_meshes: Path) -> None:
    entries = corpus_entries(shared_meshes)
    assert {e["path"] for e in entries if e["star_shaped_some_point"]} >= {"bumpy.off", "soccerball.obj"}
    for e in entries:
        mesh = sp.load(shared_meshes / e["path"])
        if e["star_shaped_some_point"]:
            m = sp.embed(mesh, "radial", center="kernel")
            assert m.valid and m.flipped == 0, (e["path"], m.message)
            assert on_unit_sphere(m.points)
        else:
            with pytest.raises(sp.MeshError, match="not star-shaped"):
                sp.embed(mesh, "radial", center="kernel")
