"""sp.batch against sp.embed in a loop, on generated meshes (issue 12, part 5).

    python benches/batch.py [--meshes 1000] [--min 5000] [--max 50000] [--workers 1 2]

Writes the meshes (PLY) to a temporary folder first (not timed), then times,
one after the other in this run:

* loop, embed: ``sp.load`` + ``sp.embed`` per mesh in this process (the work
  the issue's overhead is measured against);
* loop, embed + write: the same, plus ``sp.save`` of the sphere mesh and
  ``m.save`` of the ``.spheremap.npz`` (the outputs the batch writes; both
  synced to disk, as those functions do);
* batch with 1, 2, ... workers: the same meshes through ``sp.batch`` (its
  worker processes also measure quality, hash and journal each mesh).

Prints meshes per second, the overhead of each batch over both loops, the
speed-up over one worker, the batch's seconds per stage summed over the
meshes, and the per-mesh peak memory of the workers. The load average is
printed before each phase: the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

import spherify as sp

SHAPES = ["icosphere", "ellipsoid", "bumpy_blob", "helix_tube"]


def load_average() -> str:
    try:
        return "load %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--meshes", type=int, default=1000)
    parser.add_argument("--min", type=int, default=5000)
    parser.add_argument("--max", type=int, default=50000)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
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

        print(f"[{load_average()}]", flush=True)
        start = time.perf_counter()
        for path in paths:
            sp.embed(sp.load(path))
        loop = time.perf_counter() - start
        print(f"loop, load + embed:          {loop:8.2f} s  {args.meshes / loop:7.2f} meshes/s",
              flush=True)

        print(f"[{load_average()}]", flush=True)
        written = Path(tmp) / "loop"
        written.mkdir()
        start = time.perf_counter()
        for path in paths:
            m = sp.embed(sp.load(path))
            sp.save(sp.Mesh(m.points, m.mesh.faces), written / f"{path.stem}.sphere.ply")
            m.save(written / f"{path.stem}.spheremap.npz")
        loop_write = time.perf_counter() - start
        print(f"loop, load + embed + write:  {loop_write:8.2f} s  "
              f"{args.meshes / loop_write:7.2f} meshes/s", flush=True)

        first = None
        for workers in args.workers:
            print(f"[{load_average()}]", flush=True)
            start = time.perf_counter()
            result = sp.batch(folder, Path(tmp) / f"out{workers}", workers=workers)
            seconds = time.perf_counter() - start
            first = first or seconds
            certified = result.counts["certified"]
            print(f"batch, {workers} worker(s):         {seconds:8.2f} s  "
                  f"{args.meshes / seconds:7.2f} meshes/s  ({certified} certified; "
                  f"{seconds / loop - 1:+.1%} against load + embed, "
                  f"{seconds / loop_write - 1:+.1%} against load + embed + write; "
                  f"speed-up {first / seconds:.2f}x over the first)", flush=True)
            stages: Dict[str, float] = {}
            for row in result.rows:
                for key, value in row.items():
                    if key.startswith("seconds_") and value is not None:
                        stages[key] = stages.get(key, 0.0) + value
            print("    stages (s, summed): " + ", ".join(f"{k[8:]} {v:.1f}"
                                                        for k, v in stages.items()))
            peaks: List[float] = [r["peak_memory_mb"] for r in result.rows
                                  if r["peak_memory_mb"] is not None]
            if peaks:
                print(f"    peak memory per mesh (MB, worker process): median "
                      f"{np.median(peaks):.0f}, max {max(peaks):.0f}, min {min(peaks):.0f}")
        print(f"[{load_average()}]", flush=True)


if __name__ == "__main__":
    main()
