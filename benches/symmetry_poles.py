"""The symmetry method for poles (thesis 6.2.5) on generated shapes and the corpus.

    python benches/symmetry_poles.py [--corpus-max 60000]

Prints a markdown table: the chosen principal plane (its normal and score),
the near-plane band and its largest connected piece, whether it fell back to
fast-graph poles and why, the cut path's length, whether the theta-phi
rectangle was certified, and the seconds of the pole stage next to those of
``poles="fast_graph"`` (best of three runs each).
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path
from typing import Iterator, Tuple

import spherify as sp

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"

SHAPES = [("icosphere", 2000), ("ellipsoid", 2000), ("bumpy_blob", 2000),
          ("helix_tube", 2000), ("urchin", 3000), ("tentacles", 2000)]


def meshes(corpus_max: int) -> Iterator[Tuple[str, sp.Mesh]]:
    for name, n in SHAPES:
        yield f"{name}-{n}", sp.datasets.make(name, n)
    manifest = SHARED / "MANIFEST.json"
    if not manifest.exists():
        return
    for entry in json.loads(manifest.read_text()):
        if isinstance(entry.get("genus"), int) and entry["genus"] == 0 and entry["V"] <= corpus_max:
            yield entry["name"], sp.load(SHARED / entry["path"])


def pole_seconds(mesh: sp.Mesh, **options: object) -> Tuple[float, sp.SphereMap]:
    best, result = float("inf"), None
    for _ in range(3):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            m = sp.embed(mesh, "theta_phi", **options)
        best, result = min(best, m.seconds["poles"]), m
    assert result is not None
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--corpus-max", type=int, default=60000)
    args = parser.parse_args()
    print("| mesh | V | plane normal | score | band | piece | fell back | path | tp_valid "
          "| symmetry s | fast_graph s |")
    print("|---|---:|---|---:|---:|---:|---|---:|---|---:|---:|")
    for name, mesh in meshes(args.corpus_max):
        mesh = sp.orient(mesh)
        sym_s, m = pole_seconds(mesh, poles="symmetry")
        fast_s, _ = pole_seconds(mesh, poles="fast_graph")
        s = m.details["symmetry"]
        normal = "(" + ", ".join(f"{x:+.2f}" for x in s["normal"]) + ")" if s["normal"] else "-"
        reason = s["fallback"] or "no"
        if "no convincing" in reason:
            reason = "yes: score"
        elif "too few" in reason:
            reason = "yes: band too small"
        elif "too close" in reason:
            reason = f"yes: poles too close (spread {s['spread']:.3f})"
        score = f"{s['score']:.4f}" if s["score"] is not None else "-"
        print(f"| {name} | {mesh.n_vertices} | {normal} | {score} | {s['band']} | "
              f"{s['component']} | {reason} | {len(m.cut_path)} | {m.tp_valid} | "
              f"{sym_s:.4f} | {fast_s:.4f} |", flush=True)


if __name__ == "__main__":
    main()
