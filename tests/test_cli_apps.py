"""The application subcommands of ``spherify`` (thesis ch. 8) through
``spherify.cli.main(argv)``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import spherify as sp
from spherify import cli


def test_harmonics_writes_the_rebuilt_surface_and_the_coefficients(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "smooth.ply"
    assert cli.main(["harmonics", "--dataset", "bumpy_blob", "--n-vertices", "800",
                     "--lmax", "12", "--lowpass", "6", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "lmax 12" in text and "wrote" in text
    rebuilt = sp.load(out)
    mesh = sp.datasets.make("bumpy_blob", 800)
    m = sp.embed(mesh, "progressive")  # the applications' --method default
    want = sp.harmonics.fit(m, 12).lowpass(6).to_mesh(m)
    np.testing.assert_allclose(rebuilt.vertices, want.vertices, atol=1e-12)
    assert np.array_equal(rebuilt.faces, want.faces)
    with np.load(out.with_suffix(".npz")) as z:
        assert z["coefficients"].shape == (169, 3) and z["filtered"].shape == (49, 3)
        np.testing.assert_allclose(z["spectrum"], sp.harmonics.fit(m, 12).spectrum())


def test_harmonics_refuses_an_uncertified_map_and_bad_arguments(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.ply"
    # Relaxation folds the helix tube over: not a bijection.
    assert cli.main(["harmonics", "--dataset", "helix_tube", "--n-vertices", "600",
                     "--method", "relaxation", "-o", str(out)]) == 1
    assert "NOT certified" in capsys.readouterr().out
    assert not out.exists()
    # Radial projection has no centre for it at all.
    assert cli.main(["harmonics", "--dataset", "helix_tube", "--n-vertices", "600",
                     "--method", "radial", "-o", str(out)]) == 2
    assert "not star-shaped" in capsys.readouterr().err
    assert cli.main(["harmonics", "--dataset", "bumpy_blob", "--n-vertices", "300",
                     "--lmax", "-3", "-o", str(out)]) == 2
    assert "lmax must be" in capsys.readouterr().err
    assert cli.main(["harmonics", "--dataset", "bumpy_blob",
                     "-o", str(tmp_path / "missing" / "x.ply")]) == 2


def test_remesh_writes_an_icosphere_mesh_on_the_surface(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.ply"
    assert cli.main(["remesh", "--dataset", "bumpy_blob", "--n-vertices", "800",
                     "--level", "3", "--samples", "500", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "icosphere level 3: 642 vertices" in text and "distance to the input" in text
    r = sp.load(out)
    m = sp.embed(sp.datasets.make("bumpy_blob", 800), "progressive")  # --method default
    np.testing.assert_allclose(r.vertices, sp.remesh(m, level=3).vertices, atol=1e-12)


def test_remesh_geometry_image_writes_the_png_and_its_mesh(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g.obj"
    assert cli.main(["remesh", "--dataset", "bumpy_blob", "--n-vertices", "800",
                     "--geometry-image", "17", "--samples", "500", "-o", str(out)]) == 0
    assert "bytes per vertex" in capsys.readouterr().out
    image = sp.load_geometry_image(out.with_suffix(".png"))
    assert image.shape == (17, 17, 3)
    assert sp.check(sp.load(out)).genus == 0
    assert cli.main(["remesh", "--dataset", "bumpy_blob", "--geometry-image", "16",
                     "-o", str(out)]) == 2
    assert "odd" in capsys.readouterr().err


def test_morph_writes_the_frames_from_a_to_b(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "frame.ply"
    assert cli.main(["morph", "--dataset", "bumpy_blob", "--n-vertices", "600",
                     "--target-dataset", "ellipsoid", "--frames", "3", "-o", str(out)]) == 0
    assert "residual" in capsys.readouterr().out
    frames = sorted(tmp_path.glob("frame_*.ply"))
    assert [f.name for f in frames] == ["frame_000.ply", "frame_001.ply", "frame_002.ply"]
    a = sp.datasets.make("bumpy_blob", 600)
    m_a = sp.embed(a, "progressive")  # the applications' --method default
    m_b = sp.embed(sp.datasets.make("ellipsoid", 600), "progressive")
    mo = sp.morph(m_a, m_b)
    first = sp.load(frames[0]).vertices
    # Normalised by default: A centred at unit rms radius.
    np.testing.assert_allclose(first.mean(axis=0), 0.0, atol=1e-12)
    assert np.sqrt((first ** 2).sum(axis=1).mean()) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(first, mo.at(0).vertices, atol=1e-12)
    np.testing.assert_allclose(sp.load(frames[2]).vertices, mo.at(1).vertices, atol=1e-12)


def test_morph_with_landmarks_and_bad_landmarks(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "f.obj"
    assert cli.main(["morph", "--dataset", "bumpy_blob", "--n-vertices", "300",
                     "--target-dataset", "bumpy_blob", "--align", "landmarks",
                     "--landmarks", "0:0", "5:5", "9:9", "--frames", "2", "-o", str(out)]) == 0
    assert "landmark rms angle" in capsys.readouterr().out
    assert cli.main(["morph", "--dataset", "bumpy_blob", "--target-dataset", "ellipsoid",
                     "--landmarks", "0-0", "-o", str(out)]) == 2
    assert "I:J" in capsys.readouterr().err


@pytest.mark.parametrize("projection", ["equirectangular", "octahedral"])
def test_texture_writes_obj_mtl_and_png(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        projection: str) -> None:
    out = tmp_path / "t.obj"
    assert cli.main(["texture", "--dataset", "bumpy_blob", "--n-vertices", "500",
                     "--projection", projection, "--pattern", "grid", "--size", "64",
                     "-o", str(out)]) == 0
    assert "0 UV triangles not positive" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.mtl", "t.obj", "t.png"]
    assert cli.main(["texture", "--dataset", "bumpy_blob", "-o", str(tmp_path / "t.ply")]) == 2
    assert "OBJ" in capsys.readouterr().err


def test_texture_writes_one_glb(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t.glb"
    assert cli.main(["texture", "--dataset", "bumpy_blob", "--n-vertices", "500",
                     "--size", "32", "-o", str(out)]) == 0
    assert "sphere points and the texture" in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["t.glb"]
    assert out.read_bytes()[:4] == b"glTF"


@pytest.mark.parametrize("command, extra", [
    ("harmonics", ["--lmax", "4"]), ("remesh", ["--level", "1"]), ("texture", []),
    ("morph", ["--target-dataset", "ellipsoid"]),
])
def test_a_folder_as_output_is_refused_before_the_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str, extra: list) -> None:
    folder = tmp_path / "out.ply"
    folder.mkdir()
    code = cli.main([command, "--dataset", "bumpy_blob", "--n-vertices", "300", *extra,
                     "-o", str(folder)])
    assert code != 0
    captured = capsys.readouterr()
    assert "this is a folder" in captured.err + captured.out
    assert "vertices" not in captured.out  # nothing was mapped first
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("command, extra", [
    ("harmonics", ["--lmax", "4"]), ("remesh", ["--level", "1", "--samples", "100"]),
    ("texture", ["--size", "16"]), ("morph", ["--target-dataset", "ellipsoid", "--frames", "2"]),
])
def test_the_applications_take_map_s_method_flags(
        command: str, extra: list, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 24, item 2: --energy, --poles, --weld and --progress were refused
    # by the application commands; they take every flag of spherify map now.
    out = tmp_path / ("x.obj" if command == "texture" else "x.ply")
    assert cli.main([command, "--dataset", "icosphere", "--n-vertices", "200", "--energy",
                     "conformal", "--weld", "--progress", "-o", str(out), *extra]) == 0, \
        capsys.readouterr()
    assert "map: progressive, certified" in capsys.readouterr().out
    # An option of another method is refused as map refuses it (exit 2).
    assert cli.main([command, "--dataset", "icosphere", "--n-vertices", "200", "--poles",
                     "graph", "-o", str(out), *extra]) == 2
    assert "--poles is an option of --method theta_phi" in capsys.readouterr().err
    # The generated shape's size is bounded as for map (was unbounded).
    with pytest.raises(SystemExit) as exit_:
        cli.main([command, "--dataset", "icosphere", "--n-vertices", "1000000000",
                  "-o", str(out), *extra])
    assert exit_.value.code == 2


def test_every_option_of_the_applications_has_help_with_its_default(
        capsys: pytest.CaptureFixture[str]) -> None:
    for command in ["harmonics", "remesh", "texture", "morph"]:
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        text = capsys.readouterr().out
        for flag in ["--lmax", "--level", "--projection", "--pattern", "--size", "--frames",
                     "--align"]:
            if f"  {flag} " in text:
                block = text.split(f"  {flag} ", 1)[1].split("\n  -", 1)[0]
                assert "default:" in block, (command, flag, block)


def test_version_and_a_plain_top_level_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        cli.main(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out.strip() == f"spherify {sp.__version__}"
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    text = capsys.readouterr().out
    assert "``" not in text and "_cli_apps" not in text and "exit status" in text
