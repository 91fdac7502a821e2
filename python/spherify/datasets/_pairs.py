"""Pairs of shapes whose true correspondence is known, to measure registration.

B is made from A as the correspondence issue describes: A is resampled
through its own sphere map onto the vertices of an icosphere (so B has other
connectivity), bent by a smooth displacement field, turned and moved. The
point of B that corresponds to A's vertex ``i`` is known exactly: A's vertex
sits at ``p_i`` on the sphere; ``p_i`` lies in one triangle of the
icosphere, and the same barycentric weights on the bent triangle of B give
the point. A registration is then scored by how far from that point it puts
A's vertex on B.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._errors import MeshError
from .._mesh import Mesh
from ._spheres import icosphere

if TYPE_CHECKING:
    from .._spheremap import SphereMap

__all__ = ["DeformedCopy", "deformed_copy"]


@dataclass(frozen=True)
class DeformedCopy:
    """A shape B made from A, with the truth about which point of B is which of A.

    Attributes
    ----------
    mesh : Mesh
        B: an icosphere's connectivity, its vertices on A's surface, then bent,
        turned and moved.
    truth : (n_a, 3) float64
        For every vertex of A, the point of B's surface that corresponds to it.
    truth_faces : (n_a,) int64
        The face of B holding each ``truth`` point.
    truth_bary : (n_a, 3) float64
        Its barycentric weights on that face.
    rotation : (3, 3) float64
        The spatial rotation applied to B after bending.
    """

    mesh: Mesh
    truth: np.ndarray
    truth_faces: np.ndarray
    truth_bary: np.ndarray
    rotation: np.ndarray


def _bend(x: np.ndarray, amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """A smooth displacement: three plane waves of one wavelength per shape size,
    scaled so that its largest value over ``x`` is ``amplitude``."""
    lo, hi = x.min(axis=0), x.max(axis=0)
    size = float(np.linalg.norm(hi - lo))
    centre = (lo + hi) / 2
    field = np.zeros_like(x)
    for _ in range(3):
        wave = rng.normal(size=3)
        wave *= 2 * np.pi / (size * np.linalg.norm(wave))
        phase = rng.uniform(0, 2 * np.pi)
        field += np.sin((x - centre) @ wave + phase)[:, None] * rng.normal(size=3)
    largest = float(np.sqrt((field * field).sum(axis=1)).max())
    scaled: np.ndarray = field * (amplitude * size / largest)
    return scaled


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    rotation: np.ndarray = q
    return rotation


def deformed_copy(sphere_map: "SphereMap", *, level: int = 5, bend: float = 0.06,
                  scale: float = 1.0, seed: int = 0) -> DeformedCopy:
    """Make B from A's certified map, with the true correspondence.

    Parameters
    ----------
    sphere_map : SphereMap
        A's map; it must be certified (its inverse resamples A).
    level : int
        B's connectivity: the icosphere of this level (``10 * 4**level + 2``
        vertices).
    bend : float
        The largest displacement of the bend, as a fraction of A's
        bounding-box diagonal.
    scale : float
        B's size relative to A's.
    seed : int
        Seed of the bend, the rotation and the translation.

    Returns
    -------
    DeformedCopy

    Raises
    ------
    MapError
        ``sphere_map`` is not certified.
    MeshError
        ``level`` outside 0..8, or ``bend`` or ``scale`` not a finite
        non-negative (positive for ``scale``) number.
    """
    if not isinstance(level, int) or not 0 <= level <= 8:
        raise MeshError(f"level must be an integer in 0..8, got {level!r}")
    if not (np.isfinite(bend) and bend >= 0):
        raise MeshError(f"bend must be a finite number >= 0, got {bend!r}")
    if not (np.isfinite(scale) and scale > 0):
        raise MeshError(f"scale must be a finite number > 0, got {scale!r}")
    rng = np.random.default_rng(seed)
    grid = icosphere(subdivisions=level)
    _, _, on_a = sphere_map.to_surface(grid.vertices)
    # Where A's vertices fall among the icosphere's triangles: B's own map
    # of the undeformed resampling is the icosphere itself.
    from .._spheremap import SphereMap
    sphere_of_b = SphereMap.from_points(grid, grid.vertices)
    faces, bary, _ = sphere_of_b.to_surface(sphere_map.points)
    displaced = on_a + _bend(on_a, bend, rng)
    rotation = _random_rotation(rng)
    size = float(np.linalg.norm(on_a.max(axis=0) - on_a.min(axis=0)))
    shift = rng.normal(size=3) * size
    b_vertices = scale * displaced @ rotation.T + shift
    triangle = grid.faces[faces]
    truth = np.einsum("ij,ijk->ik", bary, b_vertices[triangle])
    return DeformedCopy(Mesh(b_vertices, grid.faces), truth, faces, bary, rotation)
