"""Accuracy and speed of registration (issue 23), for docs/correspondence.md.

    python benches/correspondence.py [--small] [--only spot hand] [--landmarks 8]
                                     [--population 100 --population-size 20000]

For every corpus mesh A (../shared/meshes, or small generated shapes with
``--small``), B is :func:`spherify.datasets.deformed_copy` of A's default map
(an icosphere of level 5 resampled from A, bent by 6% of its size, turned and
moved), so the true image of every vertex of A on B is known. Both are mapped
with the default method; each transform's error is the distance from where it
puts A's vertex on B to the true point, relative to B's bounding-box
diagonal. Where a result is right up to a rotational symmetry of A (bumpy, the
soccer ball: see :class:`Symmetry`), its error against the truth under that
symmetry is reported beside the raw one. With ``--landmarks K``, the warp is also run with K landmark pairs:
A's vertices farthest-point sampled, each paired with B's vertex nearest its
true image. Times are ratios to mapping both shapes. ``--speed N`` instead measures
issue 23's speed bar N times per mesh (by default horse and armadillo): B of
level 6 (about 41k vertices), mapping both (``sp.embed`` of A and of B) and
``register`` (the warp) each timed in this process, wall time and process
CPU time (all threads), and their ratios. ``--population N`` also
times :func:`spherify.correspond` of N generated shapes (bumpy blobs of
``--population-size`` vertices, different seeds) on this machine's cores.
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

import spherify as sp
from spherify._align import kabsch
from spherify._nearest import NearestOnSurface

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



def errors(c: sp.Correspondence, copy: sp.datasets.DeformedCopy) -> np.ndarray:
    diagonal = float(np.linalg.norm(np.ptp(copy.mesh.vertices, axis=0)))
    # A landmark map may be laid out on a refined mesh (docs/correspondence.md):
    # A's own vertices are its first rows.
    on_b = c.a_on_b.positions[:len(copy.truth)]
    out: np.ndarray = np.linalg.norm(on_b - copy.truth, axis=1) / diagonal
    return out


class Symmetry:
    """The error against the nearest equally true answer, where A has a symmetry.

    On a shape with a rotational symmetry S (bumpy, a rounded cube, turned
    90 degrees; the soccer ball) the truth names one registration of several
    that no method can tell apart: a result that lands every vertex where the
    truth puts its image under S is right. So the pull-back of a result's
    points to A (through the truth: B's true points over A's faces) is fitted
    by a rotation S about A's centroid (Kabsch), and S counts as a symmetry
    of A only if it moves A's vertices by at least a tenth of A's diagonal on
    average and yet puts them within a tenth of a mean edge length of A's
    surface (a near-symmetry such as the sword's hilt, or a small tilt, does
    not pass). Then the error is measured against the truth of S a_i.
    """

    def __init__(self, mesh: sp.Mesh, copy: sp.datasets.DeformedCopy) -> None:
        self.a = mesh.vertices
        self.faces = mesh.faces
        self.copy = copy
        self.centre = self.a.mean(axis=0)
        corners = self.a[self.faces]
        self.edge = float(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean())
        self.size = float(np.linalg.norm(np.ptp(self.a, axis=0)))
        self.on_a = NearestOnSurface(self.a, self.faces)
        # B's true points with A's connectivity: the surface that pulls B's points back to A.
        self.on_truth = NearestOnSurface(copy.truth, self.faces)
        self.diagonal = float(np.linalg.norm(np.ptp(copy.mesh.vertices, axis=0)))

    def __call__(self, c: sp.Correspondence) -> Optional[Tuple[np.ndarray, float]]:
        """The errors against the truth under A's symmetry S, and S's angle
        in degrees, or None if the result is not near a symmetry of A."""
        on_b = c.a_on_b.positions[:len(self.a)]
        f, w, _ = self.on_truth(on_b)
        pulled = (self.a[self.faces[f]] * w[:, :, None]).sum(axis=1)
        s = kabsch(self.a - self.centre, pulled - self.centre)
        turned = (self.a - self.centre) @ s.T + self.centre
        f2, w2, onto = self.on_a(turned)
        moved = float(np.linalg.norm(turned - self.a, axis=1).mean())
        off = float(np.linalg.norm(onto - turned, axis=1).mean())
        if moved < 0.1 * self.size or off > 0.1 * self.edge:
            return None
        truth = (self.copy.truth[self.faces[f2]] * w2[:, :, None]).sum(axis=1)
        angle = float(np.degrees(np.arccos(np.clip((np.trace(s) - 1) / 2, -1.0, 1.0))))
        return np.linalg.norm(on_b - truth, axis=1) / self.diagonal, angle


def run_mesh(name: str, mesh: sp.Mesh, landmarks: int) -> Dict[str, object]:
    started = time.perf_counter()
    m_a = sp.embed(mesh)
    copy = sp.datasets.deformed_copy(m_a)
    m_b = sp.embed(copy.mesh)
    # Mapping both, without the resampling that made B.
    mapping = sum(m_a.seconds.values()) + sum(m_b.seconds.values())
    row: Dict[str, object] = {"mesh": name, "n_a": mesh.n_vertices, "n_b": copy.mesh.n_vertices,
                              "map_both": mapping}
    symmetry = Symmetry(mesh, copy)
    runs: List[Tuple[str, Optional[np.ndarray]]] = [(t, None) for t in TRANSFORMS]
    if landmarks:
        ids = sp.datasets.farthest_points(mesh.vertices, landmarks)
        corners = copy.mesh.faces[copy.truth_faces[ids]]
        nearest = corners[np.arange(len(ids)), np.argmax(copy.truth_bary[ids], axis=1)]
        runs.append(("warp+landmarks", np.stack([ids, nearest], axis=1)))
    for label, pairs in runs:
        transform = "warp" if label.startswith("warp") else label
        start = time.perf_counter()
        try:
            c = sp.register(m_a, m_b, transform=transform, landmarks=pairs)
        except sp.SpherifyError as err:
            row[label] = {"error": f"{type(err).__name__}: {err}"}
            continue
        took = time.perf_counter() - start
        e = errors(c, copy)
        result: Dict[str, object] = {
            "mean": float(e.mean()), "p95": float(np.percentile(e, 95)), "max": float(e.max()),
            "ratio": took / mapping, "valid": c.map_a.valid, "margin": c.map_a.margin,
            "landmark_angle": (c.landmark_error or {}).get("max_angle")}
        under = symmetry(c)
        if under is not None:
            e_s, angle = under
            result.update(sym_mean=float(e_s.mean()), sym_p95=float(np.percentile(e_s, 95)),
                          sym_angle=angle)
        row[label] = result
    row["seconds"] = time.perf_counter() - started
    return row


def _cpu() -> float:
    import resource
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def speed(name: str, mesh: sp.Mesh, runs: int) -> List[Dict[str, object]]:
    """Issue 23's speed bar: ``register`` (warp) of A and B (level 6) against
    mapping both, wall and CPU time, ``runs`` times (the maps of each run are
    the ones timed; A's first map, which makes B, warms the caches)."""
    copy = sp.datasets.deformed_copy(sp.embed(mesh), level=6)
    out = []
    for _ in range(runs):
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        wall, cpu = time.perf_counter(), _cpu()
        m_a, m_b = sp.embed(mesh), sp.embed(copy.mesh)
        map_wall, map_cpu = time.perf_counter() - wall, _cpu() - cpu
        wall, cpu = time.perf_counter(), _cpu()
        c = sp.register(m_a, m_b)
        reg_wall, reg_cpu = time.perf_counter() - wall, _cpu() - cpu
        e = errors(c, copy)
        out.append({"mesh": name, "n_a": mesh.n_vertices, "n_b": copy.mesh.n_vertices,
                    "load": load, "map_wall": map_wall, "map_cpu": map_cpu,
                    "register_wall": reg_wall, "register_cpu": reg_cpu,
                    "wall_ratio": reg_wall / map_wall, "cpu_ratio": reg_cpu / map_cpu,
                    "stages": c.seconds, "mean": float(e.mean()),
                    "p95": float(np.percentile(e, 95)), "valid": c.map_a.valid})
    return out


def population(n: int, size: int) -> Dict[str, float]:
    started = time.perf_counter()
    maps = [sp.embed(sp.datasets.bumpy_blob(size, seed=s)) for s in range(n)]
    mapped = time.perf_counter()
    pop = sp.correspond(maps, level=5)
    done = time.perf_counter()
    return {"shapes": n, "vertices": size, "map_seconds": mapped - started,
            "correspond_seconds": done - mapped, "register_seconds_summed": pop.seconds["register"]}


def face_colours(mesh: sp.Mesh, vertex_colours: np.ndarray) -> np.ndarray:
    out: np.ndarray = np.clip(vertex_colours[mesh.faces].mean(axis=1), 0.0, 1.0)
    return out


def position_colours(points: np.ndarray, box: np.ndarray) -> np.ndarray:
    """A colour per point from its position in the bounding box of ``box``:
    each axis to one of red, green and blue."""
    lo, hi = box.min(axis=0), box.max(axis=0)
    out: np.ndarray = (points - lo) / np.where(hi > lo, hi - lo, 1.0)
    return out


def pictures(folder: Path, small: bool) -> List[Path]:
    """Three pictures for docs/correspondence.md: colours carried from A to B
    by the rotation and by the warp; a feature-aligned morph strip; a
    population's mean and first mode."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    hand = SHARED / "hand.obj"
    a = sp.load(hand) if hand.exists() and not small else sp.datasets.tentacles(3000)
    m_a = sp.embed(a)
    copy = sp.datasets.deformed_copy(m_a, bend=0.1, seed=3)
    m_b = sp.embed(copy.mesh)
    fig = plt.figure(figsize=(12, 4))
    panels = [("A", a, face_colours(a, position_colours(a.vertices, a.vertices)))]
    for transform in ("rotation", "warp"):
        back = sp.register(m_a, m_b, transform=transform).inverse()
        # Each vertex of B takes the colour of the point of A it corresponds to.
        where = back.a_on_b.positions
        panels.append((f"B, colours through {transform}", copy.mesh,
                       face_colours(copy.mesh, position_colours(where, a.vertices))))
    for k, (title, mesh, colours) in enumerate(panels):
        ax = fig.add_subplot(1, 3, k + 1, projection="3d")
        sp.plot.mesh(mesh, colors=colours, title=title, ax=ax)
    path = folder / "correspondence_colours.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    written.append(path)

    mo = sp.morph(m_a, m_b, align="warp")
    fig = plt.figure(figsize=(15, 3))
    for k, t in enumerate(np.linspace(0, 1, 5)):
        ax = fig.add_subplot(1, 5, k + 1, projection="3d")
        sp.plot.mesh(mo.at(float(t)), title=f"t = {t:.2f}", ax=ax)
    path = folder / "correspondence_morph.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    written.append(path)

    maps = [m_a] + [sp.embed(sp.datasets.deformed_copy(m_a, level=5, bend=0.08, seed=s).mesh)
                    for s in range(8 if small else 12)]
    pop = sp.correspond(maps, level=5)
    variances, modes = pop.modes(1)
    fig = plt.figure(figsize=(12, 4))
    for k, t in enumerate((-2.0, 0.0, 2.0)):
        ax = fig.add_subplot(1, 3, k + 1, projection="3d")
        shape = sp.Mesh(pop.mean().vertices + t * np.sqrt(variances[0]) * modes[0], pop.faces)
        sp.plot.mesh(shape, title="mean" if t == 0 else f"mean {t:+.0f} sd along mode 1", ax=ax)
    path = folder / "correspondence_population.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)
    written.append(path)
    return written


def table(rows: List[Dict[str, object]], landmarks: int) -> str:
    labels = list(TRANSFORMS) + (["warp+landmarks"] if landmarks else [])
    head = "| mesh | V | " + " | ".join(f"{t} mean / p95 (x map)" for t in labels) + " |"
    lines = [head, "|" + "---|" * (2 + len(labels))]
    for row in rows:
        cells = []
        for t in labels:
            r = row[t]
            assert isinstance(r, dict)
            if "error" in r:
                cells.append(str(r["error"]).split(":")[0])
                continue
            mark = "" if r["valid"] else " INVALID"
            cell = f"{100 * r['mean']:.2f}% / {100 * r['p95']:.2f}% ({r['ratio']:.1f}x){mark}"
            if "sym_mean" in r:
                cell += (f"; under a {r['sym_angle']:.0f} deg symmetry "
                         f"{100 * r['sym_mean']:.2f}% / {100 * r['sym_p95']:.2f}%")
            cells.append(cell)
        lines.append(f"| {row['mesh']} | {row['n_a']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--small", action="store_true", help="small generated shapes")
    parser.add_argument("--only", nargs="*", default=[], help="these meshes only")
    parser.add_argument("--landmarks", type=int, default=8, help="landmark pairs (0: none)")
    parser.add_argument("--population", type=int, default=0, help="shapes for correspond")
    parser.add_argument("--population-size", type=int, default=20000)
    parser.add_argument("--speed", type=int, default=0,
                        help="measure register against mapping both this many times a mesh "
                             "(B of level 6; horse and armadillo unless --only)")
    parser.add_argument("--json", default=None, help="also write the rows here")
    parser.add_argument("--pictures", default=None, help="write the docs' pictures here")
    args = parser.parse_args()
    warnings.simplefilter("ignore", sp.SpherifyWarning)
    if args.pictures:
        for path in pictures(Path(args.pictures), args.small):
            print(f"wrote {path}")
    if args.speed:
        timed = []
        for name, mesh in corpus(args.small, args.only or ["horse", "armadillo"]):
            for r in speed(name, mesh, args.speed):
                timed.append(r)
                print(f"{name}: register {r['register_wall']:.2f} s wall, "
                      f"{r['register_cpu']:.2f} s CPU; mapping both {r['map_wall']:.2f} s wall, "
                      f"{r['map_cpu']:.2f} s CPU: {r['wall_ratio']:.2f}x wall, "
                      f"{r['cpu_ratio']:.2f}x CPU (load {r['load']:.1f}; error "
                      f"{100 * r['mean']:.2f}% / {100 * r['p95']:.2f}%)", flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps({"speed": timed}, indent=1))
        return
    rows = []
    for name, mesh in corpus(args.small, args.only):
        row = run_mesh(name, mesh, args.landmarks)
        rows.append(row)
        print(name, json.dumps({k: v for k, v in row.items() if k != "mesh"}), flush=True)
    print()
    print(table(rows, args.landmarks))
    extra: Dict[str, object] = {}
    if args.population:
        extra = dict(population(args.population, args.population_size))
        print()
        print(f"correspond: {extra['shapes']} shapes of {extra['vertices']} vertices: mapping "
              f"{extra['map_seconds']:.1f} s, correspond {extra['correspond_seconds']:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "population": extra}, indent=1))


if __name__ == "__main__":
    main()
