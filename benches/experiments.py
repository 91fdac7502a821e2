"""The thesis's experiments (ch. 7), rerun with spherify; writes docs/experiments.md.

    python benches/experiments.py [--out docs/experiments.md] [--corpus-max N] [--large-max 1000000]

For every spherical method (``sp.methods()``) on generated shapes of the
thesis's sizes (about 150 to 4,000 vertices, from near-convex to helix-like)
and on every mesh of ../shared/meshes (when present): the outcome (valid,
collapsed, gave up, refused), iterations, seconds, and the quality measures of
``sp.quality`` (when available). Like Table 7.3 of the thesis, plus the pole
selection timings of Table 7.4 and the theta-phi timings of Table 7.5, which
also run on generated shapes of 100k to 1M vertices (``--large-max``). The
iterative methods get ``--max-iter`` iterations and are skipped on meshes
above ``--iterative-max`` vertices; Gotsman above ``--gotsman-max``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Tuple

import spherify as sp

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"

SHAPES: List[Tuple[str, str, int]] = [
    # (label, dataset, target vertices): thesis models range from 453 (rabbit) to 4,039 (female).
    ("icosphere-162", "icosphere", 162),
    ("bumpy_blob-450", "bumpy_blob", 450),
    ("ellipsoid-1000", "ellipsoid", 1000),
    ("helix_tube-1500", "helix_tube", 1500),
    ("bumpy_blob-4000", "bumpy_blob", 4000),
    ("tentacles-2000", "tentacles", 2000),
    ("urchin-3000", "urchin", 3000),
]

# Tables 7.4 and 7.5 also at the sizes people map today (theta-phi only; the
# other methods of Table 7.3 stay at the thesis's sizes).
LARGE_SHAPES: List[Tuple[str, str, int]] = [
    ("bumpy_blob-100k", "bumpy_blob", 100_000),
    ("helix_tube-100k", "helix_tube", 100_000),
    ("bumpy_blob-300k", "bumpy_blob", 300_000),
    ("tentacles-300k", "tentacles", 300_000),
    ("urchin-300k", "urchin", 300_000),
    ("bumpy_blob-1M", "bumpy_blob", 1_000_000),
]

QUALITY_KEYS = ["angle_mean_deg", "conformal_mean", "area_log_std", "stretch_l2", "edge_length_cv"]


def meshes(args: argparse.Namespace) -> List[Tuple[str, sp.Mesh]]:
    out = [(label, sp.datasets.make(name, n)) for label, name, n in SHAPES]
    manifest = SHARED / "MANIFEST.json"
    if manifest.exists():
        for entry in json.loads(manifest.read_text()):
            if isinstance(entry["genus"], int) and entry["V"] <= args.corpus_max:
                out.append((entry["name"], sp.load(SHARED / entry["path"])))
    return out


def run(mesh: sp.Mesh, method: str, args: argparse.Namespace) -> Dict[str, Any]:
    options: Dict[str, Any] = {}
    if method in ("relaxation", "alexa"):
        options = {"max_iter": args.max_iter}
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            m = sp.embed(mesh, method, **options)
    except sp.SpherifyError as err:
        return {"outcome": f"refused: {str(err).split(':')[0][:60]}", "seconds": time.perf_counter() - start}
    seconds = time.perf_counter() - start
    if m.valid:
        outcome = "valid"
    elif method == "theta_phi":
        outcome = "rectangle certified, GC invalid" if m.tp_valid else "not certified"
    else:
        outcome = {"collapsed": "collapsed", "max_iterations": "gave up"}.get(m.status, "invalid")
    row: Dict[str, Any] = {"outcome": outcome, "iterations": m.iterations, "seconds": seconds,
                           "flipped": m.flipped}
    if hasattr(sp, "quality"):
        q = sp.quality(m.mesh, m.points)
        row.update({k: q.get(k) for k in QUALITY_KEYS})
    return row


def embed_seconds(seconds: Dict[str, float]) -> float:
    """The embedding step of Table 7.5: every stage between the cut and the fold
    (assembly, factorisation, solve, refinement and the exact flip check)."""
    return sum(v for k, v in seconds.items() if k not in ("poles", "cut", "fold"))


def fmt(x: Any) -> str:
    if x is None:
        return ""
    if isinstance(x, float):
        return f"{x:.3g}"
    return str(x)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "experiments.md"))
    parser.add_argument("--corpus-max", type=int, default=10_000_000,
                        help="skip corpus meshes with more vertices (default: none skipped)")
    parser.add_argument("--large-max", type=int, default=1_000_000,
                        help="largest generated shape for Tables 7.4 and 7.5 (0: thesis sizes only)")
    parser.add_argument("--max-iter", type=int, default=20000)
    parser.add_argument("--iterative-max", type=int, default=12000)
    parser.add_argument("--gotsman-max", type=int, default=12000)
    args = parser.parse_args()

    lines: List[str] = []
    add = lines.append
    add("# Experiments (thesis ch. 7, rerun)\n")
    add(f"Generated by `python benches/experiments.py` on {datetime.date.today()} "
        f"({platform.machine()}, {os.cpu_count()} cores, shared machine: compare within a table). "
        "Each method runs through `sp.embed`; validity is decided by the exact tests of thesis 3.4 "
        "(`SphereMap.valid`), never by the method itself. Load average at the start: "
        f"{' / '.join(f'{x:.2f}' for x in os.getloadavg())}.\n")
    methods = sp.methods()
    rows: List[Tuple[str, int, str, Dict[str, Any]]] = []
    all_meshes = meshes(args)
    for label, mesh in all_meshes:
        for method in methods:
            iterative = method in ("relaxation", "alexa")
            if (iterative and mesh.n_vertices > args.iterative_max) or (
                    method == "gotsman" and mesh.n_vertices > args.gotsman_max):
                continue
            row = run(mesh, method, args)
            rows.append((label, mesh.n_vertices, method, row))
            print(label, method, row, flush=True)

    add("## Every method on every mesh (cf. Table 7.3)\n")
    add("outcome: `valid` is a proven GC-embedding; `collapsed` and `gave up` are the iterative "
        "methods' honest stops; `refused` means the method cannot apply (for instance radial "
        "projection of a mesh that is not star-shaped); for theta-phi, `rectangle certified, GC "
        "invalid` means the bijection h of thesis 6.6 is certified while the minor-arc drawing of "
        "6.7 is not valid.\n")
    header = ["mesh", "V", "method", "outcome", "iterations", "seconds", "flipped"] + QUALITY_KEYS
    add("| " + " | ".join(header) + " |")
    add("|" + "---|" * len(header))
    for label, n, method, row in rows:
        cells = [label, str(n), method] + [fmt(row.get(k)) for k in header[3:]]
        add("| " + " | ".join(cells) + " |")

    timing_meshes = all_meshes + [(label, sp.datasets.make(name, n))
                                  for label, name, n in LARGE_SHAPES if n <= args.large_max]

    add("\n## Pole selection (cf. Table 7.4)\n")
    add("Seconds of the pole stage of `sp.embed(mesh, 'theta_phi', poles=...)` for each pole "
        "choice (thesis 6.2.1-6.2.3; for the symmetry method of 6.2.5 see "
        "`benches/symmetry_poles.py`).\n")
    add("| mesh | V | fast_graph s | physical s | graph s |")
    add("|---|---:|---:|---:|---:|")
    for label, mesh in timing_meshes:
        cells = [label, str(mesh.n_vertices)]
        for poles in ["fast_graph", "physical", "graph"]:
            if poles == "graph" and mesh.n_vertices > 5000:
                cells.append("(O(N^2 log N): skipped)")
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sp.SpherifyWarning)
                m = sp.embed(mesh, "theta_phi", poles=poles)
            cells.append(f"{m.seconds.get('poles', 0.0):.3f}")
        add("| " + " | ".join(cells) + " |")

    add("\n## theta-phi stages (cf. Table 7.5)\n")
    add("| mesh | V | poles s | cut s | embed s | fold s | tp_valid | refinements | thinnest triangle / rectangle | GC valid | flipped |")
    add("|---|---:|---:|---:|---:|---:|---|---:|---:|---|---:|")
    for label, mesh in timing_meshes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            m = sp.embed(mesh, "theta_phi")
        s = m.seconds
        add(f"| {label} | {mesh.n_vertices} | {s.get('poles', 0):.3f} | {s.get('cut', 0):.3f} | "
            f"{embed_seconds(s):.3f} | {s.get('fold', 0):.3f} | "
            f"{m.tp_valid} | {m.details['refinements']} | {m.details['min_area_ratio']:.2e} | "
            f"{m.valid} | {m.flipped} |")

    add("\n## Where double precision runs out (theta-phi)\n")
    add("Triangles of the theta-phi rectangle that are flipped or collapsed under exact predicates "
        "after double-double refinement (0 means `tp_valid`), on shapes with long thin parts, by "
        "size, pole choice and weights. Where the count is not 0 the exact embedding's coordinates "
        "differ by less than a double can represent: `tp_valid` is False and a `SpherifyWarning` "
        "says so.\n")
    add("| shape | V | fast_graph, uniform | physical, uniform | fast_graph, mean_value |")
    add("|---|---:|---:|---:|---:|")
    for name in ["helix_tube", "tentacles", "urchin"]:
        for size in [1000, 2000, 5000, 10000, 20000]:
            mesh = sp.datasets.make(name, size)
            cells = [name, str(mesh.n_vertices)]
            for poles, weights in [("fast_graph", "uniform"), ("physical", "uniform"),
                                   ("fast_graph", "mean_value")]:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", sp.SpherifyWarning)
                    m = sp.embed(mesh, "theta_phi", poles=poles, weights=weights)
                bad = len(m.details["tp_flipped_faces"]) + len(m.details["tp_degenerate_faces"])
                cells.append(str(bad))
            add("| " + " | ".join(cells) + " |")
            print(cells, flush=True)

    out = Path(args.out)
    temporary = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    temporary.write_text("\n".join(lines) + "\n")
    os.replace(temporary, out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
