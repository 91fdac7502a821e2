"""Pictures of the theta-phi method for the docs (cf. thesis Fig. 6.3 and 6.11).

    python benches/pictures.py [--out docs]

For a few meshes: the mesh with its poles and cut path, and the cut mesh's
embedding in the theta-phi rectangle, with any triangle that is not certified
drawn in red, through ``spherify.plot``. Needs matplotlib (``pip install ".[bench,plot]"``).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import spherify as sp  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def draw_mesh(ax, mesh: sp.Mesh, m: sp.ThetaPhiMap, title: str) -> None:
    """The surface (sp.plot.mesh) with the poles and the cut path on it."""
    sp.plot.mesh(mesh, ax=ax, title=title)
    V = mesh.vertices
    path = V[m.cut_path]
    ax.plot(path[:, 0], path[:, 1], path[:, 2], color="tab:red", linewidth=2)
    for pole, colour in zip(m.poles, ["tab:blue", "tab:green"]):
        ax.scatter(*V[pole], color=colour, s=40)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    args = parser.parse_args()
    cases = [("helix_tube", sp.datasets.helix_tube(n_vertices=2000)),
             ("bumpy_blob", sp.datasets.bumpy_blob(n_vertices=2000)),
             ("tentacles", sp.datasets.tentacles(n_vertices=3000))]
    if (SHARED / "spot.obj").exists():
        cases.append(("spot", sp.load(SHARED / "spot.obj")))
    for name, mesh in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            m = sp.embed(mesh, "theta_phi")
        fig = plt.figure(figsize=(12, 6))
        draw_mesh(fig.add_subplot(1, 2, 1, projection="3d"), m.mesh, m,
                  f"{name}: poles and cut path ({len(m.cut_path)} vertices)")
        sp.plot.rectangle(m, ax=fig.add_subplot(1, 2, 2))
        target = Path(args.out) / f"theta_phi_{name}.png"
        fig.savefig(target, dpi=90, bbox_inches="tight")
        plt.close(fig)
        print(f"wrote {target}")


if __name__ == "__main__":
    main()
