"""Physical poles (thesis 6.2.1: the exact farthest pair in space) against
fast-graph poles, on generated shapes from 10k to 1M vertices.

    python benches/physical_poles.py [--max 1000000]

Prints a markdown table of the seconds of the pole stage
(``m.seconds["poles"]``) for ``poles="physical"`` and ``poles="fast_graph"``,
and the physical pair. Round shapes (icospheres, bumpy blobs) are where an
exact farthest-pair search has the least to prune. To compare two builds,
run it twice in one session, once with ``PYTHONPATH`` naming the other
build's site folder; the pairs must agree.
"""

from __future__ import annotations

import argparse
import warnings

import spherify as sp

SHAPES = [("icosphere", n) for n in (10_000, 40_000, 160_000, 1_000_000)] + [
    ("bumpy_blob", n) for n in (10_000, 100_000, 1_000_000)] + [
    ("ellipsoid", 100_000), ("helix_tube", 100_000), ("tentacles", 100_000)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=int, default=1_000_000, help="largest mesh")
    args = parser.parse_args()
    print("| shape | V | physical s | fast_graph s | physical pair |")
    print("|---|---:|---:|---:|---|")
    for name, n in SHAPES:
        if n > args.max:
            continue
        mesh = sp.datasets.make(name, n)
        seconds = {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            for poles in ("physical", "fast_graph"):
                m = sp.embed(mesh, "theta_phi", poles=poles)
                seconds[poles] = m.seconds.get("poles", 0.0)
                if poles == "physical":
                    pair = tuple(int(v) for v in m.poles)
        print(f"| {name} | {mesh.n_vertices} | {seconds['physical']:.4f} | "
              f"{seconds['fast_graph']:.4f} | {pair} |", flush=True)


if __name__ == "__main__":
    main()
