"""The non-rigid ICP's descriptor pairs (spherify._descriptors): the grid's
neighbours, the surface samples, the heights and the pairs, each against a
direct computation."""

from __future__ import annotations

import numpy as np
import pytest

import spherify as sp
from spherify import _descriptors, _nricp

import _descriptors_reference as reference


def unit_rms(mesh: sp.Mesh) -> np.ndarray:
    v = mesh.vertices - mesh.vertices.mean(axis=0)
    out: np.ndarray = v / np.sqrt((v * v).sum(axis=1).mean())
    return out


def test_the_reference_grid_finds_every_point_within_a_cell() -> None:
    rng = np.random.default_rng(1)
    points = rng.normal(size=(2000, 3))
    queries = rng.normal(size=(300, 3)) * 1.3
    cell = 0.4
    q, p = reference.Grid(points, cell).pairs(queries)
    assert np.all(np.diff(q) >= 0)
    found = set(zip(q.tolist(), p.tolist()))
    assert len(found) == len(q)
    d = np.linalg.norm(queries[:, None, :] - points[None, :, :], axis=2)
    within = set(zip(*np.nonzero(d <= cell)))
    assert within <= found


def test_the_core_gives_the_references_samples_heights_and_pairs() -> None:
    # Two shapes as registration sees them (unit rms radius), one bent:
    # the core's samples equal numpy's to the bit, the heights to the last
    # bits of exp, and the pairs are the same.
    mesh = sp.datasets.bumpy_blob(3000, bumps=6, amplitude=0.4, seed=5)
    a = unit_rms(mesh)
    b = a + 0.05 * np.sin(3.0 * a[:, [1, 2, 0]])
    n = _nricp.vertex_normals(a, mesh.faces)
    sample = np.arange(0, len(a), 3)
    scales = _nricp.DESCRIPTOR_SCALES
    old_b, new_b = reference.Surface(b, mesh.faces), _descriptors.Surface(b, mesh.faces)
    for spacing in (_nricp.DESCRIPTOR_SPACING, 0.15):
        for x, y in zip(old_b.samples(spacing), new_b.samples(spacing)):
            assert np.array_equal(x, y)
    cand, _, b_normals = new_b.samples(_nricp.DESCRIPTOR_SPACING)
    old_h = reference.heights(old_b, cand, b_normals, scales)
    new_h = _descriptors.heights(new_b, cand, b_normals, scales)
    assert np.allclose(new_h, old_h, rtol=1e-12, atol=1e-15)
    old_a = reference.heights(reference.Surface(a, mesh.faces), a[sample], n[sample], scales)
    new_a = _descriptors.heights(_descriptors.Surface(a, mesh.faces), a[sample], n[sample], scales)
    assert np.allclose(new_a, old_a, rtol=1e-12, atol=1e-15)
    weight, reach = _nricp.DESCRIPTOR_WEIGHT, _nricp.DESCRIPTOR_REACH
    old_p = reference.DescriptorPairs(cand, new_h, weight, reach)
    new_p = _descriptors.DescriptorPairs(cand, new_h, weight, reach)
    for shift in (0.0, 0.01, 0.03):
        x = a[sample] + shift
        for u, v in zip(old_p(x, new_a), new_p(x, new_a)):
            assert np.array_equal(u, v)


def test_surface_samples_keep_the_area_and_the_normals_point_out() -> None:
    mesh = sp.datasets.bumpy_blob(600, bumps=5, amplitude=0.5, seed=2)
    v = unit_rms(mesh)
    cross = np.cross(v[mesh.faces[:, 1]] - v[mesh.faces[:, 0]],
                     v[mesh.faces[:, 2]] - v[mesh.faces[:, 0]])
    area = 0.5 * np.linalg.norm(cross, axis=1).sum()
    for spacing in (0.02, 0.1, 0.3):
        points, weights, normals = _descriptors.surface_samples(v, mesh.faces, spacing)
        assert abs(weights.sum() - area) < 1e-9 * area
        # Outward on a star-shaped blob centred at the origin.
        assert np.mean((points * normals).sum(axis=1) > 0) > 0.95
    turned = _descriptors.surface_samples(v, mesh.faces[:, ::-1], 0.1)[2]
    assert np.allclose(turned, _descriptors.surface_samples(v, mesh.faces, 0.1)[2])


def test_heights_do_not_depend_on_the_resolution() -> None:
    # The same surface as 80 and as 5120 triangles (an icosphere made finer
    # by splitting its faces in the plane, not by projecting the new
    # vertices): the heights agree, positive (the sphere bulges everywhere).
    coarse = sp.datasets.icosphere(1)
    v, f = coarse.vertices, coarse.faces
    for _ in range(3):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = len(v) + inverse.ravel().reshape(3, -1).T
        v = np.vstack([v, 0.5 * (v[unique[:, 0]] + v[unique[:, 1]])])
        f = np.concatenate([np.stack([f[:, 0], mid[:, 0], mid[:, 2]], 1),
                            np.stack([f[:, 1], mid[:, 1], mid[:, 0]], 1),
                            np.stack([f[:, 2], mid[:, 2], mid[:, 1]], 1), mid])
    queries = coarse.vertices * 0.95 + coarse.vertices.mean(axis=0) * 0.05
    normals = queries / np.linalg.norm(queries, axis=1)[:, None]
    scales = (0.1, 0.3)
    h_coarse = _descriptors.heights(_descriptors.Surface(coarse.vertices, coarse.faces), queries, normals, scales)
    h_fine = _descriptors.heights(_descriptors.Surface(v, f), queries, normals, scales)
    assert np.all(h_coarse > 0)
    assert np.allclose(h_coarse, h_fine, rtol=0.1)


def test_heights_tell_a_bump_from_a_hollow() -> None:
    # A sphere with a bump at +z and a dimple at -z: the bump stands above
    # its surroundings, the dimple below, the rest of the sphere between.
    ball = sp.datasets.icosphere(subdivisions=4)
    p = ball.vertices
    bump = np.exp(-((p - [0, 0, 1]) ** 2).sum(1) / 0.05)
    dimple = np.exp(-((p - [0, 0, -1]) ** 2).sum(1) / 0.05)
    v = p * (1.0 + 0.2 * bump - 0.2 * dimple)[:, None]
    n = _nricp.vertex_normals(v, ball.faces)
    h = _descriptors.heights(_descriptors.Surface(v, ball.faces), v, n, (0.2,))[:, 0]
    top, bottom, side = np.argmax(p[:, 2]), np.argmin(p[:, 2]), np.argmin(np.abs(p[:, 2]))
    assert h[top] > h[side] > 0 > h[bottom]


def test_descriptor_pairs_are_the_nearest_in_position_and_descriptor() -> None:
    rng = np.random.default_rng(4)
    points = rng.uniform(-1, 1, size=(3000, 3))
    features = rng.normal(size=(3000, 2))
    weight, reach = 0.05, 0.15
    pairs = _descriptors.DescriptorPairs(points, features, weight, reach)
    x = rng.uniform(-1, 1, size=(400, 3))
    fx = rng.normal(size=(400, 2))
    best, plain, certain = pairs(x, fx)
    unit = features.std(axis=0)
    both = (((x[:, None, :] - points[None]) ** 2).sum(2)
            + weight ** 2 * (((fx[:, None, :] - features[None]) / unit) ** 2).sum(2))
    near = ((x[:, None, :] - points[None]) ** 2).sum(2)
    assert certain.mean() > 0.9
    assert np.array_equal(best[certain], both.argmin(axis=1)[certain])
    assert np.array_equal(plain[certain], near.argmin(axis=1)[certain])
    assert np.all(both.min(axis=1)[~certain] > reach ** 2 - 1e-12) or not (~certain).any()


def test_the_core_refuses_bad_surfaces_points_and_parameters() -> None:
    """Bad input to the core's descriptor classes and closest points is a
    MeshError naming the row or the parameter, never a panic."""
    from spherify import _core
    from spherify._nearest import NearestOnSurface
    v = np.eye(3) * 2.0 - 1.0
    f = np.array([[0, 1, 2]])
    bad = v.copy()
    bad[1, 2] = np.nan
    with pytest.raises(sp.MeshError, match="vertex 1 is not finite"):
        _core.CoreSampledSurface(bad, f)
    with pytest.raises(sp.MeshError, match="vertex 1 is not finite"):
        NearestOnSurface(bad, f)
    with pytest.raises(sp.MeshError, match="face 0 names a vertex out of range"):
        _core.CoreSampledSurface(v, np.array([[0, 1, 3]]))
    surface = _core.CoreSampledSurface(v, f)
    with pytest.raises(sp.MeshError, match="spacing must be positive"):
        surface.samples(0.0)
    with pytest.raises(sp.MeshError, match="scale must be positive"):
        surface.heights(v, v, [float("nan")], 0.75)
    with pytest.raises(sp.MeshError, match="one normal per query"):
        surface.heights(v, v[:2], [0.1], 0.75)
    features = np.zeros((3, 2))
    with pytest.raises(sp.MeshError, match="point 1 is not finite"):
        _core.CoreFeatureNearest(bad, features, 1.0)
    with pytest.raises(sp.MeshError, match="one row of features per point"):
        _core.CoreFeatureNearest(v, features[:2], 1.0)
    with pytest.raises(sp.MeshError, match="reach must be positive"):
        _core.CoreFeatureNearest(v, features, -1.0)
    near = _core.CoreFeatureNearest(v, features, 1.0)
    with pytest.raises(sp.MeshError, match=r"features must have shape \(3, 2\)"):
        near.nearest(v, np.zeros((3, 1)))
