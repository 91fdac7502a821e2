"""Outputs that stay consistent and arguments that are refused, not coerced
(issue 13, items 10-16)."""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import spherify as sp
from spherify import cli


@pytest.fixture(scope="module")
def blob() -> sp.Mesh:
    return sp.datasets.bumpy_blob(n_vertices=300)


# Items 10-11: the map's pair of files, temporaries.

def test_map_writes_a_pair_a_reader_can_check(tmp_path: Path) -> None:
    out = tmp_path / "s.ply"
    assert cli.main(["map", "--dataset", "ellipsoid", "--n-vertices", "300", "-o", str(out)]) == 0
    assert cli.pair_is_consistent(out)
    # A run cut short after the mesh and before the .npz leaves a new mesh
    # beside the old .npz: the reader tells.
    sp.save(sp.datasets.ellipsoid(n_vertices=400), out)
    assert not cli.pair_is_consistent(out)
    # Only the two files remain: no temporary left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.npz", "s.ply"]


def test_temporaries_of_killed_writers_are_cleaned_up_on_the_next_write(tmp_path: Path,
                                                                        blob: sp.Mesh) -> None:
    if not Path("/proc/self").exists():
        pytest.skip("needs /proc to tell which processes are alive")
    # What a kill -9 during a save leaves: temporaries of a process that is gone.
    dead = 2**31 - 2  # above Linux's largest pid
    stale = [tmp_path / f".out.ply.tmp-{dead}-0", tmp_path / f".out.npz.tmp-{dead}-3"]
    for s in stale:
        s.write_bytes(b"x" * 1000)
    mine = tmp_path / f".other.ply.tmp-{os.getpid()}-7"  # a live writer's: kept
    mine.write_bytes(b"x")
    sp.save(blob, tmp_path / "out.ply")
    assert not any(s.exists() for s in stale)
    assert mine.exists()


# Item 12: mode and links.

def test_saving_keeps_the_mode_and_writes_through_a_symlink(tmp_path: Path, blob: sp.Mesh) -> None:
    real = tmp_path / "real.ply"
    sp.save(blob, real)
    real.chmod(0o600)
    link = tmp_path / "link.ply"
    link.symlink_to(real.name)
    other = sp.datasets.icosphere(subdivisions=2)
    sp.save(other, link)
    assert link.is_symlink()
    assert stat.S_IMODE(real.stat().st_mode) == 0o600
    assert sp.load(real).n_vertices == other.n_vertices != blob.n_vertices
    # The .npz writer is the same one.
    npz_real = tmp_path / "real.npz"
    npz_real.write_bytes(b"old")
    npz_real.chmod(0o640)
    npz_link = tmp_path / "link.npz"
    npz_link.symlink_to(npz_real.name)
    sp._core.write_atomic(str(npz_link), b"new")
    assert npz_link.is_symlink() and npz_real.read_bytes() == b"new"
    assert stat.S_IMODE(npz_real.stat().st_mode) == 0o640


@pytest.mark.parametrize("stem", ["a" * 247, "é" * 123])
def test_a_long_legal_name_is_written_by_every_writer(tmp_path: Path, blob: sp.Mesh,
                                                       stem: str) -> None:
    # 251- and 250-byte names (255 is the limit): their temporaries, the name
    # with a dot and ".tmp-PID-N", were not legal ("File name too long").
    m = sp.embed(blob)
    writes = {".ply": lambda p: sp.save(blob, p), ".npz": lambda p: sp.save(blob, p),
              ".map": m.save, ".png": lambda p: sp.save_geometry_image(np.zeros((3, 3, 3)), p)}
    for suffix, write in writes.items():
        path = tmp_path / (stem[:len(stem) - len(suffix) + 4] + suffix)
        assert len(os.fsencode(path.name)) <= 255
        write(path)
        assert path.is_file(), suffix
    assert sp.load(tmp_path / (stem + ".ply")).n_vertices == blob.n_vertices
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".map", ".npz", ".ply", ".png"]


# Item 13: STL cannot hold every double.

@pytest.mark.parametrize("scale", [1e300, 1e-320])
def test_stl_refuses_coordinates_it_would_turn_into_inf_or_zero(scale: float, tmp_path: Path) -> None:
    mesh = sp.datasets.icosphere(subdivisions=1)
    big = sp.Mesh(mesh.vertices * scale, mesh.faces)
    with pytest.raises(sp.MeshError, match="32-bit floats cannot hold"):
        sp.save(big, tmp_path / "x.stl")
    assert not list(tmp_path.iterdir())
    sp.save(big, tmp_path / "x.ply")  # float64 formats keep them
    assert np.array_equal(sp.load(tmp_path / "x.ply").vertices, big.vertices)


# Items 14-15: arguments.

@pytest.mark.parametrize("bad", [2**70, -1, 1.5, "3", True, None, 3 + 0j])
def test_dijkstra_refuses_what_is_not_a_vertex_id(bad: Any, blob: sp.Mesh) -> None:
    with pytest.raises(sp.MeshError, match="source"):
        sp.dijkstra(blob, bad)


def test_numpy_integers_are_vertex_ids(blob: sp.Mesh) -> None:
    dist, _ = sp.dijkstra(blob, np.int32(3))
    assert dist[3] == 0.0


@pytest.mark.parametrize("option, value", [("max_refinements", -1), ("max_refinements", 2**70),
                                           ("max_iter", 2**70), ("poles", (True, 5)),
                                           ("poles", (0, 1.5))])
def test_embed_options_out_of_range_are_mesh_errors(option: str, value: Any, blob: sp.Mesh) -> None:
    method = "relaxation" if option == "max_iter" else "theta_phi"
    with pytest.raises(sp.MeshError, match=option):
        sp.embed(blob, method, **{option: value})


@pytest.mark.parametrize("max_iter", [-1, 2**70, 2.5])
def test_tutte_max_iter_is_checked(max_iter: Any) -> None:
    disk = sp.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.]]),
                   np.array([[0, 1, 2], [1, 3, 2]]))
    with pytest.raises(sp.MeshError, match="max_iter"):
        sp.tutte(disk, max_iter=max_iter)


def test_paths_may_be_bytes_but_not_none(tmp_path: Path, blob: sp.Mesh) -> None:
    path = os.fsencode(tmp_path / "b.off")
    sp.save(blob, path)
    assert sp.load(path).n_vertices == blob.n_vertices
    with pytest.raises(TypeError, match="file path"):
        sp.load(None)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="file path"):
        sp.save(blob, None)  # type: ignore[arg-type]


def test_complex_and_masked_arrays_are_refused(blob: sp.Mesh) -> None:
    m = sp.embed(blob)
    ids = np.zeros(2, dtype=np.int64)
    with pytest.raises(sp.MeshError, match="complex"):
        m.to_sphere(ids, np.full((2, 3), 1 / 3 + 0j))
    masked = np.ma.masked_array(m.points[:2], mask=[[True, False, False], [False] * 3])
    with pytest.raises(sp.MeshError, match="masked"):
        m.to_surface(masked)
    with pytest.raises(sp.MeshError, match="masked"):
        sp.Mesh(np.ma.masked_array(blob.vertices), blob.faces)
    with pytest.raises(sp.MeshError, match="complex"):
        sp.check_sphere(blob, m.points.astype(complex))


# Item 16: the command line.

def test_cli_refuses_a_size_out_of_range(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as info:
        cli.main(["map", "--dataset", "icosphere", "--n-vertices", "1000000000",
                  "-o", str(tmp_path / "x.ply")])
    assert info.value.code == 2
    assert "supported range 4 to 10,000,000" in capsys.readouterr().err


def test_cli_refuses_a_file_and_a_dataset_together(tmp_path: Path) -> None:
    torus = tmp_path / "t.off"
    torus.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    assert cli.main(["check", str(torus), "--dataset", "icosphere"]) == 2
    assert cli.main(["map", str(torus), "--dataset", "icosphere", "-o",
                     str(tmp_path / "x.ply")]) == 2
    assert not (tmp_path / "x.ply").exists()


@pytest.mark.skipif(sys.platform == "win32" or os.geteuid() == 0,
                    reason="root writes anywhere; POSIX permissions")
def test_cli_refuses_an_unwritable_folder_before_working(tmp_path: Path) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        assert cli.main(["map", "--dataset", "icosphere", "-o", str(folder / "x.ply")]) == 2
    finally:
        folder.chmod(0o700)


def test_cli_refuses_an_unknown_extension_before_working(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    def no_work(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the mesh was loaded before the output was checked")
    monkeypatch.setattr(cli, "_load", no_work)
    for command in ("map", "orient"):
        assert cli.main([command, "--dataset", "icosphere", "-o", str(tmp_path / "x.gltf")]) == 2
        assert "unknown extension '.gltf'" in capsys.readouterr().err


def test_cli_refuses_a_folder_as_output_before_working(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    def no_work(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the mesh was loaded before the output was checked")
    monkeypatch.setattr(cli, "_load", no_work)
    folder = tmp_path / "out.ply"
    folder.mkdir()
    for command in ("map", "orient"):
        assert cli.main([command, "--dataset", "icosphere", "-o", str(folder)]) == 2
        assert "this is a folder" in capsys.readouterr().err
    assert list(folder.iterdir()) == []


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs (POSIX)")
def test_cli_map_refuses_a_pipe_as_output_before_working(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """map reads OUT back for the hash in OUT's .npz: from a pipe that read
    would wait for a writer for ever."""
    def no_work(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the mesh was loaded before the output was checked")
    monkeypatch.setattr(cli, "_load", no_work)
    fifo = tmp_path / "out.ply"
    os.mkfifo(fifo)
    assert cli.main(["map", "--dataset", "icosphere", "-o", str(fifo)]) == 2
    assert "FIFO" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["out.ply"]


def test_cli_a_map_the_method_refuses_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # A helix tube is not star-shaped: radial refuses it.
    code = cli.main(["map", "--dataset", "helix_tube", "--n-vertices", "500", "--method", "radial",
                     "-o", str(tmp_path / "x.ply")])
    assert code == 1
    assert "star-shaped" in capsys.readouterr().out


# --- item 18: messages that name the real problem --------------------------


def _ico() -> sp.Mesh:
    return sp.datasets.make("icosphere", 42)


@pytest.mark.parametrize("method", ["theta_phi", "radial", "relaxation", "gotsman", "alexa"])
def test_all_vertices_at_one_point_is_called_degenerate(method: str) -> None:
    ico = _ico()
    mesh = sp.Mesh(np.zeros_like(ico.vertices), ico.faces)
    with pytest.raises(sp.MeshError, match="degenerate: all 42 vertices are at one point"):
        sp.embed(mesh, method=method)
    problems = sp.check(mesh).problems
    assert not any("orient fixes this" in p for p in problems), problems
    assert any("encloses no volume" in p for p in problems), problems


@pytest.mark.parametrize("scale,what", [(1e308, "too large"), (1e200, "too large"),
                                        (1e-310, "too small"), (1e-200, "too small")])
def test_overflowing_and_underflowing_coordinates_are_named(scale: float, what: str) -> None:
    ico = _ico()
    mesh = sp.Mesh(ico.vertices * scale, ico.faces)
    for method in ["theta_phi", "radial", "relaxation"]:
        with pytest.raises(sp.MeshError, match=what):
            sp.embed(mesh, method=method)


def test_scales_far_from_one_still_map() -> None:
    ico = _ico()
    for scale in [1e-50, 1e50]:
        m = sp.embed(sp.Mesh(ico.vertices * scale, ico.faces), method="relaxation")
        assert m.valid


def test_a_nan_mesh_report_does_not_promise_that_orient_fixes_it() -> None:
    ico = _ico()
    V = ico.vertices.copy()
    V[3] = np.nan
    problems = sp.check((V, ico.faces)).problems
    assert not any("orient fixes this" in p for p in problems), problems
    assert any("orient cannot fix this" in p for p in problems), problems
    with pytest.raises(sp.MeshError):
        sp.orient((V, ico.faces))


# --- item 17: readers note what they cannot hold against a file -----------


def test_loading_notes_a_cut_stl_and_trailing_data(tmp_path: Path) -> None:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    facets = "".join("facet normal 0 0 0\n outer loop\n"
                     + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in V[f])
                     + " endloop\nendfacet\n" for f in F)
    stl = tmp_path / "a.stl"
    stl.write_text("solid t\n" + facets)  # cut after a complete facet: no endsolid
    assert any("no endsolid after the last of 4 facets" in n for n in sp.load(stl).notes)
    stl.write_text("solid t\n" + facets + "endsolid t\n")
    assert not any("endsolid" in n for n in sp.load(stl).notes)
    off = tmp_path / "a.off"
    sp.save(sp.datasets.make("icosphere", 42), off)
    off.write_text(off.read_text() + "3 0 1 2\n")
    notes = sp.load(off).notes
    assert any("was ignored" in n for n in notes), notes
