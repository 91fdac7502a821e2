"""Issue 22, item 3: each progressive energy's time against the default's, and memory.

Usage::

    python benches/energy_speed.py [--shapes helix_tube,tentacles,...] [--n 200000]
        [--energies isometric,stretch,conformal,authalic,balanced]
    python benches/energy_speed.py --memory authalic --n 1000000 [--shapes ...]

Time: one child process per shape maps it with every energy in turn, on one
thread (``sp.set_num_threads(1)``), and measures the process's CPU time,
user and system (``resource.getrusage``), around ``sp.embed``. The machine
this is run on is shared, so wall time says little; CPU time of one thread is what the
energy costs, and the ratios to the isometric energy's time in the same
process are what the issue's bars are written in. Each row also has the
stages (``SphereMap.seconds``, wall), the certificate and the three
distortion figures of ``benches/sphereparam_quality.py``'s evaluator
(stretch, mean angle distortion, mean |log area ratio| on spherical and on
chord triangles).

Memory (``--memory ENERGY``): one fresh child process per shape, as in
``benches/default_at_scale.py``: the high-water mark (``VmHWM``) is reset
through ``/proc/self/clear_refs`` just before ``sp.embed``, and its growth
over the resident size before the call, per vertex, is reported.
"""

import argparse
import hashlib
import json
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List

import numpy as np

import spherify as sp

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from default_at_scale import measured_embed  # noqa: E402  (one measure of embed's peak)
SHAPES = ["helix_tube", "tentacles", "urchin", "bumpy_blob", "ellipsoid", "icosphere"]
ENERGIES = ["isometric", "stretch", "conformal", "authalic", "balanced"]


def cpu_seconds() -> float:
    """User and system CPU time of this process so far (the system time is
    mostly the kernel clearing freshly allocated pages)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(mesh: Any, energy: str) -> Dict[str, Any]:
    """One map of `mesh` with `energy`: CPU time, stages, certificate, distortion."""
    sys.path.insert(0, str(HERE))
    from sphereparam_quality import evaluate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        cpu = cpu_seconds()
        wall = time.perf_counter()
        m = sp.embed(mesh, method="progressive", energy=energy)
        wall = time.perf_counter() - wall
        cpu = cpu_seconds() - cpu
    row = evaluate(mesh, m.points)
    row.update({"energy": energy, "cpu": cpu, "wall": wall,
                "stages": {k: round(float(v), 2) for k, v in dict(m.seconds).items()},
                "certified": bool(m.valid),
                "sha1": hashlib.sha1(np.ascontiguousarray(m.points).tobytes()).hexdigest()[:12]})
    return row


def time_worker(shape: str, n: int, energies: List[str]) -> None:
    sp.set_num_threads(1)
    mesh = sp.datasets.make(shape, n)
    for energy in energies:
        row = measure(mesh, energy)
        row.update({"shape": shape, "n": mesh.n_vertices})
        print(json.dumps(row), flush=True)


def memory_worker(shape: str, n: int, energy: str) -> None:
    mesh = sp.datasets.make(shape, n)
    m, wall, grown = measured_embed(mesh, method="progressive", energy=energy)
    print(json.dumps({"shape": shape, "n": mesh.n_vertices, "energy": energy, "wall": wall,
                      "bytes_per_vertex": grown / mesh.n_vertices, "certified": bool(m.valid),
                      "stages": {k: round(float(v), 2) for k, v in dict(m.seconds).items()}}),
          flush=True)


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        kind, shape, n, energies = sys.argv[2:6]
        if kind == "time":
            time_worker(shape, int(n), energies.split(","))
        else:
            memory_worker(shape, int(n), energies)
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--energies", default=",".join(ENERGIES),
                    help="the first is the reference of the ratios (isometric, the default)")
    ap.add_argument("--memory", default="", help="measure this energy's memory instead of time")
    args = ap.parse_args()
    for shape in args.shapes.split(","):
        kind, what = ("memory", args.memory) if args.memory else ("time", args.energies)
        done = subprocess.run([sys.executable, __file__, "--worker", kind, shape, str(args.n), what],
                              capture_output=True, text=True)
        rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
        if done.returncode != 0:
            print(f"| {shape} | error: {done.stderr.strip()[-200:]} |", flush=True)
        if kind == "memory":
            for r in rows:
                print(f"| {shape} | {r['n']:,} | {r['energy']} | {r['wall']:.1f} | "
                      f"{r['bytes_per_vertex']:.0f} | {'yes' if r['certified'] else 'NO'} | "
                      f"{r['stages']} |", flush=True)
            continue
        base = rows[0]["cpu"] if rows else float("nan")
        for r in rows:
            print(f"| {shape} | {r['n']:,} | {r['energy']} | {r['cpu']:.1f} | {r['cpu'] / base:.2f} | "
                  f"{r['stretch']:.4f} | {r['angle']:.2f} | {r['area']:.4f} | {r['area_chord']:.4f} | "
                  f"{'yes' if r['certified'] and r['valid'] else 'NO'} | {r['sha1']} | {r['stages']} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
