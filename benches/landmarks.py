"""Landmark-exact maps (issue 23, item 1) on the real-mesh corpus.

    python benches/landmarks.py [--k 3 8 32 64] [--degrees 45] [--max-vertices 60000]
                                [--mode independent|swirl]

For each valid corpus mesh of ``../shared/meshes`` (MANIFEST.json; or
``$SPHERIFY_SHARED_MESHES``), the default map first, then for each k: k
landmarks by farthest-point sampling on that map, and
``sp.embed(mesh, landmarks=...)``. The targets: ``independent`` (default),
each landmark's point turned by a random angle up to ``--degrees`` in its own
random direction (for many landmarks, moves larger than their spacing
scramble their order); ``swirl``, the landmarks' points under one smooth
warp of the sphere (a turn about a random axis growing along it) whose
largest displacement is ``--degrees``. Prints validity, the largest angle
from a landmark to its target, the smallest triangle over the mean, the time
against the plain map (and the "landmarks" stage alone) and the vertices
added by the path layout's edge splits (0: the drag pinned them on the mesh
as given), or the error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

import spherify as sp

ROOT = Path(__file__).resolve().parents[2] / "shared" / "meshes"



def targets_for(points: np.ndarray, degrees: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    tangent = rng.normal(size=points.shape)
    tangent -= (tangent * points).sum(1, keepdims=True) * points
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    t = np.radians(rng.uniform(0, degrees, len(points)))[:, None]
    return np.cos(t) * points + np.sin(t) * tangent


def swirled(points: np.ndarray, degrees: float, seed: int) -> np.ndarray:
    axis = np.random.default_rng(seed).normal(size=3)
    axis /= np.linalg.norm(axis)
    z = points @ axis
    # (1 + z) / 2 * sqrt(1 - z^2) is largest, 0.6495..., at z = 1/2.
    turn = np.radians(degrees) / 0.6495190528383290 * (1 + z) / 2
    c, s = np.cos(turn)[:, None], np.sin(turn)[:, None]
    return c * points + s * np.cross(axis, points) + (1 - c) * z[:, None] * axis


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--k", type=int, nargs="+", default=[3, 8, 32, 64])
    parser.add_argument("--degrees", type=float, default=45.0)
    parser.add_argument("--max-vertices", type=int, default=60000)
    parser.add_argument("--only", nargs="*", default=None, help="mesh names")
    parser.add_argument("--mode", choices=["independent", "swirl"], default="independent")
    args = parser.parse_args()
    root = Path(os.environ.get("SPHERIFY_SHARED_MESHES", ROOT))
    if not (root / "MANIFEST.json").is_file():
        print(f"no corpus at {root}", file=sys.stderr)
        return 1
    entries = [e for e in json.loads((root / "MANIFEST.json").read_text())
               if e.get("genus") == 0 and e["V"] <= args.max_vertices
               and (args.only is None or e["name"] in args.only)]
    print(f"{'mesh':28} {'V':>7} {'k':>3} {'valid':>5} {'max angle':>9} {'min tri':>8} "
          f"{'plain s':>7} {'with s':>7} {'ratio':>5} {'pin s':>6} {'added':>6}")
    for entry in entries:
        mesh = sp.load(root / entry["path"])
        started = time.perf_counter()
        plain = sp.embed(mesh)
        plain_s = time.perf_counter() - started
        for k in args.k:
            ids = sp.datasets.farthest_points(plain.points, k)
            targets = (swirled(plain.points[ids], args.degrees, seed=k) if args.mode == "swirl"
                       else targets_for(plain.points[ids], args.degrees, seed=k))
            started = time.perf_counter()
            try:
                m = sp.embed(mesh, landmarks=(ids, targets))
            except sp.SpherifyError as err:
                print(f"{entry['name']:28} {entry['V']:7} {k:3} error: {str(err)[:120]}")
                continue
            with_s = time.perf_counter() - started
            unit = targets / np.linalg.norm(targets, axis=1, keepdims=True)
            got = m.points[ids]
            angle = np.arctan2(np.linalg.norm(np.cross(got, unit), axis=1), (got * unit).sum(1))
            print(f"{entry['name']:28} {entry['V']:7} {k:3} {str(m.valid):>5} "
                  f"{angle.max():9.1e} {m.margin:8.1e} {plain_s:7.2f} {with_s:7.2f} "
                  f"{with_s / plain_s:5.2f} {m.seconds.get('landmarks', 0.0):6.2f} "
                  f"{len(m.mesh.vertices) - len(mesh.vertices):6}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
