"""Pictures for the docs (cf. thesis Fig. 6.3 and 6.11).

    python benches/pictures.py [--out docs]

For a few meshes: the mesh with its poles and cut path, and the cut mesh's
embedding in the theta-phi rectangle, with any triangle that is not certified
drawn in red, through ``spherify.plot``. And README's picture
(``limbs_progressive_vs_theta_phi.png``): a limbed shape, its progressive
map and its theta-phi map side by side. Needs matplotlib
(``pip install ".[bench,plot]"``).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib
import numpy as np

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


def limbs_picture(out: Path) -> None:
    """A shape with long limbs, its progressive map coloured by the log area
    ratio, and its theta-phi map with the faces that fail the exact
    orientation test (thesis 3.4) in red: why the progressive map is the
    default (README)."""
    mesh = sp.datasets.tentacles(n_vertices=4000)
    progressive = sp.embed(mesh)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        theta_phi = sp.embed(mesh, "theta_phi")
    area = sp.face_quality(progressive.mesh, progressive.points)["area_log"]
    bound = float(np.percentile(np.abs(area), 99))
    flipped = np.tile([0.75, 0.75, 0.75], (theta_phi.mesh.n_faces, 1))
    flipped[theta_phi.report.flipped_faces] = [0.85, 0.1, 0.1]
    fig = plt.figure(figsize=(15, 5))
    panels = [(progressive.mesh, None, f"tentacles, {mesh.n_vertices} vertices"),
              (sp.Mesh(progressive.points, progressive.mesh.faces), area,
               f"progressive: {'valid' if progressive.valid else 'NOT valid'}, "
               f"{progressive.flipped} flipped; colour: log area ratio"),
              (sp.Mesh(theta_phi.points, theta_phi.mesh.faces), flipped,
               f"theta-phi: {'valid' if theta_phi.valid else 'NOT valid'}, "
               f"{theta_phi.flipped} flipped (red)")]
    for k, (surface, values, title) in enumerate(panels):
        ax = fig.add_subplot(1, 3, k + 1, projection="3d")
        if k == 2:
            sp.plot.mesh(surface, ax=ax, colors=values, title=title)
        else:
            sp.plot.mesh(surface, ax=ax, values=values, cmap="coolwarm",
                         limits=None if values is None else (-bound, bound), title=title)
    target = out / "limbs_progressive_vs_theta_phi.png"
    fig.savefig(target, dpi=80, bbox_inches="tight")
    plt.close(fig)
    print(f"wrote {target}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    args = parser.parse_args()
    limbs_picture(Path(args.out))
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
