"""SphereMap: the result of :func:`spherify.embed`."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

from . import _core
from ._errors import MeshError
from ._mesh import Mesh, check_sphere
from ._report import SphereReport


class SphereMap:
    """Points on the unit sphere, one per vertex, and the verdict on them.

    Attributes
    ----------
    mesh : Mesh
        The (consistently, outward oriented) mesh the map belongs to.
    points : (n, 3) float64
        One point on the unit sphere per input vertex, in the input's order.
    method : str
        The method that made the map.
    iterations : int
        Iterations of an iterative method (0 for direct methods).
    converged : bool
        Whether the method reached its own stopping criterion.
    status : str
        ``"converged"``, ``"direct"``, ``"max_iterations"`` or ``"collapsed"``.
    message : str
        Why the method stopped, in words.
    seconds : dict of str to float
        Time per stage.
    report : SphereReport
        The exact validity verdict of thesis 3.4 on ``points``.
    notes : list of str
        What was done to the input on the way (e.g. faces reoriented).

    Theta-phi maps (``method="theta_phi"``) also have

    poles : (int, int)
        The north and south pole vertex ids (thesis 6.2).
    cut_path : (k + 2,) int64
        The path the mesh was cut open along, from north to south pole.
    cut_mesh : Mesh
        The mesh cut open into a disk (thesis 6.3): the input's vertices, then
        one duplicate per inner path vertex; ``cut_original`` maps each of its
        vertices to the input vertex it stands for.
    theta_phi : (n + k, 2) float64
        The (theta, phi) embedding of ``cut_mesh`` in the rectangle
        [0, pi] x [0, 2 pi] (thesis 6.4).
    tp_valid : bool
        The rectangle embedding has no flipped and no zero-area triangle under
        exact predicates: the thesis's bijectivity guarantee, checked in
        floating point. False means double precision could not hold it.
    details : dict
        Refinement steps, pole-fan monotonicity and re-embedding (6.5.1), the
        thinnest triangle relative to the rectangle, and the rectangle's
        flipped / collapsed triangle ids. With ``poles="symmetry"`` also
        ``details["symmetry"]`` (thesis 6.2.5), a dict with

        * ``normals`` (3, 3) float64: unit normals of the three principal
          planes, by ascending ``variances`` (area-weighted variance of the
          face centroids across each plane); ``centre``: the area-weighted
          centroid m (eq. 6.11) all three pass through;
        * ``signed_sums`` (D of eq. 6.18), ``balances`` (|D| / sum |d|),
          ``skews`` (|sum w d^3| / sum w |d|^3) and ``scores`` (the larger of
          the two; 0 for a mirror plane), one per plane;
        * ``chosen`` (index of the best plane or None), its ``normal`` and
          ``score``;
        * ``eps`` (band half-width used), ``band`` (vertices within it),
          ``component`` (vertices in its largest connected piece),
          ``symmetry_poles`` (the poles found in it, or None), ``spread``
          (the length of the path between them inside the piece over the
          fast-graph pole distance; NaN when not reached);
        * ``fallback``: None when the poles and cut path came from the plane,
          else why the fast-graph poles were used instead.

    Every map also has ``to_sphere`` (the map h from surface points to the
    sphere) and ``to_surface`` (its inverse), see below.
    """

    def __init__(self, mesh: Mesh, points: np.ndarray, method: str, info: Dict[str, Any],
                 notes: List[str]) -> None:
        self.mesh = mesh
        self.points = points
        self.points.flags.writeable = False
        self.method = method
        self.iterations = int(info.get("iterations", 0))
        self.converged = bool(info.get("converged", True))
        self.status = str(info.get("status", "direct"))
        self.message = str(info.get("message", ""))
        self.seconds: Dict[str, float] = dict(info.get("seconds", {}))
        self.notes = list(notes)
        self.report: SphereReport = check_sphere(mesh, points)
        self._point_map: Optional[_core.CorePointMap] = None
        if "theta_phi" in info:
            self.poles = tuple(int(p) for p in info["poles"])
            self.cut_path = info["cut_path"]
            self.theta_phi = info["theta_phi"]
            self._cut_arrays = (info["cut_vertices"], info["cut_faces"])
            self._cut_mesh: Optional[Mesh] = None
            self.cut_original = info["cut_original"]
            self.tp_valid = bool(info["tp_valid"])
            self.details = {key: info[key] for key in (
                "refinements", "re_embedded", "fans_monotone", "min_area_ratio",
                "tp_flipped_faces", "tp_degenerate_faces", "cut_boundary")}
            if "symmetry" in info:
                self.details["symmetry"] = info["symmetry"]

    def _points_map(self) -> _core.CorePointMap:
        """The point-location structure, built on first use (O(F log F))."""
        if self._point_map is None:
            if self.method == "theta_phi":
                self._point_map = _core.point_map_theta_phi(
                    self.mesh._core, self.cut_mesh.faces, self.theta_phi, self.poles,
                    self.tp_valid)
            else:
                self._point_map = _core.point_map_gc(
                    self.mesh._core, self.points, self.valid, self.flipped)
        return self._point_map

    def to_sphere(self, face_ids: npt.ArrayLike, bary: npt.ArrayLike) -> np.ndarray:
        """Map surface points to the sphere: the homeomorphism h.

        For theta-phi maps this is the thesis's own bijection (6.6): the
        barycentric map into the theta-phi rectangle (h1), the stretch of the
        pole triangles onto the rectangle's top and bottom lines (h2, eq.
        6.44-6.56) and the fold onto the sphere (h3, eq. 6.35). It is a
        bijection whenever ``tp_valid`` holds, even when the folded vertices do
        not form a valid GC-embedding. For the other methods it is the
        barycentric map of thesis 3.3: the same weights of the sphere
        triangle's corners, projected onto the sphere (a bijection when
        ``valid``).

        Parameters
        ----------
        face_ids : (k,) int
            A face of ``mesh`` per point.
        bary : (k, 3) float
            Barycentric weights on that face's corners (in the order of
            ``mesh.faces``): finite, >= 0 and summing to 1 (within 1e-6; they
            are rescaled).

        Returns
        -------
        (k, 3) float64
            Unit vectors.

        Raises
        ------
        MeshError
            Wrong shapes, a face id out of range or bad weights (the row is named).
        """
        ids = np.asarray(face_ids)
        if ids.dtype.kind not in "iu":
            raise MeshError(f"face_ids must be integers, got dtype {ids.dtype}")
        return self._points_map().to_sphere(ids.astype(np.int64, copy=False),
                                            _float_rows(bary, "bary"))

    def to_surface(self, points: npt.ArrayLike) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Map points of the unit sphere back to the surface: h^-1.

        Each point is located among the cells of the map (a box tree; O(log F)
        per point, in parallel), then the inverse of :meth:`to_sphere` gives
        the face and its barycentric weights. Points on an edge or a vertex
        get one of the faces that share it.

        Parameters
        ----------
        points : (k, 3) float
            Unit vectors (norm within 1e-6 of 1; they are normalised).

        Returns
        -------
        face_ids : (k,) int64
        bary : (k, 3) float64
            Barycentric weights on the face's corners, >= 0, summing to 1.
        xyz : (k, 3) float64
            The surface points themselves.

        Raises
        ------
        MapError
            The map is not a certified bijection (``tp_valid`` False for
            theta-phi, ``valid`` False otherwise), so h^-1 is not defined.
        MeshError
            Wrong shape, or a point that is not a unit vector (the row is named).
        """
        return self._points_map().to_surface(_float_rows(points, "points"))

    @property
    def cut_mesh(self) -> Mesh:
        """The cut-open disk (theta-phi maps only; see the class docstring).
        Built on first use: copying it into the core costs as much as the
        exact validity test, and most callers never look at it."""
        if self.method != "theta_phi" or not hasattr(self, "_cut_arrays"):
            raise AttributeError("cut_mesh exists for theta-phi maps only")
        if self._cut_mesh is None:
            self._cut_mesh = Mesh(*self._cut_arrays)
        return self._cut_mesh

    @property
    def valid(self) -> bool:
        """True when the points with minor-arc edges form a valid GC-embedding
        (thesis 3.1), proven by the exact orientation test and the area test:
        the map from the mesh to the sphere is then a bijection."""
        return self.report.valid

    @property
    def flipped(self) -> int:
        """Faces failing the orientation test (3.9): upside down or collapsed."""
        return self.report.n_negative + self.report.n_zero

    def __repr__(self) -> str:
        return (f"SphereMap(method={self.method!r}, n_vertices={len(self.points)}, "
                f"valid={self.valid}, flipped={self.flipped}, status={self.status!r}, "
                f"iterations={self.iterations})")


def _float_rows(data: npt.ArrayLike, what: str) -> np.ndarray:
    try:
        array = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MeshError(f"{what} must be numbers: {err}") from None
    return np.ascontiguousarray(array)
