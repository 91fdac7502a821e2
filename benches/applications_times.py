"""Times of the applications (thesis ch. 8) at 100k and 1M vertices, for the
table in docs/applications.md.

    python benches/applications_times.py [--sizes 100000 1000000]

Each size uses the bumpy blob of spherify.datasets; its map is theta-phi
(``method="theta_phi"``) where that is affordable, else the blob's own
geodesic sphere (a certified map made elsewhere, SphereMap.from_points), as
the table says. Prints one markdown row per size. Wall-clock seconds on
whatever machine runs it; the first to_surface of a map builds its point
locator, which is timed in the row's first column that needs it.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import spherify as sp


def blob_map(n: int, embed: bool) -> sp.SphereMap:
    mesh = sp.datasets.bumpy_blob(n)
    if embed:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sp.SpherifyWarning)
            return sp.embed(mesh, "theta_phi")
    # The blob is a geodesic sphere pushed along its normals: its own sphere
    # is a valid map.
    sphere = sp.datasets.make("icosphere", n)
    assert sphere.n_vertices == mesh.n_vertices
    return sp.SphereMap.from_points(mesh, sphere.vertices)


def timed(f):  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    out = f()
    return out, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", type=int, nargs="*", default=[100_000, 1_000_000])
    parser.add_argument("--embed-up-to", type=int, default=200_000,
                        help="use theta-phi maps up to this size, the blob's sphere above")
    args = parser.parse_args()
    print("| vertices | map | build locator | fit lmax 100 | to_mesh lmax 100 | remesh level 7 "
          "| geometry image 513 | texture cube | morph (two maps of this size) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        embed = n <= args.embed_up_to
        (m, t_map) = timed(lambda: blob_map(n, embed))
        _, t_locate = timed(lambda: m.to_surface(np.array([[0.0, 0.0, 1.0]])))
        c, t_fit = timed(lambda: sp.harmonics.fit(m, 100))
        _, t_eval = timed(lambda: c.to_mesh(m))
        _, t_remesh = timed(lambda: sp.remesh(m, level=7))
        _, t_image = timed(lambda: sp.geometry_image(m, 513))
        _, t_tex = timed(lambda: sp.texture.uv(m, "cube"))
        other = sp.SphereMap.from_points(
            sp.Mesh(m.mesh.vertices * np.array([1.3, 1.0, 0.8]), m.mesh.faces),
            m.points @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).T)
        other.to_surface(np.array([[0.0, 0.0, 1.0]]))
        mo, t_morph = timed(lambda: sp.morph(m, other))
        kind = f"theta-phi {t_map:.1f} s" if embed else f"from_points {t_map:.1f} s"
        print(f"| {m.mesh.n_vertices:,} | {kind} | {t_locate:.2f} | {t_fit:.2f} | {t_eval:.1f} | "
              f"{t_remesh:.2f} | {t_image:.2f} | {t_tex:.2f} | {t_morph:.2f} "
              f"(residual {mo.alignment['residual']:.1e}) |", flush=True)


if __name__ == "__main__":
    main()
