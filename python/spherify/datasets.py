"""Procedural genus-0 shapes for tests, docs, benches and the demo.

Every shape is a closed, connected, manifold triangle mesh of genus 0, faces
counter-clockwise seen from outside (positive signed volume), free of
self-intersections, degenerate triangles and coincident vertices, at every size.
The same arguments give the same arrays, bit for bit. Only numpy is used and
all the work is vectorised; 2,000,000 vertices take a second or two.

Shapes with arms (``urchin``, ``tentacles``) are a sphere with a hole under each
arm and a tube per arm: the hole is the ``k``-ring of the body vertex the arm
leaves from (a hexagon in the lattice, hence a simple loop), the tube is a stack
of staggered rings swept along the arm's centre line with a rotation-minimising
frame, and a strip "zips" the tube's first ring to the hole's loop. Tubes end in
hemispherical caps of shrinking rings closed by a small fan.
"""

from __future__ import annotations

import math
import operator
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Sequence, Tuple

import numpy as np

if TYPE_CHECKING:
    from ._mesh import Mesh

__all__ = ["bumpy_blob", "ellipsoid", "helix_tube", "icosphere", "make", "names",
           "tentacles", "urchin"]

Arrays = Tuple[np.ndarray, np.ndarray]

_ROW = math.sqrt(3.0) / 2.0   # ring spacing / spacing around a ring: equilateral triangles
_MIN_AROUND = 4               # fewest vertices around a tube
_MAX_STRETCH = 3.0            # coarsest tube: ring spacing <= 3 x spacing around
_EDGE = 1.2046                # mean edge of the frequency-nu geodesic unit sphere, times nu
_TAPER = 0.6                  # spikes and tentacles thin to 40% of their base radius
_ROOM = 3.5                   # arms' bases at least this many base radii apart
_CLEARANCE = 0.3              # gap between an arm's first ring and its hole, in body edges
_CHUNK = 1 << 21              # (vertices x arms) per block when comparing the two


def _error(message: str) -> Exception:
    """A MeshError (a ValueError) to raise; a plain ValueError when this file is
    loaded on its own, outside the package (tests before the extension exists)."""
    try:
        from ._errors import MeshError
    except ImportError:
        return ValueError(message)
    return MeshError(message)


def _as_mesh(arrays: Arrays) -> "Mesh":
    from . import Mesh  # lazy: the package imports this module before Mesh exists
    return Mesh(*arrays)


def _count(name: str, value: Any, minimum: int) -> int:
    try:
        n = operator.index(value)
    except TypeError:
        raise _error(f"{name} must be an integer, got {value!r}") from None
    if n < minimum:
        raise _error(f"{name} must be at least {minimum}, got {n}")
    return n


def _positive(name: str, value: Any, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and (x > 0.0 or (allow_zero and x == 0.0))):
        raise _error(f"{name} must be a {'non-negative' if allow_zero else 'positive'} "
                     f"finite number, got {value!r}")
    return x


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _perpendicular(d: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to the unit vector ``d``."""
    helper = np.eye(3)[np.argmin(np.abs(d))]
    return _unit(np.cross(d, helper))


# --------------------------------------------------------------------- spheres

def _icosahedron() -> Arrays:
    g = (1.0 + math.sqrt(5.0)) / 2.0
    V = np.array([(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0),
                  (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
                  (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)], dtype=np.float64)
    F = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
                  (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
                  (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
                  (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)], dtype=np.int64)
    return _unit(V), F


def _geodesic_arrays(nu: int) -> Arrays:
    """Unit geodesic sphere of frequency ``nu``: every icosahedron face cut into
    ``nu**2`` triangles by a flat lattice, then projected onto the sphere.
    10 nu^2 + 2 vertices, 20 nu^2 faces, smallest angle about 50 degrees.

    Points on an icosahedron edge are numbered once per edge (from its lower
    corner), so faces sharing the edge agree without any merging by position.
    """
    C, T = _icosahedron()
    # the 30 edges, each once, numbered by the 20 x 3 face slots (a->b, b->c, c->a)
    start, end = T, np.roll(T, -1, axis=1)
    keys, slot_edge = np.unique(np.minimum(start, end) * 12 + np.maximum(start, end),
                                return_inverse=True)
    slot_edge = slot_edge.reshape(20, 3)
    forward = start < end                       # slot runs from the edge's lower corner
    # lattice of one face: point (i, j) = a + i/nu (b - a) + j/nu (c - a)
    i, j = np.nonzero(np.tri(nu + 1, dtype=bool)[::-1])          # i + j <= nu
    k = nu - i - j
    local = np.full((nu + 2, nu + 2), -1, dtype=np.int64)
    local[i, j] = np.arange(i.size)
    # global id of every lattice point of every face
    gid = np.empty((20, i.size), dtype=np.int64)
    first_inner = 12 + 30 * (nu - 1)
    inner = (i > 0) & (j > 0) & (k > 0)
    n_inner = int(inner.sum())
    gid[:, inner] = first_inner + np.arange(20)[:, None] * n_inner + np.arange(n_inner)
    for corner, at in enumerate([(i == 0) & (j == 0), i == nu, j == nu]):
        gid[:, at] = T[:, corner, None]
    # slot s holds the points where the weight of the opposite corner is zero;
    # p counts lattice steps from the slot's start corner
    for s, (on, p) in enumerate([((j == 0) & (i > 0) & (i < nu), i),
                                 ((k == 0) & (j > 0) & (j < nu), j),
                                 ((i == 0) & (j > 0) & (j < nu), nu - j)]):
        t = np.where(forward[:, s, None], p[on], nu - p[on])
        gid[:, on] = 12 + slot_edge[:, s, None] * (nu - 1) + t - 1
    # positions: corners, edge points, then inner points, in id order
    w = np.arange(1, nu) / nu
    a, b = C[keys // 12], C[keys % 12]
    on_edges = (1 - w)[None, :, None] * a[:, None] + w[None, :, None] * b[:, None]
    wi = np.stack([k[inner], i[inner], j[inner]], axis=1) / nu
    on_faces = wi @ C[T]                                           # (20, inner, 3)
    V = _unit(np.concatenate([C, on_edges.reshape(-1, 3), on_faces.reshape(-1, 3)]))
    # triangles pointing like the face, then those pointing the other way
    up = i + j <= nu - 1
    down = i + j <= nu - 2
    tri = np.concatenate([
        np.stack([local[i[up], j[up]], local[i[up] + 1, j[up]], local[i[up], j[up] + 1]], 1),
        np.stack([local[i[down] + 1, j[down]], local[i[down] + 1, j[down] + 1],
                  local[i[down], j[down] + 1]], 1)])
    F = gid[:, tri].reshape(-1, 3)
    return V, F


def _nearest_frequency(n_vertices: int) -> int:
    nu = max(1, round(math.sqrt(max(n_vertices - 2, 0) / 10.0)))
    return min((q for q in (nu - 1, nu, nu + 1) if q >= 1),
               key=lambda q: abs(10 * q * q + 2 - n_vertices))


def _icosphere_arrays(subdivisions: int = 3) -> Arrays:
    k = _count("subdivisions", subdivisions, 0)
    if k > 10:
        raise _error(f"subdivisions must be at most 10 (10 * 4**10 + 2 vertices), got {k}")
    return _geodesic_arrays(2 ** k)


def _sphere_arrays(n_vertices: int = 2000) -> Arrays:
    return _geodesic_arrays(_nearest_frequency(_count("n_vertices", n_vertices, 1)))


def _ellipsoid_arrays(n_vertices: int = 2000, axes: Sequence[float] = (1.0, 0.6, 0.4)) -> Arrays:
    n = _count("n_vertices", n_vertices, 1)
    if len(axes) != 3:
        raise _error(f"axes must hold three semi-axis lengths, got {axes!r}")
    scale = np.array([_positive("axes", x) for x in axes])
    V, F = _geodesic_arrays(_nearest_frequency(n))
    return V * scale, F


def _bumpy_blob_arrays(n_vertices: int = 5000, bumps: int = 12, amplitude: float = 0.25,
                       seed: int = 0) -> Arrays:
    n = _count("n_vertices", n_vertices, 1)
    bumps = _count("bumps", bumps, 0)
    amplitude = _positive("amplitude", amplitude, allow_zero=True)
    V, F = _geodesic_arrays(_nearest_frequency(n))
    rng = np.random.default_rng(seed)
    centres = _unit(rng.normal(size=(bumps, 3)))
    # about a quarter dents (60% as deep), the rest bumps
    heights = rng.uniform(0.5, 1.0, bumps) * np.where(rng.random(bumps) < 0.25, -0.6, 1.0)
    sharpness = rng.uniform(15.0, 40.0, bumps)      # von Mises-Fisher: width ~ 1/sqrt(k) rad
    r = np.ones(len(V))
    for c, a, kappa in zip(centres, heights, sharpness):   # one pass per bump: no n x bumps array
        r += amplitude * a * np.exp(kappa * (V @ c - 1.0))
    if r.min() < 0.1:
        raise _error(f"amplitude {amplitude} pushes dents through the centre; use a smaller one")
    # scaling each vertex along its own ray keeps every triangle's orientation as
    # seen from the origin, so the surface stays embedded and star-shaped
    return V * r[:, None], F


# ----------------------------------------------------------------------- tubes

def _zip(a: np.ndarray, ta: np.ndarray, Pa: np.ndarray,
         b: np.ndarray, tb: np.ndarray, Pb: np.ndarray) -> np.ndarray:
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


def _ring_steps(length: Any, taper: float, spacing: float) -> Tuple[Any, Any]:
    """Ring steps along a tube (array-friendly in ``length``), and its length
    ``u`` stretched by r(0) / r(s): equal steps in ``u`` keep rings spaced in
    proportion to the local radius."""
    u_total = length if taper == 0.0 else -(length / taper) * math.log(1.0 - taper)
    return np.maximum(1, np.round(u_total / spacing)).astype(np.int64), u_total


def _ring_positions(length: float, taper: float, spacing: float) -> np.ndarray:
    """Arc lengths of the rings of a tube whose radius falls linearly by the
    fraction ``taper`` from base to tip: ``spacing`` apart at the base and in
    proportion to the radius further on, so triangles keep their shape."""
    steps, u_total = _ring_steps(length, taper, spacing)
    u = np.linspace(0.0, u_total, int(steps) + 1)
    return u if taper == 0.0 else (length / taper) * -np.expm1(-taper * u / length)


def _cap_counts(around: int, radius: float, spacing: float) -> List[int]:
    """Vertex counts of the rings of a hemispherical cap, rim excluded, apex
    excluded: latitude steps about ``spacing`` apart, each ring about as dense as
    the rim, so the closing fan has 3 to 6 triangles (more only on coarse tubes)."""
    steps = max(1, round(0.5 * math.pi * radius / spacing))
    alpha = 0.5 * math.pi * (1.0 - np.arange(1, steps) / steps)
    return [max(3, round(around * math.sin(x))) for x in alpha]


def _cap(rim: np.ndarray, t: np.ndarray, rim_xyz: np.ndarray, centre: np.ndarray,
         frame: np.ndarray, radius: float, spacing: float, first: int) -> Arrays:
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
        faces.append(_zip(rim, t, rim_xyz, ring, tt, points[-1]))
        rim, t, rim_xyz, first = ring, tt, points[-1], first + n
    points.append((centre + radius * T)[None])
    faces.append(np.stack([rim, np.roll(rim, -1), np.full(len(rim), first)], 1))
    return np.concatenate(points), np.concatenate(faces)


def _tube(C: np.ndarray, U: np.ndarray, W: np.ndarray, T: np.ndarray, radius: np.ndarray,
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


def _cap_count(around: int, radius: float, spacing: float) -> int:
    return sum(_cap_counts(around, radius, spacing)) + 1


def _around(radius: float, h: float) -> Tuple[int, float]:
    """Vertices around a tube of base ``radius`` for target edge ``h``, and the
    ring spacing at the base."""
    m = max(_MIN_AROUND, round(2 * math.pi * radius / h))
    return m, _ROW * max(h, 2 * math.pi * radius / m)


def _pick_edge(target: int, count: Callable[[float], int], h_max: float) -> float:
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


def _check_clearance(paths: List[Tuple[np.ndarray, np.ndarray, np.ndarray]], what: str) -> None:
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
            raise _error(f"these {what} parameters make the tube run into itself or "
                         "another tube; use thinner, shorter or fewer tubes")


# ------------------------------------------------------------- helix tube

def _helix_tube_arrays(n_vertices: int = 5000, turns: float = 3.0, radius: float = 1.0,
                       tube_radius: float = 0.15, pitch: float = 0.8) -> Arrays:
    n = _count("n_vertices", n_vertices, 1)
    turns, R, r, pitch = (_positive(k, v) for k, v in [
        ("turns", turns), ("radius", radius), ("tube_radius", tube_radius), ("pitch", pitch)])
    b = pitch / (2 * math.pi)            # rise per radian
    c = math.hypot(R, b)                 # arc length per radian
    L = 2 * math.pi * turns * c
    if r * R / c**2 > 0.6:               # tube radius x curvature: inner side would fold
        raise _error("tube_radius is too large for the helix radius")

    def centre_line(s: np.ndarray) -> np.ndarray:
        t = s / c
        return np.stack([R * np.cos(t), R * np.sin(t), b * (t - math.pi * turns)], 1)

    samples = np.linspace(0, L, max(2, int(2 * L / r)) + 1)
    _check_clearance([(samples, centre_line(samples), np.full(samples.size, r))], "helix_tube")

    def count(h: float) -> int:
        m, spacing = _around(r, h)
        return m * (int(_ring_steps(L, 0.0, spacing)[0]) + 1) + 2 * _cap_count(m, r, spacing)

    h = _pick_edge(n, count, _MAX_STRETCH * 2 * math.pi * r / _MIN_AROUND / _ROW)
    m, spacing = _around(r, h)
    s = _ring_positions(L, 0.0, spacing)
    t = s / c
    Tn = np.stack([-R * np.sin(t), R * np.cos(t), np.full_like(t, b)], 1) / c
    N = np.stack([-np.cos(t), -np.sin(t), np.zeros_like(t)], 1)       # Frenet normal
    B = np.cross(Tn, N)
    # the Frenet frame spins by the torsion b / c^2 per unit length; turning it
    # back by that angle gives the rotation-minimising frame (no twist)
    spin = -(b / c**2) * s
    U = np.cos(spin)[:, None] * N + np.sin(spin)[:, None] * B
    W = np.cross(Tn, U)
    return _tube(centre_line(s), U, W, Tn, np.full(len(s), r), m, 0, start_cap=True)


# --------------------------------------------------------- body with arms

def _hole_rings(tube_radius: float, edge: float) -> int:
    """Rings of body vertices to remove under an arm: the hexagonal loop left
    (inradius about 0.8 k edges) clears the tube by ``_CLEARANCE`` edges. The
    build grows each hole until it does; this estimate serves the plan."""
    return max(1, math.ceil((tube_radius + _CLEARANCE * edge) / (0.8 * edge)))


def _body_plan(h: float, R: float, tube_radius: float, separation: float) -> Tuple[int, int]:
    """Geodesic frequency and hole rings for a body of radius ``R`` with edge
    about ``h``, refined until the centres of arms ``separation`` apart (chord)
    are likely 2k + 1 edges apart, so their holes' loops are disjoint (the build
    checks, and refines further if the estimate fell short)."""
    nu = max(3, math.ceil(_EDGE * R / h))
    while True:
        e = _EDGE * R / nu
        k = _hole_rings(tube_radius, e)
        if (2 * k + 2) * e <= separation:
            return nu, k
        nu += 1


def _body_arms_count(h: float, R: float, r: float, separation: float,
                     lengths: np.ndarray) -> int:
    nu, k = _body_plan(h, R, r, separation)
    m, spacing = _around(r, h)
    body = 10 * nu * nu + 2 - len(lengths) * (3 * k * k - 3 * k + 1)
    rings = int(np.sum(_ring_steps(lengths, _TAPER, spacing)[0] + 1))
    return body + m * rings + len(lengths) * _cap_count(m, (1 - _TAPER) * r,
                                                         (1 - _TAPER) * spacing)


def _nearest_vertices(V: np.ndarray, directions: np.ndarray) -> np.ndarray:
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


def _carve(V: np.ndarray, F: np.ndarray, centres: np.ndarray, clearance: float,
           reach: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Breadth-first rings about each centre vertex of the sphere ``V``, each grown
    until its newest ring keeps ``clearance`` from the arm's axis (the ray through
    the centre); that ring is the hole's loop, the rings inside it go.

    Only vertices within angle ``reach`` of a centre take part. Returns, per
    vertex, its arm (-1: none) and ring; per arm, the ring of its loop; and
    whether the holes are independent: no vertex to be removed neighbours another
    arm's disk (else removing both disks would pinch the body).
    """
    axes = _unit(V[centres])
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
    if np.any(np.einsum("ij,ij->i", _unit(V[labelled]), axes[arm[labelled]])
              < math.cos(0.8 * reach)):
        raise RuntimeError("spherify.datasets: a hole under an arm outgrew its search disk")
    u, v = e[:, 0], e[:, 1]
    inside_u = (arm[u] >= 0) & (ring[u] < loop_ring[arm[u]])
    inside_v = (arm[v] >= 0) & (ring[v] < loop_ring[arm[v]])
    independent = not np.any((arm[u] >= 0) & (arm[v] >= 0) & (arm[u] != arm[v])
                             & (inside_u | inside_v))
    return arm, ring, loop_ring, independent


def _holed_body(R: float, nu: int, r: float, directions: np.ndarray) -> Tuple[np.ndarray, ...]:
    """A geodesic sphere of radius ``R`` (frequency ``nu`` or finer) with a hole
    for an arm of base radius ``r`` at the vertex nearest each of ``directions``.
    Returns V, F (holes not yet cut), the centre vertices, and ``_carve``'s arm,
    ring and loop_ring."""
    while True:
        V, F = _geodesic_arrays(nu)
        V *= R
        centres = _nearest_vertices(V, directions)
        edge = _EDGE * R / nu
        k = _hole_rings(r, edge)
        arm, ring, loop_ring, independent = _carve(
            V, F, centres, r + _CLEARANCE * edge, (2 * k + 6) * edge / R)
        if independent and len(np.unique(centres)) == len(centres):
            return V, F, centres, arm, ring, loop_ring
        nu += 1        # the plan's spacing estimate fell short: refine the body


def _attach_arms(body: Tuple[np.ndarray, ...], around: int,
                 arms: Sequence[Tuple[np.ndarray, ...]]) -> Arrays:
    """Cut the holes of ``_holed_body`` and join arm ``i`` to hole ``i``: each arm
    is a tube's rings (C, U, W, T, radius) of ``around`` vertices, the first ring
    on the sphere round the hole's axis."""
    V, F, centres, arm, ring, loop_ring = body
    removed = (arm >= 0) & (ring < loop_ring[np.maximum(arm, 0)])
    new_id = np.cumsum(~removed) - 1
    parts_V = [V[~removed]]
    parts_F = [new_id[F[~removed[F].any(axis=1)]]]
    n = len(parts_V[0])
    for i, (C, U, W, T, radius) in enumerate(arms):
        tube_V, tube_F = _tube(C, U, W, T, radius, around, n, start_cap=False)
        # zip the hole's loop (ordered by angle in the arm's base frame) to the
        # tube's first ring; the surface runs from the loop inwards, normal +d
        loop = np.nonzero((arm == i) & (ring == loop_ring[i]))[0]
        angle = (np.arctan2(V[loop] @ W[0], V[loop] @ U[0]) / (2 * math.pi)) % 1.0
        order = np.argsort(angle, kind="stable")
        loop = loop[order]
        parts_F.append(_zip(new_id[loop], angle[order], V[loop], n + np.arange(around),
                                  np.arange(around) / around, tube_V[:around]))
        parts_V.append(tube_V)
        parts_F.append(tube_F)
        n += len(tube_V)
    return np.concatenate(parts_V), np.concatenate(parts_F)


def _spread(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` well-spread unit vectors: a Fibonacci lattice, randomly turned and
    jittered, then (2 to 400 points) relaxed by a few steps of mutual repulsion."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = math.pi * (1 + math.sqrt(5.0)) * i
    P = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    relax = 1 < n <= 400
    P = _unit(P @ Q + rng.normal(scale=(0.3 if relax else 0.05) / math.sqrt(n), size=(n, 3)))
    step = 0.1 * math.sqrt(4 * math.pi / n)          # a tenth of the typical spacing
    for _ in range(50 if relax else 0):
        diff = P[:, None] - P[None]
        dist = np.linalg.norm(diff, axis=-1) + np.eye(n)
        push = (diff / dist[..., None] ** 3).sum(axis=1)
        push -= (push * P).sum(axis=1, keepdims=True) * P          # along the sphere
        P = _unit(P + step * push / np.linalg.norm(push, axis=1).max())
    return P


def _separation(P: np.ndarray, R: float, r: float, what: str) -> float:
    """Smallest distance between the points ``R * P`` where arms of radius ``r``
    leave the body; MeshError if under ``_ROOM * r`` (then the body between their
    holes would need ever finer vertices)."""
    best = 2.0
    for lo in range(0, len(P), 256):
        d = np.linalg.norm(P[lo:lo + 256, None] - P[None], axis=-1)
        d[np.arange(len(d)), lo + np.arange(len(d))] = 3.0
        best = min(best, float(d.min()))
    if best * R < _ROOM * r:
        raise _error(f"{len(P)} {what} of radius {r} do not fit on the body; "
                     f"use fewer or thinner {what}")
    return best * R


# ------------------------------------------------------------------- urchin

def _urchin_arrays(n_vertices: int = 20000, spikes: int = 32, spike_length: float = 2.0,
                   spike_radius: float = 0.05, seed: int = 0) -> Arrays:
    n = _count("n_vertices", n_vertices, 1)
    spikes = _count("spikes", spikes, 1)
    length = _positive("spike_length", spike_length)
    r = _positive("spike_radius", spike_radius)
    R = 1.0
    if r > 0.25 * R:
        raise _error("spike_radius must be at most a quarter of the body radius (1)")
    if 3.8 / math.sqrt(spikes) < _ROOM * r:   # even a perfect packing would not fit them
        raise _error(f"{spikes} spikes of radius {r} do not fit on the body; "
                     "use fewer or thinner spikes")
    rng = np.random.default_rng(seed)
    directions = _spread(spikes, rng)
    lengths = length * rng.uniform(0.85, 1.15, spikes)
    # spikes are rays from the centre, so they are closest at their bases
    separation = _separation(directions, R, r, "spikes")

    def count(h: float) -> int:
        return _body_arms_count(h, R, r, separation, lengths)

    h = _pick_edge(n, count, _MAX_STRETCH * 2 * math.pi * r / _MIN_AROUND / _ROW)
    nu = _body_plan(h, R, r, separation)[0]
    m, spacing = _around(r, h)

    body = _holed_body(R, nu, r, directions)
    rings = []
    for i, d in enumerate(body[0][body[2]] / R):     # spikes leave from body vertices
        s = _ring_positions(float(lengths[i]), _TAPER, spacing)
        C = (math.sqrt(R * R - r * r) + s)[:, None] * d        # first ring lies on the body
        U = _perpendicular(d)
        ones = np.ones((len(s), 1))
        rings.append((C, ones * U, ones * np.cross(d, U), ones * d,
                      r * (1 - _TAPER * s / lengths[i])))
    return _attach_arms(body, m, rings)


# ---------------------------------------------------------------- tentacles

def _tentacles_arrays(n_vertices: int = 20000, arms: int = 8, arm_length: float = 4.0,
                      arm_radius: float = 0.12, curl: float = 1.5, seed: int = 0) -> Arrays:
    n = _count("n_vertices", n_vertices, 1)
    arms = _count("arms", arms, 1)
    length = _positive("arm_length", arm_length)
    r = _positive("arm_radius", arm_radius)
    curl = _positive("curl", curl, allow_zero=True)
    R = 1.0
    if r > 0.25 * R:
        raise _error("arm_radius must be at most a quarter of the body radius (1)")
    if length < 6 * r:
        raise _error("arm_length must be at least 6 x arm_radius")
    rng = np.random.default_rng(seed)
    # arms leave below the equator, evenly round the vertical axis; each curls
    # in its own vertical half-plane, so arms stay apart however they curl
    azimuth = 2 * math.pi * (np.arange(arms) + rng.uniform(-0.05, 0.05, arms)) / arms
    polar = math.radians(120) + rng.uniform(-0.06, 0.06, arms)
    directions = np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                           np.cos(polar)], 1)
    lengths = length * rng.uniform(0.85, 1.1, arms)
    turn = curl * math.pi * rng.uniform(0.85, 1.1, arms)
    straight = np.maximum(0.2 * lengths, 3 * r)      # radial root before the curl starts
    separation = _separation(directions, R, r, "arms")

    def centre_line(i: int, d: np.ndarray, s: np.ndarray) -> Tuple[np.ndarray, ...]:
        """Centre, tangent and in-plane unit vectors of arm ``i`` at arc lengths
        ``s``: straight from the body, then a clothoid (curvature growing linearly)
        turning through ``turn[i]`` towards +z, in the plane of d and the z axis."""
        out = _unit(np.array([d[0], d[1], 0.0]))
        up = np.array([0.0, 0.0, 1.0])
        theta0 = math.atan2(d[2], d @ out)
        L, s0 = float(lengths[i]), float(straight[i])

        def theta(x: np.ndarray) -> np.ndarray:
            return theta0 + turn[i] * (np.clip((x - s0) / (L - s0), 0.0, 1.0)) ** 2

        fine = np.linspace(0.0, L, 4097)
        th = theta(fine)
        half = 0.5 * (fine[1] - fine[0])
        x = np.concatenate([[0.0], np.cumsum(half * (np.cos(th[1:]) + np.cos(th[:-1])))])
        z = np.concatenate([[0.0], np.cumsum(half * (np.sin(th[1:]) + np.sin(th[:-1])))])
        base = math.sqrt(R * R - r * r) * d                   # first ring lies on the body
        C = base + np.interp(s, fine, x)[:, None] * out + np.interp(s, fine, z)[:, None] * up
        ts = theta(s)
        T = np.cos(ts)[:, None] * out + np.sin(ts)[:, None] * up
        return C, T, np.cross(out, up)

    def count(h: float) -> int:
        return _body_arms_count(h, R, r, separation, lengths)

    h = _pick_edge(n, count, _MAX_STRETCH * 2 * math.pi * r / _MIN_AROUND / _ROW)
    nu = _body_plan(h, R, r, separation)[0]
    m, spacing = _around(r, h)
    body = _holed_body(R, nu, r, directions)
    bases = body[0][body[2]] / R                     # arms leave from body vertices

    # clearance of the arms from each other, themselves and the body, sampled at
    # half the tip radius; and the inner side of the tightest bend must not fold
    tip = (1 - _TAPER) * r
    paths = []
    for i, d in enumerate(bases):
        s = np.linspace(0.0, lengths[i], int(2 * lengths[i] / tip) + 2)
        C = centre_line(i, d, s)[0]
        radius = r * (1 - _TAPER * s / lengths[i])
        paths.append((s, C, radius))
        curvature = 2 * turn[i] / (lengths[i] - straight[i]) ** 2 * np.maximum(s - straight[i], 0)
        beyond = s > straight[i]
        if np.any(curvature * radius > 0.6) or \
                np.any(np.linalg.norm(C[beyond], axis=1) - R < 1.05 * radius[beyond]):
            raise _error("these tentacles parameters bend an arm too tightly or into the "
                         "body; use less curl, thinner or longer arms")
    _check_clearance(paths, "tentacles")

    rings = []
    for i, d in enumerate(bases):
        s = _ring_positions(float(lengths[i]), _TAPER, spacing)
        C, T, normal = centre_line(i, d, s)
        # a plane curve's rotation-minimising frame: the plane normal and T x it
        W = np.broadcast_to(normal, C.shape)
        rings.append((C, np.cross(W, T), W, T, r * (1 - _TAPER * s / lengths[i])))
    return _attach_arms(body, m, rings)


# ------------------------------------------------------------------ public API

_GUARANTEES = """
    The mesh is closed, connected, manifold and of genus 0, with faces
    counter-clockwise seen from outside (positive signed volume), no
    self-intersections, no degenerate or duplicate faces and no coincident
    vertices. The same arguments give the same arrays, bit for bit.
    """


def _shape(function: Callable[..., "Mesh"]) -> Callable[..., "Mesh"]:
    """Append the guarantees every shape keeps to its docstring's Notes."""
    function.__doc__ = (function.__doc__ or "").rstrip() + "\n" + _GUARANTEES
    return function


@_shape
def icosphere(subdivisions: int = 3) -> "Mesh":
    """The unit icosphere: an icosahedron with each face cut into ``4**k`` triangles.

    Parameters
    ----------
    subdivisions : int, default 3
        ``k`` in 0..10.

    Returns
    -------
    Mesh
        ``vertices`` (10 * 4**k + 2, 3) float64, all on the unit sphere;
        ``faces`` (20 * 4**k, 3) int64. Smallest triangle angle about 50 degrees.

    Raises
    ------
    MeshError
        ``subdivisions`` is not an integer in 0..10.

    Notes
    -----
    Each face is cut by a flat lattice of frequency ``2**k`` and its points are
    projected onto the sphere (a class-I geodesic sphere); the connectivity is that
    of ``k`` rounds of midpoint subdivision. Cost O(4**k).
    """
    return _as_mesh(_icosphere_arrays(subdivisions))


@_shape
def ellipsoid(n_vertices: int = 2000, axes: Sequence[float] = (1.0, 0.6, 0.4)) -> "Mesh":
    """An ellipsoid centred at the origin with semi-axes ``axes`` along x, y, z.

    Parameters
    ----------
    n_vertices : int, default 2000
        Target vertex count (at least 1).
    axes : sequence of 3 positive floats, default (1.0, 0.6, 0.4)

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64, where
        ``n = 10 nu**2 + 2`` for the frequency ``nu`` that comes nearest the
        target: within 9% of it for targets of 1,000 or more, 21% from 140, 28%
        from 100. Smallest angle about 26 degrees for the default axes (lower
        for longer, thinner ellipsoids: 4 degrees for axes (3, 0.2, 0.2)).

    Raises
    ------
    MeshError
        ``n_vertices`` below 1 or not an integer; ``axes`` not three positive numbers.

    Notes
    -----
    A geodesic unit sphere scaled by ``axes``. Cost O(n).
    """
    return _as_mesh(_ellipsoid_arrays(n_vertices, axes))


@_shape
def bumpy_blob(n_vertices: int = 5000, bumps: int = 12, amplitude: float = 0.25,
               seed: int = 0) -> "Mesh":
    """A lumpy sphere, star-shaped from the origin.

    Parameters
    ----------
    n_vertices : int, default 5000
        Target vertex count (at least 1); met as for :func:`ellipsoid`.
    bumps : int, default 12
        Number of smooth bumps (and a few dents) at random places.
    amplitude : float, default 0.25
        Height of the largest bump, relative to the unit radius.
    seed : int, default 0
        Seed of the random bump placement, height and width.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64 with
        ``n = 10 nu**2 + 2`` as for :func:`ellipsoid`. Smallest angle above 35
        degrees for the defaults (any seed).

    Raises
    ------
    MeshError
        A count below its minimum or not an integer; ``amplitude`` negative or so
        large that dents reach the centre.

    Notes
    -----
    Each vertex of a geodesic unit sphere moves along its ray to radius
    ``1 + amplitude * sum_i a_i exp(k_i (x . c_i - 1))``. A radial move keeps
    every triangle facing the origin, so the result is embedded and every ray
    from the origin crosses it once. Cost O(n * bumps).
    """
    return _as_mesh(_bumpy_blob_arrays(n_vertices, bumps, amplitude, seed))


@_shape
def helix_tube(n_vertices: int = 5000, turns: float = 3.0, radius: float = 1.0,
               tube_radius: float = 0.15, pitch: float = 0.8) -> "Mesh":
    """A thin tube along a helix about the z axis, with rounded ends; not
    star-shaped from any point (like the thesis's HELIX model).

    Parameters
    ----------
    n_vertices : int, default 5000
        Target vertex count, met within 20% (within 6% from 5,000 up). The
        smallest tube (4 vertices per ring, rings 3x farther apart than the
        vertices around them) has 114 vertices for the defaults; smaller
        targets give it.
    turns : float, default 3.0
    radius : float, default 1.0
        Radius of the helix (of the tube's centre line).
    tube_radius : float, default 0.15
    pitch : float, default 0.8
        Rise per turn; the helix is centred on the origin.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64. Smallest
        angle about 40 degrees from 1,000 vertices up, 15 at the minimum.

    Raises
    ------
    MeshError
        A parameter not positive, or a tube so thick that neighbouring turns or
        the inside of the bend would meet.

    Notes
    -----
    Rings of ``m = max(4, round(2 pi tube_radius / h))`` vertices, each turned
    half a step from the last (near-equilateral triangles), swept with a
    rotation-minimising frame (the Frenet frame turned back by the torsion, so
    the mesh does not twist); each end is a hemisphere of shrinking rings closed
    by a 3-6 triangle fan. Cost O(n).
    """
    return _as_mesh(_helix_tube_arrays(n_vertices, turns, radius, tube_radius, pitch))


@_shape
def urchin(n_vertices: int = 20000, spikes: int = 32, spike_length: float = 2.0,
           spike_radius: float = 0.05, seed: int = 0) -> "Mesh":
    """A unit ball with long thin spikes.

    The spikes point away from the centre, but their tubes are triangulated
    with rings turned by half a step, so some tube faces face slightly away
    from the origin: the mesh is not star-shaped (radial projection from the
    kernel refuses it), though it comes close.

    Parameters
    ----------
    n_vertices : int, default 20000
        Target vertex count, met within 15% above the minimum. The smallest
        urchin (4 vertices around each spike, its rings 3x farther apart, a
        body fine enough to keep the spikes' holes apart) has 2,350 to 2,850
        vertices for the defaults, depending on the seed (about 80 per spike);
        smaller targets give it.
    spikes : int, default 32
        Number of spikes, spread evenly (a relaxed Fibonacci lattice).
    spike_length : float, default 2.0
        Length from the body's surface to the tip, varied by +-15% per spike.
    spike_radius : float, default 0.05
        Radius at the base, at most 0.25; spikes thin to 40% of it at the
        rounded tip.
    seed : int, default 0
        Seed of the spike directions and lengths.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64. Two
        thirds of the vertices lie on the spikes (about 400 per spike at the
        default size). Smallest angle above 15 degrees.

    Raises
    ------
    MeshError
        A parameter out of range, or too many or too thick spikes to fit.

    Notes
    -----
    The body is a geodesic sphere; under each spike the rings of body vertices
    round the nearest vertex are removed until the hole clears the spike, and
    the hole's loop is zipped to the first ring of the spike's tube. Cost O(n)
    plus O(spikes**2).
    """
    return _as_mesh(_urchin_arrays(n_vertices, spikes, spike_length, spike_radius, seed))


@_shape
def tentacles(n_vertices: int = 20000, arms: int = 8, arm_length: float = 4.0,
              arm_radius: float = 0.12, curl: float = 1.5, seed: int = 0) -> "Mesh":
    """A unit ball with long curling tentacles below its equator; not
    star-shaped from any point.

    Parameters
    ----------
    n_vertices : int, default 20000
        Target vertex count, met within 10% above the minimum: 1,700 to 2,000
        vertices for the defaults, depending on the seed (smaller targets give
        that).
    arms : int, default 8
        Number of tentacles, evenly round the vertical axis 30 degrees below
        the equator (jittered).
    arm_length : float, default 4.0
        Length along the centre line, varied by -15%..+10% per arm.
    arm_radius : float, default 0.12
        Radius at the base, at most 0.25; arms thin to 40% of it at the tip.
    curl : float, default 1.5
        How far each arm curls, in half turns (pi radians): 0 gives straight
        arms; 1.5 turns the tip through 270 degrees. Varied by -15%..+10%.
    seed : int, default 0
        Seed of the jitter in placement, length and curl.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64. Smallest
        angle about 20 degrees, above 13 at the minimum size.

    Raises
    ------
    MeshError
        A parameter out of range, or arms that would bend into themselves, each
        other or the body (checked on their centre lines).

    Notes
    -----
    Each arm leaves the body radially, then follows a clothoid (curvature
    growing linearly) in the vertical half-plane through its base, so arms in
    different half-planes cannot meet. Its tube uses the plane curve's
    rotation-minimising frame (the plane normal); the body and joins are built
    as for :func:`urchin`. Cost O(n).
    """
    return _as_mesh(_tentacles_arrays(n_vertices, arms, arm_length, arm_radius, curl, seed))


_SHAPES: Dict[str, Callable[..., Arrays]] = {
    "icosphere": _sphere_arrays,
    "ellipsoid": _ellipsoid_arrays,
    "bumpy_blob": _bumpy_blob_arrays,
    "helix_tube": _helix_tube_arrays,
    "urchin": _urchin_arrays,
    "tentacles": _tentacles_arrays,
}


def names() -> List[str]:
    """Names of the shapes :func:`make` knows, in a fixed order (simplest first).

    Returns
    -------
    list of str
    """
    return list(_SHAPES)


def _make_arrays(name: str, n_vertices: int, **kwargs: Any) -> Arrays:
    try:
        build = _SHAPES[name]
    except (KeyError, TypeError):
        raise _error(f"unknown dataset {name!r}; choose one of {', '.join(_SHAPES)}") from None
    return build(n_vertices, **kwargs)


def make(name: str, n_vertices: int, **kwargs: Any) -> "Mesh":
    """Make the shape ``name`` with about ``n_vertices`` vertices.

    Parameters
    ----------
    name : str
        One of :func:`names`.
    n_vertices : int
        Target vertex count. ``"icosphere"`` takes the geodesic unit sphere of the
        nearest frequency ``nu`` (``10 nu**2 + 2`` vertices; equal to
        ``icosphere(k)`` when ``nu = 2**k``); the others pass it on.
    **kwargs
        The shape's other keyword arguments.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64, ``faces`` (2n - 4, 3) int64.

    Raises
    ------
    MeshError
        Unknown ``name``, or arguments the shape rejects.
    TypeError
        A keyword argument the shape does not take.

    Examples
    --------
    >>> import spherify as sp
    >>> meshes = [sp.datasets.make(name, 1000) for name in sp.datasets.names()]
    """
    return _as_mesh(_make_arrays(name, n_vertices, **kwargs))
