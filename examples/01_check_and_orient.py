"""Check a mesh, repair its orientation, and save it.

    python examples/01_check_and_orient.py [MESH] [--out OUT.ply]

Without MESH it uses a generated shape with a few faces turned the wrong way.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()

    if args.mesh:
        mesh = sp.load(args.mesh)
    else:
        # A helix tube (not star-shaped) with every 7th face reversed.
        tube = sp.datasets.helix_tube(n_vertices=3000)
        F = tube.faces.copy()
        F[::7] = F[::7, ::-1]
        mesh = sp.Mesh(tube.vertices, F)

    report = sp.check(mesh)
    print(report)
    if not report.is_sphere_topology:
        raise SystemExit("not a genus-0 surface: orientation cannot fix that")

    fixed, info = sp.orient(mesh, return_info=True)
    print(f"reversed {info['flipped_faces']} faces")
    after = sp.check(fixed)
    assert after.valid, after.problems
    print(after)

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp()) / "oriented.ply"
    sp.save(fixed, out)
    reloaded = sp.load(out)
    assert np.array_equal(reloaded.faces, fixed.faces)
    print(f"saved {out}")


if __name__ == "__main__":
    main()
