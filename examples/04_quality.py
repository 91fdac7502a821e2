"""How much each method distorts the same mesh: angles, areas and stretch.

    python examples/04_quality.py [MESH] [--out FOLDER]

Prints a table of sp.quality for the progressive map with each energy and for
theta-phi, and writes FOLDER/quality.png (the angle distortion per face).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--out", default=".")
    args = parser.parse_args()
    mesh = sp.load(args.mesh) if args.mesh else sp.datasets.make("bumpy_blob", 3000)

    runs = [("progressive", {"energy": energy})
            for energy in sp.method_options("progressive")["energy"]["choices"]]
    runs.append(("theta_phi", {}))
    print(f"{'map':28s} {'valid':>5s} {'angle (deg)':>11s} {'log-area std':>12s} {'stretch':>8s}")
    best = None
    for method, options in runs:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)  # a thin margin, reported below
            m = sp.embed(mesh, method, **options)
        q = sp.quality(m.mesh, m.points)
        name = f"{method} {options.get('energy', '')}".strip()
        print(f"{name:28s} {str(m.valid):>5s} {q['angle_mean_deg']:11.2f} "
              f"{q['area_log_std']:12.3f} {q['stretch_l2']:8.3f}")
        if best is None:
            best = m
    assert best is not None and best.valid
    sp.plot.sphere(best, color="angle", path=Path(args.out) / "quality.png")
    print(f"wrote {Path(args.out) / 'quality.png'}")


if __name__ == "__main__":
    main()
