"""Crash-safe file replacement for the writers that live in Python (``.npz``,
FreeSurfer, GIfTI, ``.spheremap.npz``, the batch's outputs), the same way the
core writes its formats (``crates/mesh/src/io/atomic.rs``): write a temporary
file beside the target, sync it, rename it over the target. A rename within
one folder is atomic, so readers (and a rerun after a crash) see the old file
or the new one, never half of one. As in the core, a symbolic link at the
target is followed (the link stays a link), the new file keeps the mode of
the one it replaces, and a target that is not a regular file is never
replaced: a character device (``/dev/null``) or a pipe that a process reads
is written straight into, a pipe without a reader is refused at once (a
write would wait for one), a folder is an ``IsADirectoryError``, anything
else is refused. Writers that have their bytes in memory use the core's
writer itself (``_core.write_atomic``).
"""

from __future__ import annotations

import errno
import itertools
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Callable, Optional, Union

from . import _core
from ._errors import FormatError, as_file_error
from ._files import special_kind

PathLike = Union[str, "os.PathLike[str]"]

# Distinguishes temporary files of concurrent writes from one process.
_COUNTER = itertools.count()

#: Every temporary name starts with this prefix and contains ``.tmp-``, so
#: that leftovers of a killed process are recognisable (``is_temporary``).
TEMP_MARK = ".tmp-"


#: Bytes of the target's name its temporary's name keeps (as the core's
#: writer, ``io/atomic.rs``): with the dot and ``.tmp-PID-N`` it stays within
#: the 255 bytes a name may have, so a legal target name is never refused for
#: its temporary's.
TEMP_NAME_KEPT = 200


def temporary_path(path: Path) -> Path:
    """``dir/.name.tmp-PID-N`` beside ``path``: same file system, so the final
    rename is atomic; hidden, so a folder scan does not take it for an input.
    ``name`` is cut to :data:`TEMP_NAME_KEPT` bytes (PID-N keeps it unique)."""
    name = os.fsdecode(os.fsencode(path.name)[:TEMP_NAME_KEPT])
    return path.with_name(f".{name}{TEMP_MARK}{os.getpid()}-{next(_COUNTER)}")


def is_temporary(path: Path) -> bool:
    """Whether ``path`` is a temporary file of :func:`write_atomically`."""
    return path.name.startswith(".") and TEMP_MARK in path.name


def is_stale_temporary(path: Path) -> bool:
    """Whether ``path`` is a temporary file whose writer no longer runs (the
    process id in ``.name.tmp-PID-N``): a killed run's leftover, safe to
    remove. Another process's write in progress is not (the core's writer
    tells them apart the same way)."""
    if not is_temporary(path):
        return False
    pid, _, counter = path.name.rpartition(TEMP_MARK)[2].partition("-")
    if not (pid.isdigit() and counter.isdigit()):
        return False
    return not process_is_running(int(pid))


def process_is_running(pid: int) -> bool:
    """Whether process ``pid`` still runs. A zombie has ended: it only waits
    for its parent to collect its exit status, which an orphan's new parent
    (PID 1 of a container, for one) may never do; ``os.kill(pid, 0)`` still
    succeeds on it, so Linux's ``/proc/PID/stat`` decides where it exists."""
    try:
        stat_line = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        if Path("/proc/self/stat").exists():
            return False  # Linux: no such process
    except OSError:
        pass
    else:
        # "PID (command) STATE ...": the command may hold ") " itself.
        state = stat_line.rpartition(")")[2].split()[:1]
        return state not in (["Z"], ["X"])
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True  # alive under another user, or not a process id we can ask about
    return True


def write_bytes_atomically(path: PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` with the core's atomic writer (the one
    ``sp.save`` uses for OBJ, OFF, PLY and STL)."""
    _core.write_atomic(os.fspath(path), data)


def write_atomically(path: PathLike, fill: Callable[[Path], None]) -> None:
    """Call ``fill(temporary)`` to write the file, sync it, rename it to ``path``.

    On any error the temporary file is removed and the error propagates; an
    existing file at ``path`` is then left as it was. A character device or a
    pipe at ``path`` gets the bytes ``fill`` wrote into a scratch file.
    """
    target = Path(os.fspath(path))
    stream = _open_stream_target(target)
    if stream is not None:
        try:
            _fill_stream(stream, fill)
        finally:
            os.close(stream)
        return
    target = Path(os.path.realpath(target))
    try:
        mode: Optional[int] = stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        mode = None
    temporary = temporary_path(target)
    try:
        fill(temporary)
        if mode is not None:
            os.chmod(temporary, mode)
        # Without the sync a power loss after the rename could leave an empty file.
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, target)
    except OSError as err:
        # The temporary name means nothing to the caller: name the target.
        if err.errno is not None and err.filename in (str(temporary), temporary):
            raise as_file_error(OSError(err.errno, err.strerror, os.fspath(path))) from None
        raise
    finally:
        if temporary.exists():
            temporary.unlink()


def _fill_stream(stream: int, fill: Callable[[Path], None]) -> None:
    """``fill`` a scratch file, then copy it into the open ``stream``: the
    writers seek (a zip archive's directory points back into it), which a
    pipe cannot and ``/dev/null`` only pretends to."""
    with tempfile.TemporaryDirectory(prefix="spherify-") as folder:
        scratch = Path(folder) / "stream"
        fill(scratch)
        with open(scratch, "rb") as source, os.fdopen(stream, "wb", closefd=False) as sink:
            shutil.copyfileobj(source, sink, 1 << 20)


def _open_stream_target(path: Path) -> Optional[int]:
    """None when ``path`` (links followed) is a regular file or nothing yet,
    which is replaced atomically. For a character device or a pipe, a file
    descriptor open for writing on it, which the write goes through.

    A pipe is opened non-blocking: with no reader that fails at once (a
    blocking open would wait for one), then made blocking for the write.
    Raises IsADirectoryError for a folder and FormatError for anything else.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(path))
    if stat.S_ISCHR(mode):
        return os.open(path, os.O_WRONLY)
    if stat.S_ISFIFO(mode):
        try:
            pipe = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as err:
            if err.errno == errno.ENXIO:
                raise FormatError(f"{path}: this is a pipe that no process is reading: "
                                  "writing would wait for one", str(path)) from None
            raise
        os.set_blocking(pipe, True)
        return pipe
    what = "a block device" if stat.S_ISBLK(mode) else special_kind(mode)
    raise FormatError(f"{path}: this is {what}: only regular files (replaced atomically), "
                      "character devices such as /dev/null and pipes are written", str(path))
