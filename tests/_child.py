"""What the tests that run spherify in a child process share."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Dict

import spherify as sp


def child_env() -> Dict[str, str]:
    """The environment for a child Python that imports the same spherify as
    this process (the build under test, wherever it was imported from)."""
    env = dict(os.environ)
    package_root = str(Path(sp.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([package_root, env.get("PYTHONPATH", "")])
    env["PYTHONUNBUFFERED"] = "1"
    return env
