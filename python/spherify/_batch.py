"""Many meshes: ``sp.batch`` and ``spherify batch``.

Each mesh is one task (``_batch_task.run_task``): read, map (the core
validates, orients and certifies), measure, then write
``<name>-<hash>.sphere.ply`` (the sphere as a mesh) and
``<name>-<hash>.spheremap.npz`` (as :meth:`SphereMap.save`) under temporary
names renamed into place. Only the task (paths and options) and its summary
row travel between processes; each worker reads its own input and writes its
own output.

Where it runs (``_batch_pool``):

* by default a local pool of ``workers`` processes, each running one mesh at
  a time, watched for ``timeout`` (the worker is killed) and for its death
  (out of memory, SIGKILL: the mesh is recorded with the signal); a new
  worker takes its place and the batch goes on;
* any ``concurrent.futures.Executor`` (``executor=``): the same tasks through
  ``submit``; with a timeout each task maps its mesh in a helper process it
  kills at the timeout, so the timeout holds there too;
* a Dask cluster: ``executor=`` a ``dask.distributed.Client`` or
  ``scheduler="tcp://..."`` (``pip install "spherify[dask]"``), through the
  client's executor, as any executor.

Resumable: ``OUT/journal.jsonl`` gets one JSON line per finished mesh,
flushed as it finishes (a killed process loses none of it) and synced to disk
at most once a second and at the end; ``OUT/summary.csv`` is written at the
end. A rerun with the same method and options skips every mesh whose journal
row says it was written, whose outputs still have the size and SHA-256 the row
recorded, and whose input still has the content hash (SHA-256) recorded; it
redoes the rest. So nothing is trusted that a crash could have left
incomplete: a row lost with the last second of a power cut means that mesh is
mapped again, an output left empty by one fails its hash. The journal is
compacted at the start of a run (rows of meshes that will be redone are
dropped), so it never holds a mesh twice.
"""

from __future__ import annotations

import concurrent.futures as cf
import csv
import errno
import hashlib
import importlib
import io
import json
import os
import sys
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

from . import _args
from ._atomic import is_stale_temporary, is_temporary, write_atomically
from ._files import file_errors, file_sha256, require_regular_file, special_kind
from ._json_depth import too_deep
from ._batch_pool import LocalPool, executor_rows, usable_cores
from ._batch_task import COLUMNS, QUALITY, Task, file_matches, run_task
from ._embed import method_options, methods, pass_method, stray_options
from ._errors import FileError, FormatError, MeshError, SpherifyWarning

PathLike = Union[str, "os.PathLike[str]"]

JOURNAL = "journal.jsonl"
SUMMARY = "summary.csv"
#: Suffixes a folder is searched for (FreeSurfer surfaces by their names).
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl", ".npz", ".gii")
LIST_SUFFIXES = (".txt", ".lst")

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
    not exist; FormatError for a list that names itself, directly or through
    other lists; a SpherifyWarning for a folder without a mesh file (a wrong
    folder would otherwise give an empty batch that reports success)."""
    unique: Dict[Path, None] = {}
    for p in _expand(inputs, ()):
        unique.setdefault(p.resolve(), None)
    return list(unique)


def _expand(inputs: Iterable[PathLike], lists: Tuple[Path, ...]) -> List[Path]:
    """:func:`expand_inputs` inside the lists ``lists`` (resolved, outermost
    first), which a list must not name again (it recursed until
    ``RecursionError``; issue 26, finding 6)."""
    found: List[Path] = []
    for item in inputs:
        path = Path(os.fspath(item))
        if path.is_dir():
            meshes = sorted(p for p in path.rglob("*") if p.is_file() and _is_mesh_file(p))
            if not meshes:
                # Points at the caller of sp.batch (batch, its file_errors
                # wrapper, expand_inputs, and one _expand per list).
                warnings.warn(f"batch input folder {path} holds no mesh file (searched with its "
                              f"subfolders for {', '.join(MESH_SUFFIXES)} and FreeSurfer "
                              "surfaces such as lh.pial)", SpherifyWarning,
                              stacklevel=5 + len(lists))
            found.extend(meshes)
        elif path.suffix.lower() in LIST_SUFFIXES and path.is_file():
            resolved = path.resolve()
            if resolved in lists:
                chain = " -> ".join(str(p) for p in lists[lists.index(resolved):] + (resolved,))
                raise FormatError(f"{path}: a list of inputs that names itself ({chain})",
                                  str(path))
            found.extend(_expand(_read_list(path), lists + (resolved,)))
        elif path.is_file():
            found.append(path)
        elif path.exists():
            what = special_kind(path) or "not a regular file"
            raise MeshError(f"batch input {path} is {what}, not a mesh file: only regular "
                            "files are read")
        else:
            raise MeshError(f"batch input {path} does not exist")
    return found


def _read_list(path: Path) -> List[Path]:
    """The paths a ``.txt`` / ``.lst`` file lists (module doc of
    :func:`expand_inputs`); a listed path that does not exist is named with
    the list's line."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise FormatError(f"{path}: a list of paths must be UTF-8 text; byte {err.start} is not",
                          str(path), None, err.start) from None
    listed = []
    for number, line in enumerate(text.splitlines(), 1):
        entry = line.strip()
        if not entry or entry.startswith("#"):
            continue
        item = path.parent / entry
        try:
            exists = item.exists()
        except OSError as err:
            if err.errno != errno.ENAMETOOLONG:
                raise  # (a FileError through sp.batch: permission, I/O)
            # Raised, not "does not exist": a damaged list's line of
            # thousands of bytes (found by the fuzzer, issue 26).
            raise FormatError(f"{path} line {number}: the listed path is too long for the file "
                              f"system ({len(entry):,} characters): {entry[:80]!r}...",
                              str(path), number) from None
        if not exists:
            raise MeshError(f"batch input {item}, listed in {path} line {number}, does not exist "
                            "(a relative path is read from the list's folder)")
        listed.append(item)
    return listed


def options_hash(method: str, options: Dict[str, Any], weld: bool = False) -> str:
    """What must match for a rerun to reuse a result (``weld`` counts only
    when set, so that rows from before it existed stay reusable)."""
    what: Dict[str, Any] = {"method": method, "options": options}
    if weld:
        what["weld"] = True
    text = json.dumps(what, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# --- the journal --------------------------------------------------------------

#: The deepest nesting of lists and objects read from a journal line
#: (spherify writes 1; ``json`` recursed into 100,000 and failed).
MAX_JOURNAL_DEPTH = 16


def read_journal(path: Path) -> List[Dict[str, Any]]:
    """The rows of a journal. A line that is not a row (not UTF-8, not JSON,
    nested deeper than :data:`MAX_JOURNAL_DEPTH`, not an object whose
    ``input`` is a string) is skipped with a :class:`SpherifyWarning` naming
    its line, and its mesh is mapped again; a last line without its newline
    (cut short by a killed run) is skipped quietly. A FIFO, device or socket
    named ``journal.jsonl`` is a :class:`FormatError` at once (reading a FIFO
    would wait for a writer). Issue 26, findings 6 and 7."""
    require_regular_file(path)
    if not path.exists():
        return []
    data = path.read_bytes()
    lines = data.split(b"\n")
    rows = []
    for number, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        cut_short = number == len(lines)  # after the last newline
        why = None
        try:
            line = raw.decode("utf-8")
            if too_deep(line, MAX_JOURNAL_DEPTH):
                why = f"nested more than {MAX_JOURNAL_DEPTH} deep"
            else:
                row = json.loads(line)
                if not isinstance(row, dict):
                    why = f"a JSON {type(row).__name__}, not an object"
                elif not isinstance(row.get("input"), str):
                    why = "no input path (a string) in it"
        except UnicodeDecodeError as err:
            why = f"not UTF-8 (byte {err.start})"
        except ValueError as err:  # json.JSONDecodeError, a number beyond int's digit limit
            why = f"not JSON ({err})"
        if why is None:
            rows.append(row)
        elif not cut_short:
            warnings.warn(f"{path} line {number}: {why}; skipped (its mesh, if any, is mapped "
                          "again)", SpherifyWarning, stacklevel=2)
    return rows


def _reusable(row: Dict[str, Any], task: Task) -> bool:
    """Whether a journal row of an earlier run stands for ``task``: same
    input content, same options, and both outputs as the row wrote them."""
    return (row.get("status") == "done" and row.get("sha256") == task.sha256
            and row.get("options_hash") == task.options_hash
            and row.get("sphere") == task.sphere and row.get("spheremap") == task.spheremap
            and file_matches(task.sphere, row.get("sphere_bytes"), row.get("sphere_sha256"))
            and file_matches(task.spheremap, row.get("spheremap_bytes"),
                             row.get("spheremap_sha256")))


def _write_text(path: Path, text: str) -> None:
    """``text`` as UTF-8; a file name that is not UTF-8 (Python holds its
    bytes as lone surrogates) is written back as its own bytes, where strict
    UTF-8 raised UnicodeEncodeError at the end of the batch."""
    def fill(temporary: Path) -> None:
        temporary.write_text(text, encoding="utf-8", errors="surrogateescape")
    write_atomically(path, fill)


class _Journal:
    """The journal open for appending: each row flushed to the system as it
    comes (a killed process loses none), synced to disk at most once per
    ``SYNC_EVERY`` seconds and when closed (a power cut loses at most that
    much, and a lost row only means its mesh is mapped again)."""

    SYNC_EVERY = 1.0

    def __init__(self, path: Path) -> None:
        self.handle = open(path, "a", encoding="utf-8")
        self.synced = time.monotonic()

    def append(self, row: Dict[str, Any]) -> None:
        self.handle.write(json.dumps(row, sort_keys=True) + "\n")
        self.handle.flush()
        if time.monotonic() - self.synced >= self.SYNC_EVERY:
            self.sync()

    def sync(self) -> None:
        os.fsync(self.handle.fileno())
        self.synced = time.monotonic()

    def close(self) -> None:
        try:
            self.sync()
        finally:
            self.handle.close()


def write_summary(path: Path, rows: Sequence[Dict[str, Any]]) -> None:
    """summary.csv: one row per mesh in input order, the columns of COLUMNS."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(COLUMNS), extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if row.get(k) is None else row[k] for k in COLUMNS})
    _write_text(path, buffer.getvalue())


# --- the batch ----------------------------------------------------------------

@dataclass(repr=False)
class BatchResult:
    """What :func:`batch` did.

    Its repr is one line of counts (``BatchResult(5 meshes: 4 certified, 1
    failed; journal out/journal.jsonl)``); the rows are in ``rows`` and in
    the summary file.

    Attributes
    ----------
    rows : list of dict
        One per mesh, in input order: the columns of ``summary.csv``
        (:data:`spherify._batch.COLUMNS`).
    skipped : int
        Meshes already done by an earlier run with the same options (their
        rows are among ``rows``).
    journal : pathlib.Path
        ``OUTDIR/journal.jsonl``, one JSON row per mesh.
    summary : pathlib.Path
        ``OUTDIR/summary.csv``.
    interrupted : bool
        Whether the batch was stopped (Ctrl-C) before the end.
    counts : dict of str to int
        ``meshes``, ``skipped``, ``certified`` and ``failed``.
    """
    rows: List[Dict[str, Any]]
    skipped: int
    journal: Path
    summary: Path
    interrupted: bool = False
    counts: Dict[str, int] = field(default_factory=dict)

    def __repr__(self) -> str:
        certified = sum(_delivered(row) for row in self.rows)
        failed = sum(row.get("status") != "done" for row in self.rows)
        uncertified = len(self.rows) - certified - failed
        words = [f"{certified} certified", f"{failed} failed"]
        if uncertified:
            words.append(f"{uncertified} not certified")
        earlier = f"; {self.skipped} of them done by an earlier run" if self.skipped else ""
        stopped = "; interrupted" if self.interrupted else ""
        count = len(self.rows)
        return (f"BatchResult({count} mesh{'' if count == 1 else 'es'}: {', '.join(words)}"
                f"{earlier}{stopped}; journal {self.journal})")

    @property
    def all_certified(self) -> bool:
        """Every mesh certified and its outputs written (a row whose outputs
        could not be written, a full disk, has ``status="failed"``)."""
        return all(_delivered(row) for row in self.rows)


def _delivered(row: Dict[str, Any]) -> bool:
    """A mesh whose map is certified and whose outputs were written."""
    return row.get("status") == "done" and bool(row.get("certified"))


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


@file_errors
def batch(paths: Union[PathLike, Iterable[PathLike]], out_dir: PathLike, executor: Any = None, *,
          method: str = "progressive", workers: Optional[int] = None,
          timeout: Optional[float] = None, scheduler: Optional[str] = None,
          progress: bool = False, weld: bool = False, **options: Any) -> BatchResult:
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
        None: a local pool of ``workers`` processes (default: the number of
        cores this process may use), each a fresh interpreter whose core
        calls run on ``cores // workers`` threads and which writes one mesh's
        outputs while it maps the next; it enforces ``timeout`` by killing
        the worker (another mesh the worker held goes back to the queue).
        An executor gets one task per mesh; with ``timeout`` each
        task maps its mesh in a helper process it kills at the timeout
        (helpers are kept for the executor worker's next tasks).
    method, **options
        Passed to :func:`spherify.embed`; JSON-representable values only. The
        default is :func:`spherify.embed`'s: the progressive map, certified on
        every mesh tried; ``method="theta_phi"`` is some four times faster
        and certified on shapes without long limbs or spikes (README,
        "Mapping to the sphere").
    timeout : float, optional
        Seconds per mesh; a mesh past it is recorded as failed.
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:8786``): the batch runs there.
    progress : bool
        Draw a progress bar on stderr.
    weld : bool
        Merge vertices at exactly the same position first (:func:`spherify.weld`:
        texture seams that exporters split).

    Returns
    -------
    BatchResult
        ``rows``: one dict per mesh, in input order, with the keys of
        :data:`COLUMNS`. ``peak_memory_mb`` is the peak resident memory of
        the process that mapped the mesh while it did (interpreter and
        libraries included, some 60 MB): on Linux its high-water mark is
        reset at the start of each mesh (``/proc/self/clear_refs``; in the
        local pool, whose workers write one mesh while they map the next,
        again once the previous mesh is written, and read when the map
        ends, so that it holds neither mesh's writing);
        elsewhere it is the process's peak so far, an upper bound, and None
        on Windows. Under a threaded executor (Dask's default) without
        ``timeout``, meshes mapped at the same time in one process share
        the figure (with ``timeout`` each has its helper process).
        ``seconds_quality`` and ``seconds_write`` overlap (the measures
        run while the outputs are written). A mesh that failed (unreadable, not genus 0, a
        panic, a timeout, a dead worker) has ``status="failed"`` and
        ``error_type`` / ``error``; the batch goes on.

    Raises
    ------
    MeshError
        An input path that does not exist, bad ``workers`` or ``timeout``, an
        unknown method, an option the method does not take
        (:func:`spherify.method_options` lists each method's; theta-phi's
        ``poles`` without ``method="theta_phi"``, say), or options that cannot
        be stored.
    FileError
        ``out_dir`` cannot be made or written, or another batch is writing
        into it (``errno.EBUSY``: two at once would each rewrite the journal).
    KeyboardInterrupt
        After Ctrl-C, once the workers are stopped; the journal holds every
        mesh that finished, and a rerun resumes.

    Warns
    -----
    SpherifyWarning
        A folder among ``paths`` holds no mesh file.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    inputs = expand_inputs(paths)
    if workers is not None:
        workers = _args.integer(workers, "workers", minimum=1)
    if timeout is not None and not timeout > 0:
        raise MeshError(f"timeout must be positive seconds, got {timeout}")
    if executor is not None and scheduler is not None:
        raise MeshError("give executor= or scheduler=, not both")
    _check_method(method, options)
    try:
        json.dumps(options)
    except TypeError as err:
        raise MeshError(f"batch options must be JSON values (numbers, strings, lists): {err}") from None
    out = Path(os.fspath(out_dir))
    out.mkdir(parents=True, exist_ok=True)
    with _folder_lock(out):
        return _batch_into(out, inputs, executor, method, workers, timeout, scheduler, progress,
                           options, weld)


def _check_method(method: str, options: Dict[str, Any]) -> None:
    """Refuses at once what would fail every mesh alike: an unknown method,
    and an option the method does not take (the core's table says which
    options each method takes; the batch's default was theta-phi until the
    progressive map became spherify's default, and a call written then would
    otherwise record every mesh as failed). Values are the core's to check,
    per mesh."""
    taken = method_options(method)
    stray = stray_options(options, method)
    if stray is not None:
        what, owners, them = stray
        raise MeshError(f"{what}, not of method {method!r}: {pass_method(owners, quote=chr(39))} "
                        f"to use {them} (sp.batch's default method is sp.embed's, 'progressive')")
    unknown = [name for name in options if name not in taken]
    if unknown:
        raise MeshError(f"method {method!r} has no option {', '.join(map(repr, unknown))}; "
                        f"its options are: {', '.join(sorted(taken))}")


@contextmanager
def _folder_lock(out: Path) -> Iterator[None]:
    """One batch at a time in an output folder. Two would each rewrite the
    journal from what they read (one's rows would go to a replaced file) and
    write summary.csv in turn: neither would say what the folder holds. An
    advisory lock on the folder itself (no lock file is left behind; the
    system releases it when the process ends, however it ends) makes the
    second raise at once; without ``fcntl`` (not POSIX) there is no lock."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    folder = os.open(out, os.O_RDONLY)
    try:
        try:
            fcntl.flock(folder, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FileError(errno.EBUSY, "another spherify batch is writing into this folder; "
                            "wait for it, or give another folder", str(out)) from None
        yield
    finally:
        os.close(folder)


def _batch_into(out: Path, inputs: List[Path], executor: Any, method: str,
                workers: Optional[int], timeout: Optional[float], scheduler: Optional[str],
                progress: bool, options: Dict[str, Any], weld: bool) -> BatchResult:
    """:func:`batch` once its arguments are checked and ``out`` is locked."""
    for stale in out.iterdir():
        if is_stale_temporary(stale):  # left by a killed run
            stale.unlink()
    client: Any = None
    if scheduler is not None:
        try:
            distributed = importlib.import_module("distributed")
        except ImportError:
            raise MeshError("--scheduler needs dask: pip install 'spherify[dask]'") from None
        client = distributed.Client(scheduler)
        executor = client
    # The local workers start now and import spherify while the inputs are
    # hashed and the journal read.
    pool = (LocalPool(min(workers or usable_cores(), len(inputs)))
            if executor is None and inputs else None)
    interrupted = False
    bar = _Progress(len(inputs), progress)
    try:
        key = options_hash(method, options, weld)
        tasks = []
        for path in inputs:
            digest = file_sha256(path)
            stem = f"{_safe_name(path)}-{digest[:16]}"
            tasks.append(Task(input=str(path), sha256=digest,
                              sphere=str(out / f"{stem}.sphere.ply"),
                              spheremap=str(out / f"{stem}.spheremap.npz"), method=method,
                              options=dict(options), options_hash=key, weld=weld))
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
        for row in done.values():
            bar.update(row)
        rows: Iterator[Dict[str, Any]]
        if pool is not None:
            rows = pool.rows(todo, timeout)
        else:
            if hasattr(executor, "get_executor") and not isinstance(executor, cf.Executor):
                executor = executor.get_executor()  # a dask.distributed.Client
            rows = executor_rows(todo, executor, timeout)
        appender = _Journal(journal)
        try:
            for row in rows:
                appender.append(row)
                done[row["input"]] = row
                bar.update(row)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            close = getattr(rows, "close", None)
            if close is not None:
                close()  # stops and reaps the workers
            appender.close()
    finally:
        bar.close()
        if pool is not None:
            pool.close()
        if client is not None:
            client.close()
    ordered = [done[t.input] for t in tasks if t.input in done]
    if interrupted:
        raise KeyboardInterrupt
    write_summary(summary, ordered)
    counts = {"meshes": len(tasks), "skipped": len(tasks) - len(todo),
              "certified": sum(_delivered(r) for r in ordered),
              "failed": sum(r.get("status") != "done" for r in ordered)}
    return BatchResult(rows=ordered, skipped=len(tasks) - len(todo), journal=journal,
                       summary=summary, counts=counts)


__all__ = ["BatchResult", "COLUMNS", "QUALITY", "Task", "batch", "expand_inputs", "run_task"]
