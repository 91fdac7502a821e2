"""The type stubs of the Rust extension match what it exports (STYLE 9)."""

import subprocess
import sys

import pytest


def test_core_stubs_match_the_extension() -> None:
    pytest.importorskip("mypy")
    result = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "spherify._core"],
        capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_dir_of_the_package_and_its_submodules_shows_only_public_names() -> None:
    # Issue 24, item 8: sp.harmonics.np and friends showed in dir().
    import spherify as sp
    for module in [sp, sp.harmonics, sp.texture, sp.plot, sp.datasets]:
        assert dir(module) == sorted(module.__all__), module.__name__
        assert all(hasattr(module, name) for name in module.__all__), module.__name__
