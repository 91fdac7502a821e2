"""Honest batches and exit codes (issue 26, findings 2, 6, 7 and the orient
part of 10): a batch with an output not written is not a success, a damaged
journal line is skipped with a warning, a FIFO journal is refused at once, a
list of inputs that names itself is a FormatError, and every command exits 1
for a mesh that cannot be done, 2 for bad arguments or inputs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import List

import numpy as np
import pytest

import spherify as sp
from spherify._files import file_sha256
from spherify import _batch as batch_module

cli = pytest.importorskip("spherify.cli")


def inputs(folder: Path, n: int) -> List[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(n):
        path = folder / f"mesh{i}.ply"
        sp.save(sp.datasets.make("bumpy_blob", 80 + 20 * i), path)
        paths.append(path)
    return paths


def output_stem(path: Path) -> str:
    return f"{batch_module._safe_name(path)}-{file_sha256(path)[:16]}"


# --- finding 2: an output not written is a failed mesh -------------------------------

@pytest.mark.parametrize("blocked", [".sphere.ply", ".spheremap.npz"])
def test_a_mesh_whose_output_is_not_written_is_not_counted_certified(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], blocked: str) -> None:
    # Before: "2 meshes: 2 certified, 1 failed" and exit status 0 (a full
    # disk: "30 certified, 24 failed", exit 0). An output name taken by a
    # folder fails the rename as a full disk fails the write.
    paths = inputs(tmp_path / "in", 2)
    out = tmp_path / "out"
    (out / f"{output_stem(paths[0])}{blocked}").mkdir(parents=True)
    assert cli.main(["batch", str(tmp_path / "in"), "-o", str(out), "--workers", "1"]) == 1
    printed = capsys.readouterr().out
    assert "2 meshes: 1 certified, 1 failed" in printed, printed
    assert f"failed: {paths[0]}" in printed
    result = sp.batch(tmp_path / "in", out, workers=1)
    assert not result.all_certified
    assert result.counts["certified"] == 1 and result.counts["failed"] == 1
    row = {r["input"]: r for r in result.rows}[str(paths[0])]
    assert row["status"] == "failed" and row["certified"] is False
    # Neither output of the failed mesh is left behind.
    assert not (out / f"{output_stem(paths[0])}.sphere.ply").is_file()
    assert not (out / f"{output_stem(paths[0])}.spheremap.npz").is_file()


# --- findings 6 and 7: the journal and lists of inputs -------------------------------

DAMAGED_LINES = {
    "invalid UTF-8": b"\xff\xfe{not utf-8}\n",
    "input a list": b'{"input": [1, 2]}\n',
    "nested 100,000 deep": b'{"input": "x", "deep": ' + b"[" * 100_000 + b"]" * 100_000 + b"}\n",
    "not an object": b"[1, 2, 3]\n",
}


@pytest.mark.parametrize("case", sorted(DAMAGED_LINES))
def test_a_damaged_journal_line_is_skipped_with_a_warning_naming_it(tmp_path: Path,
                                                                    case: str) -> None:
    # Before: UnicodeDecodeError, TypeError, RecursionError on every later run.
    inputs(tmp_path / "in", 1)
    out = tmp_path / "out"
    first = sp.batch(tmp_path / "in", out, workers=1)
    assert first.all_certified
    journal = out / "journal.jsonl"
    with open(journal, "ab") as handle:
        handle.write(DAMAGED_LINES[case])
        handle.write(b'{"input": "later.ply", "status": "failed"}\n')
    with pytest.warns(sp.SpherifyWarning, match=r"journal.jsonl line 2: .*skipped"):
        again = sp.batch(tmp_path / "in", out, workers=1)
    assert again.skipped == 1 and again.all_certified  # the good row still counts
    # The compacted journal holds no damaged line: the next run is quiet.
    lines = journal.read_bytes().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["status"] == "done"


def test_a_journal_line_cut_short_by_a_killed_run_is_skipped_quietly(tmp_path: Path) -> None:
    inputs(tmp_path / "in", 1)
    out = tmp_path / "out"
    sp.batch(tmp_path / "in", out, workers=1)
    with open(out / "journal.jsonl", "ab") as handle:
        handle.write(b'{"input": "cut", "sta')  # no newline: the write a kill cut short
    assert sp.batch(tmp_path / "in", out, workers=1).skipped == 1  # (warnings are errors here)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_named_journal_is_refused_at_once(tmp_path: Path) -> None:
    # Before: the journal reader waited for a writer, for ever.
    inputs(tmp_path / "in", 1)
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "journal.jsonl")
    code = ("import sys, spherify as sp\n"
            "try:\n"
            "    sp.batch(sys.argv[1], sys.argv[2], workers=1)\n"
            "except sp.FormatError as err:\n"
            "    print('FormatError', err)\n")
    began = time.monotonic()
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "in"), str(out)],
                          capture_output=True, text=True, timeout=30)
    assert time.monotonic() - began < 20
    assert done.stdout.startswith("FormatError") and "FIFO" in done.stdout, done
    assert "journal.jsonl" in done.stdout
    assert cli.main(["batch", str(tmp_path / "in"), "-o", str(out)]) == 2


@pytest.mark.parametrize("cycle", ["itself", "a cycle of two"])
def test_a_list_of_inputs_that_names_itself_is_a_format_error(tmp_path: Path,
                                                              cycle: str) -> None:
    # Before: RecursionError (exit status 1 from the command line).
    inputs(tmp_path / "in", 1)
    first = tmp_path / "first.txt"
    if cycle == "itself":
        first.write_text("in/mesh0.ply\nfirst.txt\n")
    else:
        first.write_text("in/mesh0.ply\nsecond.txt\n")
        (tmp_path / "second.txt").write_text("first.txt\n")
    with pytest.raises(sp.FormatError, match="names itself") as info:
        sp.batch(first, tmp_path / "out")
    assert info.value.path is not None and info.value.path.endswith(".txt")
    assert cli.main(["batch", str(first), "-o", str(tmp_path / "out")]) == 2
    # A list named twice, without a cycle, is fine.
    (tmp_path / "twice.txt").write_text("in/mesh0.ply\n")
    first.write_text("twice.txt\ntwice.txt\n")
    assert sp.batch(first, tmp_path / "out").counts["meshes"] == 1


def test_a_list_line_too_long_for_a_path_is_a_format_error_naming_the_line(tmp_path: Path) -> None:
    # Before: a raw OSError (ENAMETOOLONG) from looking the path up, which
    # named neither the list nor the line (found by fuzzing the list reader).
    inputs(tmp_path / "in", 1)
    listed = tmp_path / "inputs.txt"
    listed.write_text("in/mesh0.ply\n# a comment\n" + "x" * 5000 + ".ply\n")
    with pytest.raises(sp.FormatError, match="line 3: the listed path is too long") as info:
        sp.batch(listed, tmp_path / "out")
    assert info.value.path == str(listed) and info.value.line == 3
    assert cli.main(["batch", str(listed), "-o", str(tmp_path / "out")]) == 2


@pytest.mark.skipif(sys.platform == "darwin", reason="macOS file names are UTF-8")
def test_a_mesh_whose_file_name_is_not_utf8_is_mapped_and_summarised(tmp_path: Path) -> None:
    # Found while fuzzing the journal: the summary's strict UTF-8 raised
    # UnicodeEncodeError at the end of the batch.
    (tmp_path / "in").mkdir()
    name = os.fsencode(tmp_path / "in") + b"/\xff.ply"
    sp.save(sp.datasets.make("bumpy_blob", 80), tmp_path / "in" / "ok.ply")
    os.rename(os.fsencode(tmp_path / "in" / "ok.ply"), name)
    result = sp.batch(tmp_path / "in", tmp_path / "out", workers=1)
    assert result.all_certified and result.counts["certified"] == 1
    assert b"\xff.ply" in (tmp_path / "out" / "summary.csv").read_bytes()
    assert sp.batch(tmp_path / "in", tmp_path / "out", workers=1).skipped == 1


# --- exit codes across the commands --------------------------------------------------

def non_manifold(path: Path) -> Path:
    """Three triangles on one edge: a mesh no command can do."""
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], dtype=float)
    faces = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    sp.save(sp.Mesh(vertices, faces), path)
    return path


COMMANDS = ["check", "orient", "map", "harmonics", "remesh", "texture", "morph"]


def rest(command: str, folder: Path) -> List[str]:
    """The arguments after MESH that ``command`` needs."""
    if command == "check":
        return []
    out = ["-o", str(folder / ("out.obj" if command == "texture" else "out.ply"))]
    return out + (["--target-dataset", "icosphere"] if command == "morph" else [])


@pytest.mark.parametrize("command", COMMANDS)
def test_a_mesh_that_cannot_be_done_exits_1_in_every_command(tmp_path: Path,
                                                            command: str) -> None:
    # Before: orient (and the applications) exited 2, the code for bad
    # arguments, on a non-manifold mesh.
    mesh = str(non_manifold(tmp_path / "bad.ply"))
    assert cli.main([command, mesh, *rest(command, tmp_path)]) == 1


@pytest.mark.parametrize("command", COMMANDS)
def test_an_unreadable_mesh_or_a_bad_argument_exits_2_in_every_command(tmp_path: Path,
                                                                       command: str) -> None:
    garbage = tmp_path / "garbage.obj"
    garbage.write_text("v 0 0 0\nf 1 2 3 4 5\n")
    out = rest(command, tmp_path)
    assert cli.main([command, str(garbage), *out]) == 2
    assert cli.main([command, str(tmp_path / "missing.ply"), *out]) == 2
    with pytest.raises(SystemExit) as info:
        cli.main([command, "--dataset", "icosphere", "--n-vertices", "x", *out])
    assert info.value.code == 2
