"""SphereMap: the result of :func:`spherify.embed`."""

from __future__ import annotations

from typing import Any, Dict, List, Optional

import numpy as np

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
        flipped / collapsed triangle ids.
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
