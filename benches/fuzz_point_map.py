"""Random meshes through every method, then round trips through the point map
(issue 13, "fuzzing that stays").

For each mesh (random genus-0 triangulations of 4 to ``--max-vertices``
vertices from ``tests/_meshgen.py``: bent, twisted, flattened into slivers,
edge-flipped, with some or all faces reversed; the tetrahedron; and small
``spherify.datasets`` shapes) every method runs (``improve`` on the first
valid map). On every certified map (``valid``, or ``tp_valid`` for
theta-phi):

* surface -> sphere -> surface round trips, in the caller's faces and corner
  order, must come back within the error bound ``to_surface`` states (plus
  1e-12 of the mesh size for the arithmetic of the surface points), and a
  bound above ``INACCURATE_POINT`` must come with a ``SpherifyWarning``;
* hostile arrays given to ``to_sphere`` / ``to_surface`` must raise a
  ``SpherifyError`` (or a ``TypeError`` for a wrong Python type), never
  anything else.

A finding is an exception that is not a ``SpherifyError`` (a crash), a mesh
that takes longer than ``--timeout`` seconds (a hang; each mesh runs in a
worker process), or a round trip outside its bound (wrong). Exit status 1 when
there are findings.

    python benches/fuzz_point_map.py --meshes 10000 --workers 2
    python benches/fuzz_point_map.py --meshes 40 --max-vertices 60   # CI

The mesh of each finding is written to ``--out`` (default: a temporary
folder) as ``finding-SEED.npz`` so that it can be replayed with ``--replay``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import spherify as sp  # noqa: E402
from spherify._spheremap import INACCURATE_POINT  # noqa: E402

from _meshgen import make_surface, tetrahedron  # noqa: E402

METHODS = ["gotsman", "alexa", "relaxation", "radial", "theta_phi", "progressive"]


def random_mesh(seed: int, max_vertices: int) -> Tuple[np.ndarray, np.ndarray, str]:
    """One mesh of the mix described in the module docstring."""
    rng = np.random.default_rng(seed)
    kind = int(rng.integers(10))
    if kind == 0:
        t = tetrahedron()
        V, F, recipe = t.V * rng.uniform(0.1, 10), t.F, "tetrahedron"
    elif kind == 1:
        names = ["icosphere", "ellipsoid", "bumpy_blob", "tentacles", "urchin", "helix_tube"]
        name = names[int(rng.integers(len(names)))]
        n = int(rng.integers(20, max(21, max_vertices)))
        try:
            m = sp.datasets.make(name, n_vertices=n)
        except sp.SpherifyError:
            m = sp.datasets.make("icosphere", n_vertices=n)
            name = "icosphere"
        V, F, recipe = m.vertices, m.faces, f"dataset {name} n={n}"
    else:
        n = int(rng.integers(4, max_vertices + 1))
        sliver = kind == 2
        s = make_surface(n, int(rng.integers(2**32)),
                         flip_fraction=float(rng.uniform(0, 2.0 if sliver else 1.5)),
                         stretch=1.0 + 2.0 * float(rng.uniform()),
                         flatten=float(rng.uniform(0.02, 0.1) if sliver else rng.uniform(0.5, 1)),
                         twist=np.pi * float(rng.uniform()),
                         bend=1.6 * np.pi * float(rng.uniform()),
                         log_scale=float(rng.uniform(-2, 2)))
        V, F, recipe = s.V, s.F, s.recipe + (" sliver" if sliver else "")
    F = np.array(F, dtype=np.int64)
    flip = int(rng.integers(4))
    if flip == 1:
        F = F[:, ::-1].copy()
        recipe += " all-reversed"
    elif flip == 2:
        some = rng.random(len(F)) < 0.3
        F[some] = F[some][:, ::-1]
        recipe += " some-reversed"
    return np.asarray(V, dtype=np.float64), F, recipe


def hostile_calls(m: sp.SphereMap, rng: np.random.Generator) -> List[Tuple[str, Any]]:
    """Calls with arrays a careless or hostile caller might pass."""
    n_faces = len(m.mesh.faces)
    good_w = np.full((3, 3), 1.0 / 3.0)
    calls: List[Tuple[str, Any]] = [
        ("face id = F", lambda: m.to_sphere([n_faces], [[1.0, 0, 0]])),
        ("face id -1", lambda: m.to_sphere([-1], [[1.0, 0, 0]])),
        ("face id uint64 max", lambda: m.to_sphere(np.array([2**64 - 1], np.uint64), [[1.0, 0, 0]])),
        ("face id float", lambda: m.to_sphere([0.5], [[1.0, 0, 0]])),
        ("NaN weights", lambda: m.to_sphere([0], [[np.nan, 0.5, 0.5]])),
        ("inf weights", lambda: m.to_sphere([0], [[np.inf, 0, 0]])),
        ("negative weights", lambda: m.to_sphere([0], [[-1.0, 1.0, 1.0]])),
        ("weights (k, 2)", lambda: m.to_sphere([0], [[0.5, 0.5]])),
        ("weights (k, 3, 1)", lambda: m.to_sphere([0], [[[1.0], [0.0], [0.0]]])),
        ("length mismatch", lambda: m.to_sphere([0, 0], good_w)),
        ("string weights", lambda: m.to_sphere([0], [["a", "b", "c"]])),
        ("object weights", lambda: m.to_sphere([0], np.array([[None, 1, 0]], dtype=object))),
        ("complex weights", lambda: m.to_sphere([0], np.array([[1j, 0, 1]]))),
        ("masked weights", lambda: m.to_sphere([0], np.ma.masked_array(good_w[:1], [[1, 0, 0]]))),
        ("2d face ids", lambda: m.to_sphere([[0]], good_w[:1])),
        ("NaN point", lambda: m.to_surface([[np.nan, 0, 1.0]])),
        ("inf point", lambda: m.to_surface([[np.inf, 0, 0]])),
        ("zero point", lambda: m.to_surface([[0.0, 0, 0]])),
        ("long point", lambda: m.to_surface([[2.0, 0, 0]])),
        ("points (k, 2)", lambda: m.to_surface([[1.0, 0]])),
        ("points (3,)", lambda: m.to_surface([1.0, 0, 0])),
        ("huge points", lambda: m.to_surface([[1e308, 1e308, 1e308]])),
        ("tiny points", lambda: m.to_surface([[1e-310, 0, 0]])),
        ("None", lambda: m.to_surface(None)),
    ]
    # Calls that must succeed: empty, non-contiguous, float32, big-endian.
    p = rng.normal(size=(8, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    ok: List[Tuple[str, Any]] = [
        ("empty points", lambda: m.to_surface(np.zeros((0, 3)))),
        ("empty faces", lambda: m.to_sphere(np.zeros(0, np.int64), np.zeros((0, 3)))),
        ("strided points", lambda: m.to_surface(np.repeat(p, 2, axis=0)[::2])),
        ("fortran points", lambda: m.to_surface(np.asfortranarray(p))),
        ("float32 points", lambda: m.to_surface(p.astype(np.float32) / np.linalg.norm(
            p.astype(np.float32), axis=1)[:, None])),
        ("big-endian points", lambda: m.to_surface(p.astype(">f8"))),
    ]
    return [(name, call, False) for name, call in calls] + [(name, call, True) for name, call in ok]


def round_trip(m: sp.SphereMap, V: np.ndarray, F: np.ndarray,
               rng: np.random.Generator) -> Tuple[int, int, float]:
    """(wrong, warned, worst error / bound) for surface -> sphere -> surface
    in the caller's (V, F)."""
    k = 200
    faces = np.concatenate([rng.integers(0, len(F), k), np.arange(len(F))])
    bary = np.concatenate([rng.dirichlet([1.0, 1.0, 1.0], size=k),
                           np.tile([0.5, 0.5, 0.0], (len(F), 1))])
    on_sphere = m.to_sphere(faces, bary)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        f2, b2, xyz, error = m.to_surface(on_sphere, error_bound=True)
    warned = any(issubclass(w.category, sp.SpherifyWarning) for w in caught)
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    want = np.einsum("kj,kjd->kd", bary, V[F[faces]])
    err = np.linalg.norm(xyz - want, axis=1)
    slack = 1e-12 * (size + float(np.abs(V).max()))
    wrong = int(np.count_nonzero(~(err <= error + slack)))
    # The caller's (face, bary) must give the same surface point as xyz.
    again = np.einsum("kj,kjd->kd", b2, V[F[f2]])
    wrong += int(np.count_nonzero(~(np.linalg.norm(again - xyz, axis=1) <= slack)))
    must_warn = bool(np.any(~(error <= INACCURATE_POINT * size)))
    if must_warn and not warned:
        wrong += 1
    ratio = float(np.max(err / np.maximum(error + slack, 1e-300)))
    return wrong, int(must_warn), ratio


def check_mesh(seed: int, max_vertices: int) -> Dict[str, Any]:
    """Everything for one mesh; returns counts and findings (as strings)."""
    V, F, recipe = random_mesh(seed, max_vertices)
    rng = np.random.default_rng(seed + 1)
    out: Dict[str, Any] = {"seed": seed, "recipe": recipe, "findings": [], "counts": Counter()}
    mesh = sp.Mesh(V, F)
    first_valid: Optional[sp.SphereMap] = None
    maps: List[Tuple[str, Any]] = []
    for method in METHODS:
        maps.append((method, lambda method=method: sp.embed(mesh, method=method)))
    for method, make in maps + [("improve", None)]:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sp.SpherifyWarning)
                if method == "improve":
                    if first_valid is None:
                        continue
                    m = sp.improve(first_valid, max_iter=20)
                else:
                    m = make()
        except sp.SpherifyError:
            out["counts"][f"{method} refused"] += 1
            continue
        except Exception:  # a crash: anything that is not a SpherifyError
            out["findings"].append(f"crash in {method}: {traceback.format_exc(limit=3)}")
            continue
        certified = m.tp_valid if isinstance(m, sp.ThetaPhiMap) else m.valid
        if m.valid and first_valid is None and method != "theta_phi":
            first_valid = m
        if not certified:
            out["counts"][f"{method} uncertified"] += 1
            continue
        out["counts"][f"{method} certified"] += 1
        try:
            wrong, flagged, _ = round_trip(m, V, F, rng)
        except sp.MapError:
            out["counts"][f"{method} h^-1 refused"] += 1
            continue
        except Exception:
            out["findings"].append(f"crash in {method} round trip: {traceback.format_exc(limit=3)}")
            continue
        out["counts"][f"{method} flagged inaccurate"] += flagged
        if wrong:
            out["findings"].append(f"{method}: {wrong} wrong round trips")
        for name, call, must_succeed in hostile_calls(m, rng):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", sp.SpherifyWarning)
                    call()
                if not must_succeed:
                    out["findings"].append(f"{method}: {name} was accepted")
            except (sp.SpherifyError, TypeError) as err:
                if must_succeed:
                    out["findings"].append(f"{method}: {name} raised {err!r}")
            except Exception:
                out["findings"].append(f"{method}: {name}: {traceback.format_exc(limit=2)}")
    return out


def _worker(args: Tuple[int, int]) -> Dict[str, Any]:
    return check_mesh(*args)


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0, help="seed of the first mesh")
    ap.add_argument("--max-vertices", type=int, default=300)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per mesh")
    ap.add_argument("--out", default=tempfile.gettempdir())
    ap.add_argument("--replay", type=int, default=None, help="run one seed in this process")
    args = ap.parse_args(argv)
    if args.replay is not None:
        result = check_mesh(args.replay, args.max_vertices)
        print(result["recipe"], dict(result["counts"]))
        print("\n".join(result["findings"]) or "no findings")
        return 1 if result["findings"] else 0
    start = time.time()
    counts: Counter = Counter()
    findings: List[str] = []
    hangs = 0
    seeds = list(range(args.seed, args.seed + args.meshes))
    ctx = mp.get_context("spawn")
    pool = ctx.Pool(args.workers, maxtasksperchild=200)
    pending = [(s, pool.apply_async(_worker, ((s, args.max_vertices),))) for s in seeds]
    for done, (seed, job) in enumerate(pending, 1):
        try:
            result = job.get(timeout=args.timeout)
        except mp.TimeoutError:
            hangs += 1
            findings.append(f"seed {seed}: no answer within {args.timeout} s (hang)")
            pool.terminate()
            pool = ctx.Pool(args.workers, maxtasksperchild=200)
            rest = pending[done:]
            pending[done:] = [(s, pool.apply_async(_worker, ((s, args.max_vertices),)))
                              for s, _ in rest]
            continue
        except Exception as err:  # the worker died (a crash of the process)
            findings.append(f"seed {seed}: worker failed: {err!r}")
            continue
        counts.update(result["counts"])
        for f in result["findings"]:
            findings.append(f"seed {seed} ({result['recipe']}): {f}")
            V, F, _ = random_mesh(seed, args.max_vertices)
            np.savez(os.path.join(args.out, f"finding-{seed}.npz"), V=V, F=F)
        if done % 500 == 0:
            certified = sum(v for k, v in counts.items() if k.endswith(" certified"))
            print(f"{done} meshes, {certified} certified maps, {len(findings)} findings "
                  f"({hangs} hangs), {time.time() - start:.0f} s", flush=True)
            for f in findings[-3:]:
                print("  " + f, flush=True)
    pool.close()
    pool.join()
    crashes = sum(1 for f in findings if "crash" in f or "worker failed" in f)
    wrong = sum(1 for f in findings if "wrong round trips" in f)
    print(f"{args.meshes} meshes (seeds {args.seed}..{args.seed + args.meshes - 1}, "
          f"4-{args.max_vertices} vertices) in {time.time() - start:.0f} s")
    for key in sorted(counts):
        print(f"  {key}: {counts[key]}")
    print(f"findings: {len(findings)} ({crashes} crashes, {hangs} hangs, "
          f"{wrong} maps with wrong round trips)")
    for f in findings[:50]:
        print("  " + f)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
