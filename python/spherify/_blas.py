"""numpy's BLAS held to one thread on the calling thread, for registration.

Registration's non-rigid ICP solves small dense systems in numpy (products of
3000 x 304 matrices, solves of 304 unknowns). OpenBLAS splits each over all
cores; on a machine whose cores are busy its threads wait for each other, and
a 304 x 304 solve took 150 ms instead of 1.5 ms (2 cores at load 7, issue
23): horse's warp stage took 9.6 s instead of 3.0 s. Its threads also change
the order of the sums, so the registration's bits depended on the BLAS
thread count (horse's p95 error 5.75% against 5.83%).

:func:`one_blas_thread` sets OpenBLAS's thread count to one for the block
and restores it after (``openblas_set_num_threads_local``, OpenBLAS 0.3.27
and later, which returns the count it replaces). The count is the process's,
not the thread's: while any block runs, numpy's BLAS is on one thread in every
thread of the process; nested and concurrent blocks are counted, the first
saves the count and the last restores it. The library is the one numpy has
already loaded (found in the process's memory map, or numpy's bundled
``numpy.libs``), opened without loading anything new. Where no such OpenBLAS
is found (another BLAS, an older OpenBLAS, not Linux) the block runs
unchanged.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading
from contextlib import contextmanager
from functools import lru_cache
from typing import Any, Iterator, List, Optional

__all__ = ["local_threads_setter", "one_blas_thread"]


def _candidates() -> List[str]:
    paths: List[str] = []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            for line in maps:
                path = line.rstrip("\n").split(" ")[-1]
                if "openblas" in os.path.basename(path).lower() and path not in paths:
                    paths.append(path)
    except OSError:
        pass
    import numpy
    bundled = os.path.join(os.path.dirname(os.path.dirname(numpy.__file__)), "numpy.libs")
    paths += [p for p in sorted(glob.glob(os.path.join(bundled, "*openblas*"))) if p not in paths]
    return paths


@lru_cache(maxsize=1)
def local_threads_setter() -> Optional[Any]:
    """OpenBLAS's ``openblas_set_num_threads_local`` of the library numpy
    uses (it returns the previous count), or None where there is none."""
    mode = getattr(os, "RTLD_NOLOAD", 0) | getattr(os, "RTLD_LOCAL", 0)
    for path in _candidates():
        try:
            library = ctypes.CDLL(path, mode=mode)
            setter = library.openblas_set_num_threads_local
        except (OSError, AttributeError):
            continue
        setter.argtypes = [ctypes.c_int]
        setter.restype = ctypes.c_int
        return setter
    return None


_lock = threading.Lock()
_active = 0
_saved = 0


@contextmanager
def one_blas_thread() -> Iterator[bool]:
    """Run the block with numpy's BLAS on one thread; yields whether it could."""
    global _active, _saved
    setter = local_threads_setter()
    if setter is None:
        yield False
        return
    with _lock:
        if _active == 0:
            _saved = int(setter(1))
        _active += 1
    try:
        yield True
    finally:
        with _lock:
            _active -= 1
            if _active == 0:
                setter(_saved)
