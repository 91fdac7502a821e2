"""The progressive method (thesis 9.3.3) against theta-phi (ch. 6): validity,
margin, distortion, time and memory; writes docs/progressive.md.

    python benches/progressive.py [--out docs/progressive.md] [--sizes 2000,20000,200000]
                                  [--large 1000000] [--energies isometric,conformal,authalic,stretch]
                                  [--small]

Every case runs in its own child process, so that its peak memory (the rise of
the peak resident set over the resident set before the call) is its own. Each
row maps one mesh by both methods in the same child, one after the other, so
that the time ratio is taken under the same load. ``--small`` (used by the
tests) maps two small shapes only and writes to the given ``--out``.

Measures (``sp.quality`` and ``sp.face_quality``): mean angle distortion
(degrees), mean |log area ratio| (spherical area over 4 pi against surface
area over the total), and Sander's L2 stretch (1 is ideal). ``min area`` is the
smallest spherical triangle over the mean, 4 pi / F (``m.report.min_area_ratio``):
how far the map is from the double-precision floor.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any, Dict, List

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"
SHAPES = ["tentacles", "urchin", "helix_tube", "bumpy_blob", "ellipsoid", "icosphere"]


def spherical_log_area(mesh: Any, points: Any) -> float:
    """Mean |log area ratio| with each face's spherical triangle (Van Oosterom
    and Strackee), issue 10's definition: (spherical area / 4 pi) over (surface
    area / total). Faces with no positive spherical area (flipped) are left out.
    ``mesh`` is the map's own (``m.mesh``: consistently outward, which the
    input need not be)."""
    import numpy as np
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    p = points / np.linalg.norm(points, axis=1, keepdims=True)
    a, b, c = p[F[:, 0]], p[F[:, 1]], p[F[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = 1 + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c) + np.einsum("ij,ij->i", c, a)
    sph = 2 * np.arctan2(det, den)
    surf = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.log((sph / (4 * np.pi)) / (surf / surf.sum()))
    return float(np.mean(np.abs(ratio[np.isfinite(ratio)])))


def measure(spec: Dict[str, Any]) -> Dict[str, Any]:
    """Runs in the child: one mesh, progressive (with ``energy``) then theta-phi."""
    import resource
    import time

    import numpy as np
    import psutil

    import spherify as sp

    warnings.simplefilter("ignore")
    mesh = sp.load(spec["file"]) if "file" in spec else sp.datasets.make(spec["shape"], spec["n"])
    out: Dict[str, Any] = {"V": mesh.n_vertices, "F": mesh.n_faces}
    for method in ("progressive", "theta_phi"):
        options = {"energy": spec["energy"]} if method == "progressive" else {}
        before = psutil.Process().memory_info().rss
        t = time.perf_counter()
        try:
            m = sp.embed(mesh, method, **options)
        except sp.SpherifyError as e:
            out[method] = {"error": f"{type(e).__name__}: {e}"}
            continue
        seconds = time.perf_counter() - t
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        row: Dict[str, Any] = {
            "valid": bool(m.valid), "flipped": int(m.flipped), "seconds": seconds,
            "min_area": float(m.report.min_area_ratio),
            "bytes_per_vertex": max(0, peak - before) / mesh.n_vertices,
        }
        if method == "theta_phi":
            row["tp_valid"] = bool(m.tp_valid)
        if np.isfinite(m.points).all():
            try:
                q = sp.quality(mesh, m.points)
                f = sp.face_quality(mesh, m.points)
                row.update(angle=q["angle_mean_deg"], stretch=q["stretch_l2"],
                           log_area=float(np.nanmean(np.abs(f["area_log"]))),
                           log_area_sph=spherical_log_area(m.mesh, np.asarray(m.points)))
            except sp.SpherifyError:
                pass
        out[method] = row
    if spec["energy"] == "conformal" and spec.get("lapy"):
        out["lapy"] = lapy_best(mesh)
    return out


def lapy_best(mesh: Any) -> Dict[str, Any]:
    """LaPy's spherical conformal and Tutte maps (when LaPy is installed): which
    are flip-free under the exact test, and the lower mean angle distortion of
    those that are."""
    import numpy as np

    import spherify as sp
    try:
        from lapy import TriaMesh, conformal
    except ImportError:
        return {"error": "LaPy not installed"}
    best: Dict[str, Any] = {}
    for which in ("spherical_conformal_map", "spherical_tutte_map"):
        try:
            points = np.asarray(getattr(conformal, which)(TriaMesh(mesh.vertices, mesh.faces)),
                                dtype=np.float64)
        except Exception as err:  # a failure of the peer, recorded as such
            best[which] = f"{type(err).__name__}"
            continue
        if not np.isfinite(points).all():
            best[which] = "non-finite"
            continue
        points = points / np.linalg.norm(points, axis=1, keepdims=True)
        report = sp.check_sphere(mesh, points)
        if not report.valid:
            best[which] = f"{report.n_negative + report.n_zero} flipped"
            continue
        angle = sp.quality(mesh, points)["angle_mean_deg"]
        best[which] = f"flip-free, {angle:.1f} deg"
        if "angle" not in best or angle < best["angle"]:
            best["angle"] = angle
    return best


def run_child(spec: Dict[str, Any]) -> Dict[str, Any]:
    code = ("import json, sys; sys.path.insert(0, %r); import progressive as p; "
            "print(json.dumps(p.measure(json.loads(sys.argv[1]))))" % str(Path(__file__).parent))
    done = subprocess.run([sys.executable, "-c", code, json.dumps(spec)], capture_output=True,
                          text=True, timeout=3600)
    if done.returncode != 0:
        return {"crash": done.stderr.strip().splitlines()[-1:]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def fmt(row: Dict[str, Any], key: str, spec: str) -> str:
    value = row.get(key)
    return "-" if value is None else format(value, spec)


def verdict(row: Dict[str, Any]) -> str:
    if "error" in row:
        return "error"
    return "valid" if row["valid"] else f"NOT valid ({row['flipped']} flipped)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "progressive.md"))
    ap.add_argument("--sizes", default="2000,20000,200000")
    ap.add_argument("--large", default="1000000", help="sizes of the last table (every shape)")
    ap.add_argument("--energies", default="isometric,conformal,authalic,stretch")
    ap.add_argument("--shape-energies", default="isometric",
                    help="energies of the generated-shape tables (comma-separated)")
    ap.add_argument("--no-corpus", action="store_true", help="skip the corpus table")
    ap.add_argument("--small", action="store_true")
    args = ap.parse_args()
    energies = args.energies.split(",")
    lines: List[str] = [
        "# The progressive method against theta-phi",
        "",
        f"Made by `benches/progressive.py` on {datetime.date.today()} ({platform.machine()}, "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start). Each row maps one "
        "mesh with both methods in the same child process; compare ratios, not absolute times.",
        "",
        "angle: mean |corner angle on the surface - on the sphere's chord triangle| (degrees); "
        "log area: mean |log area ratio| on chord triangles (`sp.quality`); log area sph: the same on "
        "spherical triangles (issue 10's definition; flipped faces left out); stretch: Sander's L2 stretch (1 is ideal); "
        "min area: smallest spherical triangle / mean (the double-precision floor is near 1e-16).",
        "",
    ]

    lapy_rows: List[str] = []

    def table(title: str, specs: List[Dict[str, Any]], label: Any) -> None:
        lines.extend([f"## {title}", "",
                      "| mesh | V | energy | progressive | min area | angle | log area | log area sph "
                      "| stretch | s | B/vertex | theta-phi GC | tp_valid | min area | angle | log area "
                      "| log area sph | stretch | s | time ratio |",
                      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"])
        for spec in specs:
            r = run_child(spec)
            if "crash" in r:
                lines.append(f"| {label(spec)} | | {spec['energy']} | CRASH {r['crash']} |")
                continue
            p, t = r["progressive"], r["theta_phi"]
            ratio = (p["seconds"] / t["seconds"]) if "seconds" in p and "seconds" in t else None
            lines.append(
                f"| {label(spec)} | {r['V']} | {spec['energy']} | {verdict(p)} | {fmt(p, 'min_area', '.1e')} "
                f"| {fmt(p, 'angle', '.1f')} | {fmt(p, 'log_area', '.3f')} | {fmt(p, 'log_area_sph', '.3f')} "
                f"| {fmt(p, 'stretch', '.3f')} "
                f"| {fmt(p, 'seconds', '.2f')} | {fmt(p, 'bytes_per_vertex', '.0f')} "
                f"| {verdict(t)} | {t.get('tp_valid', '-')} | {fmt(t, 'min_area', '.1e')} "
                f"| {fmt(t, 'angle', '.1f')} | {fmt(t, 'log_area', '.3f')} | {fmt(t, 'log_area_sph', '.3f')} "
                f"| {fmt(t, 'stretch', '.3f')} "
                f"| {fmt(t, 'seconds', '.2f')} | {'-' if ratio is None else format(ratio, '.1f')} |")
            if "lapy" in r:
                lapy_rows.append(f"| {label(spec)} | {fmt(p, 'angle', '.1f')} | "
                                 f"{r['lapy'].get('spherical_conformal_map', '-')} | "
                                 f"{r['lapy'].get('spherical_tutte_map', '-')} | "
                                 f"{fmt(r['lapy'], 'angle', '.1f')} |")
            print(lines[-1], flush=True)
        lines.append("")

    if args.small:
        table("Small shapes", [{"shape": s, "n": 500, "energy": "isometric"}
                               for s in ("tentacles", "bumpy_blob")],
              lambda s: s["shape"])
    else:
        if (SHARED / "MANIFEST.json").is_file() and not args.no_corpus:
            entries = [e for e in json.loads((SHARED / "MANIFEST.json").read_text())
                       if not e["path"].startswith("invalid/")]
            table("The corpus (../shared/meshes), every energy",
                  [{"file": str(SHARED / e["path"]), "energy": en, "name": e["name"], "lapy": True}
                   for e in entries for en in energies], lambda s: s["name"])
        sizes = [int(x) for x in args.sizes.split(",") if x]
        shape_energies = args.shape_energies.split(",")
        named = ", ".join(shape_energies)
        table(f"Generated shapes (spherify.datasets), {named}",
              [{"shape": s, "n": n, "energy": en}
               for en in shape_energies for n in sizes for s in SHAPES],
              lambda s: s["shape"])
        large = [int(x) for x in args.large.split(",") if x]
        if large:
            table(f"Large shapes, {named}",
                  [{"shape": s, "n": n, "energy": en}
                   for en in shape_energies for n in large for s in SHAPES],
                  lambda s: s["shape"])
    if lapy_rows:
        lines.extend(["## Conformal energy against LaPy", "",
                      "Mean angle distortion (degrees) of the progressive conformal map, and of "
                      "LaPy's `spherical_conformal_map` and `spherical_tutte_map` where the exact "
                      "test finds them flip-free.", "",
                      "| mesh | progressive conformal | LaPy conformal | LaPy Tutte | best flip-free LaPy |",
                      "|---|---|---|---|---|", *lapy_rows, ""])
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
