"""sp.save / sp.load round trips in every format and encoding (files under tmp_path)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import spherify as sp

pytest.importorskip("scipy", reason="the random mesh strategies use scipy.spatial.ConvexHull")

import _meshgen as mg  # noqa: E402

# (id, extension, keyword arguments of sp.save)
EXACT_FORMATS = [
    ("obj", "obj", {}),
    ("off", "off", {}),
    ("ply-ascii", "ply", {"ply_encoding": "ascii"}),
    ("ply-le", "ply", {"ply_encoding": "binary_little_endian"}),
    ("ply-be", "ply", {"ply_encoding": "binary_big_endian"}),
]
STL_FORMATS = [
    ("stl-binary", "stl", {"stl_binary": True}),
    ("stl-ascii", "stl", {"stl_binary": False}),
]
PLY_ENCODINGS = ["ascii", "binary_little_endian", "binary_big_endian"]


def bits(a: np.ndarray) -> np.ndarray:
    """The bit patterns of a float64 array (tells -0.0 from 0.0)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def fresh(tmp_path_factory: pytest.TempPathFactory, name: str) -> Path:
    """A new empty folder per hypothesis example, under pytest's temporary root."""
    return tmp_path_factory.mktemp("io") / name


def round_trip(tmp_path_factory: pytest.TempPathFactory, mesh: sp.Mesh, ext: str,
               **kwargs: Any) -> sp.Mesh:
    path = fresh(tmp_path_factory, f"mesh.{ext}")
    sp.save(mesh, path, **kwargs)
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name], "temporary file left behind"
    return sp.load(path)


def assert_exact(loaded: sp.Mesh, V: np.ndarray, F: np.ndarray) -> None:
    assert loaded.vertices.dtype == np.float64 and loaded.faces.dtype == np.int64
    assert np.array_equal(bits(loaded.vertices), bits(V))
    assert np.array_equal(loaded.faces, F)


def assert_welded_equal(loaded: sp.Mesh, V32: np.ndarray, F: np.ndarray) -> None:
    """STL stores a soup of float32 corners; reading welds equal corners in order
    of first appearance. The vertices come back as a permutation, the faces (in
    order, corners in order) the same after mapping through it."""
    original = {tuple(row): i for i, row in enumerate((V32 + 0.0).tolist())}
    assert len(original) == len(V32), "test setup: float32 positions must be distinct"
    assert loaded.n_vertices == len(V32)
    to_original = np.array([original[tuple(row)] for row in loaded.vertices.tolist()])
    assert np.array_equal(to_original[loaded.faces], F)
    assert any("weld" in note.lower() for note in loaded.notes), loaded.notes


# --------------------------------------------------------------------------
# Random meshes
# --------------------------------------------------------------------------

@pytest.mark.parametrize("fid, ext, kwargs", EXACT_FORMATS, ids=[f[0] for f in EXACT_FORMATS])
@given(s=mg.surfaces())
def test_round_trip_is_exact(tmp_path_factory, fid: str, ext: str, kwargs: Dict[str, Any],
                             s: mg.Surface) -> None:
    loaded = round_trip(tmp_path_factory, sp.Mesh(s.V, s.F), ext, **kwargs)
    assert_exact(loaded, s.V, s.F)
    assert loaded.notes == [] and loaded.attributes == {}
    assert sp.check(loaded).valid


@pytest.mark.parametrize("fid, ext, kwargs", STL_FORMATS, ids=[f[0] for f in STL_FORMATS])
@given(s=mg.surfaces())
def test_stl_round_trip_is_exact_in_single_precision(tmp_path_factory, fid: str, ext: str,
                                                     kwargs: Dict[str, Any], s: mg.Surface) -> None:
    V32 = s.V.astype(np.float32).astype(np.float64)
    loaded = round_trip(tmp_path_factory, sp.Mesh(V32, s.F), ext, **kwargs)
    assert_welded_equal(loaded, V32, s.F)
    assert sp.check(loaded).is_sphere_topology


@pytest.mark.parametrize("encoding", PLY_ENCODINGS)
@given(s=mg.surfaces(max_vertices=100), data=st.data())
def test_ply_attributes_round_trip(tmp_path_factory, encoding: str, s: mg.Surface,
                                   data: st.DataObject) -> None:
    n = len(s.V)
    finite = st.floats(allow_nan=False, allow_infinity=False)
    sphere = data.draw(hnp.arrays(np.float64, (n, 3), elements=finite), label="sphere")
    uv = data.draw(hnp.arrays(np.float64, (n, 2), elements=finite), label="uv")
    which = data.draw(st.sampled_from(["sphere", "uv", "both"]), label="which")
    kwargs = {"sphere": sphere if which != "uv" else None, "uv": uv if which != "sphere" else None}
    loaded = round_trip(tmp_path_factory, sp.Mesh(s.V, s.F), "ply", ply_encoding=encoding, **kwargs)
    assert_exact(loaded, s.V, s.F)
    expected = {k: v for k, v in kwargs.items() if v is not None}
    assert loaded.attributes.keys() == expected.keys()
    for key, value in expected.items():
        assert np.array_equal(bits(loaded.attributes[key]), bits(value)), key


@given(s=mg.surfaces(max_vertices=100),
       uv=st.integers(0, 2**32 - 1).map(lambda seed: np.random.default_rng(seed).random((300, 2))))
def test_obj_uv_round_trips(tmp_path_factory, s: mg.Surface, uv: np.ndarray) -> None:
    uv = uv[: len(s.V)]
    loaded = round_trip(tmp_path_factory, sp.Mesh(s.V, s.F), "obj", uv=uv)
    assert_exact(loaded, s.V, s.F)
    assert np.array_equal(bits(loaded.attributes["uv"]), bits(uv))


# --------------------------------------------------------------------------
# Awkward coordinates: extremes, subnormals, negative zero
# --------------------------------------------------------------------------

FINITE64 = st.floats(allow_nan=False, allow_infinity=False)
FINITE32 = st.floats(allow_nan=False, allow_infinity=False, width=32)


@pytest.mark.parametrize("fid, ext, kwargs", EXACT_FORMATS, ids=[f[0] for f in EXACT_FORMATS])
@given(V=hnp.arrays(np.float64, (4, 3), elements=FINITE64))
def test_any_finite_double_round_trips_bit_for_bit(tmp_path_factory, fid: str, ext: str,
                                                   kwargs: Dict[str, Any], V: np.ndarray) -> None:
    loaded = round_trip(tmp_path_factory, sp.Mesh(V, mg.TETRA_F), ext, **kwargs)
    assert_exact(loaded, V, mg.TETRA_F)


@pytest.mark.parametrize("fid, ext, kwargs", STL_FORMATS, ids=[f[0] for f in STL_FORMATS])
@given(V=hnp.arrays(np.float32, (4, 3), elements=FINITE32, unique=True))
def test_any_finite_single_round_trips_through_stl(tmp_path_factory, fid: str, ext: str,
                                                   kwargs: Dict[str, Any], V: np.ndarray) -> None:
    V64 = V.astype(np.float64)
    loaded = round_trip(tmp_path_factory, sp.Mesh(V64, mg.TETRA_F), ext, **kwargs)
    assert_welded_equal(loaded, V64, mg.TETRA_F)
    assert not np.signbit(loaded.vertices[loaded.vertices == 0]).any(), "-0.0 is welded to 0.0"


# --------------------------------------------------------------------------
# What the files say about themselves
# --------------------------------------------------------------------------

@pytest.mark.parametrize("encoding", PLY_ENCODINGS)
def test_ply_header_declares_the_requested_encoding(tmp_path: Path, encoding: str) -> None:
    path = tmp_path / "t.ply"
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F), path, ply_encoding=encoding)
    head = path.read_bytes().split(b"end_header", 1)[0].decode("ascii").splitlines()
    assert head[0] == "ply"
    assert f"format {encoding} 1.0" in head
    assert "element vertex 4" in head and "element face 4" in head


def test_default_ply_encoding_is_binary_little_endian(tmp_path: Path) -> None:
    path = tmp_path / "t.ply"
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F), path)
    assert b"format binary_little_endian 1.0" in path.read_bytes()[:200]


@pytest.mark.parametrize("binary", [True, False])
def test_stl_encoding(tmp_path: Path, binary: bool) -> None:
    path = tmp_path / "t.stl"
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F), path, stl_binary=binary)
    data = path.read_bytes()
    if binary:
        assert len(data) == 84 + 50 * 4
        assert int.from_bytes(data[80:84], "little") == 4
    else:
        assert data.lstrip().startswith(b"solid") and data.count(b"facet normal") == 4


def test_extension_is_case_insensitive_and_str_paths_work(tmp_path: Path) -> None:
    path = tmp_path / "UPPER.OBJ"
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F), str(path))
    assert_exact(sp.load(str(path)), mg.TETRA_V, mg.TETRA_F)


def test_loaded_arrays_are_read_only(tmp_path: Path) -> None:
    path = tmp_path / "t.off"
    sp.save(sp.Mesh(mg.TETRA_V, mg.TETRA_F), path)
    mesh = sp.load(path)
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 1.0
    with pytest.raises(ValueError):
        mesh.faces[0, 0] = 1
    assert (mesh.n_vertices, mesh.n_faces) == (4, 4)


def test_mesh_copies_its_input() -> None:
    V, F = mg.TETRA_V.copy(), mg.TETRA_F.copy()
    mesh = sp.Mesh(V, F)
    V[0, 0], F[0, 0] = 99.0, 3
    assert mesh.vertices[0, 0] == 0.0 and mesh.faces[0, 0] == 0


def test_mesh_accepts_any_numeric_dtype() -> None:
    for vdtype in (np.float32, np.int16, np.uint8, np.float64):
        for fdtype in (np.int8, np.uint16, np.int32, np.uint64, np.int64):
            mesh = sp.Mesh(mg.TETRA_V.astype(vdtype), mg.TETRA_F.astype(fdtype))
            assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
            assert np.array_equal(mesh.vertices, mg.TETRA_V)
            assert np.array_equal(mesh.faces, mg.TETRA_F)
    # Non-contiguous views are fine too.
    wide = np.zeros((4, 6))
    wide[:, ::2] = mg.TETRA_V
    assert np.array_equal(sp.Mesh(wide[:, ::2], mg.TETRA_F.T.copy().T).vertices, mg.TETRA_V)
