"""Where a batch's meshes run: worker processes that map one mesh at a time,
watched for their timeout and their death.

* :class:`LocalPool`: ``sp.batch``'s default, ``workers`` child processes of
  this one. A mesh that runs past ``timeout`` has its worker killed and is
  recorded as timed out; a worker that dies (out of memory, SIGKILL) has its
  mesh recorded with the signal; a new worker takes its place.
* :func:`executor_rows`: any ``concurrent.futures.Executor`` (or a Dask
  client's). With a timeout, each task is :func:`run_task_within`: the
  executor's worker hands the mesh to a helper process of its own and kills
  it at the timeout, so ``--timeout`` holds on every executor, and a mesh
  that kills its process (out of memory) is recorded instead of taking the
  executor's worker with it.

A worker is a fresh interpreter (``python -c``) joined by a socket pair, not
a ``multiprocessing`` child: it inherits no Rust thread pool or lock from its
parent (as ``fork`` would), does not re-import the caller's ``__main__`` (as
``multiprocessing``'s ``spawn`` does, which fails in a script without an
``if __name__ == "__main__"`` guard), and can be started from a daemonic
process (a Dask worker), where ``multiprocessing`` refuses to start
children. It says when it is ready, so that its start-up (importing numpy and
spherify) never counts against a mesh's timeout. POSIX only (the socket is
passed by file descriptor); on Windows creating a worker raises
SpherifyError.
"""

from __future__ import annotations

import atexit
import collections
import concurrent.futures as cf
import glob
import multiprocessing
import multiprocessing.connection
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Deque, Dict, Iterator, List, Optional, Sequence

from ._atomic import TEMP_MARK
from ._batch_task import Task, failed_row, run_task
from ._errors import SpherifyError

#: Seconds a new worker may take to import spherify and say it is ready.
START_LIMIT = 300.0

#: The worker's command. It ignores SIGINT first thing, before the imports:
#: Ctrl-C in a terminal reaches the whole process group, and the parent is
#: the one that stops the batch cleanly (a worker killed by it while starting
#: would look like a broken installation).
_CHILD = ("import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); import sys; "
          "from spherify._batch_pool import child_main; child_main(int(sys.argv[1]))")


def child_main(fd: int) -> None:
    """A worker: tasks in, rows out over the socket ``fd``, until None or
    until the parent goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # (again, for callers other than _CHILD)
    connection = multiprocessing.connection.Connection(fd)
    connection.send(("ready", os.getpid()))
    while True:
        try:
            task = connection.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        connection.send(("row", run_task(task)))


def _child_path() -> str:
    """The parent's import path, so that the child imports the same spherify."""
    return os.pathsep.join(os.path.abspath(p) for p in sys.path if p)


class Worker:
    """One worker process and its connection."""

    def __init__(self, threads: Optional[int] = None) -> None:
        if os.name != "posix":
            raise SpherifyError("sp.batch's worker processes need a POSIX system (Linux, macOS): "
                                "they receive their end of a socket pair by file descriptor")
        ours, theirs = socket.socketpair()
        env = dict(os.environ, PYTHONPATH=_child_path())
        if threads is not None and "RAYON_NUM_THREADS" not in os.environ:
            env["RAYON_NUM_THREADS"] = str(threads)  # the core's thread pool (crate::pool)
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-c", _CHILD, str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL, env=env)
        finally:
            theirs.close()
        self.connection = multiprocessing.connection.Connection(ours.detach())
        self.ready = False
        self.task: Optional[Task] = None
        self.started = 0.0

    def give(self, task: Task) -> None:
        self.task, self.started = task, time.monotonic()
        self.connection.send(task)

    def receive(self) -> Optional[Any]:
        """The next message, or None when the worker died (its end closed)."""
        try:
            return self.connection.recv()
        except (EOFError, OSError):
            return None

    def death(self) -> str:
        """Why the worker died, once its end of the socket closed."""
        try:
            code = self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.process.kill()
            code = self.process.wait()
        return f"killed by signal {-code}" if code < 0 else f"exited with status {code}"

    def kill(self) -> None:
        """Kill the worker; the temporary files it was writing for its mesh,
        if any, go with it (a rerun would remove them anyway)."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.connection.close()
        if self.task is not None:
            for output in (Path(self.task.sphere), Path(self.task.spheremap)):
                for leftover in output.parent.glob(f".{glob.escape(output.name)}{TEMP_MARK}"
                                                   f"{self.process.pid}-*"):
                    leftover.unlink(missing_ok=True)

    def stop(self) -> None:
        """Ask an idle worker to exit, then make sure it did."""
        try:
            self.connection.send(None)
            self.process.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired):
            pass
        self.kill()


def _could_not_start(worker: Worker) -> SpherifyError:
    return SpherifyError(f"a batch worker could not start ({worker.death()}; its error, if any, "
                         f"is on stderr above): the command was {sys.executable} -c {_CHILD!r}")


class LocalPool:
    """``workers`` worker processes, started at once (they import spherify
    while the caller hashes its inputs). The cores are shared among them:
    each worker's core calls run on ``cores // workers`` threads (at least
    one; ``RAYON_NUM_THREADS`` set by the caller wins), so that two workers
    on two cores do not run four threads that take turns."""

    def __init__(self, workers: int) -> None:
        self.threads = max(1, (os.cpu_count() or 1) // workers)
        self.workers: List[Worker] = [Worker(self.threads) for _ in range(workers)]

    def rows(self, tasks: Sequence[Task], timeout: Optional[float]) -> Iterator[Dict[str, Any]]:
        """Rows as meshes finish; each worker watched for its timeout and
        its death. Closing the generator stops the workers."""
        queue: Deque[Task] = collections.deque(tasks)
        pool = self.workers
        try:
            while queue or any(w.task is not None for w in pool):
                wait_for: Optional[float] = None
                busy = [w for w in pool if w.task is not None]
                if timeout is not None and busy:
                    now = time.monotonic()
                    wait_for = max(0.0, min(w.started + timeout - now for w in busy))
                ready = multiprocessing.connection.wait([w.connection for w in pool],
                                                        timeout=wait_for)
                gone: List[Worker] = []
                for i, w in enumerate(list(pool)):
                    row: Optional[Dict[str, Any]] = None
                    replace = False
                    if w.connection in ready:
                        message = w.receive()
                        if message is None and not w.ready:
                            raise _could_not_start(w)
                        if message is None:
                            if w.task is not None:  # (an idle one is just replaced)
                                row = failed_row(w.task, "WorkerDied", "the worker mapping this "
                                                 f"mesh died ({w.death()}; out of memory, or "
                                                 "killed)")
                            replace = True
                        elif message[0] == "ready":
                            w.ready = True
                        else:
                            row, w.task = message[1], None
                    elif (timeout is not None and w.task is not None
                          and time.monotonic() - w.started >= timeout):
                        row = failed_row(w.task, "Timeout", f"ran past the timeout of "
                                         f"{timeout:g} s; its worker was killed")
                        replace = True
                    if replace:
                        w.kill()
                        w.task = None
                        if queue:
                            pool[i] = w = Worker(self.threads)
                        else:  # no mesh left for a new worker
                            gone.append(w)
                    elif w.ready and w.task is None and queue:
                        w.give(queue.popleft())  # before the caller journals the row
                    if row is not None:
                        yield row
                pool[:] = [w for w in pool if w not in gone]
        finally:
            self.close()

    def close(self) -> None:
        for w in self.workers:
            if w.ready and w.task is None and w.process.poll() is None:
                w.stop()
            else:
                w.kill()


# --- timeouts inside any executor's worker -----------------------------------------

_IDLE: List[Worker] = []
_IDLE_LOCK = threading.Lock()


@atexit.register
def _stop_idle() -> None:
    with _IDLE_LOCK:
        idle, _IDLE[:] = list(_IDLE), []
    for w in idle:
        w.stop()


def run_task_within(task: Task, timeout: float) -> Dict[str, Any]:
    """:func:`run_task` in a helper process of this one, killed if the mesh
    runs past ``timeout`` seconds. Helpers are kept for the next task (one
    per thread running tasks at once), so a process pays the start-up once."""
    with _IDLE_LOCK:
        worker = _IDLE.pop() if _IDLE else None
    if worker is None:
        worker = Worker()
        if not multiprocessing.connection.wait([worker.connection], timeout=START_LIMIT):
            worker.kill()
            return failed_row(task, "WorkerDied", f"no helper process started within "
                              f"{START_LIMIT:g} s to map this mesh")
        message = worker.receive()
        if message is None:
            return failed_row(task, "WorkerDied", f"the helper process to map this mesh "
                              f"could not start ({worker.death()})")
    worker.give(task)
    if not multiprocessing.connection.wait([worker.connection], timeout=timeout):
        worker.kill()
        return failed_row(task, "Timeout", f"ran past the timeout of {timeout:g} s; "
                          "its process was killed")
    message = worker.receive()
    if message is None:
        reason = worker.death()
        worker.kill()
        return failed_row(task, "WorkerDied", f"the process mapping this mesh died "
                          f"({reason}; out of memory, or killed)")
    worker.task = None
    with _IDLE_LOCK:
        _IDLE.append(worker)
    row: Dict[str, Any] = message[1]
    return row


#: Past the timeout, how long the batch still waits for a task that an
#: executor reports running (the task stops itself at the timeout; this is a
#: backstop for an executor that does not return it, and covers a helper's
#: start-up and an executor that reports queued tasks as running).
BACKSTOP_FACTOR, BACKSTOP_SECONDS = 2.0, 60.0


def executor_rows(tasks: Sequence[Task], executor: Any,
                  timeout: Optional[float]) -> Iterator[Dict[str, Any]]:
    """Rows from any concurrent.futures.Executor (or a Dask client's); each
    task enforces ``timeout`` itself (:func:`run_task_within`)."""
    if timeout is None:
        futures = {executor.submit(run_task, task): task for task in tasks}
    else:
        futures = {executor.submit(run_task_within, task, timeout): task for task in tasks}
    pending = set(futures)
    running_since: Dict[Any, float] = {}
    try:
        while pending:
            done, pending = cf.wait(pending, timeout=None if timeout is None else 1.0,
                                    return_when=cf.FIRST_COMPLETED)
            for future in done:
                task = futures[future]
                try:
                    yield future.result()
                except Exception as err:  # the executor's failure (a broken pool, a killed worker)
                    yield failed_row(task, type(err).__name__,
                                     f"the executor lost this mesh: {err or type(err).__name__}")
            if timeout is None:
                continue
            now = time.monotonic()
            limit = timeout * BACKSTOP_FACTOR + BACKSTOP_SECONDS
            for future in list(pending):
                if future.running():
                    running_since.setdefault(future, now)
                if now - running_since.get(future, now) >= limit:
                    pending.discard(future)
                    future.cancel()
                    yield failed_row(futures[future], "Timeout",
                                     f"the executor returned no result within {limit:g} s "
                                     f"(the timeout of {timeout:g} s was not enforced there)")
    finally:
        for future in pending:
            future.cancel()
