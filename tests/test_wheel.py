"""The binary wheel (issue 24, item 1): one abi3 wheel (CPython 3.9 and
later), installed into a fresh virtual environment whose PATH has no Rust
toolchain, runs README's main job.

The wheel is built by ``.ci/run`` (``maturin build --profile wheel --zig``, in
a target folder of its own) and named by the environment
variable ``SPHERIFY_WHEEL``; without it this test is skipped, so the default
run stays fast.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Optional

import pytest

WHEEL = os.environ.get("SPHERIFY_WHEEL")
#: The oldest CPython the abi3 wheel is for, this one, and the newest tried.
PYTHONS = ["python3.9", "current", "python3.13"]


def interpreter(name: str) -> Optional[str]:
    """The interpreter called ``name`` that runs: pyenv's own builds first
    (its shims refuse a version that is not selected), then PATH's."""
    if name == "current":
        return sys.executable
    pyenv = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv")) / "versions"
    candidates = [str(p) for p in sorted(pyenv.glob(f"{name[6:]}*/bin/{name}"))]
    candidates.append(shutil.which(name) or "")
    for candidate in filter(None, candidates):
        if subprocess.run([candidate, "-c", "import venv"], capture_output=True,
                          timeout=60).returncode == 0:
            return candidate
    return None


@pytest.mark.skipif(not WHEEL, reason="SPHERIFY_WHEEL names no built wheel (.ci/run sets it)")
@pytest.mark.timeout(600)
@pytest.mark.parametrize("python", PYTHONS)
def test_the_wheel_installs_without_rust_and_runs_the_main_job(tmp_path: Path,
                                                               python: str) -> None:
    wheel = Path(str(WHEEL))
    assert wheel.is_file(), wheel
    assert "-cp39-abi3-" in wheel.name, f"not an abi3 wheel for 3.9+: {wheel.name}"
    executable = interpreter(python)
    if executable is None:
        pytest.skip(f"no {python} on PATH")
    env_dir = tmp_path / "venv"
    # no system site packages: numpy comes from PyPI
    subprocess.run([executable, "-m", "venv", str(env_dir)], check=True, timeout=300)
    bin_dir = env_dir / "bin"
    path = os.pathsep.join([str(bin_dir), "/usr/local/bin", "/usr/bin", "/bin"])
    assert shutil.which("cargo", path=path) is None and shutil.which("rustc", path=path) is None
    env = {"PATH": path, "HOME": str(tmp_path), "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
    for key in ("LANG", "OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE"):
        if key in os.environ:
            env[key] = os.environ[key]

    def run(*argv: str) -> str:
        done = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=500)
        assert done.returncode == 0, done.stdout + done.stderr
        return done.stdout

    run(str(bin_dir / "python"), "-m", "pip", "install", "-q", str(wheel))
    where = run(str(bin_dir / "python"), "-c",
                "import sys, spherify._core as c; print(c.__file__, sys.version_info[:2])")
    assert ".abi3.so" in where and str(env_dir) in where
    out = run(str(bin_dir / "spherify"), "map", "--dataset", "helix_tube", "--n-vertices",
              "20000", "-o", "helix_sphere.ply")
    assert "valid" in out
    assert (tmp_path / "helix_sphere.ply").is_file()
    print(f"{wheel.name}: {wheel.stat().st_size / 1e6:.1f} MB; {where.strip()}")
