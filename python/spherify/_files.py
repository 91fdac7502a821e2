"""What the Python side does with the paths it is given, as the core does for
its own formats (``crates/mesh/src/io``):

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
import os
import stat
from pathlib import Path
from typing import Any, Callable, Optional, TypeVar, cast

from ._errors import FormatError, as_file_error

Function = TypeVar("Function", bound=Callable[..., Any])


def special_kind(mode: int) -> Optional[str]:
    """What a file of ``os.stat`` mode ``mode`` is, in words, when it is
    neither a regular file nor a folder (None for those)."""
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def require_regular_file(path: Path) -> None:
    """Refuse to read ``path`` unless it is a regular file (links followed).

    Looked at with ``stat``, which does not open it: a FIFO would block the
    open. A missing file or a folder is left to the open that follows, which
    raises ``FileNotFoundError`` / ``IsADirectoryError``.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    what = special_kind(mode)
    if what is not None:
        raise FormatError(f"{path}: this is {what}, not a regular file: only regular files "
                          "are read", str(path))


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
