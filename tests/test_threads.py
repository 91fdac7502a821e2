"""sp.set_num_threads / sp.get_num_threads and --threads (issue 24, item 8):
the pool's size changes, the results do not."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pytest

import spherify as sp
from spherify import cli


@pytest.fixture(autouse=True)
def default_threads_after() -> Iterator[None]:
    yield
    sp.set_num_threads(None)


def test_the_pool_takes_the_count_asked_for_and_the_bits_do_not_change() -> None:
    mesh = sp.datasets.make("tentacles", 3000)
    sp.set_num_threads(1)
    assert sp.get_num_threads() == 1
    one = sp.embed(mesh)
    sp.set_num_threads(3)
    assert sp.get_num_threads() == 3
    three = sp.embed(mesh)
    np.testing.assert_array_equal(one.points, three.points)
    assert one.valid and three.valid
    sp.set_num_threads(None)
    default = int(os.environ.get("RAYON_NUM_THREADS", "0")) or os.cpu_count()
    assert sp.get_num_threads() == default


@pytest.mark.parametrize("bad", [0, -1, True, 2.5, "2", 10**6])
def test_a_count_that_is_not_a_whole_number_of_threads_is_refused(bad: Any) -> None:
    with pytest.raises(sp.MeshError, match="n must be an integer"):
        sp.set_num_threads(bad)


def test_the_command_line_takes_threads(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.ply"
    assert cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--threads", "1",
                     "-o", str(out)]) == 0
    assert sp.get_num_threads() == (int(os.environ.get("RAYON_NUM_THREADS", "0"))
                                    or os.cpu_count())  # main() restores the default
    assert cli.main(["map", "--dataset", "icosphere", "--n-vertices", "200", "--threads", "0",
                     "-o", str(out)]) == 2
    assert "n must be an integer" in capsys.readouterr().err
