"""What the Python side does with the paths it is given, by the core's own
checks (``crates/mesh/src/io``):

* Only regular files are read. Opening a FIFO for reading waits until some
  process writes to it, and a device such as ``/dev/zero`` never ends; both
  are refused with a :class:`FormatError` that says what the path is.
* What the operating system refuses (a missing file, a folder, no
  permission) is raised as a :class:`FileError`: a :class:`SpherifyError`
  and the builtin ``OSError`` subclass of its cause at once
  (:func:`file_errors`).

Writing is in :mod:`spherify._atomic`.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path
from typing import Any, Callable, Optional, TypeVar, cast

from . import _core
from ._errors import as_file_error

Function = TypeVar("Function", bound=Callable[..., Any])


def special_kind(path: Path) -> Optional[str]:
    """What is at ``path`` (links followed), in words, when it is neither a
    regular file nor a folder (None for those and for nothing at all): the
    core's words, which its readers and writers use too."""
    return _core.special_kind(path)


def require_regular_file(path: Path) -> None:
    """Refuse to read ``path`` unless it is a regular file (links followed),
    with the core's check: a :class:`FormatError` saying what it is.

    Looked at with ``stat``, which does not open it: a FIFO would block the
    open. A missing file or a folder is left to the open that follows, which
    raises ``FileNotFoundError`` / ``IsADirectoryError``.
    """
    _core.require_regular_file(path)


def file_sha256(path: "os.PathLike[str] | str") -> str:
    """SHA-256 of the bytes of the file at ``path``, as 64 hex digits (read
    in blocks of 1 MiB, so a large file is never held whole)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_errors(function: Function) -> Function:
    """Decorate a public call that touches files: a builtin ``OSError`` from
    Python's own file calls leaves it as a :class:`FileError` (which still is
    that builtin, so callers catching ``FileNotFoundError`` see no change)."""
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return function(*args, **kwargs)
        except OSError as err:
            converted = as_file_error(err)
            if converted is err:
                raise
            raise converted.with_traceback(err.__traceback__) from None
    return cast(Function, wrapper)
