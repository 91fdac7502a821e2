"""glTF 2.0 binary export, ``sp.save(mesh, "x.glb", ...)`` (issue 24, item 8):
every file is read back twice, by the parser below (the GLB header, the JSON
chunk and the binary chunk, as the glTF 2.0 specification lays them out) and,
when it is installed (the ``test`` extra installs it), by pygltflib."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any, Dict, Tuple

import numpy as np
import pytest

import spherify as sp

COMPONENTS = {5126: np.float32, 5125: np.uint32}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}


def read_glb(path: Path) -> Tuple[Dict[str, Any], bytes]:
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    json_length, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A and json_length % 4 == 0
    document = json.loads(data[20:20 + json_length])
    offset = 20 + json_length
    bin_length, bin_type = struct.unpack_from("<II", data, offset)
    assert bin_type == 0x004E4942 and bin_length % 4 == 0
    binary = data[offset + 8:offset + 8 + bin_length]
    assert offset + 8 + bin_length == len(data)
    assert document["buffers"] == [{"byteLength": bin_length}]
    return document, binary


def accessor(document: Dict[str, Any], binary: bytes, index: int) -> np.ndarray:
    acc = document["accessors"][index]
    view = document["bufferViews"][acc["bufferView"]]
    assert view["byteOffset"] % 4 == 0
    dtype = COMPONENTS[acc["componentType"]]
    width = WIDTHS[acc["type"]]
    raw = binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]]
    array = np.frombuffer(raw, dtype=dtype)
    assert array.size == acc["count"] * width
    return array.reshape(acc["count"], width) if width > 1 else array


def primitive(document: Dict[str, Any]) -> Dict[str, Any]:
    (mesh,) = document["meshes"]
    (prim,) = mesh["primitives"]
    assert prim["mode"] == 4
    return prim


def check_with_pygltflib(path: Path, n_vertices: int, n_faces: int) -> None:
    pygltflib = pytest.importorskip("pygltflib")
    gltf = pygltflib.GLTF2().load(str(path))
    prim = gltf.meshes[0].primitives[0]
    assert gltf.accessors[prim.attributes.POSITION].count == n_vertices
    assert gltf.accessors[prim.indices].count == 3 * n_faces
    assert len(gltf.binary_blob()) == gltf.buffers[0].byteLength


def test_a_mesh_with_its_sphere_points(tmp_path: Path) -> None:
    mesh = sp.datasets.make("bumpy_blob", 400)
    m = sp.embed(mesh)
    path = tmp_path / "blob.glb"
    sp.save(mesh, path, sphere=m.points)
    document, binary = read_glb(path)
    assert document["asset"]["version"] == "2.0"
    prim = primitive(document)
    positions = accessor(document, binary, prim["attributes"]["POSITION"])
    assert np.array_equal(positions, mesh.vertices.astype(np.float32))
    acc = document["accessors"][prim["attributes"]["POSITION"]]
    assert np.allclose(acc["min"], positions.min(axis=0)) and np.allclose(acc["max"],
                                                                          positions.max(axis=0))
    faces = accessor(document, binary, prim["indices"]).reshape(-1, 3)
    assert np.array_equal(faces, mesh.faces)
    normals = accessor(document, binary, prim["attributes"]["NORMAL"])
    assert np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-6)
    # outward: a star-shaped blob's normals point away from its centre
    assert (np.einsum("ij,ij->i", normals, mesh.vertices) > 0).mean() > 0.95
    sphere = accessor(document, binary, prim["attributes"]["_SPHERE"])
    assert np.allclose(sphere, m.points, atol=1e-7)
    assert "TEXCOORD_0" not in prim["attributes"] and "materials" not in document
    check_with_pygltflib(path, mesh.n_vertices, mesh.n_faces)


def test_a_textured_map_splits_its_seams(tmp_path: Path) -> None:
    mesh = sp.datasets.make("bumpy_blob", 400)
    m = sp.embed(mesh)
    layout = sp.texture.uv(m, "cube")
    image = layout.bake(sp.datasets.checkerboard, 32)
    path = tmp_path / "textured.glb"
    sp.save(mesh, path, sphere=m.points, uv=layout, texture=image)
    document, binary = read_glb(path)
    prim = primitive(document)
    positions = accessor(document, binary, prim["attributes"]["POSITION"])
    uv = accessor(document, binary, prim["attributes"]["TEXCOORD_0"])
    sphere = accessor(document, binary, prim["attributes"]["_SPHERE"])
    faces = accessor(document, binary, prim["indices"]).reshape(-1, 3).astype(np.int64)
    n = mesh.n_vertices
    assert len(positions) > n  # the atlas's seams
    # the mesh's own vertices keep their place; the copies follow them
    assert np.array_equal(positions[:n], mesh.vertices.astype(np.float32))
    # every corner sees its own vertex and its own UV (glTF's v runs down)
    assert np.array_equal(positions[faces], mesh.vertices[mesh.faces].astype(np.float32))
    assert np.array_equal(sphere[faces], m.points[mesh.faces].astype(np.float32))
    expected = np.stack([layout.uv[..., 0], 1 - layout.uv[..., 1]], axis=-1)
    assert np.array_equal(uv[faces], expected.astype(np.float32))
    # one vertex per distinct (vertex, uv): no copy is needless
    keys = {(int(v), float(a), float(b)) for v, (a, b) in
            zip(mesh.faces.ravel(), layout.uv.reshape(-1, 2))}
    assert len(positions) == len(keys)
    # the texture is the baked image, as a PNG in the binary chunk
    (img,) = document["images"]
    assert img["mimeType"] == "image/png"
    view = document["bufferViews"][img["bufferView"]]
    png = binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]]
    assert png == sp.texture.png_bytes(image)
    material = document["materials"][prim["material"]]
    assert material["pbrMetallicRoughness"]["baseColorTexture"]["index"] == 0
    check_with_pygltflib(path, len(positions), mesh.n_faces)


def test_per_vertex_uv_and_a_texture_file(tmp_path: Path) -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    uv = (mesh.vertices[:, :2] + 1) / 2
    png = tmp_path / "t.png"
    sp.texture.write_png(np.full((4, 4, 3), 0.5), png)
    path = tmp_path / "v.glb"
    sp.save(mesh, path, uv=uv, texture=png)
    document, binary = read_glb(path)
    prim = primitive(document)
    got = accessor(document, binary, prim["attributes"]["TEXCOORD_0"])
    assert len(got) == mesh.n_vertices
    assert np.allclose(got, np.column_stack([uv[:, 0], 1 - uv[:, 1]]))
    view = document["bufferViews"][document["images"][0]["bufferView"]]
    assert binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]] == \
        png.read_bytes()


def test_format_glb_and_atomic_replacement(tmp_path: Path) -> None:
    mesh = sp.datasets.icosphere(subdivisions=0)
    path = tmp_path / "model.bin"
    path.write_bytes(b"old")
    path.chmod(0o640)
    sp.save(mesh, path, format="glb")
    assert path.read_bytes()[:4] == b"glTF"
    assert path.stat().st_mode & 0o777 == 0o640  # the core's writer keeps the mode
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.bin"]  # no temporary left


@pytest.mark.parametrize("kwargs, match", [
    ({"sphere": np.zeros((3, 3))}, r"sphere must have shape \(12, 3\)"),
    ({"uv": np.zeros((5, 2))}, r"uv must have shape"),
    ({"uv": np.full((12, 2), np.nan)}, "not finite"),
    ({"texture": np.zeros((2, 2, 3))}, "needs texture coordinates"),
])
def test_bad_arrays_are_refused_before_anything_is_written(
        tmp_path: Path, kwargs: Dict[str, Any], match: str) -> None:
    path = tmp_path / "x.glb"
    with pytest.raises(sp.MeshError, match=match):
        sp.save(sp.datasets.icosphere(subdivisions=0), path, **kwargs)
    assert not path.exists()


def test_a_texture_file_that_is_no_image_is_refused(tmp_path: Path) -> None:
    mesh = sp.datasets.icosphere(subdivisions=0)
    text = tmp_path / "t.txt"
    text.write_text("not an image")
    with pytest.raises(sp.FormatError, match="PNG or JPEG"):
        sp.save(mesh, tmp_path / "x.glb", uv=np.zeros((12, 2)), texture=text)
