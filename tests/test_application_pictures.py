"""benches/applications.py, the pictures of docs/applications.md, runs at
small size (so that the script cannot rot) and writes PNGs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benches" / "applications.py"


def test_the_pictures_script_runs_small(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    result = subprocess.run([sys.executable, str(SCRIPT), "--small", "--out", str(tmp_path)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    pictures = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pictures, result.stdout
    for p in tmp_path.glob("*.png"):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 5000
