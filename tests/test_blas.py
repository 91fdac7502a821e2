"""numpy's BLAS held to one thread (spherify._blas)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from spherify import _blas

needs_openblas = pytest.mark.skipif(
    _blas.local_threads_setter() is None,
    reason="numpy's BLAS is not an OpenBLAS with openblas_set_num_threads_local")


@needs_openblas
def test_one_blas_thread_pins_nested_and_concurrent_blocks_and_restores() -> None:
    setter = _blas.local_threads_setter()
    assert setter is not None
    before = int(setter(3))
    inside = []
    release = threading.Event()
    entered = threading.Event()

    def other() -> None:
        with _blas.one_blas_thread():
            entered.set()
            release.wait(10)

    try:
        with _blas.one_blas_thread() as pinned:
            assert pinned
            thread = threading.Thread(target=other)
            thread.start()
            entered.wait(10)
            with _blas.one_blas_thread():
                inside.append(int(setter(1)))
            a = np.random.default_rng(0).normal(size=(300, 300)) + 300 * np.eye(300)
            np.linalg.solve(a, np.ones(300))
            inside.append(int(setter(1)))
        # The other thread's block still runs: still one thread.
        inside.append(int(setter(1)))
        release.set()
        thread.join()
        assert inside == [1, 1, 1]
        # The last block to end restored the count.
        assert int(setter(3)) == 3
    finally:
        release.set()
        setter(before)


@needs_openblas
def test_one_blas_thread_restores_after_an_error() -> None:
    setter = _blas.local_threads_setter()
    assert setter is not None
    before = int(setter(2))
    try:
        with pytest.raises(ValueError):
            with _blas.one_blas_thread():
                raise ValueError("inside")
        assert int(setter(2)) == 2
    finally:
        setter(before)
