"""Flatten a disk with Tutte's method and prove the result has no flipped triangle.

    python examples/02_tutte_disk.py [--picture disk.png]

The disk is a generated bumpy blob with its top cap cut away. Every weight type
is tried; the exact orientation check of every triangle is in ``info``.
"""

from __future__ import annotations

import argparse

import numpy as np

import spherify as sp


def capped_disk(n_vertices: int) -> sp.Mesh:
    blob = sp.datasets.bumpy_blob(n_vertices=n_vertices)
    V, F = blob.vertices, blob.faces
    keep = V[F].mean(axis=1)[:, 2] < 0.6
    used = np.unique(F[keep])
    remap = np.full(len(V), -1)
    remap[used] = np.arange(len(used))
    return sp.Mesh(V[used], remap[F[keep]])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--picture", default=None, help="save a PNG of the embedding")
    args = parser.parse_args()

    disk = capped_disk(5000)
    print(f"disk: {disk.n_vertices} vertices, boundary of {len(sp.boundary_loop(disk))}")
    for weights in ["uniform", "chord", "mean_value"]:
        uv, info = sp.tutte(disk, weights=weights, rho=-1.0, return_info=True)
        print(f"{weights:>10}: solver {info.solver}, residual {info.residual:.1e}, "
              f"flipped {len(info.flipped_faces)}, degenerate {len(info.degenerate_faces)}")
        assert info.valid

    if args.picture:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        uv = sp.tutte(disk, weights="mean_value")
        fig, ax = plt.subplots(figsize=(6, 6))
        ax.triplot(uv[:, 0], uv[:, 1], disk.faces, linewidth=0.2, color="k")
        ax.set_aspect("equal")
        ax.set_axis_off()
        fig.savefig(args.picture, dpi=120, bbox_inches="tight")
        print(f"saved {args.picture}")


if __name__ == "__main__":
    main()
