"""MeshReport: what :func:`spherify.check` finds out about a triangle mesh."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import List, Optional, Tuple

import numpy as np


@dataclass(frozen=True)
class MeshReport:
    """Validation report of a triangle mesh (thesis Prop. 2.8 and more).

    Lists of offending indices are capped at 100 entries; the ``n_*`` field next
    to each list gives the true total. Face and vertex ids are 0-based indices
    into the mesh's ``faces`` and ``vertices``.

    Attributes
    ----------
    is_sphere_topology : bool
        True exactly for a closed, connected, manifold, genus-0 triangle mesh in
        which every vertex is used and no face repeats a vertex.
    closed, manifold, connected : bool
        Every edge has two faces; no non-manifold edge or vertex; one component.
    n_components : int
        Connected components of the surface (unused vertices not counted).
    euler_characteristic : int
        V - E + F over the used vertices.
    genus : int or None
        From V - E + F = 2(c - g) - b (thesis eq. 2.20 with b boundary loops);
        None when the mesh is not manifold.
    boundary_loops : list of list of int
        Each hole as a cycle of vertex ids.
    nonmanifold_edges : list of (int, int)
        Edges shared by more than two faces.
    nonmanifold_vertices : list of int
        Vertices whose faces form more than one fan (e.g. two cones tip to tip).
    degenerate_faces : list of int
        Faces that repeat a vertex or have exactly zero area (exact predicate).
    duplicate_faces : list of int
        Faces with the same three vertices as an earlier face, in either order.
    unreferenced_vertices, non_finite_vertices : list of int
    out_of_range_faces : list of int
        Faces with an index outside ``0..n_vertices`` (raw arrays only).
    consistently_oriented : bool
        Every two-face edge is used once in each direction.
    inconsistent_edges : list of (int, int)
    outward : bool
        Closed, consistently oriented and enclosing positive volume: the faces
        are counter-clockwise seen from outside.
    signed_volume : float
    problems : list of str
        One sentence per problem; empty for a clean, outward genus-0 mesh.
    notes : list of str
        Remarks that are not problems (e.g. polygons triangulated on load).
    """

    n_vertices: int
    n_faces: int
    n_edges: int
    is_sphere_topology: bool
    closed: bool
    manifold: bool
    connected: bool
    n_components: int
    euler_characteristic: int
    genus: Optional[int]
    n_boundary_edges: int
    boundary_loops: List[List[int]]
    n_boundary_loops: int
    nonmanifold_edges: List[Tuple[int, int]]
    n_nonmanifold_edges: int
    nonmanifold_vertices: List[int]
    n_nonmanifold_vertices: int
    degenerate_faces: List[int]
    n_degenerate_faces: int
    duplicate_faces: List[int]
    n_duplicate_faces: int
    unreferenced_vertices: List[int]
    n_unreferenced_vertices: int
    non_finite_vertices: List[int]
    n_non_finite_vertices: int
    out_of_range_faces: List[int]
    n_out_of_range_faces: int
    consistently_oriented: bool
    inconsistent_edges: List[Tuple[int, int]]
    n_inconsistent_edges: int
    outward: bool
    signed_volume: float
    problems: List[str] = field(default_factory=list)
    notes: List[str] = field(default_factory=list)

    @property
    def valid(self) -> bool:
        """True when the mesh can be mapped as it is: sphere topology, no
        degenerate or duplicate faces, consistent outward orientation."""
        return not self.problems and self.is_sphere_topology

    def __str__(self) -> str:
        status = "valid genus-0 mesh" if self.valid else (
            "genus-0 topology, needs repair" if self.is_sphere_topology else "not a genus-0 surface")
        genus = "undefined" if self.genus is None else str(self.genus)
        lines = [
            f"MeshReport: {status}",
            f"  vertices {self.n_vertices}, faces {self.n_faces}, edges {self.n_edges}",
            f"  Euler characteristic {self.euler_characteristic}, genus {genus}, "
            f"components {self.n_components}",
            f"  closed {self.closed}, manifold {self.manifold}, "
            f"consistently oriented {self.consistently_oriented}, outward {self.outward}",
        ]
        lines += [f"  problem: {p}" for p in self.problems]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


@dataclass(frozen=True)
class SphereReport:
    """Validity of points on the sphere as a GC-embedding (thesis 3.4).

    Attributes
    ----------
    valid : bool
        Every face positively oriented under the exact predicate, the signed
        spherical areas sum to 4 pi (the drawing covers the sphere once), and
        every point is finite and away from the origin. Together these prove
        that the points with minor-arc edges form a GC-embedding: a bijection.
    n_positive, n_negative, n_zero : int
        Faces by the exact sign of det[v_i, v_j, v_k] (thesis eq. 3.9).
    flipped_faces : (k,) int64
        Faces with det <= 0: upside down or collapsed.
    area_sum : float
        Sum of signed spherical triangle areas of the normalised points (3.11).
    area_error : float
        |area_sum - 4 pi|.
    covering_degree : int
        round(area_sum / 4 pi): how many times the drawing wraps the sphere.
    max_norm_error : float
        Largest | |p| - 1 |; the orientation test does not depend on it.
    bad_points : list of int
        Points that are NaN, infinite or zero.
    min_det : float
        Smallest det[v_i, v_j, v_k] over the faces in floating point (its sign
        is decided exactly): how close the map is to a flip.
    min_area_ratio : float
        Smallest spherical triangle area divided by the mean area 4 pi / F:
        how far the map is from the double-precision floor. A map of a long
        limb by a harmonic or conformal method goes below 1e-12 here; the
        progressive method keeps areas in proportion.
    """

    valid: bool
    n_positive: int
    n_negative: int
    n_zero: int
    flipped_faces: np.ndarray
    area_sum: float
    area_error: float
    covering_degree: int
    max_norm_error: float
    bad_points: List[int] = field(default_factory=list)
    min_det: float = float("nan")
    min_area_ratio: float = float("nan")

    def __eq__(self, other: object) -> bool:
        # The generated __eq__ would compare flipped_faces with ==, an array.
        if not isinstance(other, SphereReport):
            return NotImplemented
        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name))
                   if f.name == "flipped_faces" else getattr(self, f.name) == getattr(other, f.name)
                   for f in fields(self))

    __hash__ = None  # type: ignore[assignment]  # equal reports hold equal arrays, not hashable

    def __str__(self) -> str:
        verdict = "valid GC-embedding" if self.valid else "NOT a valid embedding"
        return (f"SphereReport: {verdict}; of the faces {self.n_positive} positive, "
                f"{self.n_negative} flipped, {self.n_zero} collapsed; area sum {self.area_sum:.12g} (error {self.area_error:.3g}, "
                f"covers {self.covering_degree}x); max | |p| - 1 | = {self.max_norm_error:.3g}; "
                f"smallest triangle {self.min_area_ratio:.3g} of the mean")
