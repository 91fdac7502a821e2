"""Progress reports of the slow graph poles (thesis 6.2.2): a callable, a text
bar, and exceptions raised by the callable reaching the caller."""

from __future__ import annotations

import io
import threading
import time
from pathlib import Path
from typing import List, Tuple

import pytest

import spherify as sp
from spherify._progress import TextProgress

cli = pytest.importorskip("spherify.cli")


def test_callable_sees_increasing_counts_ending_at_total() -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=1000)
    calls: List[Tuple[int, int]] = []
    m = sp.embed(mesh, poles="graph", progress=lambda done, total: calls.append((done, total)))
    assert m.tp_valid
    done = [d for d, _ in calls]
    assert {t for _, t in calls} == {mesh.n_vertices}
    assert done == sorted(set(done)) and done[-1] == mesh.n_vertices and done[0] >= 1
    assert 10 <= len(calls) <= 101  # throttled to about one call per 1%
    # The same poles as without a callable.
    assert m.poles == sp.embed(mesh, poles="graph").poles


class Stop(Exception):
    pass


@pytest.fixture(scope="module")
def timed_mesh() -> Tuple[sp.Mesh, float]:
    """A mesh and the seconds its graph poles take without a callable."""
    mesh = sp.datasets.bumpy_blob(n_vertices=2000)
    start = time.perf_counter()
    sp.embed(mesh, poles="graph")
    return mesh, time.perf_counter() - start


@pytest.mark.parametrize("error", [Stop, KeyboardInterrupt])
def test_an_exception_in_the_callable_stops_the_search(error: type,
                                                        timed_mesh: Tuple[sp.Mesh, float]) -> None:
    mesh, full = timed_mesh
    calls: List[int] = []

    def callback(done: int, total: int) -> None:
        calls.append(done)
        if len(calls) == 3:
            raise error("enough")

    start = time.perf_counter()
    with pytest.raises(error, match="enough"):
        sp.embed(mesh, poles="graph", progress=callback)
    stopped = time.perf_counter() - start
    # Called no more after raising, and the search ended early: about 3% of
    # the sources ran (the margin is for a busy machine).
    assert len(calls) == 3
    assert stopped < full / 3, (stopped, full)
    # The interpreter is fine afterwards, and no worker is left running.
    assert threading.active_count() == 1
    assert sp.embed(mesh, poles="fast_graph").tp_valid


def test_true_draws_a_bar_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    sp.embed(sp.datasets.icosphere(2), poles="graph", progress=True)
    err = capsys.readouterr().err
    assert err.startswith("\rgraph poles [")
    assert "[" + "#" * 30 + "] 100%  162/162  " in err and err.endswith(" s\n")


def test_text_bar_redraws_at_most_20_times_a_second() -> None:
    out = io.StringIO()
    bar = TextProgress("x", stream=out)
    for done in range(1, 1001):
        bar(done, 1000)
    lines = out.getvalue().split("\r")[1:]
    assert len(lines) <= 3  # the first, perhaps one more, and the last
    assert lines[-1].startswith("x [" + "#" * 30 + "] 100%  1000/1000")


@pytest.mark.parametrize("value", [False, None])
def test_false_and_none_are_silent(value: object, capsys: pytest.CaptureFixture[str]) -> None:
    sp.embed(sp.datasets.icosphere(1), poles="graph", progress=value)
    assert capsys.readouterr().err == ""


def test_bad_progress_value_raises() -> None:
    with pytest.raises(sp.MeshError, match="progress"):
        sp.embed(sp.datasets.icosphere(1), poles="graph", progress=3)
    with pytest.raises(sp.MeshError, match="progress"):
        sp._core.embed_theta_phi(sp.datasets.icosphere(1)._core, poles="graph", progress=3)


def test_cli_progress_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.ply"
    code = cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--poles", "graph",
                     "--progress", "-o", str(out)])
    assert code == 0
    assert "graph poles [" in capsys.readouterr().err
    # Without the flag, and with stderr not a terminal, nothing is drawn.
    assert cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--poles", "graph",
                     "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""
