"""The exception hierarchy of spherify (DESIGN.md, "Errors").

Every failure a user can cause raises a subclass of :class:`SpherifyError`.
The Rust core raises these classes directly, so they are defined here once.
"""

from __future__ import annotations

import errno
from typing import Any, Dict, Optional, Type, cast


class SpherifyError(Exception):
    """Base class of every error spherify raises on purpose."""


class MeshError(SpherifyError, ValueError):
    """Bad mesh data: wrong shapes or dtypes, NaN or infinite coordinates,
    negative or out-of-range indices, empty arrays, bad arguments."""


class TopologyError(MeshError):
    """The mesh's topology does not allow the operation (not genus 0, holes,
    non-manifold, disconnected, not orientable). ``report`` holds the full
    :class:`~spherify.MeshReport`."""

    def __init__(self, message: str, report: Any = None) -> None:
        super().__init__(message)
        self.report = report


class FormatError(SpherifyError, ValueError):
    """A malformed or unsupported file. ``path`` names the file; ``line`` (text
    formats, 1-based) or ``offset`` (binary formats, bytes) says where."""

    def __init__(self, message: str, path: Optional[str] = None,
                 line: Optional[int] = None, offset: Optional[int] = None) -> None:
        super().__init__(message)
        self.path = path
        self.line = line
        self.offset = offset


class ConvergenceError(SpherifyError, RuntimeError):
    """An iterative method ran out of iterations. ``state`` carries the last
    iterate and residual so that callers can inspect or resume."""

    def __init__(self, message: str, state: Any = None) -> None:
        super().__init__(message)
        self.state = state


class MapError(SpherifyError, ValueError):
    """The map cannot answer the question: ``SphereMap.to_surface`` on a map
    that is not a certified bijection (a GC-embedding that fails the tests of
    thesis 3.4, or a theta-phi rectangle that double precision could not hold),
    where the preimage of a sphere point is not defined."""


class ResourceError(SpherifyError, MemoryError):
    """The call does not fit in the memory this process can have. Also a
    :class:`MemoryError`. Raised before the work starts when the call's
    estimate (``crates/sphere/src/memory_budget.rs``: measured bytes per
    vertex of each method and energy, with a margin) is more than the address
    space left under the process's ``RLIMIT_AS`` or the machine's available
    memory, and when an allocation of one of the core's large buffers fails.
    The message names the call, the vertex count, the bytes needed and the
    bytes available; ``bytes`` holds the bytes asked for and ``available``
    what was available (None for a failed allocation). The command line
    exits with status 1."""

    def __init__(self, message: str, bytes: Optional[int] = None,
                 available: Optional[int] = None) -> None:
        super().__init__(message)
        self.bytes = bytes
        self.available = available


class FileError(SpherifyError, OSError):
    """The operating system refused a file: missing, a folder, no permission,
    a full disk. Also an :class:`OSError`, and each instance is also the
    builtin subclass that names its cause (``FileNotFoundError``,
    ``PermissionError``, ``IsADirectoryError``, ...), so ``except
    FileNotFoundError`` works as usual. ``errno``, ``strerror`` and
    ``filename`` are set where the system said them.

    Made as ``FileError(errno, strerror, filename)`` (as the core raises
    it), it is the subclass of that errno, as ``OSError(errno, ...)`` is."""

    def __new__(cls, *args: Any) -> "FileError":
        if cls is FileError and len(args) >= 2 and isinstance(args[0], int):
            cls = _FILE_ERRORS.get(args[0], FileError)
        return super().__new__(cls, *args)


def _file_error_class(builtin: type) -> Type[FileError]:
    """``FileError`` that is also ``builtin``, kept as ``FileError.<builtin
    name>`` (where pickle finds it: batch workers send errors to the parent)."""
    name = builtin.__name__
    cls = type(name, (FileError, builtin), {
        "__module__": __name__,
        "__qualname__": f"FileError.{name}",
        "__doc__": f"A :class:`FileError` that is also a builtin ``{name}``.",
    })
    setattr(FileError, name, cls)
    return cast(Type[FileError], cls)


#: The FileError for each cause, by errno (as OSError maps its own).
_FILE_ERRORS: Dict[int, Type[FileError]] = {
    errno.ENOENT: _file_error_class(FileNotFoundError),
    errno.EACCES: _file_error_class(PermissionError),
    errno.EEXIST: _file_error_class(FileExistsError),
    errno.EISDIR: _file_error_class(IsADirectoryError),
    errno.ENOTDIR: _file_error_class(NotADirectoryError),
}
_FILE_ERRORS[errno.EPERM] = _FILE_ERRORS[errno.EACCES]


def as_file_error(err: OSError) -> FileError:
    """``err`` (a builtin OSError from Python's own file calls) as a FileError
    with the same number, text and file names; one already is returned as it is."""
    if isinstance(err, FileError):
        return err
    if err.errno is None or err.strerror is None:
        return FileError(*err.args)
    names = (err.filename,) if err.filename2 is None else (err.filename, None, err.filename2)
    return _FILE_ERRORS.get(err.errno, FileError)(err.errno, err.strerror, *names)


class SpherifyWarning(UserWarning):
    """A result that was computed but comes without its usual guarantee (for
    instance a Tutte embedding with negative cotangent weights, or one in which
    floating point flipped a triangle)."""
