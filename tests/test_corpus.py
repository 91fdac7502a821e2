"""The real-mesh corpus of ../shared/meshes: every valid mesh loads with the counts
of MANIFEST.json and is a genus-0 sphere (outward after orient); every file in
invalid/ is reported for the reason its manifest entry gives.

Skipped, with the reason, when the corpus is absent (see conftest.py)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Callable, Dict, List, Tuple

import numpy as np
import pytest

import spherify as sp

pytestmark = pytest.mark.corpus

Entry = Dict[str, Any]


def load_checked(entry: Entry) -> Tuple[sp.Mesh, sp.MeshReport]:
    mesh = sp.load(entry["file"])
    assert (mesh.n_vertices, mesh.n_faces) == (entry["V"], entry["F"])
    assert not any("fan-triangulated" in note for note in mesh.notes), mesh.notes
    return mesh, sp.check(mesh)


def same_cycles(got: np.ndarray, want: np.ndarray) -> bool:
    """Each face of ``got`` is the same face of ``want`` up to a rotation of its corners."""
    return bool(np.logical_or.reduce([(np.roll(want, k, axis=1) == got).all(axis=1)
                                      for k in range(3)]).all())


# --------------------------------------------------------------------------
# Valid meshes
# --------------------------------------------------------------------------

def test_valid_mesh_is_a_genus0_sphere(valid_corpus_entry: Entry) -> None:
    entry = valid_corpus_entry
    assert entry["genus"] == 0
    mesh, r = load_checked(entry)
    assert r.is_sphere_topology and r.genus == 0 and r.euler_characteristic == 2
    assert r.closed and r.manifold and r.connected
    assert r.n_edges == entry["E"]
    assert r.n_degenerate_faces == entry["zero_area_faces"] == 0
    assert r.n_duplicate_faces == entry["duplicate_faces"] == 0
    assert r.consistently_oriented == entry["consistently_oriented"]
    assert r.outward == entry["outward_oriented"]
    if entry["name"] == "horse":  # stored inward on purpose
        assert r.consistently_oriented and not r.outward and not r.valid

    fixed, info = sp.orient(mesh, return_info=True)
    after = sp.check(fixed)
    assert after.consistently_oriented and after.outward and after.valid
    assert after.signed_volume == pytest.approx(abs(r.signed_volume), rel=1e-9)
    if r.outward:
        assert info["flipped_faces"] == 0
        assert (fixed.faces == mesh.faces).all()
    else:
        assert info["flipped_faces"] == mesh.n_faces and info["components_turned_outward"] == 1
        assert same_cycles(fixed.faces, mesh.faces[:, ::-1])


# --------------------------------------------------------------------------
# Invalid meshes
# --------------------------------------------------------------------------

def _genus(reason: str, name: str) -> Dict[str, Any]:
    (g,) = re.findall(r"genus (\d+)", reason)
    assert name.startswith(f"genus{g}_")
    return {"genus": int(g), "closed": True, "manifold": True, "euler_characteristic": 2 - 2 * int(g)}


def _open(reason: str, name: str) -> Dict[str, Any]:
    return {"n_boundary_loops": 2 if "two holes" in reason else 1, "closed": False, "genus": 0}


def _checks(entry: Entry) -> Dict[str, Any]:
    return entry["checks_after_merging_duplicate_vertices"]


# File-name prefix -> (expected report fields from the reason and the entry).
RULES: List[Tuple[str, Callable[[str, Entry], Dict[str, Any]]]] = [
    ("genus", lambda reason, e: _genus(reason, e["name"])),
    ("open_boundary", lambda reason, e: _open(reason, e["name"])),
    ("nonmanifold_vertex", lambda reason, e: {"n_nonmanifold_vertices": 1, "n_nonmanifold_edges": 0,
                                              "manifold": False, "genus": None}),
    ("nonmanifold_edge", lambda reason, e: {"n_nonmanifold_edges": 1, "manifold": False, "genus": None}),
    ("disconnected", lambda reason, e: {"n_components": 2, "connected": False}),
    ("inconsistent_orientation", lambda reason, e: {"consistently_oriented": False, "outward": False,
                                                    "is_sphere_topology": True}),
    ("duplicate_faces", lambda reason, e: {"n_duplicate_faces": _checks(e)["duplicate_faces"]}),
    ("degenerate", lambda reason, e: {"n_degenerate_faces": _checks(e)["zero_area_faces_as_stored"],
                                      "is_sphere_topology": True}),
]

# Numbers the README states for particular files, on top of the rules.
KNOWN = {
    "duplicate_faces_blub": {"n_duplicate_faces": 7},            # 4 duplicated + 3 reversed
    "degenerate_zero_length_edge_knight": {"n_degenerate_faces": 2},
    "degenerate_collinear_box": {"n_degenerate_faces": 1},
    "open_boundary_sphere_two_holes": {"n_boundary_loops": 2, "n_unreferenced_vertices": 2},
    "open_boundary_hand": {"n_boundary_loops": 1},
    "nonmanifold_vertex_two_tets": {"closed": True, "n_components": 1, "euler_characteristic": 3},
}


def expected_for(entry: Entry) -> Dict[str, Any]:
    reason = entry["genus"]
    assert isinstance(reason, str) and reason.startswith("invalid: "), reason
    matches = [rule for prefix, rule in RULES if entry["name"].startswith(prefix)]
    assert len(matches) == 1, f"no rule (or several) for {entry['name']}: add one to RULES"
    expect = matches[0](reason[len("invalid: "):], entry)
    expect.update(KNOWN.get(entry["name"], {}))
    return expect


def test_invalid_mesh_is_reported_for_its_reason(invalid_corpus_entry: Entry) -> None:
    entry = invalid_corpus_entry
    mesh, r = load_checked(entry)
    expect = expected_for(entry)
    assert {k: getattr(r, k) for k in expect} == expect
    assert not r.valid and r.problems
    if expect.get("is_sphere_topology") is not True:
        assert not r.is_sphere_topology

    # The manifest's own counts (made with other tools) agree wherever the file
    # needed no vertex merging to be checked.
    checks = _checks(entry)
    if checks["merged_duplicate_vertices"] == 0:
        assert r.euler_characteristic == entry["euler_characteristic"]
        assert r.n_unreferenced_vertices == checks["unreferenced_vertices"]
        assert r.closed == checks["closed"]
        assert r.n_boundary_edges == checks["boundary_edges"]
        assert r.n_nonmanifold_edges == checks["nonmanifold_edges"]
        assert r.n_nonmanifold_vertices == checks["nonmanifold_vertices"]
        assert r.n_components == checks["components"]
        assert r.consistently_oriented == checks["consistently_oriented"]
        assert r.n_duplicate_faces == checks["duplicate_faces"]
        assert r.n_degenerate_faces == checks["zero_area_faces_as_stored"] + checks["faces_with_repeated_index"]

    # Orientation repair fixes exactly the orientation problem, nothing else.
    if r.n_nonmanifold_edges:
        with pytest.raises(sp.TopologyError) as err:
            sp.orient(mesh)
        assert err.value.report.n_nonmanifold_edges == r.n_nonmanifold_edges
    else:
        after = sp.check(sp.orient(mesh))
        assert after.consistently_oriented
        assert after.valid == entry["name"].startswith("inconsistent_orientation")


def test_every_invalid_file_is_in_the_manifest(shared_meshes: Path) -> None:
    import json

    manifest = json.loads((shared_meshes / "MANIFEST.json").read_text(encoding="utf-8"))
    listed = {e["path"] for e in manifest if e["path"].startswith("invalid/")}
    on_disk = {f"invalid/{p.name}" for p in (shared_meshes / "invalid").iterdir() if p.is_file()}
    assert on_disk == listed
    for e in manifest:
        if e["path"].startswith("invalid/"):
            expected_for(e)  # every invalid file has a rule
