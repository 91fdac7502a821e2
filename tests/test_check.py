"""sp.check on random valid genus-0 meshes and on meshes broken in known ways."""

from __future__ import annotations

import dataclasses
from typing import Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp

pytest.importorskip("scipy", reason="the random mesh strategies use scipy.spatial.ConvexHull")

import _meshgen as mg  # noqa: E402

CAP = 100  # lists in a MeshReport hold at most this many ids

LISTS = [
    ("boundary_loops", "n_boundary_loops"),
    ("nonmanifold_edges", "n_nonmanifold_edges"),
    ("nonmanifold_vertices", "n_nonmanifold_vertices"),
    ("degenerate_faces", "n_degenerate_faces"),
    ("duplicate_faces", "n_duplicate_faces"),
    ("unreferenced_vertices", "n_unreferenced_vertices"),
    ("non_finite_vertices", "n_non_finite_vertices"),
    ("out_of_range_faces", "n_out_of_range_faces"),
    ("inconsistent_edges", "n_inconsistent_edges"),
]


def assert_coherent(r: sp.MeshReport) -> None:
    """Relations between the fields of any report, whatever the mesh."""
    for items, total in LISTS:
        assert len(getattr(r, items)) == min(getattr(r, total), CAP), items
    assert r.valid == (r.is_sphere_topology and not r.problems)
    assert r.manifold == (r.n_nonmanifold_edges == 0 and r.n_nonmanifold_vertices == 0)
    assert r.connected == (r.n_components == 1)
    if r.closed:
        assert r.n_boundary_edges == 0 and r.n_boundary_loops == 0 and r.n_nonmanifold_edges == 0
    if r.is_sphere_topology:
        assert r.closed and r.manifold and r.connected
        assert r.euler_characteristic == 2 and r.genus == 0
        assert r.n_unreferenced_vertices == 0
    if r.outward:
        assert r.closed and r.consistently_oriented and r.signed_volume > 0
    if r.genus is not None:
        assert r.manifold
        assert r.euler_characteristic == 2 * (r.n_components - r.genus) - r.n_boundary_loops
    for a, b in list(r.nonmanifold_edges) + list(r.inconsistent_edges):
        assert 0 <= a < b < r.n_vertices
    for loop in r.boundary_loops:
        assert all(0 <= v < r.n_vertices for v in loop)


def report_of(V: np.ndarray, F: np.ndarray) -> sp.MeshReport:
    r = sp.check(sp.Mesh(V, F))
    assert_coherent(r)
    return r


# --------------------------------------------------------------------------
# Valid meshes
# --------------------------------------------------------------------------

@given(mg.surfaces())
def test_random_genus0_mesh_is_clean(s: mg.Surface) -> None:
    r = report_of(s.V, s.F)
    n, m = len(s.V), len(s.F)
    assert (r.n_vertices, r.n_faces, r.n_edges) == (n, m, 3 * m // 2)
    assert r.is_sphere_topology and r.valid
    assert r.closed and r.manifold and r.connected and r.n_components == 1
    assert r.euler_characteristic == 2 and r.genus == 0
    assert r.consistently_oriented and r.outward
    assert r.problems == []
    for items, total in LISTS:
        assert getattr(r, total) == 0 and getattr(r, items) == []
    assert r.n_boundary_edges == 0
    assert r.signed_volume == pytest.approx(mg.signed_volume(s.V, s.F), rel=1e-9)


@given(mg.surfaces(max_vertices=60))
def test_raw_pair_and_mesh_give_the_same_report(s: mg.Surface) -> None:
    by_mesh = sp.check(sp.Mesh(s.V, s.F))
    # Lists and other integer dtypes are converted, not rejected.
    by_pair = sp.check((s.V.tolist(), s.F.astype(np.int32)))
    assert by_pair == by_mesh
    assert sp.check(sp.Mesh(s.V, s.F)) == by_mesh  # deterministic


def test_tetrahedron_is_clean() -> None:
    r = report_of(mg.TETRA_V, mg.TETRA_F)
    assert r.valid and (r.n_vertices, r.n_faces, r.n_edges) == (4, 4, 6)
    assert r.signed_volume == pytest.approx(1 / 6, rel=1e-12)


@given(mg.surfaces())
def test_all_faces_reversed_is_consistent_but_inward(s: mg.Surface) -> None:
    r = report_of(s.V, s.F[:, ::-1])
    assert r.is_sphere_topology and r.consistently_oriented
    assert not r.outward and not r.valid
    assert r.signed_volume == pytest.approx(-mg.signed_volume(s.V, s.F), rel=1e-9)
    assert len(r.problems) == 1  # inward faces, nothing else


# --------------------------------------------------------------------------
# Broken meshes
# --------------------------------------------------------------------------

def comparable(value):
    """Lists of ids or id pairs compare as sorted lists of tuples; the rest as is."""
    if isinstance(value, list):
        return sorted(tuple(x) if isinstance(x, (list, tuple)) else x for x in value)
    return value


@pytest.mark.parametrize("kind", sorted(mg.BROKEN))
@given(data=st.data())
def test_broken_mesh_is_classified(kind: str, data: st.DataObject) -> None:
    b = data.draw(mg.BROKEN[kind](), label="broken")
    r = report_of(b.V, b.F)
    got = {name: comparable(getattr(r, name)) for name in b.expect}
    assert got == {name: comparable(value) for name, value in b.expect.items()}
    assert not r.valid and r.problems, "a broken mesh must come with at least one problem"


@given(mg.with_holes())
def test_holes_are_boundary_loops_running_against_the_removed_faces(b: mg.Broken) -> None:
    r = report_of(b.V, b.F)
    assert r.n_boundary_loops == len(b.info["loops"])
    unmatched = list(r.boundary_loops)
    for cycle in b.info["loops"]:
        match = [loop for loop in unmatched if mg.same_cycle(loop, cycle)]
        assert match, f"no boundary loop runs {cycle}: {r.boundary_loops}"
        unmatched.remove(match[0])


@given(mg.with_star_removed())
def test_removed_vertex_star_leaves_its_link_as_the_boundary(b: mg.Broken) -> None:
    r = report_of(b.V, b.F)
    assert len(r.boundary_loops) == 1
    assert mg.same_cycle(r.boundary_loops[0], b.info["loops"][0])


@given(mg.with_flipped_faces())
def test_flipped_faces_give_exactly_the_edges_between_flipped_and_kept(b: mg.Broken) -> None:
    r = report_of(b.V, b.F)
    listed = {tuple(e) for e in r.inconsistent_edges}
    assert r.n_inconsistent_edges == len(b.info["inconsistent"]) > 0
    if r.n_inconsistent_edges <= CAP:
        assert listed == b.info["inconsistent"]
    else:
        assert listed <= b.info["inconsistent"]
    # Flipping faces is not a topological change.
    assert r.is_sphere_topology and r.euler_characteristic == 2 and r.genus == 0


@given(mg.with_handle())
def test_handle_makes_genus_one_and_a_second_handle_genus_two(b: mg.Broken) -> None:
    r = report_of(b.V, b.F)
    assert r.genus == 1 and r.euler_characteristic == 0
    # The surface is still consistently oriented and closed: a hole in it is a
    # boundary loop on a genus-1 surface.
    holed = report_of(b.V, b.F[1:])
    assert holed.genus == 1 and holed.n_boundary_loops == 1 and holed.euler_characteristic == -1


@given(mg.with_zero_area_faces())
def test_zero_area_faces_are_degenerate_but_not_a_topology_problem(b: mg.Broken) -> None:
    r = report_of(b.V, b.F)
    assert r.is_sphere_topology and not r.valid
    assert r.degenerate_faces == b.expect["degenerate_faces"]


def test_collinear_face_with_distinct_vertices_is_degenerate() -> None:
    # An octahedron with one vertex moved to the exact midpoint of two others
    # (all coordinates small integers or halves: exactly representable).
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    r = report_of(V, F)
    assert r.valid
    W = V.copy()
    W[4] = 0.5 * (V[0] + V[2])  # on the segment 0-2: face [0, 2, 4] has zero area
    r = report_of(W, F)
    assert r.degenerate_faces == [0]
    assert r.is_sphere_topology and not r.valid


@given(mg.surfaces(max_vertices=80), st.integers(101, 250))
def test_lists_are_capped_but_counts_are_not(s: mg.Surface, extra: int) -> None:
    V = np.concatenate([s.V, np.zeros((extra, 3))])
    r = report_of(V, s.F)
    assert r.n_unreferenced_vertices == extra
    assert len(r.unreferenced_vertices) == CAP
    assert set(r.unreferenced_vertices) <= set(range(len(s.V), len(V)))


# --------------------------------------------------------------------------
# Raw (vertices, faces) pairs with NaN and bad indices
# --------------------------------------------------------------------------

@given(mg.with_duplicate_face(), st.data())
def test_raw_pair_reports_bad_values_and_keeps_input_face_ids(b: mg.Broken, data: st.DataObject) -> None:
    n, m = len(b.V), len(b.F)
    V = b.V.copy()
    poisoned = data.draw(st.lists(st.integers(0, n - 1), max_size=5, unique=True), label="poisoned")
    for i, v in enumerate(poisoned):
        V[v, i % 3] = [np.nan, np.inf, -np.inf][i % 3]
    bad_rows = data.draw(st.lists(st.sampled_from([[-1, 0, 1], [0, n, 1], [2, 1, 10**9], [-5, -6, -7]]),
                                  min_size=1, max_size=4), label="bad_rows")
    positions = data.draw(st.lists(st.integers(0, m), min_size=len(bad_rows), max_size=len(bad_rows)),
                          label="positions")
    F = b.F.tolist()
    original_id = list(range(m))
    for row, at in sorted(zip(bad_rows, positions), key=lambda x: -x[1]):
        F.insert(at, row)
        original_id.insert(at, -1)
    F = np.array(F, dtype=np.int64)
    r = sp.check((V, F))
    assert_coherent(r)
    assert r.n_faces == len(F) and r.n_vertices == n
    assert r.out_of_range_faces == [i for i, o in enumerate(original_id) if o < 0]
    assert r.non_finite_vertices == sorted(poisoned)
    # Face ids refer to the input array, bad rows included.
    (dup,) = b.expect["duplicate_faces"]
    assert r.duplicate_faces == [original_id.index(dup)]
    assert not r.is_sphere_topology and not r.valid
    assert r.problems


def test_raw_pair_with_only_bad_faces_reports_them() -> None:
    V = mg.TETRA_V
    F = np.array([[0, 1, 4], [-1, 2, 3]])
    r = sp.check((V, F))
    assert r.out_of_range_faces == [0, 1] and r.n_out_of_range_faces == 2
    assert r.n_unreferenced_vertices == 4
    assert not r.is_sphere_topology and not r.valid


# --------------------------------------------------------------------------
# Non-orientable surfaces
# --------------------------------------------------------------------------

def test_projective_plane_is_closed_non_orientable_and_has_no_genus() -> None:
    V, F = mg.projective_plane()
    r = report_of(V, F)
    assert (r.n_vertices, r.n_faces, r.n_edges) == (6, 10, 15)
    assert r.closed and r.manifold and r.euler_characteristic == 1
    assert not r.consistently_oriented and not r.is_sphere_topology
    assert r.genus is None  # 2 - chi = 1 is odd: no orientable genus


def test_moebius_strip_is_open_and_not_consistently_oriented() -> None:
    V, F = mg.moebius_strip()
    r = report_of(V, F)
    assert r.n_boundary_loops == 1 and r.euler_characteristic == 0
    assert not r.consistently_oriented and not r.closed


def test_notes_from_loading_reach_the_report(tmp_path) -> None:
    path = tmp_path / "quad.obj"
    # A cube of 6 quads: fan-triangulated on load, with a note.
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n")
    mesh = sp.load(path)
    assert mesh.n_faces == 12 and mesh.notes
    r = sp.check(mesh)
    assert r.valid
    assert set(mesh.notes) <= set(r.notes)
    assert dataclasses.replace(r, notes=[]) == dataclasses.replace(sp.check((mesh.vertices, mesh.faces)), notes=[])


def split_along_a_seam(V: np.ndarray, F: np.ndarray, side: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """What an exporter does at a texture seam: the faces in ``side`` get
    their own copies (appended) of the vertices they share with the others."""
    shared = np.intersect1d(F[side].ravel(), F[~side].ravel())
    copy_of = {int(v): len(V) + k for k, v in enumerate(shared)}
    F2 = F.copy()
    for f in np.flatnonzero(side):
        F2[f] = [copy_of.get(int(v), int(v)) for v in F[f]]
    return np.vstack([V, V[shared]]), F2


@given(mg.surfaces(max_vertices=120), st.integers(0, 2**32 - 1))
def test_weld_closes_what_a_seam_split_opened(s: mg.Surface, seed: int) -> None:
    side = np.random.default_rng(seed).random(len(s.F)) < 0.5
    V2, F2 = split_along_a_seam(s.V, s.F, side)
    split = sp.Mesh(V2, F2)
    split.attributes["uv"] = np.arange(2 * len(V2), dtype=np.float64).reshape(-1, 2)
    report = sp.check(split)
    if len(V2) > len(s.V):  # the two sides shared a vertex: the report names the seam
        assert any("sit exactly on another boundary vertex" in p and "sp.weld" in p
                   for p in report.problems), report.problems
    welded = sp.weld(split)
    # The copies go back onto the vertices they were made from: the surface
    # comes back exactly, attributes from the kept (first) vertex of each.
    assert np.array_equal(welded.vertices, s.V) and np.array_equal(welded.faces, s.F)
    assert np.array_equal(welded.attributes["uv"], split.attributes["uv"][:len(s.V)])
    assert sp.check(welded).is_sphere_topology
    merged = len(V2) - len(s.V)
    assert (f"welded {merged} vertices" in " ".join(welded.notes)) == (merged > 0)


def test_weld_merges_signed_zeros_but_not_near_misses() -> None:
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-0.0, 0.0, -0.0],
                  [np.nextafter(1.0, 2.0), 0.0, 0.0], [0.0, 1.0, 0.0]])
    welded = sp.weld(sp.Mesh(V, [[0, 1, 4], [2, 3, 4]]))
    assert welded.n_vertices == 4
    assert welded.faces.tolist() == [[0, 1, 3], [0, 2, 3]]
