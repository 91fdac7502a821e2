"""Crash-safe file replacement for the writers that live in Python (``.npz``,
FreeSurfer, GIfTI, ``.spheremap.npz``, PNG, the batch's outputs), by the
core's atomic writer (``crates/mesh/src/io/atomic.rs``), which owns every
rule: the temporary's name (``.name.tmp-PID-N`` beside the target), the
removal of dead writers' temporaries, the sync and the rename, links
followed and the mode kept, devices and pipes written into, anything else
that is not a regular file refused. This module only adapts it to writers
that fill a file by its name.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Union

from . import _core
from ._errors import as_file_error

PathLike = Union[str, "os.PathLike[str]"]


def temporary_path(path: Path) -> Path:
    """A temporary name beside ``path`` (same file system, hidden), by the
    core's rule; for writers that rename it themselves (the batch)."""
    return _core.temporary_path(path)


def is_temporary(path: Path) -> bool:
    """Whether ``path`` is named as a temporary file of the atomic writer."""
    return _core.is_temporary(path.name)


def is_stale_temporary(path: Path) -> bool:
    """Whether ``path`` is a temporary file whose writer no longer runs: a
    killed run's leftover, safe to remove (Linux, where /proc tells)."""
    return _core.is_stale_temporary(path.name)


def remove_stale_temporaries(folder: Path) -> None:
    """Remove from ``folder`` the temporaries of writers that no longer run."""
    _core.remove_stale_temporaries(folder)


def write_bytes_atomically(path: PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` with the core's atomic writer (the one
    ``sp.save`` uses for OBJ, OFF, PLY and STL)."""
    _core.write_atomic(os.fspath(path), data)


def write_atomically(path: PathLike, fill: Callable[[Path], None]) -> None:
    """Call ``fill(temporary)`` to write the file, then have the core put it
    in place (:class:`spherify._core.AtomicWrite`).

    On any error the temporary file is removed and the error propagates; an
    existing file at ``path`` is then left as it was. For a character device
    or a pipe at ``path``, ``fill`` writes a scratch file whose bytes the
    core copies in.
    """
    write = _core.AtomicWrite(os.fspath(path))
    temporary = write.temporary
    try:
        fill(temporary)
    except OSError as err:
        write.discard()
        # The temporary name means nothing to the caller: name the target.
        if err.errno is not None and err.filename in (str(temporary), temporary):
            raise as_file_error(OSError(err.errno, err.strerror, os.fspath(path))) from None
        raise
    except BaseException:
        write.discard()
        raise
    write.commit()
