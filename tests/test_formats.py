"""The formats read and written in Python: .npz / .npy pairs, FreeSurfer
surfaces and GIfTI (through nibabel); other libraries' meshes are in test_interop.py."""

from __future__ import annotations

import io
import struct
import sys
import types
from pathlib import Path
from typing import Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp
from spherify import cli
from spherify import _formats


def blob() -> sp.Mesh:
    return sp.datasets.make("bumpy_blob", 300)


def float32(a: np.ndarray) -> np.ndarray:
    return a.astype(np.float32).astype(np.float64)


def only_file(folder: Path) -> None:
    """Nothing but the final files: no temporary left behind."""
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]


def test_npz_round_trip_is_exact_with_attributes(tmp_path: Path) -> None:
    mesh = blob()
    rng = np.random.default_rng(0)
    sphere, uv = rng.normal(size=(mesh.n_vertices, 3)), rng.random((mesh.n_vertices, 2))
    sp.save(mesh, tmp_path / "m.npz", sphere=sphere, uv=uv)
    loaded = sp.load(tmp_path / "m.npz")
    assert np.array_equal(loaded.vertices, mesh.vertices)
    assert np.array_equal(loaded.faces, mesh.faces)
    assert np.array_equal(loaded.attributes["sphere"], sphere)
    assert np.array_equal(loaded.attributes["uv"], uv)
    with np.load(tmp_path / "m.npz") as arrays:
        assert arrays["V"].dtype == np.float64 and arrays["F"].dtype == np.int64
    only_file(tmp_path)


def test_npz_with_long_names_and_npy_pair(tmp_path: Path) -> None:
    mesh = blob()
    np.savez(tmp_path / "long.npz", vertices=mesh.vertices.astype(np.float32),
             faces=mesh.faces.astype(np.uint32))
    loaded = sp.load(tmp_path / "long.npz")
    assert np.array_equal(loaded.vertices, float32(mesh.vertices))
    assert np.array_equal(loaded.faces, mesh.faces)
    np.save(tmp_path / "V.npy", mesh.vertices)
    np.save(tmp_path / "F.npy", mesh.faces.astype(np.int32))
    pair = sp.load((tmp_path / "V.npy", tmp_path / "F.npy"))
    assert np.array_equal(pair.vertices, mesh.vertices) and np.array_equal(pair.faces, mesh.faces)


def test_bad_npz_files_name_the_file(tmp_path: Path) -> None:
    mesh = blob()
    cases = {
        "text.npz": lambda p: p.write_text("not a zip"),
        "nokeys.npz": lambda p: np.savez(p, X=mesh.vertices),
        "pickled.npz": lambda p: np.savez(p, V=np.array([object()], dtype=object), F=mesh.faces),
        "range.npz": lambda p: np.savez(p, V=mesh.vertices, F=mesh.faces + mesh.n_vertices),
        "shape.npz": lambda p: np.savez(p, V=mesh.vertices[:, :2], F=mesh.faces),
        "attr.npz": lambda p: np.savez(p, V=mesh.vertices, F=mesh.faces, uv=np.zeros((3, 2))),
    }
    for name, make in cases.items():
        path = tmp_path / name
        make(path)
        with pytest.raises(sp.FormatError) as info:
            sp.load(path)
        assert info.value.path == str(path) and str(path) in str(info.value), name
    with pytest.raises(sp.FormatError, match="one array"):
        sp.load(tmp_path / "V.npy")
    with pytest.raises(FileNotFoundError):
        sp.load(tmp_path / "missing.npz")


def damage_zip(data: bytes, local: Tuple[int, int], central: Tuple[int, int]) -> bytes:
    """``data`` (a zip archive) with the 16-bit field at byte ``local[0]`` of
    every local file header set to ``local[1]``, and likewise ``central`` in
    every central directory entry."""
    out = bytearray(data)
    for signature, (offset, value) in ((b"PK\x03\x04", local), (b"PK\x01\x02", central)):
        at = out.find(signature)
        while at >= 0:
            struct.pack_into("<H", out, at + offset, value)
            at = out.find(signature, at + 4)
    return bytes(out)


#: Header fields a damaged .npz can hold, and what zipfile then raised
#: before the readers caught it (found by mutating files, 2026-12-02).
DAMAGED_ZIPS = {
    "version": ((4, 0x70), (6, 0x70)),  # NotImplementedError: zip file version 11.2
    "method": ((8, 99), (10, 99)),  # NotImplementedError: compression method
    "bzip2": ((8, 12), (10, 12)),  # OSError without errno: was a FileError
    "encrypted": ((6, 1), (8, 1)),  # RuntimeError: password required
}


@pytest.mark.parametrize("damage", sorted(DAMAGED_ZIPS))
def test_a_damaged_zip_header_is_a_format_error_naming_the_file(tmp_path: Path,
                                                               damage: str) -> None:
    mesh = blob()
    good, bad = tmp_path / "good.npz", tmp_path / "bad.npz"
    sp.save(mesh, good)
    bad.write_bytes(damage_zip(good.read_bytes(), *DAMAGED_ZIPS[damage]))
    with pytest.raises(sp.FormatError) as info:
        sp.load(bad)
    assert info.value.path == str(bad) and "not a readable .npz archive" in str(info.value)
    good_map, bad_map = tmp_path / "good.spheremap.npz", tmp_path / "bad.spheremap.npz"
    sp.embed(mesh).save(good_map)
    bad_map.write_bytes(damage_zip(good_map.read_bytes(), *DAMAGED_ZIPS[damage]))
    with pytest.raises(sp.FormatError) as info:
        sp.load_map(bad_map)
    assert info.value.path == str(bad_map) and "unreadable sphere map" in str(info.value)


def test_an_npy_array_with_a_zip_end_record_is_not_an_npz(tmp_path: Path) -> None:
    # zipfile.is_zipfile reads the end of a file, np.load its start: this
    # passed the one and came back from the other as an array (TypeError).
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((3, 3)))
    data = buffer.getvalue() + b"PK\x05\x06" + bytes(18)
    for name, read in (("a.npz", sp.load), ("a.spheremap.npz", sp.load_map)):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(sp.FormatError, match="zip"):
            read(tmp_path / name)


@pytest.mark.parametrize("name", ["lh.pial", "rh.white", "lh.sphere", "lh.sphere.reg", "x.inflated"])
def test_freesurfer_round_trip_by_name(tmp_path: Path, name: str) -> None:
    pytest.importorskip("nibabel")
    mesh = blob()
    path = tmp_path / name
    sp.save(mesh, path)
    assert path.read_bytes()[:3] == _formats.FREESURFER_TRIANGLE_MAGIC
    loaded = sp.load(path)
    assert np.array_equal(loaded.vertices, float32(mesh.vertices))
    assert np.array_equal(loaded.faces, mesh.faces)
    only_file(tmp_path)


def test_freesurfer_is_recognised_by_its_magic_under_any_name(tmp_path: Path) -> None:
    pytest.importorskip("nibabel")
    mesh = blob()
    path = tmp_path / "surface_without_a_known_name"
    with pytest.raises(sp.FormatError, match="format="):
        sp.save(mesh, path)
    sp.save(mesh, path, format="freesurfer")
    assert np.array_equal(sp.load(path).faces, mesh.faces)
    # Deterministic bytes: the header stamp is fixed.
    sp.save(mesh, tmp_path / "again.pial")
    assert (tmp_path / "again.pial").read_bytes() == path.read_bytes()


def test_gifti_round_trip(tmp_path: Path) -> None:
    pytest.importorskip("nibabel")
    mesh = blob()
    for name in ("lh.pial.surf.gii", "plain.gii"):
        sp.save(mesh, tmp_path / name)
        loaded = sp.load(tmp_path / name)
        assert np.array_equal(loaded.vertices, float32(mesh.vertices))
        assert np.array_equal(loaded.faces, mesh.faces)
    only_file(tmp_path)


@given(cut=st.integers(min_value=0, max_value=2000))
def test_truncated_freesurfer_file_is_a_format_error(tmp_path_factory: pytest.TempPathFactory,
                                                     cut: int) -> None:
    pytest.importorskip("nibabel")
    folder = tmp_path_factory.mktemp("fs")
    whole = folder / "lh.white"
    sp.save(sp.datasets.make("icosphere", 100), whole)
    data = whole.read_bytes()
    # Keep at least the magic number so that the file is taken for FreeSurfer.
    short = folder / "lh.short"
    short.write_bytes(data[:3 + cut % (len(data) - 3)])
    with pytest.raises(sp.FormatError) as info:
        sp.load(short)
    assert info.value.path == str(short)


def test_garbled_gifti_and_unknown_files(tmp_path: Path) -> None:
    pytest.importorskip("nibabel")
    (tmp_path / "bad.surf.gii").write_text("<?xml version='1.0'?><GIFTI")
    (tmp_path / "empty.gii").write_text(
        "<?xml version='1.0'?><GIFTI Version='1.0' NumberOfDataArrays='0'></GIFTI>")
    (tmp_path / "notes.txt").write_text("hello")
    for name, match in [("bad.surf.gii", "GIfTI"), ("empty.gii", "POINTSET"),
                        ("notes.txt", "not a mesh file")]:
        with pytest.raises(sp.FormatError, match=match) as info:
            sp.load(tmp_path / name)
        assert info.value.path == str(tmp_path / name)


def test_without_nibabel_the_error_names_the_file_and_the_extra(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("nibabel")
    mesh = blob()
    sp.save(mesh, tmp_path / "lh.pial")
    for name in [n for n in sys.modules if n == "nibabel" or n.startswith("nibabel.")]:
        monkeypatch.setitem(sys.modules, name, None)  # importing it now raises ImportError
    for call, path in [(lambda p: sp.load(p), tmp_path / "lh.pial"),
                       (lambda p: sp.save(mesh, p), tmp_path / "lh.white"),
                       (lambda p: sp.save(mesh, p), tmp_path / "x.surf.gii")]:
        with pytest.raises(sp.FormatError, match=r"spherify\[neuro\]") as info:
            call(path)
        assert info.value.path == str(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lh.pial"]


def test_sphere_attribute_refused_where_the_format_has_none(tmp_path: Path) -> None:
    pytest.importorskip("nibabel")
    mesh = blob()
    with pytest.raises(sp.MeshError, match="per-vertex"):
        sp.save(mesh, tmp_path / "lh.sphere", sphere=mesh.vertices)
    with pytest.raises(sp.MeshError, match="format must be"):
        sp.save(mesh, tmp_path / "x.obj", format="vtk")
    assert list(tmp_path.iterdir()) == []


def test_mesh_from_an_object_with_vertices_and_faces() -> None:
    mesh = blob()
    duck = types.SimpleNamespace(vertices=mesh.vertices.tolist(), faces=mesh.faces.astype(np.int32))
    for made in (sp.Mesh(duck), sp.check(duck), sp.embed(duck, "radial").mesh):
        if isinstance(made, sp.Mesh):
            assert np.array_equal(made.vertices, mesh.vertices)
            assert np.array_equal(made.faces, mesh.faces)
        else:
            assert made.valid
    with pytest.raises(sp.MeshError, match="vertices"):
        sp.Mesh(np.zeros((4, 3)))


def test_cli_maps_a_freesurfer_surface_to_a_radius_100_sphere(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("nibabel")
    pial, sphere = tmp_path / "lh.pial", tmp_path / "lh.sphere"
    sp.save(sp.datasets.make("bumpy_blob", 800), pial)
    assert cli.main(["map", str(pial), "-o", str(sphere)]) == 0
    out = capsys.readouterr().out
    assert "radius 100" in out and "a valid GC-embedding" in out
    loaded, source = sp.load(sphere), sp.load(pial)
    assert np.array_equal(loaded.faces, source.faces)
    norms = np.linalg.norm(loaded.vertices, axis=1)
    assert np.all(np.abs(norms - 100.0) < 1e-4)
    # The stored sphere, scaled back, is certified by the exact test.
    assert sp.check_sphere(loaded, loaded.vertices / 100.0).valid


@pytest.mark.corpus
def test_fsaverage_cortex_through_freesurfer(shared_meshes: Path, tmp_path: Path) -> None:
    pytest.importorskip("nibabel")
    cortex = sp.load(shared_meshes / "cortex_fsaverage5_lh_pial.obj")
    sp.save(cortex, tmp_path / "lh.pial")
    loaded = sp.load(tmp_path / "lh.pial")
    assert np.array_equal(loaded.faces, cortex.faces)
    assert np.array_equal(loaded.vertices, float32(cortex.vertices))
    assert sp.check(loaded).is_sphere_topology
