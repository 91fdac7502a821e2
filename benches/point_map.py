"""Time SphereMap.to_sphere / to_surface (the map h of thesis 6.6 and its
inverse) on many points, and report the round-trip errors.

    python benches/point_map.py [--points 1000000] [--vertices 200000]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--vertices", type=int, default=200_000)
    parser.add_argument("--shapes", default="bumpy_blob,helix_tube")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(f"load average {os.getloadavg()[0]:.1f}; {args.points} points per run")
    print("| shape | V | build s | to_sphere s | to_surface s | surface round trip (of size) | sphere round trip |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for shape in args.shapes.split(","):
        mesh = sp.datasets.make(shape, args.vertices)
        m = sp.embed(mesh, "theta_phi")
        V, F = mesh.vertices, mesh.faces
        faces = rng.integers(0, len(F), args.points)
        bary = rng.dirichlet([1, 1, 1], args.points)
        t = time.perf_counter()
        m.to_sphere(faces[:1], bary[:1])  # builds the point-location tree
        build = time.perf_counter() - t
        t = time.perf_counter()
        points = m.to_sphere(faces, bary)
        forward = time.perf_counter() - t
        t = time.perf_counter()
        f2, b2, xyz = m.to_surface(points)
        backward = time.perf_counter() - t
        want = np.einsum("kj,kjd->kd", bary, V[F[faces]])
        surface_err = np.abs(xyz - want).max() / np.ptp(V, axis=0).max()
        q = rng.normal(size=(args.points, 3))
        q /= np.linalg.norm(q, axis=1)[:, None]
        f3, b3, _ = m.to_surface(q)
        sphere_err = np.abs(m.to_sphere(f3, b3) - q).max()
        print(f"| {shape} | {mesh.n_vertices} | {build:.2f} | {forward:.2f} | {backward:.2f} "
              f"| {surface_err:.1e} | {sphere_err:.1e} |")


if __name__ == "__main__":
    main()
