"""Accuracy and speed of registration (issue 23), for docs/correspondence.md.

    python benches/correspondence.py [--small] [--only spot hand] [--landmarks 8]
                                     [--population 100 --population-size 20000]

For every corpus mesh A (../shared/meshes, or small generated shapes with
``--small``), B is :func:`spherify.datasets.deformed_copy` of A's default map
(an icosphere of level 5 resampled from A, bent by 6% of its size, turned and
moved), so the true image of every vertex of A on B is known. Both are mapped
with the default method; each transform's error is the distance from where it
puts A's vertex on B to the true point, relative to B's bounding-box
diagonal. With ``--landmarks K``, the warp is also run with K landmark pairs:
A's vertices farthest-point sampled, each paired with B's vertex nearest its
true image. Times are ratios to mapping both shapes. ``--population N`` also
times :func:`spherify.correspond` of N generated shapes (bumpy blobs of
``--population-size`` vertices, different seeds) on this machine's cores.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

import spherify as sp

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"
TRANSFORMS = ("rotation", "moebius", "warp")


def corpus(small: bool, only: List[str]) -> List[Tuple[str, sp.Mesh]]:
    if small or not (SHARED / "MANIFEST.json").exists():
        shapes = [("bumpy_blob", sp.datasets.bumpy_blob(1500, bumps=5, amplitude=0.5, seed=1)),
                  ("tentacles", sp.datasets.tentacles(3000))]
        return [(n, m) for n, m in shapes if not only or n in only]
    entries = json.loads((SHARED / "MANIFEST.json").read_text())
    out = []
    for entry in sorted(entries, key=lambda e: e["V"]):
        if entry["path"].startswith("invalid") or (only and entry["name"] not in only):
            continue
        out.append((entry["name"], sp.load(SHARED / entry["path"])))
    return out


def farthest_points(vertices: np.ndarray, k: int) -> np.ndarray:
    """k vertices, each the farthest (in space) from those already chosen."""
    chosen = [0]
    distance = np.linalg.norm(vertices - vertices[0], axis=1)
    for _ in range(k - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(vertices - vertices[chosen[-1]], axis=1))
    return np.array(chosen, dtype=np.int64)


def errors(c: sp.Correspondence, copy: sp.datasets.DeformedCopy) -> np.ndarray:
    diagonal = float(np.linalg.norm(np.ptp(copy.mesh.vertices, axis=0)))
    return np.linalg.norm(c.a_on_b.positions - copy.truth, axis=1) / diagonal


def run_mesh(name: str, mesh: sp.Mesh, landmarks: int) -> Dict[str, object]:
    started = time.perf_counter()
    m_a = sp.embed(mesh)
    copy = sp.datasets.deformed_copy(m_a)
    m_b = sp.embed(copy.mesh)
    # Mapping both, without the resampling that made B.
    mapping = sum(m_a.seconds.values()) + sum(m_b.seconds.values())
    row: Dict[str, object] = {"mesh": name, "n_a": mesh.n_vertices, "n_b": copy.mesh.n_vertices,
                              "map_both": mapping}
    runs = [(t, None) for t in TRANSFORMS]
    if landmarks:
        ids = farthest_points(mesh.vertices, landmarks)
        corners = copy.mesh.faces[copy.truth_faces[ids]]
        nearest = corners[np.arange(len(ids)), np.argmax(copy.truth_bary[ids], axis=1)]
        runs.append(("warp+landmarks", np.stack([ids, nearest], axis=1)))
    for label, pairs in runs:
        transform = "warp" if label.startswith("warp") else label
        start = time.perf_counter()
        c = sp.register(m_a, m_b, transform=transform, landmarks=pairs)
        took = time.perf_counter() - start
        e = errors(c, copy)
        row[label] = {"mean": float(e.mean()), "p95": float(np.percentile(e, 95)),
                      "max": float(e.max()), "ratio": took / mapping, "valid": c.map_a.valid,
                      "landmark_angle": (c.landmark_error or {}).get("max_angle")}
    row["seconds"] = time.perf_counter() - started
    return row


def population(n: int, size: int) -> Dict[str, float]:
    started = time.perf_counter()
    maps = [sp.embed(sp.datasets.bumpy_blob(size, seed=s)) for s in range(n)]
    mapped = time.perf_counter()
    pop = sp.correspond(maps, level=5)
    done = time.perf_counter()
    return {"shapes": n, "vertices": size, "map_seconds": mapped - started,
            "correspond_seconds": done - mapped, "register_seconds_summed": pop.seconds["register"]}


def table(rows: List[Dict[str, object]], landmarks: int) -> str:
    labels = list(TRANSFORMS) + (["warp+landmarks"] if landmarks else [])
    head = "| mesh | V | " + " | ".join(f"{t} mean / p95 (x map)" for t in labels) + " |"
    lines = [head, "|" + "---|" * (2 + len(labels))]
    for row in rows:
        cells = []
        for t in labels:
            r = row[t]
            assert isinstance(r, dict)
            mark = "" if r["valid"] else " INVALID"
            cells.append(f"{100 * r['mean']:.2f}% / {100 * r['p95']:.2f}% ({r['ratio']:.1f}x){mark}")
        lines.append(f"| {row['mesh']} | {row['n_a']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--small", action="store_true", help="small generated shapes")
    parser.add_argument("--only", nargs="*", default=[], help="these meshes only")
    parser.add_argument("--landmarks", type=int, default=8, help="landmark pairs (0: none)")
    parser.add_argument("--population", type=int, default=0, help="shapes for correspond")
    parser.add_argument("--population-size", type=int, default=20000)
    parser.add_argument("--json", default=None, help="also write the rows here")
    args = parser.parse_args()
    warnings.simplefilter("ignore", sp.SpherifyWarning)
    rows = []
    for name, mesh in corpus(args.small, args.only):
        row = run_mesh(name, mesh, args.landmarks)
        rows.append(row)
        print(name, json.dumps({k: v for k, v in row.items() if k != "mesh"}), flush=True)
    print()
    print(table(rows, args.landmarks))
    extra: Dict[str, object] = {}
    if args.population:
        extra = population(args.population, args.population_size)
        print()
        print(f"correspond: {extra['shapes']} shapes of {extra['vertices']} vertices: mapping "
              f"{extra['map_seconds']:.1f} s, correspond {extra['correspond_seconds']:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "population": extra}, indent=1))


if __name__ == "__main__":
    main()
