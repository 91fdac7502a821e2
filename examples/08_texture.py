"""Texture mapping through the sphere (thesis 8.5): per-corner UVs, a baked
texture, an OBJ with its MTL and PNG, and the same as one glTF file.

    python examples/08_texture.py [MESH] [--projection cube] [--size 256] [--out FOLDER]

Writes FOLDER/textured.obj, .mtl and .png, FOLDER/textured.glb (mesh, normals,
UVs, the sphere points and the texture in one file, for Blender or a web
viewer), and a picture of the checkerboard on the surface
(FOLDER/texture_preview.png).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--projection", default="cube", choices=list(sp.texture.PROJECTIONS))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--out", default=".")
    args = parser.parse_args()
    out = Path(args.out)
    mesh = sp.load(args.mesh) if args.mesh else sp.datasets.make("bumpy_blob", 3000)

    m = sp.embed(mesh)
    layout = sp.texture.uv(m, projection=args.projection)   # (F, 3, 2) UVs per corner
    image = layout.bake(sp.datasets.checkerboard, args.size)
    sp.save(m.mesh, out / "textured.obj", uv=layout, texture=image)
    sp.save(m.mesh, out / "textured.glb", uv=layout, texture=image, sphere=m.points)
    # The colour of each face's centre in the texture, drawn on the surface.
    centres = layout.uv.mean(axis=1)
    rows = ((1 - centres[:, 1]) * (image.shape[0] - 1)).round().astype(int)
    cols = (centres[:, 0] * (image.shape[1] - 1)).round().astype(int)
    colours = image[rows, cols, :3]  # RGB in [0, 1]
    sp.plot.mesh(m.mesh, colors=colours, path=out / "texture_preview.png")
    print(f"{args.projection} atlas {image.shape[1]} x {image.shape[0]}; wrote "
          f"{out / 'textured.obj'} (+ .mtl, .png), {out / 'textured.glb'} and "
          f"{out / 'texture_preview.png'}")


if __name__ == "__main__":
    main()
