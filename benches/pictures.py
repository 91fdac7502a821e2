"""Pictures of the theta-phi method for the docs (cf. thesis Fig. 6.3 and 6.11).

    python benches/pictures.py [--out docs]

For a few meshes: the mesh with its poles and cut path, and the cut mesh's
embedding in the theta-phi rectangle, with any triangle that is not certified
drawn in red. Needs matplotlib (``pip install ".[bench]" matplotlib``).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import spherify as sp  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def draw_mesh(ax, mesh: sp.Mesh, m: sp.SphereMap, title: str) -> None:
    V, F = mesh.vertices, mesh.faces
    tri = V[F]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None] + 1e-300
    shade = 0.35 + 0.65 * np.clip(normal @ np.array([0.3, 0.4, 0.85]), 0, 1)
    ax.add_collection3d(Poly3DCollection(tri, facecolors=plt.cm.Greys(0.3 + 0.5 * shade),
                                         edgecolor="none", alpha=0.9))
    path = V[m.cut_path]
    ax.plot(path[:, 0], path[:, 1], path[:, 2], color="tab:red", linewidth=2)
    for pole, colour in zip(m.poles, ["tab:blue", "tab:green"]):
        ax.scatter(*V[pole], color=colour, s=40)
    lo, hi = V.min(0), V.max(0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_axis_off()
    ax.set_title(title)


def draw_rectangle(ax, m: sp.SphereMap) -> None:
    tp = m.theta_phi
    faces = m.cut_mesh.faces
    ax.triplot(tp[:, 0], tp[:, 1], faces, linewidth=0.15, color="k")
    bad = np.concatenate([m.details["tp_flipped_faces"], m.details["tp_degenerate_faces"]])
    if len(bad):
        ax.triplot(tp[:, 0], tp[:, 1], faces[bad], linewidth=0.4, color="tab:red")
    ax.set_xlim(0, np.pi)
    ax.set_ylim(0, 2 * np.pi)
    ax.set_xlabel("theta")
    ax.set_ylabel("phi")
    ax.set_aspect("equal")
    verdict = "certified flip-free" if m.tp_valid else f"{len(bad)} triangles not certified"
    ax.set_title(f"theta-phi rectangle: {verdict}")


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
            m = sp.embed(mesh)
        fig = plt.figure(figsize=(12, 6))
        draw_mesh(fig.add_subplot(1, 2, 1, projection="3d"), m.mesh, m,
                  f"{name}: poles and cut path ({len(m.cut_path)} vertices)")
        draw_rectangle(fig.add_subplot(1, 2, 2), m)
        target = Path(args.out) / f"theta_phi_{name}.png"
        fig.savefig(target, dpi=90, bbox_inches="tight")
        plt.close(fig)
        print(f"wrote {target}")


if __name__ == "__main__":
    main()
