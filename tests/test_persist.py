"""Maps that persist and travel: pickle, copy.deepcopy and save / load_map of
every public type and every method; certificates are computed again on the
way back, never read from the file."""

from __future__ import annotations

import copy
import json
import pickle
from pathlib import Path
from typing import Any, Callable, Dict

import numpy as np
import pytest

import spherify as sp


def blob() -> sp.Mesh:
    return sp.datasets.make("bumpy_blob", 400)


_MAPS: Dict[str, sp.SphereMap] = {}


def made(method: str) -> sp.SphereMap:
    if method == "points" and method not in _MAPS:
        _MAPS[method] = sp.SphereMap.from_points(blob(), made("radial").points * 100.0)
    if method not in _MAPS:
        options: Dict[str, Any] = {"max_iter": 300} if method in ("relaxation", "alexa") else {}
        _MAPS[method] = sp.embed(blob(), method, **options)
    return _MAPS[method]


def same_details(a: Dict[str, Any], b: Dict[str, Any]) -> bool:
    if set(a) != set(b):
        return False
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, dict):
            if not same_details(x, y):
                return False
        elif isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True):
                return False
        elif isinstance(x, float) and np.isnan(x):
            if not (isinstance(y, float) and np.isnan(y)):
                return False
        elif x != y:
            return False
    return True


def assert_same_map(a: sp.SphereMap, b: sp.SphereMap) -> None:
    assert type(a) is type(b)
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.faces, b.mesh.faces)
    assert a.report == b.report
    assert (a.valid, a.flipped, a.method, a.iterations, a.status, a.message, a.converged) == \
        (b.valid, b.flipped, b.method, b.iterations, b.status, b.message, b.converged)
    assert a.seconds == b.seconds and a.notes == b.notes and a.options == b.options
    assert same_details(a.details, b.details)
    if isinstance(a, sp.ThetaPhiMap) and isinstance(b, sp.ThetaPhiMap):
        assert a.tp_valid == b.tp_valid and a.poles == b.poles
        assert np.array_equal(a.cut_path, b.cut_path)
        assert np.array_equal(a.theta_phi, b.theta_phi)
        assert np.array_equal(a.cut_mesh.faces, b.cut_mesh.faces)
        assert np.array_equal(a.cut_original, b.cut_original)


def assert_same_inverse(a: sp.SphereMap, b: sp.SphereMap) -> None:
    rng = np.random.default_rng(1)
    q = rng.normal(size=(200, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    bijective = a.tp_valid if isinstance(a, sp.ThetaPhiMap) else a.valid
    if not bijective:
        for m in (a, b):
            with pytest.raises(sp.MapError):
                m.to_surface(q)
        return
    fa, wa, xa = a.to_surface(q)
    fb, wb, xb = b.to_surface(q)
    assert np.array_equal(fa, fb) and np.array_equal(wa, wb) and np.array_equal(xa, xb)


def through_file(m: sp.SphereMap, folder: Path) -> sp.SphereMap:
    path = folder / "m.spheremap.npz"
    m.save(path)
    assert sorted(p.name for p in folder.iterdir()) == ["m.spheremap.npz"]
    return sp.load_map(path)


COPIES: Dict[str, Callable[[sp.SphereMap, Path], sp.SphereMap]] = {
    "pickle": lambda m, _: pickle.loads(pickle.dumps(m)),
    "deepcopy": lambda m, _: copy.deepcopy(m),
    "file": through_file,
}


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("method", sp.methods() + ["points"])
def test_every_method_round_trips(method: str, how: str, tmp_path: Path) -> None:
    m = made(method)
    back = COPIES[how](m, tmp_path)
    assert_same_map(m, back)
    assert_same_inverse(m, back)


def test_symmetry_details_and_explicit_poles_travel(tmp_path: Path) -> None:
    mesh = sp.datasets.make("ellipsoid", 600)
    m = sp.embed(mesh, "theta_phi", poles="symmetry", weights="mean_value")
    back = through_file(m, tmp_path)
    assert_same_map(m, back)
    assert back.options == {"poles": "symmetry", "weights": "mean_value"}
    explicit = sp.embed(mesh, "theta_phi", poles=(0, 5))
    again = pickle.loads(pickle.dumps(explicit))
    assert again.options == {"poles": (0, 5)} and again.poles == explicit.poles


def test_reports_and_meshes_pickle_equal() -> None:
    mesh = blob()
    mesh.notes.append("a note")
    mesh.attributes["uv"] = np.zeros((mesh.n_vertices, 2))
    for copied in (pickle.loads(pickle.dumps(mesh)), copy.deepcopy(mesh)):
        assert np.array_equal(copied.vertices, mesh.vertices)
        assert np.array_equal(copied.faces, mesh.faces)
        assert copied.notes == mesh.notes
        assert np.array_equal(copied.attributes["uv"], mesh.attributes["uv"])
    report = sp.check(mesh)
    sphere_report = made("theta_phi").report
    for r in (report, sphere_report):
        assert pickle.loads(pickle.dumps(r)) == r and copy.deepcopy(r) == r


def test_a_pickled_mesh_is_validated_again() -> None:
    mesh = blob()
    data = pickle.dumps(mesh)
    # Out-of-range indices smuggled into the pickle do not get past the core.
    reducer, (vertices, faces, notes, attributes) = mesh.__reduce__()
    with pytest.raises(sp.MeshError):
        reducer(vertices, faces + mesh.n_vertices, notes, attributes)
    assert pickle.loads(data).n_vertices == mesh.n_vertices


def rewrite(path: Path, change: Callable[[Dict[str, Any]], None]) -> None:
    with np.load(path, allow_pickle=False) as f:
        arrays = {k: np.array(f[k]) for k in f.files}
    change(arrays)
    np.savez(path, **arrays)


def test_a_hand_edited_gc_map_gets_the_certificate_of_its_points(tmp_path: Path) -> None:
    m = made("radial")
    assert m.valid
    path = tmp_path / "r.spheremap.npz"
    m.save(path)

    def swap(a: Dict[str, Any]) -> None:
        a["points"][[0, 1]] = a["points"][[1, 0]]
        a["valid"] = np.array(True)  # a stored flag is never read
    rewrite(path, swap)
    back = sp.load_map(path)
    assert not back.valid and back.flipped > 0
    with pytest.raises(sp.MapError):
        back.to_surface(np.array([[0.0, 0.0, 1.0]]))


def test_a_hand_edited_rectangle_is_not_certified(tmp_path: Path) -> None:
    m = made("theta_phi")
    assert isinstance(m, sp.ThetaPhiMap) and m.tp_valid
    path = tmp_path / "t.spheremap.npz"
    m.save(path)
    boundary = set(m.details["cut_boundary"].tolist())
    a, b = [v for v in range(m.mesh.n_vertices) if v not in boundary][:2]

    def swap(arrays: Dict[str, Any]) -> None:
        for key in ("theta_phi", "points"):
            arrays[key][[a, b]] = arrays[key][[b, a]]
        meta = json.loads(str(arrays["meta"]))
        meta["details"]["tp_flipped_faces"] = []  # a stored verdict is never read
        arrays["meta"] = np.array(json.dumps(meta))
    rewrite(path, swap)
    back = sp.load_map(path)
    assert isinstance(back, sp.ThetaPhiMap)
    assert not back.tp_valid and len(back.details["tp_flipped_faces"]) > 0
    with pytest.raises(sp.MapError):
        back.to_surface(np.array([[1.0, 0.0, 0.0]]))


@pytest.mark.parametrize("edit, match", [
    (lambda a: a["points"].__setitem__((3, 0), a["points"][3, 0] + 1e-6), "fold"),
    (lambda a: a["theta_phi"].__setitem__((int(a["poles"][0]), 1), 1.0), "eq. 6.31"),
    (lambda a: a.__setitem__("cut_path", a["cut_path"][::-1].copy()), "north pole"),
    (lambda a: a.__setitem__("points", a["points"][:-1]), "points stored"),
    (lambda a: a.__setitem__("faces", a["faces"][:-1]), "genus|closed|boundary"),
    (lambda a: a.__setitem__("spherify_map_format", np.array(99)), "format 99"),
    (lambda a: a.pop("meta"), "missing meta"),
    (lambda a: a.__setitem__("meta", np.array("{not json")), "malformed"),
])
def test_inconsistent_files_are_format_errors(tmp_path: Path, edit: Callable[[Dict[str, Any]], None],
                                             match: str) -> None:
    path = tmp_path / "t.spheremap.npz"
    made("theta_phi").save(path)
    rewrite(path, edit)
    with pytest.raises(sp.FormatError, match=match) as info:
        sp.load_map(path)
    assert info.value.path == str(path)


def test_files_that_are_not_maps(tmp_path: Path) -> None:
    (tmp_path / "text.spheremap.npz").write_text("hello")
    sp.save(blob(), tmp_path / "mesh.npz")
    for name in ("text.spheremap.npz", "mesh.npz"):
        with pytest.raises(sp.FormatError, match="not a sphere map"):
            sp.load_map(tmp_path / name)
    with pytest.raises(FileNotFoundError):
        sp.load_map(tmp_path / "missing.spheremap.npz")
    # A sphere map file is also a mesh file: its oriented mesh.
    made("radial").save(tmp_path / "r.spheremap.npz")
    assert sp.load(tmp_path / "r.spheremap.npz").n_vertices == made("radial").mesh.n_vertices
