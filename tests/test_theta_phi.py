"""The theta-phi method (thesis ch. 6): certified flip-free in floating point."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import spherify as sp

TETRA_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def assert_theta_phi_invariants(m: sp.SphereMap, mesh: sp.Mesh) -> None:
    assert m.method == "theta_phi"
    n = mesh.n_vertices
    k = len(m.cut_path) - 2
    assert k >= 2
    assert m.cut_path[0] == m.poles[0] and m.cut_path[-1] == m.poles[1]
    np.testing.assert_allclose(np.linalg.norm(m.points, axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(m.points[m.poles[0]], [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(m.points[m.poles[1]], [0.0, 0.0, -1.0])
    # The cut mesh is a disk with a boundary of 2k + 2 vertices (thesis 6.3).
    report = sp.check(m.cut_mesh)
    assert report.euler_characteristic == 1 and report.n_boundary_loops == 1
    assert len(m.details["cut_boundary"]) == 2 * k + 2
    assert m.cut_mesh.n_vertices == n + k
    # theta in [0, pi], phi in [0, 2 pi] (6.29).
    tp = m.theta_phi
    assert tp.shape == (n + k, 2)
    assert np.all((tp[:, 0] >= 0) & (tp[:, 0] <= np.pi) & (tp[:, 1] >= 0) & (tp[:, 1] <= 2 * np.pi))
    # Folding (6.35) maps each vertex to its point; duplicates to their original's.
    t, p = tp[:, 0], tp[:, 1]
    folded = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)
    others = np.setdiff1d(np.arange(n), m.poles)
    np.testing.assert_allclose(folded[others], m.points[others], atol=1e-15)
    np.testing.assert_allclose(folded[n:], m.points[m.cut_original[n:]], atol=1e-12)


@pytest.mark.parametrize("name", ["icosphere", "ellipsoid", "bumpy_blob", "helix_tube"])
@pytest.mark.parametrize("size", [200, 5000])
def test_dataset_shapes_are_certified(name: str, size: int) -> None:
    mesh = sp.datasets.make(name, size)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = sp.embed(mesh, method="theta_phi")
    assert m.tp_valid, m.message
    assert_theta_phi_invariants(m, mesh)
    # A flip-free rectangle folds to a drawing that covers the sphere once.
    assert m.report.covering_degree == 1


@pytest.mark.parametrize("poles", ["fast_graph", "graph", "physical", (0, 100)])
def test_pole_choices(poles: object) -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=300)
    m = sp.embed(mesh, method="theta_phi", poles=poles)
    assert m.tp_valid
    assert_theta_phi_invariants(m, mesh)
    if isinstance(poles, tuple):
        assert m.poles == poles


def test_graph_poles_are_the_exact_graph_diameter() -> None:
    mesh = sp.datasets.helix_tube(n_vertices=200)
    m = sp.embed(mesh, method="theta_phi", poles="graph")
    best = max(sp.dijkstra(mesh, v)[0].max() for v in range(mesh.n_vertices))
    dist, _ = sp.dijkstra(mesh, m.poles[0])
    assert dist[m.poles[1]] == pytest.approx(best, rel=1e-12)


def test_physical_poles_are_the_farthest_pair() -> None:
    mesh = sp.datasets.tentacles(n_vertices=2000)
    m = sp.embed(mesh, method="theta_phi", poles="physical")
    V = mesh.vertices
    d = np.linalg.norm(V[:, None, :] - V[None, :, :], axis=2)
    assert np.linalg.norm(V[m.poles[0]] - V[m.poles[1]]) == d.max()


def test_tetrahedron_needs_a_lengthened_path() -> None:
    m = sp.embed(sp.Mesh(TETRA_V, TETRA_F), method="theta_phi")
    assert len(m.cut_path) == 4
    assert m.tp_valid


def test_inward_mesh_is_reoriented_first() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    inward = sp.Mesh(mesh.vertices, mesh.faces[:, ::-1])
    m = sp.embed(inward, method="theta_phi")
    assert m.tp_valid and m.valid
    assert any("reoriented" in note for note in m.notes)


def test_double_precision_limit_is_reported_not_hidden() -> None:
    # Long thin spikes: the exact embedding's coordinates there differ by less
    # than double precision can represent (see docs/experiments.md).
    mesh = sp.datasets.urchin(n_vertices=20000)
    with pytest.warns(sp.SpherifyWarning, match="double precision"):
        m = sp.embed(mesh, method="theta_phi")
    assert not m.tp_valid
    collapsed = len(m.details["tp_degenerate_faces"]) + len(m.details["tp_flipped_faces"])
    assert collapsed > 0
    assert str(collapsed) in m.message or str(len(m.details["tp_degenerate_faces"])) in m.message


def test_bad_options() -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    with pytest.raises(sp.MeshError, match="poles"):
        sp.embed(mesh, method="theta_phi", poles="symmetric")
    with pytest.raises(sp.MeshError):
        sp.embed(mesh, method="theta_phi", poles=(3, 3))
    with pytest.raises(sp.MeshError, match="weights"):
        sp.embed(mesh, method="theta_phi", weights="cotangent")
    with pytest.raises(sp.MeshError, match="method"):
        sp.embed(mesh, "no_such_method")
    with pytest.raises(sp.TopologyError):
        sp.embed(sp.Mesh(TETRA_V, TETRA_F[:3]))


@pytest.mark.corpus
def test_corpus_is_certified(shared_meshes: Path) -> None:
    manifest = json.loads((shared_meshes / "MANIFEST.json").read_text())
    for entry in manifest:
        if not isinstance(entry["genus"], int):
            continue
        mesh = sp.load(shared_meshes / entry["path"])
        m = sp.embed(mesh, method="theta_phi")
        assert m.tp_valid, f"{entry['name']}: {m.message}"


def test_re_embedded_fan_is_pinned_on_a_strictly_convex_arc() -> None:
    """A random 47-vertex mesh whose north fan needs 6.36-6.38: with the fan on
    the thesis's straight line theta = h1, a face made of three pole
    neighbours collapsed to zero area (in exact arithmetic too); on the arc
    the rectangle is certified."""
    import sys
    sys.path.insert(0, str(Path(__file__).parent))
    from _meshgen import make_surface
    s = make_surface(47, 57, flip_fraction=1.5, stretch=1.0, flatten=0.5, twist=0.0, bend=0.0,
                     log_scale=0.0)
    m = sp.embed(sp.Mesh(s.V, s.F), method="theta_phi")
    assert m.details["re_embedded"][0]
    assert m.tp_valid, m.message
    assert all(m.details["fans_monotone"])
