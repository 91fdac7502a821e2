"""Registration of two shapes through their sphere maps (thesis 8.4 and beyond).

``register(m_a, m_b)`` brings A's certified map into B's frame and reads,
for every vertex of A, the point of B's surface at the same place on the
sphere. Three transforms, each building on the one before:

- ``"rotation"``: the rotation of the sphere that best superimposes the
  shapes (:mod:`spherify._align`);
- ``"moebius"``: then the best Möbius transformation (six degrees of
  freedom), kept only where it lowers the alignment cost;
- ``"warp"`` (default): then landmark pairs pinned exactly and the flip-free
  non-rigid warp of :mod:`spherify._warp` (non-rigid ICP in space, then
  flip-free moves to the closest points' places in B's map, and energy
  sweeps with a pull towards them where the moves stop short).

A's map stays a certified bijection at every step (the exact orientation
test and the area test), so the correspondence is one-to-one by construction:
every point of A has exactly one image on B and every point of B one
preimage on A.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, Optional, Tuple

import numpy as np
import numpy.typing as npt

from . import _align, _blas, _core, _landmarks, _nearest, _warp
from ._embed import improve
from ._errors import MapError, MeshError
from ._progress import as_callback
from ._spheremap import SphereMap
from ._workers import beside

__all__ = ["Correspondence", "SurfacePoints", "TRANSFORMS", "landmark_pairs", "register"]

TRANSFORMS = ("rotation", "moebius", "warp")
# The warp keeps the pose the check in space switched to only where its ICP
# ends below this fraction of the mean distance to B that the warp from the
# map rotation's pose ends at (:func:`_warp_keeps_switch`).
WARP_SWITCH_RATIO = 0.9

# What the stages after the rotation give (:func:`_after_rotation`): A's map,
# the rotation, the Möbius transformation, the seconds and the details.
_Stages = Tuple[SphereMap, np.ndarray, Optional[Dict[str, np.ndarray]], Dict[str, float],
                Dict[str, Any]]


@dataclass(frozen=True)
class SurfacePoints:
    """Points on a mesh's surface: ``faces`` (k,) int64, barycentric ``bary``
    (k, 3) on those faces' corners, and the ``positions`` (k, 3) themselves."""

    faces: np.ndarray
    bary: np.ndarray
    positions: np.ndarray


def _read_only(x: np.ndarray) -> np.ndarray:
    x = np.array(x)
    x.flags.writeable = False
    return x


def _diagonal(vertices: np.ndarray) -> float:
    return float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))


def landmark_pairs(landmarks: Any, n_a: int, n_b: int) -> np.ndarray:
    """Check landmark pairs: a (k, 2) int64 array of (vertex of A, vertex of B)."""
    if landmarks is None:
        return np.empty((0, 2), dtype=np.int64)
    try:
        pairs = np.asarray(landmarks)
    except (TypeError, ValueError) as err:
        raise MeshError(f"landmarks must be (vertex_of_a, vertex_of_b) pairs: {err}") from None
    if pairs.size == 0:
        return np.empty((0, 2), dtype=np.int64)
    if pairs.ndim != 2 or pairs.shape[1] != 2 or pairs.dtype.kind not in "iu":
        raise MeshError("landmarks must be (vertex_of_a, vertex_of_b) integer pairs, "
                        f"got an array of shape {pairs.shape} and type {pairs.dtype}")
    pairs = pairs.astype(np.int64)
    for side, column, n in (("A", 0, n_a), ("B", 1, n_b)):
        ids = pairs[:, column]
        bad = np.flatnonzero((ids < 0) | (ids >= n))
        if len(bad):
            raise MeshError(f"landmark {int(bad[0])}: vertex {int(ids[bad[0]])} of {side} is out "
                            f"of range 0..{n - 1}")
        values, counts = np.unique(ids, return_counts=True)
        if (counts > 1).any():
            raise MeshError(f"landmarks name vertex {int(values[counts > 1][0])} of {side} more "
                            "than once")
    return pairs


def _superimposed(a: np.ndarray, xyz: np.ndarray, b: np.ndarray
                  ) -> Tuple[Dict[str, Any], Dict[str, float]]:
    """The similarity that best superimposes A's vertices ``a`` on their
    images ``xyz`` on B, and the residual distances (rms and max over B's
    bounding-box diagonal)."""
    a_centre, b_centre = a.mean(axis=0), xyz.mean(axis=0)
    a_c, y_c = a - a_centre, xyz - b_centre
    a_scale = float(np.sqrt((a_c * a_c).sum(axis=1).mean())) or 1.0
    y_scale = float(np.sqrt((y_c * y_c).sum(axis=1).mean())) or 1.0
    spin = _align.kabsch(a_c, y_c)
    scale = y_scale / a_scale
    superimposed = scale * a_c @ spin.T + b_centre
    distance = np.linalg.norm(superimposed - xyz, axis=1) / (_diagonal(b) or 1.0)
    spatial = {"rotation": _read_only(spin), "scale": scale,
               "translation": _read_only(b_centre - scale * spin @ a_centre)}
    return spatial, {"rms": float(np.sqrt(np.mean(distance ** 2))), "max": float(distance.max())}


def check_memory(call: str, m_a: SphereMap, m_b: SphereMap, items: int = 0) -> None:
    """The memory policy's check of ``call`` on the maps of A and B (their
    vertices and faces together): a ResourceError before the work starts."""
    _core.check_application(call, m_a.mesh.n_vertices + m_b.mesh.n_vertices,
                            m_a.mesh.n_faces + m_b.mesh.n_faces, items)


def _check_maps(m_a: Any, m_b: Any) -> None:
    for name, m in (("m_a", m_a), ("m_b", m_b)):
        if not isinstance(m, SphereMap):
            raise MeshError(f"{name} must be a SphereMap, got {type(m).__name__}")
        if not m.valid:
            raise MapError(f"{name} is not a certified bijection ({m.flipped} flipped faces); "
                           "registration needs both maps valid")


class Correspondence:
    """Where every vertex of A lands on B, through two certified sphere maps.

    All attributes are read-only.

    Attributes
    ----------
    transform : str
        ``"rotation"``, ``"moebius"`` or ``"warp"``.
    map_a : SphereMap
        A's certified map in B's sphere frame (after the transform).
    map_b : SphereMap
        B's map.
    a_on_b : SurfacePoints
        For every vertex of A: the face of B, barycentric weights and position.
    rotation : (3, 3) float64
        The rotation of the sphere applied to A's map (the Möbius
        transformation's rotation part for ``"moebius"`` and ``"warp"``).
    moebius : dict or None
        ``{"rotation": R, "boost": b}``: the map p -> R B_b(p) of
        :mod:`spherify._align`; None for ``"rotation"``.
    spatial : dict
        The similarity that superimposes A on B in space: ``rotation`` (3, 3),
        ``scale`` and ``translation`` (x -> scale * rotation @ x + translation).
    residual : dict
        ``rms`` and ``max`` distance between A's vertices (superimposed on B by
        ``spatial``) and their images on B, relative to B's bounding-box
        diagonal.
    landmark_error : dict or None
        With landmarks: ``max_angle`` (radians, between A's landmark on the
        sphere and B's) and ``max_distance`` (of A's landmark's image on B to
        B's landmark vertex, relative to B's diagonal).
    seconds : dict
        Wall time of each stage. The rotation's check in space runs beside
        the later stages (and where it switches the rotation, they run again
        and ``rotation`` counts the time until then).
    """

    def __init__(self, transform: str, map_a: SphereMap, map_b: SphereMap, rotation: np.ndarray,
                 moebius: Optional[Dict[str, np.ndarray]], pairs: np.ndarray,
                 seconds: Dict[str, float], details: Optional[Dict[str, Any]] = None) -> None:
        self._transform = transform
        self._map_a = map_a
        self._map_b = map_b
        self._rotation = _read_only(rotation)
        self._moebius = moebius
        self._pairs = _read_only(pairs)
        faces, bary, xyz = map_b.to_surface(map_a.points)
        self._a_on_b = SurfacePoints(_read_only(faces), _read_only(bary), _read_only(xyz))
        b = map_b.mesh.vertices
        self._spatial, self._residual = _superimposed(map_a.mesh.vertices, xyz, b)
        self._landmark_error: Optional[Dict[str, float]] = None
        if len(pairs):
            pa, pb = map_a.points[pairs[:, 0]], map_b.points[pairs[:, 1]]
            angle = np.arctan2(np.linalg.norm(np.cross(pa, pb), axis=1), (pa * pb).sum(axis=1))
            gap = np.linalg.norm(xyz[pairs[:, 0]] - b[pairs[:, 1]], axis=1) / (_diagonal(b) or 1.0)
            self._landmark_error = {"max_angle": float(angle.max()),
                                    "max_distance": float(gap.max())}
        self._seconds = dict(seconds)
        self._details = dict(details or {})

    @property
    def transform(self) -> str:
        """"rotation", "moebius" or "warp"."""
        return self._transform

    @property
    def map_a(self) -> SphereMap:
        """A's certified map in B's sphere frame (after the transform)."""
        return self._map_a

    @property
    def map_b(self) -> SphereMap:
        """B's map."""
        return self._map_b

    @property
    def a_on_b(self) -> SurfacePoints:
        """For every vertex of A: the face of B, barycentric weights and position."""
        return self._a_on_b

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) float64: the rotation of the sphere applied to A's map."""
        return self._rotation

    @property
    def moebius(self) -> Optional[Dict[str, np.ndarray]]:
        """``{"rotation": R, "boost": b}`` (p -> R B_b(p)), or None for ``"rotation"``."""
        return None if self._moebius is None else dict(self._moebius)

    @property
    def spatial(self) -> Dict[str, Any]:
        """The similarity that superimposes A on B in space: ``rotation``, ``scale``, ``translation``."""
        return dict(self._spatial)

    @property
    def landmarks(self) -> np.ndarray:
        """The landmark pairs (k, 2): (vertex of A, vertex of B)."""
        return self._pairs

    @property
    def residual(self) -> Dict[str, float]:
        """``rms`` and ``max`` distance between A superimposed on B and A's images on B, over B's diagonal."""
        return dict(self._residual)

    @property
    def landmark_error(self) -> Optional[Dict[str, float]]:
        """With landmarks: ``max_angle`` (radians) and ``max_distance`` (over B's diagonal); else None."""
        return None if self._landmark_error is None else dict(self._landmark_error)

    @property
    def seconds(self) -> Dict[str, float]:
        """Wall time of each stage (the rotation's check in space runs beside the later ones)."""
        return dict(self._seconds)

    @property
    def details(self) -> Dict[str, Any]:
        """How each stage went: the rotation's winning start, Gauss-Newton
        steps, the warp's steps and how much of each wanted move it made."""
        return dict(self._details)

    def transfer(self, values_on_b: npt.ArrayLike) -> np.ndarray:
        """Per-vertex values of B read at A's vertices (barycentric on B's faces).

        Parameters
        ----------
        values_on_b : (n_b,) or (n_b, d) float
            One value (or row) per vertex of B.

        Returns
        -------
        (n_a,) or (n_a, d) float64

        Raises
        ------
        MeshError
            Not one value per vertex of B, or not numbers.
        """
        try:
            values = np.asarray(values_on_b, dtype=np.float64)
        except (TypeError, ValueError) as err:
            raise MeshError(f"values_on_b must be numbers: {err}") from None
        n_b = len(self._map_b.points)
        if values.ndim not in (1, 2) or len(values) != n_b:
            raise MeshError(f"values_on_b must have one value or row per vertex of B ({n_b}), "
                            f"got shape {values.shape}")
        corners = self._map_b.mesh.faces[self._a_on_b.faces]
        bary = self._a_on_b.bary
        if values.ndim == 1:
            out: np.ndarray = (bary * values[corners]).sum(axis=1)
        else:
            out = np.einsum("ij,ijk->ik", bary, values[corners])
        return out

    def inverse(self) -> "Correspondence":
        """B onto A: every vertex of B located on A through the same two maps
        (the correspondence is a bijection, so this is its exact inverse up
        to the barycentric interpolation)."""
        return Correspondence(self._transform, self._map_b, self._map_a, np.eye(3), None,
                              self._pairs[:, ::-1].copy(), self._seconds,
                              {**self._details, "inverse of": "a_on_b"})

    def __repr__(self) -> str:
        return (f"Correspondence(transform={self._transform!r}, n_a={len(self._map_a.points)}, "
                f"n_b={len(self._map_b.points)}, residual_rms={self._residual['rms']:.3g})")


def _moved(current: SphereMap, points: np.ndarray) -> SphereMap:
    """``current``'s mesh with ``points``, certified. Where a face would flip
    (a triangle thinner than the rounding of a turn, or a strong boost
    squeezing a thin tube), the flip-free moves take the vertices from the
    valid ``current`` towards ``points`` instead, as far as the exact test allows."""
    moved = SphereMap.from_points(current.mesh, points)
    if moved.valid:
        return moved
    return _landmarks.move_towards(current, points, energy_sweeps=0)


def register(m_a: SphereMap, m_b: SphereMap, *, landmarks: Any = None,
             transform: str = "warp", progress: Any = None) -> Correspondence:
    """Register shape A onto shape B through their certified sphere maps.

    Parameters
    ----------
    m_a, m_b : SphereMap
        Certified maps of A and B (any methods, or maps wrapped by
        :meth:`SphereMap.from_points`).
    landmarks : sequence of (vertex_of_a, vertex_of_b) or (k, 2) int array, optional
        Points that should correspond. They choose the starting rotation
        (with at least two pairs) and, with ``"warp"``, coincide exactly on
        the sphere: A's landmark lands on B's landmark vertex.
    transform : str
        ``"rotation"``, ``"moebius"`` or ``"warp"`` (default); see the module doc.
    progress : bool or callable, optional
        ``True`` draws a bar on stderr; a callable gets ``(done, total)``.

    Returns
    -------
    Correspondence
        Cost: a few dozen ``to_surface`` calls on 2000 points for the
        rotation and the Möbius fit, and about 50 closest-point searches of
        600 points each way for the rigid ICP that checks the rotation's pose
        in space (without landmarks); for the warp, 15 least-squares fits of
        304 unknowns on at most 3000 of A's vertices, each with a
        closest-point search on B, one closest-point search for every vertex
        of A, 10 rounds of flip-free moves of all, then up to 3 stages of
        energy sweeps (at most 200,000 vertex moves each) where the moves
        stopped short of their targets. Where the moves leave A's map far
        behind its targets (thin limbs many edges away), 128 of A's
        vertices are first pinned at their targets with the landmark
        machinery (the warp's scaffold, about 1.5 s for the 50k-vertex
        scorpion on a lightly loaded 2-core machine, more where it must
        refine; then
        ``map_a`` may lie on a refined mesh whose first rows are A's
        vertices, as with landmarks); where the check in space switches
        the pose, the Möbius fit and the warp run from both poses and the
        warp keeps the switch only if it ends clearly nearer B.

    Raises
    ------
    MeshError
        Unknown ``transform``, not SphereMaps, landmark ids out of range or
        repeated.
    MapError
        A map that is not certified, or landmarks that cannot all be placed
        (the error names them).
    ResourceError
        The registration cannot fit in the memory the process can still get
        (docs/reliability.md, "Memory"); raised before it starts.
    """
    if transform not in TRANSFORMS:
        raise MeshError(f"unknown transform {transform!r}; choose one of {', '.join(TRANSFORMS)}")
    _check_maps(m_a, m_b)
    pairs = landmark_pairs(landmarks, len(m_a.points), len(m_b.points))
    check_memory("register", m_a, m_b)
    # numpy's BLAS on one thread: faster on busy cores and the same bits
    # whatever BLAS's thread count (spherify._blas).
    with _blas.one_blas_thread():
        return _registered(m_a, m_b, pairs, transform, progress)


def _registered(m_a: SphereMap, m_b: SphereMap, pairs: np.ndarray, transform: str,
                progress: Any) -> Correspondence:
    """:func:`register` after its checks."""
    callback = as_callback(progress, "register")
    reported = [0]

    def report(done: int, total: int) -> None:
        # Where the check in space switches the rotation, the later stages
        # run again: the bar does not go back.
        if callback and done > reported[0]:
            reported[0] = done
            callback(done, total)

    started = time.perf_counter()
    total = 2 + (_warp.STEPS if transform == "warp" else 0)
    landmark_rotation = None
    if len(pairs) >= 2:
        landmark_rotation = _align.kabsch(m_a.points[pairs[:, 0]], m_b.points[pairs[:, 1]])
    # B's closest-point tree (B centred and scaled to unit rms radius) is
    # made once, for the rotation's check in space and the warp.
    b_tree = _nearest.OnDemand(lambda: _align.normalised(m_b.mesh.vertices), m_b.mesh.faces)
    # B's side of the warp likewise (made beside the search for the rotation).
    b_side = _warp.BSide(m_b)
    # The stages after the rotation run from the map rotation beside the
    # rotation's check in space (spherify._align.best_rotation_then), and
    # again from the check's rotation where it switches.
    rotation, start, steps, rest = _align.best_rotation_then(
        m_a, m_b, landmark_rotation,
        lambda r: _after_rotation(m_a, m_b, r, pairs, transform, b_tree, b_side, report, total),
        b_tree, _warp_keeps_switch if transform == "warp" else None,
        b_side.make if transform == "warp" else None)
    assert rest is not None
    map_a, rotation, moebius, seconds, details = rest
    seconds = {"rotation": seconds.pop("began") - started, **seconds}
    details = {"start": start, "rotation_steps": steps, **details}
    report(total, total)
    return Correspondence(transform, map_a, m_b, rotation, moebius, pairs, seconds, details)


def _warp_keeps_switch(switched: Optional[_Stages], unswitched: Optional[_Stages]) -> bool:
    """Whether the warp from the pose the check in space switched to is kept
    over the warp from the map rotation's pose: only where its ICP ends
    clearly nearer B (its last mean distance below :data:`WARP_SWITCH_RATIO`
    of the other's). The rigid check tells a near-symmetric shape's poses
    apart by a few percent of residual; the warp's non-rigid fit tells them
    apart far more clearly where the switch is right (human_man: 0.0085
    against 0.0161) and not at all where it is not (sword, the other pose
    176 degrees about the blade: 0.003494 against 0.003502, whose warp then
    ends 4.21% / 8.90% off the truth against 1.66% / 3.99% from the map
    pose; docs/correspondence.md)."""
    assert switched is not None and unswitched is not None
    new, old = switched[4]["warp_icp_distance"][-1], unswitched[4]["warp_icp_distance"][-1]
    return bool(new < WARP_SWITCH_RATIO * old)


def _after_rotation(m_a: SphereMap, m_b: SphereMap, rotation: np.ndarray, pairs: np.ndarray,
                    transform: str, b_tree: _nearest.OnDemand, b_side: _warp.BSide,
                    report: Callable[[int, int], None], total: int) -> _Stages:
    """The stages of :func:`register` after the sphere rotation: A's map
    turned, the Möbius fit and the warp. Returns A's map, the rotation, the
    Möbius transformation, the stages' seconds (and ``"began"``, when they
    began) and details."""
    seconds: Dict[str, float] = {"began": time.perf_counter()}
    details: Dict[str, Any] = {}
    report(1, total)
    moebius: Optional[Dict[str, np.ndarray]] = None
    if transform == "rotation":
        map_a = _moved(m_a, m_a.points @ rotation.T)
    else:
        started = time.perf_counter()

        def cost(m: SphereMap) -> float:
            return _align.Cost(m_a.mesh.vertices, m.points, m_b)(lambda p: p)

        turned = m_a.points @ rotation.T

        def rotated() -> Tuple[SphereMap, float]:
            turned_map = SphereMap.from_points(m_a.mesh, turned)
            if not turned_map.valid:
                turned_map = _moved(m_a, turned)
            return turned_map, cost(turned_map)

        # The rotated map does not depend on the Möbius fit: it is certified
        # and costed beside the fit (spherify._workers; each its own bits, as
        # one after the other), then the Möbius candidate (issue 23, speed,
        # session 12: the two had waited for the fit, then gone side by side).
        (turn, boost, steps), (map_a, rotation_cost) = beside(
            lambda: _align.best_moebius(m_a, m_b, rotation), rotated)
        boosted = _align.moebius_transform(turn, boost)(m_a.points)
        candidate = SphereMap.from_points(m_a.mesh, boosted)
        if not candidate.valid:
            candidate = _moved(map_a, boosted)
        candidate_cost = cost(candidate)
        # Kept only where it is better than the rotation on all of A's vertices.
        if candidate_cost < rotation_cost:
            map_a = candidate
            rotation = turn
            moebius = {"rotation": _read_only(turn), "boost": _read_only(boost)}
        else:
            moebius = {"rotation": _read_only(rotation), "boost": _read_only(np.zeros(3))}
        details["moebius_steps"] = steps
        seconds["moebius"] = time.perf_counter() - started
    report(2, total)
    if transform == "warp":
        started = time.perf_counter()
        fixed = None
        if len(pairs):
            # Each A landmark exactly at its B landmark's sphere point (a
            # MapError names the landmarks no map can place there).
            map_a = improve(map_a, landmarks=(pairs[:, 0], m_b.points[pairs[:, 1]]))
            fixed = pairs[:, 0]
        seconds["landmarks"] = time.perf_counter() - started
        started = time.perf_counter()

        def heard(done: int, _: int) -> bool:
            report(2 + done, total)
            return False

        map_a, run = _warp.warp(map_a, m_b, fixed=fixed,
                                fixed_on_b=None if fixed is None else pairs[:, 1],
                                should_stop=heard, b_tree=b_tree, b_side=b_side)
        details["warp_icp_distance"] = run["icp"]
        details["warp_moved"] = run["moved"]
        details["warp_pulled"] = run["pulled"]
        details["warp_scaffold"] = run["scaffold"]
        seconds["warp"] = time.perf_counter() - started
    return map_a, rotation, moebius, seconds, details
