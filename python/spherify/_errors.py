"""The exception hierarchy of spherify (DESIGN.md, "Errors").

Every failure a user can cause raises a subclass of :class:`SpherifyError`.
The Rust core raises these classes directly, so they are defined here once.
"""

from __future__ import annotations

from typing import Any, Optional


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


class SpherifyWarning(UserWarning):
    """A result that was computed but comes without its usual guarantee (for
    instance a Tutte embedding with negative cotangent weights, or one in which
    floating point flipped a triangle)."""
