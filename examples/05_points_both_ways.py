"""Points between the surface and the sphere, both ways (thesis 3.3, 6.6).

    python examples/05_points_both_ways.py [MESH]

Takes random points on the surface (a face and barycentric coordinates), sends
them to the sphere with ``to_sphere`` and back with ``to_surface``, and prints
the largest round-trip error. Works for any certified map; for theta-phi the
map is the thesis's h.
"""

from __future__ import annotations

import argparse

import numpy as np

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mesh", nargs="?")
    parser.add_argument("--points", type=int, default=10_000)
    args = parser.parse_args()
    mesh = sp.load(args.mesh) if args.mesh else sp.datasets.make("helix_tube", 3000)
    rng = np.random.default_rng(0)

    for method in ["progressive", "theta_phi"]:
        m = sp.embed(mesh, method)
        bijective = m.tp_valid if isinstance(m, sp.ThetaPhiMap) else m.valid
        if not bijective:
            print(f"{method}: not a certified bijection here, skipped")
            continue
        faces = rng.integers(0, m.mesh.n_faces, args.points)
        bary = rng.dirichlet([1.0, 1.0, 1.0], args.points)
        on_sphere = m.to_sphere(faces, bary)
        back_faces, back_bary, xyz = m.to_surface(on_sphere)
        corners = m.mesh.vertices[m.mesh.faces[faces]]
        want = np.einsum("ij,ijk->ik", bary, corners)
        error = np.linalg.norm(xyz - want, axis=1).max()
        diagonal = np.linalg.norm(np.ptp(m.mesh.vertices, axis=0))
        print(f"{method}: {args.points} points there and back, largest error "
              f"{error / diagonal:.1e} of the bounding-box diagonal")
        assert error <= 1e-9 * diagonal


if __name__ == "__main__":
    main()
