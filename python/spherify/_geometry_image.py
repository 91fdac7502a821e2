"""Octahedral geometry images (Praun and Hoppe 2003; thesis 8.1, 8.2): the
surface resampled on a square grid through its sphere map, an image whose
pixels are surface points, and the closed mesh read back from it.

The square [-1, 1]^2 is the octahedron |x| + |y| + |z| = 1 unfolded: the
inner diamond |u| + |v| <= 1 is the upper half (z = 1 - |u| - |v|, the north
pole at the centre), the four corner triangles fold under it (the south pole
at the corners), and each side of the square is glued to itself at its
midpoint. Octahedron points are projected centrally onto the sphere. An
image of odd size has pixels on every octahedron edge, and the triangles of
the read-back mesh never cross one.

    g = sp.geometry_image(m, 257)               # (257, 257, 3) float64
    mesh = sp.from_geometry_image(g)            # closed genus-0 mesh
    sp.save_geometry_image(g, "g.png")          # 16-bit RGB PNG, bounding box in a text chunk
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path
from typing import Any, Tuple, Union

import numpy as np

from . import _args, _core, _progress
from ._limits import GEOMETRY_IMAGE_SIZE_MAX
from ._atomic import write_bytes_atomically
from ._errors import FormatError, MeshError
from ._files import file_errors, require_regular_file
from ._mesh import Mesh
from ._progress import as_callback
from ._spheremap import SphereMap

__all__ = ["from_geometry_image", "geometry_image", "load_geometry_image",
           "octahedral_points", "save_geometry_image"]

PathLike = Union[str, "os.PathLike[str]"]


#: Pixels per band of rows of :func:`geometry_image`, at most (the core's
#: memory rate counts one band of this size: ``memory_budget::BAND_PIXELS``).
_BAND_PIXELS = 1 << 18


def _size(size: object) -> int:
    n = _args.integer(size, "size", 3, GEOMETRY_IMAGE_SIZE_MAX)
    if n % 2 == 0:
        raise MeshError(f"size must be an odd integer in 3..{GEOMETRY_IMAGE_SIZE_MAX}, got {size!r}")
    return n


def octahedral_points(size: int) -> np.ndarray:
    """The unit vector of every pixel: (size, size, 3) float64, row ``i``
    at ``v = -1 + 2 i / (size - 1)``, column ``j`` at ``u = -1 + 2 j / (size - 1)``."""
    n = _size(size)
    t = np.linspace(-1.0, 1.0, n)
    u, v = np.meshgrid(t, t)
    p = octahedron_unfolded(u, v)
    unit: np.ndarray = p / np.linalg.norm(p, axis=-1, keepdims=True)
    return unit


def octahedron_unfolded(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The point of the octahedron |x| + |y| + |z| = 1 at (u, v) of the
    square [-1, 1]^2 (Praun and Hoppe's octahedral map, inverted): (..., 3)
    float64, not normalised. The upper half (|u| + |v| <= 1) is the square's
    diamond; the lower half's four triangles fold over its edges. The one
    inverse octahedral map, of geometry images and of the texture atlas.
    ``z`` is taken as ``+-(1 - |x| - |y|)`` of the folded ``x, y``, so that
    the point lies on the octahedron to the last digit of ``x`` and ``y``."""
    lower = np.abs(u) + np.abs(v) > 1
    su, sv = np.where(u >= 0, 1.0, -1.0), np.where(v >= 0, 1.0, -1.0)
    x = np.where(lower, su * (1 - np.abs(v)), u)
    y = np.where(lower, sv * (1 - np.abs(u)), v)
    z = np.where(lower, -1.0, 1.0) * (1 - np.abs(x) - np.abs(y))
    p: np.ndarray = np.stack([x, y, z], axis=-1)
    return p


def geometry_image(m: SphereMap, size: int, *, progress: Any = None) -> np.ndarray:
    """The surface of ``m`` at every pixel of an octahedral image.

    Parameters
    ----------
    m : SphereMap
        A certified map.
    size : int
        Odd, 3..4097 (:data:`spherify._limits.GEOMETRY_IMAGE_SIZE_MAX`).
    progress : bool or callable, optional
        ``True`` draws a bar on stderr, a callable receives ``(done, total)``
        (points located so far), as for :func:`spherify.embed`.

    Returns
    -------
    (size, size, 3) float64
        ``m.to_surface`` of :func:`octahedral_points`. O(size**2 log F).

    Raises
    ------
    MapError
        ``m`` is not a certified bijection.
    ResourceError
        The image cannot fit in the memory the process can still get
        (docs/reliability.md, "Memory"); raised before anything is allocated.
    """
    n = _size(size)
    _core.check_application("geometry_image", m.mesh.n_vertices, m.mesh.n_faces, n * n)
    callback = as_callback(progress, "geometry image")
    # In bands of rows: the pixels' directions and their located points are
    # never all held at once, only the image (24 bytes a pixel), so that the
    # largest image fits where its rate says. Each pixel is computed as in
    # octahedral_points, and point location is point by point: the same bits.
    band = max(1, (_progress.CHUNK_ROWS if callback else _BAND_PIXELS) // n)
    t = np.linspace(-1.0, 1.0, n)
    image = np.empty((n, n, 3))
    for start in range(0, n, band):
        u, v = np.meshgrid(t, t[start:start + band])
        p = octahedron_unfolded(u, v)
        p /= np.linalg.norm(p, axis=-1, keepdims=True)
        _, _, xyz = m.to_surface(p.reshape(-1, 3))
        image[start:start + band] = xyz.reshape(p.shape)
        if callback:
            callback(min(start + band, n) * n, n * n)
    return image


def _pixel_ids(n: int) -> np.ndarray:
    """The vertex of every pixel after the square's sides are glued: each
    side's pixel j and n - 1 - j are one point, the four corners one point."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    i, j = i.copy(), j.copy()
    top_bottom = (i == 0) | (i == n - 1)
    j[top_bottom] = np.minimum(j, n - 1 - j)[top_bottom]
    left_right = (j == 0) | (j == n - 1)
    left_right &= ~top_bottom
    i[left_right] = np.minimum(i, n - 1 - i)[left_right]
    corner = ((i == 0) | (i == n - 1)) & ((j == 0) | (j == n - 1))
    i[corner] = 0
    j[corner] = 0
    raw = i * n + j
    ids: np.ndarray = np.unique(raw, return_inverse=True)[1]
    return ids.reshape(n, n)


def from_geometry_image(image: np.ndarray) -> Mesh:
    """The closed mesh of an octahedral geometry image.

    Pixels glued by the octahedral folding become one vertex (taking the
    first pixel's position, in row-major order); every grid cell becomes two
    triangles split along the octahedron edge of its quadrant, counter-
    clockwise seen from outside. ``size**2 - 2 size + 3`` vertices and
    ``2 (size - 1)**2`` faces; genus 0.

    Raises
    ------
    MeshError
        Not a (size, size, 3) array of finite numbers with an odd size >= 3.
    ResourceError
        The mesh cannot fit in the memory the process can still get.
    """
    g = np.asarray(image, dtype=np.float64)
    if g.ndim != 3 or g.shape[0] != g.shape[1] or g.shape[2] != 3:
        raise MeshError(f"a geometry image must have shape (n, n, 3), got {g.shape}")
    n = _size(g.shape[0])
    _core.check_application("from_geometry_image", 0, 0, n * n)
    if not np.isfinite(g).all():
        raise MeshError("a geometry image must be finite")
    ids = _pixel_ids(n)
    vertices = np.empty((int(ids.max()) + 1, 3))
    vertices[ids[::-1, ::-1].ravel()] = g[::-1, ::-1].reshape(-1, 3)  # first pixel wins
    a, b = ids[:-1, :-1], ids[:-1, 1:]
    c, d = ids[1:, 1:], ids[1:, :-1]
    centre = np.arange(n - 1) + 0.5 - (n - 1) / 2
    cu, cv = np.meshgrid(centre, centre)
    anti = (cu * cv) > 0  # lower-left and upper-right quadrants: diagonal b-d
    first = np.where(anti[..., None], np.stack([a, b, d], -1), np.stack([a, b, c], -1))
    second = np.where(anti[..., None], np.stack([b, c, d], -1), np.stack([a, c, d], -1))
    faces = np.concatenate([first.reshape(-1, 3), second.reshape(-1, 3)])
    return Mesh(vertices, faces.astype(np.int64))


def _chunk(kind: bytes, data: bytes) -> bytes:
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


@file_errors
def save_geometry_image(image: np.ndarray, path: PathLike) -> int:
    """Write a geometry image as a 16-bit RGB PNG (8.2's compression).

    Each coordinate is quantised to 65536 levels across the image's bounding
    box, which is stored in a ``tEXt`` chunk (``spherify-bbox``) so that
    :func:`load_geometry_image` restores the units. Written atomically.

    Returns
    -------
    int
        Bytes written.
    """
    g = np.asarray(image, dtype=np.float64)
    if g.ndim != 3 or g.shape[0] != g.shape[1] or g.shape[2] != 3 or not np.isfinite(g).all():
        raise MeshError(f"a geometry image must be a finite (n, n, 3) array, got {g.shape}")
    lo, hi = g.reshape(-1, 3).min(0), g.reshape(-1, 3).max(0)
    span = np.where(hi > lo, hi - lo, 1.0)
    q = np.rint((g - lo) / span * 65535).astype(">u2")
    rows = b"".join(b"\x00" + q[i].tobytes() for i in range(q.shape[0]))
    bbox = " ".join(repr(float(x)) for x in (*lo, *hi)).encode()
    data = (b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", q.shape[1], q.shape[0], 16, 2, 0, 0, 0))
            + _chunk(b"tEXt", b"spherify-bbox\x00" + bbox)
            + _chunk(b"IDAT", zlib.compress(rows, 9))
            + _chunk(b"IEND", b""))
    write_bytes_atomically(path, data)
    return len(data)


@file_errors
def load_geometry_image(path: PathLike) -> np.ndarray:
    """Read a PNG written by :func:`save_geometry_image`: (n, n, 3) float64.

    Raises
    ------
    FormatError
        Not such a PNG (another layout, a filter other than none, a bad CRC,
        a missing bounding box), with the path and byte offset.
    """
    name = os.fspath(path)
    require_regular_file(Path(name))
    data = Path(path).read_bytes()

    def bad(message: str, offset: int) -> FormatError:
        return FormatError(f"{name}: byte {offset}: {message}", name, None, offset)

    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise bad("not a PNG file", 0)
    pos, header, bbox, idat = 8, None, None, b""
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if len(body) != length or pos + 12 + length > len(data):
            raise bad(f"chunk {kind!r} runs past the end of the file", pos)
        crc = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0]
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise bad(f"chunk {kind!r} fails its CRC", pos)
        if kind == b"IHDR":
            if length != 13:
                raise bad(f"an IHDR chunk of {length} bytes (PNG's has 13)", pos)
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"tEXt" and body.startswith(b"spherify-bbox\x00"):
            bbox = body[len(b"spherify-bbox\x00"):]
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None or header[2:] != (16, 2, 0, 0, 0) or header[0] != header[1]:
        raise bad("not a square 16-bit RGB PNG without interlacing", 8)
    if bbox is None:
        raise bad("no spherify-bbox text chunk: not written by save_geometry_image", 8)
    n = header[0]
    stride = 1 + 6 * n
    try:
        lo_hi = np.array([float(x) for x in bbox.decode().split()])
        # At most one byte more than the header's image: a small file that
        # inflates to gigabytes is refused after n * stride + 1 bytes.
        raw = zlib.decompressobj().decompress(idat, n * stride + 1)
    except (ValueError, UnicodeDecodeError, zlib.error) as err:
        raise bad(f"unreadable bounding box or image data: {err}", 8) from None
    if lo_hi.shape != (6,) or len(raw) != n * stride:
        raise bad("image data does not match the header", 8)
    if not np.isfinite(lo_hi).all():
        raise bad(f"the spherify-bbox chunk holds a value that is not finite: {bbox!r}", 8)
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(n, stride)
    if np.any(rows[:, 0] != 0):
        raise bad("only PNG filter 0 (none) is supported", 8)
    q = rows[:, 1:].copy().view(">u2").reshape(n, n, 3).astype(np.float64)
    lo, hi = lo_hi[:3], lo_hi[3:]
    return lo + q / 65535 * np.where(hi > lo, hi - lo, 0.0)
