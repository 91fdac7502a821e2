"""Morphing through two sphere maps (thesis 8.4).

Each vertex of A goes to the sphere by A's map, is moved into B's sphere
frame, and comes back on B's surface by B's inverse map; the morph
interpolates linearly between A's vertex and that point of B (the thesis's
scheme, with A's connectivity throughout).

How A's map is moved into B's frame is the registration of
:func:`spherify.register`: a rotation, a Möbius transformation, or a
flip-free warp that also makes landmark pairs coincide ("Alexa gives a
method for aligning certain features of the two models", 8.4). ``"landmarks"``
is the rotation that sends A's landmarks onto B's on the sphere in least
squares, ``"none"`` the identity.

By default both shapes are centred and scaled to unit rms radius and B is
turned into A's pose by the spatial rotation the alignment found, so a morph
between a cow and a head sixteen times smaller is a change of shape, not of
size or place.
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from . import _align
from ._errors import MeshError
from ._mesh import Mesh
from ._progress import to_surface_in_chunks
from ._register import Correspondence, check_memory, landmark_pairs, register
from ._spheremap import SphereMap

__all__ = ["Morph", "morph"]

ALIGNS = ("rotation", "moebius", "warp", "landmarks", "none")


class Morph:
    """A morph from A's surface to B's with A's connectivity (thesis 8.4).

    All attributes are read-only.

    Attributes
    ----------
    rotation : (3, 3) float64
        The rotation of the sphere applied to A's sphere points before B's
        inverse map (identity for ``align="none"``; the Möbius
        transformation's rotation part for ``"moebius"`` and ``"warp"``).
    start : (n, 3) float64
        A's vertices (centred and at unit rms radius with ``normalize``).
    end : (n, 3) float64
        Where A's vertices land on B's surface (with ``normalize``: on B
        centred, at unit rms radius and turned into A's pose).
    faces : (m, 3) int64
        A's faces.
    correspondence : Correspondence or None
        The registration behind ``"rotation"``, ``"moebius"`` and ``"warp"``.
    alignment : dict
        ``residual`` (rms of the aligned shapes' difference per vertex, both at
        unit rms radius, over all of A's vertices), ``start`` (which starting
        rotation won), ``iterations`` (Gauss-Newton steps of the rotation),
        ``spatial_rotation`` (the rotation S that superimposes A on B in
        space), and with landmarks ``landmark_residual`` (rms angle in radians
        between A's landmarks and B's on the sphere after the alignment).
    """

    def __init__(self, start: np.ndarray, end: np.ndarray, faces: np.ndarray,
                 rotation: np.ndarray, alignment: Dict[str, Any],
                 correspondence: Optional[Correspondence] = None) -> None:
        for array in (start, end, rotation):
            array.flags.writeable = False
        self._rotation = rotation
        self._start = start
        self._end = end
        self._faces = faces
        self._alignment = alignment
        self._correspondence = correspondence

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) float64: the rotation of the sphere applied to A's sphere points."""
        return self._rotation

    @property
    def start(self) -> np.ndarray:
        """(n, 3) float64: A's vertices (normalised with ``normalize``)."""
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
    def correspondence(self) -> Optional[Correspondence]:
        """The registration behind ``"rotation"``, ``"moebius"`` and ``"warp"``, else None."""
        return self._correspondence

    @property
    def alignment(self) -> Dict[str, Any]:
        """How the alignment went (see the class docstring)."""
        return dict(self._alignment)

    def at(self, t: float) -> Mesh:
        """The mesh at time ``t`` in [0, 1]: ``(1 - t) start + t end`` with A's
        faces. ``at(0)`` is ``start`` and ``at(1)`` lies on B's surface, exactly."""
        t = float(t)
        if not 0.0 <= t <= 1.0:
            raise MeshError(f"t must be in [0, 1], got {t!r}")
        return Mesh((1.0 - t) * self._start + t * self._end, self._faces)

    def __repr__(self) -> str:
        return (f"Morph(n_vertices={len(self._start)}, "
                f"residual={self._alignment.get('residual', float('nan')):.3g})")


def _unit_frame(x: np.ndarray) -> Tuple[np.ndarray, float]:
    centre = x.mean(axis=0)
    c = x - centre
    scale = float(np.sqrt((c * c).sum(axis=1).mean()))
    return centre, scale if scale > 0 else 1.0


def morph(m_a: SphereMap, m_b: SphereMap, *, align: str = "rotation",
          landmarks: Optional[Sequence[Tuple[int, int]]] = None, normalize: bool = True,
          progress: Any = None) -> Morph:
    """Morph A's surface into B's through their sphere maps (thesis 8.4).

    Parameters
    ----------
    m_a, m_b : SphereMap
        Maps of A and B; B's must be certified (``to_surface`` is used), and
        for ``"rotation"``, ``"moebius"`` and ``"warp"`` A's too.
    align : str
        How A's map is brought into B's sphere frame: ``"rotation"``
        (default), ``"moebius"`` or ``"warp"``, as in
        :func:`spherify.register` (``"warp"`` makes landmark pairs meet
        exactly: a feature-aligned morph); ``"landmarks"``: only the Kabsch
        rotation of the landmarks, not refined; ``"none"``: the identity.
    landmarks : sequence of (i_a, j_b), optional
        Vertex pairs that should correspond (at least 2 for ``"landmarks"``).
    normalize : bool, default True
        Centre both shapes, scale them to unit rms radius and turn B into A's
        pose (the spatial rotation found by the alignment), so that the morph
        changes shape, not size, place or pose. False morphs between the
        shapes as given.
    progress : bool or callable, optional
        Passed to :func:`spherify.register`.

    Returns
    -------
    Morph
        Cost: that of :func:`spherify.register` for ``align``, plus one
        ``to_surface`` of A's vertices.

    Raises
    ------
    MapError
        B's map (or, for the alignments that compare shapes, A's) is not a
        certified bijection.
    MeshError
        Unknown ``align``, landmark ids out of range or repeated, or too few
        landmarks.
    ResourceError
        The morph (with its registration) cannot fit in the memory the
        process can still get (docs/reliability.md, "Memory"); raised before
        it starts.
    """
    if align not in ALIGNS:
        raise MeshError(f"unknown align {align!r}; available: {', '.join(ALIGNS)}")
    if not isinstance(normalize, bool):
        raise MeshError(f"normalize must be True or False, got {normalize!r}")
    pairs = landmark_pairs(landmarks, len(m_a.points), len(m_b.points))
    check_memory("morph", m_a, m_b)
    alignment: Dict[str, Any] = {}
    correspondence = None
    if align == "landmarks" and not len(pairs):
        raise MeshError("align='landmarks' needs landmarks (at least 2 pairs)")
    if align in ("rotation", "landmarks") and 0 < len(pairs) < 2:
        raise MeshError(f"landmarks need at least 2 pairs to fix a rotation, got {len(pairs)}")
    if align in ("none", "landmarks"):
        if align == "none":
            rotation = np.eye(3)
        else:
            rotation = _align.kabsch(m_a.points[pairs[:, 0]], m_b.points[pairs[:, 1]])
        alignment.update(start=align, iterations=0)
        _, _, end = to_surface_in_chunks(m_b, m_a.points @ rotation.T, progress, "morph")
        points_a = m_a.points @ rotation.T
    else:
        correspondence = register(m_a, m_b, landmarks=pairs if len(pairs) else None,
                                  transform=align, progress=progress)
        rotation = np.array(correspondence.rotation)
        details = correspondence.details
        alignment.update(start=details["start"], iterations=details["rotation_steps"])
        # A map laid out on a refined mesh (landmarks, or the warp's
        # scaffold) keeps A's vertices as its first rows: the morph is A's.
        n_a = m_a.mesh.n_vertices
        end = np.array(correspondence.a_on_b.positions[:n_a])
        points_a = correspondence.map_a.points[:n_a]
    if len(pairs):
        pa, pb = points_a[pairs[:, 0]], m_b.points[pairs[:, 1]]
        angles = np.arccos(np.clip((pa * pb).sum(axis=1), -1.0, 1.0))
        alignment["landmark_residual"] = float(np.sqrt(np.mean(angles ** 2)))
    a = _align.normalised(m_a.mesh.vertices)
    b = _align.normalised(end)
    spatial = _align.kabsch(a, b)
    r = a @ spatial.T - b
    alignment["residual"] = float(np.sqrt((r * r).sum(axis=1).mean()))
    alignment["spatial_rotation"] = spatial
    start = np.array(m_a.mesh.vertices)
    if normalize:
        a_centre, a_scale = _unit_frame(start)
        b_centre, b_scale = _unit_frame(m_b.mesh.vertices)
        start = (start - a_centre) / a_scale
        end = ((end - b_centre) / b_scale) @ spatial
    return Morph(start, np.ascontiguousarray(end), m_a.mesh.faces,
                 np.array(rotation, dtype=np.float64), alignment, correspondence)
