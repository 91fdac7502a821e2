"""sp.dijkstra and sp.shortest_path (thesis App. A) against independent references."""

from __future__ import annotations

import heapq
from collections import deque
from typing import Dict, List, Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp

import _meshgen as mg

try:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra as scipy_dijkstra
except ImportError:  # pragma: no cover
    scipy_dijkstra = None

needs_scipy = pytest.mark.skipif(scipy_dijkstra is None or mg.ConvexHull is None,
                                 reason="scipy is not installed")

Graph = Dict[int, List[Tuple[int, float]]]


def edges(F: np.ndarray) -> np.ndarray:
    """Unique undirected edges (u < v), sorted."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)


def edge_lengths(V: np.ndarray, E: np.ndarray) -> np.ndarray:
    d = V[E[:, 0]] - V[E[:, 1]]
    return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])


def reference_dijkstra(n: int, E: np.ndarray, w: np.ndarray, source: int) -> np.ndarray:
    """Textbook heap Dijkstra, independent of spherify."""
    graph: Graph = {v: [] for v in range(n)}
    for (a, b), x in zip(E.tolist(), w.tolist()):
        graph[a].append((b, x))
        graph[b].append((a, x))
    dist = np.full(n, np.inf)
    dist[source] = 0.0
    heap = [(0.0, source)]
    while heap:
        d, u = heapq.heappop(heap)
        if d > dist[u]:
            continue
        for z, x in graph[u]:
            if d + x < dist[z]:
                dist[z] = d + x
                heapq.heappush(heap, (d + x, z))
    return dist


def hops(n: int, E: np.ndarray, source: int) -> np.ndarray:
    graph: Dict[int, List[int]] = {v: [] for v in range(n)}
    for a, b in E.tolist():
        graph[a].append(b)
        graph[b].append(a)
    dist = np.full(n, np.inf)
    dist[source] = 0
    queue = deque([source])
    while queue:
        u = queue.popleft()
        for z in graph[u]:
            if dist[z] == np.inf:
                dist[z] = dist[u] + 1
                queue.append(z)
    return dist


def assert_shortest_path_tree(n: int, E: np.ndarray, w: np.ndarray, source: int,
                              dist: np.ndarray, pred: np.ndarray) -> None:
    """The optimality certificate of a shortest-path tree: every edge is relaxed
    (d[v] <= d[u] + w) and every tree edge is tight (d[v] == d[p] + w)."""
    assert dist.shape == (n,) and dist.dtype == np.float64
    assert pred.shape == (n,) and pred.dtype == np.int64
    assert dist[source] == 0.0 and pred[source] == -1
    slack = 1e-12 * max(1.0, float(np.max(dist[np.isfinite(dist)])))
    a, b = E[:, 0], E[:, 1]
    assert np.all(dist[b] <= dist[a] + w + slack)
    assert np.all(dist[a] <= dist[b] + w + slack)
    weight = {(int(u), int(v)): x for (u, v), x in zip(E.tolist(), w.tolist())}
    for v in range(n):
        if v == source:
            continue
        if not np.isfinite(dist[v]):
            assert pred[v] == -1
            continue
        p = int(pred[v])
        assert 0 <= p < n
        x = weight[(min(p, v), max(p, v))]  # the predecessor is a neighbour
        assert dist[v] == pytest.approx(dist[p] + x, rel=1e-14, abs=1e-300)
        assert dist[p] < dist[v] or x == 0.0


def follow(pred: np.ndarray, target: int) -> List[int]:
    path = [target]
    while pred[path[-1]] != -1:
        path.append(int(pred[path[-1]]))
    return path[::-1]


@needs_scipy
@given(mg.surfaces(), st.data())
def test_lengths_match_scipy_and_a_reference(s: mg.Surface, data: st.DataObject) -> None:
    n = len(s.V)
    source = data.draw(st.integers(0, n - 1), label="source")
    E = edges(s.F)
    w = edge_lengths(s.V, E)
    dist, pred = sp.dijkstra(sp.Mesh(s.V, s.F), source)
    graph = coo_matrix((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
    expected = scipy_dijkstra(graph, directed=False, indices=source)
    np.testing.assert_allclose(dist, expected, rtol=1e-12, atol=0)
    np.testing.assert_allclose(dist, reference_dijkstra(n, E, w, source), rtol=1e-12, atol=0)
    assert_shortest_path_tree(n, E, w, source, dist, pred)


@needs_scipy
@given(mg.surfaces(), st.data())
def test_uniform_weights_count_hops(s: mg.Surface, data: st.DataObject) -> None:
    n = len(s.V)
    source = data.draw(st.integers(0, n - 1), label="source")
    E = edges(s.F)
    dist, pred = sp.dijkstra(sp.Mesh(s.V, s.F), source, weights="uniform")
    assert np.array_equal(dist, hops(n, E, source))
    assert np.array_equal(dist, np.round(dist))
    assert_shortest_path_tree(n, E, np.ones(len(E)), source, dist, pred)


@needs_scipy
@given(mg.surfaces(), st.data(), st.sampled_from(["length", "uniform"]))
def test_shortest_path_is_a_walk_along_edges_of_the_right_length(
        s: mg.Surface, data: st.DataObject, weights: str) -> None:
    n = len(s.V)
    source = data.draw(st.integers(0, n - 1), label="source")
    target = data.draw(st.integers(0, n - 1), label="target")
    mesh = sp.Mesh(s.V, s.F)
    length, path = sp.shortest_path(mesh, source, target, weights=weights)
    dist, pred = sp.dijkstra(mesh, source, weights=weights)
    assert path.dtype == np.int64
    assert path[0] == source and path[-1] == target
    assert len(set(path.tolist())) == len(path)  # simple
    edge_set = {tuple(e) for e in edges(s.F).tolist()}
    steps = [(min(a, b), max(a, b)) for a, b in zip(path[:-1].tolist(), path[1:].tolist())]
    assert all(step in edge_set for step in steps)
    if weights == "uniform":
        assert length == len(path) - 1
    else:
        walked = edge_lengths(s.V, np.array(steps).reshape(-1, 2)).sum() if steps else 0.0
        assert length == pytest.approx(walked, rel=1e-12, abs=0)
    # Stopping early changes nothing: same length and the same path as the full search.
    assert length == dist[target]
    assert path.tolist() == follow(pred, target)


@needs_scipy
@given(mg.two_components(), st.data())
def test_other_component_is_unreachable(b: mg.Broken, data: st.DataObject) -> None:
    n, first = len(b.V), b.info["n_first"]
    source = data.draw(st.integers(0, n - 1), label="source")
    mine = np.arange(n) < first if source < first else np.arange(n) >= first
    mesh = sp.Mesh(b.V, b.F)
    for weights in ("length", "uniform"):
        dist, pred = sp.dijkstra(mesh, source, weights=weights)
        assert np.all(np.isinf(dist[~mine])) and np.all(pred[~mine] == -1)
        assert np.all(np.isfinite(dist[mine]))
        assert np.flatnonzero(pred == -1).tolist() == sorted([source] + np.flatnonzero(~mine).tolist())
    other = int(np.flatnonzero(~mine)[0])
    with pytest.raises(sp.MeshError):
        sp.shortest_path(mesh, source, other)


def test_unused_vertex_is_unreachable() -> None:
    V = np.vstack([mg.TETRA_V, [[5.0, 5.0, 5.0]]])
    dist, pred = sp.dijkstra(sp.Mesh(V, mg.TETRA_F), 0)
    assert np.isinf(dist[4]) and pred[4] == -1
    dist, pred = sp.dijkstra(sp.Mesh(V, mg.TETRA_F), 4)
    assert dist[4] == 0 and np.all(np.isinf(dist[:4])) and np.all(pred == -1)
    assert sp.shortest_path(sp.Mesh(V, mg.TETRA_F), 4, 4)[1].tolist() == [4]


def test_source_equals_target() -> None:
    length, path = sp.shortest_path(sp.Mesh(mg.TETRA_V, mg.TETRA_F), 2, 2)
    assert length == 0.0 and path.tolist() == [2]


def test_tetrahedron_by_hand() -> None:
    dist, pred = sp.dijkstra(sp.Mesh(mg.TETRA_V, mg.TETRA_F), 0)
    assert dist.tolist() == [0.0, 1.0, 1.0, 1.0] and pred.tolist() == [-1, 0, 0, 0]
    dist, _ = sp.dijkstra(sp.Mesh(mg.TETRA_V, mg.TETRA_F), 1)
    assert dist.tolist() == [1.0, 0.0, np.sqrt(2.0), np.sqrt(2.0)]


def test_deterministic() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    first = sp.dijkstra(mesh, 0)
    second = sp.dijkstra(mesh, 0)
    assert first[0].tobytes() == second[0].tobytes() and np.array_equal(first[1], second[1])


def test_icosphere_hops_match_the_reference() -> None:
    mesh = sp.datasets.icosphere(subdivisions=2)
    n, E = mesh.n_vertices, edges(mesh.faces)
    w = edge_lengths(mesh.vertices, E)
    for source in (0, n // 2, n - 1):
        dist, pred = sp.dijkstra(mesh, source)
        np.testing.assert_allclose(dist, reference_dijkstra(n, E, w, source), rtol=1e-12, atol=0)
        assert_shortest_path_tree(n, E, w, source, dist, pred)
        hop, _ = sp.dijkstra(mesh, source, weights="uniform")
        assert np.array_equal(hop, hops(n, E, source))
