"""The contract every spherical method keeps (STYLE 12: one suite, every method).

Each test runs for every name in ``sp.methods()``, on small shapes from
``spherify.datasets`` and on random genus-0 meshes drawn by hypothesis:

* ``points`` holds one unit vector per input vertex, in the input's order;
* ``valid`` and ``flipped`` agree with an exact check written apart from
  spherify (``_exact.py``: exact orientation signs and the spherical area sum);
* ``status`` and ``message`` say how the method ended;
* a bad option raises ``MeshError``, a surface that is not genus 0
  ``TopologyError``;
* on round shapes every method gives a valid map.

A method may refuse a mesh it was not made for (``radial``: not star-shaped,
with ``MeshError``), and an iterative method may stop with an invalid map on a
hard mesh: the contract is that what the map says of itself is true, not that
every method succeeds everywhere.
"""

from __future__ import annotations

import functools
import warnings
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

import numpy as np
import pytest
from hypothesis import given

import _meshgen as mg
import spherify as sp
from _exact import exact_signs, exact_verdict, fraction_sign

try:
    from scipy.optimize import linprog
except ImportError:  # pragma: no cover - scipy is a test dependency
    linprog = None

METHODS = sp.methods()
STATUSES = {"converged", "direct", "max_iterations", "collapsed"}

# ------------------------------------------------ what the suite knows per method
# (from the signatures in crates/python/src/*.rs; a new method must be added here)

# Options that keep the hard shapes quick: iterative methods give up sooner.
QUICK: Dict[str, Dict[str, Any]] = {
    "alexa": {"max_iter": 300},
    "gotsman": {"max_iter": 15},
    "radial": {},
    "relaxation": {"max_iter": 300},
    "theta_phi": {},
    "progressive": {"max_iter": 10},
}
# Values out of each method's range.
OUT_OF_RANGE: Dict[str, List[Dict[str, Any]]] = {
    "alexa": [{"max_iter": -1}, {"check_every": 0}, {"c": -1.0}],
    "gotsman": [{"max_iter": -1}, {"tol": -1.0}, {"weights": "cotangent"}],
    "radial": [{"center": "nowhere"}, {"center": (0.0, 0.0)}],
    "relaxation": [{"max_iter": -1}, {"check_every": 0}, {"weights": "nope"}],
    "theta_phi": [{"poles": "nowhere"}, {"poles": (0, 0)}, {"weights": "nope"},
                  {"max_refinements": -1}],
    "progressive": [{"max_iter": -1}, {"tol": -1.0}, {"energy": "harmonic"}, {"energy": 3}],
}
# Methods whose result depends on the order of the vertices (ties in the
# progressive method's collapse order and sweep order are broken by vertex id):
# deterministic for one input, but a relabelled mesh gets another valid map.
ORDER_DEPENDENT = {"progressive"}
# Meshes a method may refuse, by the MeshError's message.
REFUSES = {"radial": "not star-shaped"}


def same_choices(method: str, m: sp.SphereMap, new_id: np.ndarray) -> Dict[str, Any]:
    """Options that make ``method`` choose on a relabelled mesh what it chose for
    ``m``: theta-phi's fast-graph poles start from a vertex id, so it is given
    the same poles."""
    if method == "theta_phi":
        return {"poles": (int(new_id[m.poles[0]]), int(new_id[m.poles[1]]))}
    return {}


def test_every_method_is_described() -> None:
    assert set(QUICK) == set(OUT_OF_RANGE) == set(METHODS)


# ----------------------------------------------------------------------- meshes

SHAPES: Dict[str, Callable[[], sp.Mesh]] = {
    "icosphere1": lambda: sp.datasets.icosphere(subdivisions=1),
    "icosphere2": lambda: sp.datasets.icosphere(subdivisions=2),
    "ellipsoid": lambda: sp.datasets.ellipsoid(250, axes=(1.0, 0.5, 0.3)),
    "bumpy_blob": lambda: sp.datasets.bumpy_blob(300, amplitude=0.4),
    "helix_tube": lambda: sp.datasets.helix_tube(150),    # star-shaped from no point
    "tentacles": lambda: sp.datasets.tentacles(1),        # the smallest: 1,744 vertices
    "urchin": lambda: sp.datasets.urchin(1),              # the smallest: 2,786 vertices
}
ROUND = ["icosphere1", "icosphere2", "ellipsoid"]


@functools.lru_cache(maxsize=None)
def shape(name: str) -> sp.Mesh:
    return SHAPES[name]()


def torus(n_around: int = 9, n_tube: int = 5) -> sp.Mesh:
    """A triangulated torus (genus 1), faces outward."""
    i, j = np.meshgrid(np.arange(n_around), np.arange(n_tube), indexing="ij")
    u, v = 2 * np.pi * i / n_around, 2 * np.pi * j / n_tube
    V = np.stack([(1.0 + 0.4 * np.cos(v)) * np.cos(u), (1.0 + 0.4 * np.cos(v)) * np.sin(u),
                  0.4 * np.sin(v)], -1).reshape(-1, 3)
    a = (i * n_tube + j).ravel()
    b = (((i + 1) % n_around) * n_tube + j).ravel()
    c = (((i + 1) % n_around) * n_tube + (j + 1) % n_tube).ravel()
    d = (i * n_tube + (j + 1) % n_tube).ravel()
    return sp.Mesh(V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]))


def not_genus_zero(name: str) -> sp.Mesh:
    ico = sp.datasets.icosphere(subdivisions=1)
    if name == "torus":
        return torus()
    if name == "open":                     # one face missing: a disk
        return sp.Mesh(ico.vertices, ico.faces[1:])
    if name == "two_spheres":
        n = ico.n_vertices
        return sp.Mesh(np.concatenate([ico.vertices, ico.vertices + 3.0]),
                       np.concatenate([ico.faces, ico.faces + n]))
    raise ValueError(name)


# -------------------------------------------------------------------- contract

def kernel_depth(mesh: sp.Mesh) -> float:
    """Largest distance from a point to the planes of all faces while on their
    inner side (positive: star-shaped from that point), by a linear program."""
    V, F = mesh.vertices, mesh.faces
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    # maximise t subject to n_f . x + t <= n_f . a_f, with t <= 1 to stay bounded
    A = np.column_stack([n, np.ones(len(F))])
    b = np.einsum("ij,ij->i", n, V[F[:, 0]])
    result = linprog(c=[0, 0, 0, -1], A_ub=A, b_ub=b,
                     bounds=[(None, None)] * 3 + [(None, 1.0)], method="highs")
    assert result.status == 0, result.message
    return float(-result.fun)


def embed_or_refuse(mesh: sp.Mesh, method: str, **options: Any) -> Optional[sp.SphereMap]:
    """``sp.embed``, or None where the method refuses the mesh as documented
    (and the refusal is true)."""
    try:
        return sp.embed(mesh, method, **options)
    except sp.MeshError as err:
        if isinstance(err, sp.TopologyError) or REFUSES.get(method, "\0") not in str(err):
            raise
        if linprog is not None:
            size = float(np.ptp(mesh.vertices, axis=0).max())
            assert kernel_depth(mesh) <= 1e-9 * size, f"{method} refused a star-shaped mesh: {err}"
        return None


def collapsed_to_rounding(points: np.ndarray, faces: np.ndarray) -> bool:
    """Whether some face has two corners equal or opposite to within 1e-9.

    Gotsman's iteration can end at the trivial solution with the points of a
    tiny mesh at two antipodal spots, equal to the last bits. Their exact
    orientation signs are still decided, but no floating-point area sum, the
    core's or this file's, says anything there (the two disagree at random), so
    the covering degree is not compared for such maps. (Reliability issue:
    every map is to carry its margin and warn below it.)
    """
    p = points[faces]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        d = np.einsum("ij,ij->i", p[:, i], p[:, j])
        if np.any(np.abs(np.abs(d) - 1.0) < 1e-9):
            return True
    return False


def assert_contract(m: sp.SphereMap, mesh: sp.Mesh, method: str) -> None:
    n = mesh.n_vertices
    assert isinstance(m, sp.SphereMap) and m.method == method
    # One unit vector per input vertex, in the input's order: the map's mesh is
    # the input's vertices unchanged, and its faces index the rows.
    assert m.points.shape == (n, 3) and m.points.dtype == np.float64
    assert np.isfinite(m.points).all()
    np.testing.assert_allclose(np.linalg.norm(m.points, axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.array_equal(m.mesh.vertices, mesh.vertices)
    assert m.mesh.n_faces == mesh.n_faces
    # What the map says of itself is true.
    verdict = exact_verdict(m.points, m.mesh.faces)
    assert m.flipped == verdict.flipped, (verdict, m.message)
    if not collapsed_to_rounding(m.points, m.mesh.faces):
        assert m.valid == verdict.valid, (verdict, m.message)
    # And it says how it ended.
    assert m.status in STATUSES, m.status
    assert isinstance(m.message, str) and m.message.strip()
    assert m.converged == (m.status in {"converged", "direct"}), (m.status, m.converged)
    assert isinstance(m.iterations, int) and m.iterations >= 0


# ----------------------------------------------------------------------- tests

@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("method", METHODS)
def test_contract_on_datasets(method: str, name: str) -> None:
    mesh = shape(name)
    m = embed_or_refuse(mesh, method, **QUICK[method])
    if m is not None:
        assert_contract(m, mesh, method)


@pytest.mark.parametrize("name", ROUND)
@pytest.mark.parametrize("method", METHODS)
def test_round_shapes_give_valid_maps(method: str, name: str) -> None:
    mesh = shape(name)
    m = sp.embed(mesh, method)
    assert_contract(m, mesh, method)
    assert m.valid and m.flipped == 0, m.message


@pytest.mark.skipif(linprog is None, reason="scipy is needed to draw random meshes")
@pytest.mark.parametrize("method", METHODS)
@given(surface=mg.surfaces(max_vertices=150))
def test_contract_on_random_genus0_meshes(method: str, surface: mg.Surface) -> None:
    mesh = sp.Mesh(surface.V, surface.F)
    m = embed_or_refuse(mesh, method, **QUICK[method])
    if m is not None:
        assert_contract(m, mesh, method)


@pytest.mark.parametrize("method", METHODS)
def test_relabelled_vertices_relabel_the_rows(method: str) -> None:
    # A shape every method maps validly without ties between path lengths.
    mesh = sp.datasets.bumpy_blob(300)
    V, F = mesh.vertices, mesh.faces
    old_id = np.random.default_rng(1).permutation(mesh.n_vertices)  # new vertex k is old_id[k]
    new_id = np.argsort(old_id)
    relabelled = sp.Mesh(V[old_id], new_id[F])
    a = sp.embed(mesh, method)
    b = sp.embed(relabelled, method, **same_choices(method, a, new_id))
    assert_contract(b, relabelled, method)
    if method in ORDER_DEPENDENT:
        assert a.valid and b.valid
        return
    np.testing.assert_allclose(b.points, a.points[old_id], rtol=0, atol=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_unknown_option_raises_mesh_error(method: str) -> None:
    with pytest.raises(sp.MeshError, match="no_such_option"):
        sp.embed(shape("icosphere1"), method, no_such_option=1)


def test_the_default_method_is_progressive_isometric() -> None:
    mesh = shape("icosphere1")
    m = sp.embed(mesh)
    assert m.method == "progressive" and not isinstance(m, sp.ThetaPhiMap)
    named = sp.embed(mesh, "progressive", energy="isometric")
    np.testing.assert_array_equal(m.points, named.points)


# A value theta-phi accepts for each of its options.
THETA_PHI_VALUES = {"poles": "symmetry", "weights": "chord", "rho": 2.0, "symmetry_eps": 0.1,
                    "symmetry_max_score": 0.1, "max_refinements": 3}


def test_the_core_lists_theta_phi_s_options_once() -> None:
    # The refusal of an unknown option, sp.method_options and the hint all
    # read the core's one table.
    with pytest.raises(sp.MeshError) as err:
        sp.embed(shape("icosphere1"), "theta_phi", no_such_option=1)
    listed = str(err.value).split("its options are: ")[1].split(", ")
    assert sorted(listed) == sorted(sp.method_options("theta_phi")) == sorted(THETA_PHI_VALUES)


def _owners(names: List[str]) -> List[str]:
    return [m for m in sp.methods() if all(n in sp.method_options(m) for n in names)]


@pytest.mark.parametrize("names", [[name] for name in THETA_PHI_VALUES]
                         + [["weights", "symmetry_eps"]])
def test_another_method_s_options_without_the_method_say_which_methods_take_them(
        names: List[str]) -> None:
    # Issue 10, item 8: sp.embed(mesh, poles=...) used to mean theta-phi.
    # The hint names every method that takes the options (weights and rho
    # are relaxation's and Gotsman's too), from the core's table.
    options = {name: THETA_PHI_VALUES[name] for name in names}
    with pytest.raises(sp.MeshError) as err:
        sp.embed(shape("icosphere1"), **options)
    text = str(err.value)
    owners = _owners(names)
    assert "theta_phi" in owners and "progressive" not in owners
    assert all(repr(name) in text for name in names), text
    assert 'default method is "progressive"' in text
    assert "pass method=" in text and all(f'"{m}"' in text for m in owners), text
    assert (" is an option of " if len(names) == 1 else " are options of ") in text
    # Named, theta-phi takes them (the symmetry options with symmetry poles).
    if any(name.startswith("symmetry_") for name in names):
        options["poles"] = "symmetry"
    if "rho" in names:
        options["weights"] = "chord"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)  # symmetry may fall back
        assert sp.embed(shape("icosphere1"), "theta_phi", **options).method == "theta_phi"


# A value each kind of option takes, for the options of every method.
def _sample(method: str, row: Dict[str, Any]) -> Any:
    if row["kind"] == "count":
        return max(row["minimum"], 2)
    if row["kind"] == "number":
        return {"tol": 1e-6, "rho": 2.0, "c": 1.0}.get(row["name"], 0.1)
    if row["kind"] == "flag":
        return False
    if row["kind"] == "points":
        return shape("icosphere1").vertices
    return row["choices"][-1] if row["name"] != "poles" else "physical"


@pytest.mark.parametrize("method", METHODS + ["improve"])
def test_every_option_in_the_core_s_table_is_read_by_its_method(method: str) -> None:
    # The bindings read keywords through the table; an entry its reader
    # forgot would be refused as a bug, one it reads without the table
    # could never be given. Each option alone, with what it requires.
    mesh = shape("icosphere1")
    table = sp.method_options(method)
    assert table, method
    for name, row in table.items():
        if name == "center" and method == "radial":
            continue  # the kernel / centroid / a point: test_radial.py
        options = {name: _sample(method, row)}
        if row["requires"] is not None:
            other, value = row["requires"]
            options[other] = value
        if "initial" in options and "center" in options:
            del options["center"]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            if method == "improve":
                m = sp.improve(sp.embed(mesh), **options)
            else:
                m = sp.embed(mesh, method, **options)
        assert m.points.shape == (len(mesh.vertices), 3), (method, name)


def test_the_table_s_defaults_are_what_the_methods_run_with() -> None:
    mesh = shape("icosphere1")
    for method in ["relaxation", "alexa", "gotsman", "theta_phi"]:
        given = {name: row["default"] for name, row in sp.method_options(method).items()
                 if row["default"] is not None and row["requires"] is None}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            np.testing.assert_array_equal(sp.embed(mesh, method, **given).points,
                                          sp.embed(mesh, method).points)
    by_energy = sp.method_options("progressive")["max_iter"]["default_by"]
    for energy, max_iter in by_energy.items():
        tol = sp.method_options("progressive")["tol"]["default_by"][energy]
        np.testing.assert_array_equal(
            sp.embed(mesh, energy=energy, max_iter=max_iter, tol=tol).points,
            sp.embed(mesh, energy=energy).points)


def test_other_methods_keep_the_core_s_message() -> None:
    with pytest.raises(sp.MeshError) as err:
        sp.embed(shape("icosphere1"), "radial", poles="graph")
    assert "theta_phi" not in str(err.value) and 'no option "poles"' in str(err.value)


def _out_of_range_cases() -> Iterator[Any]:
    for method in METHODS:
        for options in OUT_OF_RANGE[method]:
            (key, value), = options.items()
            yield pytest.param(method, options, id=f"{method}-{key}={value!r}")


@pytest.mark.parametrize("method, options", list(_out_of_range_cases()))
def test_out_of_range_option_raises_mesh_error(method: str, options: Dict[str, Any]) -> None:
    with pytest.raises(sp.MeshError):
        sp.embed(shape("icosphere1"), method, **options)


@pytest.mark.parametrize("surface", ["torus", "open", "two_spheres"])
@pytest.mark.parametrize("method", METHODS)
def test_not_genus_zero_raises_topology_error(method: str, surface: str) -> None:
    mesh = not_genus_zero(surface)
    with pytest.raises(sp.TopologyError) as err:
        sp.embed(mesh, method)
    assert not err.value.report.is_sphere_topology


# --------------------------------------------------------- the checker itself

def test_exact_check_on_the_octahedron() -> None:
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    good = exact_verdict(V, F)
    assert good.valid and good.flipped == 0
    assert abs(good.area_sum - 4 * np.pi) < 1e-12
    inward = exact_verdict(V, F[:, ::-1])
    assert not inward.valid and inward.flipped == inward.n_negative == 8
    assert abs(inward.area_sum + 4 * np.pi) < 1e-12
    swapped = exact_verdict(V[[2, 1, 0, 3, 4, 5]], F)
    assert not swapped.valid and swapped.n_negative > 0
    collapsed = V.copy()
    collapsed[4] = collapsed[0]
    assert exact_verdict(collapsed, F).n_zero > 0
    nan = V.copy()
    nan[3, 1] = np.nan
    assert not exact_verdict(nan, F).valid


def test_exact_signs_decide_what_floats_cannot() -> None:
    # c = s a + t b is coplanar with a, b and the origin up to rounding: the
    # determinant is tiny and its float sign unreliable; the filter must hand
    # these faces to the rational fallback and agree with it everywhere.
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(2, 400, 3))
    c = rng.normal(size=(400, 1)) * a + rng.normal(size=(400, 1)) * b
    c[:200] += rng.normal(scale=1e-14, size=(200, 3))          # some just off the plane
    P = np.concatenate([a, b, c])
    F = np.arange(1200).reshape(3, 400).T
    signs, n_exact = exact_signs(P, F)
    truth = [fraction_sign(P[i], P[j], P[k]) for i, j, k in F]
    assert signs.tolist() == truth
    assert n_exact > 0
    naive = np.sign(np.linalg.det(P[F]))
    assert (naive != np.array(truth)).any(), "the sample should fool plain floating point"
    # Faces the float filter decides never reach the fallback.
    assert n_exact < len(F)


@pytest.mark.parametrize("weights", [None, "uniform", "mean_value"])
def test_rho_without_chord_weights_is_refused(weights: Optional[str]) -> None:
    # rho sets the chord weights' exponent; with other weights it would be
    # ignored without a word.
    extra = {} if weights is None else {"weights": weights}
    with pytest.raises(sp.MeshError, match='rho only applies to weights="chord"'):
        sp.embed(shape("icosphere1"), "theta_phi", rho=2.0, **extra)
