"""Maps that persist and travel: ``SphereMap.save`` / :func:`load_map` (a
``.spheremap.npz``) and pickling, which share one record.

The record holds everything a map holds: the (oriented) mesh with its notes
and attributes, the points, the method, its options, iterations, status,
message, seconds, notes and details, for theta-phi the poles, the cut
path and the rectangle, and for a map pinned to landmarks ``landmark_ids``
and ``landmark_points`` (each point must be the map's own point for its id,
bit for bit, or the file is refused: an older spherify, which does not read
them, loads the map without its landmarks), and for a map whose landmarks
were laid out on a refined mesh its map back: ``input_faces`` (the input is
the first ``input_vertices`` vertices with them), ``refinement_faces`` and
``refinement_barycentric``, checked on load to reproduce every vertex (such
a file is format 2, which earlier readers refuse rather than lose the map
back). It holds no verdict that is believed: rebuilding a
map sends the mesh through the core's validation and the parts through
``_core.restore_map``, which certifies the points (``valid``, thesis 3.4) and
for theta-phi makes the cut again and checks the rectangle (``tp_valid``)
with exact predicates. A file edited by hand gets the certificate of what it
holds, or a FormatError when its parts do not fit together.

The ``.npz`` is plain arrays (loaded with ``allow_pickle=False``): ``meta``
is one JSON string; arrays inside the options and details are stored beside
it as ``array_<k>`` and referenced from the JSON.

A pickled map is the bytes of that same ``.npz`` (:func:`map_archive`), and
unpickling reads them with :func:`load_map`'s reader (:func:`unpickle_map`):
the pickle machine makes one ``bytes`` object and no numpy array, so a
damaged pickle meets the same checks as a damaged file (issue 26). Before,
the record's arrays went into the pickle as numpy objects, and a mutated
pickle could hand numpy a freed buffer or a broken dtype and crash the
process before spherify saw the record (about once in 100,000 fuzzed pickles).
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _core
from ._atomic import write_atomically
from ._errors import FormatError, MeshError
from ._files import file_errors, require_regular_file
from ._formats import damaged_archive, is_zip_archive, is_zip_stream
from ._json_depth import too_deep
from ._npz_check import check_npz

if TYPE_CHECKING:
    from ._spheremap import SphereMap

PathLike = Union[str, "os.PathLike[str]"]

#: Bumped when the layout changes; a reader refuses files newer than itself.
#: Version 2 adds the map back of a refined landmark map (``input_faces``,
#: ``refinement_faces``, ``refinement_barycentric``); maps without one are
#: still written as version 1, which every earlier reader reads.
FORMAT_VERSION = 2
#: The version written for a map without a refinement.
PLAIN_VERSION = 1
VERSION_KEY = "spherify_map_format"

Record = Dict[str, np.ndarray]

#: The deepest nesting of lists and objects read from a record's ``meta``
#: (spherify writes 4 or 5; ``json`` recursed into 100,000 and failed).
MAX_META_DEPTH = 64
#: Stored points whose norm is within this of 1 are kept as they are; the
#: others are projected onto the unit sphere on load (:func:`_unit_points`).
UNIT_TOLERANCE = 4 * float(np.finfo(np.float64).eps)


def _encode(value: Any, arrays: Record) -> Any:
    """``value`` as JSON, its arrays moved into ``arrays`` and referenced."""
    if isinstance(value, np.ndarray):
        key = f"array_{len(arrays)}"
        arrays[key] = value
        return {"__array__": key}
    if isinstance(value, dict):
        return {str(k): _encode(v, arrays) for k, v in value.items()}
    if isinstance(value, tuple):
        return {"__tuple__": [_encode(v, arrays) for v in value]}
    if isinstance(value, list):
        return [_encode(v, arrays) for v in value]
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise MeshError(f"cannot store a {type(value).__name__} in a sphere map record")


def _decode(value: Any, arrays: Any) -> Any:
    if isinstance(value, dict):
        if set(value) == {"__array__"}:
            return np.asarray(arrays[value["__array__"]])
        if set(value) == {"__tuple__"}:
            return tuple(_decode(v, arrays) for v in value["__tuple__"])
        return {k: _decode(v, arrays) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v, arrays) for v in value]
    return value


def record(m: "SphereMap") -> Record:
    """Everything ``m`` holds, as named arrays (see the module docstring)."""
    from ._spheremap import ThetaPhiMap

    arrays: Record = {}
    meta: Dict[str, Any] = {
        "spherify_version": _core.__version__,
        "method": m.method,
        "iterations": m.iterations,
        "status": m.status,
        "message": m.message,
        "seconds": [[k, v] for k, v in m.seconds.items()],
        "notes": m.notes,
        "options": _encode(m.options, arrays),
        "details": _encode(m.details, arrays),
        "mesh_notes": list(m.mesh.notes),
        "mesh_attributes": _encode(dict(m.mesh.attributes), arrays),
    }
    arrays.update({
        VERSION_KEY: np.array(PLAIN_VERSION if m.refinement is None else FORMAT_VERSION),
        "vertices": m.mesh.vertices,
        "faces": m.mesh.faces,
        "points": m.points,
    })
    if m.landmarks is not None:
        arrays.update(landmark_ids=m.landmarks[0], landmark_points=m.landmarks[1])
    if m.refinement is not None:
        source = m.input_mesh
        arrays.update(input_faces=source.faces, refinement_faces=m.refinement[0],
                      refinement_barycentric=m.refinement[1])
        meta["input_vertices"] = len(source.vertices)
    if isinstance(m, ThetaPhiMap):
        arrays.update(poles=np.array(m.poles, dtype=np.int64), cut_path=m.cut_path,
                      theta_phi=m.theta_phi)
        details = m.details
        meta["refinements"] = int(details["refinements"])
        meta["re_embedded"] = [bool(x) for x in details["re_embedded"]]
    arrays["meta"] = np.array(json.dumps(meta))
    return arrays


def _unit_points(points: np.ndarray, fail: Callable[[str], FormatError]
                 ) -> Tuple[np.ndarray, Optional[str]]:
    """Stored points as unit vectors, as :meth:`SphereMap.from_points` makes
    them (issue 26, finding 8): a row that is not finite or is zero is
    refused; a row whose norm is off 1 by more than :data:`UNIT_TOLERANCE`
    is divided by its norm (taken of the row scaled by its largest
    component, so that 1e300 does not overflow), and a note says how many
    were. Rows within the tolerance keep their bits, so a saved map loads
    exactly as it was. Not (n, 3): left to the core to refuse."""
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        return points, None
    finite = np.isfinite(points).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise fail(f"point {row} {points[row].tolist()} is not finite")
    largest = np.abs(points).max(axis=1)
    if not largest.all():
        row = int(np.argmin(largest))
        raise fail(f"point {row} is zero: it has no direction on the sphere")
    scaled = points / largest[:, None]
    lengths = np.linalg.norm(scaled, axis=1)
    with np.errstate(over="ignore"):
        error = np.abs(lengths * largest - 1.0)
    off = error > UNIT_TOLERANCE
    if not off.any():
        return points, None
    unit = points.copy()
    unit[off] = scaled[off] / lengths[off, None]
    return unit, (f"{int(off.sum())} of {len(points)} stored points were not unit vectors "
                  f"(largest | |p| - 1 | {float(error.max()):.3e}): projected onto the unit "
                  "sphere on load and certified as projected")


def _meta_text(meta: np.ndarray) -> str:
    """The record's ``meta``: one numpy string, decoded from its UTF-32 code
    units by Python's codec, which refuses what is not a character (a code
    unit beyond U+10FFFF, a surrogate). ``str()`` of the array let such a
    unit through into a Python string, which reached the core as a Rust
    string that is not UTF-8 and made it panic (found by the fuzzer)."""
    if meta.shape != () or meta.dtype.kind != "U":
        raise TypeError(f"meta must be one string, got an array of {meta.dtype} and shape "
                        f"{meta.shape}")
    units = np.ascontiguousarray(meta, dtype=meta.dtype.newbyteorder("<")).tobytes()
    return units.decode("utf-32-le").rstrip("\x00")  # numpy pads with NUL


def _count(value: Any, what: str) -> int:
    """A stored count the core takes as an unsigned 64-bit integer."""
    count = int(value)
    if not 0 <= count < 2**64:
        raise ValueError(f"{what} {count} is not a count (0 to 2^64 - 1)")
    return count


def rebuild(arrays: Any, source: str) -> "SphereMap":
    """A map from its record (a dict or an open ``.npz``), certified again
    in the core. ``source`` names where the record came from, for errors:
    whatever a damaged record holds, the error is a :class:`FormatError`
    naming it (issue 26, finding 4: wrong types, counts out of range, a
    ``meta`` nested 100,000 deep)."""
    from ._mesh import Mesh
    from ._spheremap import SphereMap, ThetaPhiMap

    def fail(why: str) -> FormatError:
        return FormatError(f"{source}: {why}", source)

    names = set(arrays.keys()) if isinstance(arrays, dict) else set(arrays.files)
    if VERSION_KEY not in names:
        raise fail(f"not a sphere map (no {VERSION_KEY!r} entry; save one with SphereMap.save)")
    stored_version = np.asarray(arrays[VERSION_KEY])
    if stored_version.shape != () or stored_version.dtype.kind not in "iu":
        raise fail(f"the format version must be one integer, got an array of "
                   f"{stored_version.dtype} and shape {stored_version.shape}")
    version = int(stored_version)
    if version > FORMAT_VERSION or version < 1:
        raise fail(f"sphere map format {version}; this spherify reads format 1 to {FORMAT_VERSION}")
    missing = {"vertices", "faces", "points", "meta"} - names
    if missing:
        raise fail(f"missing {', '.join(sorted(missing))}")
    try:
        text = _meta_text(np.asarray(arrays["meta"]))
        if too_deep(text, MAX_META_DEPTH):
            raise ValueError(f"meta nests lists and objects more than {MAX_META_DEPTH} deep")
        meta = json.loads(text)
        if not isinstance(meta, dict):
            raise TypeError(f"meta is a JSON {type(meta).__name__}, not an object")
        method, iterations = str(meta["method"]), _count(meta["iterations"], "iterations")
        status, message = str(meta["status"]), str(meta["message"])
        seconds: List[Tuple[str, float]] = [(str(k), float(v)) for k, v in meta["seconds"]]
        notes = [str(n) for n in meta["notes"]]
        options = _decode(meta["options"], arrays)
        details = _decode(meta["details"], arrays)
        mesh_notes = [str(n) for n in meta["mesh_notes"]]
        attributes = _decode(meta["mesh_attributes"], arrays)
        if not isinstance(attributes, dict) or not isinstance(options, dict) \
                or not isinstance(details, dict):
            raise TypeError("mesh_attributes, options and details must be JSON objects")
        theta_phi: Dict[str, Any] = {}
        if "poles" in names:
            north, south = (int(p) for p in np.asarray(arrays["poles"]))
            re_embedded = tuple(bool(x) for x in meta["re_embedded"])
            if len(re_embedded) != 2:
                raise ValueError(f"re_embedded holds {len(re_embedded)} values, not 2")
            theta_phi = dict(poles=(north, south),
                             cut_path=np.ascontiguousarray(arrays["cut_path"], dtype=np.int64),
                             theta_phi=np.ascontiguousarray(arrays["theta_phi"], dtype=np.float64),
                             refinements=_count(meta["refinements"], "refinements"),
                             re_embedded=re_embedded)
        stored_points = np.asarray(arrays["points"])
        if stored_points.dtype.kind not in "iuf":
            raise TypeError(f"points are {stored_points.dtype}, not numbers")
        points, projected = _unit_points(np.ascontiguousarray(stored_points, dtype=np.float64),
                                         fail)
    except (KeyError, ValueError, TypeError, OverflowError) as err:
        if isinstance(err, FormatError):
            raise
        raise fail(f"malformed record ({type(err).__name__}: {err})") from None
    try:
        mesh = Mesh(arrays["vertices"], arrays["faces"])
        refinement = None
        if {"input_faces", "refinement_faces", "refinement_barycentric"} & names:
            refinement = _refinement(arrays, names, meta, mesh.vertices, fail)
        core = _core.restore_map(mesh._core, method, points, iterations, status, message,
                                 **theta_phi, refinement=refinement)
    except (ValueError, TypeError, OverflowError) as err:
        # MeshError and TopologyError (the stored mesh is not genus 0)
        # included, and UnicodeEncodeError: a JSON "\udf63" escape gives a
        # lone surrogate, which no Rust string holds (found by the fuzzer).
        raise fail(str(err)) from None
    mesh.notes = mesh_notes
    mesh.attributes = dict(attributes)
    if projected is not None:
        notes = notes + [projected]
    cls = SphereMap if core.tp_valid is None else ThetaPhiMap
    m = cls._restored(core, mesh, seconds=seconds, notes=notes, options=options,
                      details=details)
    if "landmark_ids" in names or "landmark_points" in names:
        m._landmarks = _landmarks(arrays, names, m.points, fail)
    return m


#: How far a refined vertex may lie from the point its stored face and
#: weights give, relative to the input's largest coordinate (the layout
#: computes both the same way; a file is data, not proof).
REFINEMENT_TOLERANCE = 1e-12


def _refinement(arrays: Any, names: Any, meta: Dict[str, Any], vertices: np.ndarray,
                fail: Callable[[str], FormatError]) -> Tuple[Any, np.ndarray, np.ndarray]:
    """A refined map's stored map back, checked against the stored mesh:
    the input is the first ``input_vertices`` vertices with ``input_faces``,
    every vertex has a face of the input and weights (non-negative, summing
    to 1) that reproduce it, and the input's own vertices keep their ids
    (weight 1 at their own corner). Returns ``(input CoreMesh, faces,
    weights)`` for the core, or a :class:`FormatError` naming the row."""
    from ._mesh import Mesh

    if not {"input_faces", "refinement_faces", "refinement_barycentric"} <= set(names):
        raise fail("input_faces, refinement_faces and refinement_barycentric are stored together")
    if "input_vertices" not in meta:
        raise fail("a refined map's record names its input_vertices")
    n_input = _count(meta["input_vertices"], "input_vertices")
    if not 4 <= n_input <= len(vertices):
        raise fail(f"input_vertices {n_input} does not fit a refined mesh of "
                   f"{len(vertices)} vertices")
    input_mesh = Mesh(vertices[:n_input], arrays["input_faces"])
    if not _core.check(input_mesh._core).is_sphere_topology:
        raise fail("input_faces are not a closed genus-0 mesh on the first "
                   f"{n_input} vertices (the input a refinement maps back to)")
    faces = np.asarray(arrays["refinement_faces"])
    weights = np.asarray(arrays["refinement_barycentric"])
    if faces.shape != (len(vertices),) or faces.dtype.kind not in "iu" \
            or weights.shape != (len(vertices), 3) or weights.dtype != np.float64:
        raise fail(f"the refinement must be int faces ({len(vertices)},) and float64 weights "
                   f"({len(vertices)}, 3), got {faces.dtype}{faces.shape} and "
                   f"{weights.dtype}{weights.shape}")
    n_faces = len(input_mesh.faces)
    if len(faces) and (faces.min() < 0 or faces.max() >= n_faces):
        row = int(np.argmax((faces < 0) | (faces >= n_faces)))
        raise fail(f"refinement row {row} names face {int(faces[row])}; the input has {n_faces}")
    bad = ~np.isfinite(weights).all(axis=1) | (weights < 0).any(axis=1) \
        | (np.abs(weights.sum(axis=1) - 1.0) > 1e-12)
    if bad.any():
        row = int(np.argmax(bad))
        raise fail(f"refinement row {row} has weights {weights[row].tolist()}: not barycentric")
    corners = input_mesh.faces[faces]
    back = np.einsum("nk,nkd->nd", weights, input_mesh.vertices[corners])
    scale = max(float(np.abs(input_mesh.vertices).max()), np.finfo(np.float64).tiny)
    off = np.abs(back - vertices).max(axis=1) > REFINEMENT_TOLERANCE * scale
    own = np.arange(n_input)
    off[:n_input] |= weights[own, np.argmax(corners[:n_input] == own[:, None], axis=1)] != 1.0
    if off.any():
        row = int(np.argmax(off))
        raise fail(f"refined vertex {row} is not where refinement row {row} puts it "
                   f"(face {int(faces[row])} of the input, weights {weights[row].tolist()})")
    return input_mesh._core, faces.astype(np.int64), np.ascontiguousarray(weights)


def _landmarks(arrays: Any, names: Any, points: np.ndarray,
               fail: Callable[[str], FormatError]) -> Tuple[np.ndarray, np.ndarray]:
    """A pinned map's landmarks as stored: ids in range and each point the
    map's own point for its id, bit for bit (what pinning guarantees), or a
    :class:`FormatError`: a file is data, not proof."""
    if not {"landmark_ids", "landmark_points"} <= set(names):
        raise fail("landmark_ids and landmark_points are stored together")
    ids, stored = np.asarray(arrays["landmark_ids"]), np.asarray(arrays["landmark_points"])
    if ids.ndim != 1 or ids.dtype.kind not in "iu" or stored.shape != (len(ids), 3) \
            or stored.dtype != np.float64:
        raise fail(f"landmarks must be ids (k,) and float64 points (k, 3), got "
                   f"{ids.dtype}{ids.shape} and {stored.dtype}{stored.shape}")
    if len(ids) and (ids.min() < 0 or ids.max() >= len(points)):
        raise fail(f"a landmark id is not a vertex of the mesh ({len(points)} vertices)")
    ids = ids.astype(np.int64)
    if not np.array_equal(points[ids], stored):
        wrong = int(np.argmax((points[ids] != stored).any(axis=1)))
        raise fail(f"landmark {int(ids[wrong])} is stored at {stored[wrong].tolist()}, "
                   f"but the map has it at {points[ids[wrong]].tolist()}")
    ids.flags.writeable = False
    stored = stored.copy()
    stored.flags.writeable = False
    return ids, stored


@file_errors
def save_map(m: "SphereMap", path: PathLike) -> None:
    """Write ``m`` to ``path`` atomically (temporary file, then rename)."""
    arrays: Dict[str, Any] = record(m)

    def fill(temporary: Path) -> None:
        with open(temporary, "wb") as handle:
            np.savez(handle, **arrays)
    write_atomically(path, fill)


@file_errors
def load_map(path: PathLike) -> "SphereMap":
    """Read a map written by :meth:`SphereMap.save` and certify it again.

    The certificate (``valid``, ``report``; for theta-phi ``tp_valid``) is
    computed in the core from the stored points and rectangle, never read
    from the file; the cut of a theta-phi map is made again from its path.
    The points are unit vectors: a stored row off unit length is projected
    onto the sphere (a note says how many were), as ``from_points`` does.
    Declared array sizes are checked before anything is inflated
    (``_npz_check``). Cost: O(file size) and the certification, O(n + m).

    Raises
    ------
    FileError
        The file cannot be read (also the builtin ``FileNotFoundError``,
        ``PermissionError``, ``IsADirectoryError``, ... of the cause).
    FormatError
        Not a sphere map, a newer format, or parts that do not fit the mesh or
        each other (points off the fold of the rectangle, a rectangle boundary
        not where eq. 6.31 puts it, a path that is not a cut), a point that is
        not finite or is zero, an array larger than the file can hold, a
        damaged zip or record; names the file.
    """
    file = Path(os.fspath(path))
    require_regular_file(file)
    if not is_zip_archive(file):  # (FileNotFoundError, PermissionError, ... from open)
        raise FormatError(f"{file}: not a sphere map (.spheremap.npz is a zip archive)", str(file))
    # (An open file, not the path: see _formats.read_npz.)
    with open(file, "rb") as handle:
        return _read_archive(handle, str(file))


def map_archive(m: "SphereMap") -> bytes:
    """``m``'s record as the bytes of a ``.spheremap.npz`` (what a pickled
    map carries: see the module docstring). Cost: O(n + m), one copy."""
    arrays: Dict[str, Any] = record(m)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def unpickle_map(archive: Any, source: str) -> "SphereMap":
    """The map a pickle carries as :func:`map_archive`'s bytes, read and
    certified as :func:`load_map` reads a file; whatever the bytes hold, the
    error is a :class:`FormatError` naming ``source``."""
    if not isinstance(archive, bytes):
        raise FormatError(f"{source}: a pickled map carries bytes, not a "
                          f"{type(archive).__name__}", source)
    handle = io.BytesIO(archive)
    if not is_zip_stream(handle):
        raise FormatError(f"{source}: not a sphere map archive", source)
    return _read_archive(handle, source)


def _read_archive(handle: IO[bytes], source: str) -> "SphereMap":
    """The map in the open ``.npz`` ``handle``: declared sizes checked before
    anything is inflated, then :func:`rebuild`."""
    try:
        # (The declared sizes are checked before numpy allocates them.)
        shapes = check_npz(handle, source)
        vertices, points = shapes.get("vertices", ()), shapes.get("points", ())
        if vertices[:1] and points[:1] and vertices[0] != points[0]:
            # Refused before either is inflated (a map of 60 vertices
            # whose points member declared 50M rows of deflated zeros).
            raise FormatError(f"{source}: {points[0]:,} points stored for {vertices[0]:,} "
                              "vertices (declared; a map has one point per vertex)", source)
        with np.load(handle, allow_pickle=False) as arrays:
            return rebuild(arrays, source)
    except Exception as err:
        if isinstance(err, FormatError) or not damaged_archive(err):
            raise
        raise FormatError(f"{source}: unreadable sphere map ({err})", source) from None
