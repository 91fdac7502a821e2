"""Meshes of other Python libraries, both ways: trimesh, meshio and pyvista
(issue 24, item 8). None of them is a dependency of spherify: each is imported
when a conversion to its type is asked for, with an ImportError that says what
to install when it is missing (``pip install "spherify[interop]"`` brings all
three). Converting *from* their objects needs no import: the arrays are read
off the object (``Mesh.from_trimesh``, ``Mesh.from_meshio``,
``Mesh.from_pyvista``, and :func:`arrays_of`, through which ``sp.Mesh(obj)``,
``sp.embed(obj)`` and every function that takes a mesh accept them directly).

Vertices are never merged or reordered either way: vertex ``i`` of the other
library's mesh is vertex ``i`` of spherify's, so per-vertex results
(``m.points``) line up with its arrays.
"""

from __future__ import annotations

import importlib
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np

from ._errors import MeshError

#: The extra that installs every library this module converts to.
EXTRA = 'pip install "spherify[interop]"'


def _library(name: str, what: str) -> Any:
    # Imported by name: the libraries are optional, and the package
    # type-checks without them.
    try:
        return importlib.import_module(name)
    except ImportError:
        raise ImportError(f"{what} needs {name}, which spherify does not depend on: "
                          f"pip install {name} (or {EXTRA})") from None


def _from_library(obj: Any, library: str) -> bool:
    """Whether ``obj``'s class comes from ``library`` (by its module name:
    nothing is imported to tell)."""
    return any(type_.__module__.split(".")[0] == library for type_ in type(obj).__mro__)


def is_meshio(obj: Any) -> bool:
    """A ``meshio.Mesh``."""
    return _from_library(obj, "meshio") and hasattr(obj, "cells") and hasattr(obj, "points")


def is_pyvista(obj: Any) -> bool:
    """A pyvista data set (``PolyData``, or any with ``extract_surface``)."""
    return _from_library(obj, "pyvista") and hasattr(obj, "points")


def meshio_arrays(obj: Any) -> Tuple[np.ndarray, np.ndarray]:
    """(V, F) of a ``meshio.Mesh`` whose cells are all triangles (its
    ``"triangle"`` blocks, in order); ``MeshError`` naming any other cell
    type, or points that are not 3D."""
    points = np.asarray(obj.points)
    if points.ndim != 2 or points.shape[1] != 3:
        raise MeshError(f"the meshio mesh's points must have shape (n, 3), got {points.shape}")
    blocks = [(block.type, np.asarray(block.data)) for block in obj.cells]
    others = sorted({kind for kind, _ in blocks if kind != "triangle"})
    if others:
        raise MeshError(f"the meshio mesh has cells of type {', '.join(others)}; spherify takes "
                        "triangles only (triangulate it first)")
    if not blocks:
        raise MeshError("the meshio mesh has no triangle cells")
    return points, np.concatenate([data for _, data in blocks], axis=0)


def pyvista_arrays(obj: Any) -> Tuple[np.ndarray, np.ndarray]:
    """(V, F) of a pyvista ``PolyData`` made of triangles only; another data
    set (an ``UnstructuredGrid``) is refused, since taking its surface could
    merge or drop points."""
    if not hasattr(obj, "faces") or not hasattr(obj, "is_all_triangles"):
        raise MeshError(f"a pyvista {type(obj).__name__} is not a surface: pass a PolyData "
                        "(for example its .extract_surface().triangulate())")
    if getattr(obj, "n_lines", 0) or getattr(obj, "n_verts", 0) or getattr(obj, "n_strips", 0):
        raise MeshError("the pyvista PolyData holds lines, vertices or strips besides its "
                        "faces; spherify takes triangles only (triangulate it first)")
    if obj.n_cells == 0 or not obj.is_all_triangles:
        raise MeshError("the pyvista PolyData's faces are not all triangles; call "
                        ".triangulate() first")
    faces = np.asarray(obj.faces).reshape(-1, 4)
    return np.asarray(obj.points), faces[:, 1:]


def arrays_of(obj: Any) -> Optional[Tuple[Any, Any]]:
    """(vertices, faces) of another library's mesh: a meshio ``Mesh``, a
    pyvista ``PolyData``, or any object with ``vertices`` and ``faces``
    arrays (a ``trimesh.Trimesh``); None for anything else."""
    if is_meshio(obj):
        return meshio_arrays(obj)
    if is_pyvista(obj):
        return pyvista_arrays(obj)
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):
        return obj.vertices, obj.faces
    return None


def to_trimesh(vertices: np.ndarray, faces: np.ndarray) -> Any:
    """A ``trimesh.Trimesh`` with ``process=False``: nothing merged or
    reordered."""
    trimesh = _library("trimesh", "Mesh.to_trimesh")
    return trimesh.Trimesh(vertices=np.array(vertices), faces=np.array(faces), process=False)


def to_meshio(vertices: np.ndarray, faces: np.ndarray,
              point_data: Mapping[str, np.ndarray]) -> Any:
    """A ``meshio.Mesh`` with one ``"triangle"`` block and ``point_data``."""
    meshio = _library("meshio", "Mesh.to_meshio")
    return meshio.Mesh(np.array(vertices), [("triangle", np.array(faces))],
                       point_data={name: np.array(a) for name, a in point_data.items()})


def to_pyvista(vertices: np.ndarray, faces: np.ndarray,
               point_data: Mapping[str, np.ndarray]) -> Any:
    """A pyvista ``PolyData`` of triangles with ``point_data``."""
    pyvista = _library("pyvista", "Mesh.to_pyvista")
    cells = np.column_stack([np.full(len(faces), 3, dtype=np.int64), faces]).ravel()
    poly = pyvista.PolyData(np.array(vertices), cells)
    for name, array in point_data.items():
        poly.point_data[name] = np.array(array)
    return poly


def point_data(attributes: Dict[str, np.ndarray], extra: Optional[Dict[str, Any]],
               n_vertices: int) -> Dict[str, np.ndarray]:
    """The per-vertex arrays to hand over: the mesh's ``attributes`` (from
    its file) and those given, each checked to have one row per vertex."""
    data = dict(attributes)
    for name, value in (extra or {}).items():
        array = np.asarray(value)
        if array.ndim == 0 or array.shape[0] != n_vertices:
            raise MeshError(f"point data {name!r} must have one row per vertex "
                            f"({n_vertices}), got shape {array.shape}")
        data[name] = array
    return data
