"""Texture coordinates from a sphere map (thesis 8.5): per-corner UVs, an
atlas to bake any spherical texture into, and OBJ + MTL export.

    t = sp.texture.uv(m, projection="cube")     # UVLayout: t.uv (F, 3, 2)
    image = t.bake(sp.datasets.checkerboard, 512)
    sp.save(m.mesh, "out.obj", uv=t, texture=image)  # as sp.texture.save_obj(...)

Projections (the image a UV points into is the layout's atlas, made by
:meth:`UVLayout.bake` from a function of the direction on the sphere):

* ``"cube"`` (default): each face goes to the cube face its centroid points
  at and its corners are projected onto that cube face's plane (gnomonic
  projection). Six square tiles, three by two; each tile reaches a margin
  beyond its cube face so that the faces that straddle a cube edge keep
  their whole triangle in their own tile (no smearing across a seam). The
  gnomonic projection maps great circles to lines, so a positively oriented
  spherical triangle (certified by the map) has a positively oriented UV
  triangle: exactly, not by a tolerance.
* ``"equirectangular"``: u from phi, v from theta. The projection's poles are
  put at two vertices first (a rotation takes the vertex nearest the north
  pole there, then a Moebius transformation - a translation of the
  stereographic plane - takes the vertex nearest the opposite point to the
  south pole; for theta-phi maps, whose poles are vertices at +-z, both are
  the identity), so no face holds a pole inside; a pole corner takes the mean
  u of its face's other corners. Faces across the date line keep their own
  unwrapped u; the atlas covers a little more than 2 pi in phi
  (``u_span``), so every u stays in [0, 1].
* ``"octahedral"``: Praun and Hoppe's (2003) octahedral map onto a square:
  a point p goes to p / (|x| + |y| + |z|) on the octahedron, the upper half
  (z >= 0) to the diamond |s| + |t| <= 1 by (s, t) = (x, y), each lower
  octant folded out to its corner of [-1, 1]^2. On each octant this is a
  gnomonic projection followed by an affine map of positive determinant, so
  a face inside one octant keeps its orientation. The seams are the four
  half-meridians of the lower half (the square's edges, each glued to
  itself turned by 180 degrees about its midpoint): a face across one takes,
  for each corner, the copy under those turns nearest its other corners, and
  the atlas shows a margin beyond the square (``extent`` E >= 1: the atlas
  is [-E, E]^2, read back by the same turns). The map bends at the octant
  boundaries, so a thin face across one (or a face around one of the four
  equator vertices of the octahedron) can come out reversed or much thinner
  than on the sphere: such a face (``projected``, under one in a hundred
  on a 1.5k-vertex mesh, 0.15 % at 20k) takes its corners from the
  projection of one octant extended beyond it (the one whose UVs come
  nearest its points), which keeps it positive exactly, as the cube
  projection does; its corners then show their points only to within some
  degrees on coarse meshes (up to 20 at 1.5k vertices, 6 at 20k).
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Union

import numpy as np
import numpy.typing as npt

from . import _args, _core
from ._atomic import write_bytes_atomically
from ._errors import FormatError, MeshError
from ._files import file_errors
from ._geometry_image import _chunk, octahedron_unfolded
from ._limits import ATLAS_HEIGHT_MAX
from ._mesh import Mesh
from ._progress import as_callback
from ._quality import quality
from ._spheremap import SphereMap

__all__ = ["PROJECTIONS", "UVLayout", "save_obj", "uv", "write_png"]

#: The projections of :func:`uv`, the default first (see the module doc).
PROJECTIONS = ("cube", "equirectangular", "octahedral")

#: Pixels per band of rows of :meth:`UVLayout.bake`, at most (the core's
#: memory rate counts one band of this size: ``memory_budget::BAND_PIXELS``).
_BAND_PIXELS = 1 << 18
PathLike = Union[str, "os.PathLike[str]"]

# Cube tiles: normal, s axis, t axis (s x t = normal, so CCW stays CCW), atlas column, row.
_TILES = [
    ((1, 0, 0), (0, 1, 0), (0, 0, 1), 0, 1),
    ((-1, 0, 0), (0, -1, 0), (0, 0, 1), 1, 1),
    ((0, 1, 0), (-1, 0, 0), (0, 0, 1), 2, 1),
    ((0, -1, 0), (1, 0, 0), (0, 0, 1), 0, 0),
    ((0, 0, 1), (1, 0, 0), (0, 1, 0), 1, 0),
    ((0, 0, -1), (1, 0, 0), (0, -1, 0), 2, 0),
]
_NORMALS = np.array([t[0] for t in _TILES], dtype=np.float64)
_S = np.array([t[1] for t in _TILES], dtype=np.float64)
_T = np.array([t[2] for t in _TILES], dtype=np.float64)
_COLS = np.array([t[3] for t in _TILES])
_ROWS = np.array([t[4] for t in _TILES])
#: A corner must be within about 78 degrees of its tile's axis.
_MIN_COS = 0.2


def _stereo(p: np.ndarray) -> np.ndarray:
    """Stereographic projection from the north pole, as complex numbers."""
    w: np.ndarray = (p[..., 0] + 1j * p[..., 1]) / (1 - p[..., 2])
    return w


def _istereo(w: np.ndarray) -> np.ndarray:
    r2 = np.abs(w) ** 2
    p: np.ndarray = np.stack([2 * w.real, 2 * w.imag, r2 - 1], axis=-1) / (r2 + 1)[..., None]
    return p


def _rotation_to_north(p: np.ndarray) -> np.ndarray:
    """A rotation taking the unit vector p to (0, 0, 1)."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(p, z), float(p @ z)
    if np.linalg.norm(v) < 1e-15:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    r: np.ndarray = np.eye(3) + k + k @ k / (1 + c)
    return r


class UVLayout:
    """Per-corner texture coordinates of a mesh and the atlas they point into.

    All attributes are read-only.

    Attributes
    ----------
    projection : str
    uv : (m, 3, 2) float64
        Corner k of face f at ``uv[f, k]``, in [0, 1]^2, v upwards (OBJ).
    params : dict
        ``cube``: ``tiles`` (m,) the tile of each face (+x, -x, +y, -y, +z,
        -z) and ``extent`` L (each tile shows the gnomonic square [-L, L]^2).
        ``equirectangular``: ``u_span`` (u = phi / (2 pi u_span)),
        ``rotation``, ``shift`` (the Moebius translation) and ``poles`` (the
        two vertex ids at the projection's poles). ``octahedral``:
        ``extent`` E (the atlas shows [-E, E]^2 of the octahedral square)
        and ``projected`` (the faces that take their corners from their
        own octant's projection, see the module doc).
    """

    def __init__(self, projection: str, uv: np.ndarray, params: Dict[str, Any]) -> None:
        self._projection = projection
        uv.flags.writeable = False
        self._uv = uv
        self._params = params

    @property
    def projection(self) -> str:
        """The projection's name (:data:`PROJECTIONS`)."""
        return self._projection

    @property
    def uv(self) -> np.ndarray:
        """(m, 3, 2) float64: corner k of face f at ``uv[f, k]``, v upwards."""
        return self._uv

    @property
    def params(self) -> Dict[str, Any]:
        """The projection's parameters (see the class docstring)."""
        return dict(self._params)

    def directions(self, height: int, width: int) -> np.ndarray:
        """The unit vector each atlas pixel shows: (height, width, 3) float64,
        row 0 at the top (v = 1). Bake a texture by colouring these."""
        if height < 1 or width < 1:
            raise MeshError(f"the atlas needs a positive size, got {height} x {width}")
        u = (np.arange(width) + 0.5) / width
        v = 1 - (np.arange(height) + 0.5) / height
        uu, vv = np.meshgrid(u, v)
        return self.direction_at(np.stack([uu, vv], axis=-1))

    def direction_at(self, uv: npt.ArrayLike) -> np.ndarray:
        """The unit vector at atlas coordinates ``uv`` (..., 2): the inverse
        of the projection (each face corner's UV gives that vertex's point)."""
        p = np.asarray(uv, dtype=np.float64)
        uu, vv = p[..., 0], p[..., 1]
        if self._projection == "cube":
            col = np.clip(np.floor(uu * 3).astype(np.int64), 0, 2)
            row = np.clip(np.floor(vv * 2).astype(np.int64), 0, 1)
            tile = np.zeros_like(col)
            for k in range(6):
                tile[(col == _COLS[k]) & (row == _ROWS[k])] = k
            extent = self._params["extent"]
            s = ((uu * 3 - col) * 2 - 1) * extent
            t = ((vv * 2 - row) * 2 - 1) * extent
            d = _NORMALS[tile] + s[..., None] * _S[tile] + t[..., None] * _T[tile]
        elif self._projection == "octahedral":
            extent = self._params["extent"]
            d = _octahedral_inverse((uu * 2 - 1) * extent, (vv * 2 - 1) * extent)
        else:
            phi = 2 * np.pi * uu * self._params["u_span"]
            theta = np.pi * (1 - vv)
            d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                          np.cos(theta)], axis=-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                back = _istereo(_stereo(d) + self._params["shift"])
            back[d[..., 2] >= 1.0] = [0.0, 0.0, 1.0]
            d = back @ self._params["rotation"]  # R^T applied to rows
        unit: np.ndarray = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return unit

    def bake(self, texture: Callable[[np.ndarray], np.ndarray], height: int,
             width: Optional[int] = None, *, progress: Any = None) -> np.ndarray:
        """The atlas image: ``texture(directions)`` at every pixel.

        Parameters
        ----------
        texture : callable
            Takes (..., 3) unit vectors and returns (..., 3) RGB in [0, 1]
            (for example ``sp.datasets.checkerboard``).
        height : int
            Rows of the atlas, 1..4096 (:data:`spherify._limits.ATLAS_HEIGHT_MAX`:
            the largest atlas fits in 4 GB with its directions).
        width : int, optional
            Columns, 1..8192; default ``1.5 height`` for the cube atlas,
            ``2 height`` for equirectangular and ``height`` for octahedral.
        progress : bool or callable, optional
            ``True`` draws a bar on stderr, a callable receives ``(done,
            total)`` rows; ``texture`` is then called on 64 rows at a time
            (otherwise on bands of about a million pixels: it is called on
            each pixel's direction, in pieces).

        Returns
        -------
        (height, width, 3) float64

        Raises
        ------
        MeshError
            ``height`` or ``width`` not an integer in its range (before
            anything is allocated).
        ResourceError
            The atlas cannot fit in the memory the process can still get
            (docs/reliability.md, "Memory"); raised before it is allocated.
        """
        height = _args.integer(height, "height", 1, ATLAS_HEIGHT_MAX)
        if width is None:
            aspect = {"cube": 1.5, "equirectangular": 2.0}.get(self._projection, 1.0)
            width = int(round(height * aspect))
        width = _args.integer(width, "width", 1, 2 * ATLAS_HEIGHT_MAX)
        _core.check_application("UVLayout.bake", 0, 0, height * width)
        callback = as_callback(progress, "bake")
        # In bands of rows: the directions (and whatever texture makes of
        # them) are never all held at once, only the atlas, so that the
        # largest atlas fits where its rate says. Each pixel's direction is
        # the one directions() gives it.
        band = max(1, _BAND_PIXELS // width)
        if callback:
            band = min(band, 64)
        u = (np.arange(width) + 0.5) / width
        v = 1 - (np.arange(height) + 0.5) / height
        image = np.empty((height, width, 3))
        for start in range(0, height, band):
            uu, vv = np.meshgrid(u, v[start:start + band])
            colour = np.asarray(texture(self.direction_at(np.stack([uu, vv], axis=-1))),
                                dtype=np.float64)
            if colour.shape != uu.shape + (3,):
                raise MeshError(f"texture must return one RGB row per direction, shape "
                                f"{uu.shape + (3,)} for directions of shape {uu.shape + (3,)}, "
                                f"got {colour.shape}")
            image[start:start + band] = colour
            if callback:
                callback(min(start + band, height), height)
        return image

    def sample(self, image: np.ndarray, face_ids: npt.ArrayLike, bary: npt.ArrayLike) -> np.ndarray:
        """The atlas colour at surface points (nearest pixel): for renderers
        and tests. Returns (k, channels)."""
        f = np.asarray(face_ids, dtype=np.int64)
        w = np.asarray(bary, dtype=np.float64)
        p = np.einsum("kj,kjd->kd", w, self._uv[f])
        h, wd = image.shape[:2]
        col = np.clip((p[:, 0] * wd).astype(np.int64), 0, wd - 1)
        row = np.clip(((1 - p[:, 1]) * h).astype(np.int64), 0, h - 1)
        result: np.ndarray = image[row, col]
        return result

    def quality(self, mesh: Mesh) -> Dict[str, Union[float, int]]:
        """:func:`spherify.quality` of the texture map: every face on its
        own (the mesh exploded into separate triangles) against its UV
        triangle, so ``stretch_l2`` is the texture stretch of Sander et al."""
        corners = mesh.vertices[mesh.faces].reshape(-1, 3)
        faces = np.arange(len(corners), dtype=np.int64).reshape(-1, 3)
        flat = np.concatenate([self._uv.reshape(-1, 2), np.zeros((len(corners), 1))], axis=1)
        return quality((corners, faces), flat)


def _cube(points: np.ndarray, faces: np.ndarray) -> UVLayout:
    p = points[faces]  # (m, 3, 3)
    centre = p.sum(axis=1)
    axis = np.abs(centre).argmax(axis=1)
    negative = centre[np.arange(len(centre)), axis] < 0
    tile = 2 * axis + negative  # +x, -x, +y, -y, +z, -z
    n, es, et = _NORMALS[tile][:, None], _S[tile][:, None], _T[tile][:, None]
    depth = (p * n).sum(-1)
    if depth.min() < _MIN_COS:
        f = int(np.argmin(depth.min(axis=1)))
        raise MeshError(f"face {f} is too large for the cube projection: a corner is "
                        f"{np.degrees(np.arccos(np.clip(depth.min(), -1, 1))):.1f} degrees from "
                        "its tile's axis (at most 78)")
    s, t = (p * es).sum(-1) / depth, (p * et).sum(-1) / depth
    extent = float(max(1.0, np.abs(s).max(), np.abs(t).max())) * (1 + 1e-9)
    u = (_COLS[tile][:, None] + (s / extent + 1) / 2) / 3
    v = (_ROWS[tile][:, None] + (t / extent + 1) / 2) / 2
    return UVLayout("cube", np.stack([u, v], axis=-1), {"tiles": tile, "extent": extent})


def _equirectangular(points: np.ndarray, faces: np.ndarray) -> UVLayout:
    north = int(np.argmax(points[:, 2]))
    rotation = _rotation_to_north(points[north])
    q = points @ rotation.T
    q[north] = [0.0, 0.0, 1.0]
    south = int(np.argmin(q[:, 2]))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = _stereo(q)
    shift = complex(w[south])
    others = np.arange(len(q)) != north
    moved = q.copy()
    moved[others] = _istereo(w[others] - shift)
    moved[south] = [0.0, 0.0, -1.0]
    theta = np.arccos(np.clip(moved[:, 2], -1.0, 1.0))
    phi = np.mod(np.arctan2(moved[:, 1], moved[:, 0]), 2 * np.pi)
    pole = np.zeros(len(q), dtype=bool)
    pole[[north, south]] = True
    f_phi, f_pole = phi[faces], pole[faces]
    # Unwrap each face's phi about its first corner that is not a pole.
    ref = f_phi[np.arange(len(faces)), np.argmin(f_pole, axis=1)]
    unwrapped = ref[:, None] + np.mod(f_phi - ref[:, None] + np.pi, 2 * np.pi) - np.pi
    if f_pole.any():
        rows = np.nonzero(f_pole.any(axis=1))[0]
        for r in rows:
            k = np.nonzero(f_pole[r])[0]
            rest = np.nonzero(~f_pole[r])[0]
            unwrapped[r, k] = unwrapped[r, rest].mean()
    low = unwrapped.min(axis=1)
    unwrapped += np.where(low < 0, 2 * np.pi, 0.0)[:, None]
    span = float(max(1.0, unwrapped.max() / (2 * np.pi))) * (1 + 1e-12)
    u = unwrapped / (2 * np.pi * span)
    v = 1 - theta[faces] / np.pi
    return UVLayout("equirectangular", np.stack([u, v], axis=-1),
                    {"u_span": span, "rotation": rotation, "shift": shift,
                     "poles": (north, south)})


#: The turns of the octahedral square that glue its edges (180 degrees about
#: each edge's midpoint) and their products nearest the square (translations
#: by (+-2, +-2)); the identity first.
_TURN_CENTRES = np.array([[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0]])
_SHIFTS = np.array([[2.0, 2.0], [2.0, -2.0], [-2.0, 2.0], [-2.0, -2.0]])
#: The octants (signs of x, y, z) in the order of ``_octant``'s index.
_OCTANTS = np.array([[sx, sy, sz] for sz in (1, -1) for sy in (1, -1) for sx in (1, -1)],
                    dtype=np.float64)


def _octahedral_forward(q: np.ndarray) -> np.ndarray:
    """Praun and Hoppe's octahedral map of unit vectors to [-1, 1]^2."""
    o = q / np.abs(q).sum(axis=-1, keepdims=True)
    x, y, z = o[..., 0], o[..., 1], o[..., 2]
    sx, sy = np.where(x >= 0, 1.0, -1.0), np.where(y >= 0, 1.0, -1.0)
    lower = z < 0
    s = np.where(lower, sx * (1 - np.abs(y)), x)
    t = np.where(lower, sy * (1 - np.abs(x)), y)
    st: np.ndarray = np.stack([s, t], axis=-1)
    return st


def _octahedral_inverse(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The unit vector at (s, t) of the octahedral plane: first brought into
    [-1, 1]^2 by the turns that glue the square's edges."""
    s, t = s.copy(), t.copy()
    for _ in range(8):  # each turn brings a point at most E <= 3 a step closer
        top, bottom = t > 1, t < -1
        s[top | bottom] = -s[top | bottom]
        t[top], t[bottom] = 2 - t[top], -2 - t[bottom]
        right, left = s > 1, s < -1
        t[right | left] = -t[right | left]
        s[right], s[left] = 2 - s[right], -2 - s[left]
    return octahedron_unfolded(s, t)


def _nearest_copies(w: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """For each corner (m, 3, 2), its copy under the gluing turns nearest
    ``reference`` (m, 3, 2)."""
    copies = np.concatenate([w[:, :, None, :],
                             2 * _TURN_CENTRES[None, None] - w[:, :, None, :],
                             w[:, :, None, :] + _SHIFTS[None, None]], axis=2)  # (m, 3, 9, 2)
    best = np.argmin(np.linalg.norm(copies - reference[:, :, None, :], axis=-1), axis=2)
    nearest: np.ndarray = np.take_along_axis(copies, best[..., None, None], axis=2)[:, :, 0]
    return nearest


def _octahedral_shared(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each corner at the octahedral map of its point, a face across a seam
    put in one piece by the gluing turns: (m, 3, 2)."""
    w = _octahedral_forward(points)[faces]
    # Next to the corner farthest from the south pole; then a corner at the
    # south pole itself (which the square shows at all four of its corners)
    # goes to the corner between its face's other two.
    top = np.argmax(points[faces][..., 2], axis=1)
    w = _nearest_copies(w, np.repeat(w[np.arange(len(w)), top][:, None], 3, axis=1))
    pole = np.all(np.abs(np.abs(w) - 1) == 0, axis=-1) & (points[faces][..., 2] < 0)
    if pole.any():
        between = _nearest_copies(w, (w.sum(axis=1, keepdims=True) - w) / 2)
        w[pole] = between[pole]
    return w


def _octant_projection(p: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """The octahedral map of one octant (signs (k, 3)) extended beyond it:
    p (k, 3, 3) -> (k, 3, 2). A gnomonic projection onto that face of the
    octahedron and an affine map of positive determinant."""
    o = p / (p * signs[:, None]).sum(axis=-1, keepdims=True)
    sx, sy, sz = (signs[:, k, None] for k in range(3))
    s = np.where(sz > 0, o[..., 0], sx * (1 - sy * o[..., 1]))
    t = np.where(sz > 0, o[..., 1], sy * (1 - sx * o[..., 0]))
    st: np.ndarray = np.stack([s, t], axis=-1)
    return st


#: A face across an octant boundary whose UV triangle (under the shared
#: octahedral map) has less than this part of the shape quality of its
#: sphere triangle takes its best octant's projection, if that is better.
_THIN = 0.25


def _doubled_areas(w: np.ndarray) -> np.ndarray:
    e1, e2 = w[:, 1] - w[:, 0], w[:, 2] - w[:, 0]
    areas: np.ndarray = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    return areas


def _shape(doubled_areas: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """2 sqrt(3) (doubled area) / (sum of squared edges): 1 for an
    equilateral triangle, 0 for a degenerate one, negative if reversed."""
    edges = corners - np.roll(corners, 1, axis=1)
    q: np.ndarray = 2 * np.sqrt(3) * doubled_areas / np.sum(edges ** 2, axis=(1, 2))
    return q


def _octahedral(points: np.ndarray, faces: np.ndarray) -> UVLayout:
    w = _octahedral_shared(points, faces)
    area = _doubled_areas(w)
    # The octahedral map bends at the octant boundaries, and around the four
    # octahedron vertices of the equator the square has half the sphere's
    # angle: a thin face across a bend, or a face around such a vertex, may
    # come out reversed or much thinner than on the sphere (shape quality
    # below a quarter of its sphere triangle's). Such a face takes its corners from
    # the projection of one octant, extended beyond it: a gnomonic
    # projection (great circles to lines, so a positive spherical triangle
    # stays positive, exactly, as in the cube projection) followed by an
    # affine map of positive determinant. Of the octants whose projection
    # reaches every corner, the one whose UVs, read back by the shared map,
    # come nearest the corners.
    octant = (points[faces] >= 0) @ np.array([1, 2, 4])
    across = np.nonzero((octant != octant[:, :1]).any(axis=1) | (area <= 0))[0]
    p = points[faces[across]]
    best = np.zeros((len(p), 3, 2))
    best_error = np.full(len(p), np.inf)
    for signs in _OCTANTS:
        depth = (p @ signs).min(axis=1)
        candidate = _octant_projection(p, np.broadcast_to(signs, (len(p), 3)))
        shown = _octahedral_inverse(candidate[..., 0], candidate[..., 1])
        shown /= np.linalg.norm(shown, axis=-1, keepdims=True)
        error = np.where(depth >= _MIN_COS, -np.sum(shown * p, axis=-1).min(axis=1), np.inf)
        better = error < best_error
        best[better] = candidate[better]
        best_error[better] = error[better]
    reached = np.isfinite(best_error)
    if not np.all(reached | (area[across] > 0)):
        f = int(across[np.argmax(~reached & (area[across] <= 0))])
        raise MeshError(f"face {f} is too large for the octahedral projection: the "
                        "octahedral map reverses it and no octant's projection reaches all "
                        "its corners")
    sphere = points[faces[across]]
    sphere_shape = _shape(np.linalg.norm(np.cross(sphere[:, 1] - sphere[:, 0],
                                                  sphere[:, 2] - sphere[:, 0]), axis=1), sphere)
    shared_shape = _shape(area[across], w[across])
    use = reached & ((area[across] <= 0) | ((shared_shape < _THIN * sphere_shape)
                                            & (_shape(_doubled_areas(best), best) > shared_shape)))
    projected = across[use]
    w[projected] = best[use]
    extent = float(max(1.0, np.abs(w).max())) * (1 + 1e-12)
    return UVLayout("octahedral", (w / extent + 1) / 2,
                    {"extent": extent, "projected": projected})


def uv(m: SphereMap, projection: str = "cube") -> UVLayout:
    """Per-corner texture coordinates of ``m.mesh`` from its sphere points.

    Parameters
    ----------
    m : SphereMap
        Best a certified one (``valid``): then every UV triangle of the cube
        projection is positively oriented.
    projection : str
        ``"cube"``, ``"equirectangular"`` or ``"octahedral"`` (see the
        module doc).

    Returns
    -------
    UVLayout
        ``uv`` (m, 3, 2) float64 in [0, 1]^2. O(m).

    Raises
    ------
    MeshError
        Unknown projection; for ``"cube"``, a face so large that a corner is
        more than 78 degrees from its tile's axis; for ``"octahedral"``, a
        reversed face that no octant's projection reaches whole.
    ResourceError
        The layout cannot fit in the memory the process can still get
        (docs/reliability.md, "Memory"); raised before it is made.
    """
    if projection not in PROJECTIONS:
        raise MeshError(f"unknown projection {projection!r}; available: {', '.join(PROJECTIONS)}")
    _core.check_application(f"texture.uv {projection}", m.mesh.n_vertices, m.mesh.n_faces, 0)
    points, faces = np.asarray(m.points), m.mesh.faces
    if projection == "cube":
        return _cube(points, faces)
    if projection == "octahedral":
        return _octahedral(points, faces)
    return _equirectangular(points, faces)


def png_bytes(image: npt.ArrayLike) -> bytes:
    """An (h, w, 3) RGB image with values in [0, 1] encoded as an 8-bit PNG.

    Parameters
    ----------
    image : (h, w, 3) array_like of float
        Values in [0, 1] (clipped); every value must be finite.

    Returns
    -------
    bytes
        The PNG file's bytes.

    Raises
    ------
    MeshError
        A wrong shape, or values that are not finite (with how many):
        written as black, they would hide whatever made them.
    """
    a = np.asarray(image, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise MeshError(f"an image must have shape (h, w, 3), got {a.shape}")
    finite = np.isfinite(a)
    if not finite.all():
        raise MeshError(f"{int(a.size - finite.sum())} of the image's {a.size} values are not "
                        "finite; a texture must be numbers in [0, 1]")
    q = np.rint(np.clip(a, 0, 1) * 255).astype(np.uint8)
    rows = b"".join(b"\x00" + q[i].tobytes() for i in range(q.shape[0]))
    return (b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", q.shape[1], q.shape[0], 8, 2, 0, 0, 0))
            + _chunk(b"IDAT", zlib.compress(rows, 6)) + _chunk(b"IEND", b""))


@file_errors
def write_png(image: npt.ArrayLike, path: PathLike) -> None:
    """An (h, w, 3) RGB image with values in [0, 1] as an 8-bit PNG
    (:func:`png_bytes`), written atomically."""
    write_bytes_atomically(Path(path), png_bytes(image))


@file_errors
def save_obj(mesh: Mesh, path: PathLike, layout: UVLayout,
             image: Optional[npt.ArrayLike] = None) -> None:
    """Write ``mesh`` as OBJ with one ``vt`` per face corner and, with
    ``image``, an MTL next to it whose ``map_Kd`` is that image written as
    PNG (``<stem>.png``). Every file is written atomically. The same as
    ``sp.save(mesh, path, uv=layout, texture=image)``."""
    if layout.uv.shape != (mesh.n_faces, 3, 2):
        raise MeshError(f"the layout has {layout.uv.shape[0]} faces, the mesh {mesh.n_faces}")
    _write_obj(mesh, Path(path), layout.uv, layout.projection, image)


def _write_obj(mesh: Mesh, target: Path, corners: np.ndarray, label: str,
               texture: Any = None) -> None:
    """OBJ with ``vt`` per corner (the core's OBJ writer); ``texture`` an
    image array (written as ``<stem>.png``) or the path of an image file
    (referenced, not copied), named by an MTL file written here."""
    library: Optional[str] = None
    if texture is not None:
        # mtllib and map_Kd name these files on a line of their own, and
        # readers split those lines at white space: a line break in the name
        # would write lines of its own into the files (issue 26, finding 9).
        for name in (target.with_suffix(".mtl").name, target.with_suffix(".png").name):
            if any(c.isspace() or not c.isprintable() for c in name):
                raise MeshError(f"the output name {name!r} holds white space or a control "
                                "character, which an OBJ's mtllib and an MTL's map_Kd cannot "
                                "carry; name the .obj without them")
        if isinstance(texture, (str, os.PathLike)):
            image_path = Path(texture)
            name = (image_path.as_posix() if image_path.is_absolute()
                    else Path(os.path.relpath(image_path, target.parent)).as_posix())
            if any(c.isspace() for c in name):
                raise MeshError(f"the texture's path {name!r} holds white space, which MTL "
                                "cannot reference")
        else:
            write_png(texture, target.with_suffix(".png"))
            name = target.with_suffix(".png").name
        mtl = target.with_suffix(".mtl")
        write_bytes_atomically(mtl, f"newmtl texture\nKa 1 1 1\nKd 1 1 1\nmap_Kd {name}\n".encode())
        library = mtl.name
    uv = np.ascontiguousarray(np.asarray(corners, dtype=np.float64).reshape(-1, 2))
    _core.save_textured_obj(mesh._core, os.fspath(target), uv, label, library)


def _is_per_corner(uv: Any) -> bool:
    """Whether ``uv`` (for :func:`spherify.save`) is per face corner: a
    :class:`UVLayout` or an array of three dimensions."""
    return isinstance(uv, UVLayout) or (uv is not None and np.ndim(uv) == 3)


def _save_textured(mesh: Mesh, target: Path, uv: Any, texture: Any, sphere: Any,
                  format: Optional[str]) -> None:
    """:func:`spherify.save` with per-corner ``uv`` or a ``texture``: OBJ only."""
    if format is not None or target.suffix.lower() != ".obj":
        raise MeshError(f"per-corner texture coordinates and textures are written to .obj "
                        f"only (with an MTL), got {target.name}"
                        + (f" with format={format!r}" if format is not None else ""))
    if sphere is not None:
        raise FormatError("a .obj file cannot hold per-vertex sphere positions: .ply and "
                          ".npz do", path=str(target))
    if uv is None:
        raise MeshError("a texture needs texture coordinates: pass uv= (sp.texture.uv(m).uv, "
                        "or a per-vertex (n, 2) array)")
    if isinstance(uv, UVLayout):
        corners, label = uv.uv, uv.projection
    else:
        try:
            array = np.asarray(uv, dtype=np.float64)
        except (TypeError, ValueError) as err:
            raise MeshError(f"uv must be a numeric array: {err}") from None
        if array.shape == (mesh.n_vertices, 2) and array.ndim == 2:
            corners, label = array[mesh.faces], "per-vertex"
        elif array.shape == (mesh.n_faces, 3, 2):
            corners, label = array, "per-corner"
        else:
            raise MeshError(f"uv must have shape ({mesh.n_faces}, 3, 2) (per face corner) or "
                            f"({mesh.n_vertices}, 2) (per vertex), got {array.shape}")
    if corners.shape != (mesh.n_faces, 3, 2):
        raise MeshError(f"the layout has {corners.shape[0]} faces, the mesh {mesh.n_faces}")
    if not np.all(np.isfinite(corners)):
        f = int(np.nonzero(~np.isfinite(corners).all(axis=(1, 2)))[0][0])
        raise MeshError(f"uv of face {f} is not finite")
    _write_obj(mesh, target, corners, label, texture)


def __dir__() -> List[str]:
    """Only the public names (PEP 562): dir() lists what __all__ does."""
    return sorted(__all__)
