"""Non-rigid ICP in space: a smooth deformation of A fitted onto B's surface.

Registration through two sphere maps starts from correspondences that are
right in the large (a rotation or Möbius transformation has put A's map in
B's frame) but wrong in the small: the two maps put the features in slightly
different places, so A's finger lands beside B's finger. Measured on the
sphere alone, that sliding along the surface and the true bend of the shape
look alike. A deformation model tells them apart: B is A bent smoothly in
space, and a smooth map of space cannot follow a slide that changes from
one finger to the next.

The model (the Gaussian radial-basis deformation of coherent point drift,
Myronenko and Song 2010, with an affine part):

    T(x) = M x + t + sum_k w_k exp(-|x - c_k|^2 / (2 sigma^2)),

with control points ``c_k`` farthest-point sampled on A. Given target points
``y_i`` for A's points ``a_i`` with weights ``v_i``, ``T`` minimises

    sum_i v_i |T(a_i) - y_i|^2 + lambda tr(W^T G W) + mu |M - I|^2,

(``G`` the kernel between the control points: the norm of the radial part
in the kernel's space, which penalises wiggles more than broad bends), a
linear least-squares problem of 4 + K unknowns per coordinate.

Non-rigid ICP (Amberg, Romdhani and Vetter 2007) alternates the fit with new
targets: the closest points of B's surface to the deformed A
(:class:`spherify._nearest.NearestOnSurface`), pairs much farther apart than
the typical pair, or whose normals disagree, left out. The stiffness is
annealed: the kernel width ``sigma`` and ``lambda`` go from wide and stiff
(the global bend, with the first targets taken through the sphere maps) to
narrow and soft. Landmark pairs enter as targets of high weight throughout.

Without landmarks, the stiff stages also use reverse pairs, as symmetric
(two-way) ICP does: each sampled point ``b_j`` of B pulls on the deformed
point of A's sample nearest to it, so the data term becomes

    sum_i v_i |T(a_i) - y_i|^2 + sum_j u_j |T(a_{n(j)}) - b_j|^2,

still linear in ``T`` (the pairs of one row merge into one weighted target).
The one-way pairs only ask that A lie on B; a part of B that no part of A
has reached (a human's arm matched to the side of the torso, a scorpion's leg
to its neighbour) pulls on nothing. The reverse pairs ask that B be covered,
which carries whole limbs to their counterparts while the deformation is
still stiff enough to move them together. Only B's points not covered yet
pull: those farther from the deformed A, or from the points of B that A's
own pairs land on, than twice the median of such gaps. On covered, smooth
parts the pairs between discrete sample points only add noise. Measured on
issue 23's pairs (docs/correspondence.md, "Reverse pairs"), the targets'
mean / p95 error, one-way against two-way: human_man 2.00% / 9.31% ->
0.91% / 2.38%, horse 1.22% / 2.98% -> 0.91% / 1.72%, hand 1.15% / 2.77% ->
1.00% / 2.27%, octopus 1.31% / 2.80% -> 0.76% / 1.87%, scorpion 2.85% /
10.28% -> 0.93% / 3.38%; spot, knight and igea within 0.01-0.04 points;
but blub_control (112 vertices) 1.49% / 3.21% -> 2.13% / 5.12%, which is
not understood (see the doc). The soft stages go on one-way (with the pairs on every
stage igea's targets went 1.19% -> 1.30%). With landmarks the pairs already
hold the limbs and the reverse pairs made the targets a little worse (igea
0.73% -> 0.80%, hand 0.60% -> 0.63%), so they are not used.

The closest points hold a point tangentially where the last fit put it, so
on a smooth surface a slide of the start survives the ICP. With
``descriptors`` (:mod:`spherify._descriptors`), a pair whose nearest
candidate of B in position *and* in the heights of the surface around it is
not its nearest in position alone moves by the difference of the two
(feature-augmented ICP: Johnson and Kang 1999; Sharp, Lee and Wehe 2002).
Measured on issue 23's pairs (docs/correspondence.md, "Session 10: igea and
Möbius"), the warp without landmarks: igea 1.21% / 2.84% -> 0.69% / 1.55%
(mean / p95), hand 1.00% / 2.27% -> 0.80% / 1.76%, horse 1.34% / 4.28% ->
1.05% / 4.27%. Their cost, with the heights and the search in the core
("Session 11: the descriptor pairs in the core"): +4.5-6.5% of `register`'s
CPU on the speed pairs, most of it the shifted pairs' closest-point searches.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ._descriptors import DescriptorPairs
from ._nearest import NearestOnSurface
from ._workers import beside, run_all

__all__ = ["Deformation", "SCHEDULE", "control_points", "fit", "nonrigid_icp"]

# (sigma over the shape's rms radius, lambda per point, ICP iterations),
# wide and stiff to narrow and soft. Measured on issue 23's pairs (targets'
# mean error over B's diagonal, from the Möbius start): stopping at sigma 0.4
# left hand at 1.38% and horse at 1.38% against 1.15% and 1.19% with this
# schedule; one iteration a stage instead of three, 1.87% and 2.07%.
SCHEDULE: Tuple[Tuple[float, float, int], ...] = (
    (1.0, 1e-1, 3), (0.6, 3e-2, 3), (0.4, 1e-2, 3), (0.25, 3e-3, 3), (0.15, 1e-3, 3))
# How strongly the affine part is held to the identity (per point).
AFFINE_STIFFNESS = 1e-3
# Pairs whose normals' cosine is at most this are left out: a point of the
# deformed A facing away from its closest point of B is on the wrong side of a
# thin part (a leg's front matched to the other leg's back). A test of the
# distance (pairs beyond 3 or 5 times the median) was tried and left out: on
# horse it dropped a quarter of the pairs, exactly where the fit was still
# wrong, and the error from the true pairs grew from 0.7% to 1.1%.
NORMAL_COSINE = 0.0
# The reverse pairs (module doc): B's sample weighs this many times A's in
# the data term (0: one-way ICP throughout; 0.5 left the targets between 0
# and 1), in the stages whose sigma is at least REVERSE_SIGMA (the three
# stiffest; with 0.6, the two stiffest, or 1.0 the gain shrank: human_man
# 1.17% / 3.09% and 1.61% / 6.39% with every point of B pulling), and only
# from B's points not covered yet: their gap to the nearest deformed point of
# A, or to the nearest point of B that A's own pairs land on, above
# REVERSE_FAR times the median of such gaps (0: every point pulls). With
# every point pulling, spot's and igea's targets got worse (0.63% / 1.85% ->
# 0.65% / 1.96%; 1.19% / 2.80% -> 1.20-1.30%); with the first gap alone
# scorpion kept little of its gain (1.73% / 7.66%: its legs lie close to
# their neighbours, but A's pairs on B's legs are missing); with the second
# alone octopus kept less (1.04% / 2.39%); thresholds of 1.5 (spot, igea
# worse), 2.5 and 3 (less gain) were measured too.
REVERSE = 1.0
REVERSE_SIGMA = 0.4
REVERSE_FAR = 2.0
# The descriptor pairs (spherify._descriptors): the heights of the surface
# over its neighbourhood at DESCRIPTOR_SCALES (over the rms radius), each
# scaled by its spread over B's candidates (B's surface DESCRIPTOR_SPACING
# apart) and weighted by DESCRIPTOR_WEIGHT against the position (0: closest
# points only); a pair is certain where the weighted distance is at most
# DESCRIPTOR_REACH (else the closest point stands). Measured on issue 23's
# pairs (docs/correspondence.md, "Session 10: igea and Möbius"), warp without
# landmarks, mean / p95: weight 0.04 left igea at 0.86% / 2.03% and blub's p95
# at 6.61% (its bar 6.18%), 0.06 igea 0.69% / 1.55%; used in every stage
# (only at sigma <= 0.25 or <= 0.4, igea 0.96% and 0.88%).
DESCRIPTOR_WEIGHT = 0.06
DESCRIPTOR_SCALES = (0.1, 0.2)
DESCRIPTOR_REACH = 0.1
DESCRIPTOR_SPACING = 0.05
# Control points of the radial part. Fitted to the true pairs of horse's
# bend, 100 or 300 reproduce it to 0.06-0.1% of the diagonal; 300 leave room
# for bends less smooth than the bench's.
CONTROLS = 300
# Points whose kernel is evaluated at once (memory: ROWS x CONTROLS doubles).
# 2000 rows (4.8 MB) stay near the cache through the kernel's passes; with
# 20,000 the deformation of horse's 48k vertices took 0.34-0.80 s, with 2000
# (and the passes in place) 0.15-0.37 s, the same bits (issue 23, speed).
ROWS = 2000

@dataclass
class Deformation:
    """T(x) = x @ linear.T + shift + kernel(x) @ weights (module doc)."""

    linear: np.ndarray
    shift: np.ndarray
    controls: np.ndarray
    weights: np.ndarray
    sigma: float

    def kernel(self, x: np.ndarray) -> np.ndarray:
        # exp(-|x - c|^2 / 2 sigma^2), the squared distances through the
        # product x c^T; every pass in place on one array (a new array per
        # pass made this memory-bound).
        d2: np.ndarray = (x * x).sum(1)[:, None] + (self.controls * self.controls).sum(1)[None, :]
        d2 -= 2.0 * x @ self.controls.T
        np.maximum(d2, 0.0, out=d2)
        np.negative(d2, out=d2)
        np.divide(d2, 2.0 * self.sigma ** 2, out=d2)
        np.exp(d2, out=d2)
        return d2

    def __call__(self, x: np.ndarray) -> np.ndarray:
        out = np.empty_like(x)

        def block(start: int) -> None:
            part = x[start:start + ROWS]
            out[start:start + ROWS] = (part @ self.linear.T + self.shift
                                       + self.kernel(part) @ self.weights)

        # Blocks side by side on two cores (spherify._workers), each written
        # to its own rows: the same bits as one after another.
        run_all(block, range(0, len(x), ROWS))
        return out

    def turn_normals(self, normals: np.ndarray) -> np.ndarray:
        """Normals carried by the affine part (the radial part's turn is
        small against the angle the outlier test allows)."""
        n = normals @ np.linalg.inv(self.linear)
        out: np.ndarray = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        return out


def fit(a: np.ndarray, y: np.ndarray, v: np.ndarray, controls: np.ndarray, sigma: float,
        stiffness: float, phi: Optional[np.ndarray] = None,
        normal: Optional[np.ndarray] = None, design: Optional[np.ndarray] = None,
        gram: Optional[np.ndarray] = None) -> Deformation:
    """The deformation minimising the module doc's energy for points ``a``,
    targets ``y`` and weights ``v`` (lambda = stiffness times the weights'
    sum); ``phi`` is the kernel between ``a`` and the controls if known,
    ``normal`` the data term's normal matrix D^T diag(v) D (D = [a, 1, phi])
    if known, ``design`` D itself if known and ``gram`` the kernel between
    the controls if known (the ICP's fits of one width share them)."""
    model = Deformation(np.eye(3), np.zeros(3), controls, np.zeros((len(controls), 3)), sigma)
    if design is None:
        design = _design(a, model.kernel(a) if phi is None else phi)
    if normal is None:
        normal = design.T @ (design * v[:, None])
    else:
        normal = normal.copy()
    rhs = design.T @ (y * v[:, None])
    total = float(v.sum())
    k = len(controls)
    normal[:3, :3] += AFFINE_STIFFNESS * total * np.eye(3)
    rhs[:3] += AFFINE_STIFFNESS * total * np.eye(3)
    if gram is None:
        gram = model.kernel(controls)
    normal[4:, 4:] += stiffness * total * gram
    # The kernel between close controls is nearly singular; a whisker of
    # ridge keeps the solve well posed without changing the fit.
    normal[4:, 4:] += 1e-10 * total * np.eye(k)
    theta = np.linalg.solve(normal, rhs)
    return Deformation(theta[:3].T.copy(), theta[3].copy(), controls, theta[4:].copy(), sigma)


def _design(a: np.ndarray, phi: np.ndarray) -> np.ndarray:
    out: np.ndarray = np.hstack([a, np.ones((len(a), 1)), phi])
    return out


def _outward(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The faces' cross products, turned outwards: a mesh may come with its
    faces turned in (``embed`` reorients only its own copy), and the normal
    test compares A's normals with B's."""
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                     vertices[faces[:, 2]] - vertices[faces[:, 0]])
    volume = float((cross * vertices[faces[:, 0]]).sum())
    out: np.ndarray = -cross if volume < 0 else cross
    return out


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted outward vertex normals (unit; zero where the faces cancel)."""
    cross = _outward(vertices, faces)
    # Each face's cross product added to its three corners: bincount sums
    # in the order of its input, all first corners, then all second ones,
    # then the third (the order of np.add.at one corner after another), so
    # the same bits; armadillo's normals 24 ms -> 15 ms (issue 23, speed).
    corners = faces.T.ravel()
    normals = np.stack([np.bincount(corners, np.tile(cross[:, j], 3), len(vertices))
                        for j in range(3)], axis=1)
    length = np.linalg.norm(normals, axis=1)
    out: np.ndarray = normals / np.where(length > 0, length, 1.0)[:, None]
    return out


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Outward unit face normals."""
    cross = _outward(vertices, faces)
    length = np.linalg.norm(cross, axis=1)
    out: np.ndarray = cross / np.where(length > 0, length, 1.0)[:, None]
    return out


def control_points(a: np.ndarray) -> np.ndarray:
    """The radial part's control points: :data:`CONTROLS` of ``a``'s rows,
    farthest-point sampled."""
    from .datasets import farthest_points
    out: np.ndarray = a[farthest_points(a, min(CONTROLS, len(a)))]
    return out


class _Reverse:
    """The reverse pairs of the module doc: each point of B's sample paired
    with the nearest point of the deformed A, pairs whose normals disagree
    left out, and only from B's points that are not covered yet (see
    :data:`REVERSE_FAR`). The deformed A is its sample's points (the core's
    closest-point tree over one-point triangles: Ericson's closest point of
    a triangle whose corners coincide is that corner) or, where the sample
    is all of A (``faces`` given), its surface: a pair then pulls on the
    corners of its face, each with its barycentric share of the weight (on
    blub's 112 vertices a point of B in the middle of a large face of A
    pulled one corner to it). Called with A's deformed points, their
    normals and the points of B their own pairs land on, returns per point
    of A the weight of the B points paired with it and their weighted sum."""

    def __init__(self, b_sample: Tuple[np.ndarray, np.ndarray, np.ndarray], a_total: float,
                 n: int, faces: Optional[np.ndarray] = None) -> None:
        self.points, self.normals, area = b_sample
        # B's sample weighs REVERSE times A's in all.
        self.weight = REVERSE * area * (a_total / float(area.sum()))
        self.n = n
        self.dots = np.repeat(np.arange(n, dtype=np.int64)[:, None], 3, axis=1)
        self.faces = self.dots if faces is None else faces

    def nearest_to_b(self, moved: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The first half of a call, which needs only A's deformed points:
        B's sample's closest points on the deformed A (face, barycentric
        weights, points)."""
        return NearestOnSurface(moved, self.faces)(self.points)

    def __call__(self, moved: np.ndarray, normals: np.ndarray, landed: np.ndarray,
                 near: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]] = None
                 ) -> Tuple[np.ndarray, np.ndarray]:
        """``near``: :meth:`nearest_to_b` of ``moved`` if already made."""
        face, bary, onto = self.nearest_to_b(moved) if near is None else near
        corners = self.faces[face]
        normal = (normals[corners] * bary[:, :, None]).sum(axis=1)
        keep = (normal * self.normals).sum(1) > NORMAL_COSINE
        if REVERSE_FAR > 0:
            # Far from the deformed A, or far from where A's own pairs land
            # on B (a leg of B beside A's leg, which A's pairs put on the
            # neighbouring leg of B).
            gap = np.linalg.norm(onto - self.points, axis=1)
            far = gap > REVERSE_FAR * float(np.median(gap))
            if len(landed):
                _, _, hit = NearestOnSurface(landed, self.dots[:len(landed)])(self.points)
                cover = np.linalg.norm(hit - self.points, axis=1)
                far |= cover > REVERSE_FAR * float(np.median(cover))
            keep &= far
        w, b = self.weight[keep], self.points[keep]
        at = corners[keep].T.ravel()
        share = (bary[keep] * w[:, None]).T.ravel()
        total = np.bincount(at, share, self.n)
        summed = np.stack([np.bincount(at, share * np.tile(b[:, c], 3), self.n)
                           for c in range(3)], axis=1)
        return total, summed


Shifted = Tuple[np.ndarray, np.ndarray, np.ndarray, Optional[np.ndarray], Optional[np.ndarray]]


def _moved_by_pairs(pairs: DescriptorPairs, moved: np.ndarray, best: np.ndarray,
                    plain: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """The deformed points of the rows ``shift`` moved by the difference of
    their two candidates of B (best in position and descriptor, minus
    nearest in position alone): where their pairs are searched."""
    shifted: np.ndarray = moved[shift] + pairs.points[best[shift]] - pairs.points[plain[shift]]
    return shifted


def _shifted(descriptors: Tuple[DescriptorPairs, np.ndarray], nearest: NearestOnSurface,
             moved: np.ndarray) -> Shifted:
    """The descriptor pairs' word on the deformed points ``moved`` (module
    doc): the rows whose candidate of B nearest in position and descriptor
    is certain and not the one nearest in position alone (the mask), both
    candidates of every row, and for the masked rows the closest point of B
    to the point moved by the difference of the two (its face and the
    point). A face near the best candidate bounds that search (a hint: the
    same answers), so it needs nothing of the moved points' own closest
    points and runs beside them; where the candidates carry no face, the
    faces and points are None and the caller searches from the moved
    points' own faces."""
    pairs, features = descriptors
    best, plain, certain = pairs(moved, features)
    shift = certain & (best != plain)
    if pairs.faces is None or not shift.any():
        return shift, best, plain, None, None
    at, _, onto = nearest(_moved_by_pairs(pairs, moved, best, plain, shift),
                          pairs.faces[best[shift]])
    return shift, best, plain, at, onto


def nonrigid_icp(a: np.ndarray, a_normals: np.ndarray, area: np.ndarray,
                 first_targets: Optional[np.ndarray],
                 nearest: NearestOnSurface, b_face_normals: np.ndarray, *,
                 landmarks: Optional[Tuple[np.ndarray, np.ndarray]] = None,
                 landmark_weight: float = 50.0,
                 b_sample: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]] = None,
                 a_faces: Optional[np.ndarray] = None,
                 schedule: Sequence[Tuple[float, float, int]] = SCHEDULE,
                 should_stop: Callable[[int, int], bool] = lambda done, total: False,
                 controls: Optional[np.ndarray] = None,
                 descriptors: Optional[Tuple[DescriptorPairs, np.ndarray]] = None,
                 first_faces: Optional[np.ndarray] = None
                 ) -> Tuple[Deformation, Dict[str, Any]]:
    """Fit a deformation of A's points ``a`` (all in one normalised frame)
    onto B's surface (``nearest``), starting from ``first_targets``.

    ``area`` weighs each point; ``landmarks`` are (rows of ``a``, points on
    B) that keep their pairing and weigh ``landmark_weight`` mean points
    each. ``b_sample`` (points of B, their unit outward normals and their
    vertex areas) gives the reverse pairs of the module doc; None, or
    landmarks, leaves them out. ``a_faces``: faces over the rows of ``a``
    where ``a`` is all of a mesh (the reverse pairs then find its surface).
    ``first_targets`` None starts from closest points. ``controls`` are
    :func:`control_points` of ``a`` if already made. ``descriptors``
    (B's :class:`spherify._descriptors.DescriptorPairs` and the descriptors
    of ``a``'s rows) moves each pair along B by the descriptor pairs' word
    (module doc of :mod:`spherify._descriptors`). ``first_faces``, if
    given, are faces of B near ``first_targets`` (the faces they lie on):
    the first search's hints (the same answers, faster). Returns the
    deformation and a record (``kept``: the fraction of
    pairs used at each iteration, ``distance``: their mean distance).
    """
    if controls is None:
        controls = control_points(a)
    n = len(a)
    v0 = area / area.mean()
    ids = np.zeros(0, dtype=np.int64)
    targets_l = np.zeros((0, 3))
    if landmarks is not None and len(landmarks[0]):
        ids, targets_l = landmarks
    use = np.ones(len(a), dtype=bool)
    # The reverse pairs' weight and weighted sum of B's points per row of a
    # (none before the first fit: its targets come through the sphere maps).
    back_w = np.zeros(n)
    back_s = np.zeros((n, 3))
    reverse = None
    if b_sample is not None and REVERSE > 0 and not len(ids):
        reverse = _Reverse(b_sample, float(v0.sum()), n, a_faces)
    targets = nearest(a)[2] if first_targets is None else first_targets
    total = sum(s for _, _, s in schedule)
    done = 0
    record: Dict[str, Any] = {"kept": [], "distance": []}
    model: Optional[Deformation] = None
    # Each point's face at the fit before bounds its next search (the
    # first from the faces of the first targets, where given: the first fit
    # moves the points near them; issue 23, speed, session 12).
    hints: Optional[np.ndarray] = None if first_faces is None else first_faces
    if len(ids):
        a = np.vstack([a, a[ids]])
    every = v0 if not len(ids) else np.concatenate([v0, np.full(len(ids), landmark_weight)])

    def width(sigma: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What the fits of one kernel width share: A's kernel, the design
        matrix, the controls' kernel and the normal matrix with every pair in.
        None of it depends on the fits: A's points do not move between them."""
        kernel = Deformation(np.eye(3), np.zeros(3), controls, np.zeros((0, 3)), sigma).kernel
        phi = kernel(a)
        design = _design(a, phi)
        # The normal matrix with every pair in, once a width: a fit takes
        # out the few pairs the normal test leaves out (a tenth or less)
        # instead of forming D^T diag(v) D anew, a 304 x 304 x 3000 product
        # that was a third of the ICP's time (issue 23, speed). Its two
        # column halves are two products on two threads (spherify._workers;
        # run one after the other inside a piece); split so for any thread
        # count, so the bits do not depend on it.
        weighted = design * every[:, None]
        half = design.shape[1] // 2
        normal_every = np.hstack(run_all(lambda cols: design.T @ weighted[:, cols],
                                         [slice(0, half), slice(half, None)]))
        return phi, design, kernel(controls), normal_every

    # The next width's matrices are made beside the fits of this one
    # (spherify._workers): the same bits, off the fits' serial chain.
    upcoming: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = \
        width(schedule[0][0]) if len(schedule) else None
    for w, (sigma, stiffness, steps) in enumerate(schedule):
        assert upcoming is not None
        phi, design, gram, normal_every = upcoming

        def fits(phi: np.ndarray = phi, design: np.ndarray = design, gram: np.ndarray = gram,
                 normal_every: np.ndarray = normal_every, sigma: float = sigma,
                 stiffness: float = stiffness, steps: int = steps) -> bool:
            """This width's fits; True where ``should_stop`` stopped them."""
            nonlocal model, use, targets, done, back_w, back_s, hints
            for _ in range(steps):
                v = v0 * use
                y, weights = targets, v
                if len(ids):
                    y = np.vstack([targets, targets_l])
                    weights = np.concatenate([v, np.full(len(ids), landmark_weight)])
                out = np.flatnonzero(~use)
                left = design[out]
                normal = normal_every - left.T @ (left * v0[out, None])
                # The reverse pairs of a row merge with its own pair into
                # one target of their summed weight (the same least-squares
                # problem).
                back = np.flatnonzero(back_w > 0)
                if len(back):
                    rows = design[back]
                    pulled = rows * back_w[back, None]
                    half = design.shape[1] // 2
                    normal = normal + np.hstack(run_all(lambda cols: rows.T @ pulled[:, cols],
                                                        [slice(0, half), slice(half, None)]))
                    both = v[back] + back_w[back]
                    y = y.copy()
                    y[back] = (v[back, None] * targets[back] + back_s[back]) / both[:, None]
                    weights = weights.copy()
                    weights[back] = both
                model = fit(a, y, weights, controls, sigma, stiffness, phi, normal, design, gram)
                theta = np.vstack([model.linear.T, model.shift, model.weights])
                moved = (design @ theta)[:n]
                # The searches that need only the deformed points run side by
                # side (spherify._workers; each its own bits): their closest
                # points on B (each point's face at the fit before starts its
                # search from a bound, spherify._nearest: the same answers,
                # faster), the descriptor pairs and the reverse pairs' search
                # of the deformed A (issue 23, speed, session 12).
                searches: List[Callable[[], Any]] = [lambda: nearest(moved, hints)]
                if descriptors is not None:
                    searches.append(lambda: _shifted(descriptors, nearest, moved))
                backward = reverse is not None and sigma >= REVERSE_SIGMA
                if backward:
                    assert reverse is not None
                    searches.append(lambda: reverse.nearest_to_b(moved))
                found = run_all(lambda search: search(), searches)
                faces, _, on_b = found[0]
                hints = faces
                distance = np.linalg.norm(on_b - moved, axis=1)
                turned = model.turn_normals(a_normals)
                b_normals = b_face_normals[faces]
                if descriptors is not None:
                    shift, best, plain, at, onto = found[1]
                    if at is None and shift.any():
                        # No face known near the candidates: the moved
                        # point's own bounds the shifted point's search.
                        at, _, onto = nearest(
                            _moved_by_pairs(descriptors[0], moved, best, plain, shift),
                            faces[shift])
                    if shift.any():
                        on_b = on_b.copy()
                        on_b[shift] = onto
                        b_normals = b_normals.copy()
                        b_normals[shift] = b_face_normals[at]
                agree = (turned * b_normals).sum(1)
                use = agree > NORMAL_COSINE
                targets = on_b
                back_w = np.zeros(n)
                if backward:
                    assert reverse is not None
                    back_w, back_s = reverse(moved, turned, on_b[use], found[-1])
                record["kept"].append(float(use.mean()))
                record["distance"].append(float(distance.mean()))
                done += 1
                if should_stop(done, total):
                    return True
            return False

        following = schedule[w + 1][0] if w + 1 < len(schedule) else None
        stopped, upcoming = beside(fits, lambda: None if following is None else width(following))
        if stopped:
            break
    assert model is not None
    return model, record
