"""Morphing through two sphere maps (thesis 8.4).

Each vertex of A goes to the sphere by A's map, is turned by a rotation R of
the sphere, and comes back on B's surface by B's inverse map; the morph
interpolates linearly between A's vertex and that point of B (the thesis's
scheme, with A's connectivity throughout).

The rotation aligns the two maps, which are independent: each method puts
its own features wherever it likes on the sphere. It minimises

    E(R) = min over S of  sum_i | S a_i - b(R p_i) |^2

over A's vertices (``p_i`` on the sphere, ``a_i`` on A; ``b(q)`` B's surface
at ``q``), both shapes centred and scaled to unit rms radius, and ``S`` the
spatial rotation that best superimposes them (Kabsch 1976, solved exactly at
every step): so the alignment compares shapes, not their placement in space.
Starting points: the identity; the four rotations that carry the principal
frame of A's degree-1 spherical harmonics (the best-fitting ellipsoid, 8.3)
onto B's; and, given landmark pairs, the rotation that sends A's landmarks
onto B's on the sphere in least squares (Kabsch on the sphere). The best
start is refined by Gauss-Newton on the rotation (finite differences through
``to_surface``), on at most 2000 of A's vertices.
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from . import harmonics
from ._errors import MeshError
from ._mesh import Mesh
from ._progress import to_surface_in_chunks
from ._spheremap import SphereMap

__all__ = ["Morph", "morph"]

ALIGNS = ("rotation", "landmarks", "none")
SUBSAMPLE = 2000


def _kabsch(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The proper rotation R minimising sum |R p_i - q_i|^2 (rows p_i, q_i)."""
    u, _, vt = np.linalg.svd(q.T @ p)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation: np.ndarray = u @ np.diag([1.0, 1.0, d]) @ vt
    return rotation


def _rodrigues(w: np.ndarray) -> np.ndarray:
    """exp of the skew matrix of w: the rotation by |w| about w."""
    angle = float(np.linalg.norm(w))
    k = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if angle < 1e-300:
        return np.eye(3)
    k /= angle
    rotation: np.ndarray = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)
    return rotation


def _normalised(x: np.ndarray) -> np.ndarray:
    c = x - x.mean(axis=0)
    scale = np.sqrt((c * c).sum(axis=1).mean())
    result: np.ndarray = c / (scale if scale > 0 else 1.0)
    return result


class _Cost:
    """E(R) on a fixed set of A's vertices."""

    def __init__(self, a: np.ndarray, p: np.ndarray, m_b: SphereMap) -> None:
        self.a = _normalised(a)
        self.p = p
        self.m_b = m_b

    def residual(self, rotation: np.ndarray) -> np.ndarray:
        _, _, xyz = self.m_b.to_surface(self.p @ rotation.T)
        return self.residual_at(xyz)

    def residual_at(self, xyz: np.ndarray) -> np.ndarray:
        """The residual where the rotated points land on B's surface."""
        b = _normalised(xyz)
        s = _kabsch(self.a, b)
        r: np.ndarray = (self.a @ s.T - b).ravel()
        return r

    def __call__(self, rotation: np.ndarray) -> float:
        r = self.residual(rotation)
        return float(r @ r)


def _frame_candidates(m_a: SphereMap, m_b: SphereMap) -> List[np.ndarray]:
    """Rotations carrying the principal axes of A's degree-1 harmonics onto B's."""
    def linear_part(m: SphereMap) -> np.ndarray:
        c = harmonics.fit(m, 1, oversample=8).coefficients
        # f1(p) = sqrt(3 / 4 pi) (c(1,1) x + c(1,-1) y + c(1,0) z): columns per axis.
        return np.stack([c[3], c[1], c[2]], axis=1)

    _, _, va = np.linalg.svd(linear_part(m_a))
    _, _, vb = np.linalg.svd(linear_part(m_b))
    out = []
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1),
                  (-1, -1, -1), (-1, 1, 1), (1, -1, 1), (1, 1, -1)):
        r = vb.T @ np.diag(signs) @ va
        if np.linalg.det(r) > 0:
            out.append(r)
    return out


def _refine(cost: _Cost, rotation: np.ndarray, max_iter: int = 50) -> Tuple[np.ndarray, int]:
    """Gauss-Newton on the rotation, w in R^3 with R <- exp(w) R, central
    differences, step halving when the cost does not fall."""
    current = cost(rotation)
    h = 1e-6
    for iteration in range(1, max_iter + 1):
        r = cost.residual(rotation)
        jac = np.empty((len(r), 3))
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            jac[:, k] = (cost.residual(_rodrigues(e) @ rotation)
                         - cost.residual(_rodrigues(-e) @ rotation)) / (2 * h)
        step = -np.linalg.lstsq(jac, r, rcond=None)[0]
        for _ in range(30):
            trial = _rodrigues(step) @ rotation
            value = cost(trial)
            if value <= current:
                break
            step /= 2
        else:
            return rotation, iteration
        rotation, previous, current = trial, current, value
        if np.linalg.norm(step) < 1e-12 or previous - current <= 1e-15 * max(previous, 1e-300):
            return rotation, iteration
    return rotation, max_iter


class Morph:
    """A morph from A's surface to B's with A's connectivity (thesis 8.4).

    All attributes are read-only.

    Attributes
    ----------
    rotation : (3, 3) float64
        The rotation of the sphere applied to A's sphere points before B's
        inverse map (identity for ``align="none"``).
    start : (n, 3) float64
        A's vertices.
    end : (n, 3) float64
        Where A's vertices land on B's surface.
    faces : (m, 3) int64
        A's faces.
    alignment : dict
        ``residual`` (rms of the aligned shapes' difference per vertex, both at
        unit rms radius, over all of A's vertices), ``start`` (which starting
        rotation won), ``iterations`` (Gauss-Newton steps), ``spatial_rotation``
        (S in the module doc), and with landmarks ``landmark_residual`` (rms
        angle in radians between R p_a and p_b after the Kabsch step).
    """

    def __init__(self, m_a: SphereMap, m_b: SphereMap, rotation: np.ndarray,
                 alignment: Dict[str, Any], end: Optional[np.ndarray] = None) -> None:
        self._rotation = rotation
        self._rotation.flags.writeable = False
        self._start = m_a.mesh.vertices
        if end is None:
            _, _, end = m_b.to_surface(m_a.points @ rotation.T)
        end.flags.writeable = False
        self._end = end
        self._faces = m_a.mesh.faces
        self._alignment = alignment

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) float64: the rotation of the sphere applied to A's sphere points before B's
        inverse map."""
        return self._rotation

    @property
    def start(self) -> np.ndarray:
        """(n, 3) float64: A's vertices."""
        return self._start

    @property
    def end(self) -> np.ndarray:
        """(n, 3) float64: where A's vertices land on B's surface."""
        return self._end

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64: A's faces."""
        return self._faces

    @property
    def alignment(self) -> Dict[str, Any]:
        """How the rotation was found (see the class docstring)."""
        return dict(self._alignment)

    def at(self, t: float) -> Mesh:
        """The mesh at time ``t`` in [0, 1]: ``(1 - t) start + t end`` with A's
        faces. ``at(0)`` is A and ``at(1)`` lies on B's surface, exactly."""
        t = float(t)
        if not 0.0 <= t <= 1.0:
            raise MeshError(f"t must be in [0, 1], got {t!r}")
        return Mesh((1.0 - t) * self._start + t * self._end, self._faces)

    def __repr__(self) -> str:
        return (f"Morph(n_vertices={len(self._start)}, "
                f"residual={self._alignment.get('residual', float('nan')):.3g})")


def morph(m_a: SphereMap, m_b: SphereMap, *, align: str = "rotation",
          landmarks: Optional[Sequence[Tuple[int, int]]] = None,
          progress: Any = None) -> Morph:
    """Morph A's surface into B's through their sphere maps (thesis 8.4).

    Parameters
    ----------
    m_a, m_b : SphereMap
        Maps of A and B; B's must be certified (``to_surface`` is used).
    align : str
        ``"rotation"`` (default): the rotation of the sphere that best matches
        the shapes (module doc), from the identity, the degree-1 harmonic
        frames and the landmarks if given. ``"landmarks"``: only the Kabsch
        rotation of the landmarks, not refined. ``"none"``: the identity.
    landmarks : sequence of (i_a, j_b), optional
        Vertex pairs that should correspond (at least 2 for ``"landmarks"``).
    progress : bool or callable, optional
        ``True`` draws a bar on stderr, a callable receives ``(done, total)``:
        A's vertices located on B's surface so far (the long part on large
        meshes), as for :func:`spherify.embed`.

    Returns
    -------
    Morph
        Cost: a few dozen ``to_surface`` calls on at most 2000 points, two
        harmonic fits of degree 1, and one ``to_surface`` of A's vertices.

    Raises
    ------
    MapError
        B's map (or, for the harmonic frames, A's) is not a certified bijection.
    MeshError
        Unknown ``align``, landmark ids out of range, or too few landmarks.
    """
    if align not in ALIGNS:
        raise MeshError(f"unknown align {align!r}; available: {', '.join(ALIGNS)}")
    alignment: Dict[str, Any] = {}
    starts: List[Tuple[str, np.ndarray]] = []
    if landmarks is not None:
        pairs = np.asarray(landmarks)
        if pairs.ndim != 2 or pairs.shape[1] != 2 or pairs.dtype.kind not in "iu":
            raise MeshError(f"landmarks must be (i_a, j_b) integer pairs, got shape {pairs.shape}")
        na, nb = len(m_a.points), len(m_b.points)
        if len(pairs) and (pairs.min() < 0 or pairs[:, 0].max() >= na or pairs[:, 1].max() >= nb):
            raise MeshError(f"landmark ids must be in 0..{na - 1} (A) and 0..{nb - 1} (B)")
        if len(pairs) < 2:
            raise MeshError(f"landmarks need at least 2 pairs to fix a rotation, got {len(pairs)}")
        pa, pb = m_a.points[pairs[:, 0]], m_b.points[pairs[:, 1]]
        r = _kabsch(pa, pb)
        angles = np.arccos(np.clip(((pa @ r.T) * pb).sum(axis=1), -1.0, 1.0))
        alignment["landmark_residual"] = float(np.sqrt(np.mean(angles ** 2)))
        starts.append(("landmarks", r))
    elif align == "landmarks":
        raise MeshError("align='landmarks' needs landmarks")
    if align == "none":
        rotation = np.eye(3)
        alignment.update(start="none", iterations=0)
    elif align == "landmarks":
        rotation = starts[0][1]
        alignment.update(start="landmarks", iterations=0)
    else:
        starts.append(("identity", np.eye(3)))
        starts += [(f"harmonic frame {k}", r) for k, r in enumerate(_frame_candidates(m_a, m_b))]
        pick = np.unique(np.linspace(0, len(m_a.points) - 1, SUBSAMPLE).astype(np.int64))
        cost = _Cost(m_a.mesh.vertices[pick], m_a.points[pick], m_b)
        name, best = min(starts, key=lambda s: cost(s[1]))
        rotation, iterations = _refine(cost, best)
        alignment.update(start=name, iterations=iterations)
    # A's every vertex located on B's surface once (three times before):
    # the residual, the spatial rotation and the morph's end all read it.
    end = to_surface_in_chunks(m_b, m_a.points @ rotation.T, progress, "morph")[2]
    full = _Cost(m_a.mesh.vertices, m_a.points, m_b)
    r = full.residual_at(end).reshape(-1, 3)
    alignment["residual"] = float(np.sqrt((r * r).sum(axis=1).mean()))
    alignment["spatial_rotation"] = _kabsch(full.a, _normalised(end))
    return Morph(m_a, m_b, np.array(rotation, dtype=np.float64), alignment, end)
