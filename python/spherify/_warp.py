"""A flip-free non-rigid warp of A's sphere map onto B's: registration's last step.

After a rotation or Möbius transformation has put A's map in B's frame, A's
vertex ``i`` sits at ``q_i`` on the sphere and so at ``y_i = b(q_i)`` on B's
surface. Those correspondences are right in the large and wrong in the
small (the two maps put the features in slightly different places). The
warp finds better ones in space and then moves A's map to them:

1. Both shapes are centred and scaled to unit rms radius, and A is turned by
   the rotation that best superimposes it on the ``y_i`` (Kabsch).
2. Non-rigid ICP (:mod:`spherify._nricp`) fits a smooth deformation ``T`` of
   space that carries A onto B's surface, starting from the ``y_i`` and then
   from closest points, from stiff to soft; landmark pairs weigh heavily.
   Without landmarks, the stiff stages also pull the deformed A onto the
   parts of B it does not cover yet (the reverse pairs).
   It is done on an even sample of A's vertices (the deformation is smooth).
3. Every vertex of A gets the closest point of B's surface to ``T(a_i)``
   (:class:`spherify._nearest.NearestOnSurface`), and that point's place on
   the sphere in B's map (:meth:`SphereMap.to_sphere`) is its target.
4. A's map moves towards the targets by rounds of flip-free moves, each
   round aimed a little further along the way
   (:func:`spherify._landmarks.move_towards`: each vertex goes as far along
   its great circle as every face around it stays positive under the exact
   test), landmarks held. So A's map is certified after every round, and
   where the targets fold (two vertices of A wanting one point of B) the
   map stops short of the fold instead of flipping.
   Where the rounds leave the map far behind its targets (a scorpion's
   legs many edges from where they belong: each round moves a vertex at
   most about an edge), **the scaffold** (:func:`scaffold`, step 4b) pins
   :data:`SCAFFOLD` of A's vertices at their targets first with the
   landmark machinery (:func:`spherify.improve` with ``landmarks``), which
   carries whole parts of the map at once (coarse), and the rounds run
   again from there (fine); kept where they end nearer the targets on A's
   own vertices. Where the drag cannot pin them, the landmarks' layout
   refines A's mesh by edge splits (A's vertices stay its first rows, as
   for a landmark map); the new vertices get their targets from the same
   deformation (:func:`_sphere_targets`' placement).
5. Where it stopped short (a vertex more than :data:`PULL_SHORT` of a mean
   edge from its target), the region around (:data:`PULL_RINGS` rings) is
   pulled on by energy sweeps (:func:`spherify._landmarks.pull_towards`):
   flip-free Newton moves lowering the isometric distortion of A's surface
   triangles against their chord triangles plus ``lambda * sum_i m_i |x_i -
   t_i|^2`` (``m_i`` A's vertex areas over their mean, ``t_i`` the targets),
   ``lambda`` growing over :data:`PULL_STAGES`; the rest of the map and the
   landmarks are held. The distortion's barrier keeps the triangles open,
   so a fold spreads over its neighbourhood instead of jamming at its edge,
   and the map stays a good map of A while it follows the data. Certified
   after every stage.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _core, _descriptors, _landmarks, _nricp
from ._align import kabsch
from ._embed import improve
from ._errors import MapError, MeshError, ResourceError
from ._nearest import OnDemand
from ._spheremap import SphereMap
from ._workers import beside, run_all
from .datasets._sampling import farthest_points

__all__ = ["BSide", "PULL_STAGES", "ROUNDS", "SAMPLE", "SCAFFOLD", "SCAFFOLD_GROWTH", "STEPS",
           "lagging", "move_rounds", "pull", "scaffold", "sphere_targets", "warp"]

# Vertices of A the deformation is fitted on (all of a smaller mesh).
SAMPLE = 3000
# Vertices of B whose reverse pairs may enter the fit (spherify._nricp).
# Without the gap test, 500 to 3000 gave the same targets within about 0.05
# points of the diagonal (horse 0.94-1.07%, igea 1.18-1.23%, scorpion
# 0.92-1.12%); with 3000 the rows they add to the normal matrix cost 0.1 s
# of CPU in horse's register.
REVERSE_SAMPLE = 1000
# Rounds of flip-free moves: HOMOTOPY rounds aimed ever closer to the
# targets, then the rest aimed at them.
ROUNDS = 10
HOMOTOPY = 8
# A landmark pair weighs this many mean vertices in the fit.
LANDMARK_WEIGHT = 50.0
# Step 5, the pull. Its strengths lambda, one stage each: the pull per unit
# of the sphere's area against the isometric density's 4 at an isometry, so
# that a displacement can bend over about 1 / sqrt(lambda) radians (0.03,
# 0.01, 0.003; horse's mean edge is 0.02). Starting weak lets a region move
# together before the pull pins each vertex (horse, from the rounds' 1.68% /
# 5.51% mean / p95, with the distortion against the sphere before the warp:
# 1e3, 1e4, 1e5 gave 1.40% / 3.27%; 1e4, 1e5 1.49% / 3.91%; 1e5, 1e6
# 1.54% / 4.36%).
PULL_STAGES = (1e3, 1e4, 1e5)
# Most sweeps per stage (horse with 30: 1.49% / 3.91%; the stages seldom
# converge before their last sweep).
PULL_SWEEPS = 50
# A vertex farther than this fraction of the mean chord edge from its target
# stopped short; the region pulled on is such vertices and PULL_RINGS rings
# around them. Pulling on horse's whole map or on 0.3 of an edge and 5 rings
# (35% of the vertices) gave the same error, the latter in half the time;
# 0.5 and 3 rings (23% of horse, 33% of armadillo) the same again with 20
# sweeps a stage (armadillo 1.01% / 4.13%), a little worse on small meshes
# (octopus 1.57% / 4.09% against 1.50% / 3.68%).
PULL_SHORT = 0.5
PULL_RINGS = 3
# Most vertex moves per stage: the pull's cost is capped at 3 x 200,000
# moves (about 0.6 s on 2 quiet cores, 1-1.5 s on busy ones), so that a
# register of two 50k meshes stays within 3x mapping both. Measured with 0.5
# and 3 rings against B of 41k vertices (the speed pairs), mean / p95:
# armadillo 1.10% / 4.85% with 150,000, 1.01% / 4.13% with 300,000,
# 0.96% / 3.71% with 400,000 (and with 0.3, 5 rings and no cap, 50 sweeps a
# stage: 0.82% / 2.68%, at 4.7x mapping both); horse 1.62% / 5.38%, 1.53% /
# 4.39% and 1.47% / 3.76%; without the pull 1.17% / 5.34% and 1.69% / 5.93%.
# On the busy machine (load 6-7) 300,000 added 1.5-2 s to the warp.
PULL_WORK = 200_000
# Step 4b, the scaffold: where the rounds leave the map more than
# SCAFFOLD_LAG mean chord edges from its targets on average, whole parts of
# the map (a scorpion's legs) are many edges from where they belong, and
# local moves of at most an edge a round cannot carry them there. Then
# SCAFFOLD of A's vertices are pinned at their targets first, by the
# landmark machinery, which lays out the whole map around them (coarse), and
# the rounds start from that map (fine). It costs 5-15 s of CPU on a 50k
# mesh on a busy machine (1.5 s of wall for scorpion's pinning on a lightly
# loaded one; more where the layout refines the mesh much), so it is tried
# only where the rounds lag: mean angle left over the mean chord edge of
# A's map above SCAFFOLD_LAG without landmarks (after the rounds: horse 0.70,
# armadillo 0.43, human_man 0.37-1.0, sword 2.0, scorpion 6.3; the speed
# bar is measured on horse and armadillo) and above SCAFFOLD_LAG_LANDMARKS
# with them (horse 0.15, armadillo 0.17, octopus 0.10, human_man 0.37,
# sword 0.91; scorpion more), where it gains most (docs/correspondence.md). Measured on scorpion's pair
# (docs/correspondence.md, "The scaffold"): 32, 64, 128, 256 pinned vertices
# gave 2.65% / 7.72%, 1.77% / 5.23%, 1.16% / 3.70%, 1.01% / 3.37% after
# the pull, against 5.77% / 17.58% without, at 5, 5, 6 and 14 s of pinning.
SCAFFOLD = 128
SCAFFOLD_LAG = 3.0
SCAFFOLD_LAG_LANDMARKS = 0.25
# Most vertices of a scaffold's map, as a multiple of A's (a bound on its
# cost, not a test of its gain): the rounds after it cost as much more as
# the layout refined the mesh. Measured (docs/correspondence.md, "The
# scaffold's size"): kept and better for it, scorpion 1.50-1.62x, sword
# 1.94x and with 8 landmarks 2.73x; refused, helix_tube 100k 15.4x (40.7%
# mean error against 40.0% without, 200 s against 15 s, 1.57M rows
# returned for 102k vertices) and sword with 3 landmarks 5.0x (a loss on
# the mean). The layout stops as soon as it passes the bound.
SCAFFOLD_GROWTH = 4.0
# The steps reported to a progress callback: one per ICP iteration, one per
# round and one per stage of the pull.
STEPS = sum(s for _, _, s in _nricp.SCHEDULE) + ROUNDS + len(PULL_STAGES)


def _vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """A third of the area of the faces around each vertex, over their mean."""
    e1 = vertices[faces[:, 1]] - vertices[faces[:, 0]]
    e2 = vertices[faces[:, 2]] - vertices[faces[:, 0]]
    area = np.linalg.norm(np.cross(e1, e2), axis=1)
    share = np.bincount(faces.ravel(), np.repeat(area, 3), len(vertices))
    mean = float(share.mean())
    out: np.ndarray = share / (mean if mean > 0 else 1.0)
    return out


class BSide:
    """B's side of the warp, which depends on B alone (not on A's pose):
    B centred and scaled to unit rms radius (:func:`_frame`), its outward
    face normals, the reverse pairs' sample of B (:data:`REVERSE_SAMPLE`
    of its vertices with their normals and vertex areas) and the descriptor
    pairs' candidates on B with their heights (:mod:`spherify._descriptors`;
    once a registration, where a second warp made them again). Each part is made
    once, by whichever caller asks first (a lock: registration makes them on
    a pool thread beside its search for the rotation, :meth:`make`, where
    the other core had little to do, instead of on the warp's path)."""

    def __init__(self, m_b: SphereMap) -> None:
        self._mesh = m_b.mesh
        self._lock = threading.Lock()
        self._frame: Optional[Tuple[np.ndarray, float, np.ndarray]] = None
        self._normals: Optional[np.ndarray] = None
        self._sample: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]] = None
        self._candidates: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]] = None

    def frame(self) -> Tuple[np.ndarray, float, np.ndarray]:
        """B's centre, rms radius and vertices centred and scaled by them."""
        with self._lock:
            if self._frame is None:
                centre, scale = _frame(self._mesh.vertices)
                self._frame = (centre, scale, (self._mesh.vertices - centre) / scale)
            return self._frame

    def face_normals(self) -> np.ndarray:
        """B's outward unit face normals (of the scaled B)."""
        b_all = self.frame()[2]
        with self._lock:
            if self._normals is None:
                self._normals = _nricp.face_normals(b_all, self._mesh.faces)
            return self._normals

    def reverse_sample(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reverse pairs' sample of B: points, unit normals, vertex areas."""
        b_all = self.frame()[2]
        with self._lock:
            if self._sample is None:
                faces = self._mesh.faces
                n_b = len(b_all)
                rows = np.unique(np.linspace(0, n_b - 1, min(n_b, REVERSE_SAMPLE)
                                             ).astype(np.int64))
                self._sample = (b_all[rows], _nricp.vertex_normals(b_all, faces)[rows],
                                _vertex_areas(b_all, faces)[rows])
            return self._sample

    def candidates(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The descriptor pairs' candidates on B (B's surface
        :data:`spherify._nricp.DESCRIPTOR_SPACING` apart, (k, 3)), their
        heights at :data:`spherify._nricp.DESCRIPTOR_SCALES` (k, scales) and
        a face of B near each (k,)."""
        b_all = self.frame()[2]
        with self._lock:
            if self._candidates is None:
                surface = _descriptors.Surface(b_all, self._mesh.faces)
                points, _, normals, faces = surface.samples_on_faces(_nricp.DESCRIPTOR_SPACING)
                self._candidates = (points, _descriptors.heights(surface, points, normals,
                                                                 _nricp.DESCRIPTOR_SCALES), faces)
            return self._candidates

    def make(self) -> None:
        """Every part, now."""
        self.face_normals()
        self.reverse_sample()
        if _nricp.DESCRIPTOR_WEIGHT > 0:
            self.candidates()


def _frame(x: np.ndarray) -> Tuple[np.ndarray, float]:
    centre = x.mean(axis=0)
    c = x - centre
    scale = float(np.sqrt((c * c).sum(axis=1).mean()))
    return centre, scale if scale > 0 else 1.0


# Rows of one block of the angle computation (each row's angle is computed
# alone, so the blocks give the same bits as one pass).
ANGLE_ROWS = 8192


def _angles(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The angle between each row of ``p`` and of ``q``, in row blocks on two
    threads (spherify._workers): 25 calls on all of A's vertices were a
    tenth of horse's warp, on one core."""
    out = np.empty(len(p))

    def block(start: int) -> None:
        a, b = p[start:start + ANGLE_ROWS], q[start:start + ANGLE_ROWS]
        out[start:start + ANGLE_ROWS] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1),
                                                   (a * b).sum(axis=1))

    run_all(block, range(0, len(p), ANGLE_ROWS))
    return out


def sphere_targets(map_a: SphereMap, m_b: SphereMap, *, fixed: Optional[np.ndarray] = None,
                   fixed_on_b: Optional[np.ndarray] = None,
                   schedule: Sequence[Tuple[float, float, int]] = _nricp.SCHEDULE,
                   should_stop: Callable[[int, int], bool] = lambda done, total: False,
                   b_tree: Optional[OnDemand] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Steps 1-3 of the module doc: where on the sphere each vertex of A
    should go, (n_a, 3) unit vectors in B's map (the ``fixed`` vertices keep
    their places), and the ICP's record. ``b_tree``, if given, is the
    closest-point tree of B's vertices centred and scaled to unit rms radius
    (made once for the registration)."""
    targets, icp, _ = _sphere_targets(map_a, m_b, fixed=fixed, fixed_on_b=fixed_on_b,
                                      schedule=schedule, should_stop=should_stop, b_tree=b_tree)
    return targets, icp


def _descriptor_pairs(a_all: np.ndarray, a_faces: np.ndarray, a_sample: np.ndarray,
                      a_normals: np.ndarray, b_side: BSide
                      ) -> Tuple[_descriptors.DescriptorPairs, np.ndarray]:
    """The ICP's descriptor pairs (:mod:`spherify._descriptors`): B's
    candidates (:meth:`BSide.candidates`) and the descriptors of A's sample
    (``a_sample``, with their ``a_normals``; both shapes in the ICP's
    normalised frame). A's and B's descriptors side by side
    (spherify._workers; each its own bits) where B's are not made yet."""
    def a_side() -> np.ndarray:
        return _descriptors.heights(_descriptors.Surface(a_all, a_faces), a_sample, a_normals,
                                    _nricp.DESCRIPTOR_SCALES)

    a_heights, (candidates, b_heights, faces) = beside(a_side, b_side.candidates)
    pairs = _descriptors.DescriptorPairs(candidates, b_heights, _nricp.DESCRIPTOR_WEIGHT,
                                         _nricp.DESCRIPTOR_REACH, faces)
    return pairs, a_heights


def _sphere_targets(map_a: SphereMap, m_b: SphereMap, *, fixed: Optional[np.ndarray] = None,
                    fixed_on_b: Optional[np.ndarray] = None,
                    schedule: Sequence[Tuple[float, float, int]] = _nricp.SCHEDULE,
                    should_stop: Callable[[int, int], bool] = lambda done, total: False,
                    b_tree: Optional[OnDemand] = None
                    ) -> Tuple[np.ndarray, Dict[str, Any], Callable[[np.ndarray], np.ndarray]]:
    """:func:`sphere_targets`, and the placement it used: a function of
    points of A's surface (A's own frame, (k, 3)) giving their targets on
    B's sphere (the closest point of B to the fitted deformation of each,
    through B's map), for the vertices a scaffold's edge splits add."""
    targets, icp, place, _ = _targets_and_areas(map_a, m_b, fixed=fixed, fixed_on_b=fixed_on_b,
                                                schedule=schedule, should_stop=should_stop,
                                                b_tree=b_tree)
    return targets, icp, place


def _targets_and_areas(map_a: SphereMap, m_b: SphereMap, *,
                       fixed: Optional[np.ndarray] = None,
                       fixed_on_b: Optional[np.ndarray] = None,
                       schedule: Sequence[Tuple[float, float, int]] = _nricp.SCHEDULE,
                       should_stop: Callable[[int, int], bool] = lambda done, total: False,
                       b_tree: Optional[OnDemand] = None, b_side: Optional["BSide"] = None
                       ) -> Tuple[np.ndarray, Dict[str, Any], Callable[[np.ndarray], np.ndarray],
                                  np.ndarray]:
    """:func:`_sphere_targets`, and A's vertex areas (:func:`_vertex_areas`,
    made beside the first targets; the pull weighs by them too).
    ``b_side``, if given, is :class:`BSide` of ``m_b`` (made once for the
    registration)."""
    a_mesh, b_mesh = map_a.mesh, m_b.mesh
    a_centre, a_scale = _frame(a_mesh.vertices)
    a_all = (a_mesh.vertices - a_centre) / a_scale
    if b_side is None:
        b_side = BSide(m_b)
    b_centre, b_scale, b_all = b_side.frame()
    if b_tree is None:
        b_tree = OnDemand(lambda: b_all, b_mesh.faces)
    n = len(a_all)
    sample = np.unique(np.linspace(0, n - 1, min(n, SAMPLE)).astype(np.int64))
    held = fixed is not None and fixed_on_b is not None and len(fixed) > 0
    if held:
        assert fixed is not None and fixed_on_b is not None
        sample = np.union1d(sample, fixed)
    # B's closest-point tree, B's face normals and A's vertex areas do not
    # depend on the first targets: they are made beside them
    # (spherify._workers; each its own bits).
    tree = b_tree
    (first_faces, _, through_sphere), (nearest, b_normals, areas) = beside(
        lambda: m_b.to_surface(map_a.points[sample]),
        lambda: (tree(), b_side.face_normals(), _vertex_areas(a_mesh.vertices, a_mesh.faces)))
    first = (through_sphere - b_centre) / b_scale
    spin = kabsch(a_all[sample], first)
    a_all = a_all @ spin.T
    landmarks = None
    if held:
        assert fixed is not None and fixed_on_b is not None
        landmarks = (np.searchsorted(sample, fixed), b_all[fixed_on_b])
    # A's normals beside the fit's control points (spherify._workers).
    normals, controls = beside(lambda: _nricp.vertex_normals(a_all, a_mesh.faces),
                               lambda: _nricp.control_points(a_all[sample]))
    # B's sample for the reverse pairs, which are used without landmarks only.
    b_sample = None if held else b_side.reverse_sample()
    descriptors = None
    if _nricp.DESCRIPTOR_WEIGHT > 0:
        descriptors = _descriptor_pairs(a_all, a_mesh.faces, a_all[sample], normals[sample],
                                        b_side)
    model, icp = _nricp.nonrigid_icp(
        a_all[sample], normals[sample], areas[sample],
        first, nearest, b_normals, landmarks=landmarks, b_sample=b_sample,
        a_faces=a_mesh.faces if len(sample) == n else None,
        landmark_weight=LANDMARK_WEIGHT, schedule=schedule, should_stop=should_stop,
        controls=controls, descriptors=descriptors, first_faces=first_faces)
    faces, bary, _ = nearest(model(a_all))
    targets = m_b.to_sphere(faces, bary)
    if held:
        assert fixed is not None
        targets[fixed] = map_a.points[fixed]

    def place(points: np.ndarray) -> np.ndarray:
        at, weights, _ = nearest(model(((points - a_centre) / a_scale) @ spin.T))
        placed: np.ndarray = m_b.to_sphere(at, weights)
        return placed

    return targets, icp, place, areas


def warp(map_a: SphereMap, m_b: SphereMap, *, fixed: Optional[np.ndarray] = None,
         fixed_on_b: Optional[np.ndarray] = None,
         should_stop: Callable[[int, int], bool] = lambda done, total: False,
         b_tree: Optional[OnDemand] = None, b_side: Optional[BSide] = None
         ) -> Tuple[SphereMap, Dict[str, Any]]:
    """Warp ``map_a`` (A's certified map, already in B's frame) onto B's map.

    ``fixed`` are A's vertices that do not move (landmarks already at their
    targets) and ``fixed_on_b`` B's vertices they pair with. ``should_stop(done,
    total)`` is asked after every ICP iteration, every round of moves and
    every stage of the pull. ``b_tree`` is as in :func:`sphere_targets`,
    ``b_side`` :class:`BSide` of ``m_b`` if already made.
    Returns the warped, certified map and a record
    of the run (``icp``: the mean distance from the deformed sample to B at
    each iteration, ``moved``: the mean angle still to go after each round
    of moves and each stage of the pull, ``pulled``: the fraction of A's
    vertices the pull worked on, ``scaffold``: whether the map came through
    the scaffold of step 4b, in which case it may be laid out on a refined
    mesh whose first rows are A's vertices).
    """
    done = 0

    def step(_: int, __: int) -> bool:
        nonlocal done
        done += 1
        return should_stop(done, STEPS)

    targets, icp, place, areas = _targets_and_areas(map_a, m_b, fixed=fixed,
                                                    fixed_on_b=fixed_on_b, should_stop=step,
                                                    b_tree=b_tree, b_side=b_side)
    current, left, stopped, angles = _move_rounds(map_a, targets, fixed=fixed, should_stop=step)
    if stopped:
        return current, {"icp": icp["distance"], "moved": left, "pulled": 0.0,
                         "scaffold": False}
    used = False
    held = fixed is not None and len(fixed) > 0
    # The angles left after the rounds, A's mean chord edge and A's vertex
    # areas are made once for the scaffold's test and the pull (each was
    # made two or three times: the same values).
    edge = _mean_edge(current)
    if _lagging(angles, edge, SCAFFOLD_LAG_LANDMARKS if held else SCAFFOLD_LAG):
        # Step 4b (module doc): the scaffold, kept where its rounds end
        # nearer the targets on A's own vertices than the plain rounds.
        pinned = scaffold(map_a, targets, place, fixed=fixed)
        if pinned is not None and pinned[0].mesh.n_vertices > len(targets):
            # The rounds and the pull now work on the refined mesh: the
            # memory policy's check of the registration is asked again for
            # its size (up to SCAFFOLD_GROWTH times A's), and where it does
            # not fit, the plain rounds stand.
            mesh_a, mesh_b = pinned[0].mesh, m_b.mesh
            try:
                _core.check_application("register", mesh_a.n_vertices + mesh_b.n_vertices,
                                        mesh_a.n_faces + mesh_b.n_faces, 0)
            except ResourceError:
                pinned = None
        if pinned is not None:
            n = len(targets)
            trial, trial_left, stopped = move_rounds(
                pinned[0], pinned[1], fixed=fixed, should_stop=lambda _, __: should_stop(done, STEPS))
            if stopped:
                return trial, {"icp": icp["distance"], "moved": trial_left, "pulled": 0.0,
                               "scaffold": True}
            if _angles(trial.points[:n], targets).mean() < angles.mean():
                current, left, targets, used = trial, trial_left, pinned[1], True
    if used:
        # The pull on the scaffold's map (a refined mesh, maybe): its own.
        current, pulled, after = pull(current, targets, fixed=fixed, should_stop=step)
    else:
        current, pulled, after = _pull(current, targets, fixed=fixed, should_stop=step,
                                       left=angles, edge=edge, areas=areas)
    return current, {"icp": icp["distance"], "moved": left + after, "pulled": pulled,
                     "scaffold": used}


def lagging(current: SphereMap, targets: np.ndarray, lag: float = SCAFFOLD_LAG) -> bool:
    """Whether the rounds left ``current`` so far from ``targets`` (mean
    angle above ``lag`` mean chord edges) that whole parts of the map have
    still to travel: the scaffold's case."""
    return _lagging(_angles(current.points, targets), _mean_edge(current), lag)


def _lagging(angles: np.ndarray, edge: float, lag: float) -> bool:
    """:func:`lagging` from the angles left and the mean chord edge."""
    return bool(angles.mean() > lag * edge)


def _mean_edge(current: SphereMap) -> float:
    """The mean chord length of the edges (a, b) of ``current``'s faces."""
    points, faces = current.points, current.mesh.faces
    return float(np.linalg.norm(points[faces[:, 0]] - points[faces[:, 1]], axis=1).mean())


def scaffold(map_a: SphereMap, targets: np.ndarray, place: Callable[[np.ndarray], np.ndarray],
             *, fixed: Optional[np.ndarray] = None) -> Optional[Tuple[SphereMap, np.ndarray]]:
    """Step 4b of the module doc: :data:`SCAFFOLD` of A's vertices
    (farthest-point sampled in space) pinned exactly at their targets by the
    landmark machinery (:func:`spherify.improve` with ``landmarks``: the
    drag, or a layout on a refined mesh where the drag cannot place them),
    the ``fixed`` vertices pinned where they are. Returns the certified
    pinned map and a target for each of its vertices (``place`` for the
    vertices an edge split added), or None where no map places them
    (:class:`MapError`), none within :data:`SCAFFOLD_GROWTH` times A's
    vertices (the layout stops there: a :class:`MapError` too), two share a
    target (:class:`MeshError`) or the layout would not fit the memory
    budget (:class:`ResourceError`)."""
    mesh = map_a.mesh
    ids = farthest_points(mesh.vertices, min(SCAFFOLD, len(targets)))
    points = targets[ids]
    if fixed is not None and len(fixed):
        keep = ~np.isin(ids, fixed)
        ids = np.concatenate([np.asarray(fixed, dtype=np.int64), ids[keep]])
        points = np.concatenate([map_a.points[fixed], points[keep]])
    n = len(targets)
    try:
        pinned = improve(map_a, landmarks=(ids, points),
                         max_vertices=max(4, int(SCAFFOLD_GROWTH * n)))
    except (MapError, MeshError, ResourceError):
        # No map places them within SCAFFOLD_GROWTH (MapError), two of them
        # share a target where the targets fold (MeshError), or the refined
        # layout would not fit the memory budget (ResourceError): the plain
        # rounds stand.
        return None
    if pinned.mesh.n_vertices == n:
        return pinned, targets
    extended = np.concatenate([targets, place(pinned.mesh.vertices[n:])])
    return pinned, extended


def move_rounds(map_a: SphereMap, targets: np.ndarray, *, fixed: Optional[np.ndarray] = None,
                should_stop: Callable[[int, int], bool] = lambda done, total: False
                ) -> Tuple[SphereMap, List[float], bool]:
    """Step 4 of the module doc: ``ROUNDS`` rounds of flip-free moves towards
    ``targets``. Returns the certified map, the mean angle left to the
    targets at the start and after each round, and whether ``should_stop``
    (asked after every round) stopped it."""
    current, left, stopped, _ = _move_rounds(map_a, targets, fixed=fixed, should_stop=should_stop)
    return current, left, stopped


def _move_rounds(map_a: SphereMap, targets: np.ndarray, *, fixed: Optional[np.ndarray] = None,
                 should_stop: Callable[[int, int], bool] = lambda done, total: False
                 ) -> Tuple[SphereMap, List[float], bool, np.ndarray]:
    """:func:`move_rounds`, and the angle each vertex has left to its
    target at the end (n,)."""
    current = map_a
    start = map_a.points
    # The angles from the start to the targets serve the record's first
    # entry and the great circles' arcs (one computation, the same values).
    along = _Slerp(start, targets)
    left = [float(along.angles.mean())]
    # The first rounds aim part of the way (along each great circle), so
    # that a region moves together instead of its first vertices running
    # ahead and blocking the rest: on horse, 8 rounds to 1/8, 2/8, ...
    # of the way left 1.75% mean error against 1.91% for 8 rounds aimed
    # at the targets (1.19% if every target were reached). The rounds from
    # the HOMOTOPY-th on all aim at the targets: one set of points.
    aims: Dict[float, np.ndarray] = {}

    def aim(k: int) -> np.ndarray:
        t = min(1.0, k / HOMOTOPY)
        if t not in aims:
            aims[t] = along(t)
        return aims[t]

    aim(1)
    # Each round's core call runs beside the numpy work that does not wait
    # for it (spherify._workers): the next round's aim and the angle left
    # after the round before. The same points and the same record.
    last: Optional[np.ndarray] = None
    for k in range(1, ROUNDS + 1):
        moving = current
        goal = aim(k)

        def aside(before: Optional[np.ndarray] = last, k: int = k) -> Optional[float]:
            if k < ROUNDS:
                aim(k + 1)
            return None if before is None else float(_angles(before, targets).mean())

        current, before_left = beside(
            lambda: _landmarks.move_towards(moving, goal, fixed=fixed, energy_sweeps=0), aside)
        if before_left is not None:
            left.append(before_left)
        last = current.points
        if should_stop(0, 0):
            angles = _angles(last, targets)
            left.append(float(angles.mean()))
            return current, left, True, angles
    angles = _angles(current.points, targets)
    left.append(float(angles.mean()))
    return current, left, False, angles


def pull(current: SphereMap, targets: np.ndarray, *, fixed: Optional[np.ndarray] = None,
         should_stop: Callable[[int, int], bool] = lambda done, total: False
         ) -> Tuple[SphereMap, float, List[float]]:
    """Step 5 of the module doc: energy sweeps with a pull towards
    ``targets`` where ``current`` stopped short of them. Returns the
    certified map, the fraction of vertices worked on and the mean angle
    left to the targets after each stage. ``should_stop`` is asked after
    every stage (and once per stage even when there is nothing to do)."""
    return _pull(current, targets, fixed=fixed, should_stop=should_stop)


def _pull(current: SphereMap, targets: np.ndarray, *, fixed: Optional[np.ndarray] = None,
          should_stop: Callable[[int, int], bool] = lambda done, total: False,
          left: Optional[np.ndarray] = None, edge: Optional[float] = None,
          areas: Optional[np.ndarray] = None) -> Tuple[SphereMap, float, List[float]]:
    """:func:`pull`, given (where already made) the angles ``left`` from
    ``current`` to the targets, its mean chord ``edge`` and its mesh's
    vertex ``areas`` (:func:`_vertex_areas`)."""
    points, faces = current.points, current.mesh.faces
    n = len(points)
    if left is None:
        left = _angles(points, targets)
    if edge is None:
        edge = _mean_edge(current)
    region = left > PULL_SHORT * edge
    if fixed is not None:
        region[fixed] = False
    after: List[float] = []
    if not region.any():
        for _ in PULL_STAGES:
            if should_stop(0, 0):
                break
        return current, 0.0, after
    def grow() -> None:
        for _ in range(PULL_RINGS):
            region[faces[region[faces].any(axis=1)]] = True

    # The region grows beside A's vertex areas (spherify._workers), where
    # they are not given.
    if areas is None:
        _, weights = beside(grow, lambda: _vertex_areas(current.mesh.vertices, faces))
    else:
        grow()
        weights = areas
    held = ~region
    if fixed is not None:
        held[fixed] = True
    # The pull per unit of the sphere's area: each vertex stands for m_i of
    # the mean vertex's share, 4 pi / n.
    share = weights * (4.0 * np.pi / n)
    # The work of a stage is capped at PULL_WORK moves, so the pull on a
    # large region takes fewer sweeps.
    sweeps = max(1, min(PULL_SWEEPS, PULL_WORK // int(region.sum())))
    held_ids = np.flatnonzero(held)
    # Each stage's core call runs beside the angle left after the stage
    # before (as the rounds do): the same record.
    last: Optional[np.ndarray] = None
    for strength in PULL_STAGES:
        moving = current

        def aside(before: Optional[np.ndarray] = last) -> Optional[float]:
            return None if before is None else float(_angles(before, targets).mean())

        current, before_left = beside(
            lambda: _landmarks.pull_towards(moving, targets, strength * share, fixed=held_ids,
                                            sweeps=sweeps), aside)
        if before_left is not None:
            after.append(before_left)
        last = current.points
        if should_stop(0, 0):
            break
    if last is not None:
        after.append(float(_angles(last, targets).mean()))
    return current, float(region.mean()), after


class _Slerp:
    """Points a fraction of the way from ``p`` to ``q`` along each great
    circle; the angles and their sines are computed once for all rounds."""

    def __init__(self, p: np.ndarray, q: np.ndarray) -> None:
        self.p, self.q = p, q
        self.angles = _angles(p, q)
        self.angle = self.angles[:, None]
        sine = np.sin(self.angle)
        self.safe = np.where(sine > 1e-12, sine, 1.0)

    def __call__(self, t: float) -> np.ndarray:
        p, q, angle = self.p, self.q, self.angle
        out = np.where(angle > 1e-12,
                       (np.sin((1 - t) * angle) * p + np.sin(t * angle) * q) / self.safe, p)
        result: np.ndarray = out / np.linalg.norm(out, axis=1)[:, None]
        return result
