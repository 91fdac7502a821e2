"""sp.orient: consistent, outward faces from any orientation of an orientable mesh."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp

pytest.importorskip("scipy", reason="the random mesh strategies use scipy.spatial.ConvexHull")

import _meshgen as mg  # noqa: E402


def reversed_where(F: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = F.copy()
    out[mask] = out[mask][:, ::-1]
    return out


def assert_same_oriented_faces(got: np.ndarray, want: np.ndarray) -> None:
    """Face i of ``got`` is face i of ``want`` up to a rotation of its corners."""
    assert got.shape == want.shape
    assert mg.canonical_faces(got) == mg.canonical_faces(want)


@given(mg.surfaces(), st.data())
def test_orient_restores_the_outward_orientation(s: mg.Surface, data: st.DataObject) -> None:
    m = len(s.F)
    flipped = np.array(data.draw(st.lists(st.booleans(), min_size=m, max_size=m), label="flipped"))
    mesh = sp.Mesh(s.V, reversed_where(s.F, flipped))
    fixed, info = sp.orient(mesh, return_info=True)
    assert_same_oriented_faces(fixed.faces, s.F)
    assert fixed.vertices.tobytes() == mesh.vertices.tobytes()
    assert info["flipped_faces"] == int(flipped.sum())
    assert info["components"] == 1
    # Propagation starts from face 0, so the component is turned as a whole
    # exactly when face 0 was one of the reversed faces.
    assert info["components_turned_outward"] == int(flipped[0] and flipped.sum() > 0)
    r = sp.check(fixed)
    assert r.valid and r.consistently_oriented and r.outward and r.problems == []


@given(mg.surfaces())
def test_orient_turns_an_inward_mesh_inside_out(s: mg.Surface) -> None:
    fixed, info = sp.orient(sp.Mesh(s.V, s.F[:, ::-1]), return_info=True)
    assert_same_oriented_faces(fixed.faces, s.F)
    assert info["flipped_faces"] == len(s.F)
    assert info["components_turned_outward"] == 1


@given(mg.surfaces())
def test_orient_leaves_a_good_mesh_alone(s: mg.Surface) -> None:
    mesh = sp.Mesh(s.V, s.F)
    fixed, info = sp.orient(mesh, return_info=True)
    assert np.array_equal(fixed.faces, s.F)
    assert info == {"flipped_faces": 0, "components": 1, "components_turned_outward": 0}
    again = sp.orient(fixed)
    assert np.array_equal(again.faces, fixed.faces)
    assert isinstance(fixed, sp.Mesh) and not fixed.faces.flags.writeable


@given(mg.two_components(), st.data())
def test_orient_fixes_every_component(b: mg.Broken, data: st.DataObject) -> None:
    m = len(b.F)
    flipped = np.array(data.draw(st.lists(st.booleans(), min_size=m, max_size=m), label="flipped"))
    fixed, info = sp.orient(sp.Mesh(b.V, reversed_where(b.F, flipped)), return_info=True)
    assert_same_oriented_faces(fixed.faces, b.F)
    assert info["components"] == 2
    assert info["flipped_faces"] == int(flipped.sum())
    r = sp.check(fixed)
    assert r.consistently_oriented and r.outward and r.n_components == 2


@given(mg.with_holes(), st.data())
def test_open_mesh_is_made_consistent_with_its_first_face(b: mg.Broken, data: st.DataObject) -> None:
    m = len(b.F)
    flipped = np.array(data.draw(st.lists(st.booleans(), min_size=m, max_size=m), label="flipped"))
    fixed, info = sp.orient(sp.Mesh(b.V, reversed_where(b.F, flipped)), return_info=True)
    # An open surface has no inside: it is not turned, only made consistent.
    want = b.F[:, ::-1] if flipped[0] else b.F
    assert_same_oriented_faces(fixed.faces, want)
    assert info["components_turned_outward"] == 0
    r = sp.check(fixed)
    assert r.consistently_oriented and not r.outward and not r.closed


@given(mg.with_handle(), st.data())
def test_orient_works_on_higher_genus(b: mg.Broken, data: st.DataObject) -> None:
    m = len(b.F)
    flipped = np.array(data.draw(st.lists(st.booleans(), min_size=m, max_size=m), label="flipped"))
    fixed = sp.orient(sp.Mesh(b.V, reversed_where(b.F, flipped)))
    r = sp.check(fixed)
    assert r.consistently_oriented and r.genus == 1
    # Consistent with the construction, up to turning the whole surface.
    got = mg.canonical_faces(fixed.faces)
    assert got in (mg.canonical_faces(b.F), mg.canonical_faces(b.F[:, ::-1]))


@given(mg.with_nonmanifold_edge())
def test_orient_refuses_a_nonmanifold_edge(b: mg.Broken) -> None:
    with pytest.raises(sp.TopologyError) as info:
        sp.orient(sp.Mesh(b.V, b.F))
    err = info.value
    assert isinstance(err.report, sp.MeshReport)
    assert err.report.n_nonmanifold_edges > 0
    assert err.report.nonmanifold_edges == b.expect["nonmanifold_edges"]
    a, c = b.expect["nonmanifold_edges"][0]
    assert str(a) in str(err) and str(c) in str(err)


@given(mg.with_repeated_index_face())
def test_orient_refuses_a_face_repeating_a_vertex(b: mg.Broken) -> None:
    with pytest.raises(sp.TopologyError) as info:
        sp.orient(sp.Mesh(b.V, b.F))
    assert info.value.report.degenerate_faces == b.expect["degenerate_faces"]
    assert isinstance(info.value, sp.MeshError)


@pytest.mark.parametrize("surface", [mg.projective_plane, mg.moebius_strip])
def test_orient_refuses_a_non_orientable_surface(surface) -> None:
    V, F = surface()
    with pytest.raises(sp.TopologyError) as info:
        sp.orient(sp.Mesh(V, F))
    assert not info.value.report.consistently_oriented
    assert "orient" in str(info.value).lower()


def test_orient_keeps_notes_and_attributes(tmp_path) -> None:
    path = tmp_path / "inward.ply"
    sphere = np.random.default_rng(7).normal(size=(4, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F[:, ::-1]), path, sphere=sphere)
    mesh = sp.load(path)
    fixed = sp.orient(mesh)
    assert fixed.notes == mesh.notes
    assert fixed.attributes.keys() == mesh.attributes.keys()
    assert np.array_equal(fixed.attributes["sphere"], sphere)
    assert_same_oriented_faces(fixed.faces, mg.TETRA_F)
