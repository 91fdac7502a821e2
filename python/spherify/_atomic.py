"""Crash-safe file replacement for the writers that live in Python (``.npz``,
FreeSurfer, GIfTI, ``.spheremap.npz``, the batch's outputs), the same way the
core writes its formats (``crates/mesh/src/io/atomic.rs``): write a temporary
file beside the target, sync it, rename it over the target. A rename within
one folder is atomic, so readers (and a rerun after a crash) see the old file
or the new one, never half of one.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import Callable, Union

PathLike = Union[str, "os.PathLike[str]"]

# Distinguishes temporary files of concurrent writes from one process.
_COUNTER = itertools.count()

#: Every temporary name starts with this prefix and contains ``.tmp-``, so
#: that leftovers of a killed process are recognisable (``is_temporary``).
TEMP_MARK = ".tmp-"


def temporary_path(path: Path) -> Path:
    """``dir/.name.tmp-PID-N`` beside ``path``: same file system, so the final
    rename is atomic; hidden, so a folder scan does not take it for an input."""
    return path.with_name(f".{path.name}{TEMP_MARK}{os.getpid()}-{next(_COUNTER)}")


def is_temporary(path: Path) -> bool:
    """Whether ``path`` is a temporary file of :func:`write_atomically`."""
    return path.name.startswith(".") and TEMP_MARK in path.name


def write_atomically(path: PathLike, fill: Callable[[Path], None]) -> None:
    """Call ``fill(temporary)`` to write the file, sync it, rename it to ``path``.

    On any error the temporary file is removed and the error propagates; an
    existing file at ``path`` is then left as it was.
    """
    target = Path(os.fspath(path))
    temporary = temporary_path(target)
    try:
        fill(temporary)
        # Without the sync a power loss after the rename could leave an empty file.
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, target)
    finally:
        if temporary.exists():
            temporary.unlink()
