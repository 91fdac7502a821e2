"""Hypothesis strategies: random genus-0 triangulations and deliberately broken meshes.

A valid mesh is made in four steps:

1. the convex hull of random points on the unit sphere (every point is a hull
   vertex), faces turned counter-clockwise seen from outside;
2. random edge flips that keep the triangulation simplicial: no flip creates an
   edge that already exists or leaves a vertex with fewer than three neighbours,
   and none lets the enclosed volume shrink below half of the hull's;
3. a smooth orientation-preserving deformation: stretch, twist about the long
   axis, then bend the long axis into an arc of up to ~290 degrees, which makes the
   shape a banana that is star-shaped from no point;
4. a random relabelling of vertices, faces and face corners, then a random
   scale and translation.

Every step keeps all faces of non-zero area and the signed volume clearly
positive, so the result is a closed, connected, consistently outward-oriented
genus-0 mesh whatever the draw. Each broken-mesh strategy starts from such a mesh,
breaks it in one known way and returns the report fields that must follow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Sequence, Set, Tuple

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

try:  # scipy is a test dependency; modules that use the hull skip without it
    from scipy.spatial import ConvexHull
except ImportError:  # pragma: no cover - exercised only without scipy
    ConvexHull = None

Edge = Tuple[int, int]


# --------------------------------------------------------------------------
# Small geometric and combinatorial helpers (numpy, independent of spherify)
# --------------------------------------------------------------------------

def face_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def signed_volume(V: np.ndarray, F: np.ndarray) -> float:
    """Enclosed volume by the divergence theorem, about the bounding-box centre."""
    o = 0.5 * (V.min(axis=0) + V.max(axis=0))
    a, b, c = V[F[:, 0]] - o, V[F[:, 1]] - o, V[F[:, 2]] - o
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def undirected_edges(F: np.ndarray) -> Set[Edge]:
    out: Set[Edge] = set()
    for a, b, c in F.tolist():
        for u, v in ((a, b), (b, c), (c, a)):
            out.add((min(u, v), max(u, v)))
    return out


def canonical_face(face: Sequence[int]) -> Tuple[int, int, int]:
    """The face rotated so that its smallest index comes first (keeps the cyclic order)."""
    face = [int(x) for x in face]
    k = face.index(min(face))
    return tuple(face[k:] + face[:k])  # type: ignore[return-value]


def canonical_faces(F: np.ndarray) -> List[Tuple[int, int, int]]:
    return [canonical_face(f) for f in F]


def same_cycle(loop: Sequence[int], cycle: Sequence[int]) -> bool:
    """True when ``loop`` is ``cycle`` up to rotation (same direction)."""
    loop, cycle = [int(x) for x in loop], [int(x) for x in cycle]
    if len(loop) != len(cycle) or not loop:
        return False
    if cycle[0] not in loop:
        return False
    k = loop.index(cycle[0])
    return loop[k:] + loop[:k] == cycle


def vertex_link(F: np.ndarray, v: int) -> List[int]:
    """The neighbours of ``v`` in the cyclic order of its (ccw) faces."""
    nxt: Dict[int, int] = {}
    for face in F.tolist():
        if v in face:
            k = face.index(v)
            nxt[face[(k + 1) % 3]] = face[(k + 2) % 3]
    start = min(nxt)
    cycle = [start]
    while nxt[cycle[-1]] != start:
        cycle.append(nxt[cycle[-1]])
    assert len(cycle) == len(nxt), "the link of a vertex of a simplicial sphere is one cycle"
    return cycle


# --------------------------------------------------------------------------
# Valid genus-0 meshes
# --------------------------------------------------------------------------

@dataclass(frozen=True)
class Surface:
    """A valid genus-0 mesh (closed, outward) and how it was made."""

    V: np.ndarray
    F: np.ndarray
    recipe: str = ""

    def __repr__(self) -> str:  # short, so that hypothesis failure output stays readable
        return f"Surface({self.recipe}, n_vertices={len(self.V)}, n_faces={len(self.F)})"


TETRA_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)


def tetrahedron() -> Surface:
    return Surface(TETRA_V.copy(), TETRA_F.copy(), "tetrahedron")


def _hull(rng: np.random.Generator, n: int) -> Tuple[np.ndarray, np.ndarray]:
    """Convex hull of n random points on the unit sphere, outward, every point used."""
    if ConvexHull is None:  # pragma: no cover
        raise RuntimeError("scipy is needed to generate random meshes")
    for _ in range(1000):
        P = rng.normal(size=(n, 3))
        P /= np.linalg.norm(P, axis=1, keepdims=True)
        hull = ConvexHull(P)
        if len(hull.vertices) != n:
            continue  # a point fell (numerically) onto a facet: draw again
        F = hull.simplices.astype(np.int64)
        normals = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
        inward = np.einsum("ij,ij->i", normals, hull.equations[:, :3]) < 0
        F[inward] = F[inward][:, ::-1]
        # Well-shaped enough that rounding can never decide a sign: no sliver
        # tetrahedron, no face near zero area.
        if signed_volume(P, F) > 0.02 and face_areas(P, F).min() > 1e-7:
            return P, F
    raise RuntimeError(f"no well-shaped hull of {n} points found")  # pragma: no cover


def _cross(u: Sequence[float], v: Sequence[float]) -> Tuple[float, float, float]:
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _tet_volume(P: Sequence[Sequence[float]], face: Sequence[int]) -> float:
    """Signed volume of the tetrahedron (origin, face) (plain floats: this runs
    once per candidate flip, where numpy's call overhead dominates)."""
    a, b, c = P[face[0]], P[face[1]], P[face[2]]
    n = _cross(b, c)
    return (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0


def _area(P: Sequence[Sequence[float]], face: Sequence[int]) -> float:
    a, b, c = P[face[0]], P[face[1]], P[face[2]]
    n = _cross([b[i] - a[i] for i in range(3)], [c[i] - a[i] for i in range(3)])
    return 0.5 * math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)


def flip_edges(rng: np.random.Generator, V: np.ndarray, F: np.ndarray, n_flips: int) -> np.ndarray:
    """Random edge flips keeping a simplicial sphere, consistent orientation and
    at least half of the starting volume."""
    faces = [list(f) for f in F.tolist()]
    P = V.tolist()
    where: Dict[Edge, int] = {}
    for i, (a, b, c) in enumerate(faces):
        where[(a, b)], where[(b, c)], where[(c, a)] = i, i, i
    degree = np.zeros(len(V), dtype=np.int64)
    for (a, b) in where:
        degree[a] += 1  # each undirected edge is seen once from each end
    volume = sum(_tet_volume(P, f) for f in faces)
    floor = 0.5 * volume
    done = 0
    for _ in range(20 * n_flips + 20):
        if done >= n_flips:
            break
        f = int(rng.integers(len(faces)))
        k = int(rng.integers(3))
        a, b, c = faces[f][k], faces[f][(k + 1) % 3], faces[f][(k + 2) % 3]
        g = where[(b, a)]
        d = next(x for x in faces[g] if x != a and x != b)
        if (c, d) in where or (d, c) in where or degree[a] <= 3 or degree[b] <= 3:
            continue
        new_f, new_g = [d, b, c], [c, a, d]
        change = (_tet_volume(P, new_f) + _tet_volume(P, new_g)
                  - _tet_volume(P, faces[f]) - _tet_volume(P, faces[g]))
        if volume + change < floor or min(_area(P, new_f), _area(P, new_g)) < 1e-7:
            continue
        for e in ((a, b), (b, c), (c, a), (b, a), (a, d), (d, b)):
            del where[e]
        faces[f], faces[g] = new_f, new_g
        for i, (x, y, z) in ((f, new_f), (g, new_g)):
            where[(x, y)], where[(y, z)], where[(z, x)] = i, i, i
        degree[a] -= 1
        degree[b] -= 1
        degree[c] += 1
        degree[d] += 1
        volume += change
        done += 1
    return np.array(faces, dtype=np.int64)


def deform(V: np.ndarray, stretch: float, flatten: float, twist: float, bend: float) -> np.ndarray:
    """Stretch along z (half-length ``stretch``), squash y by ``flatten``, twist about
    z by up to ``twist`` radians end to end, then bend the z axis into an arc of
    ``bend`` radians about the line x = R, y free. Each map has a positive
    Jacobian on the shape (the bend needs R > max x = 1, guaranteed below)."""
    X = V * np.array([1.0, flatten, stretch])
    angle = twist * X[:, 2] / (2.0 * stretch)
    cos, sin = np.cos(angle), np.sin(angle)
    X = np.column_stack([cos * X[:, 0] - sin * X[:, 1], sin * X[:, 0] + cos * X[:, 1], X[:, 2]])
    if bend > 1e-3:  # below that the arc radius overflows; the shape is straight anyway
        R = 2.0 * stretch / bend          # arc of length 2*stretch and angle bend
        r = R - X[:, 0]                   # > 0 since |x| <= 1 < R
        phi = X[:, 2] / R
        X = np.column_stack([R - r * np.cos(phi), X[:, 1], r * np.sin(phi)])
    return X


def make_surface(n: int, seed: int, flip_fraction: float, stretch: float, flatten: float,
                 twist: float, bend: float, log_scale: float) -> Surface:
    """A valid genus-0 mesh with ``n`` vertices; see the module docstring."""
    rng = np.random.default_rng(seed)
    V, F = _hull(rng, n)
    F = flip_edges(rng, V, F, int(flip_fraction * n))
    start = signed_volume(V, F)
    # The bend must keep R = 2*stretch/bend > 1.1 (x never reaches the axis).
    bend = min(bend, 2.0 * stretch / 1.1)
    for _ in range(12):
        W = deform(V, stretch, flatten, twist, bend)
        if signed_volume(W, F) > 0.2 * start * flatten and face_areas(W, F).min() > 1e-9:
            break
        # A coarse mesh can fold under a strong deformation: soften it.
        twist, bend, stretch = 0.5 * twist, 0.5 * bend, 1.0 + 0.5 * (stretch - 1.0)
    else:
        W, twist, bend, stretch = V * np.array([1.0, flatten, 1.0]), 0.0, 0.0, 1.0
    # Relabel vertices, shuffle faces, rotate corners; scale and move.
    perm = rng.permutation(n)
    V2 = np.empty_like(W)
    V2[perm] = W
    F2 = perm[F][rng.permutation(len(F))]
    shift = rng.integers(3, size=len(F2))
    F2 = np.take_along_axis(F2, (np.arange(3)[None, :] + shift[:, None]) % 3, axis=1)
    scale = 10.0 ** log_scale
    V2 = V2 * scale + rng.uniform(-5, 5, size=3) * scale
    recipe = (f"n={n} seed={seed} flips={flip_fraction:.2f} stretch={stretch:.2f} "
              f"flatten={flatten:.2f} twist={twist:.2f} bend={bend:.2f} scale=1e{log_scale:.1f}")
    return Surface(V2, F2.astype(np.int64), recipe)


@st.composite
def surfaces(draw: Any, min_vertices: int = 4, max_vertices: int = 300) -> Surface:
    """Valid closed genus-0 meshes with outward faces; the tetrahedron included."""
    if min_vertices <= 4 and draw(st.integers(0, 9)) == 0:
        return tetrahedron()
    n = draw(st.integers(min_vertices, max_vertices))
    seed = draw(st.integers(0, 2**32 - 1))
    unit = st.floats(0.0, 1.0)
    return make_surface(
        n, seed,
        flip_fraction=draw(st.floats(0.0, 1.5)),
        stretch=1.0 + 2.0 * draw(unit),
        flatten=0.5 + 0.5 * draw(unit),
        twist=math.pi * draw(unit),
        bend=1.6 * math.pi * draw(unit),
        log_scale=draw(st.floats(-2.0, 2.0)),
    )


# --------------------------------------------------------------------------
# Broken meshes
# --------------------------------------------------------------------------

@dataclass
class Broken:
    """A mesh broken in one known way.

    ``expect`` maps MeshReport field names to the exact value they must have;
    ``base`` is the valid mesh it came from and ``info`` holds what was changed
    (face or vertex ids) for tests that need more than field equality.
    """

    kind: str
    V: np.ndarray
    F: np.ndarray
    base: Surface
    expect: Dict[str, Any]
    info: Dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        return f"Broken({self.kind}, {self.info}, from {self.base!r})"


def _rng(draw: Any) -> np.random.Generator:
    return np.random.default_rng(draw(st.integers(0, 2**32 - 1)))


def _disjoint_faces(rng: np.random.Generator, F: np.ndarray, k: int) -> List[int]:
    """Up to k faces, chosen at random, no two sharing a vertex."""
    used: Set[int] = set()
    chosen: List[int] = []
    for f in rng.permutation(len(F)).tolist():
        if len(chosen) == k:
            break
        if not used.intersection(F[f].tolist()):
            chosen.append(f)
            used.update(F[f].tolist())
    return chosen


def _insert_rows(F: np.ndarray, rows: np.ndarray, at: int) -> np.ndarray:
    return np.concatenate([F[:at], rows, F[at:]]).astype(np.int64)


@st.composite
def with_holes(draw: Any, max_holes: int = 3) -> Broken:
    """Remove 1..max_holes faces no two of which share a vertex: one boundary loop
    each, running opposite to the removed face."""
    s = draw(surfaces())
    rng = _rng(draw)
    gone = _disjoint_faces(rng, s.F, draw(st.integers(1, max_holes)))
    F = np.delete(s.F, gone, axis=0)
    k = len(gone)
    return Broken("holes", s.V, F, s, {
        "closed": False, "manifold": True, "is_sphere_topology": False,
        "n_components": 1, "genus": 0, "euler_characteristic": 2 - k,
        "n_boundary_loops": k, "n_boundary_edges": 3 * k,
        "n_nonmanifold_edges": 0, "n_nonmanifold_vertices": 0,
        "consistently_oriented": True, "outward": False,
    }, {"loops": [s.F[f][::-1].tolist() for f in gone]})


@st.composite
def with_star_removed(draw: Any) -> Broken:
    """Remove a vertex and every face around it (the vertex is dropped and the
    others renumbered): one boundary loop along its link."""
    s = draw(surfaces(min_vertices=5))
    v = draw(st.integers(0, len(s.V) - 1))
    link = vertex_link(s.F, v)
    keep = ~np.any(s.F == v, axis=1)
    renumber = np.arange(len(s.V)) - (np.arange(len(s.V)) > v)
    F = renumber[s.F[keep]]
    V = np.delete(s.V, v, axis=0)
    loop = [int(renumber[u]) for u in reversed(link)]
    return Broken("star_removed", V, F, s, {
        "closed": False, "manifold": True, "is_sphere_topology": False, "genus": 0,
        "euler_characteristic": 1, "n_boundary_loops": 1, "n_boundary_edges": len(link),
        "n_unreferenced_vertices": 0, "consistently_oriented": True,
    }, {"vertex": v, "loops": [loop]})


def _annulus(P: Sequence[int], Q: Sequence[int]) -> List[List[int]]:
    """Triangles joining loops P and Q: uses P's edges forward, Q's backward."""
    k = len(P)
    out = []
    for i in range(k):
        j = (i + 1) % k
        out += [[P[i], P[j], Q[j]], [P[i], Q[j], Q[i]]]
    return out


@st.composite
def with_handle(draw: Any) -> Broken:
    """Remove two vertex-disjoint faces and join their holes by a tube through a
    ring of three new vertices: a closed, consistently oriented genus-1 surface."""
    s = draw(surfaces(min_vertices=8))
    rng = _rng(draw)
    pair = _disjoint_faces(rng, s.F, 2)
    if len(pair) < 2:
        reject()
    A, B = s.F[pair[0]].tolist(), s.F[pair[1]].tolist()
    n = len(s.V)
    Bq = [B[0], B[2], B[1]]
    C = [n, n + 1, n + 2]
    size = float(np.ptp(s.V, axis=0).max())
    ring = 0.5 * (s.V[A] + s.V[Bq]) + rng.normal(scale=0.1 * size, size=(3, 3))
    V = np.concatenate([s.V, ring])
    tube = np.array(_annulus(A, C) + _annulus(C, Bq), dtype=np.int64)
    F = np.concatenate([np.delete(s.F, pair, axis=0), tube])
    if face_areas(V, F).min() <= 1e-12 * size * size:
        reject()
    return Broken("handle", V, F, s, {
        "closed": True, "manifold": True, "connected": True, "n_components": 1,
        "euler_characteristic": 0, "genus": 1, "is_sphere_topology": False,
        "consistently_oriented": True, "n_boundary_loops": 0,
    }, {"removed": pair})


@st.composite
def bowties(draw: Any) -> Broken:
    """Two spheres sharing one vertex (the second sphere's vertex is replaced by
    the first's, the second sphere moved so that they meet there)."""
    s = draw(surfaces(max_vertices=80))
    t = draw(surfaces(max_vertices=80))
    v1 = draw(st.integers(0, len(s.V) - 1))
    v2 = draw(st.integers(0, len(t.V) - 1))
    n = len(s.V)
    W = np.delete(t.V + (s.V[v1] - t.V[v2]), v2, axis=0)
    index = np.arange(len(t.V)) + n - (np.arange(len(t.V)) > v2)
    index[v2] = v1
    V = np.concatenate([s.V, W])
    F = np.concatenate([s.F, index[t.F]])
    return Broken("bowtie", V, F, s, {
        "nonmanifold_vertices": [v1], "n_nonmanifold_vertices": 1, "n_nonmanifold_edges": 0,
        "closed": True, "manifold": False, "genus": None, "n_components": 1,
        "connected": True, "euler_characteristic": 3, "is_sphere_topology": False,
    }, {"vertex": v1})


@st.composite
def two_components(draw: Any) -> Broken:
    """Two disjoint valid spheres side by side."""
    s = draw(surfaces(max_vertices=150))
    t = draw(surfaces(max_vertices=150))
    shift = s.V.max(axis=0) - t.V.min(axis=0) + 1.0
    V = np.concatenate([s.V, t.V + shift])
    F = np.concatenate([s.F, t.F + len(s.V)])
    return Broken("two_components", V, F, s, {
        "n_components": 2, "connected": False, "closed": True, "manifold": True,
        "euler_characteristic": 4, "genus": 0, "is_sphere_topology": False,
        "consistently_oriented": True, "outward": True,
    }, {"n_first": len(s.V)})


def inconsistent_edges_of(F: np.ndarray, flipped: np.ndarray) -> Set[Edge]:
    """Edges between a face of the ``flipped`` mask and one outside it."""
    owner: Dict[Edge, List[int]] = {}
    for i, (a, b, c) in enumerate(F.tolist()):
        for u, v in ((a, b), (b, c), (c, a)):
            owner.setdefault((min(u, v), max(u, v)), []).append(i)
    return {e for e, (f, g) in owner.items() if flipped[f] != flipped[g]}


@st.composite
def with_flipped_faces(draw: Any) -> Broken:
    """A non-empty proper subset of faces reversed."""
    s = draw(surfaces())
    rng = _rng(draw)
    m = len(s.F)
    k = draw(st.integers(1, m - 1))
    flipped = np.zeros(m, dtype=bool)
    flipped[rng.choice(m, size=k, replace=False)] = True
    F = s.F.copy()
    F[flipped] = F[flipped][:, ::-1]
    bad = inconsistent_edges_of(s.F, flipped)
    return Broken("flipped", s.V, F, s, {
        "consistently_oriented": False, "outward": False, "is_sphere_topology": True,
        "closed": True, "manifold": True, "genus": 0, "n_inconsistent_edges": len(bad),
    }, {"flipped": flipped, "inconsistent": bad})


@st.composite
def with_duplicate_face(draw: Any) -> Broken:
    """A copy of one face (same, rotated or reversed corner order) inserted anywhere."""
    s = draw(surfaces())
    m = len(s.F)
    f = draw(st.integers(0, m - 1))
    at = draw(st.integers(0, m))
    copy = s.F[f].copy()
    variant = draw(st.sampled_from(["same", "rotated", "reversed"]))
    if variant == "rotated":
        copy = np.roll(copy, 1)
    elif variant == "reversed":
        copy = copy[::-1]
    F = _insert_rows(s.F, copy[None, :], at)
    original = f + (f >= at)
    a, b, c = s.F[f].tolist()
    edges = sorted({(min(u, v), max(u, v)) for u, v in ((a, b), (b, c), (c, a))})
    return Broken("duplicate_face", s.V, F, s, {
        "duplicate_faces": [max(original, at)], "n_duplicate_faces": 1,
        "nonmanifold_edges": edges, "n_nonmanifold_edges": 3,
        "manifold": False, "is_sphere_topology": False, "genus": None,
    }, {"face": f, "variant": variant, "at": at})


@st.composite
def with_repeated_index_face(draw: Any) -> Broken:
    """An extra face repeating a vertex, e.g. (a, a, b), inserted anywhere."""
    s = draw(surfaces())
    n, m = len(s.V), len(s.F)
    a = draw(st.integers(0, n - 1))
    b = draw(st.integers(0, n - 1))
    pattern = draw(st.sampled_from([(a, a, b), (a, b, a), (b, a, a)]))
    at = draw(st.integers(0, m))
    F = _insert_rows(s.F, np.array([pattern]), at)
    return Broken("repeated_index", s.V, F, s, {
        "degenerate_faces": [at], "n_degenerate_faces": 1,
        "is_sphere_topology": False, "genus": None,
    }, {"face": at, "pattern": pattern})


@st.composite
def with_zero_area_faces(draw: Any) -> Broken:
    """Vertex c moved exactly onto its neighbour a: the two faces on edge (a, c)
    get exactly zero area (a zero-length edge); the topology is untouched."""
    s = draw(surfaces())
    e = draw(st.integers(0, len(s.F) * 3 - 1))
    a, c = int(s.F[e // 3][e % 3]), int(s.F[e // 3][(e % 3 + 1) % 3])
    V = s.V.copy()
    V[c] = V[a]
    on_edge = sorted(i for i, f in enumerate(s.F.tolist()) if a in f and c in f)
    others = [i for i, f in enumerate(s.F.tolist()) if c in f and a not in f]
    # The moved vertex could by chance land on a line through two others; such
    # draws are left out so that the expected list is exact.
    if len(others) and face_areas(V, s.F[others]).min() <= 1e-12 * float(np.ptp(V)) ** 2:
        reject()
    return Broken("zero_area", V, s.F, s, {
        "degenerate_faces": on_edge, "n_degenerate_faces": 2,
        "is_sphere_topology": True, "closed": True, "manifold": True, "genus": 0,
    }, {"moved": c, "onto": a})


@st.composite
def with_unreferenced_vertex(draw: Any) -> Broken:
    """A vertex that no face uses, inserted at any position."""
    s = draw(surfaces())
    n = len(s.V)
    k = draw(st.integers(0, n))
    point = draw(st.sampled_from(["far", "inside", "copy"]))
    p = {"far": s.V.max(axis=0) + 1.0, "inside": s.V.mean(axis=0), "copy": s.V[0]}[point]
    V = np.concatenate([s.V[:k], p[None, :], s.V[k:]])
    F = s.F + (s.F >= k)
    return Broken("unreferenced", V, F, s, {
        "unreferenced_vertices": [k], "n_unreferenced_vertices": 1,
        "is_sphere_topology": False, "closed": True, "manifold": True,
        "euler_characteristic": 2, "genus": 0, "n_components": 1, "outward": True,
    }, {"vertex": k})


@st.composite
def with_nonmanifold_edge(draw: Any) -> Broken:
    """A third face on an existing edge, through a new vertex."""
    s = draw(surfaces())
    e = draw(st.integers(0, len(s.F) * 3 - 1))
    a, b = int(s.F[e // 3][e % 3]), int(s.F[e // 3][(e % 3 + 1) % 3])
    n = len(s.V)
    centre = s.V.mean(axis=0)
    mid = 0.5 * (s.V[a] + s.V[b])
    x = mid + (mid - centre) + 0.25 * (s.V[b] - s.V[a])  # off the line a-b
    V = np.concatenate([s.V, x[None, :]])
    F = np.concatenate([s.F, [[a, b, n] if draw(st.booleans()) else [b, a, n]]])
    if face_areas(V, F[-1:])[0] <= 1e-12 * float(np.ptp(V)) ** 2:
        reject()
    return Broken("nonmanifold_edge", V, F.astype(np.int64), s, {
        "nonmanifold_edges": [(min(a, b), max(a, b))], "n_nonmanifold_edges": 1,
        "manifold": False, "closed": False, "genus": None, "is_sphere_topology": False,
        "n_boundary_edges": 2,
    }, {"edge": (a, b)})


BROKEN = {
    "holes": with_holes,
    "star_removed": with_star_removed,
    "handle": with_handle,
    "bowtie": bowties,
    "two_components": two_components,
    "flipped": with_flipped_faces,
    "duplicate_face": with_duplicate_face,
    "repeated_index": with_repeated_index_face,
    "zero_area": with_zero_area_faces,
    "unreferenced": with_unreferenced_vertex,
    "nonmanifold_edge": with_nonmanifold_edge,
}


# --------------------------------------------------------------------------
# Fixed non-orientable surfaces
# --------------------------------------------------------------------------

def moebius_strip() -> Tuple[np.ndarray, np.ndarray]:
    """The 5-vertex Moebius band: triangles {i, i+1, i+2} mod 5, on a twisted ring."""
    t = np.arange(5) * 2 * np.pi / 5
    V = np.column_stack([np.cos(t), np.sin(t), 0.3 * np.sin(2.5 * t) + 0.1 * np.arange(5)])
    F = np.array([[i, (i + 1) % 5, (i + 2) % 5] for i in range(5)], dtype=np.int64)
    return V, F


def projective_plane() -> Tuple[np.ndarray, np.ndarray]:
    """The 6-vertex real projective plane: the icosahedron with antipodes identified
    (closed, edge-manifold, Euler characteristic 1, not orientable)."""
    phi = (1 + 5 ** 0.5) / 2
    corners = []
    for s1 in (1, -1):
        for s2 in (phi, -phi):
            corners += [(0, s1, s2), (s1, s2, 0), (s2, 0, s1)]
    P = np.array(corners, dtype=float)
    faces = ConvexHull(P).simplices
    label = {}
    for i in range(12):
        j = int(np.argmin(np.linalg.norm(P + P[i], axis=1)))
        label[i] = min(i, j)
    ids = sorted(set(label.values()))
    index = {v: k for k, v in enumerate(ids)}
    F = {tuple(sorted(index[label[v]] for v in f)) for f in faces.tolist()}
    V = P[ids] * np.array([1.0, 1.1, 1.2]) + 0.05 * np.arange(6)[:, None]
    return V, np.array(sorted(F), dtype=np.int64)
