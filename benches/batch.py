"""sp.batch against sp.embed in a loop, on generated meshes (issue 12, part 5).

    python benches/batch.py [--meshes 1000] [--min 5000] [--max 50000] [--workers 1 2] [--cores]

Writes the meshes (PLY) to a temporary folder first (not timed), then times
the phases below. The meshes are dealt into ``--rounds`` groups, and each
round runs every phase on its group, starting with a different phase each
round, so that the load of a shared machine falls on all phases alike (each
batch phase pays its start-up once per round):

* loop, embed: ``sp.load`` + ``sp.embed`` per mesh in this process (the work
  the issue's overhead is measured against);
* loop, embed + write: the same, plus ``sp.save`` of the sphere mesh and
  ``m.save`` of the ``.spheremap.npz`` (the outputs the batch writes; both
  synced to disk, as those functions do);
* batch with 1, 2, ... workers: the same meshes through ``sp.batch`` (its
  worker processes also measure quality, hash and journal each mesh);
* with ``--cores`` (Linux), the speed-up with the cores measured honestly:
  ``loop, 1 core`` (the loop in a child process pinned to one core, its core
  calls on one thread; timed inside the child, without its start-up) and
  ``batch, 1 worker on 1 core`` (``sp.batch`` with this process pinned to one
  core while it starts its worker, which inherits that). Each batch is then
  also compared with the batch of 1 worker on 1 core: the speed-up the cores
  give, where "1 worker" on all cores already uses them all part of the time.

Prints meshes per second, the overhead of each batch over both loops, the
speed-up over one worker, the batch's seconds per stage summed over the
meshes, and the per-mesh peak memory of the workers. The load average is
printed before each phase: the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Set

import numpy as np

import spherify as sp

SHAPES = ["icosphere", "ellipsoid", "bumpy_blob", "helix_tube"]


def load_average() -> str:
    try:
        return "load %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load unknown"


def cpu_seconds() -> float:
    """User + system CPU time of this process and of its children that have
    ended (the batch's workers are reaped when it returns): a measure of the
    work done that the machine's load does not inflate, beside the wall time."""
    import resource
    total = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        usage = resource.getrusage(who)
        total += usage.ru_utime + usage.ru_stime
    return total


LOOP_ONE_CORE = """
import sys, time, spherify as sp
method, paths = sys.argv[1], sys.argv[2:]
start = time.perf_counter()
for path in paths:
    sp.embed(sp.load(path), method)
print(time.perf_counter() - start)
"""


def pinned_to_one_core() -> Set[int]:
    """Pins this thread (and the processes it starts) to its first usable
    core; returns the cores to restore."""
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})
    return cores


def loop_on_one_core(paths: List[Path], method: str) -> float:
    """Seconds of the load + embed loop in a child pinned to one core."""
    cores = pinned_to_one_core()
    try:
        env = dict(os.environ, RAYON_NUM_THREADS="1")
        done = subprocess.run([sys.executable, "-c", LOOP_ONE_CORE, method, *map(str, paths)], env=env,
                              check=True, capture_output=True, text=True)
    finally:
        os.sched_setaffinity(0, cores)
    return float(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--meshes", type=int, default=1000)
    parser.add_argument("--min", type=int, default=5000)
    parser.add_argument("--max", type=int, default=50000)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=4,
                        help="split the meshes into this many rounds, each running every phase")
    parser.add_argument("--method", default="theta_phi", choices=sp.methods(),
                        help="the method of every phase (default: theta_phi, the method of "
                             "the tables in docs/benchmarks.md; the batch's own default is "
                             "progressive)")
    parser.add_argument("--cores", action="store_true",
                        help="add the loop and a 1-worker batch pinned to one core (Linux)")
    args = parser.parse_args()
    if args.cores and not hasattr(os, "sched_setaffinity"):
        parser.error("--cores needs os.sched_setaffinity (Linux)")
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "in"
        folder.mkdir()
        total_vertices = 0
        for i in range(args.meshes):
            mesh = sp.datasets.make(SHAPES[i % len(SHAPES)], int(rng.integers(args.min, args.max)))
            total_vertices += mesh.n_vertices
            sp.save(mesh, folder / f"m{i:05d}.ply")
        print(f"{args.meshes} meshes, {total_vertices} vertices in all "
              f"({args.min}-{args.max} requested each); {os.cpu_count()} cores", flush=True)
        paths = sorted(folder.iterdir())
        rounds = max(1, min(args.rounds, args.meshes))
        phases = ["loop", "loop_write"] + [f"batch{w}" for w in args.workers]
        if args.cores:
            phases += ["loop_core1", "batch1_core1"]
        wall = {p: 0.0 for p in phases}
        cpu = {p: 0.0 for p in phases}
        rows: Dict[str, List[Dict[str, Any]]] = {p: [] for p in phases}
        for r in range(rounds):
            group = paths[r::rounds]
            # Each round runs every phase on its share of the meshes, starting
            # with a different phase each time, so that a change in the
            # machine's load falls on all phases alike.
            order = phases[r % len(phases):] + phases[:r % len(phases)]
            for phase in order:
                print(f"round {r + 1}/{rounds}, {phase} [{load_average()}]", flush=True)
                start, used = time.perf_counter(), cpu_seconds()
                inner: Optional[float] = None
                if phase == "loop_core1":
                    inner = loop_on_one_core(group, args.method)
                elif phase == "batch1_core1":
                    cores = pinned_to_one_core()
                    try:
                        result = sp.batch(group, Path(tmp) / f"{phase}-{r}", workers=1,
                                          method=args.method)
                    finally:
                        os.sched_setaffinity(0, cores)
                    rows[phase].extend(result.rows)
                elif phase == "loop":
                    for path in group:
                        sp.embed(sp.load(path), args.method)
                elif phase == "loop_write":
                    written = Path(tmp) / f"loop{r}"
                    written.mkdir()
                    for path in group:
                        m = sp.embed(sp.load(path), args.method)
                        sp.save(sp.Mesh(m.points, m.mesh.faces), written / f"{path.stem}.sphere.ply")
                        m.save(written / f"{path.stem}.spheremap.npz")
                else:
                    workers = int(phase[5:])
                    result = sp.batch(group, Path(tmp) / f"{phase}-{r}", workers=workers,
                                      method=args.method)
                    rows[phase].extend(result.rows)
                wall[phase] += time.perf_counter() - start if inner is None else inner
                cpu[phase] += cpu_seconds() - used
        print(f"[{load_average()}]")
        n = args.meshes
        print(f"loop, load + embed:          {wall['loop']:8.2f} s  {n / wall['loop']:7.2f} meshes/s"
              f"  (CPU {cpu['loop']:.2f} s)")
        print(f"loop, load + embed + write:  {wall['loop_write']:8.2f} s  "
              f"{n / wall['loop_write']:7.2f} meshes/s  (CPU {cpu['loop_write']:.2f} s)")
        if args.cores:
            one = wall["loop_core1"]
            print(f"loop, 1 core (in a child):   {one:8.2f} s  {n / one:7.2f} meshes/s  "
                  f"(CPU {cpu['loop_core1']:.2f} s, the child's start-up included)")
        first = None
        for phase in [f"batch{w}" for w in args.workers] + (["batch1_core1"] if args.cores else []):
            workers = 1 if phase == "batch1_core1" else int(phase[5:])
            seconds, used, got = wall[phase], cpu[phase], rows[phase]
            first = first or seconds
            certified = sum(bool(row["certified"]) for row in got)
            label = "1 worker on 1 core:" if phase == "batch1_core1" else f"{workers} worker(s):   "
            print(f"batch, {label}      {seconds:8.2f} s  {n / seconds:7.2f} "
                  f"meshes/s  ({certified} certified; {seconds / wall['loop'] - 1:+.1%} against "
                  f"load + embed, {seconds / wall['loop_write'] - 1:+.1%} against load + embed + "
                  f"write; speed-up {first / seconds:.2f}x over the first)")
            print(f"    CPU {used:.2f} s: {used / cpu['loop'] - 1:+.1%} against load + embed, "
                  f"{used / cpu['loop_write'] - 1:+.1%} against load + embed + write")
            if args.cores:
                print(f"    against the loop on 1 core {seconds / wall['loop_core1'] - 1:+.1%}; "
                      f"speed-up over 1 worker on 1 core "
                      f"{wall['batch1_core1'] / seconds:.2f}x")
            stages: Dict[str, float] = {}
            for row in got:
                for key, value in row.items():
                    if key.startswith("seconds_") and value is not None:
                        stages[key] = stages.get(key, 0.0) + value
            print("    stages (s, summed over meshes): "
                  + ", ".join(f"{k[8:]} {v:.1f}" for k, v in stages.items()))
            peaks = [row["peak_memory_mb"] for row in got if row["peak_memory_mb"] is not None]
            sizes = [row["n_vertices"] for row in got if row["peak_memory_mb"] is not None]
            if peaks:
                big = int(np.argmax(sizes))
                print(f"    peak memory per mesh (MB, the worker process): median "
                      f"{np.median(peaks):.0f}, min {min(peaks):.0f}, max {max(peaks):.0f}; "
                      f"largest mesh ({sizes[big]} vertices) {peaks[big]:.0f}")


if __name__ == "__main__":
    main()
