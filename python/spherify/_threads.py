"""How many worker threads the core's calls run on: ``sp.set_num_threads``
and ``sp.get_num_threads`` (and the command line's ``--threads``)."""

from __future__ import annotations

from typing import Any, Optional

from . import _args, _core


def set_num_threads(n: Optional[Any]) -> None:
    """Run later core calls on ``n`` worker threads (``None``: the default,
    ``RAYON_NUM_THREADS`` if set, else one per CPU).

    Results do not depend on it: every method gives the same bits for every
    thread count. A call already running finishes on the threads it has.

    Raises
    ------
    MeshError
        ``n`` is not an integer from 1 to 4096 (or None).
    SpherifyError
        Called from inside a progress callable.
    """
    _core.set_num_threads(None if n is None else _args.integer(n, "n", minimum=1, maximum=4096))


def get_num_threads() -> int:
    """The number of worker threads core calls run on."""
    return int(_core.get_num_threads())
