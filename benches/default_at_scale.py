"""The default map at scale against one CHOLMOD factorisation (issue 27).

    python benches/default_at_scale.py [--shapes helix_tube tentacles bumpy_blob ellipsoid]
                                       [--n 1000000] [--slope 10000 100000 1000000 2000000]
                                       [--threads] [--no-cholmod] [--repeat K]

Each measurement runs in a fresh process (the driver holds no mesh):

* **default**: the shape is made (``sp.datasets.make``), then ``sp.embed(mesh)``
  with the default method and energy; ``m.seconds`` per stage, the
  certificate, the SHA-1 of the points (the same bits for every thread
  count), and the growth of the process's high-water mark (``VmHWM``, reset
  through ``/proc/self/clear_refs`` before the call) per vertex.
* **CHOLMOD floor**: in the same process, theta-phi's map of the same mesh
  gives its cut Tutte system (``theta_phi_pipeline.cut_system``), and
  scikit-sparse's analyse + factorise + solve of it, supernodal, with AMD and
  with METIS, the faster taken (scikit-sparse 0.4 builds against Debian 12's
  SuiteSparse 5: ``apt-get install libsuitesparse-dev``,
  ``pip install "scikit-sparse<0.5"``).
* ``--threads``: the default map of the first shape on 1 and on 2 worker
  threads (``sp.set_num_threads``), each in its own process.
* ``--repeat K``: every row above K times, each in a fresh process, and the
  medians: of each shape's embed / CHOLMOD ratios, and of the optimisation
  stage's 1-thread over 2-thread time (the two alternate, pair by pair).
* ``--slope``: tentacles at each size, the default alone; the log-log slope
  of the time against the vertex count.

The machine is shared: compare ratios within one run. The load average is
printed first.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

import spherify as sp

HERE = Path(__file__).resolve().parent


def vm(field: str) -> int:
    """One field of /proc/self/status, in bytes."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    return 0


def measured_embed(mesh: sp.Mesh, **options: Any) -> Tuple[sp.SphereMap, float, int]:
    """``sp.embed(mesh, **options)`` with its wall time and the growth of this
    process's high-water mark over its resident size just before the call
    (the mark is reset first, so whatever made ``mesh`` does not count)."""
    with open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")  # the high-water mark starts again from here
    before = vm("VmRSS")
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        m = sp.embed(mesh, **options)
    return m, time.perf_counter() - started, vm("VmHWM") - before


def worker(shape: str, n: int, threads: Optional[int], cholmod: bool) -> Dict[str, Any]:
    if threads is not None:
        sp.set_num_threads(threads)
    mesh = sp.datasets.make(shape, n)
    m, seconds, grown = measured_embed(mesh)
    out: Dict[str, Any] = {
        "shape": shape, "n": mesh.n_vertices, "threads": threads, "seconds": seconds,
        "stages": dict(m.seconds), "valid": bool(m.valid), "margin": float(m.margin),
        "bytes_per_vertex": grown / mesh.n_vertices,
        "sha1": hashlib.sha1(np.ascontiguousarray(m.points).tobytes()).hexdigest()[:12],
    }
    if not cholmod:
        return out
    del m
    sys.path.insert(0, str(HERE))
    from theta_phi_pipeline import cut_system
    from sksparse.cholmod import cholesky  # type: ignore[import-untyped]
    tp = sp.embed(mesh, method="theta_phi")
    A, B = cut_system(tp)
    del tp
    for ordering in ("amd", "metis"):
        started = time.perf_counter()
        factor = cholesky(A, mode="supernodal", ordering_method=ordering)
        factor(B)
        out[f"cholmod_{ordering}"] = time.perf_counter() - started
        del factor
    out["cholmod"] = min(out["cholmod_amd"], out["cholmod_metis"])
    return out


def run(shape: str, n: int, threads: Optional[int], cholmod: bool) -> Dict[str, Any]:
    args = [sys.executable, __file__, "--worker", shape, str(n), str(threads or 0),
            "1" if cholmod else "0"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=3600)
    if done.returncode != 0:
        return {"shape": shape, "n": n, "error": done.stderr[-500:]}
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def row(r: Dict[str, Any]) -> str:
    if "error" in r:
        return f"| {r['shape']} | {r['n']:,} | error: {r['error'][-120:]} |"
    s = r["stages"]
    chol = r.get("cholmod")
    ratio = f"{r['seconds'] / chol:.2f}" if chol else ""
    chol_cell = f"{chol:.1f} ({r['cholmod_amd']:.1f} / {r['cholmod_metis']:.1f})" if chol else ""
    return (f"| {r['shape']} | {r['n']:,} | {r['threads'] or 'default'} | {r['seconds']:.1f} | "
            f"{s.get('hierarchy', 0):.1f} | {s.get('insertion', 0):.1f} | "
            f"{s.get('optimisation', 0):.1f} | {s.get('certify', 0):.1f} | "
            f"{r['bytes_per_vertex']:.0f} | {'yes' if r['valid'] else 'NO'} | {r['sha1']} | "
            f"{chol_cell} | {ratio} |")


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        shape, size, threads, cholmod = sys.argv[2:6]
        print(json.dumps(worker(shape, int(size), int(threads) or None, cholmod == "1")))
        return 0
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shapes", nargs="+",
                        default=["helix_tube", "tentacles", "bumpy_blob", "ellipsoid"])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--slope", type=int, nargs="*", default=[])
    parser.add_argument("--threads", action="store_true")
    parser.add_argument("--no-cholmod", action="store_true")
    parser.add_argument("--repeat", type=int, default=1,
                        help="measure every row this many times (fresh processes) and "
                             "print the medians")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print("| shape | vertices | threads | embed (s) | hierarchy | insertion | optimisation | "
          "certify | bytes / vertex | certified | points SHA-1 | CHOLMOD s (AMD / METIS) | "
          "embed / CHOLMOD |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    # With --repeat K every row is measured K times, each in a fresh process
    # (the embed and CHOLMOD alike), and the medians are printed below the
    # rows: one process's wall time on this machine varies by 15-25%.
    ratios: Dict[str, List[float]] = {}
    for _ in range(args.repeat):
        for shape in args.shapes:
            r = run(shape, args.n, None, not args.no_cholmod)
            print(row(r), flush=True)
            if r.get("cholmod"):
                ratios.setdefault(shape, []).append(r["seconds"] / r["cholmod"])
    speedups: List[float] = []
    if args.threads:
        for _ in range(args.repeat):
            # One and two threads alternate, so that both see the same load.
            one, two = (run(args.shapes[0], args.n, count, False) for count in (1, 2))
            print(row(one), flush=True)
            print(row(two), flush=True)
            if "error" not in one and "error" not in two:
                speedups.append(one["stages"]["optimisation"] / two["stages"]["optimisation"])
    if args.repeat > 1:
        for shape, values in ratios.items():
            print(f"{shape}: embed / CHOLMOD, median of {len(values)} processes "
                  f"{float(np.median(values)):.2f} (each: "
                  f"{', '.join(f'{v:.2f}' for v in values)})")
        if speedups:
            print(f"{args.shapes[0]}: optimisation stage on 1 thread over 2, median of "
                  f"{len(speedups)} pairs {float(np.median(speedups)):.2f}x (each: "
                  f"{', '.join(f'{v:.2f}' for v in speedups)})")
    points: List[Any] = []
    for n in args.slope:
        r = run("tentacles", n, None, False)
        print(row(r), flush=True)
        if "error" not in r:
            points.append((r["n"], r["seconds"]))
    if len(points) >= 2:
        x = np.log([p[0] for p in points])
        y = np.log([p[1] for p in points])
        slope = float(np.polyfit(x, y, 1)[0])
        first, last = points[0], points[-1]
        pairwise = math.log(last[1] / first[1]) / math.log(last[0] / first[0])
        print(f"log-log slope of the time, tentacles {first[0]:,} to {last[0]:,}: "
              f"{slope:.3f} (fit), {pairwise:.3f} (end points)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
