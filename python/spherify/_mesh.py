"""The Mesh type and the functions that read, write, check and orient it."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any, Dict, List, Literal, Optional, Tuple, Union, overload

import numpy as np

from . import _args, _core, _formats, _interop
from ._files import file_errors
from ._errors import FormatError, MeshError
from ._report import MeshReport, SphereReport

PathLike = Union[str, "os.PathLike[str]"]


def _as_vertices(vertices: Any, what: str = "vertices") -> np.ndarray:
    _args.refuse_lossy(vertices, what)
    try:
        array = np.asarray(vertices)
        if array.dtype.kind not in "fiub":
            raise TypeError(f"dtype {array.dtype}")
        return np.ascontiguousarray(array, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MeshError(f"{what} must be a numeric (n, 3) array: {err}") from None


def _as_faces(faces: Any) -> np.ndarray:
    _args.refuse_lossy(faces, "faces")
    array = np.asarray(faces)
    if array.dtype.kind not in "iu":
        raise MeshError(
            f"faces must be an integer array of shape (m, 3), got dtype {array.dtype}")
    if array.dtype.kind == "u" and array.size and array.max() > np.iinfo(np.int64).max:
        raise MeshError("faces hold indices larger than int64 can represent")
    return np.ascontiguousarray(array, dtype=np.int64)


class Mesh:
    """A triangle mesh: vertex positions and faces, copied into the Rust core.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Positions; any float or integer dtype, stored as float64. Or, with
        ``faces`` left out, a mesh of another library: a ``trimesh.Trimesh``
        (or any object with ``vertices`` and ``faces`` arrays), a
        ``meshio.Mesh`` or a pyvista ``PolyData`` of triangles (see
        :meth:`from_meshio`, :meth:`from_pyvista`). Every function that takes
        a mesh (``sp.embed``, ``sp.check``, ...) takes these too.
    faces : (m, 3) array_like of int
        Vertex indices of each triangle, counter-clockwise seen from outside;
        any integer dtype, stored as int64.

    Raises
    ------
    MeshError
        Wrong shapes or dtypes, empty arrays, NaN or infinite coordinates,
        negative or out-of-range indices. Topology is not required here: use
        :func:`check` to find out what the mesh is.

    Notes
    -----
    The arrays are never reordered or merged. ``vertices`` and ``faces`` are
    read-only copies; build a new Mesh to change them. Cost O(n + m).
    A Mesh pickles (and deep-copies) as its arrays, notes and attributes;
    unpickling validates the arrays in the core again.
    """

    __slots__ = ("_core", "_vertices", "_faces", "notes", "attributes")

    def __init__(self, vertices: Any, faces: Any = None) -> None:
        if faces is None:
            arrays = _interop.arrays_of(vertices)
            if arrays is None:
                raise MeshError("Mesh takes (vertices, faces), or one mesh of another library "
                                "(a trimesh.Trimesh, a meshio.Mesh, a pyvista.PolyData or any "
                                f"object with `vertices` and `faces` arrays); got a "
                                f"{type(vertices).__name__}")
            vertices, faces = arrays
        core = _core.CoreMesh(_as_vertices(vertices), _as_faces(faces))
        self._set(core, [], {})

    @classmethod
    def from_trimesh(cls, mesh: Any) -> "Mesh":
        """A Mesh from a ``trimesh.Trimesh``: its ``vertices`` and ``faces``,
        copied as they are (what trimesh merged on loading stays merged).

        Parameters
        ----------
        mesh : trimesh.Trimesh
            Any object with ``vertices`` (n, 3) and ``faces`` (m, 3) arrays.

        Returns
        -------
        Mesh
        """
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise MeshError(f"from_trimesh takes a trimesh.Trimesh, got a {type(mesh).__name__}")
        return cls(mesh.vertices, mesh.faces)

    @classmethod
    def from_meshio(cls, mesh: Any) -> "Mesh":
        """A Mesh from a ``meshio.Mesh`` (what ``meshio.read`` returns): its
        points and its ``"triangle"`` cell blocks, in order.

        Parameters
        ----------
        mesh : meshio.Mesh
            Points (n, 3); cells of type ``"triangle"`` only.

        Returns
        -------
        Mesh

        Raises
        ------
        MeshError
            Cells of another type (quads, lines, tetrahedra: named), points
            that are not 3D, or no triangles at all.
        """
        if not _interop.is_meshio(mesh):
            raise MeshError(f"from_meshio takes a meshio.Mesh, got a {type(mesh).__name__}")
        return cls(*_interop.meshio_arrays(mesh))

    @classmethod
    def from_pyvista(cls, mesh: Any) -> "Mesh":
        """A Mesh from a pyvista ``PolyData`` made of triangles.

        Parameters
        ----------
        mesh : pyvista.PolyData
            Triangles only (``.triangulate()`` first otherwise), no lines,
            vertex cells or strips.

        Returns
        -------
        Mesh

        Raises
        ------
        MeshError
            Another kind of data set, or cells that are not triangles.
        """
        if not _interop.is_pyvista(mesh):
            raise MeshError(f"from_pyvista takes a pyvista.PolyData, got a "
                            f"{type(mesh).__name__}")
        return cls(*_interop.pyvista_arrays(mesh))

    @classmethod
    def _from_core(cls, core: Any, notes: List[str], attributes: Dict[str, np.ndarray]) -> "Mesh":
        mesh = cls.__new__(cls)
        mesh._set(core, notes, attributes)
        return mesh

    def _set(self, core: Any, notes: List[str], attributes: Dict[str, np.ndarray]) -> None:
        self._core = core
        self._vertices: Optional[np.ndarray] = None
        self._faces: Optional[np.ndarray] = None
        #: Remarks from loading (e.g. polygons fan-triangulated, STL welding).
        self.notes: List[str] = list(notes)
        #: Per-vertex arrays read from the file: ``"sphere"`` (n, 3), ``"uv"`` (n, 2).
        self.attributes: Dict[str, np.ndarray] = dict(attributes)

    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) float64, read-only."""
        if self._vertices is None:
            self._vertices = self._core.vertices()
            self._vertices.flags.writeable = False
        return self._vertices

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64, read-only."""
        if self._faces is None:
            self._faces = self._core.faces()
            self._faces.flags.writeable = False
        return self._faces

    @property
    def n_vertices(self) -> int:
        """The number of vertices, n."""
        return int(self._core.n_vertices)

    @property
    def n_faces(self) -> int:
        """The number of faces, m."""
        return int(self._core.n_faces)

    def __repr__(self) -> str:
        return f"Mesh(n_vertices={self.n_vertices}, n_faces={self.n_faces})"

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        # The core handle does not pickle; the arrays do, and _restore_mesh
        # sends them through the core's validation again.
        return (_restore_mesh, (self.vertices, self.faces, list(self.notes),
                                dict(self.attributes)))

    def to_trimesh(self) -> Any:
        """This mesh as a ``trimesh.Trimesh`` (``process=False``: the vertices
        are neither merged nor reordered).

        Returns
        -------
        trimesh.Trimesh

        Raises
        ------
        ImportError
            trimesh is not installed (spherify does not depend on it:
            ``pip install "spherify[interop]"``).
        """
        return _interop.to_trimesh(self.vertices, self.faces)

    def to_meshio(self, point_data: Optional[Dict[str, Any]] = None) -> Any:
        """This mesh as a ``meshio.Mesh`` (one ``"triangle"`` block), for
        ``meshio.write`` to any of its formats (VTK, VTU, XDMF, Gmsh, ...).

        Parameters
        ----------
        point_data : dict of str to (n, ...) array_like, optional
            Per-vertex arrays to attach (say ``{"sphere": m.points}``), beside
            the mesh's own :attr:`attributes`.

        Returns
        -------
        meshio.Mesh

        Raises
        ------
        ImportError
            meshio is not installed (``pip install "spherify[interop]"``).
        MeshError
            An array of ``point_data`` without one row per vertex.
        """
        data = _interop.point_data(self.attributes, point_data, self.n_vertices)
        return _interop.to_meshio(self.vertices, self.faces, data)

    def to_pyvista(self, point_data: Optional[Dict[str, Any]] = None) -> Any:
        """This mesh as a pyvista ``PolyData`` of triangles, to plot or to
        filter with VTK.

        Parameters
        ----------
        point_data : dict of str to (n, ...) array_like, optional
            Per-vertex arrays to attach (say ``{"sphere": m.points}``), beside
            the mesh's own :attr:`attributes`.

        Returns
        -------
        pyvista.PolyData

        Raises
        ------
        ImportError
            pyvista is not installed (``pip install "spherify[interop]"``).
        MeshError
            An array of ``point_data`` without one row per vertex.
        """
        data = _interop.point_data(self.attributes, point_data, self.n_vertices)
        return _interop.to_pyvista(self.vertices, self.faces, data)


def _restore_mesh(vertices: np.ndarray, faces: np.ndarray, notes: List[str],
                  attributes: Dict[str, np.ndarray]) -> Mesh:
    """Unpickling: a Mesh from its arrays, validated in the core again."""
    mesh = Mesh(vertices, faces)
    mesh.notes = list(notes)
    mesh.attributes = dict(attributes)
    return mesh


MeshLike = Union[Mesh, Tuple[Any, Any]]


def as_mesh(mesh: Any) -> Mesh:
    """``mesh`` itself when it is a :class:`Mesh`; ``Mesh(V, F)`` for a
    ``(V, F)`` pair or an object with ``vertices`` and ``faces`` (trimesh);
    :class:`MeshError` for anything else."""
    if isinstance(mesh, Mesh):
        return mesh
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Mesh(*mesh)
    arrays = _interop.arrays_of(mesh)
    if arrays is not None:
        return Mesh(*arrays)
    raise MeshError("expected a spherify.Mesh, a (vertices, faces) pair or a mesh of another "
                    "library (trimesh, meshio, pyvista: an object with `vertices` and `faces` "
                    f"arrays), got {type(mesh).__name__}")


@file_errors
def load(path: Union[PathLike, Tuple[PathLike, PathLike]]) -> Mesh:
    """Read a triangle mesh; the format is chosen by the file's name.

    * ``.obj``, ``.off``, ``.ply`` (ascii or binary), ``.stl`` (ascii or
      binary): read by the core.
    * ``.npz`` holding ``V`` (n, 3) and ``F`` (m, 3) (or ``vertices`` and
      ``faces``; ``sphere`` and ``uv`` arrays become attributes), or a pair of
      paths ``(V.npy, F.npy)``. Never unpickles.
    * FreeSurfer binary surfaces (``lh.pial``, ``lh.white``, ``lh.sphere``:
      any name, recognised by the file's magic number) and GIfTI ``.gii``
      surfaces, through nibabel (``pip install "spherify[neuro]"``).

    Polygons are fan-triangulated and STL corners welded, each with a note in
    ``mesh.notes``. Per-vertex ``sphere_x/y/z`` and ``u v`` PLY properties and
    OBJ ``vt`` coordinates land in ``mesh.attributes``. O(file size).

    Raises
    ------
    FileError
        The file cannot be read (also the builtin ``FileNotFoundError``,
        ``PermissionError``, ``IsADirectoryError``, ... of the cause).
    FormatError
        The file is malformed, holds bad indices or coordinates, or is in no
        format spherify reads (or needs nibabel, which is missing); the message
        names the file, and for the core's formats the line (text) or byte
        offset (binary).
    """
    if isinstance(path, tuple):
        if len(path) != 2:
            raise MeshError(f"load takes a path or a (V.npy, F.npy) pair, got {len(path)} paths")
        v_path, f_path = Path(_args.path(path[0])), Path(_args.path(path[1]))
        return _from_arrays(f_path, _formats.read_npy_pair(v_path, f_path))
    file = Path(_args.path(path))
    reader = _formats.reader_for(file)
    if reader is not None:
        return _from_arrays(file, reader(file))
    core, notes, attributes = _core.load(_args.path(path))
    return Mesh._from_core(core, notes, attributes)


def _from_arrays(path: Path, loaded: _formats.Loaded) -> Mesh:
    """A Mesh from what a Python reader found in ``path``; bad data there is
    the file's fault, so it is a FormatError naming the file."""
    vertices, faces, notes, attributes = loaded
    try:
        mesh = Mesh(vertices, faces)
        n = mesh.n_vertices
        for name, width in (("sphere", 3), ("uv", 2)):
            if name in attributes and attributes[name].shape != (n, width):
                raise MeshError(f"the {name} array has shape {attributes[name].shape}, "
                                f"expected ({n}, {width})")
    except MeshError as err:
        raise FormatError(f"{path}: {err}", str(path)) from None
    mesh.notes = list(notes)
    mesh.attributes = dict(attributes)
    return mesh


@file_errors
def save(mesh: MeshLike, path: PathLike, *, sphere: Any = None, uv: Any = None,
         texture: Any = None, ply_encoding: str = "binary_little_endian",
         stl_binary: bool = True, format: Optional[str] = None) -> None:
    """Write ``mesh`` to ``path`` (format by the name, or ``format``).

    Parameters
    ----------
    mesh : Mesh or (V, F)
        The mesh to write (or another library's mesh, as for :class:`Mesh`).
    path : str or os.PathLike
        Where to write it.
    sphere : (n, 3) array_like of float, optional
        Per-vertex sphere positions, stored as PLY properties
        ``sphere_x sphere_y sphere_z`` (``.ply``), an array ``sphere``
        (``.npz``) or the float32 attribute ``_SPHERE`` (``.glb``).
    uv : (n, 2) or (m, 3, 2) array_like of float, or a UVLayout, optional
        Per-vertex texture coordinates (``.ply`` as ``u v``, ``.obj`` as
        ``vt``, ``.npz`` as ``uv``, ``.glb`` as ``TEXCOORD_0``), or per face
        corner (``.obj``, one ``vt`` per corner, and ``.glb``, a vertex per
        distinct UV): ``sp.texture.uv(m)`` or its ``.uv``.
    texture : str, os.PathLike or (h, w, 3) array_like, optional
        ``.obj`` and ``.glb``, with ``uv``. For ``.obj`` an MTL
        ``<stem>.mtl`` is written next to the OBJ whose ``map_Kd`` is this
        image: a path (relative to the current folder, referenced from the
        OBJ's folder, not copied) or an RGB image in [0, 1] (written as
        ``<stem>.png``, e.g. from ``UVLayout.bake``). A ``.glb`` holds the
        image itself (an array as PNG, or a PNG or JPEG file's bytes) as its
        material's base colour.
    ply_encoding : {"binary_little_endian", "binary_big_endian", "ascii"}
        The PLY encoding.
    stl_binary : bool
        Binary STL (float32) rather than ascii.
    format : {None, "npz", "freesurfer", "gifti", "glb"}
        None: by the name: ``.obj .off .ply .stl`` (the core), ``.npz`` (``V``
        float64, ``F`` int64), ``.gii`` (GIfTI), ``.glb`` (glTF 2.0 binary:
        positions, normals, uv and sphere points as float32, see
        ``spherify._gltf``), or a FreeSurfer surface name (``lh.pial``,
        ``lh.white``, ``lh.sphere``, ``.inflated``, ``.orig``, ...).
        FreeSurfer and GIfTI store float32 coordinates (the values are
        rounded) and need nibabel.

    Notes
    -----
    The file is written under a temporary name and renamed into place, so an
    existing file is never left half-written.
    """
    from . import _gltf, texture as _texture  # here: texture imports this module

    if _gltf.is_glb(Path(_args.path(path)), format):
        mesh = as_mesh(mesh)
        _gltf.save_glb(mesh.vertices, mesh.faces, Path(_args.path(path)), sphere=sphere, uv=uv,
                       texture=texture)
        return
    if texture is not None or _texture._is_per_corner(uv):
        _texture._save_textured(as_mesh(mesh), Path(_args.path(path)), uv, texture, sphere,
                               format)
        return
    sphere_array = None if sphere is None else _as_vertices(sphere, "sphere")
    uv_array = None if uv is None else _as_vertices(uv, "uv")
    mesh = as_mesh(mesh)
    file = Path(_args.path(path))
    writer = _formats.writer_for(file, format)
    if writer is None:
        _core.save(mesh._core, _args.path(path), sphere_array, uv_array, ply_encoding, stl_binary)
        return
    attributes = {name: array for name, array in (("sphere", sphere_array), ("uv", uv_array))
                  if array is not None}
    for name, array in attributes.items():
        width = 3 if name == "sphere" else 2
        if array.shape != (mesh.n_vertices, width):
            raise MeshError(f"{name} must have shape ({mesh.n_vertices}, {width}), "
                            f"got {array.shape}")
    writer(file, mesh.vertices, mesh.faces, attributes)


def check(mesh: MeshLike) -> MeshReport:
    """Validate a mesh and report every problem found.

    Parameters
    ----------
    mesh : Mesh or (vertices, faces)
        A raw ``(vertices, faces)`` pair may hold NaN coordinates and negative
        or out-of-range indices: those are reported rather than raised.

    Returns
    -------
    MeshReport
        Topology (closed, manifold, components, Euler characteristic, genus,
        boundary loops), defects (non-manifold edges and vertices, degenerate,
        duplicate faces, unused vertices) and orientation (consistent, outward).
        Cost O(m log d), d the largest vertex degree.
    """
    if isinstance(mesh, Mesh):
        report = _core.check(mesh._core)
        notes = mesh.notes
    elif isinstance(mesh, tuple) and len(mesh) == 2:
        report = _core.check_raw(_as_vertices(mesh[0]), _as_faces(mesh[1]))
        notes = []
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return check(Mesh(mesh))
    else:
        raise MeshError(f"check expects a Mesh, a (vertices, faces) pair or an object with "
                        f"`vertices` and `faces`, got {type(mesh).__name__}")
    if notes:
        report = dataclasses.replace(report, notes=list(notes) + list(report.notes))
    return report


@overload
def orient(mesh: MeshLike, *, return_info: Literal[False] = False) -> Mesh: ...
@overload
def orient(mesh: MeshLike, *, return_info: Literal[True]) -> Tuple[Mesh, Dict[str, int]]: ...


def orient(mesh: MeshLike, *,
           return_info: bool = False) -> Union[Mesh, Tuple[Mesh, Dict[str, int]]]:
    """Orient every face consistently and outward (thesis Alg. 2.9).

    Unlike Alg. 2.9 no seed face is needed: each connected component is made
    consistent with its first face, and a closed component that then encloses
    negative volume is reversed as a whole. Open components are made consistent
    only. O(m log d).

    Returns
    -------
    Mesh
        Same vertices; faces reordered within themselves where needed. With
        ``return_info=True``, ``(mesh, info)`` where ``info`` has
        ``flipped_faces``, ``components`` and ``components_turned_outward``.

    Raises
    ------
    TopologyError
        An edge has more than two faces, a face repeats a vertex, or the surface
        is not orientable; ``err.report`` is the full :class:`MeshReport`.
    """
    mesh = as_mesh(mesh)
    core, info = _core.orient(mesh._core)
    oriented = Mesh._from_core(core, mesh.notes, mesh.attributes)
    return (oriented, info) if return_info else oriented


def weld(mesh: MeshLike) -> Mesh:
    """Merge vertices that sit at exactly the same position.

    Exporters often split a closed surface along its texture seams, giving
    each side its own copy of the seam's vertices; the file then describes an
    open surface (``sp.check`` says so, and how many boundary vertices sit on
    another), which no spherical map accepts. Welding closes it. Positions
    must be bitwise equal (``-0.0`` and ``0.0`` are one), as the STL reader
    welds every file; nothing within a tolerance is merged. O(n log n).

    Returns
    -------
    Mesh
        Each group of copies becomes its first vertex, in the input's order;
        faces renumbered and otherwise unchanged (a face with two corners at
        one position repeats a vertex and is reported as degenerate). Per-vertex
        ``attributes`` are taken from the kept vertex of each group; a note
        says how many vertices were merged.
    """
    mesh = as_mesh(mesh)
    core, kept = _core.weld(mesh._core)
    merged = mesh.n_vertices - len(kept)
    notes = list(mesh.notes)
    if merged:
        notes.append(f"welded {merged} vertices onto others at exactly the same position "
                     f"({mesh.n_vertices} -> {len(kept)} vertices)")
    attributes = {name: np.ascontiguousarray(values[kept])
                  for name, values in mesh.attributes.items()}
    return Mesh._from_core(core, notes, attributes)


def dijkstra(mesh: MeshLike, source: int, *, weights: str = "length") -> Tuple[np.ndarray, np.ndarray]:
    """Shortest-path distances from ``source`` along mesh edges (thesis App. A).

    Parameters
    ----------
    weights : {"length", "uniform"}
        Euclidean edge lengths, or 1 per edge (graph distance).

    Returns
    -------
    distances : (n,) float64
        ``inf`` for vertices in other components.
    predecessors : (n,) int64
        Previous vertex on a shortest path; -1 for the source and unreachable ones.

    Binary-heap Dijkstra, O((n + e) log n), deterministic tie-breaking.
    """
    return _core.dijkstra(as_mesh(mesh)._core, _args.vertex_id(source, "source"), weights)


def shortest_path(mesh: MeshLike, source: int, target: int, *, weights: str = "length") -> Tuple[float, np.ndarray]:
    """Length and vertex sequence ``(k,) int64`` of a shortest path from
    ``source`` to ``target``; stops as soon as ``target`` is settled.
    Raises :class:`MeshError` when no path exists."""
    return _core.shortest_path(as_mesh(mesh)._core, _args.vertex_id(source, "source"),
                               _args.vertex_id(target, "target"), weights)


def check_sphere(mesh: MeshLike, points: Any) -> SphereReport:
    """Decide whether ``points`` on the sphere form a valid GC-embedding of ``mesh``.

    Parameters
    ----------
    mesh : Mesh
        Consistently oriented, counter-clockwise seen from outside (run
        :func:`orient` first).
    points : (n, 3) array_like of float
        One point per vertex, on (or near) the unit sphere centred at the origin.

    Returns
    -------
    SphereReport
        The orientation test (thesis 3.9) with an exact sign per face and the
        area test (3.11) with signed spherical excess. O(m), in parallel.
    """
    return _core.check_sphere(as_mesh(mesh)._core, _as_vertices(points, "points"))
