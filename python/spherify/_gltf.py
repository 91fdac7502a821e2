"""glTF 2.0 binary (``.glb``) export of a mesh with its sphere map and texture
(issue 24, item 8): ``sp.save(mesh, "out.glb", sphere=m.points, uv=layout,
texture=image)``.

One file for glTF viewers and engines (read back here by pygltflib, trimesh
and VTK's glTF importer): a scene with one node and one triangle primitive
whose attributes are

* ``POSITION`` (float32) and ``NORMAL`` (float32, area-weighted vertex
  normals, unit length),
* ``TEXCOORD_0`` (float32), with ``uv`` per vertex (n, 2) or per face corner
  (m, 3, 2), a :class:`~spherify.texture.UVLayout`; glTF's v runs downwards
  from the image's top, so v is written as 1 - v,
* ``_SPHERE`` (float32 VEC3), with ``sphere``: the map's point of each vertex
  (an application-specific attribute: glTF names those with a leading
  underscore; viewers ignore it, code reads it back),

and ``indices`` (uint32). With ``texture`` (an (h, w, 3) RGB image in [0, 1],
or the path of a PNG or JPEG file), the image is stored in the binary chunk
and the primitive gets a material whose base colour is that texture.

A vertex with corner UVs that differ between its faces (a seam of the
atlas) is written once per distinct UV, as every glTF exporter does (glTF
has no per-corner attributes): vertices keep their order, and the copies
follow them. glTF stores float32: the certificate is of the float64 points,
not of their float32 copies (``sp.load_map`` of the ``.spheremap.npz`` is
the map to trust). The file is assembled in memory and written atomically by
the core's writer (:func:`spherify._atomic.write_bytes_atomically`).

The writer is here, about a hundred lines of numpy and ``struct`` (the
format is a JSON chunk and a binary chunk), rather than through a glTF
library: spherify keeps numpy as its only dependency, and the tests read
every file back with ``pygltflib`` (a maintained glTF library) as well as
with their own parser of the two chunks.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._atomic import write_bytes_atomically
from ._errors import FormatError, MeshError

GLB_MAGIC = b"glTF"
JSON_CHUNK = 0x4E4F534A
BIN_CHUNK = 0x004E4942
FLOAT, UNSIGNED_INT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
TRIANGLES = 4
#: The name of the sphere points' attribute.
SPHERE_ATTRIBUTE = "_SPHERE"
_IMAGE_TYPES = {b"\x89PNG\r\n\x1a\n": "image/png", b"\xff\xd8\xff": "image/jpeg"}


def is_glb(path: Path, format: Optional[str]) -> bool:
    """Whether ``sp.save`` writes glTF: ``format="glb"`` or a ``.glb`` name."""
    return format == "glb" or (format is None and path.suffix.lower() == ".glb")


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals per vertex, each the sum of its faces' cross products
    (area-weighted); a vertex whose sum vanishes gets (0, 0, 1)."""
    v = vertices[faces]
    cross = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, faces[:, k], cross)
    length = np.linalg.norm(normals, axis=1)
    flat = ~(length > 0)
    normals[flat] = (0.0, 0.0, 1.0)
    length[flat] = 1.0
    unit: np.ndarray = normals / length[:, None]
    return unit


def split_seams(n: int, faces: np.ndarray,
                corner_uv: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices for per-corner UVs: one per distinct (vertex, u, v), the
    first copy of each vertex keeping its index (so vertices with one UV stay
    where they are). Returns (source vertex of each glTF vertex, its uv, the
    faces in glTF vertices). ``n`` is the mesh's vertex count."""
    ids = faces.reshape(-1)
    uv = corner_uv.reshape(-1, 2)
    bits = np.ascontiguousarray(uv).view(np.int64)
    keys = np.column_stack([ids, bits])
    unique, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    source = unique[:, 0]
    # the first distinct UV of each vertex keeps the vertex's own index
    order = np.lexsort((first, source))
    is_first = np.ones(len(order), dtype=bool)
    is_first[1:] = source[order][1:] != source[order][:-1]
    index = np.empty(len(unique), dtype=np.int64)
    index[order[is_first]] = source[order[is_first]]
    copies = order[~is_first]
    index[copies] = n + np.arange(len(copies))
    sources = np.concatenate([np.arange(n), np.zeros(len(copies), dtype=np.int64)])
    uvs = np.zeros((n + len(copies), 2))
    sources[index] = source
    uvs[index] = uv[first]
    return sources, uvs, index[inverse].reshape(-1, 3)


def _image(texture: Any, png_bytes: Any) -> Tuple[bytes, str]:
    """The image's bytes and MIME type: an array encoded as PNG, or a PNG or
    JPEG file's bytes."""
    if isinstance(texture, (str, os.PathLike)):
        data = Path(texture).read_bytes()
        for magic, mime in _IMAGE_TYPES.items():
            if data.startswith(magic):
                return data, mime
        raise FormatError(f"{os.fspath(texture)}: a glTF texture must be a PNG or JPEG file",
                          os.fspath(texture))
    return png_bytes(texture), "image/png"


class _Buffer:
    """The binary chunk being assembled, and the JSON's views and accessors."""

    def __init__(self) -> None:
        self.parts: List[bytes] = []
        self.length = 0
        self.views: List[Dict[str, Any]] = []
        self.accessors: List[Dict[str, Any]] = []

    def view(self, data: bytes, target: Optional[int] = None) -> int:
        view: Dict[str, Any] = {"buffer": 0, "byteOffset": self.length, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        padded = data + b"\x00" * (-len(data) % 4)
        self.parts.append(padded)
        self.length += len(padded)
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, array: np.ndarray, kind: str, target: int,
                 bounds: bool = False) -> int:
        """An accessor of ``array`` in a view of its own; ``bounds``: its
        per-component min and max (which glTF requires of POSITION)."""
        component = UNSIGNED_INT if array.dtype == np.uint32 else FLOAT
        flat = array.reshape(len(array), -1)
        accessor: Dict[str, Any] = {
            "bufferView": self.view(np.ascontiguousarray(array).tobytes(), target),
            "componentType": component, "count": int(array.size if kind == "SCALAR"
                                                     else len(array)), "type": kind}
        if bounds:
            accessor["min"] = [float(x) for x in flat.min(axis=0)]
            accessor["max"] = [float(x) for x in flat.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def glb_bytes(vertices: np.ndarray, faces: np.ndarray, *, sphere: Optional[np.ndarray],
              uv: Optional[np.ndarray], image: Optional[Tuple[bytes, str]],
              generator: str) -> bytes:
    """The ``.glb`` file of a mesh: ``uv`` per vertex (n, 2) or per corner
    (m, 3, 2), ``image`` the texture's (bytes, MIME type)."""
    normals = vertex_normals(vertices, faces)
    if uv is not None and uv.ndim == 3:
        sources, uv, faces = split_seams(len(vertices), faces, uv)
        vertices, normals = vertices[sources], normals[sources]
        sphere = None if sphere is None else sphere[sources]
    buffer = _Buffer()
    attributes = {
        "POSITION": buffer.accessor(vertices.astype(np.float32), "VEC3", ARRAY_BUFFER, True),
        "NORMAL": buffer.accessor(normals.astype(np.float32), "VEC3", ARRAY_BUFFER)}
    if uv is not None:
        flipped = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)
        attributes["TEXCOORD_0"] = buffer.accessor(flipped, "VEC2", ARRAY_BUFFER)
    if sphere is not None:
        attributes[SPHERE_ATTRIBUTE] = buffer.accessor(sphere.astype(np.float32), "VEC3",
                                                       ARRAY_BUFFER)
    primitive: Dict[str, Any] = {
        "attributes": attributes, "mode": TRIANGLES,
        "indices": buffer.accessor(faces.reshape(-1).astype(np.uint32), "SCALAR",
                                   ELEMENT_ARRAY_BUFFER)}
    document: Dict[str, Any] = {"asset": {"version": "2.0", "generator": generator},
                                "scene": 0, "scenes": [{"nodes": [0]}],
                                "nodes": [{"mesh": 0, "name": "spherify"}]}
    if image is not None:
        document["images"] = [{"bufferView": buffer.view(image[0]), "mimeType": image[1]}]
        document["samplers"] = [{"magFilter": 9729, "minFilter": 9729,
                                 "wrapS": 33071, "wrapT": 33071}]
        document["textures"] = [{"source": 0, "sampler": 0}]
        document["materials"] = [{"name": "texture", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0}}]
        primitive["material"] = 0
    document["meshes"] = [{"name": "spherify", "primitives": [primitive]}]
    document["accessors"] = buffer.accessors
    document["bufferViews"] = buffer.views
    document["buffers"] = [{"byteLength": buffer.length}]
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary = b"".join(buffer.parts)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (GLB_MAGIC + struct.pack("<II", 2, total)
            + struct.pack("<II", len(text), JSON_CHUNK) + text
            + struct.pack("<II", len(binary), BIN_CHUNK) + binary)


def _array(value: Any, name: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MeshError(f"{name} must be a numeric array: {err}") from None
    if not np.all(np.isfinite(array)):
        raise MeshError(f"{name} holds values that are not finite")
    return array


def save_glb(vertices: np.ndarray, faces: np.ndarray, path: Path, *, sphere: Any, uv: Any,
             texture: Any) -> None:
    """``sp.save`` to a ``.glb``: check the arrays against the mesh, then
    write the file atomically."""
    from . import __version__
    from .texture import UVLayout, png_bytes

    n, m = len(vertices), len(faces)
    sphere_array = None if sphere is None else _array(sphere, "sphere")
    if sphere_array is not None and sphere_array.shape != (n, 3):
        raise MeshError(f"sphere must have shape ({n}, 3), got {sphere_array.shape}")
    uv_array = None if uv is None else _array(uv.uv if isinstance(uv, UVLayout) else uv, "uv")
    if uv_array is not None and uv_array.shape not in ((n, 2), (m, 3, 2)):
        raise MeshError(f"uv must have shape ({m}, 3, 2) (per face corner) or ({n}, 2) (per "
                        f"vertex), got {uv_array.shape}")
    if texture is not None and uv_array is None:
        raise MeshError("a texture needs texture coordinates: pass uv= (sp.texture.uv(m), or "
                        "a per-vertex (n, 2) array)")
    image = None if texture is None else _image(texture, png_bytes)
    data = glb_bytes(vertices, faces, sphere=sphere_array, uv=uv_array, image=image,
                     generator=f"spherify {__version__}")
    write_bytes_atomically(path, data)
