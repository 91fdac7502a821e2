"""Two Python threads for registration's independent pieces of numpy work.

On two quiet cores the mapping of two shapes runs on both, while most of
registration's Python side (the non-rigid ICP's kernel blocks, the rigid
ICP's starts) ran on one: issue 23 measured register at 3.3-4.2x the wall
time of mapping both with 2.5-3.2x its CPU time. numpy releases the GIL in
its matrix products and large ufuncs, and the core's calls release it too, so
independent pieces run side by side on a small thread pool.

Bits: each piece is computed exactly as it would be alone (numpy's BLAS is
held to one thread for the whole process during registration,
:mod:`spherify._blas`, so a product in a worker takes the same path as in
the caller) and its result is taken in the order of the inputs, so the
output does not depend on the number of threads. With
``sp.set_num_threads(1)``, or under an address-space limit (``RLIMIT_AS``;
see ``_address_space_limited``), the pieces run one after another on the
caller.

Ctrl-C: the caller waits on each result with an interruptible wait; when it
is interrupted the pieces not yet started are cancelled, and the ones
running (milliseconds to a few tenths of a second each) finish in the
background.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable, Iterable, List, Optional, Tuple, TypeVar

from . import _core

__all__ = ["THREADS", "beside", "parallel", "run_all"]

# Pool threads: the machine's two cores (more would only queue behind the
# core's own pool, which the workers' core calls share).
THREADS = 2

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")

_lock = threading.Lock()
_pool: Optional[ThreadPoolExecutor] = None


def _forget_pool() -> None:
    # A forked child has the parent's pool object but not its threads: work
    # queued on it would never run. The child makes its own on first use.
    global _pool, _lock
    _pool = None
    _lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def _executor() -> ThreadPoolExecutor:
    global _pool
    with _lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(THREADS, thread_name_prefix="spherify-register")
        return _pool


_inside = threading.local()


def _marked(work: Callable[[T], R]) -> Callable[[T], R]:
    """``work`` marked as running on a pool thread while it runs."""
    def run(x: T) -> R:
        _inside.flag = True
        try:
            return work(x)
        finally:
            _inside.flag = False
    return run


def _address_space_limited() -> bool:
    # Each pool thread reserves address space the memory budget cannot see
    # coming: a malloc arena or two (64 MiB each), its stack (8 MiB) and
    # OpenBLAS's buffer for a new calling thread (32 MiB); measured, two
    # threads took a process from 387 to 696 MiB of address space. Under an
    # address-space limit (RLIMIT_AS) that is room the budgeted work itself
    # may need (a small register under 908 MiB was refused its point
    # locator), so there the pieces run on the caller: the same results,
    # only slower.
    try:
        import resource
    except ImportError:  # not on POSIX: no RLIMIT_AS either
        return False
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return soft != resource.RLIM_INFINITY


def parallel() -> bool:
    """Whether :func:`run_all` and :func:`beside` would spread their pieces
    over the pool from this thread (two threads or more, not inside a piece,
    no address-space limit)."""
    return _parallel()


def _parallel() -> bool:
    # A piece that itself asks for pieces runs them on its own thread: a pool
    # thread waiting for pieces queued behind it could wait for ever.
    return (_core.get_num_threads() >= 2 and not getattr(_inside, "flag", False)
            and not _address_space_limited())


def _results(futures: List["Future[R]"]) -> List[R]:
    try:
        return [f.result() for f in futures]
    except BaseException:
        for f in futures:
            f.cancel()
        raise


def run_all(work: Callable[[T], R], items: Iterable[T]) -> List[R]:
    """``[work(x) for x in items]``, the calls spread over the caller (the
    first) and the pool (the rest) when the core runs on two threads or more
    (``sp.get_num_threads``) and the caller is not itself a piece; the first
    error is raised after the pieces not yet started are cancelled."""
    todo = list(items)
    if len(todo) < 2 or not _parallel():
        return [work(x) for x in todo]
    # The caller takes the first piece itself instead of waiting idle: where
    # a pool thread is busy with a long piece of its own (registration's
    # check in space runs beside the later stages), the others still go two
    # at a time (issue 23, speed).
    futures = [_executor().submit(_marked(work), x) for x in todo[1:]]
    try:
        first = work(todo[0])
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    return [first] + _results(futures)


def beside(here: Callable[[], R], there: Callable[[], S]) -> Tuple[R, S]:
    """``(here(), there())``: ``there`` on a pool thread while ``here`` runs
    on the caller, so that ``here`` can still spread its own pieces over
    the pool (:func:`run_all`)."""
    if not _parallel():
        return here(), there()
    future = _executor().submit(_marked(lambda _: there()), None)
    try:
        first = here()
    except BaseException:
        future.cancel()
        raise
    return first, _results([future])[0]
