"""The warp's pull (issue 23): energy sweeps with a data term that reach
folded targets where the flip-free moves straight at them stop short
(``spherify._warp.pull``, ``crates/sphere/src/methods/progressive/target_pull.rs``)."""

from __future__ import annotations

import warnings
from typing import Tuple

import numpy as np
import pytest

import spherify as sp
from spherify import _landmarks, _nricp, _warp


@pytest.fixture(scope="module")
def stopped_short() -> Tuple[sp.SphereMap, sp.SphereMap, np.ndarray, sp.datasets.DeformedCopy]:
    # Thin tentacles: the ICP's targets fold there, and the moves stop short.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        m_a = sp.embed(sp.datasets.tentacles(3000))
        copy = sp.datasets.deformed_copy(m_a, level=3, seed=2)
        m_b = sp.embed(copy.mesh)
        map_a = sp.register(m_a, m_b, transform="moebius").map_a
    targets, _ = _warp.sphere_targets(map_a, m_b)
    return map_a, m_b, targets, copy


def truth_error(m_b: sp.SphereMap, points: np.ndarray, copy: sp.datasets.DeformedCopy
                ) -> np.ndarray:
    diagonal = float(np.linalg.norm(np.ptp(copy.mesh.vertices, axis=0)))
    out: np.ndarray = np.linalg.norm(m_b.to_surface(points)[2] - copy.truth, axis=1) / diagonal
    return out


def test_the_warp_pull_lowers_the_error_where_the_moves_stop_short(stopped_short: Tuple) -> None:
    map_a, m_b, targets, copy = stopped_short
    fixed = np.array([5, 400, 2000])
    rounds, _, stopped = _warp.move_rounds(map_a, targets, fixed=fixed)
    assert not stopped
    pulled, fraction, after = _warp.pull(rounds, targets, fixed=fixed)
    assert pulled.valid and rounds.valid
    assert 0.0 < fraction <= 1.0 and len(after) == len(_warp.PULL_STAGES)
    np.testing.assert_array_equal(pulled.points[fixed], map_a.points[fixed])
    # Measured: mean 6.3% -> 4.5% of B's diagonal, targets 2.1%.
    before, now = truth_error(m_b, rounds.points, copy), truth_error(m_b, pulled.points, copy)
    assert now.mean() < 0.85 * before.mean(), (now.mean(), before.mean())
    assert np.mean(_warp._angles(pulled.points, targets)) < after[0] * 1.0001


def test_the_warp_pull_gives_the_same_bits_on_one_and_two_threads(stopped_short: Tuple) -> None:
    map_a, _, targets, _ = stopped_short
    weights = np.full(len(targets), 1e3 * 4 * np.pi / len(targets))
    threads = sp.get_num_threads()
    try:
        runs = []
        for n in (1, 2):
            sp.set_num_threads(n)
            runs.append(_landmarks.pull_towards(map_a, targets, weights, sweeps=5).points)
    finally:
        sp.set_num_threads(threads)
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], map_a.points)


def test_the_warp_pull_refuses_bad_input(stopped_short: Tuple) -> None:
    map_a, _, targets, _ = stopped_short
    n = len(targets)
    ones = np.ones(n)
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets[1:], ones)
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets, np.full(n, np.nan))
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets, ones, fixed=[n])
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets, ones, energy="harmonic")
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets, ones, sweeps=-1)
    with pytest.raises(sp.MeshError):
        _landmarks.pull_towards(map_a, targets, ones, rest=np.zeros((3, 3)))


def test_the_scaffold_pins_its_vertices_and_carries_the_map_to_the_targets(
        stopped_short: Tuple, monkeypatch: pytest.MonkeyPatch) -> None:
    # Step 4b of spherify._warp: some of A's vertices pinned at their
    # targets by the landmark machinery, the rounds from there. On these
    # tentacles 128 cannot all be pinned (the layout would refine the mesh
    # past its budget: a MapError, and the plain rounds stand); 16 can.
    map_a, m_b, targets, copy = stopped_short
    same, _, place = _warp._sphere_targets(map_a, m_b)
    np.testing.assert_array_equal(same, targets)
    fixed = np.array([5, 400, 2000])
    monkeypatch.setattr(_warp, "SCAFFOLD", 16)
    runs = []
    threads = sp.get_num_threads()
    try:
        for n in (1, 2):
            sp.set_num_threads(n)
            pinned = _warp.scaffold(map_a, targets, place, fixed=fixed)
            assert pinned is not None
            runs.append(pinned)
    finally:
        sp.set_num_threads(threads)
    (m, t), (m2, t2) = runs
    np.testing.assert_array_equal(m.points, m2.points)
    np.testing.assert_array_equal(t, t2)
    assert m.valid and len(t) == m.mesh.n_vertices
    n = len(targets)
    np.testing.assert_array_equal(t[:n], targets)
    ids = sp.datasets.farthest_points(map_a.mesh.vertices, 16)
    ids = ids[~np.isin(ids, fixed)]
    assert _warp._angles(m.points[ids], targets[ids]).max() < 1e-14
    assert _warp._angles(m.points[fixed], map_a.points[fixed]).max() < 1e-14
    # The refined rows sit on A's surface and get their targets from the
    # same deformation: the rounds reach them as they reach A's own.
    plain, _, _ = _warp.move_rounds(map_a, targets, fixed=fixed)
    carried, _, _ = _warp.move_rounds(m, t, fixed=fixed)
    assert carried.valid
    # Measured: mean 6.0% -> 3.1% of B's diagonal.
    before = truth_error(m_b, plain.points, copy).mean()
    now = truth_error(m_b, carried.points[:n], copy).mean()
    assert now < 0.7 * before, (now, before)


def test_the_scaffold_gives_way_where_no_map_places_it(stopped_short: Tuple,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    # 128 vertices of these tentacles at the targets of the closest points
    # alone cannot be pinned on a mesh of bounded size: None, not an error
    # (the warp then keeps its plain rounds). (At the targets of the
    # descriptor pairs, spherify._descriptors, the layout places them, on a
    # refined mesh of 80,593 vertices: measured.)
    monkeypatch.setattr(_nricp, "DESCRIPTOR_WEIGHT", 0.0)
    map_a, m_b, _, _ = stopped_short
    targets, _, place = _warp._sphere_targets(map_a, m_b)
    assert _warp.scaffold(map_a, targets, place) is None


def test_the_scaffold_gives_way_where_its_layout_grows_the_mesh_past_its_bound(
        stopped_short: Tuple, monkeypatch: pytest.MonkeyPatch) -> None:
    # 48 pinned vertices: the layout refines these tentacles several times
    # over. Within the bound the scaffold stands on the refined mesh; with
    # the bound below that growth, None (the plain rounds stand), however
    # valid the layout.
    map_a, m_b, targets, _ = stopped_short
    _, _, place = _warp._sphere_targets(map_a, m_b)
    monkeypatch.setattr(_warp, "SCAFFOLD", 48)
    monkeypatch.setattr(_warp, "SCAFFOLD_GROWTH", 1e3)
    grown = _warp.scaffold(map_a, targets, place)
    assert grown is not None and grown[0].valid
    n, rows = len(targets), grown[0].mesh.n_vertices
    assert rows > 1.5 * n
    monkeypatch.setattr(_warp, "SCAFFOLD_GROWTH", (rows + 0.5) / n)
    again = _warp.scaffold(map_a, targets, place)
    assert again is not None
    np.testing.assert_array_equal(again[0].points, grown[0].points)
    monkeypatch.setattr(_warp, "SCAFFOLD_GROWTH", (rows - 0.5) / n)
    assert _warp.scaffold(map_a, targets, place) is None
    # The bound is improve's own option: the layout stops there, a MapError.
    ids = sp.datasets.farthest_points(map_a.mesh.vertices, 48)
    with pytest.raises(sp.MapError, match="max_vertices"):
        sp.improve(map_a, landmarks=(ids, targets[ids]), max_vertices=rows - 1)
    with pytest.raises(sp.MeshError, match="max_vertices"):
        sp.improve(map_a, max_vertices=3)


def forced_scaffold(monkeypatch: pytest.MonkeyPatch) -> Tuple[sp.SphereMap, sp.SphereMap]:
    """The scaffold forced (the gate off, 48 pinned vertices, no bound on
    the growth) on a pair of tentacles whose layout refines A: the maps of
    A and B."""
    monkeypatch.setattr(_warp, "SCAFFOLD", 48)
    monkeypatch.setattr(_warp, "SCAFFOLD_LAG", 0.0)
    monkeypatch.setattr(_warp, "SCAFFOLD_GROWTH", 1e3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        m_a = sp.embed(sp.datasets.tentacles(3000))
        copy = sp.datasets.deformed_copy(m_a, level=3, seed=2)
        return m_a, sp.embed(copy.mesh)


def test_a_registration_through_a_refined_scaffold_transfers_inverts_and_morphs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The layout refines these tentacles (3041 -> 22,089 vertices,
    # measured), so the map of A has more rows than A, its first rows A's
    # own, as for a landmark map.
    m_a, m_b = forced_scaffold(monkeypatch)
    morph = sp.morph(m_a, m_b, align="warp")
    c = morph.correspondence
    assert c is not None
    n = m_a.mesh.n_vertices
    assert c.details["warp_scaffold"] and c.map_a.valid
    assert c.map_a.mesh.n_vertices > n and c.map_a.refinement is not None
    np.testing.assert_array_equal(c.map_a.mesh.vertices[:n], m_a.mesh.vertices)
    assert c.transfer(np.ones(m_b.mesh.n_vertices)).shape == (c.map_a.mesh.n_vertices,)
    assert c.inverse().map_a.valid
    np.testing.assert_array_equal(morph.faces, m_a.mesh.faces)
    assert morph.at(1.0).vertices.shape == (n, 3)


def test_a_refined_scaffold_that_the_memory_policy_refuses_leaves_the_plain_rounds(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # The scaffold's refined mesh is asked of the memory policy again before
    # the rounds work on it; refused (here by a policy that fits A and B as
    # given and nothing larger), the registration goes on without it.
    m_a, m_b = forced_scaffold(monkeypatch)
    given = m_a.mesh.n_vertices + m_b.mesh.n_vertices
    asked = []
    check = _warp._core.check_application

    def policy(name: str, n_vertices: int, n_faces: int, items: int) -> None:
        asked.append((name, n_vertices))
        if name == "register" and n_vertices > given:
            raise sp.ResourceError(f"{name}: {n_vertices} vertices do not fit")
        check(name, n_vertices, n_faces, items)

    monkeypatch.setattr(_warp._core, "check_application", policy)
    c = sp.register(m_a, m_b)
    assert ("register", given) in asked and any(n > given for _, n in asked)
    assert not c.details["warp_scaffold"] and c.map_a.valid
    assert c.map_a.mesh.n_vertices == m_a.mesh.n_vertices
