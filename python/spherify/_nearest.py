"""Closest points on a triangle mesh's surface, in numpy (registration's ICP).

:class:`NearestOnSurface` answers "which point of this surface is nearest to
each query point?" without a dependency beyond numpy (scipy's KD-tree is a
test-only extra). Two steps:

1. The nearest *vertex*, by a uniform grid of cubic cells: a query's nearest
   vertex within distance ``h`` lies in the 27 cells around the query's own,
   so a query whose best candidate there is within ``h`` is settled. The rest
   are asked again on a grid three times coarser, and so on; a query the
   coarsest grid (about the mesh's size) leaves unsettled, far outside the
   mesh's box, is compared with every vertex. Cells
   are keyed by one integer and found by binary search in the sorted keys,
   so the cost is O((q + n) log n) whatever the shape's extent.
2. The nearest point on the faces around that vertex (Ericson 2005,
   "Real-Time Collision Detection", 5.1.5: the closest point of a triangle
   by its Voronoi regions). The true closest point of the surface lies on
   such a face unless a face far from every vertex passes closer, which on
   the meshes registration sees (edges short against the shape) moves the
   answer by a fraction of an edge.
"""

from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np

__all__ = ["NearestOnSurface", "closest_on_triangles"]

# Grid steps, coarse over fine: each level settles the queries farther from
# the surface than the level before could.
COARSER = 3.0
# Queries handled at once (memory: about 27 * cell occupancy candidates each).
CHUNK = 20000
# The largest grid given a table of cells (8 bytes a cell).
TABLE_CELLS = 1 << 22


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
                         ) -> Tuple[np.ndarray, np.ndarray]:
    """The closest point of triangle (a_i, b_i, c_i) to p_i, row by row.

    Returns the barycentric weights (k, 3) on (a, b, c) and the points (k, 3):
    Ericson's Voronoi-region test, vectorised (a degenerate triangle gets
    the closest of its vertices and edges through the same tests)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    k = len(p)
    w = np.zeros((k, 3))
    done = np.zeros(k, dtype=bool)

    def settle(mask: np.ndarray, weights: np.ndarray) -> None:
        mask = mask & ~done
        w[mask] = weights[mask]
        done[mask] = True

    one, zero = np.ones(k), np.zeros(k)
    with np.errstate(divide="ignore", invalid="ignore"):
        settle((d1 <= 0) & (d2 <= 0), np.stack([one, zero, zero], 1))
        settle((d3 >= 0) & (d4 <= d3), np.stack([zero, one, zero], 1))
        settle((d6 >= 0) & (d5 <= d6), np.stack([zero, zero, one], 1))
        t = d1 / (d1 - d3)
        settle((vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t, t, zero], 1))
        t = d2 / (d2 - d6)
        settle((vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t, zero, t], 1))
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        settle((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), np.stack([zero, 1 - t, t], 1))
        total = va + vb + vc
        v, u = vb / total, vc / total
        inside = np.stack([1 - v - u, v, u], 1)
    inside[~np.isfinite(inside).all(axis=1)] = 1.0 / 3.0
    settle(np.ones(k, dtype=bool), inside)
    points = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    return w, points


class _Grid:
    """B's vertices sorted by the key of their cell of side ``h``."""

    def __init__(self, vertices: np.ndarray, origin: np.ndarray, h: float) -> None:
        self.origin, self.h = origin, h
        cells = np.floor((vertices - origin) / h).astype(np.int64)
        # Cells are at least -1 (queries may lie a little outside the box)
        # and below `span`, so one integer names each.
        self.span = int(cells.max()) + 3
        keys = self._keys(cells)
        self.order = np.argsort(keys, kind="stable")
        self.keys = keys[self.order]
        # Where the grid is small enough, a table from every cell's key to its
        # first vertex replaces the binary searches (half the query time).
        self.table: Optional[np.ndarray] = None
        if self.span ** 3 <= TABLE_CELLS:
            self.table = np.searchsorted(self.keys, np.arange(self.span ** 3 + 1))

    def _keys(self, cells: np.ndarray) -> np.ndarray:
        c = cells + 1
        out: np.ndarray = (c[:, 0] * self.span + c[:, 1]) * self.span + c[:, 2]
        return out

    def candidates(self, queries: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """(query row, vertex id) for every vertex in the 27 cells around each query."""
        cells = np.floor((queries - self.origin) / self.h).astype(np.int64)
        inside = ((cells >= -1) & (cells <= self.span - 2)).all(axis=1)
        rows_out: List[np.ndarray] = []
        ids_out: List[np.ndarray] = []
        offsets = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1]), -1).reshape(-1, 3)
        rows = np.flatnonzero(inside)
        for offset in offsets:
            neighbour = cells[rows] + offset
            ok = ((neighbour >= -1) & (neighbour <= self.span - 2)).all(axis=1)
            keys = self._keys(neighbour[ok])
            if self.table is not None:
                lo, hi = self.table[keys], self.table[keys + 1]
            else:
                lo = np.searchsorted(self.keys, keys, "left")
                hi = np.searchsorted(self.keys, keys, "right")
            counts = hi - lo
            if not counts.any():
                continue
            which = np.repeat(rows[ok], counts)
            starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
            rows_out.append(which)
            ids_out.append(self.order[starts + np.arange(len(which))])
        if not rows_out:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        return np.concatenate(rows_out), np.concatenate(ids_out)


class NearestOnSurface:
    """Closest points of one triangle mesh's surface to many query points.

    Build once per mesh (O(n log n)); each :meth:`__call__` is
    O(q log n) for q queries near the surface.

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        extent = float((hi - lo).max()) or 1.0
        edges = self.vertices[self.faces[:, 1]] - self.vertices[self.faces[:, 0]]
        # About one vertex per cell near the surface: the mean edge length.
        h = max(float(np.linalg.norm(edges, axis=1).mean()), extent * 1e-6)
        origin = lo - h
        self.grids = []
        while True:
            self.grids.append(_Grid(self.vertices, origin, h))
            if h > 2.0 * extent:
                break
            h *= COARSER
        # Faces around each vertex, as ranges of one array.
        corner_vertex = self.faces.ravel()
        order = np.argsort(corner_vertex, kind="stable")
        self.vertex_faces = order // 3
        self.first = np.searchsorted(corner_vertex[order], np.arange(len(self.vertices) + 1))

    def nearest_vertices(self, queries: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """The nearest vertex of the mesh to each query and its distance."""
        q = len(queries)
        best = np.full(q, -1, dtype=np.int64)
        distance = np.full(q, np.inf)
        todo = np.arange(q)
        for grid in self.grids:
            if not len(todo):
                break
            for start in range(0, len(todo), CHUNK):
                part = todo[start:start + CHUNK]
                rows, ids = grid.candidates(queries[part])
                if not len(rows):
                    continue
                d = np.linalg.norm(queries[part][rows] - self.vertices[ids], axis=1)
                found, vertex, d_min = _smallest(rows, d, ids)
                found = part[found]
                better = d_min < distance[found]
                distance[found[better]] = d_min[better]
                best[found[better]] = vertex[better]
            # Settled: a vertex within this grid's step was found, so no vertex
            # outside the 27 cells can be nearer.
            todo = todo[~(distance[todo] <= grid.h)]
        # Queries farther outside the mesh's box than the coarsest grid
        # reaches: every vertex, a few queries at a time (rare: the deformed
        # shape stays near the surface it is fitted to).
        for start in range(0, len(todo), 64):
            part = todo[start:start + 64]
            d = np.linalg.norm(queries[part][:, None, :] - self.vertices[None, :, :], axis=2)
            best[part] = np.argmin(d, axis=1)
            distance[part] = d[np.arange(len(part)), best[part]]
        return best, distance

    def __call__(self, queries: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest surface points: (face ids (q,), barycentric weights (q, 3),
        points (q, 3)), on the faces around each query's nearest vertex."""
        queries = np.ascontiguousarray(queries, dtype=np.float64)
        vertex, _ = self.nearest_vertices(queries)
        lo, hi = self.first[vertex], self.first[vertex + 1]
        counts = hi - lo
        rows = np.repeat(np.arange(len(queries)), counts)
        starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
        faces = self.vertex_faces[starts + np.arange(len(rows))]
        corners = self.faces[faces]
        v = self.vertices
        bary, points = closest_on_triangles(queries[rows], v[corners[:, 0]], v[corners[:, 1]],
                                            v[corners[:, 2]])
        d = np.linalg.norm(points - queries[rows], axis=1)
        _, pick, _ = _smallest(rows, d, np.arange(len(rows)))
        return faces[pick], bary[pick], points[pick]


def _smallest(rows: np.ndarray, d: np.ndarray, items: np.ndarray
              ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each distinct row: the row, the item of its smallest ``d`` and
    that distance (a scatter-min, O(k), instead of sorting the candidates)."""
    top = int(rows.max()) + 1 if len(rows) else 0
    smallest = np.full(top, np.inf)
    np.minimum.at(smallest, rows, d)
    hit = np.flatnonzero(d == smallest[rows])
    # Ties: the last hit of a row wins, any of them is nearest.
    item = np.full(top, -1, dtype=np.int64)
    item[rows[hit]] = items[hit]
    found = np.flatnonzero(item >= 0)
    return found, item[found], smallest[found]
