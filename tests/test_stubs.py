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
