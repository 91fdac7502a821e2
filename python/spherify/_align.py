"""Rigid and conformal alignment of two sphere maps: a rotation or a Möbius
transformation of the sphere carrying A's map onto B's.

Each method puts the features of a shape wherever it likes on the sphere, so
two maps are compared only after one is moved onto the other. The best
transformation T minimises

    E(T) = min over S of  sum_i | S a_i - b(T p_i) |^2

over A's vertices (``p_i`` on the sphere, ``a_i`` on A; ``b(q)`` is B's surface
at ``q``), both shapes centred and scaled to unit rms radius, and ``S`` the
spatial rotation that best superimposes them (Kabsch 1976, solved exactly at
every step): so the alignment compares shapes, not their placement in space.

Rotations: starts from the identity, the rotations that carry the principal
frame of A's degree-1 spherical harmonics (the best-fitting ellipsoid, thesis
8.3) onto B's and, given landmark pairs, the rotation that sends A's
landmarks onto B's on the sphere in least squares (Kabsch on the sphere); the
best starts are refined by Gauss-Newton on the rotation (central differences
through ``to_surface``), on at most 1000 of A's vertices (:func:`best_rotation`).
The winner is checked in space (:mod:`spherify._rigid_icp`): where rigid
ICP finds a clearly better pose of the shapes that is not a polish of the
winner's (another of a near-symmetric shape's poses, as human_man's front
and back), the rotation is taken from that pose.

Möbius transformations (the conformal automorphisms of the sphere; Baden,
Crane and Kazhdan 2018 register shapes with them): T = R o B_b, a rotation
after a boost. The boost by ``b`` (|b| < 1) is the sphere's view of a Lorentz
boost, the aberration of light with velocity ``b``:

    B_b(x) = (sqrt(1 - |b|^2) x + (b.x) b / (1 + sqrt(1 - |b|^2)) + b) / (1 + b.x),

a unit vector for every unit ``x``, the identity at ``b = 0``, and it draws
points towards ``b / |b|``. The six parameters start from the best rotation
with ``b = 0`` and are refined by the same Gauss-Newton.
"""

from __future__ import annotations

from typing import Callable, List, Optional, Sequence, Tuple, TypeVar

import numpy as np

from . import _nearest, _rigid_icp, harmonics
from ._spheremap import SphereMap
from ._workers import beside, parallel, run_all

T = TypeVar("T")

__all__ = ["boost", "kabsch", "normalised", "best_rotation", "best_moebius"]

SUBSAMPLE = 1000
# Vertices on which every start is ranked, and how many of the best are refined.
RANKING_SAMPLE = 150
RANKING_STEPS = 3
REFINED_STARTS = 3
# How many starts go on to each ranking step after the first: before the
# step, the starts still in are ranked by their cost where they stand, and
# only these many best take the step's probes (the Jacobian's six sets of
# points, six sevenths of a step's ``to_surface`` work). Each start's steps
# are its own (its residuals, its least squares), so wherever the three best
# after the last step are still in, the winner and its bits are those of
# ranking every start to the end. Measured on issue 23's pairs (the 13
# corpus meshes below igea against B of level 5, horse and armadillo against
# B of level 6): the three best after the last step ranked at most 13th
# (sword, horse) before the second step and 9th (bumpy) before the third.
# About half the ranking's ``to_surface`` points (1112 sets of the sample
# instead of 2134); horse's rotation stage 2.6 s -> 1.4 s at load 5, the
# same bits.
RANKING_KEPT = (32, 16)
# The largest |b| a Möbius fit may reach: beyond it the boost squeezes half
# the sphere into a cap too small for the map's triangles.
MAX_BOOST = 0.9
# Gauss-Newton stops when a step lowers the cost by less than this fraction.
# At 1e-6 (before) horse's three refined starts ended 8-11 steps later within
# 2e-7 of each other; 1e-4 stops them a few steps earlier (issue 23, speed).
TOLERANCE = 1e-4
# The rigid ICP's pose in space replaces the map rotation's
# (:func:`_pose_in_space`) when they differ by more than this angle (radians)
# and its symmetric closest-point residual is below this fraction of the map
# pose's. human_man's true pose is 0.962 of its front-to-back one; the other
# corpus pairs' best poses are within a degree of their map poses.
SWITCH_ANGLE = 0.5
SWITCH_RATIO = 0.98


def kabsch(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The proper rotation R minimising sum |R p_i - q_i|^2 (rows p_i, q_i)."""
    u, _, vt = np.linalg.svd(q.T @ p)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation: np.ndarray = u @ np.diag([1.0, 1.0, d]) @ vt
    return rotation


def rodrigues(w: np.ndarray) -> np.ndarray:
    """exp of the skew matrix of w: the rotation by |w| about w."""
    angle = float(np.linalg.norm(w))
    if angle < 1e-300:
        return np.eye(3)
    k = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]) / angle
    rotation: np.ndarray = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)
    return rotation


def _kabsch_many(p: np.ndarray, qs: np.ndarray) -> np.ndarray:
    """:func:`kabsch` of ``p`` onto each of ``qs`` (k, n, 3) at once: (k, 3, 3),
    the same bits as one call each (the same products and SVDs, without
    Python's cost per call: the ranking makes about a thousand)."""
    u, _, vt = np.linalg.svd(np.matmul(qs.transpose(0, 2, 1), p))
    d = np.sign(np.linalg.det(u @ vt))
    signs = np.ones((len(qs), 1, 3))
    signs[:, 0, 2] = np.where(d == 0, 1.0, d)
    rotations: np.ndarray = np.matmul(u * signs, vt)
    return rotations


def _normalised_many(xs: np.ndarray) -> np.ndarray:
    """:func:`normalised` of each of ``xs`` (k, n, 3), the same bits."""
    c = xs - xs.mean(axis=1)[:, None, :]
    scale = np.sqrt((c * c).sum(axis=2).mean(axis=1))
    result: np.ndarray = c / np.where(scale > 0, scale, 1.0)[:, None, None]
    return result


def normalised(x: np.ndarray) -> np.ndarray:
    """``x`` centred on its mean and scaled to unit rms radius."""
    c = x - x.mean(axis=0)
    scale = np.sqrt((c * c).sum(axis=1).mean())
    result: np.ndarray = c / (scale if scale > 0 else 1.0)
    return result


def boost(b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """B_b applied to the unit rows of ``x`` (module doc)."""
    b = np.asarray(b, dtype=np.float64)
    root = np.sqrt(max(0.0, 1.0 - float(b @ b)))
    bx = x @ b
    out: np.ndarray = (root * x + np.outer(bx / (1.0 + root), b) + b) / (1.0 + bx)[:, None]
    # The formula is a unit vector in exact arithmetic; one division removes
    # the rounding so the result is as good a sphere point as the input.
    out /= np.linalg.norm(out, axis=1)[:, None]
    return out


class Cost:
    """E(T) on a fixed set of A's vertices, T given as a function of sphere points."""

    def __init__(self, a: np.ndarray, p: np.ndarray, m_b: SphereMap) -> None:
        self.a = normalised(a)
        self.p = p
        self.m_b = m_b

    def residual(self, transform: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        _, _, xyz = self.m_b.to_surface(transform(self.p))
        b = normalised(xyz)
        s = kabsch(self.a, b)
        r: np.ndarray = (self.a @ s.T - b).ravel()
        return r

    def __call__(self, transform: Callable[[np.ndarray], np.ndarray]) -> float:
        r = self.residual(transform)
        return float(r @ r)

    def residuals_of(self, transforms: List[Callable[[np.ndarray], np.ndarray]]) -> np.ndarray:
        """The residuals of several transformations with one ``to_surface``
        call (each point is located on its own, so the bits are those of
        one call per transformation): (k, 3 * points)."""
        _, _, xyz = self.m_b.to_surface(np.concatenate([t(self.p) for t in transforms]))
        return self._residuals_at(xyz.reshape(len(transforms), len(self.p), 3))

    def residuals_of_rotations(self, rotations: np.ndarray) -> np.ndarray:
        """The residuals of many rotations (k, 3, 3) with one ``to_surface``
        call: (k, 3 * points)."""
        k, n = len(rotations), len(self.p)
        turned = np.einsum("kij,nj->kni", rotations, self.p).reshape(k * n, 3)
        _, _, xyz = self.m_b.to_surface(turned)
        return self._residuals_at(xyz.reshape(k, n, 3))

    def _residuals_at(self, xyz: np.ndarray) -> np.ndarray:
        """The residuals for k sets of points on B (k, points, 3), all at once
        (the same bits as :meth:`residual` on each): (k, 3 * points)."""
        b = _normalised_many(xyz)
        spins = _kabsch_many(self.a, b)
        out: np.ndarray = (np.matmul(self.a, spins.transpose(0, 2, 1)) - b).reshape(len(b), -1)
        return out


def subsample_cost(m_a: SphereMap, m_b: SphereMap) -> Cost:
    """The cost on at most :data:`SUBSAMPLE` of A's vertices, evenly spread in index."""
    pick = np.unique(np.linspace(0, len(m_a.points) - 1, SUBSAMPLE).astype(np.int64))
    return Cost(m_a.mesh.vertices[pick], m_a.points[pick], m_b)


def _turn(rotation: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    return lambda p: p @ rotation.T


def moebius_transform(rotation: np.ndarray, b: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The function p -> R B_b(p)."""
    return lambda p: boost(b, p) @ rotation.T


def frame_candidates(m_a: SphereMap, m_b: SphereMap) -> List[np.ndarray]:
    """Rotations carrying the principal axes of A's degree-1 harmonics onto B's."""
    def linear_part(m: SphereMap) -> np.ndarray:
        c = harmonics.fit(m, 1, oversample=8).coefficients
        # f1(p) = sqrt(3 / 4 pi) (c(1,1) x + c(1,-1) y + c(1,0) z): columns per axis.
        return np.stack([c[3], c[1], c[2]], axis=1)

    # The two fits side by side (spherify._workers; each its own bits).
    parts = run_all(linear_part, [m_a, m_b])
    _, _, va = np.linalg.svd(parts[0])
    _, _, vb = np.linalg.svd(parts[1])
    out = []
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1),
                  (-1, -1, -1), (-1, 1, 1), (1, -1, 1), (1, 1, -1)):
        r = vb.T @ np.diag(signs) @ va
        if np.linalg.det(r) > 0:
            out.append(r)
    return out


def _gauss_newton(cost: Cost, params: np.ndarray,
                  transform: Callable[[np.ndarray], Callable[[np.ndarray], np.ndarray]],
                  max_iter: int) -> Tuple[np.ndarray, int]:
    """Gauss-Newton on ``params`` (central differences, step halving when the
    cost does not fall); ``transform(params)`` is the sphere map they stand
    for. Returns the parameters and the iterations taken."""
    return _gauss_newton_many(cost, [params], lambda _, w: transform(w), max_iter)[0]


def _gauss_newton_many(cost: Cost, starts: Sequence[np.ndarray],
                       transform: Callable[[int, np.ndarray],
                                           Callable[[np.ndarray], np.ndarray]],
                       max_iter: int) -> List[Tuple[np.ndarray, int]]:
    """:func:`_gauss_newton` from each of ``starts`` (``transform(k, params)``
    the sphere map of start k's parameters), all at once: each start takes
    its own steps and halvings, but the probes of every start still going
    are located in one ``to_surface`` call per step, and the trial points of
    every start still halving in one call per halving (each point is located
    on its own, so the bits are those of one start at a time). The starts
    share the core's threads instead of taking one each: three starts on two
    threads kept one thread busy with two of them (issue 23, speed)."""
    h = 1e-6
    k_all = len(starts)
    params = [np.asarray(w, dtype=np.float64) for w in starts]
    steps = [np.eye(len(w)) * h for w in params]
    rows = cost.residuals_of([transform(k, params[k]) for k in range(k_all)])
    current = [float(r @ r) for r in rows]
    ended: List[Optional[int]] = [None] * k_all
    for iteration in range(1, max_iter + 1):
        live = [k for k in range(k_all) if ended[k] is None]
        if not live:
            break
        # The residual and both probes of every parameter of every start
        # going on in one call (each ``to_surface`` call costs about a
        # millisecond besides its points).
        probes = [t for k in live for t in
                  [transform(k, params[k])] + [transform(k, params[k] + sign * e)
                                               for e in steps[k] for sign in (1.0, -1.0)]]
        rows = cost.residuals_of(probes)
        step = {}
        at = 0
        for k in live:
            block = rows[at:at + 1 + 2 * len(params[k])]
            at += len(block)
            jac = ((block[1::2] - block[2::2]) / (2 * h)).T
            step[k] = -np.linalg.lstsq(jac, block[0], rcond=None)[0]
        # The line searches side by side: each start halves its step until
        # its cost does not rise (at most 30 times).
        waiting = list(live)
        accepted = {}
        for _ in range(30):
            if not waiting:
                break
            trials = {k: params[k] + step[k] for k in waiting}
            rows = cost.residuals_of([transform(k, trials[k]) for k in waiting])
            still = []
            for k, r in zip(waiting, rows):
                value = float(r @ r)
                if value <= current[k]:
                    accepted[k] = (trials[k], value)
                else:
                    step[k] /= 2
                    still.append(k)
            waiting = still
        for k in waiting:
            ended[k] = iteration
        for k, (trial, value) in accepted.items():
            params[k], previous, current[k] = trial, current[k], value
            if (np.linalg.norm(step[k]) < 1e-9
                    or previous - current[k] <= TOLERANCE * max(previous, 1e-300)):
                ended[k] = iteration
    return [(w, max_iter if end is None else end) for w, end in zip(params, ended)]


def refine_rotation(cost: Cost, rotation: np.ndarray, max_iter: int = 50) -> Tuple[np.ndarray, int]:
    """Gauss-Newton on the rotation, w in R^3 with R <- exp(w) R."""
    return refine_rotations(cost, [rotation], max_iter)[0]


def refine_rotations(cost: Cost, rotations: Sequence[np.ndarray],
                     max_iter: int = 50) -> List[Tuple[np.ndarray, int]]:
    """:func:`refine_rotation` of each of ``rotations``, all at once
    (:func:`_gauss_newton_many`: the bits of one start at a time)."""
    bases = [np.asarray(r) for r in rotations]
    done = _gauss_newton_many(cost, [np.zeros(3) for _ in bases],
                              lambda k, w: _turn(rodrigues(w) @ bases[k]), max_iter)
    return [(rodrigues(w) @ base, iterations) for (w, iterations), base in zip(done, bases)]


def _batched_gauss_newton(cost: Cost, rotations: np.ndarray, steps: int,
                          kept: Sequence[int] = ()) -> Tuple[np.ndarray, np.ndarray]:
    """A few plain Gauss-Newton steps on every rotation at once (central
    differences; all probes of a step in one ``to_surface`` call), so that
    each start is ranked by the minimum its basin leads to, not by where it
    begins. Before step ``s + 1`` only the ``kept[s]`` starts of lowest cost
    where they stand take the step (:data:`RANKING_KEPT`); the others drop
    out. Returns the indices of the starts still in (ascending) and their
    rotations after the last step."""
    h = 1e-6
    probes = [rodrigues(sign * h * e) for e in np.eye(3) for sign in (1.0, -1.0)]
    alive = np.arange(len(rotations))
    rotations = rotations.copy()
    for s in range(steps):
        current = rotations[alive]
        r0 = cost.residuals_of_rotations(current)
        if 1 <= s <= len(kept) and kept[s - 1] < len(alive):
            best = np.sort(np.argsort((r0 ** 2).sum(axis=1), kind="stable")[:kept[s - 1]])
            alive, current, r0 = alive[best], current[best], r0[best]
        k = len(alive)
        batch = np.concatenate([np.einsum("ij,kjl->kil", q, current) for q in probes])
        r = cost.residuals_of_rotations(batch).reshape(6, k, -1)
        for i in range(k):
            jac = np.stack([(r[2 * a, i] - r[1 + 2 * a, i]) / (2 * h) for a in range(3)],
                           axis=1)
            step = -np.linalg.lstsq(jac, r0[i], rcond=None)[0]
            angle = float(np.linalg.norm(step))
            if angle > 0.5:  # a linearisation is not trusted beyond ~30 degrees
                step *= 0.5 / angle
            rotations[alive[i]] = rodrigues(step) @ current[i]
    return alive, rotations[alive]


def octahedral_group() -> List[np.ndarray]:
    """The 24 rotations that map the coordinate axes onto themselves."""
    out = []
    for perm in ((0, 1, 2), (1, 2, 0), (2, 0, 1), (1, 0, 2), (0, 2, 1), (2, 1, 0)):
        for signs in ((1, 1, 1), (1, 1, -1), (1, -1, 1), (1, -1, -1),
                      (-1, 1, 1), (-1, 1, -1), (-1, -1, 1), (-1, -1, -1)):
            r = np.zeros((3, 3))
            r[np.arange(3), perm] = signs
            if np.linalg.det(r) > 0:
                out.append(r)
    return out


def best_rotation(m_a: SphereMap, m_b: SphereMap,
                  landmark_rotation: Optional[np.ndarray] = None) -> Tuple[np.ndarray, str, int]:
    """The rotation of the sphere that best matches the shapes (module doc):
    the rotation, the name of the start that won, and the Gauss-Newton steps.
    Given the landmarks' rotation, only it is refined.

    Every start takes :data:`RANKING_STEPS` Gauss-Newton steps on
    :data:`RANKING_SAMPLE` vertices (all starts at once; before the second
    and the third step only the :data:`RANKING_KEPT` best where they stand
    go on), and the best :data:`REFINED_STARTS` are refined to the end. Besides the identity, the harmonic frames
    and the landmarks' rotation, each harmonic frame turned by the 24
    rotations of the octahedral group is a start: the frame of a shape with
    a near-symmetric ellipsoid (an octopus, whose eight arms make it round)
    says little, and the cost has a minimum near each turn of it. The
    winner is then checked in space (:func:`_pose_in_space`): its start is
    named ``"rigid ICP in space"`` where that check replaced it."""
    rotation, name, iterations, _ = best_rotation_then(m_a, m_b, landmark_rotation)
    return rotation, name, iterations


def best_rotation_then(m_a: SphereMap, m_b: SphereMap,
                       landmark_rotation: Optional[np.ndarray] = None,
                       then: Optional[Callable[[np.ndarray], T]] = None,
                       b_tree: Optional[_nearest.OnDemand] = None,
                       keep_switch: Optional[Callable[[T, T], bool]] = None,
                       prepare: Optional[Callable[[], None]] = None
                       ) -> Tuple[np.ndarray, str, int, Optional[T]]:
    """:func:`best_rotation` and ``then(rotation)`` (the rest of a
    registration: the Möbius fit and the warp): the rotation, its start's
    name, its steps and what ``then`` returned (None without ``then``).
    ``b_tree``, if given, is the closest-point tree of B's vertices
    normalised (:func:`normalised`), for the check in space (registration
    shares it with the warp).

    ``then`` runs from the map rotation on this thread (its own pieces go to
    the pool) while the check in space runs on a pool thread beside it
    (spherify._workers): on issue 23's pairs the check switched the rotation
    only on human_man, so its time is mostly hidden. Where the check
    switches, ``then`` runs again from the new rotation, so the results are
    those of the check first and ``then`` after it, to the bit. Where the
    pieces cannot run side by side (one thread), the check goes first.

    ``keep_switch(switched, unswitched)``, if given, has the last word on a
    switch: it sees ``then``'s results from both rotations (the one from
    the map rotation is made after all on one thread, so the answer is the
    same for every thread count) and the map rotation stands where it says
    no.

    ``prepare``, if given, is called on the pool thread that makes B's
    closest-point tree beside the search for the rotation (work of ``then``
    that does not depend on the rotation)."""
    def after(rotation: np.ndarray) -> Optional[T]:
        return None if then is None else then(rotation)

    if landmark_rotation is not None:
        # Landmarks say which of a symmetric shape's equally good rotations is
        # meant: only their rotation is refined.
        rotation, iterations = refine_rotation(subsample_cost(m_a, m_b), landmark_rotation)
        return rotation, "landmarks", iterations, after(rotation)
    # B's closest-point tree (shared with the warp) and ``prepare`` (the
    # warp's side of B) do not depend on the rotation: they are made on a
    # pool thread beside the search for it (spherify._workers). The check's
    # own rough runs from the principal frames (A's tree and four rigid ICP
    # runs) are not: they go with the check, beside the stages after the
    # rotation, whose pieces leave the second core idle more than the
    # search's do (the search's located batches run on both cores alone);
    # the same poses, each run's bits its own (issue 23, speed, session 12).
    def aside() -> None:
        if b_tree is not None:
            b_tree()
        if prepare is not None:
            prepare()

    (rotation, name, iterations, cost), _ = beside(lambda: _search_rotation(m_a, m_b), aside)

    def check() -> Optional[Tuple[np.ndarray, int]]:
        return _pose_in_space(m_a, m_b, rotation, cost, b_tree)

    unswitched: Optional[T] = None
    if then is None or not parallel():
        switched = check()
        if switched is None or keep_switch is not None:
            unswitched = after(rotation)
    else:
        # ``then`` on this thread, from the map rotation, while the check
        # runs beside it; where the check switches, its result is kept only
        # for ``keep_switch``.
        unswitched, switched = beside(lambda: after(rotation), check)
    if switched is None:
        return rotation, name, iterations, unswitched
    result = after(switched[0])
    if keep_switch is not None and then is not None:
        assert result is not None and unswitched is not None
        if not keep_switch(result, unswitched):
            return rotation, name, iterations, unswitched
    return switched[0], "rigid ICP in space", switched[1], result


def _search_rotation(m_a: SphereMap, m_b: SphereMap) -> Tuple[np.ndarray, str, int, Cost]:
    """:func:`best_rotation`'s search on the sphere, before the check in
    space: the rotation, its start's name, its steps and the cost on
    :data:`SUBSAMPLE` vertices it was refined on."""
    starts: List[Tuple[str, np.ndarray]] = [("identity", np.eye(3))]
    frames = frame_candidates(m_a, m_b)
    starts += [(f"harmonic frame {k}", r) for k, r in enumerate(frames)]
    group = octahedral_group()[1:]  # the first is the identity
    starts += [(f"harmonic frame {k} turned {j + 1}", g @ r)
               for k, r in enumerate(frames) for j, g in enumerate(group)]
    pick = np.unique(np.linspace(0, len(m_a.points) - 1, RANKING_SAMPLE).astype(np.int64))
    rough = Cost(m_a.mesh.vertices[pick], m_a.points[pick], m_b)
    alive, rotations = _batched_gauss_newton(rough, np.stack([r for _, r in starts]),
                                             RANKING_STEPS, RANKING_KEPT)
    values = (rough.residuals_of_rotations(rotations) ** 2).sum(axis=1)
    ranked = [(starts[alive[i]][0], rotations[i]) for i in np.argsort(values, kind="stable")]
    ranked = ranked[:REFINED_STARTS]
    cost = subsample_cost(m_a, m_b)
    best: Optional[Tuple[float, np.ndarray, str, int]] = None
    # The starts are refined side by side (each its own bits) and compared
    # in their ranked order.
    for (name, _), (rotation, iterations) in zip(
            ranked, refine_rotations(cost, [r for _, r in ranked])):
        value = cost(_turn(rotation))
        if best is None or value < best[0]:
            best = (value, rotation, name, iterations)
    assert best is not None
    return best[1], best[2], best[3], cost


def _pose_in_space(m_a: SphereMap, m_b: SphereMap, rotation: np.ndarray, cost: Cost,
                   b_tree: Optional[_nearest.OnDemand] = None,
                   search: Optional[_rigid_icp.Search] = None
                   ) -> Optional[Tuple[np.ndarray, int]]:
    """The sphere rotation of a better pose in space (:mod:`spherify._rigid_icp`),
    or None where the map rotation's own pose is as good.

    The switch needs the two poses to differ by more than :data:`SWITCH_ANGLE`
    (another of a near-symmetric shape's poses, not a polish of the same one)
    and the other's symmetric closest-point residual to be below
    :data:`SWITCH_RATIO` of the map pose's. The new sphere rotation sends A's
    sphere points onto the sphere points (in B's map) of their closest points
    on B in that pose, and is refined by the map cost's Gauss-Newton.
    ``search``, if given, is the :class:`spherify._rigid_icp.Search` of the
    normalised shapes (with ``b_tree``) already made."""
    a, b = m_a.mesh, m_b.mesh
    if b_tree is None:
        b_n = normalised(b.vertices)
        b_tree = _nearest.OnDemand(lambda: b_n, b.faces)
    if search is None:
        search = _rigid_icp.Search(normalised(a.vertices), a.faces, normalised(b.vertices),
                                   b.faces, b_tree)
    a_n = search.pair.a
    _, _, xyz = m_b.to_surface(cost.p @ rotation.T)
    # The spatial pose the map rotation implies: A's subsample onto its images.
    map_pose = kabsch(cost.a, normalised(xyz))
    best, from_map = search.best(map_pose)
    if (_rigid_icp.pose_angle(best.rotation, from_map.rotation) <= SWITCH_ANGLE
            or best.residual >= SWITCH_RATIO * from_map.residual):
        return None
    pick = np.unique(np.linspace(0, len(m_a.points) - 1, SUBSAMPLE).astype(np.int64))
    faces, bary, _ = b_tree()(a_n[pick] @ best.rotation.T + best.shift)
    start = kabsch(m_a.points[pick], m_b.to_sphere(faces, bary))
    return refine_rotation(cost, start)


def best_moebius(m_a: SphereMap, m_b: SphereMap, rotation: np.ndarray,
                 max_iter: int = 20) -> Tuple[np.ndarray, np.ndarray, int]:
    """The Möbius transformation R B_b refined from ``rotation`` (and b = 0):
    returns (R, b, Gauss-Newton steps). |b| is kept below :data:`MAX_BOOST`."""
    cost = subsample_cost(m_a, m_b)

    def transform(params: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        return moebius_transform(rodrigues(params[:3]) @ rotation, _capped(params[3:]))

    params, iterations = _gauss_newton(cost, np.zeros(6), transform, max_iter)
    return rodrigues(params[:3]) @ rotation, _capped(params[3:]), iterations


def _capped(b: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(b))
    if norm <= MAX_BOOST:
        return b
    capped: np.ndarray = b * (MAX_BOOST / norm)
    return capped
