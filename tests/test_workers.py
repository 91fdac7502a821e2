"""spherify._workers: registration's independent pieces on two threads."""

import threading

import numpy as np
import pytest

import spherify as sp
from spherify import _workers


def test_results_in_input_order_and_the_same_bits_for_one_and_two_threads():
    rng = np.random.default_rng(4)
    blocks = [rng.normal(size=(500, 40)) for _ in range(7)]

    def work(x):
        return np.exp(-(x @ x.T)).sum(axis=1)

    before = sp.get_num_threads()
    try:
        sp.set_num_threads(1)
        one = _workers.run_all(work, blocks)
        sp.set_num_threads(2)
        two = _workers.run_all(work, blocks)
    finally:
        sp.set_num_threads(before)
    assert len(one) == len(two) == 7
    for a, b, x in zip(one, two, blocks):
        assert np.array_equal(a, b)
        assert np.array_equal(a, work(x))


def test_two_threads_run_side_by_side_and_one_thread_on_the_caller():
    before = sp.get_num_threads()
    try:
        sp.set_num_threads(2)
        barrier = threading.Barrier(2, timeout=5)
        # Both pieces must be running at once to pass the barrier.
        assert _workers.run_all(lambda k: (barrier.wait(), k)[1], [0, 1]) == [0, 1]
        sp.set_num_threads(1)
        caller = threading.get_ident()
        assert _workers.run_all(lambda _: threading.get_ident(), [0, 1, 2]) == [caller] * 3
    finally:
        sp.set_num_threads(before)


def test_the_first_error_is_raised():
    def work(k):
        if k == 2:
            raise ValueError("piece 2")
        return k

    with pytest.raises(ValueError, match="piece 2"):
        _workers.run_all(work, range(5))


def test_beside_runs_both_and_pieces_inside_pieces_do_not_wait_for_ever():
    before = sp.get_num_threads()
    try:
        sp.set_num_threads(2)
        # A piece that asks for pieces (as the rigid ICP's check does inside
        # registration) runs them on its own thread instead of queueing them
        # behind itself on a pool of two.
        nested = _workers.run_all(lambda k: sum(_workers.run_all(lambda j: j * k, range(4))),
                                  range(4))
        assert nested == [6 * k for k in range(4)]
        here, there = _workers.beside(lambda: _workers.run_all(lambda j: j + 1, range(3)),
                                      lambda: threading.get_ident())
        assert here == [1, 2, 3]
        assert there != threading.get_ident()
        sp.set_num_threads(1)
        assert _workers.beside(lambda: 1, lambda: threading.get_ident()) == (
            1, threading.get_ident())
    finally:
        sp.set_num_threads(before)


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="needs os.fork")
@pytest.mark.filterwarnings("ignore:.*fork.*:DeprecationWarning")
def test_a_forked_child_makes_its_own_pool():
    import os
    import signal

    before = sp.get_num_threads()
    try:
        sp.set_num_threads(2)
        assert _workers.run_all(lambda k: k, range(4)) == [0, 1, 2, 3]  # the parent's pool
        pid = os.fork()
        if pid == 0:  # the child: the parent's pool threads are not here
            signal.alarm(20)  # work queued for threads that are not there: killed, not hung
            ok = _workers.run_all(lambda k: k * 2, range(4)) == [0, 2, 4, 6]
            os._exit(0 if ok else 1)
        _, status = os.waitpid(pid, 0)
        assert os.waitstatus_to_exitcode(status) == 0
    finally:
        sp.set_num_threads(before)


def test_under_an_address_space_limit_the_pieces_run_on_the_caller():
    # The pool's threads reserve hundreds of MiB of address space (arenas,
    # stacks, BLAS buffers) that the memory budget does not see; under
    # RLIMIT_AS that room belongs to the budgeted work.
    resource = pytest.importorskip("resource")
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent("""
        import resource, threading
        import spherify as sp
        from spherify import _workers
        sp.set_num_threads(2)
        free = _workers.run_all(lambda _: threading.get_ident(), [0, 1, 2, 3])
        resource.setrlimit(resource.RLIMIT_AS, (8 << 30, resource.RLIM_INFINITY))
        caller = threading.get_ident()
        limited = _workers.run_all(lambda _: threading.get_ident(), [0, 1, 2, 3])
        print(any(t != caller for t in free), limited == [caller] * 4)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True)
    assert out.stdout.split() == ["True", "True"], out.stdout + out.stderr
