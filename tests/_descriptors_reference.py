"""The descriptor pairs in numpy: session 10's spherify._descriptors
(branch s10-regacc, f050f15), kept as the reference the core's
(spherify_mesh::surface_heights, feature_nearest, cell_grid) is tested
against in test_descriptors.py: the same samples to the bit, the heights to
the last bits of exp, the same pairs."""

from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

# Subdivisions of a face along an edge, at most (a face longer than this
# many sampling spacings is sampled more coarsely than the rest).
MAX_SPLIT = 64
# Only the surface facing the query's way counts (not the far side of a
# thin part, nor a neighbouring part facing back).
SAME_SIDE = True
# The 27 cells around a cell (itself included).
_OFFSETS = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
                    axis=-1).reshape(-1, 3).astype(np.int64)
# The sampling spacing of the surface around a query, over the scale r.
SOURCE_SPACING = 0.75


class Grid:
    """Points sorted by the cell of a uniform grid (side ``cell``), for
    all pairs of a query and a point in the 27 cells around the query's."""

    def __init__(self, points: np.ndarray, cell: float) -> None:
        self.cell = float(cell)
        at = np.floor(points / self.cell).astype(np.int64)
        # One cell of margin on every side, so a neighbour cell of a query
        # inside the box has a key.
        self.low = at.min(axis=0) - 1
        self.dims = at.max(axis=0) - self.low + 2
        keys = self._key(at)
        self.order = np.argsort(keys, kind="stable")
        self.keys, self.starts, self.counts = np.unique(keys[self.order], return_index=True,
                                                        return_counts=True)

    def _key(self, at: np.ndarray) -> np.ndarray:
        shifted = at - self.low
        out: np.ndarray = (shifted[:, 0] * self.dims[1] + shifted[:, 1]) * self.dims[2] + shifted[:, 2]
        return out

    def pairs(self, queries: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """(query rows, point rows) of every point in the 27 cells around
        each query's cell: every point within ``cell`` of a query is among
        them. Ordered by query, then neighbour cell, then point."""
        at = np.floor(queries / self.cell).astype(np.int64)
        near = at[:, None, :] + _OFFSETS[None, :, :]
        inside = ((near >= self.low + 1) & (near < self.low + self.dims - 1)).all(axis=2)
        key = self._key(np.where(inside[:, :, None], near, self.low).reshape(-1, 3))
        pos = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
        hit = inside.ravel() & (self.keys[pos] == key)
        c = np.where(hit, self.counts[pos], 0)
        s = np.where(hit, self.starts[pos], 0)
        total = int(c.sum())
        first = np.repeat(np.cumsum(c) - c, c)
        points = self.order[np.repeat(s, c) + np.arange(total, dtype=np.int64) - first]
        rows = np.repeat(np.arange(len(queries), dtype=np.int64), len(_OFFSETS))
        return np.repeat(rows, c), points


class Surface:
    """A triangle surface ready to be sampled at several spacings
    (:meth:`samples`): its faces' corners, outward cross products, areas,
    centroids and longest edges, made once."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.corners = vertices[faces]
        c = self.corners
        lengths = np.stack([((c[:, 1] - c[:, 0]) ** 2).sum(1), ((c[:, 2] - c[:, 1]) ** 2).sum(1),
                            ((c[:, 0] - c[:, 2]) ** 2).sum(1)], axis=1)
        self.longest = np.sqrt(lengths.max(axis=1))
        cross = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        # Outwards, as spherify._nricp's normals (a mesh may come turned in).
        if float((cross * c[:, 0]).sum()) < 0:
            cross = -cross
        self.cross = cross
        self.area = 0.5 * np.linalg.norm(cross, axis=1)
        self.centroid = c.mean(axis=1)

    def samples(self, spacing: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points of the surface, their areas and unit outward normals,
        about ``spacing`` apart: each face split into m^2 equal
        sub-triangles (m the longest edge over ``spacing``, rounded up, at
        most :data:`MAX_SPLIT`), each represented by its centroid, then
        lumped into grid cells of side ``spacing`` (areas summed;
        area-weighted centroids and normals). O(area / spacing^2 + faces)."""
        split = np.clip(np.ceil(self.longest / spacing), 1, MAX_SPLIT).astype(np.int64)
        whole = split == 1
        points, weights, normals = [self.centroid[whole]], [self.area[whole]], [self.cross[whole]]
        for m in np.unique(split[~whole]):
            chosen = np.flatnonzero(split == m)
            # The centroids of a face's m^2 sub-triangles, in barycentric
            # coordinates (1 - u - v, u, v): the upright ones at (i + 1/3,
            # j + 1/3) / m with i + j <= m - 1, the turned ones at
            # (i + 2/3, j + 2/3) / m with i + j <= m - 2.
            i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
            up = i + j <= m - 1
            down = i + j <= m - 2
            u = np.concatenate([(i[up] + 1 / 3) / m, (i[down] + 2 / 3) / m])
            v = np.concatenate([(j[up] + 1 / 3) / m, (j[down] + 2 / 3) / m])
            bary = np.stack([1.0 - u - v, u, v], axis=1)
            points.append(np.einsum("sk,fkc->fsc", bary, self.corners[chosen]).reshape(-1, 3))
            weights.append(np.repeat(self.area[chosen] / (m * m), len(bary)))
            normals.append(np.repeat(self.cross[chosen] / (m * m), len(bary), axis=0))
        p, w, n = np.concatenate(points), np.concatenate(weights), np.concatenate(normals)
        at = np.floor(p / spacing).astype(np.int64)
        at -= at.min(axis=0)
        span = at.max(axis=0) + 1
        _, cell = np.unique((at[:, 0] * span[1] + at[:, 1]) * span[2] + at[:, 2],
                            return_inverse=True)
        cell = cell.ravel()
        total = np.bincount(cell, w)
        lumped = (np.stack([np.bincount(cell, w * p[:, c]) for c in range(3)], axis=1)
                  / np.where(total > 0, total, 1.0)[:, None])
        summed = np.stack([np.bincount(cell, n[:, c]) for c in range(3)], axis=1)
        length = np.linalg.norm(summed, axis=1)
        keep = (total > 0) & (length > 0)
        return lumped[keep], total[keep], summed[keep] / length[keep, None]


def surface_samples(vertices: np.ndarray, faces: np.ndarray,
                    spacing: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`Surface.samples` of the surface (vertices, faces)."""
    return Surface(vertices, faces).samples(spacing)


def heights(surface: Surface, queries: np.ndarray, normals: np.ndarray,
            scales: Sequence[float]) -> np.ndarray:
    """The module doc's h_r at ``queries`` (points of ``surface``, with
    their unit outward ``normals``) for each r of ``scales``: (queries,
    scales), the surface sampled :data:`SOURCE_SPACING` r apart. A query
    whose neighbourhood is empty gets 0."""
    out = np.zeros((len(queries), len(scales)))
    n = len(queries)
    for k, r in enumerate(scales):
        points, area, facing = surface.samples(SOURCE_SPACING * r)
        q, p = Grid(points, 2.0 * r).pairs(queries)
        # h = sum_p w_p n_q . (q - p) / sum_p w_p, one coordinate at a time.
        d2 = np.zeros(len(q))
        along = np.zeros(len(q))
        agree = np.zeros(len(q))
        for c in range(3):
            gap = queries[:, c][q] - points[:, c][p]
            d2 += gap * gap
            along += normals[:, c][q] * gap
            agree += normals[:, c][q] * facing[:, c][p]
        # Only the pairs within the cut (and on the same side) count; the
        # others would add zeros, so leaving them out keeps every sum's bits.
        inside = d2 <= 4.0 * r * r
        if SAME_SIDE:
            inside &= agree > 0.0
        q, d2, along = q[inside], d2[inside], along[inside]
        w = area[p[inside]] * np.exp(d2 * (-0.5 / (r * r)))
        total = np.bincount(q, w, n)
        found = total > 0
        out[found, k] = np.bincount(q, w * along, n)[found] / total[found]
    return out


class DescriptorPairs:
    """Candidates on B (points with descriptors), and for points near B the
    candidate nearest in position and descriptor: the minimiser over the
    candidates c_j of

        |x - c_j|^2 + weight^2 |d(x) - d_j|^2,

    with the descriptors scaled by their spread over the candidates, beside
    the candidate nearest in position alone. Exact where that minimum is at
    most ``reach`` (every candidate nearer in space is in the grid's cells
    around x); elsewhere not certain."""

    def __init__(self, points: np.ndarray, descriptors: np.ndarray, weight: float,
                 reach: float) -> None:
        spread = descriptors.std(axis=0)
        self.unit = np.where(spread > 0, spread, 1.0)
        self.weight = float(weight)
        self.points = points
        self.features = self.weight * descriptors / self.unit
        self.reach = float(reach)
        self.grid = Grid(points, self.reach)

    def __call__(self, x: np.ndarray,
                 descriptors: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(best candidate, nearest candidate in position, whether both are
        certain) per row of ``x``; ``descriptors`` are the rows' own
        (unscaled) descriptors."""
        features = self.weight * descriptors / self.unit
        q, p = self.grid.pairs(x)
        near = np.zeros(len(q))
        for c in range(3):
            gap = x[:, c][q] - self.points[:, c][p]
            near += gap * gap
        # A pair farther than the reach in space is farther in both measures:
        # it cannot be a certain answer.
        within = near <= self.reach ** 2
        q, p, near = q[within], p[within], near[within]
        both = near.copy()
        for c in range(features.shape[1]):
            gap = features[:, c][q] - self.features[:, c][p]
            both += gap * gap
        best, value = _smallest(q, p, both, len(x))
        plain, gap = _smallest(q, p, near, len(x))
        certain = (value <= self.reach ** 2) & (gap <= self.reach ** 2)
        return best, plain, certain


def _smallest(q: np.ndarray, p: np.ndarray, value: np.ndarray,
              n: int) -> Tuple[np.ndarray, np.ndarray]:
    """Per query row (0..n-1; ``q`` grouped by row, as :meth:`Grid.pairs`
    gives them), the point of the smallest value (ties to the first pair)
    and that value; -1 and inf where a row has no pair."""
    per = np.bincount(q, minlength=n)
    has = per > 0
    smallest = np.full(n, np.inf)
    best = np.full(n, -1, dtype=np.int64)
    if not len(q):
        return best, smallest
    smallest[has] = np.minimum.reduceat(value, (np.cumsum(per) - per)[has])
    at = np.flatnonzero(value == smallest[q])
    first = np.ones(len(at), dtype=bool)
    first[1:] = q[at[1:]] != q[at[:-1]]
    best[q[at[first]]] = p[at[first]]
    return best, smallest
