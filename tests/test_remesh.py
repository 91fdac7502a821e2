"""Remeshing through the sphere map (thesis 8.1) and octahedral geometry
images (Praun and Hoppe 2003; 8.2's compression)."""

from __future__ import annotations

import struct
import tracemalloc
import zlib
from pathlib import Path
from typing import Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp
from spherify._geometry_image import octahedral_points


@pytest.fixture(scope="module")
def blob_map() -> sp.SphereMap:
    return sp.embed(sp.datasets.bumpy_blob(2000))


def test_the_remesh_is_a_valid_genus_zero_mesh_on_the_surface(blob_map: sp.SphereMap) -> None:
    for level in (0, 2, 4):
        r = sp.remesh(blob_map, "icosphere", level=level)
        ico = sp.datasets.icosphere(subdivisions=level)
        assert r.n_vertices == ico.n_vertices and np.array_equal(r.faces, ico.faces)
        report = sp.check(r)
        assert report.valid and report.genus == 0, report
        # Every vertex lies on the input surface: at h^-1 of the icosphere vertex.
        _, _, xyz = blob_map.to_surface(ico.vertices)
        np.testing.assert_array_equal(r.vertices, xyz)


def test_the_distance_to_the_surface_shrinks_as_the_level_grows(blob_map: sp.SphereMap) -> None:
    d = [sp.surface_distance(blob_map, sp.remesh_map(blob_map, level=k), samples=5000)
         for k in range(1, 6)]
    maxima = [x["max"] for x in d]
    rms = [x["rms"] for x in d]
    assert all(a > b for a, b in zip(maxima, maxima[1:])), maxima
    assert all(a > 2 * b for a, b in zip(rms, rms[1:])), rms  # about 3x per level
    assert maxima[-1] < 0.02


def test_the_distance_of_a_surface_to_itself_is_zero_and_is_symmetric(
        blob_map: sp.SphereMap) -> None:
    assert sp.surface_distance(blob_map, blob_map, samples=1000)["max"] == 0.0
    r = sp.remesh_map(blob_map, level=3)
    a, b = sp.surface_distance(blob_map, r, seed=3), sp.surface_distance(r, blob_map, seed=3)
    assert a["max"] * a["diagonal"] == pytest.approx(b["max"] * b["diagonal"], rel=1e-12)


def test_an_uncertified_map_cannot_be_remeshed() -> None:
    ico = sp.datasets.icosphere(subdivisions=2)
    points = ico.vertices.copy()
    points[0] = -points[0]
    m = sp.SphereMap.from_points(ico, points)
    with pytest.raises(sp.MapError):
        sp.remesh(m, level=2)
    with pytest.raises(sp.MapError):
        sp.geometry_image(m, 9)


@pytest.mark.parametrize("kwargs, match", [
    ({"kind": "quads"}, "unknown remesh kind 'quads'"),
    ({"level": 10}, "level must be an integer in 0..9"),
    ({"level": -1}, "level must be"),
    ({"level": 2.0}, "level must be"),
])
def test_bad_remesh_arguments(blob_map: sp.SphereMap, kwargs, match: str) -> None:
    with pytest.raises(sp.MeshError, match=match):
        sp.remesh(blob_map, **kwargs)


@given(k=st.integers(1, 6))
def test_octahedral_images_of_any_odd_size_read_back_as_genus_zero(k: int) -> None:
    n = 2 * k + 1
    sphere = sp.from_geometry_image(octahedral_points(n))
    report = sp.check(sphere)
    assert report.valid and report.genus == 0
    assert sphere.n_vertices == n * n - 2 * n + 3 and sphere.n_faces == 2 * (n - 1) ** 2
    # Its own vertices are a valid sphere map: no triangle crosses an octahedron edge.
    assert sp.SphereMap.from_points(sphere, sphere.vertices).valid


def test_a_geometry_image_reads_back_as_a_closed_surface_near_the_input(
        blob_map: sp.SphereMap) -> None:
    errors = []
    for n in (17, 33, 65):
        g = sp.geometry_image(blob_map, n)
        assert g.shape == (n, n, 3)
        mesh = sp.from_geometry_image(g)
        assert sp.check(mesh).valid and sp.check(mesh).genus == 0
        own = sp.SphereMap.from_points(mesh, sp.from_geometry_image(octahedral_points(n)).vertices)
        assert own.valid
        errors.append(sp.surface_distance(blob_map, own, samples=3000)["max"])
    assert errors[0] > errors[1] > errors[2], errors


def test_sixteen_bit_png_round_trip(blob_map: sp.SphereMap, tmp_path: Path) -> None:
    g = sp.geometry_image(blob_map, 33)
    path = tmp_path / "g.png"
    size = sp.save_geometry_image(g, path)
    assert size == path.stat().st_size and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    back = sp.load_geometry_image(path)
    span = np.ptp(g.reshape(-1, 3), axis=0)
    # Quantised to 65536 levels across the bounding box.
    assert np.all(np.abs(back - g) <= span / 65535 * 0.5 + 1e-12)
    assert sp.check(sp.from_geometry_image(back)).genus == 0
    assert [p.name for p in tmp_path.iterdir()] == ["g.png"]


def test_bad_images_and_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(sp.MeshError, match="odd"):
        sp.from_geometry_image(np.zeros((4, 4, 3)))
    with pytest.raises(sp.MeshError, match="shape"):
        sp.from_geometry_image(np.zeros((5, 4, 3)))
    with pytest.raises(sp.MeshError, match="finite"):
        sp.from_geometry_image(np.full((5, 5, 3), np.nan))
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(sp.FormatError, match="not a PNG"):
        sp.load_geometry_image(bad)
    good = tmp_path / "good.png"
    sp.save_geometry_image(octahedral_points(5), good)
    data = bytearray(good.read_bytes())
    data[-20] ^= 0xFF
    bad.write_bytes(bytes(data))
    with pytest.raises(sp.FormatError, match="CRC"):
        sp.load_geometry_image(bad)


def png(*chunks: Tuple[bytes, bytes]) -> bytes:
    """A PNG of the given (kind, body) chunks, each with its right CRC."""
    return b"\x89PNG\r\n\x1a\n" + b"".join(
        struct.pack(">I", len(body)) + kind + body
        + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF) for kind, body in chunks)


def test_crafted_geometry_images_with_right_crcs_are_refused(tmp_path: Path) -> None:
    # Chunks whose CRCs hold but whose content does not: each once gave
    # something other than a FormatError (struct.error; a 300 MB inflation
    # before the size check; an image of NaN).
    header = (b"IHDR", struct.pack(">IIBBBBB", 5, 5, 16, 2, 0, 0, 0))
    box = (b"tEXt", b"spherify-bbox\x000 0 0 1 1 1")
    rows = (b"IDAT", zlib.compress(b"\x00" * (5 * 31)))
    end = (b"IEND", b"")
    bad = tmp_path / "bad.png"
    bad.write_bytes(png(*[header, box, rows, end]))
    assert sp.load_geometry_image(bad).shape == (5, 5, 3)  # the crafted good one reads
    cases = {
        "an IHDR chunk of 12 bytes": [(b"IHDR", bytes(12)), box, rows, end],
        # 30 MB of zeros in 30 kB: inflated no further than the 155 bytes
        # the header promises, plus one
        "does not match the header": [header, box, (b"IDAT", zlib.compress(bytes(30_000_000))),
                                      end],
        "not finite": [header, (b"tEXt", b"spherify-bbox\x00nan 0 0 inf 1 1"), rows, end],
    }
    for match, chunks in cases.items():
        bad.write_bytes(png(*chunks))
        tracemalloc.start()
        with pytest.raises(sp.FormatError, match=match):
            sp.load_geometry_image(bad)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 5_000_000, (match, peak)
