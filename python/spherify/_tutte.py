"""2D Tutte embedding of a disk (thesis ch. 4)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Union

import numpy as np

from . import _args, _core
from ._errors import SpherifyWarning
from ._mesh import MeshLike, _as_vertices, as_mesh


@dataclass(frozen=True)
class TutteInfo:
    """How a Tutte embedding was computed, and its certificate.

    Attributes
    ----------
    solver : str
        The solver that ran ("direct", "cg_ic0", "cg_jacobi", "gauss_seidel").
    iterations : int
        Iterations of the slowest coordinate (0 for the direct solver).
    residual : float
        Final relative residual ``|b - A x| / |b|``, the worse of x and y.
    seconds : float
        Time spent in the solver.
    boundary : (k,) int64
        The boundary loop, counter-clockwise, in the order its points were placed.
    flipped_faces, degenerate_faces : (j,) int64
        Faces that are clockwise, or of exactly zero area, in the plane, decided
        with an exact orientation predicate. Empty for a valid embedding.
    negative_weights : int
        Number of negative (directed) edge weights; only cotangent weights have any.
    """

    solver: str
    iterations: int
    residual: float
    seconds: float
    boundary: np.ndarray
    flipped_faces: np.ndarray
    degenerate_faces: np.ndarray
    negative_weights: int

    @property
    def valid(self) -> bool:
        """No flipped and no degenerate triangle: a straight-line embedding."""
        return len(self.flipped_faces) == 0 and len(self.degenerate_faces) == 0


def boundary_loop(mesh: MeshLike) -> np.ndarray:
    """The boundary loop of a disk-topology mesh.

    Returns
    -------
    (k,) int64
        Boundary vertex ids in counter-clockwise order (the direction of the
        faces' boundary edges), starting at the smallest id.

    Raises
    ------
    TopologyError
        The mesh is not a consistently oriented manifold disk (exactly one
        boundary loop and Euler characteristic 1, thesis Cor. 2.7).
    """
    return _core.boundary_loop(as_mesh(mesh)._core)


def tutte(mesh: MeshLike, *, weights: str = "uniform", rho: float = 1.0,
          boundary: Union[str, Any] = "circle", solver: str = "auto", tol: float = 1e-10,
          max_iter: int = 10_000, return_info: bool = False) -> Any:
    """Embed a disk in the plane with Tutte's method (thesis 4.3).

    The boundary loop is pinned to a convex polygon and each interior vertex is
    the weighted average of its neighbours, sum_j w_ij (u_i - u_j) = 0.

    Parameters
    ----------
    mesh : Mesh
        A topological disk: one boundary loop, V - E + F = 1, consistently oriented.
    weights : {"uniform", "chord", "mean_value", "cotangent"}
        Tutte's uniform weights (eq. 4.45); chord-length weights
        ``|x_i - x_j| ** rho`` (eq. 4.46-4.48); Floater's mean-value weights
        ``(tan(a/2) + tan(b/2)) / |x_i - x_j|``; cotangent weights
        ``(cot a + cot b) / 2``, which can be negative: then no embedding is
        guaranteed and a :class:`SpherifyWarning` is issued.
    rho : float
        Exponent of the chord-length weights.
    boundary : "circle", "circle_length" or (k, 2) array_like
        Equal spacing on the unit circle (eq. 4.22), spacing by boundary edge
        length, or your own convex counter-clockwise polygon with one point per
        vertex of :func:`boundary_loop`, in that order (collinear points on a
        side are allowed). A polygon that is not convex raises :class:`MeshError`.
    solver : {"auto", "direct", "cg", "cg_jacobi", "gauss_seidel"}
        "auto" picks the fastest measured solver (a sparse Cholesky or LU);
        "cg" is conjugate gradients with IC(0); "gauss_seidel" is thesis 4.5.
    tol, max_iter : float, int
        Relative residual and iteration limit of the iterative solvers. Running
        out raises :class:`ConvergenceError` whose ``state["uv"]`` is the last iterate.
    return_info : bool
        Also return a :class:`TutteInfo`.

    Returns
    -------
    uv : (n, 2) float64
        One point per vertex; boundary vertices exactly on the polygon. With
        ``return_info=True``, ``(uv, info)``.

    Notes
    -----
    The x and y systems share one matrix and are solved together (one
    factorisation). After solving, every triangle is checked with an exact 2D
    orientation predicate; flipped or degenerate triangles (possible with
    cotangent weights, or where double precision runs out) are listed in
    ``info`` and reported with a :class:`SpherifyWarning`. The heavy work runs
    without the GIL. Cost: about O(n^1.5) for the direct solver on meshes.
    """
    mesh = as_mesh(mesh)
    rho, tol = _args.real(rho, "rho"), _args.real(tol, "tol")
    max_iter = _args.integer(max_iter, "max_iter")
    if isinstance(boundary, str):
        uv, raw = _core.tutte(mesh._core, weights, rho, boundary, None, solver, tol,
                              max_iter)
    else:
        polygon = _as_vertices(boundary, "boundary polygon")
        uv, raw = _core.tutte(mesh._core, weights, rho, "polygon", polygon, solver, tol,
                              max_iter)
    info = TutteInfo(**raw)
    if info.negative_weights:
        warnings.warn(
            f"{info.negative_weights} edge weights are negative (cotangent weights on obtuse "
            f"triangles): Tutte's theorem does not apply; {len(info.flipped_faces)} faces flipped, "
            f"{len(info.degenerate_faces)} degenerate", SpherifyWarning, stacklevel=2)
    elif not info.valid:
        warnings.warn(
            f"the embedding has {len(info.flipped_faces)} flipped and "
            f"{len(info.degenerate_faces)} degenerate triangles: double precision could not "
            f"hold it", SpherifyWarning, stacklevel=2)
    return (uv, info) if return_info else uv
