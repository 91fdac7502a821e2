"""sp.batch against sp.embed in a loop, on generated meshes (issue 12, part 5).

    python benches/batch.py [--meshes 1000] [--min 5000] [--max 50000] [--workers 1 2]

Writes the meshes (PLY) to a temporary folder first (not timed), then times:

* loop: ``sp.load`` + ``sp.embed`` per mesh in this process (the work alone);
* batch with 1, 2, ... workers: the same meshes through ``sp.batch`` (spawned
  pool; it also checks, measures quality, writes the sphere and the
  ``.spheremap.npz`` and journals each mesh).

Prints meshes per second and the overhead of the one-worker batch over the loop.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import spherify as sp

SHAPES = ["icosphere", "ellipsoid", "bumpy_blob", "helix_tube"]


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
              f"({args.min}-{args.max} requested each)")
        start = time.perf_counter()
        for path in sorted(folder.iterdir()):
            sp.embed(sp.load(path))
        loop = time.perf_counter() - start
        print(f"loop (load + embed):  {loop:8.2f} s  {args.meshes / loop:7.2f} meshes/s")
        for workers in args.workers:
            start = time.perf_counter()
            result = sp.batch(folder, Path(tmp) / f"out{workers}", workers=workers)
            seconds = time.perf_counter() - start
            certified = result.counts["certified"]
            print(f"batch, {workers} worker(s): {seconds:8.2f} s  {args.meshes / seconds:7.2f} "
                  f"meshes/s  ({certified} certified; {seconds / loop - 1:+.1%} against the loop)")


if __name__ == "__main__":
    main()
