"""How the map's quality reaches the applications (issue 22, item 5).

    python benches/applications_quality.py [--meshes hand spot armadillo] [--out FILE.md]

For each corpus mesh (``../shared/meshes`` or ``$SPHERIFY_SHARED_MESHES``)
and each map (the progressive method with every energy, and theta-phi), two
errors relative to the mesh's bounding-box diagonal:

* harmonics: the degree-L surface of ``sp.harmonics.fit(m, L)`` evaluated at
  the vertices' sphere points, against the vertices (mean and max distance),
  for L = 16, 32, 64, 128;
* remeshing: ``sp.remesh_map(m, level=l)`` against the map's own surface by
  ``sp.surface_distance`` (rms and max over 100,000 random sphere points and
  both meshes' vertices), for icosphere levels 4, 5, 6.

A map that is not certified is reported and skipped. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import List

import numpy as np

import spherify as sp

ROOT = Path(os.environ.get("SPHERIFY_SHARED_MESHES",
                           Path(__file__).resolve().parents[2] / "shared" / "meshes"))
MAPS = ["isometric", "balanced", "stretch", "conformal", "authalic", "theta_phi"]
DEGREES = [16, 32, 64, 128]
LEVELS = [4, 5, 6]


def find_mesh(name: str) -> Path:
    for path in sorted(ROOT.glob(f"{name}.*")):
        return path
    raise SystemExit(f"no mesh named {name!r} in {ROOT}")


def make_map(mesh: sp.Mesh, name: str) -> sp.SphereMap:
    if name == "theta_phi":
        return sp.embed(mesh, method="theta_phi")
    return sp.embed(mesh, method="progressive", energy=name)


def row(mesh_name: str, mesh: sp.Mesh, name: str) -> str:
    t = time.perf_counter()
    m = make_map(mesh, name)
    seconds = time.perf_counter() - t
    certified = m.tp_valid if name == "theta_phi" else m.valid
    if not certified:
        return f"| {mesh_name} | {name} | not certified | " + " | ".join(["-"] * 7) + " |"
    vertices = m.mesh.vertices
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    cells: List[str] = []
    for degree in DEGREES:
        surface = sp.harmonics.fit(m, degree).evaluate(m.points)
        error = np.linalg.norm(surface - vertices, axis=1) / diagonal
        cells.append(f"{error.mean():.2e} / {error.max():.2e}")
    for level in LEVELS:
        d = sp.surface_distance(m, sp.remesh_map(m, level=level))
        cells.append(f"{d['rms']:.2e} / {d['max']:.2e}")
    return f"| {mesh_name} | {name} ({seconds:.1f} s) | " + " | ".join(cells) + " |"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["hand", "spot", "armadillo"])
    parser.add_argument("--maps", nargs="+", default=MAPS, choices=MAPS)
    args = parser.parse_args()
    header = ("| mesh | map (time) | " + " | ".join(f"harmonics L={d} mean / max" for d in DEGREES)
              + " | " + " | ".join(f"remesh level {l} rms / max" for l in LEVELS) + " |")
    print(header)
    print("|" + "---|" * (2 + len(DEGREES) + len(LEVELS)))
    for mesh_name in args.meshes:
        mesh = sp.load(find_mesh(mesh_name))
        for name in args.maps:
            print(row(mesh_name, mesh, name), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
