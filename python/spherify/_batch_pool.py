"""Where a batch's meshes run: worker processes that map one mesh at a time,
watched for their timeout and their death.

* :class:`LocalPool`: ``sp.batch``'s default, ``workers`` child processes of
  this one. Each worker writes one mesh's outputs on a thread while it maps
  the next (:func:`child_main`), so it holds at most two meshes. A mesh that
  runs past ``timeout`` has its worker killed and is recorded as timed out; a
  worker that dies (out of memory, SIGKILL) has the mesh it was mapping
  recorded with the signal (the maps are where memory peaks); a new worker
  takes its place. The other mesh the worker held, if any, is not at fault:
  it goes back to the queue, once (a second loss records it as failed, so
  that a mesh whose writing kills workers cannot loop).
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
from typing import Any, Deque, Dict, Iterator, List, Optional, Sequence, Set, Tuple

from ._atomic import remove_stale_temporaries
from ._batch_task import (Mapped, Task, failed_row, finish_task, map_task, peak_memory_mb,
                          reset_peak_memory, run_task)
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
    until the parent goes away.

    Each mesh is mapped on the main thread (:func:`map_task`), then written on
    a second thread (:func:`finish_task`) while the next mesh is read and
    mapped: the map's core calls and the writing's measures, hashes and file
    writes all release the GIL, and the writing mostly waits for the disk or
    uses a core the map leaves idle. Messages: ``("mapped", input)`` when a
    mesh is mapped and the previous one written (the parent may then send the
    next task: at most two meshes are in a worker), ``("row", row)`` once its
    outputs are renamed into place (or it failed)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # (again, for callers other than _CHILD)
    connection = multiprocessing.connection.Connection(fd)
    lock = threading.Lock()

    def send(message: Tuple[str, Any]) -> None:
        with lock:  # the two threads send whole messages, one at a time
            connection.send(message)

    def finish(box: List[Mapped]) -> None:
        row = finish_task(box.pop())
        # The mesh's arrays are freed now (the box held the last reference):
        # the high-water mark starts again for the mesh being mapped, so
        # that its peak does not hold this one's writing. (What the C
        # library keeps of the freed memory stays resident: handing it back
        # with malloc_trim made the next map fault its pages in again, some
        # 15 ms of CPU per mesh.)
        reset_peak_memory()
        try:
            send(("row", row))
        except OSError:  # the parent went away: the main thread sees it next
            pass

    send(("ready", os.getpid()))
    writer = cf.ThreadPoolExecutor(1, thread_name_prefix="spherify-writer")
    writing: Optional["cf.Future[None]"] = None
    try:
        while True:
            try:
                task = connection.recv()
            except (EOFError, OSError):
                return
            if task is None:
                return
            mapped = map_task(task)
            if writing is not None:
                writing.result()  # one mesh written at a time
            # The peak since this mesh began, or since the previous one's
            # outputs were written if that came later (``finish``).
            mapped.row["peak_memory_mb"] = peak_memory_mb(mapped.reset)
            send(("mapped", task.input))
            writing = writer.submit(finish, [mapped])
            del mapped  # (the writer's box holds it, and frees it when done)
    finally:
        writer.shutdown(wait=True)  # the last mesh's outputs and row


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
        #: The meshes it holds, oldest first, with when each was given: at
        #: most one being written and one being mapped (``mapping``).
        self.tasks: List[Tuple[Task, float]] = []
        self.mapping: Optional[Task] = None

    def give(self, task: Task) -> None:
        self.tasks.append((task, time.monotonic()))
        self.mapping = task
        self.connection.send(task)

    def can_take(self) -> bool:
        """Whether it is ready for another mesh: started, its last one
        mapped, and at most one being written."""
        return self.ready and self.mapping is None and len(self.tasks) < 2

    def finished(self, name: str) -> None:
        """A row came for the input ``name``."""
        self.tasks = [(t, s) for t, s in self.tasks if t.input != name]

    def mapped(self) -> None:
        """The mesh being mapped is mapped; it is written next. Its clock
        starts again: the timeout holds for the writing on its own. The
        writing shares the worker's core threads with the next mesh's map,
        and can wait behind a long parallel step of it; from the give on,
        the mesh being written would run out its time first and be blamed
        for the next one's."""
        now = time.monotonic()
        self.tasks = [(t, now if t is self.mapping else s) for t, s in self.tasks]
        self.mapping = None

    def late(self, timeout: float) -> Optional[Task]:
        """A mesh it holds that has run past ``timeout`` seconds, if any:
        the one being mapped first (a mesh being written may be waiting
        for it, see :meth:`mapped`)."""
        now = time.monotonic()
        overdue = [t for t, s in self.tasks if now - s >= timeout]
        if self.mapping is not None and self.mapping in overdue:
            return self.mapping
        return overdue[0] if overdue else None

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
        # Reaped, the worker is no longer running: its temporaries are stale.
        for folder in {Path(output).parent for task, _ in self.tasks
                       for output in (task.sphere, task.spheremap)}:
            remove_stale_temporaries(folder)

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


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity where the system
    has one (``taskset``, a container's cpuset), else the machine's count."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # no sched_getaffinity (macOS)
        return os.cpu_count() or 1


class LocalPool:
    """``workers`` worker processes, started at once (they import spherify
    while the caller hashes its inputs). The cores are shared among them:
    each worker's core calls run on ``cores // workers`` threads (at least
    one; ``RAYON_NUM_THREADS`` set by the caller wins), so that two workers
    on two cores do not run four threads that take turns. The cores are those
    this process may use (:func:`usable_cores`), which the workers inherit."""

    def __init__(self, workers: int) -> None:
        self.threads = max(1, usable_cores() // workers)
        self.workers: List[Worker] = [Worker(self.threads) for _ in range(workers)]

    def rows(self, tasks: Sequence[Task], timeout: Optional[float]) -> Iterator[Dict[str, Any]]:
        """Rows as meshes finish; each worker watched for its timeout and
        its death. Closing the generator stops the workers."""
        queue: Deque[Task] = collections.deque(tasks)
        requeued: Set[str] = set()
        pool = self.workers

        def lose(w: Worker, blamed: Task, error_type: str, error: str) -> List[Dict[str, Any]]:
            """Rows for a worker that is lost: ``blamed`` failed; the other
            mesh it held goes back to the queue, or fails if it did once."""
            rows = [failed_row(blamed, error_type, error)]
            for task, _ in w.tasks:
                if task is blamed:
                    continue
                if task.input in requeued:
                    rows.append(failed_row(task, "WorkerDied", "a second worker holding this "
                                           f"mesh was lost while it held another ({error})"))
                else:
                    requeued.add(task.input)
                    queue.appendleft(task)
            return rows

        try:
            while queue or any(w.tasks for w in pool):
                wait_for: Optional[float] = None
                started = [s for w in pool for _, s in w.tasks]
                if timeout is not None and started:
                    wait_for = max(0.0, min(started) + timeout - time.monotonic())
                ready = multiprocessing.connection.wait([w.connection for w in pool],
                                                        timeout=wait_for)
                gone: List[Worker] = []
                for i, w in enumerate(list(pool)):
                    rows: List[Dict[str, Any]] = []
                    replace = False
                    late = None if timeout is None else w.late(timeout)
                    if w.connection in ready:
                        message = w.receive()
                        if message is None and not w.ready:
                            raise _could_not_start(w)
                        if message is None:
                            if w.tasks:  # (an idle one is just replaced)
                                blamed = w.mapping or w.tasks[0][0]
                                rows = lose(w, blamed, "WorkerDied", "the worker mapping this "
                                            f"mesh died ({w.death()}; out of memory, or killed)")
                            replace = True
                        elif message[0] == "ready":
                            w.ready = True
                        elif message[0] == "mapped":
                            w.mapped()
                        else:
                            rows.append(message[1])
                            w.finished(message[1]["input"])
                    elif late is not None:
                        rows = lose(w, late, "Timeout", f"ran past the timeout of {timeout:g} s; "
                                    "its worker was killed")
                        replace = True
                    if replace:
                        w.kill()
                        w.tasks, w.mapping = [], None
                        if queue:
                            pool[i] = w = Worker(self.threads)
                        else:  # no mesh left for a new worker
                            gone.append(w)
                    elif w.can_take() and queue:
                        w.give(queue.popleft())  # before the caller journals the row
                    yield from rows
                pool[:] = [w for w in pool if w not in gone]
        finally:
            self.close()

    def close(self) -> None:
        for w in self.workers:
            if w.ready and not w.tasks and w.process.poll() is None:
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
    deadline = time.monotonic() + timeout
    while True:  # ("mapped", ...) comes first, then ("row", ...)
        left = deadline - time.monotonic()
        if left <= 0 or not multiprocessing.connection.wait([worker.connection], timeout=left):
            worker.kill()
            return failed_row(task, "Timeout", f"ran past the timeout of {timeout:g} s; "
                              "its process was killed")
        message = worker.receive()
        if message is None:
            reason = worker.death()
            worker.kill()
            return failed_row(task, "WorkerDied", f"the process mapping this mesh died "
                              f"({reason}; out of memory, or killed)")
        if message[0] == "row":
            break
    worker.tasks, worker.mapping = [], None
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
