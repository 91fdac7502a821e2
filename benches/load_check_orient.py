"""Side-by-side: spherify vs trimesh on load + check (+ orient) of the same files.

    python benches/load_check_orient.py [--repeats 5] [--n-vertices 500000]

spherify: ``load`` + ``check`` (full MeshReport) + ``orient``.
trimesh:  ``trimesh.load`` + ``is_watertight`` + ``is_winding_consistent``.
Runs on the largest meshes of ../shared/meshes (when present) and on a
generated ~1M-face bumpy blob written as binary PLY and as OBJ. Both libraries
run in the same process, alternating, and the table reports median seconds and
the ratio trimesh / spherify (higher is better for spherify). Absolute times
depend on the machine's load; the ratios are what to compare.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Callable, List

import spherify as sp

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def spherify_job(path: Path) -> None:
    mesh = sp.load(path)
    report = sp.check(mesh)
    if report.is_sphere_topology:
        sp.orient(mesh)


def trimesh_job(path: Path) -> None:
    import trimesh

    mesh = trimesh.load(str(path), force="mesh")
    _ = mesh.is_watertight
    _ = mesh.is_winding_consistent


def median_seconds(job: Callable[[Path], None], path: Path, repeats: int) -> float:
    times: List[float] = []
    for _ in range(repeats):
        start = time.perf_counter()
        job(path)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--n-vertices", type=int, default=500_000)
    args = parser.parse_args()

    files: List[Path] = []
    for name in ["igea.ply", "scorpion.ply", "armadillo.obj"]:
        if (SHARED / name).exists():
            files.append(SHARED / name)
    with tempfile.TemporaryDirectory() as tmp:
        blob = sp.datasets.bumpy_blob(n_vertices=args.n_vertices)
        for suffix in (".ply", ".obj"):
            target = Path(tmp) / f"bumpy_blob_{blob.n_faces}f{suffix}"
            sp.save(blob, target)
            files.append(target)

        print("| mesh | faces | spherify s | trimesh s | trimesh / spherify |")
        print("|---|---:|---:|---:|---:|")
        for path in files:
            faces = sp.load(path).n_faces
            # Warm up both (imports, page cache), then alternate.
            spherify_job(path)
            trimesh_job(path)
            ours = median_seconds(spherify_job, path, args.repeats)
            theirs = median_seconds(trimesh_job, path, args.repeats)
            print(f"| {path.name} | {faces} | {ours:.3f} | {theirs:.3f} | {theirs / ours:.1f}x |",
                  flush=True)


if __name__ == "__main__":
    main()
