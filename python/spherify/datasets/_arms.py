"""A round body with arms: where the arms leave it, the holes cut under them,
and the joins between each hole and its arm's tube (for ``urchin`` and
``tentacles``).

The body is a geodesic sphere with a hole under each arm: the hole is the
``k``-ring of the body vertex the arm leaves from (a hexagon in the lattice,
hence a simple loop), and a strip "zips" the arm tube's first ring to the
hole's loop.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence, Tuple

import numpy as np

from .._errors import MeshError
from ._geodesic import EDGE, geodesic
from ._tubes import (MAX_STRETCH, MIN_AROUND, ROW, TAPER, cap_count, pick_edge, ring_size, ring_steps,
                     tube, zip_rings)
from ._vectors import Arrays, Floats, Ints, unit

ROOM = 3.5          # arms' bases at least this many base radii apart
_CLEARANCE = 0.3    # gap between an arm's first ring and its hole, in body edges
_CHUNK = 1 << 21    # (vertices x arms) per block when comparing the two

# An arm's tube as rings along its centre line: centres C, frame U, W (across)
# and T (along), radii; each (rings, 3) or (rings,).
ArmRings = Tuple[Floats, Floats, Floats, Floats, Floats]


class HoledBody(NamedTuple):
    """A body with its holes marked (not yet cut): see :func:`holed_body`."""

    V: Floats            # (n, 3) body vertices
    F: Ints              # (m, 3) body faces
    centres: Ints        # (arms,) the vertex each arm leaves from
    arm: Ints            # (n,) the arm whose hole a vertex is in or round, or -1
    ring: Ints           # (n,) ring number about that arm's centre vertex, or -1
    loop_ring: Ints      # (arms,) the ring that is the hole's loop


def _hole_rings(tube_radius: float, edge: float) -> int:
    """Rings of body vertices to remove under an arm: the hexagonal loop left
    (inradius about 0.8 k edges) clears the tube by ``_CLEARANCE`` edges. The
    build grows each hole until it does; this estimate serves the plan."""
    return max(1, math.ceil((tube_radius + _CLEARANCE * edge) / (0.8 * edge)))


def body_plan(h: float, R: float, tube_radius: float, separation: float) -> Tuple[int, int]:
    """Geodesic frequency and hole rings for a body of radius ``R`` with edge
    about ``h``, refined until the centres of arms ``separation`` apart (chord)
    are likely 2k + 1 edges apart, so their holes' loops are disjoint (the build
    checks, and refines further if the estimate fell short)."""
    nu = max(3, math.ceil(EDGE * R / h))
    while True:
        e = EDGE * R / nu
        k = _hole_rings(tube_radius, e)
        if (2 * k + 2) * e <= separation:
            return nu, k
        nu += 1


def body_arms_count(h: float, R: float, r: float, separation: float,
                    lengths: Floats) -> int:
    """Vertices of a body of radius ``R`` with arms of base radius ``r`` and the
    given ``lengths``, at edge length ``h``: an estimate from the plan."""
    nu, k = body_plan(h, R, r, separation)
    m, spacing = ring_size(r, h)
    body = 10 * nu * nu + 2 - len(lengths) * (3 * k * k - 3 * k + 1)
    rings = int(np.sum(ring_steps(lengths, TAPER, spacing)[0] + 1))
    return body + m * rings + len(lengths) * cap_count(m, (1 - TAPER) * r,
                                                       (1 - TAPER) * spacing)


def _nearest_vertices(V: Floats, directions: Floats) -> Ints:
    """Index of the vertex of the origin-centred sphere ``V`` nearest each direction."""
    best = np.full(len(directions), -np.inf)
    where = np.zeros(len(directions), dtype=np.int64)
    rows = np.arange(len(directions))
    chunk = max(1024, _CHUNK // len(directions))
    for lo in range(0, len(V), chunk):
        dots = directions @ V[lo:lo + chunk].T
        arg = np.argmax(dots, axis=1)
        val = dots[rows, arg]
        better = val > best
        best[better], where[better] = val[better], lo + arg[better]
    return where


def _carve(V: Floats, F: Ints, centres: Ints, clearance: float,
           reach: float) -> Tuple[Ints, Ints, Ints, bool]:
    """Breadth-first rings about each centre vertex of the sphere ``V``, each grown
    until its newest ring keeps ``clearance`` from the arm's axis (the ray through
    the centre); that ring is the hole's loop, the rings inside it go.

    Only vertices within angle ``reach`` of a centre take part. Returns, per
    vertex, its arm (-1: none) and ring; per arm, the ring of its loop; and
    whether the holes are independent: no vertex to be removed neighbours another
    arm's disk (else removing both disks would pinch the body).
    """
    axes = unit(V[centres])
    near = np.zeros(len(V), dtype=bool)
    chunk = max(1024, _CHUNK // len(centres))
    for lo in range(0, len(V), chunk):
        near[lo:lo + chunk] = (axes @ V[lo:lo + chunk].T).max(axis=0) > \
            math.cos(min(reach, math.pi)) * np.linalg.norm(V[lo:lo + chunk], axis=1)
    Fn = F[near[F].all(axis=1)]
    e = np.concatenate([Fn[:, [0, 1]], Fn[:, [1, 2]], Fn[:, [2, 0]]])
    e = e[e[:, 0] < e[:, 1]]
    arm = np.full(len(V), -1, dtype=np.int64)
    ring = np.full(len(V), -1, dtype=np.int64)
    arm[centres], ring[centres] = np.arange(len(centres)), 0
    loop_ring = np.zeros(len(centres), dtype=np.int64)
    growing = np.ones(len(centres), dtype=bool)
    step = 0
    while growing.any():
        step += 1
        for u, v in ((e[:, 0], e[:, 1]), (e[:, 1], e[:, 0])):
            grow = (ring[u] == step - 1) & (arm[u] >= 0) & (arm[v] < 0)
            grow[grow] = growing[arm[u[grow]]]
            arm[v[grow]], ring[v[grow]] = arm[u[grow]], step
        new = np.nonzero(ring == step)[0]
        gap = np.full(len(centres), np.inf)
        np.minimum.at(gap, arm[new], np.linalg.norm(np.cross(V[new], axes[arm[new]]), axis=1))
        if np.isinf(gap[growing]).any() or step > 10_000:
            raise RuntimeError("spherify.datasets: a hole under an arm stopped growing")
        done = growing & (gap >= clearance)
        loop_ring[done] = step
        growing &= ~done
    labelled = np.nonzero(arm >= 0)[0]
    if np.any(np.einsum("ij,ij->i", unit(V[labelled]), axes[arm[labelled]])
              < math.cos(0.8 * reach)):
        raise RuntimeError("spherify.datasets: a hole under an arm outgrew its search disk")
    u, v = e[:, 0], e[:, 1]
    inside_u = (arm[u] >= 0) & (ring[u] < loop_ring[arm[u]])
    inside_v = (arm[v] >= 0) & (ring[v] < loop_ring[arm[v]])
    independent = not np.any((arm[u] >= 0) & (arm[v] >= 0) & (arm[u] != arm[v])
                             & (inside_u | inside_v))
    return arm, ring, loop_ring, independent


def holed_body(R: float, nu: int, r: float, directions: Floats) -> HoledBody:
    """A geodesic sphere of radius ``R`` (frequency ``nu`` or finer) with a hole
    for an arm of base radius ``r`` at the vertex nearest each of ``directions``.
    Returns V, F (holes not yet cut), the centre vertices, and ``_carve``'s arm,
    ring and loop_ring."""
    while True:
        V, F = geodesic(nu)
        V *= R
        centres = _nearest_vertices(V, directions)
        edge = EDGE * R / nu
        k = _hole_rings(r, edge)
        arm, ring, loop_ring, independent = _carve(
            V, F, centres, r + _CLEARANCE * edge, (2 * k + 6) * edge / R)
        if independent and len(np.unique(centres)) == len(centres):
            return HoledBody(V, F, centres, arm, ring, loop_ring)
        nu += 1        # the plan's spacing estimate fell short: refine the body


def attach_arms(body: HoledBody, around: int, arms: Sequence[ArmRings]) -> Arrays:
    """Cut the holes of ``holed_body`` and join arm ``i`` to hole ``i``: each arm
    is a tube's rings (C, U, W, T, radius) of ``around`` vertices, the first ring
    on the sphere round the hole's axis."""
    V, F, centres, arm, ring, loop_ring = body
    removed = (arm >= 0) & (ring < loop_ring[np.maximum(arm, 0)])
    new_id = np.cumsum(~removed) - 1
    parts_V = [V[~removed]]
    parts_F = [new_id[F[~removed[F].any(axis=1)]]]
    n = len(parts_V[0])
    for i, (C, U, W, T, radius) in enumerate(arms):
        tube_V, tube_F = tube(C, U, W, T, radius, around, n, start_cap=False)
        # zip the hole's loop (ordered by angle in the arm's base frame) to the
        # tube's first ring; the surface runs from the loop inwards, normal +d
        loop = np.nonzero((arm == i) & (ring == loop_ring[i]))[0]
        angle = (np.arctan2(V[loop] @ W[0], V[loop] @ U[0]) / (2 * math.pi)) % 1.0
        order = np.argsort(angle, kind="stable")
        loop = loop[order]
        parts_F.append(zip_rings(new_id[loop], angle[order], V[loop], n + np.arange(around),
                                 np.arange(around) / around, tube_V[:around]))
        parts_V.append(tube_V)
        parts_F.append(tube_F)
        n += len(tube_V)
    return np.concatenate(parts_V), np.concatenate(parts_F)


def spread_directions(n: int, rng: np.random.Generator) -> Floats:
    """``n`` well-spread unit vectors: a Fibonacci lattice, randomly turned and
    jittered, then (2 to 400 points) relaxed by a few steps of mutual repulsion."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = math.pi * (1 + math.sqrt(5.0)) * i
    P = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    relax = 1 < n <= 400
    P = unit(P @ Q + rng.normal(scale=(0.3 if relax else 0.05) / math.sqrt(n), size=(n, 3)))
    step = 0.1 * math.sqrt(4 * math.pi / n)          # a tenth of the typical spacing
    for _ in range(50 if relax else 0):
        diff = P[:, None] - P[None]
        dist = np.linalg.norm(diff, axis=-1) + np.eye(n)
        push = (diff / dist[..., None] ** 3).sum(axis=1)
        push -= (push * P).sum(axis=1, keepdims=True) * P          # along the sphere
        P = unit(P + step * push / np.linalg.norm(push, axis=1).max())
    return P


def arm_separation(P: Floats, R: float, r: float, what: str) -> float:
    """Smallest distance between the points ``R * P`` where arms of radius ``r``
    leave the body; MeshError if under ``ROOM * r`` (then the body between their
    holes would need ever finer vertices)."""
    best = 2.0
    for lo in range(0, len(P), 256):
        d = np.linalg.norm(P[lo:lo + 256, None] - P[None], axis=-1)
        d[np.arange(len(d)), lo + np.arange(len(d))] = 3.0
        best = min(best, float(d.min()))
    if best * R < ROOM * r:
        raise MeshError(f"{len(P)} {what} of radius {r} do not fit on the body; "
                        f"use fewer or thinner {what}")
    return best * R


class ArmPlan(NamedTuple):
    """The sizes a body with arms is built at."""
    edge: float        # target edge length h
    around: int        # vertices around each arm
    spacing: float     # distance between the arms' rings
    body: HoledBody    # the body with a hole where each arm leaves


def plan_arms(n: int, R: float, r: float, separation: float, lengths: Floats,
              directions: Floats) -> ArmPlan:
    """The edge length that gives about ``n`` vertices to a body of radius ``R``
    with arms of radius ``r`` and these ``lengths`` leaving in ``directions``,
    and the body and ring sizes at that length."""
    def count(h: float) -> int:
        return body_arms_count(h, R, r, separation, lengths)

    h = pick_edge(n, count, MAX_STRETCH * 2 * math.pi * r / MIN_AROUND / ROW)
    nu = body_plan(h, R, r, separation)[0]
    around, spacing = ring_size(r, h)
    return ArmPlan(h, around, spacing, holed_body(R, nu, r, directions))
