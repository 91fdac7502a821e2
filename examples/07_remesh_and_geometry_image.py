"""Remeshing through the sphere (thesis 8.1, 8.2): a semi-regular mesh and an
octahedral geometry image.

    python examples/07_remesh_and_geometry_image.py [MESH] [--level 4] [--size 65] [--out FOLDER]

Writes FOLDER/remeshed.ply (icosphere connectivity on the input surface),
FOLDER/geometry_image.png (16-bit) and FOLDER/from_image.ply, and prints how far
each lies from the input.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--level", type=int, default=4)
    parser.add_argument("--size", type=int, default=65)
    parser.add_argument("--out", default=".")
    args = parser.parse_args()
    out = Path(args.out)
    mesh = sp.load(args.mesh) if args.mesh else sp.datasets.make("bumpy_blob", 3000)

    m = sp.embed(mesh)
    remeshed = sp.remesh_map(m, level=args.level)      # with its own certified map
    distance = sp.surface_distance(m, remeshed)
    print(f"remeshed: {remeshed.mesh.n_vertices} vertices, distance to the input "
          f"rms {distance['rms']:.2e}, max {distance['max']:.2e} of the bounding-box diagonal")
    sp.save(remeshed.mesh, out / "remeshed.ply")

    image = sp.geometry_image(m, args.size)             # (size, size, 3) positions
    sp.save_geometry_image(image, out / "geometry_image.png")
    back = sp.from_geometry_image(sp.load_geometry_image(out / "geometry_image.png"))
    sp.save(back, out / "from_image.ply")
    print(f"geometry image {args.size} x {args.size}: a closed mesh of {back.n_vertices} "
          "vertices")
    print(f"wrote {out / 'remeshed.ply'}, {out / 'geometry_image.png'} and "
          f"{out / 'from_image.ply'}")


if __name__ == "__main__":
    main()
