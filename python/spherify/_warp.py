"""A flip-free non-rigid warp of A's sphere map onto B's: registration's last step.

After a rotation or Möbius transformation has put A's map in B's frame, A's
vertex ``i`` sits at ``q_i`` on the sphere and so at ``y_i = b(q_i)`` on B's
surface. The warp moves the ``q_i`` so that the spatial residual
``r_i = y_i - S a_i`` (both shapes at unit rms radius, ``S`` the best spatial
rotation) becomes smooth: a smooth residual is a bend of the shape, which a
correspondence must keep, while a residual that changes quickly is the two
maps disagreeing about where the features are, which it must remove. It is
non-rigid ICP (Amberg, Romdhani and Vetter 2007) with the stiffness given by
a smoothing width, annealed from wide to narrow, and the matching done
through B's sphere map instead of a nearest-point search:

1. ``D = smooth(r, sigma)`` is the bend at scale ``sigma``; ``a_i + D_i`` is
   where A's vertex should lie on B, and ``delta_i = D_i - r_i`` is how far
   ``y_i`` must move along B.
2. In the face of B holding ``y_i``, the affine map from B's triangle to its
   chord triangle on the sphere turns ``delta_i`` (its component in the
   triangle's plane) into a move of ``q_i``: one Gauss-Newton step of
   ``|b(q_i) - (a_i + D_i)|``.
3. The moves are smoothed too (so that the warp is a smooth motion of the
   sphere, not a shuffle of vertices) and made flip-free by
   :func:`spherify._landmarks.move_towards`, which moves each vertex only as
   far as every face around it stays positive under the exact test. So A's
   map is certified after every step.

Smoothing is done on the sphere: each field is spread by barycentric weights
(times the vertices' surface areas) onto the vertices of an icosphere
(:class:`SphereSmoother`), convolved there with a Gaussian of the angle, and
read back with the same weights. Its cost does not grow with the mesh.
Landmark pairs are held fixed (each A landmark at its B landmark's sphere
point) and weigh :data:`LANDMARK_WEIGHT` times a mean vertex in the bend, so
the bend follows them, and in the moves, where they want none: the moves
around a landmark taper to it rather than crowd onto it.
"""

from __future__ import annotations

import functools
from typing import Any, Callable, Dict, Optional, Sequence, Tuple

import numpy as np

from . import _landmarks
from ._align import kabsch
from ._spheremap import SphereMap

__all__ = ["SCHEDULE", "warp"]

FINE_WIDTH = 0.2
# Vertices of A the moves are worked out on (all of a smaller mesh).
SAMPLE = 8000
LANDMARK_WEIGHT = 50.0
# (bend width, move width, steps): widths in radians of the sphere, wide to
# narrow. Measured on issue 23's pairs (mean error over B's diagonal, from the
# Möbius start): moves smoothed as widely as the bend, and a fifth, narrower
# stage, took hand from 1.8% to 1.1%, knight 3.5% to 1.7%, spot 0.68% to
# 0.61% (cortex 1.05% to 1.08%) against moves half as wide in four stages.
SCHEDULE: Tuple[Tuple[float, float, int], ...] = (
    (0.6, 0.6, 4), (0.4, 0.4, 4), (0.25, 0.25, 4), (0.15, 0.15, 4), (0.1, 0.1, 4))


def _unit_rows(x: np.ndarray) -> np.ndarray:
    out: np.ndarray = x / np.linalg.norm(x, axis=1)[:, None]
    return out


def _vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """A third of the area of the faces around each vertex, over their mean."""
    e1 = vertices[faces[:, 1]] - vertices[faces[:, 0]]
    e2 = vertices[faces[:, 2]] - vertices[faces[:, 0]]
    area = np.linalg.norm(np.cross(e1, e2), axis=1)
    share = np.bincount(faces.ravel(), np.repeat(area, 3), len(vertices))
    mean = float(share.mean())
    out: np.ndarray = share / (mean if mean > 0 else 1.0)
    return out


@functools.lru_cache(maxsize=None)
def _grid_map(level: int) -> SphereMap:
    """The icosphere of ``level`` as its own certified sphere map (built once)."""
    from .datasets import icosphere
    grid = icosphere(subdivisions=level)
    return SphereMap.from_points(grid, grid.vertices)


@functools.lru_cache(maxsize=None)
def _kernel(level: int, sigma: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Gaussian of the angle between the grid's vertices, cut at 3 sigma,
    as a sparse matrix (rows, columns, values); built once per width."""
    vertices = _grid_map(level).mesh.vertices
    cosines = vertices @ vertices.T
    rows, cols = np.nonzero(cosines > np.cos(min(3.0 * sigma, np.pi)))
    # exp((cos d - 1) / sigma^2) ~ exp(-d^2 / (2 sigma^2)) for small d.
    return rows, cols, np.exp((cosines[rows, cols] - 1.0) / (sigma * sigma))


class _Grid:
    """One icosphere with the points' barycentric weights on it."""

    def __init__(self, level: int, q: np.ndarray, weights: np.ndarray) -> None:
        grid = _grid_map(level)
        self.level = level
        self.n = len(grid.points)
        faces, bary, _ = grid.to_surface(q)
        self.corners = grid.mesh.faces[faces]
        self.bary = bary
        self.weighted = bary * weights[:, None]
        self.mass = self.spread(np.ones((len(q), 1)))[:, 0]

    def spread(self, values: np.ndarray) -> np.ndarray:
        index = self.corners.ravel()
        return np.stack([np.bincount(index, (self.weighted * values[:, k:k + 1]).ravel(), self.n)
                         for k in range(values.shape[1])], axis=1)

    def convolve(self, values: np.ndarray, sigma: float) -> np.ndarray:
        rows, cols, weights = _kernel(self.level, sigma)
        return np.stack([np.bincount(rows, weights * values[cols, k], self.n)
                         for k in range(values.shape[1])], axis=1)


class SphereSmoother:
    """Gaussian smoothing of fields given at sphere points ``q`` with ``weights``,
    read back at ``q`` or at other points (``read_at``): on an icosphere of
    level 3 for widths of at least :data:`FINE_WIDTH` radians, of level 4
    below (about four grid steps per width)."""

    def __init__(self, q: np.ndarray, weights: np.ndarray,
                 read_at: Optional[np.ndarray] = None) -> None:
        self.q = q
        self.weights = weights
        self.read_at = read_at
        self.grids: Dict[int, Tuple[_Grid, _Grid]] = {}

    def __call__(self, values: np.ndarray, sigma: float, *, at_read: bool = False) -> np.ndarray:
        level = 3 if sigma >= FINE_WIDTH else 4
        grids = self.grids.get(level)
        if grids is None:
            spread = _Grid(level, self.q, self.weights)
            read = spread if self.read_at is None else _Grid(level, self.read_at,
                                                             np.ones(len(self.read_at)))
            grids = self.grids[level] = (spread, read)
        spread, read = grids if at_read else (grids[0], grids[0])
        mass = spread.convolve(spread.mass[:, None], sigma)[:, 0]
        field = spread.convolve(spread.spread(values), sigma) / np.maximum(mass, 1e-300)[:, None]
        out: np.ndarray = np.einsum("ij,ijk->ik", read.bary, field[read.corners])
        return out


def _face_jacobians(m_b: SphereMap) -> np.ndarray:
    """Per face of B, the linear map from a displacement in its plane to the
    displacement of its chord triangle's point on the sphere."""
    v, f, s = m_b.mesh.vertices, m_b.mesh.faces, m_b.points
    edges = np.stack([v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]], axis=2)
    chords = np.stack([s[f[:, 1]] - s[f[:, 0]], s[f[:, 2]] - s[f[:, 0]]], axis=2)
    out: np.ndarray = chords @ np.linalg.pinv(edges)
    return out


def _frame(x: np.ndarray) -> Tuple[np.ndarray, float]:
    centre = x.mean(axis=0)
    c = x - centre
    scale = float(np.sqrt((c * c).sum(axis=1).mean()))
    return centre, scale if scale > 0 else 1.0


def warp(map_a: SphereMap, m_b: SphereMap, *, fixed: Optional[np.ndarray] = None,
         schedule: Sequence[Tuple[float, float, int]] = SCHEDULE,
         should_stop: Callable[[int, int], bool] = lambda done, total: False
         ) -> Tuple[SphereMap, Dict[str, Any]]:
    """Warp ``map_a`` (A's certified map, already in B's frame) onto B's map.

    ``fixed`` are A's vertices that do not move (landmarks already at their
    targets). ``should_stop(done, total)`` is asked after every step. Returns
    the warped, certified map and a record of the run (``steps``, and
    ``moved``: the mean fraction of the wanted move each step achieved).
    """
    a_centre, a_scale = _frame(map_a.mesh.vertices)
    b_centre, b_scale = _frame(m_b.mesh.vertices)
    n = len(map_a.points)
    # The moves are smooth at the narrowest width, so they are worked out on
    # an even sample of A's vertices (and the held ones) and read back at all.
    sample = np.unique(np.linspace(0, n - 1, min(n, SAMPLE)).astype(np.int64))
    if fixed is not None and len(fixed):
        sample = np.union1d(sample, fixed)
    a = (map_a.mesh.vertices[sample] - a_centre) / a_scale
    weights = _vertex_areas(map_a.mesh.vertices, map_a.mesh.faces)
    held = np.zeros(n, dtype=bool)
    if fixed is not None and len(fixed):
        held[fixed] = True
        weights[fixed] *= LANDMARK_WEIGHT
    weights, held_in_sample = weights[sample], held[sample]
    jacobians = _face_jacobians(m_b)
    faces_b, sphere_b = m_b.mesh.faces, m_b.points
    total = sum(steps for _, _, steps in schedule)
    done = 0
    moved = []
    current = map_a
    for bend_width, move_width, steps in schedule:
        smooth = SphereSmoother(current.points[sample], weights, read_at=current.points)
        for _ in range(steps):
            q = current.points
            face, bary, xyz = m_b.to_surface(q[sample])
            y = (xyz - b_centre) / b_scale
            aligned = a @ kabsch(a, y).T
            residual = y - aligned
            delta = smooth(residual, bend_width) - residual
            chord = np.einsum("ij,ijk->ik", bary, sphere_b[faces_b[face]])
            wanted = (_unit_rows(chord + np.einsum("ijk,ik->ij", jacobians[face], delta))
                      - q[sample])
            # Held vertices want no move and weigh heavily, so the moves
            # around a landmark taper to it instead of piling onto it.
            wanted[held_in_sample] = 0.0
            target = _unit_rows(q + smooth(wanted, move_width, at_read=True))
            current = _landmarks.move_towards(current, target, fixed=fixed, energy_sweeps=0)
            want = np.linalg.norm(target - q, axis=1)
            got = np.linalg.norm(current.points - q, axis=1)
            moved.append(float(got.sum() / max(float(want.sum()), 1e-300)))
            done += 1
            if should_stop(done, total):
                return current, {"steps": done, "moved": moved}
    return current, {"steps": done, "moved": moved}
