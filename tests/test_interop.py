"""Meshes of other libraries both ways (issue 24, item 8): trimesh, meshio and
pyvista. Each library's tests skip when it is not installed (the ``test``
extra installs all three, so CI runs them); the errors for a missing library
are tested without it, by hiding it."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pytest

import spherify as sp


def blob() -> sp.Mesh:
    return sp.datasets.make("bumpy_blob", 300)


def same(a: sp.Mesh, b: sp.Mesh) -> bool:
    return np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


# --- trimesh ------------------------------------------------------------------

def test_trimesh_both_ways() -> None:
    trimesh = pytest.importorskip("trimesh")
    mesh = blob()
    t = mesh.to_trimesh()
    assert isinstance(t, trimesh.Trimesh)
    assert np.array_equal(t.vertices, mesh.vertices) and np.array_equal(t.faces, mesh.faces)
    assert same(sp.Mesh(t), mesh) and same(sp.Mesh.from_trimesh(t), mesh)
    assert sp.embed(t).valid  # taken directly wherever a mesh is


def test_from_trimesh_refuses_what_is_not_a_mesh() -> None:
    with pytest.raises(sp.MeshError, match="trimesh.Trimesh"):
        sp.Mesh.from_trimesh(np.zeros((3, 3)))


# --- meshio -------------------------------------------------------------------

def test_meshio_both_ways(tmp_path: Any) -> None:
    meshio = pytest.importorskip("meshio")
    mesh = blob()
    m = sp.embed(mesh)
    out = mesh.to_meshio(point_data={"sphere": m.points})
    assert isinstance(out, meshio.Mesh)
    assert np.array_equal(out.cells_dict["triangle"], mesh.faces)
    assert np.array_equal(out.point_data["sphere"], m.points)
    path = tmp_path / "blob.vtu"
    meshio.write(path, out)  # a format spherify does not write itself
    back = sp.Mesh.from_meshio(meshio.read(path))
    assert same(back, mesh)
    assert same(sp.Mesh(out), mesh)
    assert sp.embed(out).valid


def test_from_meshio_takes_several_triangle_blocks_and_refuses_other_cells() -> None:
    meshio = pytest.importorskip("meshio")
    mesh = blob()
    half = mesh.n_faces // 2
    split = meshio.Mesh(mesh.vertices, [("triangle", mesh.faces[:half]),
                                        ("triangle", mesh.faces[half:])])
    assert same(sp.Mesh.from_meshio(split), mesh)
    quads = meshio.Mesh(mesh.vertices, [("triangle", mesh.faces), ("quad", [[0, 1, 2, 3]])])
    with pytest.raises(sp.MeshError, match="quad"):
        sp.Mesh.from_meshio(quads)
    flat = meshio.Mesh(mesh.vertices[:, :2], [("triangle", mesh.faces)])
    with pytest.raises(sp.MeshError, match=r"\(n, 3\)"):
        sp.Mesh.from_meshio(flat)
    with pytest.raises(sp.MeshError, match="no triangle"):
        sp.Mesh.from_meshio(meshio.Mesh(mesh.vertices, []))
    with pytest.raises(sp.MeshError, match="meshio.Mesh"):
        sp.Mesh.from_meshio(mesh)


def test_point_data_needs_a_row_per_vertex() -> None:
    pytest.importorskip("meshio")
    with pytest.raises(sp.MeshError, match="one row per vertex"):
        blob().to_meshio(point_data={"bad": np.zeros(3)})


# --- pyvista ------------------------------------------------------------------

def test_pyvista_both_ways() -> None:
    pyvista = pytest.importorskip("pyvista")
    mesh = blob()
    m = sp.embed(mesh)
    poly = mesh.to_pyvista(point_data={"sphere": m.points})
    assert isinstance(poly, pyvista.PolyData)
    assert poly.n_points == mesh.n_vertices and poly.n_cells == mesh.n_faces
    assert np.array_equal(poly.point_data["sphere"], m.points)
    assert same(sp.Mesh.from_pyvista(poly), mesh)
    assert same(sp.Mesh(poly), mesh)
    assert sp.embed(poly).valid


def test_from_pyvista_refuses_polygons_and_volumes() -> None:
    pyvista = pytest.importorskip("pyvista")
    quad = pyvista.PolyData(np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
                            np.array([4, 0, 1, 2, 3]))
    with pytest.raises(sp.MeshError, match="triangulate"):
        sp.Mesh.from_pyvista(quad)
    grid = pyvista.ImageData(dimensions=(2, 2, 2))
    with pytest.raises(sp.MeshError, match="not a surface"):
        sp.Mesh.from_pyvista(grid)


# --- a library that is not installed --------------------------------------------

@pytest.mark.parametrize("library, call", [
    ("trimesh", lambda mesh: mesh.to_trimesh()),
    ("meshio", lambda mesh: mesh.to_meshio()),
    ("pyvista", lambda mesh: mesh.to_pyvista()),
])
def test_a_missing_library_says_what_to_install(monkeypatch: pytest.MonkeyPatch,
                                                library: str, call: Any) -> None:
    monkeypatch.setitem(sys.modules, library, None)  # importing it now raises ImportError
    with pytest.raises(ImportError, match=rf"pip install {library}.*spherify\[interop\]"):
        call(blob())


def test_an_object_that_is_no_mesh_is_named() -> None:
    with pytest.raises(sp.MeshError, match="meshio.Mesh, a pyvista.PolyData"):
        sp.Mesh(object())
    with pytest.raises(sp.MeshError, match="got object"):
        sp.check(object())  # type: ignore[arg-type]
