"""Checks of scalar arguments and paths at the Python boundary (issue 13).

Python's ints are unbounded and bools are ints; numpy silently casts complex
numbers to real ones and drops the mask of a masked array. Each of these
reaching the core either overflows (``OverflowError``) or is quietly coerced
into something the caller did not mean. These helpers turn them into
:class:`MeshError` (or ``TypeError`` for a missing path) naming the argument.
"""

from __future__ import annotations

import operator
import os
from typing import Any, Optional

import numpy as np

from ._errors import MeshError

#: The largest count or index the core takes (its indices are 32-bit, its
#: counts machine words).
_INT64_MAX = 2**63 - 1


def integer(value: Any, name: str, minimum: int = 0, maximum: int = _INT64_MAX) -> int:
    """``value`` as an int in ``[minimum, maximum]``: a Python or numpy
    integer (anything with ``__index__``), not a bool, a float or a string.
    The one check of integer arguments; its MeshError names the argument and
    says "an integer >= minimum", or "an integer in minimum..maximum" when
    there is a maximum of the caller's."""
    if isinstance(value, (bool, np.bool_)):
        raise MeshError(f"{name} must be an integer, got {value!r}")
    try:
        number = operator.index(value)
    except TypeError:
        raise MeshError(f"{name} must be an integer, got {value!r}") from None
    if not minimum <= number <= maximum:
        wanted = (f"an integer >= {minimum}" if maximum == _INT64_MAX and number < minimum
                  else f"an integer in {minimum}..{maximum}")
        raise MeshError(f"{name} must be {wanted}, got {value!r}")
    return number


def vertex_id(value: Any, name: str) -> int:
    """An int64 for the core to range-check against the mesh (which names
    the vertex count): Python and numpy integers only."""
    return integer(value, name, minimum=-_INT64_MAX - 1)


def real(value: Any, name: str) -> float:
    """``value`` as a float: a real int or float (not a bool, complex or string)."""
    if isinstance(value, (bool, np.bool_, complex, np.complexfloating, str, bytes)):
        raise MeshError(f"{name} must be a real number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        raise MeshError(f"{name} must be a real number, got {value!r}") from None


def path(value: Any, what: str = "path") -> str:
    """A file path as ``str``: ``str``, ``bytes`` (decoded as the file system
    does) or any ``os.PathLike``; ``None`` and anything else is a TypeError."""
    if value is None:
        raise TypeError(f"{what} must be a file path (str, bytes or os.PathLike), got None")
    try:
        return os.fsdecode(value)
    except TypeError:
        raise TypeError(f"{what} must be a file path (str, bytes or os.PathLike), "
                        f"got {type(value).__name__}") from None


def refuse_lossy(array: Any, what: str) -> Optional[np.ndarray]:
    """Refuses arrays whose conversion to float64 would lose something
    silently: masked arrays (the mask would be dropped) and complex values
    (the imaginary part would be dropped). Returns None; raises MeshError."""
    if isinstance(array, np.ma.MaskedArray):
        raise MeshError(f"{what} is a masked array: fill or drop the masked values first "
                        "(the mask would be ignored)")
    kind = getattr(getattr(array, "dtype", None), "kind", None)
    if kind == "c" or isinstance(array, complex):
        raise MeshError(f"{what} must be real numbers, got complex values")
    return None
