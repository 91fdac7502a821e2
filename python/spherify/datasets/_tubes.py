"""Tubes: rings of vertices swept along a centre line, the bands between rings,
the hemispherical caps that close them, and how finely to cut them.

A tube is a stack of staggered rings swept along its centre line with a
rotation-minimising frame; it ends in a hemispherical cap of shrinking rings
closed by a small fan. Tubes taper linearly (spikes, tentacles) or not (helix).
"""

from __future__ import annotations

import math
from typing import Any, Callable, List, Tuple

import numpy as np

from .._errors import MeshError
from ._vectors import Arrays, Floats, Ints

ROW = math.sqrt(3.0) / 2.0   # ring spacing / spacing around a ring: equilateral triangles
MIN_AROUND = 4               # fewest vertices around a tube
MAX_STRETCH = 3.0            # coarsest tube: ring spacing <= 3 x spacing around
TAPER = 0.6                  # spikes and tentacles thin to 40% of their base radius


def zip_rings(a: Ints, ta: Floats, Pa: Floats, b: Ints, tb: Floats, Pb: Floats) -> Ints:
    """Triangulate the band between two closed rings, one triangle per ring edge.

    ``a``, ``b`` are vertex ids in counter-clockwise order about an axis, ``ta``,
    ``tb`` their angles as fractions of a turn (sorted), ``Pa``, ``Pb`` their
    positions. The surface runs from ring ``a`` to ring ``b``; faces come out
    counter-clockwise when the outward normal is (direction of increasing angle)
    x (a -> b). The walk keeps both rings in step by angle, so the band cannot
    fold or wrap, and where the next vertices of the two rings are within half a
    step of each other it takes the shorter diagonal (better triangles on the
    irregular loops round the arms' holes). Sequential, O(len(a) + len(b)).
    """
    na, nb = len(a), len(b)
    j0 = int(np.argmin(np.abs((tb - ta[0] + 0.5) % 1.0 - 0.5)))   # start: b nearest a[0]
    ub = (np.roll(tb, -j0) - ta[0] + 0.5) % 1.0 - 0.5              # angles unwrapped from a[0]
    ub[1:] += ub[1:] < ub[0]
    # plain lists: this loop runs once per ring vertex
    A, B = a.tolist(), np.roll(b, -j0).tolist()
    ua, vb = np.append(ta - ta[0], 1.0).tolist(), np.append(ub, ub[0] + 1.0).tolist()
    pa, pb = Pa.tolist(), np.roll(Pb, -j0, axis=0).tolist()
    slack = 0.5 / min(na, nb)
    faces, i, j = [], 0, 0
    while i < na or j < nb:
        if j == nb or (i < na and ua[i + 1] <= vb[j + 1] + slack and (
                vb[j + 1] > ua[i + 1] + slack
                or math.dist(pa[(i + 1) % na], pb[j % nb]) < math.dist(pa[i], pb[(j + 1) % nb]))):
            faces.append((A[i], A[(i + 1) % na], B[j % nb]))
            i += 1
        else:
            faces.append((A[i % na], B[(j + 1) % nb], B[j]))
            j += 1
    return np.array(faces, dtype=np.int64)


def ring_steps(length: Any, taper: float, spacing: float) -> Tuple[Any, Any]:
    """Ring steps along a tube (array-friendly in ``length``), and its length
    ``u`` stretched by r(0) / r(s): equal steps in ``u`` keep rings spaced in
    proportion to the local radius."""
    u_total = length if taper == 0.0 else -(length / taper) * math.log(1.0 - taper)
    return np.maximum(1, np.round(u_total / spacing)).astype(np.int64), u_total


def ring_positions(length: float, taper: float, spacing: float) -> Floats:
    """Arc lengths of the rings of a tube whose radius falls linearly by the
    fraction ``taper`` from base to tip: ``spacing`` apart at the base and in
    proportion to the radius further on, so triangles keep their shape."""
    steps, u_total = ring_steps(length, taper, spacing)
    u = np.linspace(0.0, u_total, int(steps) + 1)
    return u if taper == 0.0 else (length / taper) * -np.expm1(-taper * u / length)


def _cap_counts(around: int, radius: float, spacing: float) -> List[int]:
    """Vertex counts of the rings of a hemispherical cap, rim excluded, apex
    excluded: latitude steps about ``spacing`` apart, each ring about as dense as
    the rim, so the closing fan has 3 to 6 triangles (more only on coarse tubes)."""
    steps = max(1, round(0.5 * math.pi * radius / spacing))
    alpha = 0.5 * math.pi * (1.0 - np.arange(1, steps) / steps)
    return [max(3, round(around * math.sin(x))) for x in alpha]


def _cap(rim: Ints, t: Floats, rim_xyz: Floats, centre: Floats,
         frame: Floats, radius: float, spacing: float, first: int) -> Arrays:
    """Close the ring ``rim`` (angles ``t`` in ``frame`` = rows U, W, T, positions
    ``rim_xyz`` on the circle of ``radius`` about ``centre`` normal to T) with a
    hemisphere bulging along +T. New vertices are numbered from ``first``."""
    U, W, T = frame
    counts = _cap_counts(len(rim), radius, spacing)
    points, faces = [], []
    for step, n in enumerate(counts, start=1):
        alpha = 0.5 * math.pi * (1.0 - step / (len(counts) + 1))
        tt = (np.arange(n) + 0.5 * (step % 2)) / n          # stagger successive rings
        phi = 2 * math.pi * tt
        around = np.cos(phi)[:, None] * U + np.sin(phi)[:, None] * W
        points.append(centre + radius * (math.sin(alpha) * around + math.cos(alpha) * T))
        ring = first + np.arange(n)
        faces.append(zip_rings(rim, t, rim_xyz, ring, tt, points[-1]))
        rim, t, rim_xyz, first = ring, tt, points[-1], first + n
    points.append((centre + radius * T)[None])
    faces.append(np.stack([rim, np.roll(rim, -1), np.full(len(rim), first)], 1))
    return np.concatenate(points), np.concatenate(faces)


def tube(C: Floats, U: Floats, W: Floats, T: Floats, radius: Floats,
         around: int, first: int, start_cap: bool) -> Arrays:
    """A tube of ``around`` vertices per ring about the centre line ``C`` (rings
    in planes normal to T, rotation-minimising frame U, W), capped at the end and,
    if asked, at the start. Successive rings are turned by half a step so the
    triangles are near equilateral. Vertex ids start at ``first``; the first
    ring's vertices are ``first + arange(around)`` at angles ``arange(around) / around``."""
    rings, m = len(C), around
    stagger = 0.5 * (np.arange(rings) % 2)
    phi = (2 * math.pi / m) * (np.arange(m)[None, :] + stagger[:, None])
    V = C[:, None] + radius[:, None, None] * (np.cos(phi)[..., None] * U[:, None]
                                              + np.sin(phi)[..., None] * W[:, None])
    V = V.reshape(-1, 3)
    j, i = np.arange(rings - 1)[:, None], np.arange(m)[None, :]
    a, a1 = j * m + i, j * m + (i + 1) % m
    even = (j % 2) == 0
    # next ring: between a_i and a_{i+1} sits b_i (even rings) or b_{i+1} (odd)
    mid = np.where(even, a + m, a1 + m)
    before = np.where(even, (j + 1) * m + (i - 1) % m, a + m)
    F = np.concatenate([np.stack([a, a1, mid], -1).reshape(-1, 3),
                        np.stack([a, mid, before], -1).reshape(-1, 3)]) + first
    parts_V, parts_F, n = [V], [F], first + len(V)
    spacing = np.linalg.norm(C[-1] - C[-2])
    last = first + (rings - 1) * m + np.arange(m)
    frame = np.stack([U[-1], W[-1], T[-1]])
    Vc, Fc = _cap(last, (np.arange(m) + stagger[-1]) / m, V[-m:], C[-1], frame,
                  float(radius[-1]), float(spacing), n)
    parts_V.append(Vc)
    parts_F.append(Fc)
    if start_cap:
        # the same cap seen from the other end: frame (U, -W, -T), angles negated
        n += len(Vc)
        t = (-np.arange(m) / m) % 1.0
        order = np.argsort(t, kind="stable")
        frame = np.stack([U[0], -W[0], -T[0]])
        spacing = np.linalg.norm(C[1] - C[0])
        Vc, Fc = _cap(first + order, t[order], V[order], C[0], frame,
                      float(radius[0]), float(spacing), n)
        parts_V.append(Vc)
        parts_F.append(Fc)
    return np.concatenate(parts_V), np.concatenate(parts_F)


def cap_count(around: int, radius: float, spacing: float) -> int:
    """Vertices a cap adds to a ring of ``around`` vertices (apex included)."""
    return sum(_cap_counts(around, radius, spacing)) + 1


def ring_size(radius: float, h: float) -> Tuple[int, float]:
    """Vertices around a tube of base ``radius`` for target edge ``h``, and the
    ring spacing at the base."""
    m = max(MIN_AROUND, round(2 * math.pi * radius / h))
    return m, ROW * max(h, 2 * math.pi * radius / m)


def pick_edge(target: int, count: Callable[[float], int], h_max: float) -> float:
    """The edge length, from ``h_max`` (the coarsest allowed) down, whose vertex
    count is closest to ``target`` in ratio. Counts are estimates from the plan."""
    hs = h_max * np.geomspace(1.0, 1e-4, 400)
    errors = []
    for h in hs:
        c = count(h)
        errors.append(abs(math.log(c / target)))
        if c > 2 * target:
            break
    return float(hs[int(np.argmin(errors))])


def check_clearance(paths: List[Tuple[Floats, Floats, Floats]], what: str) -> None:
    """Raise MeshError if two tubes, or two stretches of one tube, come closer
    than 1.05 x the sum of their radii. ``paths`` holds (s, C, r) samples of each
    centre line, spaced at most half the local radius."""
    s = np.concatenate([p[0] for p in paths])
    C = np.concatenate([p[1] for p in paths])
    r = np.concatenate([p[2] for p in paths])
    arm = np.repeat(np.arange(len(paths)), [len(p[0]) for p in paths])
    for lo in range(0, len(s), 512):
        hi = min(lo + 512, len(s))
        d = np.linalg.norm(C[lo:hi, None] - C[None], axis=-1)
        reach = r[lo:hi, None] + r[None]
        far = (arm[lo:hi, None] != arm[None]) | (np.abs(s[lo:hi, None] - s[None]) > 1.5 * reach)
        if np.any(far & (d < 1.05 * reach)):
            raise MeshError(f"these {what} parameters make the tube run into itself or "
                            "another tube; use thinner, shorter or fewer tubes")
