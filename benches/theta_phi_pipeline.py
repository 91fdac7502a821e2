"""The theta-phi pipeline end to end, against LaPy and against a CHOLMOD floor.

    python benches/theta_phi_pipeline.py [--quick] [--max-vertices 2000000]
                                         [--lapy-timeout 600] [--write docs/benchmarks.md]
                                         [--shapes helix_tube:1000000 ...]
                                         [--no-lapy | --no-lapy-conformal]

For every mesh (bumpy blobs from 10k to 2M vertices, a few other generated
shapes at 100k-1M, and every corpus mesh of ../shared/meshes when present),
in one run:

* **spherify**: ``sp.embed(mesh, method="theta_phi")`` end to end (check,
  orient, fast_graph poles, cut, solve with refinement, exact flip check,
  fold, and the exact GC validity test of the returned ``SphereMap``), with
  ``m.seconds`` per stage, ``tp_valid`` and the GC verdict. Each mesh runs in
  a fresh subprocess, which also reports the growth of its peak resident set
  (``ru_maxrss``) across the call, per vertex.
* **CHOLMOD floor**: the same process assembles, with scipy, the
  uniform-weight Tutte system of ``m.cut_mesh`` with the cut boundary fixed at
  its ``m.theta_phi`` positions, and times only scikit-sparse's analyse +
  factorise + solve of the free block for both right-hand sides, supernodal,
  once with AMD and once with METIS; the faster counts. Any method
  that solves this system directly pays at least that much.
* **LaPy** ``lapy.conformal.spherical_tutte_map`` and
  ``spherical_conformal_map`` (default SciPy LU solver), each in its own
  subprocess with a timeout. Their flips are counted with spherify's exact
  ``sp.check_sphere`` (negative plus zero orientation signs). An exception
  raised by LaPy is recorded as a failure of LaPy.

The machine is shared and noisy: compare the ratios of one run, not seconds
across runs. The load average is printed with the table.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

import spherify as sp

HERE = Path(__file__).resolve()
SHARED = HERE.parents[2] / "shared" / "meshes"
DOC = HERE.parents[1] / "docs" / "benchmarks.md"
SECTION = "## Theta-phi pipeline end to end (issue: theta-phi performance)"

# (label, dataset, target vertices); the bumpy-blob series gives the slope.
BLOB_SIZES = [10_000, 30_000, 100_000, 300_000, 1_000_000, 2_000_000]
OTHER_SHAPES = [
    ("helix_tube", 100_000),
    ("tentacles", 300_000),
    ("urchin", 300_000),
    ("ellipsoid", 1_000_000),
]
QUICK = [("bumpy_blob", 10_000), ("bumpy_blob", 30_000), ("bumpy_blob", 100_000),
         ("helix_tube", 100_000)]


def peak_rss_bytes() -> int:
    """ru_maxrss of this process in bytes (kilobytes on Linux, bytes on macOS).

    Linux carries ru_maxrss across fork and exec, so a worker starts with its
    parent's peak; the driver therefore never holds a large mesh itself (the
    meshes are generated and checked in workers too)."""
    scale = 1 if sys.platform == "darwin" else 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale


# ---------------------------------------------------------------- workers

def load_job(path: str) -> sp.Mesh:
    """A corpus file through ``sp.load``, or a generated mesh stored as .npz."""
    if path.endswith(".npz"):
        with np.load(path) as data:
            return sp.Mesh(data["V"], data["F"])
    return sp.load(path)


def cut_system(m: Any) -> Tuple[Any, np.ndarray]:
    """The free block of the uniform-weight Tutte system of ``m.cut_mesh``,
    boundary at its ``m.theta_phi`` positions, and the two right-hand sides."""
    import scipy.sparse as sparse

    F = m.cut_mesh.faces
    n = m.cut_mesh.n_vertices
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    # Each interior edge appears once per direction in the faces; a boundary
    # edge once. Symmetrise and set every edge to weight 1.
    W = sparse.coo_matrix((np.ones(2 * len(i)), (np.concatenate([i, j]), np.concatenate([j, i]))),
                          shape=(n, n)).tocsr()
    W.data[:] = 1.0
    L = (sparse.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()
    boundary = np.asarray(m.details["cut_boundary"], dtype=np.int64)
    is_free = np.ones(n, dtype=bool)
    is_free[boundary] = False
    free = np.flatnonzero(is_free)
    A = L[free][:, free].tocsc()
    B = -(L[free][:, boundary] @ m.theta_phi[boundary])
    return A, np.ascontiguousarray(B)


def worker_spherify(path: str, repeats: int, cholmod: bool = True) -> Dict[str, Any]:
    mesh = load_job(path)
    n = mesh.n_vertices
    gc.collect()
    before = peak_rss_bytes()
    best: Optional[float] = None
    m = None
    for _ in range(repeats):
        m = None
        gc.collect()
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            m = sp.embed(mesh, method="theta_phi")
        elapsed = time.perf_counter() - start
        best = elapsed if best is None else min(best, elapsed)
        if best == elapsed:
            stages = dict(m.seconds)
        if _ == 0:
            after = peak_rss_bytes()
    assert m is not None and best is not None
    # What sp.embed spends before the core call, on a fresh copy of the mesh
    # (the first call cached the edge table in ``mesh``).
    fresh = load_job(path)
    start = time.perf_counter()
    report = sp.check(fresh)
    if not (report.consistently_oriented and report.outward):
        sp.orient(fresh)
    check_orient = time.perf_counter() - start
    del fresh
    out: Dict[str, Any] = {
        "check_orient": check_orient,
        "n": n, "faces": mesh.n_faces, "seconds": best, "stages": stages,
        "tp_valid": bool(m.tp_valid), "valid": bool(m.valid), "flipped": int(m.flipped),
        "refinements": int(m.details["refinements"]),
        "rss_bytes_per_vertex": (after - before) / n,
    }
    try:
        from sksparse.cholmod import cholesky
    except ImportError:
        cholmod = False
    if not cholmod:
        out["cholmod"] = None
        return out
    A, B = cut_system(m)
    del m
    # CHOLMOD's best: supernodal, with AMD and with METIS (issue 14 asks for
    # the faster of the two), each timed as analyse + factorise + solve.
    for ordering in ("amd", "metis"):
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            factor = cholesky(A, mode="supernodal", ordering_method=ordering)
            X = factor(B)
            times.append(time.perf_counter() - start)
            del factor
        out[f"cholmod_{ordering}"] = min(times)
        out[f"cholmod_{ordering}_residual"] = float(np.abs(A @ X - B).max() / np.abs(B).max())
    out["cholmod"] = min(out["cholmod_amd"], out["cholmod_metis"])
    return out


def worker_generate(name: str, n: int, path: str) -> Dict[str, Any]:
    mesh = sp.datasets.make(name, n)
    np.savez(path, V=mesh.vertices, F=mesh.faces)
    return {"n": mesh.n_vertices}


def worker_lapy(path: str, which: str) -> Dict[str, Any]:
    from lapy import TriaMesh
    from lapy import conformal

    mesh = load_job(path)
    tria = TriaMesh(np.array(mesh.vertices), np.array(mesh.faces))
    function = getattr(conformal, which)
    start = time.perf_counter()
    try:
        points = function(tria)
    except Exception as err:  # a failure of the peer, recorded as such
        return {"seconds": time.perf_counter() - start, "error": f"{type(err).__name__}: {err}"}
    seconds = time.perf_counter() - start
    points = np.asarray(points, dtype=np.float64)
    if not np.all(np.isfinite(points)):
        return {"seconds": seconds, "error": "non-finite points"}
    # check_sphere wants points near the unit sphere; LaPy's conformal map is
    # on it already, normalising only removes rounding.
    points = points / np.linalg.norm(points, axis=1, keepdims=True)
    report = sp.check_sphere(mesh, points)
    return {"seconds": seconds, "flipped": int(report.n_negative + report.n_zero),
            "valid": bool(report.valid)}


# ---------------------------------------------------------------- driver

def run_worker(args: List[str], timeout: Optional[float]) -> Dict[str, Any]:
    command = [sys.executable, str(HERE), "--worker", *args]
    # CHOLMOD's dense kernels are OpenBLAS's: let it pick its own kernel for
    # this CPU (this machine's environment forces a slower one).
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"error": "timeout", "seconds": timeout}
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": f"exit {done.returncode}: {tail}"}
    return json.loads(done.stdout.strip().splitlines()[-1])


def jobs(args: argparse.Namespace, scratch: Path) -> List[Tuple[str, str, str]]:
    """(label, kind, path) for every mesh of this run; generated meshes are
    written to ``scratch`` as .npz so that each worker only reads arrays."""
    if args.shapes:
        shapes = [(spec.split(":")[0], int(spec.split(":")[1])) for spec in args.shapes]
    else:
        shapes = QUICK if args.quick else (
            [("bumpy_blob", n) for n in BLOB_SIZES] + OTHER_SHAPES)
    out = []
    for name, n in shapes:
        if n > args.max_vertices:
            continue
        path = scratch / f"{name}-{n}.npz"
        made = run_worker(["generate", name, str(n), str(path)], None)
        if "error" in made:
            print(f"{name} {n}: {made['error']}", file=sys.stderr)
            continue
        out.append((f"{name} {n // 1000}k", "dataset", str(path)))
    manifest = SHARED / "MANIFEST.json"
    if manifest.exists() and not args.quick and not args.shapes:
        for entry in sorted(json.loads(manifest.read_text()), key=lambda e: e["V"]):
            if entry.get("genus") == 0 and entry["V"] <= args.max_vertices:
                out.append((entry["name"], "corpus", str(SHARED / entry["path"])))
    return out


def slope(points: List[Tuple[int, float]]) -> Optional[float]:
    """Least-squares slope of log(seconds) against log(vertices)."""
    if len(points) < 2:
        return None
    x = np.log([p[0] for p in points])
    y = np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def fmt(x: Optional[float], digits: int = 3) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def peer_cell(r: Dict[str, Any]) -> Tuple[str, str]:
    if r.get("error") == "not run":
        return "not run", "-"
    if "error" in r:
        reason = "timeout" if r["error"] == "timeout" else "failed"
        return reason, r["error"][:60] if reason == "failed" else f"> {r['seconds']:.0f} s"
    return f"{r['seconds']:.2f}", str(r["flipped"])


def table(rows: List[Dict[str, Any]]) -> str:
    lines = [
        "| mesh | vertices | check+orient | poles | cut | system | factor | solve+refine | "
        "exact check + fold | check_sphere + wrap | "
        "spherify s | tp_valid / GC valid / flips | refine | CHOLMOD best s (AMD / METIS) | "
        "spherify / CHOLMOD | "
        "LaPy Tutte s | LaPy Tutte flips | LaPy Tutte / spherify | LaPy conformal s | "
        "LaPy conformal flips | peak RSS B/vertex |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        s = row["spherify"]
        if "error" in s:
            lines.append(f"| {row['label']} | - | spherify failed: {s['error']} |" + " |" * 19)
            continue
        st = s["stages"]
        core = sum(st.values())
        stage = lambda *names: sum(st.get(k, 0.0) for k in names)  # noqa: E731
        wrapper = s["seconds"] - core
        tutte, conformal = row["lapy_tutte"], row["lapy_conformal"]
        t_sec, t_flips = peer_cell(tutte)
        c_sec, c_flips = peer_cell(conformal)
        ratio_lapy = (f"{tutte['seconds'] / s['seconds']:.1f}x" if "error" not in tutte
                      else ("> " + f"{tutte['seconds'] / s['seconds']:.0f}x" if tutte["error"] == "timeout" else "-"))
        chol = s.get("cholmod")
        ratio_chol = f"{s['seconds'] / chol:.2f}x" if chol else "-"
        chol_cell = (f"{chol:.3f} ({s['cholmod_amd']:.2f} / {s['cholmod_metis']:.2f})"
                     if chol else "not run")
        cells = [
            row["label"], f"{s['n']:,}", fmt(row["check_orient"]), fmt(stage("poles")),
            fmt(stage("cut")), fmt(stage("system")), fmt(stage("factor")),
            fmt(stage("solve", "refine")), fmt(stage("check", "fold")),
            fmt(wrapper - (row["check_orient"] or 0.0)), f"**{s['seconds']:.3f}**",
            f"{s['tp_valid']} / {s['valid']} / {s['flipped']}", str(s["refinements"]),
            chol_cell, ratio_chol, t_sec, t_flips, ratio_lapy, c_sec, c_flips,
            f"{s['rss_bytes_per_vertex']:.0f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a few meshes up to 100k vertices")
    parser.add_argument("--max-vertices", type=int, default=2_000_000)
    parser.add_argument("--repeats", type=int, default=1,
                        help="spherify and CHOLMOD runs per mesh (the fastest is kept)")
    parser.add_argument("--lapy-timeout", type=float, default=600.0)
    parser.add_argument("--no-lapy", action="store_true")
    parser.add_argument("--no-cholmod", action="store_true", help="time spherify alone")
    parser.add_argument("--no-lapy-conformal", action="store_true",
                        help="run LaPy's spherical_tutte_map only")
    parser.add_argument("--shapes", nargs="+", metavar="NAME:N",
                        help="only these generated shapes (e.g. helix_tube:1000000), no corpus")
    parser.add_argument("--write", nargs="?", const=str(DOC), default=None,
                        help=f"write the table as a new section of {DOC.name}")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()

    if args.worker:
        kind, *rest = args.worker
        if kind == "generate":
            result = worker_generate(rest[0], int(rest[1]), rest[2])
        elif kind == "spherify":
            result = worker_spherify(rest[0], int(rest[1]), rest[2:] != ["no-cholmod"])
        else:
            result = worker_lapy(rest[0], kind)
        print(json.dumps(result))
        return

    try:
        import lapy
        lapy_version: Optional[str] = lapy.__version__
    except ImportError as err:
        lapy_version = None
        print(f"LaPy not available ({err}); its columns stay empty", file=sys.stderr)
    rows = []
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="spherify-bench-") as tmp:
        for label, kind, path in jobs(args, Path(tmp)):
            print(f"{label} ...", file=sys.stderr, flush=True)
            row: Dict[str, Any] = {"label": label, "kind": kind}
            row["spherify"] = run_worker(
                ["spherify", path, str(args.repeats)] + (["no-cholmod"] if args.no_cholmod else []),
                None)
            row["check_orient"] = row["spherify"].get("check_orient")
            for which in ("spherical_tutte_map", "spherical_conformal_map"):
                key = "lapy_tutte" if which == "spherical_tutte_map" else "lapy_conformal"
                if lapy_version is None or args.no_lapy or (
                        args.no_lapy_conformal and which == "spherical_conformal_map"):
                    row[key] = {"error": "not run", "seconds": 0.0}
                else:
                    row[key] = run_worker([which, path], args.lapy_timeout)
            print(f"    {json.dumps(row)}", file=sys.stderr, flush=True)
            rows.append(row)

    blobs = [(r["spherify"]["n"], r["spherify"]["seconds"]) for r in rows
             if r["label"].startswith("bumpy_blob") and "error" not in r["spherify"]]
    k = slope(blobs)
    load = os.getloadavg()
    header = [
        SECTION, "",
        f"Command: `python benches/theta_phi_pipeline.py{' --quick' if args.quick else ''}"
        f"{'' if args.max_vertices == 2_000_000 else f' --max-vertices {args.max_vertices}'}`, "
        f"run on {datetime.date.today()} ({platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores), load average {load_start[0]:.2f} / {load_start[1]:.2f} / "
        f"{load_start[2]:.2f} at the start, {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} "
        f"at the end. LaPy {lapy_version or 'not installed'}.", "",
        "Seconds are wall clock; the stage columns are spherify's `m.seconds` (Rust core) plus "
        "`check+orient` (timed separately on the same mesh) and the rest of `sp.embed` "
        "(the exact `check_sphere` of the result and the conversion to a `SphereMap`). "
        "Flips count negative and zero exact orientation signs. Peak RSS is the growth of the "
        "worker's peak resident set across the first `sp.embed` call, per vertex.", "",
        table(rows), "",
        f"Log-log slope of spherify's end-to-end time over the bumpy-blob series "
        f"({', '.join(f'{n:,}' for n, _ in blobs)} vertices): **{fmt(k, 2)}**.", "",
    ]
    text = "\n".join(header)
    print(text)
    if args.write:
        doc = Path(args.write)
        old = doc.read_text() if doc.exists() else "# Benchmarks\n"
        if SECTION in old:
            # Replace our section, keep everything else.
            before, _, after = old.partition(SECTION)
            nxt = after.find("\n## ")
            old = before.rstrip() + "\n\n" + ("" if nxt < 0 else after[nxt + 1:])
        doc.write_text(old.rstrip() + "\n\n" + text)


if __name__ == "__main__":
    main()
