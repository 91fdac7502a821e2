"""Many meshes: ``sp.batch`` and ``spherify batch``.

Each mesh is one task: read, check, map (orienting on the way), certify,
measure, then write ``<name>-<hash>.sphere.ply`` (the sphere as a mesh) and
``<name>-<hash>.spheremap.npz`` (:meth:`SphereMap.save`) under temporary names
renamed into place. Only the task (paths and options) and its summary row
travel between processes; each worker reads its own input and writes its own
output.

Where it runs:

* by default a local pool of ``workers`` processes started with the
  ``spawn`` method (not ``fork``: a fresh interpreter does not inherit the
  parent's Rust thread pool or locks), each running one mesh at a time. The
  pool watches every worker: a mesh that runs past ``timeout`` has its worker
  killed and is recorded as timed out; a worker that dies (out of memory,
  SIGKILL) has its mesh recorded with the signal; a new worker takes its
  place and the batch goes on;
* any ``concurrent.futures.Executor`` (``executor=``): the same tasks through
  ``submit``. A timeout is then recorded but cannot stop the task, and a pool
  that breaks records every mesh it held;
* a Dask cluster: ``executor=`` a ``dask.distributed.Client`` or
  ``scheduler="tcp://..."`` (``pip install "spherify[dask]"``), through the
  client's executor.

Resumable: ``OUT/journal.jsonl`` gets one JSON line per finished mesh, flushed
and synced as it finishes; ``OUT/summary.csv`` is written at the end. A rerun
with the same method and options skips every mesh whose journal row says it
was written, whose outputs exist, and whose input still has the content hash
(SHA-256) recorded; it redoes the rest. The journal is compacted at the start
of a run (rows of meshes that will be redone are dropped), so it never holds
a mesh twice.
"""

from __future__ import annotations

import concurrent.futures as cf
import csv
import hashlib
import importlib
import io
import json
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

from ._atomic import is_temporary, write_atomically
from ._errors import MeshError

PathLike = Union[str, "os.PathLike[str]"]

JOURNAL = "journal.jsonl"
SUMMARY = "summary.csv"
#: Suffixes a folder is searched for (FreeSurfer surfaces by their names).
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl", ".npz", ".gii")
LIST_SUFFIXES = (".txt", ".lst")
#: The columns of summary.csv, in order; the journal's rows hold the same keys.
COLUMNS = ("input", "sha256", "status", "certified", "n_vertices", "n_faces", "method",
           "valid", "tp_valid", "flipped", "margin", "angle_mean_deg", "angle_max_deg",
           "conformal_mean", "area_log_std", "stretch_l2", "stretch_linf", "edge_length_cv",
           "seconds_read", "seconds_check", "seconds_map", "seconds_certify",
           "seconds_quality", "seconds_write", "seconds_total", "peak_memory_mb",
           "sphere", "spheremap", "error_type", "error", "warnings", "options_hash")
#: The quality measures copied into a row.
QUALITY = ("angle_mean_deg", "angle_max_deg", "conformal_mean", "area_log_std", "stretch_l2",
           "stretch_linf", "edge_length_cv")


# --- inputs -------------------------------------------------------------------

def _is_mesh_file(path: Path) -> bool:
    from ._formats import FREESURFER_NAMES
    name = path.name.lower()
    if is_temporary(path) or name.endswith(".spheremap.npz") or name.endswith(".sphere.ply"):
        return False
    return (path.suffix.lower() in MESH_SUFFIXES
            or path.suffix.lower().lstrip(".") in FREESURFER_NAMES)


def expand_inputs(inputs: Iterable[PathLike]) -> List[Path]:
    """Files as given; folders searched recursively for mesh files (by
    extension or FreeSurfer surface name; outputs of a batch are left out);
    ``.txt`` / ``.lst`` files read as one path per line (relative to the list's
    folder; blank lines and ``#`` comments skipped). Sorted within a folder,
    duplicates dropped, order otherwise kept. MeshError for a path that does
    not exist."""
    found: List[Path] = []
    for item in inputs:
        path = Path(os.fspath(item))
        if path.is_dir():
            found.extend(sorted(p for p in path.rglob("*") if p.is_file() and _is_mesh_file(p)))
        elif path.suffix.lower() in LIST_SUFFIXES and path.is_file():
            lines = path.read_text(encoding="utf-8").splitlines()
            listed = [path.parent / line.strip() for line in lines
                      if line.strip() and not line.strip().startswith("#")]
            found.extend(expand_inputs(listed))
        elif path.is_file():
            found.append(path)
        else:
            raise MeshError(f"batch input {path} does not exist")
    unique: Dict[Path, None] = {}
    for p in found:
        unique.setdefault(p.resolve(), None)
    return list(unique)


def content_hash(path: Path) -> str:
    """SHA-256 of the file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def options_hash(method: str, options: Dict[str, Any]) -> str:
    """What must match for a rerun to reuse a result."""
    text = json.dumps({"method": method, "options": options}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# --- one mesh -----------------------------------------------------------------

@dataclass(frozen=True)
class Task:
    """What travels to a worker: paths and options only."""
    input: str
    sha256: str
    sphere: str
    spheremap: str
    method: str
    options: Dict[str, Any]
    options_hash: str


def _peak_memory_mb() -> Optional[float]:
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # kilobytes on Linux, bytes on macOS
    return round(peak / (1 << 20 if sys.platform == "darwin" else 1 << 10), 1)


def run_task(task: Task) -> Dict[str, Any]:
    """Map one mesh and write its outputs; never raises for the mesh's faults:
    the row says what went wrong. Runs in a worker."""
    from ._embed import embed
    from ._mesh import Mesh, check, load, save
    from ._quality import quality
    from ._spheremap import ThetaPhiMap

    row: Dict[str, Any] = {key: None for key in COLUMNS}
    row.update(input=task.input, sha256=task.sha256, method=task.method,
               options_hash=task.options_hash, status="failed", certified=False)
    clock = time.perf_counter()
    start = clock

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        row[f"seconds_{stage}"] = round(now - clock, 6)
        clock = now

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = load(task.input)
            row.update(n_vertices=mesh.n_vertices, n_faces=mesh.n_faces)
            lap("read")
            report = check(mesh)
            lap("check")
            if not report.is_sphere_topology:
                from ._errors import TopologyError
                raise TopologyError("not a closed, connected, manifold genus-0 surface: "
                                    + "; ".join(report.problems), report)
            m = embed(mesh, task.method, **task.options)
            seconds = m.seconds
            row["seconds_map"] = round(sum(v for k, v in seconds.items() if k != "certify"), 6)
            row["seconds_certify"] = round(seconds.get("certify", 0.0), 6)
            clock = time.perf_counter()
            row.update(valid=m.valid, flipped=m.flipped)
            certified = m.valid
            if isinstance(m, ThetaPhiMap):
                row["tp_valid"] = m.tp_valid
                row["margin"] = float(m.details["min_area_ratio"])
                certified = m.tp_valid
            row["certified"] = bool(certified)
            q = quality(m.mesh, m.points)
            row.update({k: float(q[k]) for k in QUALITY})
            lap("quality")
            save(Mesh(m.points, m.mesh.faces), task.sphere)
            m.save(task.spheremap)
            lap("write")
            row.update(status="done", sphere=task.sphere, spheremap=task.spheremap)
        row["warnings"] = "; ".join(str(w.message) for w in caught) or None
    except Exception as err:  # the mesh's fault, recorded in its row
        row.update(error_type=type(err).__name__, error=str(err))
    except BaseException as err:  # a Rust panic (PanicException) is a BaseException
        if isinstance(err, (KeyboardInterrupt, SystemExit)):
            raise
        row.update(error_type=type(err).__name__,
                   error=f"{err} ({traceback.format_exc(limit=1).strip()})")
    row["seconds_total"] = round(time.perf_counter() - start, 6)
    row["peak_memory_mb"] = _peak_memory_mb()
    return row


def _failed(task: Task, error_type: str, message: str) -> Dict[str, Any]:
    row: Dict[str, Any] = {key: None for key in COLUMNS}
    row.update(input=task.input, sha256=task.sha256, method=task.method,
               options_hash=task.options_hash, status="failed", certified=False,
               error_type=error_type, error=message)
    return row


# --- the local pool -----------------------------------------------------------

def _worker_main(connection: Any) -> None:
    """A pool worker: tasks in, rows out, until it receives None."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    while True:
        task = connection.recv()
        if task is None:
            return
        connection.send(run_task(task))


class _Worker:
    def __init__(self, context: Any) -> None:
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_worker_main, args=(child,), daemon=True)
        self.process.start()
        child.close()
        self.task: Optional[Task] = None
        self.started = 0.0

    def give(self, task: Task) -> None:
        self.task, self.started = task, time.monotonic()
        self.connection.send(task)

    def kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join()
        self.connection.close()


def _local_pool(tasks: Sequence[Task], workers: int, timeout: Optional[float]) -> Iterator[Dict[str, Any]]:
    """Rows as meshes finish, from ``workers`` spawned processes, each watched
    for its timeout and its death."""
    context = multiprocessing.get_context("spawn")
    queue = list(reversed(tasks))
    pool = [_Worker(context) for _ in range(min(workers, len(tasks)))]
    try:
        for w in pool:
            if queue:
                w.give(queue.pop())
        while any(w.task is not None for w in pool):
            busy = [w for w in pool if w.task is not None]
            wait_for: Optional[float] = None
            if timeout is not None:
                now = time.monotonic()
                wait_for = max(0.0, min(w.started + timeout - now for w in busy))
            waitables: List[Any] = [w.connection for w in busy] + [w.process.sentinel for w in busy]
            ready = multiprocessing.connection.wait(waitables, timeout=wait_for)
            for i, w in enumerate(pool):
                if w.task is None:
                    continue
                task = w.task
                row: Optional[Dict[str, Any]] = None
                replace = False
                if w.connection in ready or w.process.sentinel in ready:
                    try:
                        row = w.connection.recv() if w.connection.poll() else None
                    except (EOFError, OSError):
                        row = None
                    if row is None:
                        w.process.join(timeout=5)
                        code = w.process.exitcode
                        reason = (f"killed by signal {-code}" if code is not None and code < 0
                                  else f"exited with status {code}")
                        row = _failed(task, "WorkerDied",
                                      f"the worker mapping this mesh died ({reason}; out of "
                                      "memory, or killed)")
                        replace = True
                elif timeout is not None and time.monotonic() - w.started >= timeout:
                    row = _failed(task, "Timeout", f"ran past the timeout of {timeout:g} s; "
                                  "its worker was killed")
                    replace = True
                if row is None:
                    continue
                w.task = None
                if replace:
                    w.kill()
                    pool[i] = w = _Worker(context)
                if queue:
                    w.give(queue.pop())
                yield row
    finally:
        for w in pool:
            if w.task is None and w.process.is_alive():
                try:
                    w.connection.send(None)
                except OSError:
                    pass
            w.process.join(timeout=0.5 if w.task is None else 0)
            w.kill()


def _executor_pool(tasks: Sequence[Task], executor: Any,
                   timeout: Optional[float]) -> Iterator[Dict[str, Any]]:
    """Rows from any concurrent.futures.Executor (or a Dask client's). The
    timeout counts from when the executor first reports a task running
    (polled each second); an executor cannot stop a task, so past it the
    mesh is recorded and no longer waited for."""
    futures = {executor.submit(run_task, task): task for task in tasks}
    pending = set(futures)
    running_since: Dict[Any, float] = {}
    while pending:
        done, pending = cf.wait(pending, timeout=None if timeout is None else 1.0,
                                return_when=cf.FIRST_COMPLETED)
        for future in done:
            task = futures[future]
            try:
                yield future.result()
            except Exception as err:  # the executor's failure (a broken pool, a killed worker)
                yield _failed(task, type(err).__name__,
                              f"the executor lost this mesh: {err or type(err).__name__}")
        if timeout is None:
            continue
        now = time.monotonic()
        for future in list(pending):
            if future.running():
                running_since.setdefault(future, now)
            if now - running_since.get(future, now) >= timeout:
                pending.discard(future)
                yield _failed(futures[future], "Timeout",
                              f"no result within the timeout of {timeout:g} s (the executor "
                              "cannot stop the task; it may still be running)")


# --- the journal --------------------------------------------------------------

def read_journal(path: Path) -> List[Dict[str, Any]]:
    """The rows of a journal; a last line cut short by a killed run is ignored."""
    if not path.exists():
        return []
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(row, dict) and "input" in row:
            rows.append(row)
    return rows


def _reusable(row: Dict[str, Any], task: Task) -> bool:
    return (row.get("status") == "done" and row.get("sha256") == task.sha256
            and row.get("options_hash") == task.options_hash
            and row.get("sphere") == task.sphere and row.get("spheremap") == task.spheremap
            and Path(task.sphere).is_file() and Path(task.spheremap).is_file())


def _write_text(path: Path, text: str) -> None:
    def fill(temporary: Path) -> None:
        temporary.write_text(text, encoding="utf-8")
    write_atomically(path, fill)


def _append(handle: Any, row: Dict[str, Any]) -> None:
    handle.write(json.dumps(row, sort_keys=True) + "\n")
    handle.flush()
    os.fsync(handle.fileno())


def write_summary(path: Path, rows: Sequence[Dict[str, Any]]) -> None:
    """summary.csv: one row per mesh in input order, the columns of COLUMNS."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(COLUMNS), extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if row.get(k) is None else row[k] for k in COLUMNS})
    _write_text(path, buffer.getvalue())


# --- the batch ----------------------------------------------------------------

@dataclass
class BatchResult:
    """What :func:`batch` did: ``rows`` (one per mesh, input order),
    how many were ``skipped`` (already done), and the files it wrote."""
    rows: List[Dict[str, Any]]
    skipped: int
    journal: Path
    summary: Path
    interrupted: bool = False
    counts: Dict[str, int] = field(default_factory=dict)

    @property
    def all_certified(self) -> bool:
        return all(row.get("certified") for row in self.rows)


def _safe_name(path: Path) -> str:
    name = path.name
    for suffix in (".surf.gii",):
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
    return keep.strip(".") or "mesh"


class _Progress:
    """A one-line bar on stderr: done of total, certified, failed, rate."""

    def __init__(self, total: int, show: bool) -> None:
        self.total, self.show = total, show
        self.done = self.certified = self.failed = 0
        self.start = time.monotonic()

    def update(self, row: Dict[str, Any]) -> None:
        self.done += 1
        self.certified += bool(row.get("certified"))
        self.failed += row.get("status") != "done"
        if self.show:
            rate = self.done / max(time.monotonic() - self.start, 1e-9)
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total}"
                             f" certified {self.certified} failed {self.failed}"
                             f" {rate:.2f} meshes/s")
            sys.stderr.flush()

    def close(self) -> None:
        if self.show:
            sys.stderr.write("\n")
            sys.stderr.flush()


def batch(paths: Union[PathLike, Iterable[PathLike]], out_dir: PathLike, executor: Any = None, *,
          method: str = "theta_phi", workers: Optional[int] = None,
          timeout: Optional[float] = None, scheduler: Optional[str] = None,
          progress: bool = False, **options: Any) -> BatchResult:
    """Map many meshes, in parallel, resumably.

    Parameters
    ----------
    paths : path or iterable of paths
        Mesh files, folders (searched recursively for the supported formats)
        or ``.txt`` / ``.lst`` files listing paths, one a line.
    out_dir : path
        Created if missing. Receives ``<name>-<hash>.sphere.ply``,
        ``<name>-<hash>.spheremap.npz``, ``journal.jsonl`` and ``summary.csv``.
    executor : None, concurrent.futures.Executor or dask.distributed.Client
        None: a local pool of ``workers`` spawned processes (default: the
        number of cores) that enforces ``timeout`` by killing the worker.
    method, **options
        Passed to :func:`spherify.embed`; JSON-representable values only.
    timeout : float, optional
        Seconds per mesh; a mesh past it is recorded as failed.
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:8786``): the batch runs there.
    progress : bool
        Draw a progress bar on stderr.

    Returns
    -------
    BatchResult
        ``rows``: one dict per mesh, in input order, with the keys of
        :data:`COLUMNS`. A mesh that failed (unreadable, not genus 0, a
        panic, a timeout, a dead worker) has ``status="failed"`` and
        ``error_type`` / ``error``; the batch goes on.

    Raises
    ------
    MeshError
        An input path that does not exist, bad ``workers`` or ``timeout``, or
        options that cannot be stored.
    KeyboardInterrupt
        After Ctrl-C, once the workers are stopped; the journal holds every
        mesh that finished, and a rerun resumes.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    inputs = expand_inputs(paths)
    if workers is not None and workers < 1:
        raise MeshError(f"workers must be at least 1, got {workers}")
    if timeout is not None and not timeout > 0:
        raise MeshError(f"timeout must be positive seconds, got {timeout}")
    if executor is not None and scheduler is not None:
        raise MeshError("give executor= or scheduler=, not both")
    try:
        json.dumps(options)
    except TypeError as err:
        raise MeshError(f"batch options must be JSON values (numbers, strings, lists): {err}") from None
    out = Path(os.fspath(out_dir))
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.iterdir():
        if is_temporary(stale):  # left by a killed run
            stale.unlink()
    key = options_hash(method, options)
    tasks = []
    for path in inputs:
        digest = content_hash(path)
        stem = f"{_safe_name(path)}-{digest[:16]}"
        tasks.append(Task(input=str(path), sha256=digest, sphere=str(out / f"{stem}.sphere.ply"),
                          spheremap=str(out / f"{stem}.spheremap.npz"), method=method,
                          options=dict(options), options_hash=key))

    journal, summary = out / JOURNAL, out / SUMMARY
    previous = {row["input"]: row for row in read_journal(journal)}
    done: Dict[str, Dict[str, Any]] = {}
    for task in tasks:
        row = previous.get(task.input)
        if row is not None and _reusable(row, task):
            done[task.input] = row
    # Compact: keep the rows being reused, each once; the rest will be redone.
    _write_text(journal, "".join(json.dumps(done[t.input], sort_keys=True) + "\n"
                                 for t in tasks if t.input in done))
    todo = [t for t in tasks if t.input not in done]
    bar = _Progress(len(tasks), progress)
    for row in done.values():
        bar.update(row)

    client: Any = None
    if scheduler is not None:
        try:
            distributed = importlib.import_module("distributed")
        except ImportError:
            raise MeshError("--scheduler needs dask: pip install 'spherify[dask]'") from None
        client = distributed.Client(scheduler)
        executor = client
    interrupted = False
    try:
        if executor is None:
            rows = _local_pool(todo, workers or os.cpu_count() or 1, timeout)
        else:
            if hasattr(executor, "get_executor") and not isinstance(executor, cf.Executor):
                executor = executor.get_executor()  # a dask.distributed.Client
            rows = _executor_pool(todo, executor, timeout)
        with open(journal, "a", encoding="utf-8") as handle:
            try:
                for row in rows:
                    _append(handle, row)
                    done[row["input"]] = row
                    bar.update(row)
            except KeyboardInterrupt:
                interrupted = True
            finally:
                close = getattr(rows, "close", None)
                if close is not None:
                    close()  # stops and reaps the local workers
    finally:
        bar.close()
        if client is not None:
            client.close()
    ordered = [done[t.input] for t in tasks if t.input in done]
    if interrupted:
        raise KeyboardInterrupt
    write_summary(summary, ordered)
    counts = {"meshes": len(tasks), "skipped": len(tasks) - len(todo),
              "certified": sum(bool(r.get("certified")) for r in ordered),
              "failed": sum(r.get("status") != "done" for r in ordered)}
    return BatchResult(rows=ordered, skipped=len(tasks) - len(todo), journal=journal,
                       summary=summary, counts=counts)


__all__ = ["BatchResult", "COLUMNS", "Task", "batch", "expand_inputs", "run_task"]
