"""Progress reports of the slow graph poles (thesis 6.2.2): a callable, a text
bar, and exceptions raised by the callable reaching the caller."""

from __future__ import annotations

import io
import threading
from pathlib import Path
from typing import List, Tuple

import pytest

import spherify as sp
from spherify import cli
from spherify._progress import TextProgress


def test_callable_sees_increasing_counts_ending_at_total() -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=1000)
    calls: List[Tuple[int, int]] = []
    m = sp.embed(mesh, method="theta_phi", poles="graph",
                 progress=lambda done, total: calls.append((done, total)))
    assert m.tp_valid
    done = [d for d, _ in calls]
    assert {t for _, t in calls} == {mesh.n_vertices}
    assert done == sorted(set(done)) and done[-1] == mesh.n_vertices and done[0] >= 1
    assert 10 <= len(calls) <= 101  # throttled to about one call per 1%
    # The same poles as without a callable.
    assert m.poles == sp.embed(mesh, method="theta_phi", poles="graph").poles


class Stop(Exception):
    pass


@pytest.fixture(scope="module")
def mesh_2000() -> sp.Mesh:
    """A mesh whose graph poles take 2,000 sources (a second or so)."""
    return sp.datasets.bumpy_blob(n_vertices=2000)


@pytest.mark.parametrize("error", [Stop, KeyboardInterrupt])
def test_an_exception_in_the_callable_stops_the_search(error: type, mesh_2000: sp.Mesh) -> None:
    # Every claim is in work units (the sources the callable was told about)
    # and Python objects, none in seconds or OS threads: a loaded machine
    # cannot change them.
    calls: List[Tuple[int, int]] = []
    threads_before = set(threading.enumerate())

    def callback(done: int, total: int) -> None:
        calls.append((done, total))
        if len(calls) == 3:
            raise error("enough")

    with pytest.raises(error, match="enough"):
        sp.embed(mesh_2000, method="theta_phi", poles="graph", progress=callback)
    # The exception reached the caller after the third call, and the callable
    # was not called again: not by a worker still running, nor to report the end.
    assert len(calls) == 3
    done, total = calls[-1]
    assert total == mesh_2000.n_vertices
    # Raised well before the end: about 3% in, as calls come every 1% of the
    # sources (the margin is for the sources other workers finish meanwhile).
    assert done < total // 2, calls
    # The interpreter is fine afterwards, no Python thread was left behind,
    # and nothing calls the callable late.
    assert sp.embed(mesh_2000, method="theta_phi", poles="fast_graph").tp_valid
    assert set(threading.enumerate()) <= threads_before
    assert len(calls) == 3


def test_true_draws_a_bar_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    sp.embed(sp.datasets.icosphere(subdivisions=2), method="theta_phi", poles="graph", progress=True)
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
    sp.embed(sp.datasets.icosphere(subdivisions=1), method="theta_phi", poles="graph", progress=value)
    assert capsys.readouterr().err == ""


def test_bad_progress_value_raises() -> None:
    with pytest.raises(sp.MeshError, match="progress"):
        sp.embed(sp.datasets.icosphere(subdivisions=1), method="theta_phi", poles="graph", progress=3)
    with pytest.raises(sp.MeshError, match="progress"):
        sp._core.embed(sp.datasets.icosphere(subdivisions=1)._core, "theta_phi", {"poles": "graph"}, 3)


def test_cli_progress_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.ply"
    code = cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--method", "theta_phi",
                     "--poles", "graph", "--progress", "-o", str(out)])
    assert code == 0
    assert "graph poles [" in capsys.readouterr().err
    # Without the flag, and with stderr not a terminal, nothing is drawn.
    assert cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--method", "theta_phi",
                     "--poles", "graph", "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""


# --- the iterative methods and the applications (issue 24, item 4) ------------

@pytest.mark.parametrize("method", ["relaxation", "alexa", "gotsman"])
def test_iterative_methods_report_their_iterations(method: str) -> None:
    mesh = sp.datasets.bumpy_blob(n_vertices=500)
    calls: List[Tuple[int, int]] = []
    m = sp.embed(mesh, method, progress=lambda done, total: calls.append((done, total)))
    assert calls, f"{method} reported nothing"
    (total,) = {t for _, t in calls}
    done = [d for d, _ in calls]
    assert done == sorted(set(done)) and done[-1] == total  # ends at the end
    assert m.iterations <= total
    # the same bits as without a callable
    assert (m.points == sp.embed(mesh, method).points).all()


def test_applications_report_the_points_they_locate(monkeypatch: pytest.MonkeyPatch) -> None:
    from spherify import _progress

    monkeypatch.setattr(_progress, "CHUNK_ROWS", 500)  # several pieces on a small mesh
    m = sp.embed(sp.datasets.bumpy_blob(n_vertices=800))
    target = sp.embed(sp.datasets.ellipsoid(n_vertices=600))

    def counted(call: object) -> List[Tuple[int, int]]:
        calls: List[Tuple[int, int]] = []
        assert callable(call)
        call(lambda done, total: calls.append((done, total)))
        return calls

    for run, total in [
        (lambda p: sp.remesh(m, level=3, progress=p), 642),
        (lambda p: sp.geometry_image(m, 33, progress=p), 33 * 33),
    ]:
        calls = counted(run)
        assert len(calls) > 1 and calls[-1] == (total, total)
        assert [d for d, _ in calls] == sorted({d for d, _ in calls})
    # A morph reports its registration's stages (sp.register), ending at the total.
    calls = counted(lambda p: sp.morph(m, target, align="warp", progress=p))
    assert len(calls) > 2 and calls[-1][0] == calls[-1][1]
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)
    # the same arrays as in one piece
    assert (sp.morph(m, target, progress=lambda d, t: None).end
            == sp.morph(m, target).end).all()
    assert (sp.geometry_image(m, 33, progress=True) == sp.geometry_image(m, 33)).all()
    layout = sp.texture.uv(m)
    rows: List[Tuple[int, int]] = []
    image = layout.bake(sp.datasets.checkerboard, 100,
                        progress=lambda done, total: rows.append((done, total)))
    assert rows[-1] == (100, 100) and len(rows) == 2  # 64 rows a piece
    assert (image == layout.bake(sp.datasets.checkerboard, 100)).all()


def test_harmonics_report_rings_and_orders() -> None:
    m = sp.embed(sp.datasets.bumpy_blob(n_vertices=800))
    calls: List[Tuple[int, int]] = []
    lmax = 40
    c = sp.harmonics.fit(m, lmax, progress=lambda done, total: calls.append((done, total)))
    total = 2 * (lmax + 1) + lmax + 1  # rings sampled, rings summed, orders
    assert {t for _, t in calls} == {total} and calls[-1] == (total, total)
    done = [d for d, _ in calls]
    assert done == sorted(set(done)) and len(calls) > 10
    assert (c.coefficients == sp.harmonics.fit(m, lmax).coefficients).all()
