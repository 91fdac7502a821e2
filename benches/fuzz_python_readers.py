"""A mutation fuzzer for the readers that live in Python (docs/reliability.md,
"Fuzzing"): ``.npz`` meshes, GIfTI and FreeSurfer surfaces, sphere maps
(``sp.load_map``), pickled sphere maps (unpickling rebuilds them through the
same record), a batch's ``journal.jsonl`` (read, and each row tried for
reuse as a rerun does) and geometry images (``sp.load_geometry_image``).
``crates/mesh/examples/fuzz_readers.rs`` does the same for the core's OBJ,
OFF, PLY and STL readers.

Pickles are loaded by an unpickler that resolves only the globals the seed
pickle names (``spherify._persist.unpickle_map``: a map pickles as the bytes
of its ``.spheremap.npz``): an error of the pickle machine itself (a damaged
opcode stream) is the pickle format's, not spherify's, and is not counted;
an exception that leaves ``unpickle_map`` other than a ``SpherifyError`` is
a finding.

Each input is a valid file written by spherify, mutated a few times (bytes
set, cut, inserted, swapped, a slice repeated; a file cut short; a 32-bit field set to an
extreme; the first four bytes set to another format's magic; the shape in an
``.npy`` header changed). A finding is a read that raises anything other
than a ``SpherifyError``, leaves a file open (a ``ResourceWarning``), or
takes longer than ``--slow`` seconds, or raises the process's peak resident
memory by more than ``--extra-mb`` over what it was before the input (Linux:
the high-water mark is reset before each input through
``/proc/self/clear_refs``). Findings are written to ``--out`` and the exit
status is 1 when there is any. ``--only`` fuzzes some seeds (by name).

    python benches/fuzz_python_readers.py --inputs 20000 --seed 1
    python benches/fuzz_python_readers.py --inputs 600000 --seed 3 \
        --only mesh.npz,tp.spheremap.npz,pm.spheremap.npz,lm.spheremap.npz,tp.pickle,pm.pickle,journal.jsonl
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import gc
import io
import pickle
import random
import signal
import re
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Set, Tuple

import numpy as np

import spherify as sp
from spherify import _batch, _files, _persist
from spherify._batch_task import Task, peak_memory_mb, reset_peak_memory

#: Field values that break size and count checks.
EXTREMES = (0, 1, 2**31 - 1, 2**31, 2**31 + 5, 2**32 - 1)
#: The magic numbers of the formats read here and of a plain .npy array.
MAGICS = (b"\x93NUM", b"PK\x05\x06", b"PK\x03\x04", b"\x89PNG", b"\xff\xff\xfe\x00")
#: Shapes written into an .npy header in place of the real one.
SHAPES = (b"10000000000000, 3", b"-1, 3", b"3", b"60, 3, 2", b"", b"0, 3", b"4294967297, 3",
          b"99999999999999999999999,")
SHAPE_FIELD = re.compile(rb"'shape': \(([0-9, -]*)\)")


class PickleMachineError(Exception):
    """An error of the pickle machine itself (not of spherify's rebuild)."""


class RebuildError(Exception):
    """``rebuild`` raised something other than a SpherifyError (a finding)."""


def globals_of(data: bytes) -> Set[Tuple[str, str]]:
    """The (module, name) globals a pickle resolves as it loads."""
    found: Set[Tuple[str, str]] = set()

    class Recording(pickle.Unpickler):
        def find_class(self, module: str, name: str) -> Any:
            found.add((module, name))
            return super().find_class(module, name)
    Recording(io.BytesIO(data)).load()
    return found


#: The resident memory (MB) and the time when ``rebuild`` began on the
#: current input, when it did: a pickle's peak and seconds are measured from
#: there, since what the pickle machine does before (allocating for a length
#: field of gigabytes, numpy taking 3.7 s over a mutated array) is Python's.
REBUILD_START: Dict[str, Optional[float]] = {"mb": None, "at": None}


def checked(rebuild: Callable[[Any, str], Any]) -> Callable[[Any, str], Any]:
    """``rebuild`` (``_persist.unpickle_map``, or ``_persist.rebuild`` of
    pickles written before maps pickled as archive bytes), its start noted
    and anything but a SpherifyError made a finding."""
    def run(record: Any, source: str) -> Any:
        REBUILD_START["mb"] = peak_memory_mb(reset_peak_memory())
        REBUILD_START["at"] = time.perf_counter()
        try:
            return rebuild(record, source)
        except sp.SpherifyError:
            raise
        except Exception as err:
            raise RebuildError(f"{type(err).__name__}: {err}") from err
    return run


SPHERIFY_REBUILDERS = {("spherify._persist", "unpickle_map"): checked(_persist.unpickle_map),
                       ("spherify._persist", "rebuild"): checked(_persist.rebuild)}


def pickle_reader(allowed: Set[Tuple[str, str]]) -> Callable[[Path], object]:
    """Unpickles a file with only ``allowed`` globals, rebuild wrapped."""
    class Restricted(pickle.Unpickler):
        def find_class(self, module: str, name: str) -> Any:
            if (module, name) in SPHERIFY_REBUILDERS:
                return SPHERIFY_REBUILDERS[(module, name)]
            if (module, name) not in allowed:
                raise pickle.UnpicklingError(f"global {module}.{name} is not allowed")
            return super().find_class(module, name)

    def read(path: Path) -> object:
        try:
            return Restricted(io.BytesIO(path.read_bytes())).load()
        except (sp.SpherifyError, RebuildError):
            raise
        except Exception as err:  # the pickle machine's or numpy's reconstruction
            raise PickleMachineError(f"{type(err).__name__}: {err}") from None
    return read


def journal_reader(folder: Path, tasks: List[Task]) -> Callable[[Path], object]:
    """Reads a journal as a rerun does: its rows, each tried for reuse
    against the seed batch's tasks, and a summary written from them."""
    def read(path: Path) -> object:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)  # damaged lines: expected
            rows = _batch.read_journal(path)
        previous = {row["input"]: row for row in rows}
        reused = [previous[t.input] for t in tasks
                  if t.input in previous and _batch._reusable(previous[t.input], t)]
        _batch.write_summary(folder / "fuzz-summary.csv", reused)  # (what a rerun writes)
        return reused
    return read


def seed_batch(folder: Path) -> Tuple[bytes, List[Task]]:
    """The journal of a small batch (two meshes, one broken) and its tasks."""
    inputs = folder / "batch-in"
    inputs.mkdir()
    sp.save(sp.datasets.make("icosphere", 50), inputs / "a.ply")
    (inputs / "broken.obj").write_text("v 0 0 0\nf 1 2 3\n")
    out = folder / "batch-out"
    with cf.ThreadPoolExecutor(1) as pool:
        sp.batch(inputs, out, executor=pool)
    key = _batch.options_hash("progressive", {})
    tasks = []
    for path in sorted(inputs.iterdir()):
        digest = _files.file_sha256(path)
        stem = f"{_batch._safe_name(path)}-{digest[:16]}"
        tasks.append(Task(input=str(path.resolve()), sha256=digest,
                          sphere=str(out / f"{stem}.sphere.ply"),
                          spheremap=str(out / f"{stem}.spheremap.npz"), method="progressive",
                          options={}, options_hash=key))
    return (out / _batch.JOURNAL).read_bytes(), tasks


def refined_map(mesh: sp.Mesh, m: sp.SphereMap) -> sp.SphereMap:
    """A map whose 12 landmarks, each turned 0.8 radians its own way, are laid
    out on a refined mesh (268 vertices from 42): its file holds the map back
    (format 2), which the reader checks row by row."""
    ids = sp.datasets.farthest_points(m.points, 12)
    points = m.points[ids]
    tangent = np.random.default_rng(2).normal(size=points.shape)
    tangent -= (tangent * points).sum(1, keepdims=True) * points
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    refined = sp.embed(mesh, landmarks=(ids, np.cos(0.8) * points + np.sin(0.8) * tangent))
    assert refined.refinement is not None, "the seed must be a refined map"
    return refined


def seed_files(folder: Path) -> Dict[str, Tuple[bytes, Callable[[Path], object]]]:
    """Valid files of every Python-read format, with the call that reads each."""
    mesh = sp.datasets.make("bumpy_blob", 60)
    files: Dict[str, Callable[[Path], object]] = {"mesh.npz": sp.load}
    try:
        import nibabel  # noqa: F401
        files.update({"mesh.surf.gii": sp.load, "lh.pial": sp.load})
    except ImportError:
        print("nibabel missing: GIfTI and FreeSurfer are not fuzzed", file=sys.stderr)
    for name in files:
        sp.save(mesh, folder / name)
    tp, pm = sp.embed(mesh, "theta_phi"), sp.embed(mesh)
    tp.save(folder / "tp.spheremap.npz")
    pm.save(folder / "pm.spheremap.npz")
    refined_map(mesh, pm).save(folder / "lm.spheremap.npz")
    sp.save_geometry_image(np.random.default_rng(0).random((9, 9, 3)), folder / "image.png")
    files.update({"tp.spheremap.npz": sp.load_map, "pm.spheremap.npz": sp.load_map,
                  "lm.spheremap.npz": sp.load_map,
                  "image.png": sp.load_geometry_image})
    seeds = {name: ((folder / name).read_bytes(), read) for name, read in files.items()}
    for name, m in (("tp.pickle", tp), ("pm.pickle", pm)):
        # The default protocol (4), as multiprocessing and Dask send maps.
        # When maps pickled their record's arrays as numpy objects, a mutated
        # pickle could free a bytearray numpy viewed in place or give numpy a
        # damaged dtype, and numpy crashed the process about once in
        # 100,000-220,000 inputs; a map now pickles as bytes, which the pickle
        # machine builds without numpy (docs/reliability.md).
        data = pickle.dumps(m, protocol=pickle.DEFAULT_PROTOCOL)
        seeds[name] = (data, pickle_reader(globals_of(data)))
    journal, tasks = seed_batch(folder)
    seeds["journal.jsonl"] = (journal, journal_reader(folder, tasks))
    # A list of inputs for `spherify batch` (paths relative to its folder, a
    # comment, a blank line), read as the batch reads one. Not expanded: a
    # mutated line naming "/" would have the batch search the whole disk for
    # meshes, which is what such a list asks for, not a reader's fault.
    listed = b"# two meshes\nbatch-in/a.ply\n\nbatch-in/broken.obj\n"
    seeds["inputs.txt"] = (listed, _files.file_errors(_batch._read_list))
    return seeds


def mutate(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        op = rng.random()
        if not b:
            b.extend(rng.randbytes(rng.randint(1, 16)))
        elif op < 0.35:
            b[rng.randrange(len(b))] = rng.randrange(256)
        elif op < 0.5:
            at = rng.randrange(len(b))
            del b[at:at + rng.randint(1, 64)]
        elif op < 0.65:
            at = rng.randrange(len(b) + 1)
            b[at:at] = rng.randbytes(rng.randint(1, 16))
        elif op < 0.72:
            del b[rng.randrange(len(b)):]
        elif op < 0.82 and len(b) >= 4:
            at = rng.randrange(len(b) - 3)
            b[at:at + 4] = rng.choice(EXTREMES).to_bytes(4, rng.choice(("little", "big")))
        elif op < 0.87:
            b[0:4] = rng.choice(MAGICS)
        elif op < 0.94:
            fields = list(SHAPE_FIELD.finditer(bytes(b)))
            if fields:
                field = rng.choice(fields)
                b[field.start(1):field.end(1)] = rng.choice(SHAPES)
        elif op < 0.97:
            i, j = rng.randrange(len(b)), rng.randrange(len(b))
            b[i], b[j] = b[j], b[i]
        else:
            # A slice repeated up to 600 times: lines, names and fields far
            # longer than the seeds' (a list's line of 5,000 bytes gave a raw
            # OSError, ENAMETOOLONG).
            at = rng.randrange(len(b))
            piece = b[at:at + rng.randint(1, 32)]
            b[at:at] = piece * rng.randint(2, 600)
    return bytes(b)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--inputs", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--slow", type=float, default=5.0, help="seconds that make a finding")
    parser.add_argument("--out", type=Path, default=Path("fuzz-python-findings"))
    parser.add_argument("--only", default=None,
                        help="comma-separated seed names to fuzz (default: all)")
    parser.add_argument("--report-every", type=int, default=0,
                        help="print a progress line every this many inputs (0: never)")
    parser.add_argument("--max-memory-gb", type=float, default=4.0,
                        help="address-space limit of the process (RLIMIT_AS; 0: none): an "
                             "allocation beyond it raises MemoryError (a finding unless the "
                             "pickle machine made it) instead of filling the machine")
    parser.add_argument("--extra-mb", type=float, default=200.0,
                        help="peak resident memory above the start of an input that makes a "
                             "finding (Linux)")
    args = parser.parse_args()
    if args.max_memory_gb > 0:
        try:
            import resource
            limit = int(args.max_memory_gb * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        except (ImportError, ValueError, OSError):
            print("no address-space limit on this system", file=sys.stderr)
    rng = random.Random(args.seed)
    findings: List[str] = []
    start = time.perf_counter()
    counts: Dict[str, int] = {}
    stats: Dict[str, Any] = {"pickle_refused": 0, "worst_extra": 0.0, "worst_input": "",
                             "stop": False}
    stopped = False
    measure = reset_peak_memory()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        seeds = seed_files(folder)
        if args.only:
            wanted = args.only.split(",")
            unknown = sorted(set(wanted) - set(seeds))
            if unknown:
                parser.error(f"--only: no seed named {', '.join(unknown)}; seeds: "
                             f"{', '.join(sorted(seeds))}")
            seeds = {name: seeds[name] for name in wanted}
        names = sorted(seeds)
        # SIGTERM stops a long run after the input at hand, and it reports
        # what it did.
        signal.signal(signal.SIGTERM, lambda *_: stats.__setitem__("stop", True))
        fuzz(args, rng, folder, seeds, names, findings, counts, stats, measure)
        stopped = bool(stats["stop"])
    done = sum(counts.values())
    per_seed = ", ".join(f"{name} {counts.get(name, 0)}" for name in names)
    worst_extra, worst_input = stats["worst_extra"], stats["worst_input"]
    memory = (f"; largest peak above an input's start {worst_extra:.1f} MB ({worst_input}), "
              f"process peak {peak_memory_mb(False)} MB" if measure else "")
    print(f"fuzz_python_readers: {done} inputs ({per_seed}) from seed {args.seed} "
          f"in {time.perf_counter() - start:.1f} s{' (stopped early)' if stopped else ''}: "
          f"{len(findings)} findings; {stats['pickle_refused']} pickles refused by the pickle "
          f"machine{memory}")
    return 1 if findings else 0


def fuzz(args: argparse.Namespace, rng: random.Random, folder: Path,
         seeds: Dict[str, Tuple[bytes, Callable[[Path], object]]], names: List[str],
         findings: List[str], counts: Dict[str, int], stats: Dict[str, Any],
         measure: bool) -> None:
    """The loop of :func:`main`: ``args.inputs`` mutated inputs."""
    start = time.perf_counter()
    for k in range(args.inputs):
        if stats["stop"]:
            break
        name = rng.choice(names)
        data, read = seeds[name]
        path = folder / f"input-{name}"
        path.write_bytes(mutate(data, rng))
        counts[name] = counts.get(name, 0) + 1
        began = time.perf_counter()
        problem = None
        before = peak_memory_mb(reset_peak_memory()) if measure else None
        REBUILD_START["mb"] = REBUILD_START["at"] = None
        is_pickle = name.endswith(".pickle")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                read(path)
            except sp.SpherifyError:
                pass
            except PickleMachineError:
                stats["pickle_refused"] += 1
            except (KeyboardInterrupt, SystemExit):
                raise
            except BaseException as err:  # the finding itself (a Rust panic included)
                problem = f"{type(err).__name__}: {err}"
            gc.collect(0)  # an unclosed file held in a cycle warns when collected
        if is_pickle and before is not None:
            before = REBUILD_START["mb"]  # None: the pickle machine refused it
        if before is not None:
            after = peak_memory_mb(True)
            extra = (after or 0.0) - before
            if extra > stats["worst_extra"]:
                stats["worst_extra"] = extra
                stats["worst_input"] = f"input {k} ({name}, {len(data)} bytes seed)"
            if problem is None and extra > args.extra_mb:
                problem = f"peak memory {extra:.0f} MB above the start"
        leaks = [w for w in caught if issubclass(w.category, ResourceWarning)]
        if problem is None and leaks:
            problem = f"ResourceWarning: {leaks[0].message}"
        seconds = time.perf_counter() - began
        if is_pickle:  # spherify's part of it: from where rebuild began
            at = REBUILD_START["at"]
            seconds = 0.0 if at is None else time.perf_counter() - at
        if problem is None and seconds > args.slow:
            problem = f"slow: {seconds:.1f} s"
        if args.report_every and (k + 1) % args.report_every == 0:
            print(f"{k + 1} inputs, {len(findings)} findings, "
                  f"{time.perf_counter() - start:.0f} s, largest peak above an input's "
                  f"start {stats['worst_extra']:.1f} MB", flush=True)
        if problem is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            kept = args.out / f"{len(findings):04d}-{name}"
            kept.write_bytes(path.read_bytes())
            findings.append(f"{kept}: input {k} of seed {args.seed}: {problem[:200]}")
            print(f"FINDING {findings[-1]}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
