"""Where a point sits on a surface, beyond where it is: the non-rigid ICP's descriptor pairs.

The closest points of B's surface hold each point of the deformed A
tangentially where the last fit put it, so on a smooth surface a slide of
the start survives the ICP (igea's bust: docs/correspondence.md, "Session
10: igea and Möbius"). A descriptor of the surface around a point that a
smooth bend barely changes tells the ICP which way along the surface a point
belongs: the pairs are then the nearest points of B in position *and*
descriptor, as colored ICP pairs points in position and colour (Johnson and
Kang 1999, "Registration and integration of textured 3D data"; Park, Zhou
and Koltun 2017, "Colored point cloud registration revisited"), and as
feature-augmented ICP (Sharp, Lee and Wehe 2002, "ICP registration using
invariant features") appends invariant features to the coordinates with a
weight.

The descriptor is the surface's **height** over its neighbourhood at a few
scales r (fractions of the shape's rms radius): for a point q with unit
outward normal n,

    h_r(q) = n . (q - c_r(q)),   c_r(q) = the area-weighted mean of the surface
                                           around q, with Gaussian weights
                                           exp(-|x - q|^2 / 2 r^2) out to 2 r,

a difference-of-Gaussians (smoothed mean curvature times r^2 to first
order): positive on a bump such as a nose, negative in a hollow such as an
eye socket, zero on flat or evenly curved parts. It is the same on two
meshes of the same surface whatever their resolution: the surface is
sampled by points of known area (faces larger than the sampling spacing
split into equal sub-triangles) and the samples are lumped into cells of
r / 2 (their area summed, their area-weighted centroid kept), so a scan of
134k vertices and a 112-vertex control mesh cost alike and estimate the
same integral.

The sums and searches run in the core (``spherify_mesh::surface_heights``,
``feature_nearest``, on a uniform grid, every sum and minimum in a fixed
order, so the bits do not depend on threads); session 10's numpy version,
which they follow operation for operation (the same values up to the last
bits of ``exp``), is the reference of ``tests/test_descriptors.py``.
"""

from __future__ import annotations

from typing import Optional, Sequence, Tuple

import numpy as np

from . import _core

__all__ = ["DescriptorPairs", "Surface", "heights", "surface_samples"]

# The sampling spacing of the surface around a query, over the scale r.
SOURCE_SPACING = 0.75


class Surface:
    """A triangle surface (V (n, 3) float64, F (m, 3) int64) ready to be
    sampled at several spacings (:meth:`samples`) and to give heights
    (:func:`heights`): its faces' corners, outward cross products, areas,
    centroids and longest edges, made once in the core (the whole surface
    turned out if its signed volume is negative)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.core = _core.CoreSampledSurface(np.ascontiguousarray(vertices, dtype=np.float64),
                                             np.ascontiguousarray(faces, dtype=np.int64))

    def samples(self, spacing: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points of the surface (k, 3), their areas (k,) and unit outward
        normals (k, 3), about ``spacing`` apart: each face split into m^2
        equal sub-triangles (m the longest edge over ``spacing``, rounded
        up, at most 64: the core's ``MAX_SPLIT``), each represented by its centroid,
        then lumped into grid cells of side ``spacing`` (areas summed;
        area-weighted centroids and normals). O(area / spacing^2 + faces)."""
        points, area, normals, _ = self.core.samples(float(spacing))
        return points, area, normals

    def samples_on_faces(self, spacing: float
                         ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`samples` and a face near each point (k,) int64 (the face
        of the first sub-triangle lumped into its cell: a closest-point
        search's hint)."""
        out: Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = \
            self.core.samples(float(spacing))
        return out


def surface_samples(vertices: np.ndarray, faces: np.ndarray,
                    spacing: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`Surface.samples` of the surface (vertices, faces)."""
    return Surface(vertices, faces).samples(spacing)


def heights(surface: Surface, queries: np.ndarray, normals: np.ndarray,
            scales: Sequence[float]) -> np.ndarray:
    """The module doc's h_r at ``queries`` ((q, 3), points of ``surface``,
    with their unit outward ``normals``) for each r of ``scales``: (q,
    scales) float64, the surface sampled :data:`SOURCE_SPACING` r apart. A
    query whose neighbourhood is empty gets 0. O(q x the samples within 2r),
    on the core's threads."""
    out: np.ndarray = surface.core.heights(np.ascontiguousarray(queries, dtype=np.float64),
                                           np.ascontiguousarray(normals, dtype=np.float64),
                                           [float(r) for r in scales], SOURCE_SPACING)
    return out


class DescriptorPairs:
    """Candidates on B (points with descriptors), and for points near B the
    candidate nearest in position and descriptor: the minimiser over the
    candidates c_j of

        |x - c_j|^2 + weight^2 |d(x) - d_j|^2,

    with the descriptors scaled by their spread over the candidates, beside
    the candidate nearest in position alone. Exact where that minimum is at
    most ``reach`` (every candidate nearer in space is in the grid's cells
    around x); elsewhere not certain. The search is the core's
    (``spherify_mesh::feature_nearest``)."""

    def __init__(self, points: np.ndarray, descriptors: np.ndarray, weight: float,
                 reach: float, faces: Optional[np.ndarray] = None) -> None:
        spread = descriptors.std(axis=0)
        self.unit = np.where(spread > 0, spread, 1.0)
        self.weight = float(weight)
        self.points = points
        # A face of B near each candidate, if known (a search's hint).
        self.faces = faces
        self.features = self.weight * descriptors / self.unit
        self.reach = float(reach)
        self.core = _core.CoreFeatureNearest(np.ascontiguousarray(points, dtype=np.float64),
                                             np.ascontiguousarray(self.features), self.reach)

    def __call__(self, x: np.ndarray,
                 descriptors: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(best candidate, nearest candidate in position, whether both are
        certain) per row of ``x``; ``descriptors`` are the rows' own
        (unscaled) descriptors."""
        features = np.ascontiguousarray(self.weight * descriptors / self.unit)
        best, plain, certain = self.core.nearest(np.ascontiguousarray(x, dtype=np.float64),
                                                 features)
        return best, plain, certain
