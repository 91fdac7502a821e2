"""Spherical harmonics of a surface through its map (thesis 8.3): smoothing.

    python examples/06_harmonics.py [MESH] [--lmax 32] [--out FOLDER]

Fits the surface's x, y and z as functions on the sphere up to degree lmax,
keeps the degrees up to lmax / 4, and writes the rebuilt surfaces
(FOLDER/harmonics_full.ply, FOLDER/harmonics_smooth.ply) and a picture
(FOLDER/harmonics.png). Prints the reconstruction error against the input.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--lmax", type=int, default=32)
    parser.add_argument("--out", default=".")
    args = parser.parse_args()
    out = Path(args.out)
    mesh = sp.load(args.mesh) if args.mesh else sp.datasets.make("bumpy_blob", 3000)

    m = sp.embed(mesh)
    c = sp.harmonics.fit(m, args.lmax)
    full = c.to_mesh(m)
    smooth = c.lowpass(args.lmax // 4).to_mesh(m)
    diagonal = np.linalg.norm(np.ptp(m.mesh.vertices, axis=0))
    for name, surface in [("full", full), ("smooth", smooth)]:
        error = np.linalg.norm(surface.vertices - m.mesh.vertices, axis=1)
        print(f"degree {args.lmax if name == 'full' else args.lmax // 4}: mean distance to the "
              f"input {error.mean() / diagonal:.2e}, largest {error.max() / diagonal:.2e} "
              "of the bounding-box diagonal")
        sp.save(surface, out / f"harmonics_{name}.ply")
    spectrum = c.spectrum()
    print("energy per degree (first 8):", np.array2string(spectrum[:8], precision=3))
    sp.plot.mesh(smooth, path=out / "harmonics.png")
    print(f"wrote {out / 'harmonics_full.ply'}, {out / 'harmonics_smooth.ply'} and "
          f"{out / 'harmonics.png'}")


if __name__ == "__main__":
    main()
