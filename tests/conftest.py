"""Shared test configuration: hypothesis profiles and the real-mesh corpus.

Hypothesis profiles (STYLE 13), chosen by the environment variable
``HYPOTHESIS_PROFILE``:

* ``fast`` (default): few examples, for the edit-test loop;
* ``ci``: more examples, derandomized so that a CI run is reproducible;
* ``slow``: many examples, on demand.

The corpus of real meshes lives beside the repository clone in
``../shared/meshes`` (with ``MANIFEST.json``); ``SPHERIFY_SHARED_MESHES`` points
elsewhere. Tests that need it take the ``shared_meshes`` fixture or the
``valid_corpus_entry`` / ``invalid_corpus_entry`` parameters, and skip, saying
why, when it is absent.
"""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path
from typing import Any, Dict, List, Optional

import pytest
from hypothesis import HealthCheck, settings

# The Ctrl-C tests send SIGINT to children and expect KeyboardInterrupt there.
# A test run started in the background of a script (``cmd &``, nohup) ignores
# SIGINT, and an ignored signal stays ignored across exec: every child would
# ignore it too, and those tests would fail for the harness's sake. A Python
# handler here is reset to the default in each child by exec.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

settings.register_profile(
    "fast",
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "ci",
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,  # derandomized runs replay nothing and write no .hypothesis/
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "slow",
    max_examples=1000,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fast"))

#: Where the corpus is when the repository clone sits beside ``../shared``.
SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def shared_meshes_dir() -> Path:
    """The corpus folder: ``$SPHERIFY_SHARED_MESHES`` if set, else :data:`SHARED`."""
    env = os.environ.get("SPHERIFY_SHARED_MESHES")
    return Path(env) if env else SHARED


def _why_missing(root: Path) -> Optional[str]:
    if not (root / "MANIFEST.json").is_file():
        return (f"mesh corpus not found: no MANIFEST.json in {root} "
                "(set SPHERIFY_SHARED_MESHES to the folder of ../shared/meshes)")
    return None


def load_manifest(root: Path) -> List[Dict[str, Any]]:
    with open(root / "MANIFEST.json", encoding="utf-8") as f:
        return json.load(f)


@pytest.fixture(scope="session")
def shared_meshes() -> Path:
    """The corpus folder; skips the test when it is absent."""
    root = shared_meshes_dir()
    reason = _why_missing(root)
    if reason:
        pytest.skip(reason)
    return root


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrizes ``valid_corpus_entry`` and ``invalid_corpus_entry`` with the
    manifest entries of the valid meshes and of ``invalid/`` (each a dict, with
    the absolute file path added under ``"file"``)."""
    for name, want_invalid in (("valid_corpus_entry", False), ("invalid_corpus_entry", True)):
        if name not in metafunc.fixturenames:
            continue
        root = shared_meshes_dir()
        reason = _why_missing(root)
        if reason:
            metafunc.parametrize(name, [pytest.param(None, marks=pytest.mark.skip(reason=reason))],
                                 ids=["no-corpus"])
            continue
        entries = [dict(e, file=root / e["path"]) for e in load_manifest(root)
                   if e["path"].startswith("invalid/") == want_invalid]
        metafunc.parametrize(name, entries, ids=[e["path"] for e in entries])
