"""spherify's sphere maps against Praun and Hoppe's SphereParam (issue 22):
stretch, area and angle distortion and time, on the same meshes in the same
run, all measured by one evaluator; writes a section of docs/progressive.md.

    python benches/sphereparam_quality.py [--sphereparam-bin DIR] [--pipeline PATH]
        [--cache DIR] [--no-cache] [--peer-only] [--only NAME,...]
        [--sizes 20000,200000] [--no-corpus] [--no-shapes]
        [--energies default,stretch,isometric,conformal,authalic] [--out docs/progressive.md]

Without ``--sphereparam-bin`` spherify runs alone. With it, SphereParam is run
through the pipeline script of ``../shared/peers/sphereparam/`` (MeshSimplify,
reverselines, Filterprog, SphereParam; ``SPBIN`` picks the binary, by default
``SphereParam_p9`` when it exists: it writes the float32 result with 9
digits, so that the map read back is the map it made). Its points are cached
in ``--cache`` under the mesh's hash, so that development runs do not redo
the peer's 150 s per 200k-vertex mesh; ``--no-cache`` runs it again (and
refreshes the cache), as a final table must. ``--peer-only`` fills the cache
and measures nothing.

The one evaluator (every map, spherify's and the peer's alike; issue 22's
definitions): the exact certificate (``sp.check_sphere``) and the smallest
spherical triangle over the mean; stretch: Sander's L2 stretch of the chord
triangles, 1 ideal (``sp.quality``); angle: mean over corners of |surface
angle - chord triangle angle| in degrees; area: mean over faces of
|log((spherical area / 4 pi) / (surface area / total area))|, and the same
on chord triangles. The peer's float32 points are normalised in double
before they are measured.

Meshes: the corpus of ``../shared/meshes`` (MANIFEST.json) and every shape
of ``spherify.datasets`` at ``--sizes``, each oriented outward
(``sp.orient``; horse.ply is stored inward) before either method sees it.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from progressive import SHAPES, SHARED, spherical_log_area  # noqa: E402

import spherify as sp  # noqa: E402

PEER_README = Path(__file__).resolve().parents[2] / "shared" / "peers" / "sphereparam"
BEGIN = "<!-- sphereparam_quality.py: begin -->"
END = "<!-- sphereparam_quality.py: end -->"
# The energies a run maps with; "default" is sp.embed(mesh) with no option
# (the isometric energy), "balanced" the best-quality energy of issue 22.
ENERGIES = ["balanced", "default", "stretch", "isometric", "conformal", "authalic"]


def meshes(args: argparse.Namespace) -> List[Tuple[str, Callable[[], Any]]]:
    """(name, loader) of every mesh of the run, in table order."""
    out: List[Tuple[str, Callable[[], Any]]] = []
    if not args.no_corpus and (SHARED / "MANIFEST.json").is_file():
        for e in json.loads((SHARED / "MANIFEST.json").read_text()):
            if not e["path"].startswith("invalid/"):
                out.append((e["name"], lambda p=SHARED / e["path"]: sp.load(p)))
    if not args.no_shapes:
        for n in [int(x) for x in args.sizes.split(",") if x]:
            for s in SHAPES:
                out.append((f"{s} {n // 1000}k", lambda s=s, n=n: sp.datasets.make(s, n)))
    if args.only:
        keep = set(args.only.split(","))
        out = [(name, load) for name, load in out if name in keep or name.split()[0] in keep]
    return out


def mesh_hash(mesh: Any) -> str:
    h = hashlib.sha256()
    for a in (np.ascontiguousarray(mesh.vertices, dtype=np.float64),
              np.ascontiguousarray(mesh.faces, dtype=np.int64)):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:20]


def evaluate(mesh: Any, points: Any) -> Dict[str, Any]:
    """The one evaluator: certificate, smallest triangle, stretch, angle, area."""
    points = np.asarray(points, dtype=np.float64)
    row: Dict[str, Any] = {}
    if not np.isfinite(points).all():
        return {"valid": False, "note": "non-finite points"}
    points = points / np.linalg.norm(points, axis=1, keepdims=True)
    report = sp.check_sphere(mesh, points)
    row["valid"] = bool(report.valid)
    row["flipped"] = int(len(report.flipped_faces))
    row["min_area"] = float(report.min_area_ratio)
    q = sp.quality(mesh, points)
    f = sp.face_quality(mesh, points)
    row["stretch"] = float(q["stretch_l2"])
    row["angle"] = float(q["angle_mean_deg"])
    row["area_chord"] = float(np.nanmean(np.abs(f["area_log"])))
    row["area"] = spherical_log_area(mesh, points)
    return row


def elapsed(path: Path) -> Tuple[float, int]:
    """Wall seconds and peak resident kilobytes of one `/usr/bin/time -v` file."""
    text = path.read_text()
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", text)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    seconds = 0.0
    for part in (wall.group(1) if wall else "0").split(":"):
        seconds = 60 * seconds + float(part)
    return seconds, int(rss.group(1)) if rss else 0


def read_m(path: Path, n: int) -> np.ndarray:
    """The `sph=(x y z)` of every `Vertex i` line of a Hoppe .m file, as (n, 3)."""
    points = np.full((n, 3), np.nan)
    pattern = re.compile(r"^Vertex (\d+) .*sph=\(([^)]*)\)")
    with open(path) as f:
        for line in f:
            m = pattern.match(line)
            if m:
                points[int(m.group(1)) - 1] = [float(x) for x in m.group(2).split()]
    return points


def run_peer(name: str, mesh: Any, args: argparse.Namespace) -> Dict[str, Any]:
    """SphereParam's map of `mesh` (cached by the mesh's hash), timed stage by stage."""
    spbin = args.spbin
    key = f"{mesh_hash(mesh)}-{spbin}"
    cache = Path(args.cache) / key
    if not args.no_cache and (cache / "points.npy").is_file():
        meta = json.loads((cache / "meta.json").read_text())
        meta["cached"] = True
        return {**meta, "points": np.load(cache / "points.npy")}
    work = Path(tempfile.mkdtemp(prefix="sphereparam-"))
    try:
        src = work / "mesh.obj"
        sp.save(mesh, src)
        env = dict(os.environ, BIN=str(Path(args.sphereparam_bin).resolve()), PYTHON=sys.executable,
                   RUNS=str(work / "runs"), SPBIN=spbin)
        t = time.perf_counter()
        done = subprocess.run(["bash", str(Path(args.pipeline).resolve()), "run", str(src)], env=env,
                              capture_output=True, text=True, cwd=work)
        wall = time.perf_counter() - t
        run = work / "runs" / "run"
        if done.returncode != 0 or not (run / "out.m").is_file():
            errs = " ".join((run / f).read_text()[-300:] for f in ("s1.err", "s4.err") if (run / f).is_file())
            return {"error": f"{done.stdout.strip()} {errs}".strip()}
        stages = {s: elapsed(run / f"{s}.time") for s in
                  ("s1_simplify", "s2_reverse", "s3_filterprog", "s4_sphereparam")}
        meta = {"seconds": sum(s for s, _ in stages.values()), "wall": wall,
                "stages": {k: v[0] for k, v in stages.items()},
                "peak_kb": max(kb for _, kb in stages.values()), "name": name,
                "date": datetime.datetime.now().isoformat(timespec="seconds"), "binary": spbin}
        points = read_m(run / "out.m", mesh.n_vertices)
        cache.mkdir(parents=True, exist_ok=True)
        np.save(cache / "points.npy", points)
        (cache / "meta.json").write_text(json.dumps(meta, indent=1))
        return {**meta, "cached": False, "points": points}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def run_spherify(mesh: Any, energy: str) -> Dict[str, Any]:
    t = time.perf_counter()
    try:
        if energy == "theta_phi":
            m = sp.embed(mesh, method="theta_phi")
        elif energy == "default":
            m = sp.embed(mesh)
        else:
            m = sp.embed(mesh, method="progressive", energy=energy)
    except sp.SpherifyError as e:
        return {"error": f"{type(e).__name__}: {e}"}
    seconds = time.perf_counter() - t
    row = evaluate(mesh, m.points)
    row["seconds"] = seconds
    row["certified"] = bool(m.valid)
    if energy == "theta_phi":
        row["tp_valid"] = bool(m.tp_valid)
    return row


def fmt(row: Optional[Dict[str, Any]], key: str, spec: str) -> str:
    if row is None or row.get(key) is None:
        return "-"
    return format(row[key], spec)


def verdict(row: Dict[str, Any]) -> str:
    if "error" in row:
        return "error"
    return "valid" if row.get("valid") else f"NOT valid ({row.get('flipped', '?')} flipped)"


def mark(value: Optional[float], peer: Optional[float], factor: float = 1.0) -> str:
    """A value with `*` when it is worse than the peer's (times factor)."""
    if value is None:
        return "-"
    return "" if peer is None or value <= peer * factor else "*"


def tables(results: List[Dict[str, Any]], energies: List[str], peer: bool) -> List[str]:
    lines = []
    head = "| mesh | V | map | certificate | min area | stretch | area | area chord | angle | s |"
    sep = "|---|---|---|---|---|---|---|---|---|---|"
    if peer:
        head += " SphereParam s / s |"
        sep += "---|"
    lines += [head, sep]
    for r in results:
        p = r.get("sphereparam")
        order = (["sphereparam"] if p else []) + energies + ["theta_phi"]
        for key in order:
            row = r.get(key)
            if row is None:
                continue
            label = "SphereParam" if key == "sphereparam" else key
            if "error" in row:
                lines.append(f"| {r['name']} | {r['V']} | {label} | error: {row['error'][:120]} |")
                continue
            pe = p if (p and "error" not in p and key != "sphereparam") else None
            stretch = fmt(row, "stretch", ".3f") + mark(row.get("stretch"), pe and pe.get("stretch"))
            area = fmt(row, "area", ".3f") + mark(row.get("area"), pe and pe.get("area"))
            angle = fmt(row, "angle", ".1f") + mark(row.get("angle"), pe and pe.get("angle"), 1.1)
            line = (f"| {r['name']} | {r['V']} | {label} | {verdict(row)} | {fmt(row, 'min_area', '.1e')} "
                    f"| {stretch} | {area} | {fmt(row, 'area_chord', '.3f')} | {angle} "
                    f"| {fmt(row, 'seconds', '.2f')} |")
            if peer:
                ratio = (pe["seconds"] / row["seconds"]) if pe and row.get("seconds") else None
                line += f" {'-' if ratio is None else format(ratio, '.0f')} |"
            lines.append(line)
    return lines


def summary(results: List[Dict[str, Any]], energies: List[str]) -> List[str]:
    """How many meshes each map matches SphereParam on (issue 22's acceptance)."""
    lines = ["| map | stretch <= SphereParam | area <= SphereParam | angle <= 1.1 x SphereParam "
             "| all three | certified | time ratio min / median |", "|---|---|---|---|---|---|---|"]
    for key in energies + ["theta_phi"]:
        n = s = a = g = all3 = cert = 0
        ratios = []
        for r in results:
            p, row = r.get("sphereparam"), r.get(key)
            if not p or "error" in p or not row or "error" in row:
                continue
            n += 1
            ok = [row["stretch"] <= p["stretch"], row["area"] <= p["area"], row["angle"] <= 1.1 * p["angle"]]
            s, a, g = s + ok[0], a + ok[1], g + ok[2]
            all3 += all(ok)
            cert += bool(row.get("valid"))
            ratios.append(p["seconds"] / row["seconds"])
        if n:
            lines.append(f"| {key} | {s} / {n} | {a} / {n} | {g} / {n} | {all3} / {n} | {cert} / {n} "
                         f"| {min(ratios):.0f} / {float(np.median(ratios)):.0f} |")
    return lines


def write_section(out: Path, section: List[str]) -> None:
    """Replaces the section between the markers of `out` (or appends it)."""
    text = out.read_text() if out.is_file() else ""
    block = "\n".join([BEGIN, *section, END])
    if BEGIN in text and END in text:
        start, end = text.index(BEGIN), text.index(END) + len(END)
        text = text[:start] + block + text[end:]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    out.write_text(text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sphereparam-bin", help="folder of the built SphereParam programs")
    ap.add_argument("--pipeline", default=str(PEER_README / "pipeline.sh"))
    ap.add_argument("--spbin", default=None, help="SphereParam binary name (default SphereParam_p9 if built)")
    ap.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "sphereparam-cache"))
    ap.add_argument("--no-cache", action="store_true", help="run the peer again on every mesh")
    ap.add_argument("--peer-only", action="store_true", help="only run the peer (fill the cache)")
    ap.add_argument("--only", default="", help="mesh names (or shape names) to keep, comma-separated")
    ap.add_argument("--sizes", default="20000,200000")
    ap.add_argument("--no-corpus", action="store_true")
    ap.add_argument("--no-shapes", action="store_true")
    ap.add_argument("--energies", default=",".join(ENERGIES))
    ap.add_argument("--no-theta-phi", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "progressive.md"))
    ap.add_argument("--json", default=None, help="also write every measure to this JSON file")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    peer = args.sphereparam_bin is not None
    if peer and args.spbin is None:
        args.spbin = "SphereParam_p9" if (Path(args.sphereparam_bin) / "SphereParam_p9").is_file() \
            else "SphereParam"
    energies = [e for e in args.energies.split(",") if e]
    started = datetime.datetime.now(datetime.timezone.utc)
    load = os.getloadavg()[0]
    results: List[Dict[str, Any]] = []
    for name, loader in meshes(args):
        mesh = sp.orient(loader())
        r: Dict[str, Any] = {"name": name, "V": mesh.n_vertices}
        if peer:
            got = run_peer(name, mesh, args)
            if "error" in got:
                r["sphereparam"] = got
            else:
                row = evaluate(mesh, got.pop("points"))
                row.update(seconds=got["seconds"], cached=got["cached"], peak_kb=got["peak_kb"])
                r["sphereparam"] = row
            print(f"{name}: SphereParam {json.dumps(r['sphereparam'])}", flush=True)
        if args.peer_only:
            continue
        for energy in energies + ([] if args.no_theta_phi else ["theta_phi"]):
            r[energy] = run_spherify(mesh, energy)
            print(f"{name}: {energy} {json.dumps(r[energy])}", flush=True)
        results.append(r)
    if args.peer_only:
        return
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    cached = sum(1 for r in results if r.get("sphereparam", {}).get("cached"))
    section = [
        "## Against SphereParam (issue 22)",
        "",
        f"Made by `benches/sphereparam_quality.py` on {started:%Y-%m-%d %H:%M} UTC ({platform.machine()}, "
        f"{os.cpu_count()} cores, load average {load:.1f} at the start), spherify {sp.__version__}"
        + (f"; SphereParam (`{args.spbin}`) run in the same run on {len(results) - cached} of "
           f"{len(results)} meshes ({cached} from the cache of an earlier run)" if peer else
           "; SphereParam not given (spherify alone)") + ".",
        "",
        "One evaluator for every map: certificate = exact GC-embedding test (`sp.check_sphere`); "
        "min area = smallest spherical triangle / mean; stretch = Sander's L2 stretch of the chord "
        "triangles (1 is ideal); area = mean |log((spherical area / 4 pi) / (surface area / total))|; "
        "area chord = the same on chord triangles; angle = mean |surface corner angle - chord corner "
        "angle| (degrees); s = seconds of the whole map (SphereParam: the four stages of its pipeline, "
        "MeshSimplify included); the last column is SphereParam's time over this map's. "
        "`*`: worse than SphereParam (angle: more than 1.1 times).",
        "",
    ]
    if peer:
        section += ["### Summary", "", *summary(results, energies), ""]
    section += ["### Per mesh", "", *tables(results, energies, peer), ""]
    write_section(Path(args.out), section)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
