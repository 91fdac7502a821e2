"""An exact verdict on a drawing of a mesh on the unit sphere (thesis 3.4),
written apart from spherify so that tests can hold ``SphereMap.valid`` and
``SphereMap.flipped`` to it (``sp.check_sphere`` is what they are made of, so
comparing with it proves nothing).

Orientation test (3.9): the sign of det[a, b, c] for every face, decided
exactly on the float64 coordinates. The determinant is first evaluated in
floating point with a forward error bound; only faces whose value lies within
the bound are recomputed with :class:`fractions.Fraction` (exact rational
arithmetic on the exact values of the floats), so the test stays fast.

Area test (3.11): the signed spherical triangle areas of the normalised points,
E = 2 atan2(det[a, b, c], 1 + a.b + b.c + c.a) (Van Oosterom and Strackee),
summed. With every face positive the drawing covers the sphere k times and the
sum is 4 pi k; a sum within 2 pi of 4 pi means k = 1.

valid = every point finite and not the origin, every face positive, and the
area sum within 2 pi of 4 pi. flipped = faces with det <= 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Sequence, Tuple

import numpy as np

_EPS = np.finfo(np.float64).eps / 2        # unit roundoff u = 2^-53
# Coordinates with magnitudes in this range (or exactly 0) keep every product of
# the determinant away from underflow and overflow, so the relative bound holds.
_SMALL, _LARGE = 1e-100, 1e100


@dataclass(frozen=True)
class Verdict:
    """What :func:`exact_verdict` finds."""

    valid: bool
    flipped: int              # faces with det <= 0
    n_negative: int
    n_zero: int
    area_sum: float
    n_exact: int              # faces the float filter could not decide


def _float_det(P: np.ndarray, F: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """det[a, b, c] per face in floating point, and a bound on its error.

    Evaluated as a0 (b1 c2 - b2 c1) + a1 (b2 c0 - b0 c2) + a2 (b0 c1 - b1 c0),
    one IEEE operation at a time (numpy does not fuse them). Each 2x2 minor is
    off by at most (2u + u^2) times the sum of its two products' magnitudes, each
    term by (3u + O(u^2)) times |a_i| times that sum, and the two additions add u
    each: at most about 5u times the permanent (the sum of the six products'
    magnitudes). 8u leaves room for the rounding of the permanent itself; the
    absolute 1e-300 covers gradual underflow of a minor times a coordinate.
    """
    a, b, c = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    p = (b[:, 1] * c[:, 2], b[:, 2] * c[:, 0], b[:, 0] * c[:, 1])
    q = (b[:, 2] * c[:, 1], b[:, 0] * c[:, 2], b[:, 1] * c[:, 0])
    det = a[:, 0] * (p[0] - q[0]) + a[:, 1] * (p[1] - q[1]) + a[:, 2] * (p[2] - q[2])
    permanent = sum(np.abs(a[:, i]) * (np.abs(p[i]) + np.abs(q[i])) for i in range(3))
    return det, 8.0 * _EPS * permanent + 1e-300


def fraction_sign(a: Sequence[float], b: Sequence[float], c: Sequence[float]) -> int:
    """The sign of det[a, b, c] in exact rational arithmetic (finite floats)."""
    a0, a1, a2 = (Fraction(float(x)) for x in a)
    b0, b1, b2 = (Fraction(float(x)) for x in b)
    c0, c1, c2 = (Fraction(float(x)) for x in c)
    det = a0 * (b1 * c2 - b2 * c1) + a1 * (b2 * c0 - b0 * c2) + a2 * (b0 * c1 - b1 * c0)
    return (det > 0) - (det < 0)


def exact_signs(points: np.ndarray, faces: np.ndarray) -> Tuple[np.ndarray, int]:
    """Exact sign (-1, 0, 1) of det[a, b, c] per face, and how many faces needed
    the rational fallback. A face with a non-finite corner gets 0 (not positive)."""
    P = np.asarray(points, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    det, bound = _float_det(P, F)
    corners = np.abs(P[F])                                          # (m, 3, 3)
    finite = np.isfinite(corners).all(axis=(1, 2))
    signs = np.zeros(len(F), dtype=np.int64)                        # non-finite: 0
    signs[finite] = np.sign(det[finite])
    tame = ((corners == 0) | ((corners >= _SMALL) & (corners <= _LARGE))).all(axis=(1, 2))
    unsure = finite & (~tame | ~(np.abs(det) > bound))
    for f in np.nonzero(unsure)[0]:
        i, j, k = F[f]
        signs[f] = fraction_sign(P[i], P[j], P[k])
    return signs, int(unsure.sum())


def spherical_area_sum(points: np.ndarray, faces: np.ndarray) -> float:
    """Sum of the signed spherical triangle areas of the normalised points."""
    P = np.asarray(points, dtype=np.float64)
    U = P / np.linalg.norm(P, axis=1, keepdims=True)
    a, b, c = U[faces[:, 0]], U[faces[:, 1]], U[faces[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    dots = np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c) + np.einsum("ij,ij->i", c, a)
    return float(np.sum(2.0 * np.arctan2(det, 1.0 + dots)))


def exact_verdict(points: np.ndarray, faces: np.ndarray) -> Verdict:
    """The verdict of thesis 3.4 on ``points`` (n, 3), one per vertex of ``faces``."""
    P = np.asarray(points, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    signs, n_exact = exact_signs(P, F)
    good_points = bool(np.isfinite(P).all() and (np.abs(P).max(axis=1) > 0).all())
    with np.errstate(invalid="ignore", divide="ignore"):
        area = spherical_area_sum(P, F)
    covers_once = math.isfinite(area) and abs(area - 4.0 * math.pi) < 2.0 * math.pi
    positive = bool((signs > 0).all())
    return Verdict(valid=good_points and positive and covers_once,
                   flipped=int((signs <= 0).sum()),
                   n_negative=int((signs < 0).sum()),
                   n_zero=int((signs == 0).sum()),
                   area_sum=area,
                   n_exact=n_exact)
