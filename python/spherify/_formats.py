"""The file formats that live in Python, beside the core's OBJ, OFF, PLY and STL.

* ``.npz`` holding ``V`` (n, 3) and ``F`` (m, 3) (``vertices`` / ``faces`` are
  accepted too), and a pair of ``.npy`` files, for data-set users; numpy only,
  never unpickling (``allow_pickle=False``).
* FreeSurfer binary triangle surfaces (``lh.pial``, ``lh.white``,
  ``lh.sphere``, ...) and GIfTI surfaces (``.surf.gii``), through nibabel, an
  optional extra (``pip install "spherify[neuro]"``).

:func:`reader_for` and :func:`writer_for` say which format a path is in (by
its name, and for reading FreeSurfer's nameless format by its magic number);
``sp.load`` and ``sp.save`` send everything they do not know to the core.
Every malformed file raises :class:`FormatError` naming the file.
"""

from __future__ import annotations

import errno
import importlib
import lzma
import os
import zipfile
import zlib
from xml.parsers import expat
from pathlib import Path
from typing import IO, Any, Callable, Dict, List, Optional, Tuple

import numpy as np

from ._atomic import write_atomically
from ._errors import FormatError, MeshError
from ._files import require_regular_file
from ._npz_check import DEFLATE_RATIO, DEFLATE_SLACK, MAX_ELEMENTS, check_npy, check_npz

#: What a reader returns: vertices, faces, notes, per-vertex attributes.
Loaded = Tuple[np.ndarray, np.ndarray, List[str], Dict[str, np.ndarray]]
Reader = Callable[[Path], Loaded]
Writer = Callable[[Path, np.ndarray, np.ndarray, Dict[str, np.ndarray]], None]

CORE_SUFFIXES = (".obj", ".off", ".ply", ".stl")
#: Names FreeSurfer gives its surfaces (``lh.pial``, ``rh.sphere.reg``): the
#: last suffix of a file to be written in FreeSurfer's format.
FREESURFER_NAMES = ("pial", "white", "sphere", "inflated", "orig", "smoothwm", "reg",
                    "midthickness", "graymid", "qsphere", "pial_semi_inflated", "very_inflated")
#: The first three bytes of a FreeSurfer triangle file, and of the older quad file.
FREESURFER_TRIANGLE_MAGIC = b"\xff\xff\xfe"
FREESURFER_QUAD_MAGIC = b"\xff\xff\xff"
#: What FreeSurfer writes into the file's header line: fixed, so that the
#: same mesh gives the same bytes (nibabel would stamp the user and the time).
FREESURFER_STAMP = "created by spherify"
#: FreeSurfer's sphere radius (mris_sphere, ?h.sphere).
FREESURFER_RADIUS = 100.0

SUPPORTED = (".obj, .off, .ply, .stl, .npz (V, F), a (V.npy, F.npy) pair, FreeSurfer surfaces "
             "(lh.pial, lh.white, lh.sphere, ...) and GIfTI .gii (the last two with "
             "pip install 'spherify[neuro]')")
FORMATS = ("npz", "freesurfer", "gifti")


def _name(path: Path) -> str:
    return path.name.lower()


def reader_for(path: Path) -> Optional[Reader]:
    """The Python reader of ``path``, or None when the core reads it.

    Raises FileNotFoundError / OSError when a file without a known extension
    cannot be opened to look at its first bytes, and FormatError when it is
    in no format spherify reads.
    """
    name = _name(path)
    if name.endswith(".gii"):
        return read_gifti
    if name.endswith(".npz"):
        return read_npz
    if name.endswith(".npy"):
        raise FormatError(f"{path}: a .npy file holds one array; give a (V.npy, F.npy) pair "
                          "of paths or an .npz holding V and F", str(path))
    if path.suffix.lower() in CORE_SUFFIXES:
        return None
    require_regular_file(path)
    with open(path, "rb") as handle:
        magic = handle.read(3)
    if magic in (FREESURFER_TRIANGLE_MAGIC, FREESURFER_QUAD_MAGIC):
        return read_freesurfer
    raise FormatError(f"{path}: not a mesh file spherify reads; supported: {SUPPORTED}", str(path))


def writer_for(path: Path, format: Optional[str]) -> Optional[Writer]:
    """The Python writer for ``path`` (``format`` forces one of
    :data:`FORMATS`), or None when the core writes it (it checks the extension)."""
    if format is not None:
        writers: Dict[str, Writer] = {"npz": write_npz, "freesurfer": write_freesurfer,
                                      "gifti": write_gifti}
        if format not in writers:
            raise MeshError(f"format must be None or one of {', '.join(FORMATS)}, glb, "
                            f"got {format!r}")
        return writers[format]
    name = _name(path)
    if name.endswith(".gii"):
        return write_gifti
    if name.endswith(".npz"):
        return write_npz
    if path.suffix.lower() in CORE_SUFFIXES:
        return None
    if path.suffix.lower().lstrip(".") in FREESURFER_NAMES:
        return write_freesurfer
    raise FormatError(f"{path}: cannot tell the format from the name; supported: {SUPPORTED}, "
                      "and .glb (glTF, written only); or pass format='freesurfer' | 'gifti' | "
                      "'npz' | 'glb'", str(path))


def is_freesurfer_name(path: Path) -> bool:
    """Whether ``path`` would be written as a FreeSurfer surface by its name."""
    try:
        return writer_for(path, None) is write_freesurfer
    except FormatError:
        return False


# --- numpy --------------------------------------------------------------------

def _pick(arrays: Any, path: Path, names: Tuple[str, ...]) -> np.ndarray:
    for name in names:
        if name in arrays.files:
            return np.asarray(arrays[name])
    raise FormatError(f"{path}: holds no array named {' or '.join(names)} "
                      f"(it has {', '.join(sorted(arrays.files)) or 'none'})", str(path))


def is_zip_archive(path: Path) -> bool:
    """Whether ``path`` is a zip archive as ``np.load`` and ``zipfile`` both
    read one (see :func:`is_zip_stream`)."""
    with open(path, "rb") as handle:
        return is_zip_stream(handle)


def is_zip_stream(handle: IO[bytes]) -> bool:
    """Whether the open ``handle`` (a file, or bytes in memory) holds a zip
    archive as ``np.load`` and ``zipfile`` both read one: ``np.load`` goes by
    the first bytes, ``zipfile.is_zipfile`` by the end, and an ``.npy`` array
    with a zip's end record appended passed the one and came back as an array
    from the other. Leaves ``handle`` at its start."""
    handle.seek(0)
    start = handle.read(4)
    found = start in (b"PK\x03\x04", b"PK\x05\x06") and zipfile.is_zipfile(handle)
    handle.seek(0)
    return found


def damaged_archive(err: BaseException) -> bool:
    """Whether ``err``, raised while numpy read a zip archive, says the
    archive is damaged (a :class:`FormatError` for the reader to raise, naming
    the file) rather than that something else went wrong. Besides the
    ``ValueError`` / ``BadZipFile`` family, ``zipfile`` raises
    ``NotImplementedError`` for an unknown zip version or compression method,
    ``RuntimeError`` for an encrypted member, and the decompressors their
    own errors: ``zlib.error``, ``lzma.LZMAError``, and for bzip2 an
    ``OSError`` without an errno (one with an errno is the disk's, a
    ``FileError``). Found by mutating ``.npz`` files (2026-12-02). Also
    ``EINVAL``: a central directory that points past its end record makes
    ``zipfile`` seek before the file's start (a regular file's read or seek
    gives EINVAL for nothing else; issue 26, finding 4)."""
    if isinstance(err, (ValueError, EOFError, KeyError, zipfile.BadZipFile,
                        NotImplementedError, zlib.error, lzma.LZMAError)):
        return True
    if isinstance(err, RuntimeError):
        return "encrypted" in str(err)
    return isinstance(err, OSError) and err.errno in (None, errno.EINVAL)


def read_npz(path: Path) -> Loaded:
    """``V``/``F`` (or ``vertices``/``faces``) from an ``.npz``; ``sphere`` (n, 3)
    and ``uv`` (n, 2), when present, become attributes. Never unpickles."""
    require_regular_file(path)
    if not is_zip_archive(path):  # (FileNotFoundError, PermissionError, ... from open)
        raise FormatError(f"{path}: not an .npz (zip) archive", str(path))
    try:
        # np.load gets an open file: given a path, it leaks its handle when
        # the zip's central directory is refused (an unknown zip version).
        # The declared sizes are checked before numpy allocates them.
        with open(path, "rb") as handle:
            check_npz(handle, str(path))
            with np.load(handle, allow_pickle=False) as arrays:
                vertices = _pick(arrays, path, ("V", "vertices"))
                faces = _pick(arrays, path, ("F", "faces"))
                attributes = {name: np.asarray(arrays[name], dtype=np.float64)
                              for name in ("sphere", "uv") if name in arrays.files}
    except Exception as err:
        if isinstance(err, FormatError) or not damaged_archive(err):
            raise
        raise FormatError(f"{path}: not a readable .npz archive: {err}", str(path)) from None
    return vertices, faces, [], attributes


def read_npy_pair(vertices_path: Path, faces_path: Path) -> Loaded:
    """Vertices and faces from two ``.npy`` files. Never unpickles."""
    arrays = []
    for path in (vertices_path, faces_path):
        require_regular_file(path)
        try:
            with open(path, "rb") as handle:
                check_npy(handle, str(path))  # before numpy allocates what it declares
                loaded = np.load(handle, allow_pickle=False)
                if not isinstance(loaded, np.ndarray):
                    loaded.close()
                    raise FormatError(f"{path}: an .npz archive, not an .npy array", str(path))
                arrays.append(loaded)
        except FormatError:
            raise
        except (ValueError, EOFError) as err:
            raise FormatError(f"{path}: not a readable .npy array: {err}", str(path)) from None
    return arrays[0], arrays[1], [], {}


def write_npz(path: Path, vertices: np.ndarray, faces: np.ndarray,
              attributes: Dict[str, np.ndarray]) -> None:
    """``V`` (n, 3) float64, ``F`` (m, 3) int64 and any attributes, uncompressed."""
    arrays: Dict[str, Any] = {"V": vertices, "F": faces, **attributes}

    def fill(temporary: Path) -> None:
        with open(temporary, "wb") as handle:
            np.savez(handle, **arrays)
    write_atomically(path, fill)


# --- nibabel ------------------------------------------------------------------

def _nibabel(path: Path, what: str, module: str) -> Any:
    """``nibabel.<module>``, imported on use (an optional extra, and loosely
    typed: as ``Any`` the calls below read the same with nibabel or without)."""
    try:
        importlib.import_module("nibabel")
        return importlib.import_module(f"nibabel.{module}")
    except ImportError:
        raise FormatError(f"{path}: {what} needs nibabel: pip install 'spherify[neuro]'",
                          str(path)) from None


def _no_attributes(path: Path, attributes: Dict[str, np.ndarray], what: str) -> None:
    if attributes:
        raise MeshError(f"{path}: {what} files hold no per-vertex {', '.join(sorted(attributes))}; "
                        "use .ply or .npz for those")


def read_freesurfer(path: Path) -> Loaded:
    """A FreeSurfer binary surface (``lh.pial``, ``lh.sphere``, ...): float32
    coordinates in millimetres (a FreeSurfer sphere has radius 100)."""
    fsio = _nibabel(path, "reading a FreeSurfer surface", "freesurfer.io")
    try:
        vertices, faces = fsio.read_geometry(os.fspath(path))
    except OSError:
        raise
    except Exception as err:
        # nibabel's parser reports a truncated or garbled file as whatever numpy
        # raised on the short read (ValueError, struct.error, IndexError, ...).
        raise FormatError(f"{path}: not a readable FreeSurfer surface "
                          f"({type(err).__name__}: {err})", str(path)) from None
    notes = []
    with open(path, "rb") as handle:
        if handle.read(3) == FREESURFER_QUAD_MAGIC:
            notes.append("FreeSurfer quad surface: each quad split into two triangles by nibabel")
    return np.asarray(vertices), np.asarray(faces), notes, {}


def write_freesurfer(path: Path, vertices: np.ndarray, faces: np.ndarray,
                     attributes: Dict[str, np.ndarray]) -> None:
    """FreeSurfer's binary triangle format: big-endian float32 coordinates
    (rounded from float64) and int32 faces, with a fixed header stamp."""
    _no_attributes(path, attributes, "FreeSurfer")
    fsio = _nibabel(path, "writing a FreeSurfer surface", "freesurfer.io")
    if len(vertices) > np.iinfo(np.int32).max:
        raise MeshError(f"{path}: FreeSurfer stores at most 2^31 - 1 vertices")
    write_atomically(path, lambda temporary: fsio.write_geometry(
        os.fspath(temporary), vertices, faces, create_stamp=FREESURFER_STAMP))


#: GIfTI's largest Dimensionality (Dim0 ... Dim5).
GIFTI_MAX_DIMENSIONS = 6


def check_gifti_arrays(data: bytes, path: Path) -> None:
    """Refuse, before nibabel reads ``data``, a GIfTI file whose data arrays
    declare what no file of this size holds: a ``Dimensionality`` that is
    not a number from 0 to 6 (nibabel counts up to it: a mutated file
    declaring a 180-digit one hung the reader, found by the fuzzer, issue 26),
    a ``Dim<i>`` that is not a count, or more elements than ``MAX_ELEMENTS`` or
    than the file's bytes could inflate to (deflate at most 1032 : 1). Reads
    the XML once with expat, which also decodes the attributes' entities as
    nibabel's parser will."""
    def fail(why: str) -> FormatError:
        return FormatError(f"{path}: not a readable GIfTI file ({why})", str(path))

    most = DEFLATE_RATIO * len(data) + DEFLATE_SLACK

    def start(name: str, attributes: Dict[str, str]) -> None:
        if name != "DataArray":
            return
        text = attributes.get("Dimensionality", "0").strip()
        if not (text.isdigit() and len(text) < 3 and int(text) <= GIFTI_MAX_DIMENSIONS):
            raise fail(f"a DataArray's Dimensionality is {text[:40]!r}, not 0 to "
                       f"{GIFTI_MAX_DIMENSIONS}")
        elements = 1
        for i in range(int(text)):
            dim = attributes.get(f"Dim{i}", "").strip()
            if not (dim.isdigit() and len(dim) < 20):
                raise fail(f"a DataArray's Dim{i} is {dim[:40]!r}, not a count")
            elements *= int(dim)
        if elements > min(MAX_ELEMENTS, most):
            raise fail(f"a DataArray declares {elements:,} elements, more than its "
                       f"{len(data):,}-byte file can hold")

    parser = expat.ParserCreate()
    parser.StartElementHandler = start
    try:
        parser.Parse(data, True)
    except (expat.ExpatError, LookupError, ValueError) as err:
        # (LookupError: an encoding the XML declaration names that Python
        # does not know; ValueError: text that is not in it. Found by the
        # fuzzer once this check read the file before nibabel.)
        raise fail(f"{type(err).__name__}: {err}") from None


def read_gifti(path: Path) -> Loaded:
    """A GIfTI surface: its ``NIFTI_INTENT_POINTSET`` and ``NIFTI_INTENT_TRIANGLE`` arrays."""
    gifti = _nibabel(path, "reading a GIfTI surface", "gifti")
    require_regular_file(path)
    data = path.read_bytes()
    check_gifti_arrays(data, path)
    try:
        image = gifti.GiftiImage.from_bytes(data)
        points = image.get_arrays_from_intent("NIFTI_INTENT_POINTSET")
        triangles = image.get_arrays_from_intent("NIFTI_INTENT_TRIANGLE")
    except Exception as err:
        # The XML parser and nibabel's decoders raise their own types
        # (ExpatError, ValueError, KeyError, zlib.error, ...).
        raise FormatError(f"{path}: not a readable GIfTI file ({type(err).__name__}: {err})",
                          str(path)) from None
    if len(points) != 1 or len(triangles) != 1:
        raise FormatError(f"{path}: a GIfTI surface needs one POINTSET and one TRIANGLE array, "
                          f"found {len(points)} and {len(triangles)}", str(path))
    return np.asarray(points[0].data), np.asarray(triangles[0].data), [], {}


def write_gifti(path: Path, vertices: np.ndarray, faces: np.ndarray,
                attributes: Dict[str, np.ndarray]) -> None:
    """A GIfTI surface: float32 POINTSET (GIfTI has no float64) and int32 TRIANGLE."""
    _no_attributes(path, attributes, "GIfTI")
    gifti = _nibabel(path, "writing a GIfTI surface", "gifti")
    if len(vertices) > np.iinfo(np.int32).max:
        raise MeshError(f"{path}: GIfTI stores int32 face indices, at most 2^31 - 1 vertices")
    image = gifti.GiftiImage(darrays=[
        gifti.GiftiDataArray(vertices.astype(np.float32), intent="NIFTI_INTENT_POINTSET",
                       datatype="NIFTI_TYPE_FLOAT32"),
        gifti.GiftiDataArray(faces.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE",
                       datatype="NIFTI_TYPE_INT32"),
    ])
    data: bytes = image.to_bytes()

    def fill(temporary: Path) -> None:
        temporary.write_bytes(data)
    write_atomically(path, fill)
