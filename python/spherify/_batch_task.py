"""One mesh of a batch (:func:`run_task`): read, map (the core validates and
orients on the way, and certifies), measure, write, and the summary row that
says what happened. Runs in a worker; what travels is a :class:`Task` (paths
and options) in and a row (a dict of plain values) out. The work comes in two
halves, :func:`map_task` and :func:`finish_task` (measure and write), so that
a worker of the local pool can write one mesh while it maps the next.

The outputs are written under temporary names and renamed into place, without
an ``fsync``: a killed worker cannot leave a half-written file under a final
name (the rename is atomic), and the row records the size and SHA-256 of each
output, hashed from the bytes as they were written, so that a rerun after a
power loss (which may leave a renamed file empty) finds the mismatch and maps
the mesh again rather than trusting the file (``_batch._reusable``).
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import io
import os
import re
import sys
import time
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._atomic import temporary_path
from ._files import file_sha256

#: The columns of summary.csv, in order; the journal's rows hold the same keys.
COLUMNS = ("input", "sha256", "status", "certified", "n_vertices", "n_faces", "method",
           "valid", "tp_valid", "flipped", "margin", "angle_mean_deg", "angle_max_deg",
           "conformal_mean", "area_log_std", "stretch_l2", "stretch_linf", "edge_length_cv",
           "seconds_read", "seconds_map", "seconds_certify", "seconds_quality",
           "seconds_write", "seconds_total", "peak_memory_mb", "sphere", "sphere_bytes",
           "sphere_sha256", "spheremap", "spheremap_bytes", "spheremap_sha256",
           "error_type", "error", "warnings", "options_hash")
#: The quality measures copied into a row.
QUALITY = ("angle_mean_deg", "angle_max_deg", "conformal_mean", "area_log_std", "stretch_l2",
           "stretch_linf", "edge_length_cv")


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
    #: Merge vertices at one position before mapping (``sp.weld``).
    weld: bool = False


def failed_row(task: Task, error_type: str, message: str) -> Dict[str, Any]:
    """The row of a mesh that failed outside :func:`run_task` (a timeout, a
    dead worker, an executor that lost it)."""
    row: Dict[str, Any] = {key: None for key in COLUMNS}
    row.update(input=task.input, sha256=task.sha256, method=task.method,
               options_hash=task.options_hash, status="failed", certified=False,
               error_type=error_type, error=message)
    return row


# --- peak memory per mesh -------------------------------------------------------

_HWM = re.compile(rb"VmHWM:\s+(\d+)\s+kB")


def reset_peak_memory() -> bool:
    """Start a new high-water mark of this process's resident memory (Linux:
    writing 5 to /proc/self/clear_refs resets VmHWM to the current RSS).
    False where that is not possible (other systems, a locked-down /proc)."""
    try:
        with open("/proc/self/clear_refs", "w") as handle:
            handle.write("5")
        return True
    except OSError:
        return False


def peak_memory_mb(reset: bool) -> Optional[float]:
    """The peak resident memory (MB) of this process since :func:`reset_peak_memory`
    when ``reset`` (it succeeded): VmHWM from /proc/self/status. Otherwise the
    process's peak since it started (``getrusage``), an upper bound of the
    mesh's; None where neither exists (Windows)."""
    if reset:
        try:
            with open("/proc/self/status", "rb") as handle:
                found = _HWM.search(handle.read())
            if found:
                return round(int(found.group(1)) / 1024, 1)
        except OSError:
            pass
    try:
        import resource
    except ImportError:
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # kilobytes on Linux, bytes on macOS
    return round(peak / (1 << 20 if sys.platform == "darwin" else 1 << 10), 1)


# --- writing ------------------------------------------------------------------

class Output:
    """One output written under a temporary name beside its final one (no
    fsync: see the module docstring), with its size and SHA-256; renamed into
    place by :meth:`commit`, or removed by :meth:`discard`."""

    def __init__(self, path: str, data: bytes) -> None:
        self.target = Path(path)
        self.temporary = temporary_path(self.target)
        self.size, self.sha256 = len(data), hashlib.sha256(data).hexdigest()
        try:
            with open(self.temporary, "wb") as handle:
                handle.write(data)
        except BaseException:
            self.discard()
            raise

    def commit(self) -> None:
        os.replace(self.temporary, self.target)

    def discard(self) -> None:
        if self.temporary.exists():
            self.temporary.unlink()


def file_matches(path: str, size: Any, sha256: Any) -> bool:
    """Whether the file at ``path`` has this size and SHA-256 (what a row
    recorded when it wrote the file)."""
    try:
        if not isinstance(size, int) or os.path.getsize(path) != size:
            return False
        return bool(file_sha256(path) == sha256)
    except OSError:
        return False


# --- one mesh -----------------------------------------------------------------

def _timed(function: Any, *args: Any) -> Tuple[Any, float]:
    start = time.perf_counter()
    result = function(*args)
    return result, round(time.perf_counter() - start, 6)


def _fault(row: Dict[str, Any], err: BaseException) -> None:
    """Records in ``row`` an error that is the mesh's fault; re-raises Ctrl-C
    and SystemExit, which are not."""
    if isinstance(err, (KeyboardInterrupt, SystemExit)):
        raise err
    if isinstance(err, Exception):
        row.update(error_type=type(err).__name__, error=str(err))
    else:  # a Rust panic (PanicException) is a BaseException
        row.update(error_type=type(err).__name__,
                   error=f"{err} ({traceback.format_exc(limit=1).strip()})")


@dataclass
class Mapped:
    """A mesh between :func:`map_task` and :func:`finish_task`: its row so
    far, and its map when it has one."""
    task: Task
    row: Dict[str, Any]
    map: Any
    #: Seconds spent on the mesh so far (reading, mapping, certifying).
    seconds: float
    #: Whether the process's memory high-water mark was reset for this mesh.
    reset: bool


def map_task(task: Task) -> Mapped:
    """The first half of :func:`run_task`: read, map and certify (the core
    validates and orients on the way); never raises for the mesh's faults.
    The row's ``peak_memory_mb`` is left for the caller to read once it
    knows which work the figure covers (``run_task``, ``child_main``)."""
    from ._embed import embed
    from ._mesh import load, weld
    from ._spheremap import ThetaPhiMap

    reset = reset_peak_memory()
    row: Dict[str, Any] = {key: None for key in COLUMNS}
    row.update(input=task.input, sha256=task.sha256, method=task.method,
               options_hash=task.options_hash, status="failed", certified=False)
    start = time.perf_counter()
    m = None
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = load(task.input)
            if task.weld:
                mesh = weld(mesh)
            row.update(n_vertices=mesh.n_vertices, n_faces=mesh.n_faces)
            row["seconds_read"] = round(time.perf_counter() - start, 6)
            # embed validates (a TopologyError carries the MeshReport), orients
            # and certifies in the core: no separate sp.check.
            m = embed(mesh, task.method, **task.options)
            certify = m.seconds.get("certify", 0.0)
            row["seconds_map"] = round(time.perf_counter() - start - row["seconds_read"]
                                       - certify, 6)
            row["seconds_certify"] = round(certify, 6)
            row.update(valid=m.valid, flipped=m.flipped, margin=float(m.margin))
            # Certified: what is written is what it claims to be. The sphere
            # mesh is the minor-arc drawing, so it must be valid; a theta-phi
            # map's .spheremap.npz carries h, whose rectangle must be
            # certified too. (Counting the rectangle alone called batches of
            # limbed shapes certified while their sphere meshes folded over.)
            certified = m.valid
            if isinstance(m, ThetaPhiMap):
                row["tp_valid"] = m.tp_valid
                certified = m.valid and m.tp_valid
            row["certified"] = bool(certified)
        row["warnings"] = "; ".join(str(w.message) for w in caught) or None
    except BaseException as err:
        _fault(row, err)
        m = None
    return Mapped(task=task, row=row, map=m, seconds=time.perf_counter() - start, reset=reset)


def finish_task(mapped: Mapped) -> Dict[str, Any]:
    """The second half of :func:`run_task`: measure the map, write the sphere
    mesh and the ``.spheremap.npz`` under temporary names, rename them into
    place, and complete the row; never raises for the mesh's faults. Only
    core calls that release the GIL and file writes: a worker runs it on a
    thread of its own while it maps its next mesh."""
    from . import _core
    from ._mesh import Mesh
    from ._persist import record
    from ._quality import quality

    row, m, task = mapped.row, mapped.map, mapped.task
    start = time.perf_counter()
    if m is not None:
        try:
            # The measures (in the core, without the GIL) and the writing of
            # the outputs run at the same time; the outputs are renamed into
            # place once both are done, so a mesh whose row says "failed"
            # leaves no output.
            # (The encoding runs first: it takes the core's thread pool, which
            # the measures then have to themselves.)
            clock = time.perf_counter()
            sphere = _core.encode(Mesh(m.points, m.mesh.faces)._core, task.sphere)
            with cf.ThreadPoolExecutor(1) as helper:
                measuring = helper.submit(_timed, quality, m.mesh, m.points)
                outputs: List[Output] = []
                committed = 0
                try:
                    outputs.append(Output(task.sphere, sphere))
                    buffer = io.BytesIO()
                    arrays: Dict[str, Any] = record(m)
                    np.savez(buffer, **arrays)
                    outputs.append(Output(task.spheremap, buffer.getvalue()))
                    row["seconds_write"] = round(time.perf_counter() - clock, 6)
                    q, row["seconds_quality"] = measuring.result()
                    row.update({k: float(q[k]) for k in QUALITY})
                    for output in outputs:
                        output.commit()
                        committed += 1
                except BaseException:
                    # Failed between the two renames (a full disk): the mesh
                    # has a failed row, so it keeps no output at all.
                    for output in outputs[:committed]:
                        output.target.unlink(missing_ok=True)
                    raise
                finally:
                    for output in outputs:
                        output.discard()
            row["sphere_bytes"], row["sphere_sha256"] = outputs[0].size, outputs[0].sha256
            row["spheremap_bytes"], row["spheremap_sha256"] = outputs[1].size, outputs[1].sha256
            row.update(status="done", sphere=task.sphere, spheremap=task.spheremap)
        except BaseException as err:
            # Not written (a full disk, a folder in the way): not delivered,
            # so not counted certified (issue 26, finding 2).
            row["certified"] = False
            _fault(row, err)
    row["seconds_total"] = round(mapped.seconds + time.perf_counter() - start, 6)
    return row


def run_task(task: Task) -> Dict[str, Any]:
    """Map one mesh and write its outputs (:func:`map_task`, then
    :func:`finish_task`); never raises for the mesh's faults: the row says
    what went wrong. Runs in a worker. The row's peak memory is the
    process's over both halves."""
    mapped = map_task(task)
    row = finish_task(mapped)
    row["peak_memory_mb"] = peak_memory_mb(mapped.reset)
    return row
