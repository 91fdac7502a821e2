"""Readers of stored files (issue 26, findings 3, 4 and 8): ``.npz`` sizes
checked before anything is inflated, every damaged map file or pickle a
``FormatError`` naming the file, and points that are unit vectors on load."""

from __future__ import annotations

import io
import json
import pickle
import struct
import time
import tracemalloc
import zipfile
import zlib
from pathlib import Path
from typing import Any, Callable, Dict, List, Set, Tuple

import numpy as np
import pytest

import spherify as sp
from spherify import _persist


def small_map() -> sp.SphereMap:
    return sp.embed(sp.datasets.make("bumpy_blob", 60))


def npy_header(shape: Tuple[int, ...], descr: str = "<f8") -> bytes:
    """An .npy version 1.0 header declaring ``shape``."""
    text = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape!r}, }}"
    text += " " * (63 - (10 + len(text)) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode("latin1")


def deflated(header: bytes, n_mib: int) -> Tuple[bytes, int, int]:
    """A raw deflate stream of ``header`` and then ``n_mib`` MiB of zero
    bytes (about 1 kB per MiB: deflate's largest ratio), its CRC-32 and its
    inflated size, made without compressing a gigabyte: after the first MiB
    every flushed MiB of zeros compresses to the same bytes."""
    chunk = bytes(1 << 20)
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    start = compressor.compress(header) + compressor.flush(zlib.Z_SYNC_FLUSH)
    first = compressor.compress(chunk) + compressor.flush(zlib.Z_SYNC_FLUSH)
    again = compressor.compress(chunk) + compressor.flush(zlib.Z_SYNC_FLUSH)
    crc = zlib.crc32(header)
    for _ in range(n_mib):
        crc = zlib.crc32(chunk, crc)
    data = start + first + again * (n_mib - 1) + b"\x03\x00"
    return data, crc, len(header) + (n_mib << 20)


def write_zip(path: Path, members: List[Tuple[str, bytes, int, int, int]]) -> None:
    """A zip of ``(name, compressed bytes, method, crc, inflated size)``
    members, written by hand so that a member can be deflated data zipfile
    never compressed (and its sizes anything)."""
    out = io.BytesIO()
    central = b""
    for name, data, method, crc, size in members:
        offset = out.tell()
        encoded = name.encode()
        out.write(struct.pack("<4s5H3L2H", b"PK\x03\x04", 20, 0, method, 0, 0x21, crc,
                              len(data), size, len(encoded), 0) + encoded + data)
        central += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, 20, 0, method, 0, 0x21, crc,
                               len(data), size, len(encoded), 0, 0, 0, 0, 0, offset) + encoded
    start = out.tell()
    out.write(central + struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, len(members), len(members),
                                    len(central), start, 0))
    path.write_bytes(out.getvalue())


def stored_members(path: Path) -> Dict[str, bytes]:
    with zipfile.ZipFile(path) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


def stored(name: str, data: bytes) -> Tuple[str, bytes, int, int, int]:
    return (name, data, zipfile.ZIP_STORED, zlib.crc32(data), len(data))


def refused_in_small_memory(read: Callable[[Path], Any], path: Path, match: str) -> float:
    """``read(path)`` raises a FormatError matching ``match`` and naming the
    file, with a small peak of traced memory; returns the seconds it took."""
    began = time.perf_counter()
    tracemalloc.start()
    try:
        with pytest.raises(sp.FormatError, match=match) as info:
            read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert info.value.path == str(path) and str(path) in str(info.value)
    assert peak < 20_000_000, peak
    return time.perf_counter() - began


# --- finding 3: sizes before inflating ------------------------------------------------

@pytest.mark.parametrize("reader", ["load", "load_map"])
def test_a_header_declaring_1e11_rows_is_refused_before_anything_is_allocated(
        tmp_path: Path, reader: str) -> None:
    # Before: numpy's MemoryError "Unable to allocate 2.18 TiB" from a 2.6 KB file.
    m = small_map()
    path = tmp_path / ("m.npz" if reader == "load" else "m.spheremap.npz")
    m.save(path) if reader == "load_map" else sp.save(m.mesh, path)
    members = stored_members(path)
    name = "V.npy" if reader == "load" else "points.npy"
    members[name] = npy_header((10**11, 3)) + members[name][128:]
    write_zip(path, [stored(k, v) for k, v in members.items()])
    refused_in_small_memory(getattr(sp, reader), path, r"declares 300,000,000,000 elements")


def test_an_npy_pair_declaring_1e11_rows_is_refused_before_anything_is_allocated(
        tmp_path: Path) -> None:
    # Before: numpy's MemoryError (2.18 TiB) from a 1 kB V.npy.
    vertices, faces = tmp_path / "V.npy", tmp_path / "F.npy"
    vertices.write_bytes(npy_header((10**11, 3)) + bytes(1000))
    np.save(faces, small_map().mesh.faces)
    refused_in_small_memory(lambda p: sp.load((p, faces)), vertices,
                            r"declares 300,000,000,000 elements")
    vertices.write_bytes(npy_header((100, 3)) + bytes(1000))  # 2,400 bytes declared
    refused_in_small_memory(lambda p: sp.load((p, faces)), vertices, "more than its 1,000 bytes")


@pytest.mark.parametrize("reader", ["load", "load_map"])
@pytest.mark.parametrize("lie", ["honest sizes", "inflated size overstated"])
def test_a_one_megabyte_file_declaring_50M_points_is_refused_in_small_memory(
        tmp_path: Path, reader: str, lie: str) -> None:
    # Before: 1.17 MB declared as 50M points peaked at 2.4 GB and 14 s in
    # load_map, and loaded as a 50M-vertex mesh in sp.load.
    m = small_map()
    path = tmp_path / ("m.npz" if reader == "load" else "m.spheremap.npz")
    m.save(path) if reader == "load_map" else sp.save(m.mesh, path)
    members = [stored(k, v) for k, v in stored_members(path).items()
               if k != ("V.npy" if reader == "load" else "points.npy")]
    header = npy_header((50_000_000, 3))
    data, crc, inflated = deflated(header, 950)  # 0.98 MB of deflate, 996 MB of zeros
    if lie == "inflated size overstated":
        inflated = len(header) + 50_000_000 * 24  # what the header asks for
    members.append((("V.npy" if reader == "load" else "points.npy"), data,
                    zipfile.ZIP_DEFLATED, crc, inflated))
    write_zip(path, members)
    assert path.stat().st_size < 1_100_000
    seconds = refused_in_small_memory(getattr(sp, reader), path, "hold")
    assert seconds < 2.0


def test_a_map_whose_points_honestly_hold_50M_zeros_is_refused_before_inflating(
        tmp_path: Path) -> None:
    # 1.2 GB of zeros deflate into 1.2 MB, within deflate's ratio: the file
    # can hold them, but a map of 42 vertices has 42 points. Before: 2.4 GB
    # and 14 s, then a refusal.
    path = tmp_path / "m.spheremap.npz"
    small_map().save(path)
    members = [stored(k, v) for k, v in stored_members(path).items() if k != "points.npy"]
    header = npy_header((50_000_000, 3))
    data, crc, inflated = deflated(header, 1145)  # 1.2e9 bytes of zeros
    members.append(("points.npy", data, zipfile.ZIP_DEFLATED, crc, inflated))
    write_zip(path, members)
    assert path.stat().st_size < 1_300_000
    seconds = refused_in_small_memory(sp.load_map, path, r"50,000,000 points stored for \d+ vertices")
    assert seconds < 2.0


def test_members_that_could_not_inflate_to_their_stated_size_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.npz"
    sp.save(small_map().mesh, path)
    members = stored_members(path)
    compressed = zlib.compress(members["V.npy"])[2:-4]
    lying = [("V.npy", compressed, zipfile.ZIP_DEFLATED, zlib.crc32(members["V.npy"]),
              2000 * len(compressed)), stored("F.npy", members["F.npy"])]
    write_zip(path, lying)
    refused_in_small_memory(sp.load, path, "inflates to .* hold at most")
    bzip = tmp_path / "b.npz"
    with zipfile.ZipFile(bzip, "w", zipfile.ZIP_BZIP2) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    with pytest.raises(sp.FormatError, match="only stored and deflated members"):
        sp.load(bzip)


# --- finding 4: every damaged map file or pickle is a FormatError ---------------------

def edited_record(m: sp.SphereMap, edit: Callable[[Dict[str, Any]], None]) -> Dict[str, Any]:
    arrays: Dict[str, Any] = {k: np.array(v) for k, v in _persist.record(m).items()}
    edit(arrays)
    return arrays


def edit_meta(**changes: Any) -> Callable[[Dict[str, Any]], None]:
    def edit(arrays: Dict[str, Any]) -> None:
        meta = json.loads(str(arrays["meta"]))
        meta.update(changes)
        arrays["meta"] = np.array(json.dumps(meta))
    return edit


def deep_meta(arrays: Dict[str, Any]) -> None:
    meta = json.loads(str(arrays["meta"]))
    text = json.dumps(meta)
    arrays["meta"] = np.array(text[:-1] + ', "deep": ' + "[" * 100_000 + "]" * 100_000 + "}")


def beyond_unicode(meta: np.ndarray) -> np.ndarray:
    """``meta`` with the 's' of "progressive" made the code unit 0x53000073."""
    units = np.frombuffer(np.ascontiguousarray(meta, dtype=meta.dtype.newbyteorder("<"))
                          .tobytes(), dtype="<u4").copy()
    text = str(meta)
    at = text.index('"progressive"') + 6
    units[at] = 0x53000073
    return np.frombuffer(units.tobytes(), dtype=meta.dtype.newbyteorder("<")).reshape(())


EDITS: Dict[str, Callable[[Dict[str, Any]], None]] = {
    "version as 2 elements": lambda a: a.__setitem__(_persist.VERSION_KEY, np.array([1, 1])),
    "version complex": lambda a: a.__setitem__(_persist.VERSION_KEY, np.array(1 + 2j)),
    "version empty": lambda a: a.__setitem__(_persist.VERSION_KEY, np.array([], dtype=np.int64)),
    "mesh_attributes a list": edit_meta(mesh_attributes=[1, 2]),
    "iterations negative": edit_meta(iterations=-1),
    "iterations 2^64": edit_meta(iterations=2**64),
    "meta nested 100,000 deep": deep_meta,
    "meta a list": lambda a: a.__setitem__("meta", np.array("[1, 2]")),
    # a JSON escape of a lone surrogate, which no Rust string holds
    # (UnicodeEncodeError; found by the fuzzer)
    "message a lone surrogate": edit_meta(message="\udf63"),
    # a code unit beyond U+10FFFF in the numpy string: reached the core as
    # a Rust string that is not UTF-8 and made it panic (found by the fuzzer)
    "method beyond Unicode": lambda a: a.__setitem__("meta", beyond_unicode(a["meta"])),
    "meta not a string": lambda a: a.__setitem__("meta", np.array([1.0, 2.0])),
    "points as text": lambda a: a.__setitem__("points", np.array([["a", "b", "c"]])),
}


@pytest.mark.parametrize("case", sorted(EDITS))
def test_a_damaged_map_file_or_pickle_is_a_format_error_naming_it(tmp_path: Path,
                                                                   case: str) -> None:
    # Before: TypeError, OverflowError, RecursionError, from load_map and unpickling.
    arrays = edited_record(small_map(), EDITS[case])
    path = tmp_path / "m.spheremap.npz"
    np.savez(path, **arrays)
    with pytest.raises(sp.FormatError) as info:
        sp.load_map(path)
    assert info.value.path == str(path)
    with pytest.raises(sp.FormatError, match="pickled SphereMap"):
        _persist.rebuild(arrays, "pickled SphereMap")


def archive_of(arrays: Dict[str, Any]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


class DamagedInTransit:
    """Pickles as a SphereMap does (``_persist.unpickle_map`` of the bytes of
    its ``.spheremap.npz``), with a record damaged on the way; ``old`` as
    spherify did before (``_persist.rebuild`` of the record's arrays), which
    a pickle written then still goes through."""

    def __init__(self, record: Dict[str, Any], old: bool = False) -> None:
        self.record, self.old = record, old

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        if self.old:
            return (_persist.rebuild, (self.record, "pickled SphereMap"))
        return (_persist.unpickle_map, (archive_of(self.record), "pickled SphereMap"))


@pytest.mark.parametrize("old", [False, True], ids=["archive", "record of before"])
@pytest.mark.parametrize("case", ["iterations negative", "meta nested 100,000 deep",
                                  "version complex"])
def test_an_unpickled_damaged_record_is_a_format_error(case: str, old: bool) -> None:
    m = small_map()
    assert pickle.loads(pickle.dumps(m)).valid
    blob = pickle.dumps(DamagedInTransit(edited_record(m, EDITS[case]), old))
    with pytest.raises(sp.FormatError, match="pickled SphereMap"):
        pickle.loads(blob)


def globals_of(blob: bytes) -> Set[Tuple[str, str]]:
    found: Set[Tuple[str, str]] = set()

    class Recording(pickle.Unpickler):
        def find_class(self, module: str, name: str) -> Any:
            found.add((module, name))
            return super().find_class(module, name)
    Recording(io.BytesIO(blob)).load()
    return found


def test_a_pickled_map_carries_its_file_bytes_and_no_numpy_object() -> None:
    # Before, the record's arrays were pickled as numpy objects, and a mutated
    # pickle could make numpy crash the process (about once in 100,000 fuzzed
    # pickles) before spherify saw the record. Now the pickle machine makes one
    # bytes object, read as load_map reads a file.
    m = small_map()
    blob = pickle.dumps(m)
    assert globals_of(blob) == {("spherify._persist", "unpickle_map")}
    again = pickle.loads(blob)
    assert again.valid and np.array_equal(again.points, m.points)
    archive = _persist.map_archive(m)
    assert archive in blob
    for damaged in (archive[: len(archive) // 2], archive[:-30] + bytes(30), b"PK\x03\x04",
                    archive.replace(b"points", b"pointz")):
        with pytest.raises(sp.FormatError, match="pickled SphereMap"):
            _persist.unpickle_map(damaged, "pickled SphereMap")
    with pytest.raises(sp.FormatError, match="carries bytes, not a str"):
        _persist.unpickle_map("PK", "pickled SphereMap")


def test_an_npy_header_with_an_unbalanced_bracket_is_a_format_error(tmp_path: Path) -> None:
    # Before: tokenize.TokenError from numpy's header parser.
    path = tmp_path / "m.spheremap.npz"
    small_map().save(path)
    members = stored_members(path)
    text = "{'descr': '<f8', 'fortran_order': False, 'shape': ((60, 3), }"
    text += " " * (63 - (10 + len(text)) % 64) + "\n"
    members["points.npy"] = (b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text))
                             + text.encode() + members["points.npy"][128:])
    write_zip(path, [stored(k, v) for k, v in members.items()])
    with pytest.raises(sp.FormatError, match="malformed .npy header") as info:
        sp.load_map(path)
    assert info.value.path == str(path)
    mesh = tmp_path / "m.npz"
    write_zip(mesh, [stored("V.npy", members["points.npy"]), stored("F.npy", members["faces.npy"])])
    with pytest.raises(sp.FormatError, match="malformed .npy header"):
        sp.load(mesh)


@pytest.mark.parametrize("reader", ["load", "load_map"])
def test_a_central_directory_past_its_end_record_is_a_format_error(tmp_path: Path,
                                                                    reader: str) -> None:
    # Before: FileError "[Errno 22] Invalid argument" with no file name.
    path = tmp_path / ("m.npz" if reader == "load" else "m.spheremap.npz")
    m = small_map()
    m.save(path) if reader == "load_map" else sp.save(m.mesh, path)
    data = bytearray(path.read_bytes())
    end = data.rindex(b"PK\x05\x06")
    # The end record says the central directory starts 1000 bytes further on
    # than it does (past the end record itself): zipfile takes the
    # difference for bytes prepended to the archive and seeks to member
    # offsets 1000 bytes before the file's start.
    offset = struct.unpack("<L", data[end + 16:end + 20])[0]
    data[end + 16:end + 20] = struct.pack("<L", offset + 1000)
    path.write_bytes(bytes(data))
    with pytest.raises(sp.FormatError) as info:
        getattr(sp, reader)(path)
    assert info.value.path == str(path) and str(path) in str(info.value)


# --- finding 8: unit vectors on load --------------------------------------------------

def test_loaded_points_are_unit_vectors_normalised_and_certified_again(tmp_path: Path) -> None:
    m = small_map()
    path = tmp_path / "m.spheremap.npz"
    scaled = edited_record(m, lambda a: a.__setitem__("points", a["points"] * 2.0))
    np.savez(path, **scaled)
    back = sp.load_map(path)
    assert np.allclose(np.linalg.norm(back.points, axis=1), 1.0, rtol=0, atol=1e-15)
    assert back.valid == m.valid and np.allclose(back.points, m.points, rtol=0, atol=1e-15)
    assert any("unit sphere" in note for note in back.notes)
    huge = edited_record(m, lambda a: a["points"].__setitem__(0, [1e300, -1.0, 0.0]))
    np.savez(path, **huge)
    back = sp.load_map(path)
    assert np.allclose(np.linalg.norm(back.points, axis=1), 1.0, rtol=0, atol=1e-15)
    back.to_sphere(np.array([0]), np.array([[1 / 3, 1 / 3, 1 / 3]]))  # raised before
    # A saved map loads bit for bit, with no note.
    m.save(path)
    assert np.array_equal(sp.load_map(path).points, m.points)
    assert sp.load_map(path).notes == m.notes


@pytest.mark.parametrize("row, what", [([np.inf, 0.0, 0.0], "not finite"),
                                       ([np.nan, 1.0, 0.0], "not finite"),
                                       ([0.0, 0.0, 0.0], "zero")])
def test_a_point_that_is_not_finite_or_zero_is_refused(tmp_path: Path, row: List[float],
                                                       what: str) -> None:
    path = tmp_path / "m.spheremap.npz"
    np.savez(path, **edited_record(small_map(), lambda a: a["points"].__setitem__(7, row)))
    with pytest.raises(sp.FormatError, match=f"point 7 .*{what}") as info:
        sp.load_map(path)
    assert info.value.path == str(path)


# --- GIfTI: declared arrays checked before nibabel reads them ---------------------------

def gifti_with(tmp_path: Path, old: bytes, new: bytes) -> Path:
    pytest.importorskip("nibabel")
    path = tmp_path / "m.surf.gii"
    sp.save(sp.datasets.icosphere(200), path)
    data = path.read_bytes()
    assert old in data
    damaged = tmp_path / "damaged.surf.gii"
    damaged.write_bytes(data.replace(old, new, 1))
    return damaged


@pytest.mark.timeout(60)
@pytest.mark.parametrize("old, new, why", [
    # Found by the fuzzer: nibabel counted up to the Dimensionality, and a
    # 180-digit one hung sp.load (it never returned).
    (b'Dimensionality="2"', b'Dimensionality="' + b"2" * 180 + b'"', "Dimensionality is"),
    # The same through a character reference, which the XML parser decodes.
    (b'Dimensionality="2"', b'Dimensionality="&#50;' + b"2" * 180 + b'"', "Dimensionality is"),
    (b'Dimensionality="2"', b'Dimensionality="7"', "Dimensionality is '7'"),
    (b'Dim1="3"', b'Dim1="-3"', "Dim1 is '-3', not a count"),
    (b'Dim0="', b'Dim0="99999999', "elements, more than its"),
    # An encoding Python does not know (LookupError from the XML parser).
    (b'encoding="UTF-8"', b'encoding="UTF-n"', "LookupError"),
])
def test_a_gifti_declaring_arrays_no_file_holds_is_refused_at_once(
        tmp_path: Path, old: bytes, new: bytes, why: str) -> None:
    path = gifti_with(tmp_path, old, new)
    started = time.perf_counter()
    with pytest.raises(sp.FormatError, match=why) as info:
        sp.load(path)
    assert time.perf_counter() - started < 5
    assert info.value.path == str(path)
