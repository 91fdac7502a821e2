"""The documented size bounds of the applications (issue 26, finding 5):
refused before anything is allocated above them, and working under a 4 GB
address-space limit at them (an error or a result, never a signal)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import List

import numpy as np
import pytest

import spherify as sp
from spherify import cli
from spherify._limits import (ATLAS_HEIGHT_MAX, DISTANCE_SAMPLES_MAX, GEOMETRY_IMAGE_SIZE_MAX,
                              MORPH_FRAMES_MAX, REMESH_LEVEL_MAX)

from _child import child_env

FOUR_GB = 4 * 2**30


@pytest.fixture(scope="module")
def small() -> sp.SphereMap:
    return sp.embed(sp.datasets.ellipsoid(300))


def test_one_above_each_bound_is_refused_by_name(small: sp.SphereMap) -> None:
    with pytest.raises(sp.MeshError, match=f"level must be an integer in 0..{REMESH_LEVEL_MAX}"):
        sp.remesh(small, level=REMESH_LEVEL_MAX + 1)
    with pytest.raises(sp.MeshError, match="size must be an"):
        sp.geometry_image(small, GEOMETRY_IMAGE_SIZE_MAX + 2)
    layout = sp.texture.uv(small, "cube")
    with pytest.raises(sp.MeshError, match="height must be an integer"):
        layout.bake(sp.datasets.checkerboard, ATLAS_HEIGHT_MAX + 1)
    with pytest.raises(sp.MeshError, match="height must be an integer"):
        layout.bake(sp.datasets.checkerboard, 10.5)  # type: ignore[arg-type]
    with pytest.raises(sp.MeshError, match="width must be an integer"):
        layout.bake(sp.datasets.checkerboard, 16, width=2 * ATLAS_HEIGHT_MAX + 1)
    with pytest.raises(sp.MeshError, match="samples must be an integer"):
        sp.surface_distance(small, small, samples=DISTANCE_SAMPLES_MAX + 1)


@pytest.mark.parametrize("argv", [
    ["texture", "--size", str(ATLAS_HEIGHT_MAX + 1), "-o", "{out}/x.obj"],
    ["morph", "--target-dataset", "ellipsoid", "--frames", str(MORPH_FRAMES_MAX + 1),
     "-o", "{out}/f.obj"],
    ["remesh", "--samples", str(DISTANCE_SAMPLES_MAX + 1), "-o", "{out}/r.obj"],
    ["remesh", "--level", str(REMESH_LEVEL_MAX + 1), "-o", "{out}/r.obj"],
    ["remesh", "--geometry-image", str(GEOMETRY_IMAGE_SIZE_MAX + 2), "-o", "{out}/r.obj"],
])
def test_the_command_line_refuses_them_with_status_2(argv: List[str], tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    words = [w.format(out=tmp_path) for w in argv]
    assert cli.main(words[:1] + ["--dataset", "ellipsoid", "--n-vertices", "200"] + words[1:]) == 2
    assert "must be" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
import spherify as sp
m = sp.embed(sp.datasets.ellipsoid(300))
for name in sys.argv[1:]:
    try:
        if name == "remesh":
            sp.remesh(m, level={level})
        elif name == "geometry_image":
            sp.geometry_image(m, {size})
        elif name == "bake":
            sp.texture.uv(m, "cube").bake(sp.datasets.checkerboard, {height})
        elif name == "harmonics":
            sp.harmonics.fit(m, 2000)
        print(name, "ok", flush=True)
    except sp.SpherifyError as err:
        print(name, type(err).__name__, flush=True)
"""


def run_limited(names: List[str]) -> List[str]:
    code = CHILD.format(limit=FOUR_GB, level=REMESH_LEVEL_MAX, size=GEOMETRY_IMAGE_SIZE_MAX,
                        height=ATLAS_HEIGHT_MAX)
    done = subprocess.run([sys.executable, "-c", code, *names], env=child_env(),
                          capture_output=True, text=True, timeout=900)
    # A signal (an abort on a failed allocation) is a negative return code.
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    return done.stdout.split("\n")[:-1]


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_the_largest_remesh_and_geometry_image_fit_in_4_gb() -> None:
    assert run_limited(["remesh", "geometry_image"]) == ["remesh ok", "geometry_image ok"]


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_the_largest_atlas_and_harmonic_fit_fit_in_4_gb() -> None:
    assert run_limited(["bake", "harmonics"]) == ["bake ok", "harmonics ok"]


def test_limits_are_what_the_docs_say() -> None:
    from spherify import _limits
    doc = _limits.__doc__ or ""
    for value in (REMESH_LEVEL_MAX, GEOMETRY_IMAGE_SIZE_MAX, ATLAS_HEIGHT_MAX, MORPH_FRAMES_MAX):
        assert f"| {value} |" in doc
    assert np.isfinite(DISTANCE_SAMPLES_MAX)
