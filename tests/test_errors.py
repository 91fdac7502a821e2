"""Every failure a user can cause raises the right SpherifyError subclass (for
the file system a FileError, also the builtin OSError of its cause), with a
message that says what is wrong."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable, List

import numpy as np
import pytest

import spherify as sp

V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
TETRA_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def tetra() -> sp.Mesh:
    return sp.Mesh(V, F)


def with_value(a: np.ndarray, row: int, col: int, value: Any) -> np.ndarray:
    out = a.copy()
    out[row, col] = value
    return out


def raises(exc: type, call: Callable[[], Any], *words: str) -> Any:
    """Asserts that ``call`` raises ``exc`` whose message holds every word."""
    with pytest.raises(exc) as info:
        call()
    message = str(info.value)
    for word in words:
        assert word in message, f"{word!r} missing from {message!r}"
    return info.value


# --------------------------------------------------------------------------
# The hierarchy
# --------------------------------------------------------------------------

def test_hierarchy() -> None:
    assert issubclass(sp.MeshError, sp.SpherifyError) and issubclass(sp.MeshError, ValueError)
    assert issubclass(sp.FormatError, sp.SpherifyError) and issubclass(sp.FormatError, ValueError)
    assert issubclass(sp.TopologyError, sp.MeshError)
    assert issubclass(sp.ConvergenceError, sp.SpherifyError) and issubclass(sp.ConvergenceError, RuntimeError)


# --------------------------------------------------------------------------
# Bad arrays
# --------------------------------------------------------------------------

BAD_MESHES: List[Any] = [
    # (id, vertices, faces, words the message must contain)
    ("vertices-1d", V.ravel(), F, ["vertices", "(n, 3)"]),
    ("vertices-3d", V[None], F, ["vertices", "(n, 3)"]),
    ("vertices-2-columns", V[:, :2], F, ["vertices", "(n, 3)", "2"]),
    ("faces-4-columns", V, np.hstack([F, F[:, :1]]), ["faces", "3"]),
    ("faces-1d", V, F.ravel(), ["faces"]),
    ("vertices-strings", V.astype(str), F, ["vertices", "numeric"]),
    ("vertices-complex", V.astype(complex), F, ["vertices", "complex"]),
    ("vertices-ragged", [[0, 0, 0], [1, 2]], F, ["vertices"]),
    ("faces-float", V, F.astype(float), ["faces", "integer", "float64"]),
    ("faces-bool", V, F.astype(bool), ["faces", "integer"]),
    ("faces-strings", V, F.astype(str), ["faces", "integer"]),
    ("vertices-empty", np.zeros((0, 3)), F, ["no vertices"]),
    ("faces-empty", V, np.zeros((0, 3), dtype=np.int64), ["no faces"]),
    ("vertex-nan", with_value(V, 2, 1, np.nan), F, ["vertex 2", "NaN"]),
    ("vertex-inf", with_value(V, 3, 0, np.inf), F, ["vertex 3", "inf"]),
    ("vertex-minus-inf", with_value(V, 1, 2, -np.inf), F, ["vertex 1", "inf"]),
    ("index-negative", V, with_value(F, 2, 1, -1), ["face 2", "-1"]),
    ("index-too-large", V, with_value(F, 3, 2, 4), ["face 3", "4", "4 vertices"]),
    ("index-huge", V, with_value(F, 0, 0, 2**40), ["face 0", str(2**40)]),
    ("index-beyond-int64", V, F.astype(np.uint64) + np.uint64(2**63), ["int64"]),
]


@pytest.mark.parametrize("vertices, faces, words", [b[1:] for b in BAD_MESHES],
                         ids=[b[0] for b in BAD_MESHES])
def test_bad_arrays_raise_mesh_error(vertices: Any, faces: Any, words: List[str]) -> None:
    err = raises(sp.MeshError, lambda: sp.Mesh(vertices, faces), *words)
    assert isinstance(err, ValueError) and not isinstance(err, sp.TopologyError)


def test_check_reports_rather_than_raises_bad_values() -> None:
    report = sp.check((with_value(V, 0, 0, np.nan), with_value(F, 1, 1, 7)))
    assert report.non_finite_vertices == [0] and report.out_of_range_faces == [1]


@pytest.mark.parametrize("arg", [[V, F], (V, F, F), "mesh.obj", None, (V,)],
                         ids=["list", "triple", "str", "none", "single"])
def test_check_of_something_else_raises_mesh_error(arg: Any) -> None:
    raises(sp.MeshError, lambda: sp.check(arg), "Mesh")


def test_check_raw_pair_with_bad_shapes_raises_mesh_error() -> None:
    raises(sp.MeshError, lambda: sp.check((V[:, :2], F)), "vertices", "(n, 3)")
    raises(sp.MeshError, lambda: sp.check((V, F.astype(float))), "faces", "integer")


# --------------------------------------------------------------------------
# Bad arguments
# --------------------------------------------------------------------------

@pytest.mark.parametrize("weights", ["euclidean", "Length", "", "cotan"])
def test_unknown_weights_raise_mesh_error(weights: str) -> None:
    mesh = tetra()
    raises(sp.MeshError, lambda: sp.dijkstra(mesh, 0, weights=weights), "'length'", "'uniform'", repr(weights)[1:-1])
    raises(sp.MeshError, lambda: sp.shortest_path(mesh, 0, 1, weights=weights), "'length'", "'uniform'")


@pytest.mark.parametrize("source", [-1, 4, 10**12])
def test_out_of_range_source_raises_mesh_error(source: int) -> None:
    mesh = tetra()
    raises(sp.MeshError, lambda: sp.dijkstra(mesh, source), str(source), "4 vertices")
    raises(sp.MeshError, lambda: sp.shortest_path(mesh, source, 0), str(source))
    raises(sp.MeshError, lambda: sp.shortest_path(mesh, 0, source), str(source))


def test_unreachable_target_raises_mesh_error() -> None:
    two = sp.Mesh(np.vstack([V, V + 5.0]), np.vstack([F, F + 4]))
    raises(sp.MeshError, lambda: sp.shortest_path(two, 0, 6), "0", "6")


def test_unknown_ply_encoding_raises_mesh_error(tmp_path: Path) -> None:
    raises(sp.MeshError, lambda: sp.save(tetra(), tmp_path / "t.ply", ply_encoding="utf8"),
           "ascii", "binary_little_endian", "utf8")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------
# Malformed files
# --------------------------------------------------------------------------

def format_error(path: Path, *words: str) -> sp.FormatError:
    err = raises(sp.FormatError, lambda: sp.load(path), str(path), *words)
    assert isinstance(err, sp.FormatError)
    assert isinstance(err, ValueError) and isinstance(err, sp.SpherifyError)
    assert err.path == str(path)
    return err


@pytest.mark.parametrize("bad_line", [1, 3, 4, 6])
def test_obj_bad_number_names_its_line(tmp_path: Path, bad_line: int) -> None:
    lines = TETRA_OBJ.splitlines()
    lines.insert(bad_line - 1, "v 0 0.5 zero")
    path = tmp_path / "bad.obj"
    path.write_text("\n".join(lines) + "\n")
    err = format_error(path, "zero", f"line {bad_line}")
    assert err.line == bad_line and err.offset is None


def test_obj_index_out_of_range_names_its_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.obj"
    path.write_text(TETRA_OBJ + "f 1 2 9\n")
    err = format_error(path, "9")
    assert err.line == 9


def test_binary_ply_truncated_names_a_byte_offset(tmp_path: Path) -> None:
    good = tmp_path / "good.ply"
    sp.save(tetra(), good)
    data = good.read_bytes()
    header = data.index(b"end_header\n") + len(b"end_header\n")
    for cut in (len(data) - 1, len(data) - 13, header + 10):
        path = tmp_path / f"cut{cut}.ply"
        path.write_bytes(data[:cut])
        err = format_error(path)
        assert err.offset is not None and err.line is None
        assert header <= err.offset <= len(data)


@pytest.mark.parametrize("encoding", ["binary_little_endian", "ascii"])
def test_ply_announcing_a_trillion_vertices_fails_fast(tmp_path: Path, encoding: str) -> None:
    path = tmp_path / "huge.ply"
    path.write_text(f"ply\nformat {encoding} 1.0\nelement vertex {10**12}\n"
                    "property float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n")
    start = time.perf_counter()
    err = format_error(path, str(10**12))
    assert time.perf_counter() - start < 1.0
    assert err.line is not None or err.offset is not None


def test_off_count_mismatch_names_the_counts_line(tmp_path: Path) -> None:
    body = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
    for counts in ("5 4 0", "4 5 0"):
        path = tmp_path / f"c{counts[0]}{counts[2]}.off"
        path.write_text(f"OFF\n{counts}\n{body}")
        err = format_error(path)
        assert err.line == 2
    path = tmp_path / "ok.off"
    path.write_text(f"OFF\n4 4 0\n{body}")
    assert sp.load(path).n_faces == 4


def test_binary_stl_with_wrong_size_is_a_format_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.stl"
    path.write_bytes(b"\0" * 80 + (10).to_bytes(4, "little") + b"\0" * 60)
    err = format_error(path, "10")
    assert err.offset is not None


@pytest.mark.parametrize("name, content", [("empty.obj", ""), ("empty.off", ""), ("empty.ply", ""),
                                           ("junk.ply", "\x00\xff garbage\n"), ("empty.stl", "")])
def test_empty_or_garbage_files_are_format_errors(tmp_path: Path, name: str, content: str) -> None:
    path = tmp_path / name
    path.write_text(content)
    format_error(path)


@pytest.mark.parametrize("name", ["mesh.gltf", "mesh", "mesh.obj.bak"])
def test_unknown_extension_is_a_format_error(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_text(TETRA_OBJ)
    format_error(path, ".obj", ".ply")
    raises(sp.FormatError, lambda: sp.save(tetra(), tmp_path / ("out_" + name)), ".obj")
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_missing_file_is_file_not_found(tmp_path: Path) -> None:
    path = tmp_path / "missing.obj"
    err = raises(FileNotFoundError, lambda: sp.load(path), str(path))
    assert isinstance(err, sp.FileError) and isinstance(err, sp.SpherifyError)


# --------------------------------------------------------------------------
# Saving
# --------------------------------------------------------------------------

def save_with(path: Path, attribute: str, value: np.ndarray) -> None:
    if attribute == "sphere":
        sp.save(tetra(), path, sphere=value)
    else:
        sp.save(tetra(), path, uv=value)


@pytest.mark.parametrize("ext, attribute", [("obj", "sphere"), ("off", "sphere"), ("stl", "sphere"),
                                            ("off", "uv"), ("stl", "uv")])
def test_attribute_the_format_cannot_hold_is_a_format_error(tmp_path: Path, ext: str, attribute: str) -> None:
    value = np.zeros((4, 3 if attribute == "sphere" else 2))
    path = tmp_path / f"t.{ext}"
    err = raises(sp.FormatError, lambda: save_with(path, attribute, value), f".{ext}", ".ply")
    assert err.path == str(path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("attribute, shape", [("sphere", (3, 3)), ("sphere", (4, 2)), ("uv", (5, 2)),
                                              ("uv", (4, 3)), ("uv", (8,))])
def test_attribute_of_the_wrong_shape_is_a_mesh_error(tmp_path: Path, attribute: str, shape: Any) -> None:
    raises(sp.MeshError, lambda: save_with(tmp_path / "t.ply", attribute, np.zeros(shape)), attribute)
    assert list(tmp_path.iterdir()) == []


def test_save_into_a_missing_folder_raises_and_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "no" / "such" / "folder" / "t.ply"
    raises(FileNotFoundError, lambda: sp.save(tetra(), target), str(target))
    assert list(tmp_path.iterdir()) == []


def test_save_over_a_folder_raises_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "taken.obj"
    target.mkdir()
    raises(OSError, lambda: sp.save(tetra(), target), str(target))
    assert [p.name for p in tmp_path.iterdir()] == ["taken.obj"] and target.is_dir()
    assert list(target.iterdir()) == []


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "stl"])
def test_failed_save_leaves_the_old_file_untouched(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"keep.{ext}"
    sp.save(tetra(), path)
    before = path.read_bytes()
    other = sp.Mesh(V * 2.0, F)
    # A wrong-length attribute fails after the target exists.
    raises(sp.MeshError, lambda: sp.save(other, path, uv=np.zeros((3, 2))), "uv")
    if ext == "ply":
        raises(sp.MeshError, lambda: sp.save(other, path, sphere=np.zeros((5, 3))), "sphere")
    else:
        raises(sp.FormatError, lambda: sp.save(other, path, sphere=np.zeros((4, 3))), "sphere")
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "stl"])
def test_save_replaces_an_existing_file(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"t.{ext}"
    path.write_bytes(b"old content that is not a mesh " * 100)
    sp.save(sp.Mesh(V * 2.0, F), path)
    loaded = sp.load(path)  # STL renumbers the vertices: compare as sets of rows
    assert sorted(map(tuple, loaded.vertices.tolist())) == sorted(map(tuple, (V * 2.0).tolist()))
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
