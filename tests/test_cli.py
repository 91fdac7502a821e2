"""The ``spherify`` command line through ``spherify.cli.main(argv)``: exit status
0 for a valid (or orient-repairable) genus-0 mesh, 1 for problems orient cannot
repair, 2 for unreadable input or bad arguments."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path
from typing import List

import numpy as np
import pytest

import spherify as sp
from spherify import cli


V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)


def write(tmp_path: Path, name: str, faces: np.ndarray, vertices: np.ndarray = V) -> Path:
    path = tmp_path / name
    sp.save(sp.Mesh(vertices, faces), path)
    return path


def test_check_dataset_is_valid(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["check", "--dataset", "icosphere", "--n-vertices", "200"]) == 0
    out = capsys.readouterr().out
    mesh = sp.datasets.make("icosphere", 200)
    assert "MeshReport" in out
    assert f"{mesh.n_vertices} vertices" in out and f"{mesh.n_faces} faces" in out


@pytest.mark.parametrize("ext", ["obj", "ply"])
def test_check_valid_file(tmp_path: Path, capsys: pytest.CaptureFixture[str], ext: str) -> None:
    path = write(tmp_path, f"tetra.{ext}", F)
    assert cli.main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert str(path) in out and "problem" not in out


def test_check_file_with_a_hole_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, "open.obj", F[1:])
    assert cli.main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    report = sp.check(sp.load(path))
    for problem in report.problems:  # every problem the report finds is printed
        assert problem in out


def test_check_inward_file_is_repaired_by_orient(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, "inward.off", F[:, ::-1])
    before = path.read_bytes()
    assert cli.main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "orient" in out and "4 faces" in out
    assert path.read_bytes() == before  # check only reports; it never writes
    assert [p.name for p in tmp_path.iterdir()] == ["inward.off"]


def test_check_nonmanifold_file_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Two tetrahedra glued along edge (0, 1): 4 faces on one edge.
    V2 = np.vstack([V, [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]])
    F2 = np.vstack([F, [[0, 1, 4], [0, 5, 1], [0, 4, 5], [1, 5, 4]]])
    path = write(tmp_path, "glued.obj", F2, V2)
    assert cli.main(["check", str(path)]) == 1
    assert "non-manifold" in capsys.readouterr().out


def test_check_missing_file_is_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.obj"
    assert cli.main(["check", str(missing)]) == 2
    captured = capsys.readouterr()
    assert str(missing) in captured.err and captured.out == ""
    assert list(tmp_path.iterdir()) == []


def test_check_malformed_file_is_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.obj"
    path.write_text("v 0 0 0\nv 1 0 nope\n")
    assert cli.main(["check", str(path)]) == 2
    assert "line 2" in capsys.readouterr().err


def test_check_without_input_is_status_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["check"]) == 2
    assert "--dataset" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["check", "--dataset", "no_such_shape"], ["frobnicate"], []])
def test_bad_arguments_exit_with_status_2(argv, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 2
    assert "usage" in capsys.readouterr().err


def test_orient_writes_an_outward_copy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = write(tmp_path, "inward.obj", F[:, ::-1])
    before = source.read_bytes()
    out = tmp_path / "fixed.ply"
    assert cli.main(["orient", str(source), "-o", str(out)]) == 0
    assert str(out) in capsys.readouterr().out
    fixed = sp.load(out)
    assert sp.check(fixed).valid
    assert np.array_equal(fixed.vertices, V)
    assert source.read_bytes() == before  # the input is left alone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fixed.ply", "inward.obj"]


def test_orient_dataset(tmp_path: Path) -> None:
    out = tmp_path / "ico.off"
    assert cli.main(["orient", "--dataset", "icosphere", "--n-vertices", "100", "-o", str(out)]) == 0
    assert sp.check(sp.load(out)).valid


def test_orient_refuses_a_nonmanifold_mesh(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    V2 = np.vstack([V, [[0.5, 0.5, 0.5]]])
    F2 = np.vstack([F, [[1, 2, 4]]])  # a third face on edge (1, 2)
    source = write(tmp_path, "fin.obj", F2, V2)
    out = tmp_path / "out.obj"
    # 1: a mesh that cannot be done (README's table; it was 2, issue 26, finding 10)
    assert cli.main(["orient", str(source), "-o", str(out)]) == 1
    assert "error" in capsys.readouterr().err
    assert not out.exists()


def test_orient_requires_an_output(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = write(tmp_path, "t.obj", F)
    with pytest.raises(SystemExit) as info:
        cli.main(["orient", str(source)])
    assert info.value.code == 2


def test_map_writes_the_sphere_and_the_npz(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sphere.ply"
    code = cli.main(["map", "--dataset", "helix_tube", "--n-vertices", "500", "--method", "theta_phi",
                     "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "certified flip-free" in text and "GC-embedding" in text
    assert "quality: angle distortion mean" in text and "stretch L2" in text
    sphere = sp.load(out)
    np.testing.assert_allclose(np.linalg.norm(sphere.vertices, axis=1), 1.0, atol=1e-12)
    data = np.load(tmp_path / "sphere.npz")
    np.testing.assert_array_equal(data["points"], sphere.vertices)
    assert data["theta_phi"].shape[1] == 2
    assert data["poles"].shape == (2,) and data["cut_path"][0] == data["poles"][0]


def test_map_defaults_to_the_progressive_isometric_map(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sphere.ply"
    code = cli.main(["map", "--dataset", "helix_tube", "--n-vertices", "500", "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "method: progressive" in text and "GC-embedding (minor-arc edges): valid, 0 faces" in text
    assert "theta-phi" not in text and "poles:" not in text
    mesh = sp.datasets.make("helix_tube", 500)
    want = sp.embed(mesh, "progressive", energy="isometric")
    data = np.load(tmp_path / "sphere.npz")
    assert {"faces", "points", "sphere_sha256"} <= set(data.files)
    assert "mesh_sha256" not in data.files  # a generated shape has no file to hash
    np.testing.assert_array_equal(data["points"], want.points)
    np.testing.assert_array_equal(sp.load(out).vertices, want.points)
    assert cli.pair_is_consistent(out)


@pytest.mark.parametrize("method", ["progressive", "theta_phi"])
def test_what_map_writes_reads_back_as_a_certified_map(
        method: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 24, item 3: nothing could read back the .npz spherify map wrote,
    # and its mesh_sha256 was the hash of the output, not of the input.
    source = tmp_path / "blob.ply"
    sp.save(sp.datasets.make("bumpy_blob", 600), source)
    out = tmp_path / "sphere.ply"
    assert cli.main(["map", str(source), "--method", method, "-o", str(out)]) == 0
    capsys.readouterr()
    m = sp.load_map(tmp_path / "sphere.npz")
    direct = sp.embed(sp.load(source), method)
    assert m.method == method and m.valid == direct.valid
    np.testing.assert_array_equal(m.points, direct.points)
    if method == "theta_phi":
        assert isinstance(m, sp.ThetaPhiMap) and m.tp_valid and m.poles == direct.poles
    with np.load(tmp_path / "sphere.npz") as data:
        assert str(data["mesh_sha256"]) == hashlib.sha256(source.read_bytes()).hexdigest()
        assert str(data["sphere_sha256"]) == hashlib.sha256(out.read_bytes()).hexdigest()
    assert cli.pair_is_consistent(out)
    out.write_bytes(out.read_bytes() + b"\n")  # the sphere changed after the .npz was written
    assert not cli.pair_is_consistent(out)


@pytest.mark.parametrize("flags, message", [
    (["--poles", "symmetry"], "--poles is an option of --method theta_phi, and the default "
                              "method is progressive: add --method theta_phi to use it"),
    (["--weights", "chord"], "--weights is an option of --method relaxation, gotsman or "
                             "theta_phi, and the default method is progressive: add --method "
                             "relaxation, gotsman or theta_phi to use it"),
    (["--poles", "symmetry", "--symmetry-eps", "0.1"],
     "--poles, --symmetry-eps are options of --method theta_phi, and the default method is "
     "progressive: add --method theta_phi to use them"),
    (["--method", "progressive", "--poles", "graph"],
     "--poles is an option of --method theta_phi, not of --method progressive: use "
     "--method theta_phi, or leave it out"),
    (["--method", "theta_phi", "--energy", "stretch"],
     "--energy is an option of --method progressive, not of --method theta_phi: use "
     "--method progressive, or leave it out"),
    (["--method", "radial", "--energy", "conformal"],
     "--energy is an option of --method progressive, not of --method radial"),
    (["--method", "theta_phi", "--symmetry-eps", "0.1"],
     "--symmetry-eps 0.1 only applies to --poles symmetry: add --poles symmetry to use it"),
    (["--method", "gotsman", "--weights", "mean_value"],
     "--weights mean_value is not one of --method gotsman's: it takes uniform, chord"),
    (["--method", "relaxation", "--check-every", "0"], "--check-every must be at least 1, got 0"),
])
def test_map_refuses_an_option_its_method_would_ignore(
        flags: List[str], message: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 10, item 8: `spherify map MESH --poles symmetry` meant theta-phi
    # before the default became progressive; ignoring --poles now would map
    # with another method than the one asked for.
    out = tmp_path / "x.ply"
    assert cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", *flags,
                     "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert f"spherify: error: {message}" in captured.err and captured.out == ""
    assert not out.exists()


def test_map_refuses_broken_input_and_missing_folders(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2]])
    broken = tmp_path / "open.obj"
    sp.save(sp.Mesh(V, F), broken)
    assert cli.main(["map", str(broken), "-o", str(tmp_path / "x.ply")]) == 1
    assert "refusing" in capsys.readouterr().out
    assert cli.main(["map", "--dataset", "icosphere", "-o", str(tmp_path / "no" / "x.ply")]) == 2
    assert not (tmp_path / "x.ply").exists()


def test_map_with_symmetry_poles(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.ply"
    assert cli.main(["map", "--dataset", "ellipsoid", "--n-vertices", "500", "--method", "theta_phi",
                     "--poles", "symmetry", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "symmetry plane: normal (" in text and "fell back" not in text
    # The helix's plane meets the tube in small loops: reported, not hidden.
    assert cli.main(["map", "--dataset", "helix_tube", "--n-vertices", "800", "--method", "theta_phi",
                     "--poles", "symmetry", "--symmetry-eps", "0.05", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "symmetry poles fell back to fast_graph" in text


def test_the_cli_offers_the_core_s_choices(tmp_path: Path) -> None:
    names = sp._core.choices()
    assert names["methods"] == sp.methods()
    assert set(names["theta_phi_weights"]) < set(names["weights"])
    assert "cotangent" not in names["theta_phi_weights"]
    with pytest.raises(SystemExit):
        cli.main(["map", "--dataset", "icosphere", "-o", str(tmp_path / "x.ply"),
                  "--poles", "nowhere"])


@pytest.mark.parametrize("buffered", [False, True])
def test_a_reader_that_leaves_does_not_stop_the_job(tmp_path: Path, buffered: bool) -> None:
    # `spherify map ... | head -1`: the reader closes the pipe early. The
    # command still writes its files and exits with the job's status, with
    # nothing on stderr (a print after the close raised BrokenPipeError and
    # the files were never written).
    from _child import child_env
    env = child_env()
    if buffered:
        env.pop("PYTHONUNBUFFERED")  # the interpreter's last flush hits the closed pipe
    out = tmp_path / "sphere.ply"
    read, write_end = os.pipe()
    os.close(read)  # the reader has left before the first line
    done = subprocess.run([sys.executable, "-m", "spherify", "map", "--dataset", "bumpy_blob",
                           "--n-vertices", "400", "-o", str(out)], env=env, stdout=write_end,
                          stderr=subprocess.PIPE, text=True, timeout=120)
    os.close(write_end)
    assert done.returncode == 0 and done.stderr == ""
    assert sp.load(out).n_vertices == sp.datasets.make("bumpy_blob", 400).n_vertices
    assert out.with_suffix(".npz").is_file()


def test_weld_closes_a_seam_the_file_split(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from test_check import split_along_a_seam
    mesh = sp.datasets.make("bumpy_blob", 400)
    side = mesh.vertices[mesh.faces].mean(1)[:, 0] > 0
    path = tmp_path / "seam.obj"
    sp.save(sp.Mesh(*split_along_a_seam(mesh.vertices, mesh.faces, side)), path)
    assert cli.main(["check", str(path)]) == 1
    assert "welding (sp.weld, --weld) closes" in capsys.readouterr().out
    assert cli.main(["check", "--weld", str(path)]) == 0
    out = capsys.readouterr().out
    assert "valid genus-0 mesh" in out and "note: welded" in out
    assert cli.main(["map", "--weld", str(path), "-o", str(tmp_path / "s.ply")]) == 0
    assert sp.load(tmp_path / "s.ply").n_vertices == mesh.n_vertices
