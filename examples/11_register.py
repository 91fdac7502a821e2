"""Register two shapes through their sphere maps, with landmarks, and build a population.

    python examples/11_register.py [A] [--landmarks 8] [--out FOLDER]

B is a bent, turned and moved copy of A on another connectivity
(``sp.datasets.deformed_copy``), so the true correspondence is known and the
script can print how far each transform is from it. Then a population of
bent copies is put on one connectivity and its mean written to
FOLDER/mean.ply.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import spherify as sp



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("a", nargs="?")
    parser.add_argument("--landmarks", type=int, default=8)
    parser.add_argument("--out", default=".")
    args = parser.parse_args()
    a = sp.load(args.a) if args.a else sp.datasets.bumpy_blob(2000, bumps=5, amplitude=0.5, seed=1)

    m_a = sp.embed(a)
    copy = sp.datasets.deformed_copy(m_a, level=4, seed=2)
    m_b = sp.embed(copy.mesh)
    diagonal = np.linalg.norm(np.ptp(copy.mesh.vertices, axis=0))

    # Landmark pairs: A's vertices far apart, each with B's vertex nearest its true image.
    ids = sp.datasets.farthest_points(a.vertices, args.landmarks)
    corners = copy.mesh.faces[copy.truth_faces[ids]]
    on_b = corners[np.arange(len(ids)), np.argmax(copy.truth_bary[ids], axis=1)]
    pairs = np.stack([ids, on_b], axis=1)

    for transform, landmarks in [("rotation", None), ("moebius", None), ("warp", None),
                                 ("warp", pairs)]:
        c = sp.register(m_a, m_b, transform=transform, landmarks=landmarks)
        error = np.linalg.norm(c.a_on_b.positions - copy.truth, axis=1) / diagonal
        label = transform + (f" + {len(pairs)} landmarks" if landmarks is not None else "")
        print(f"{label:22s} error mean {100 * error.mean():.2f}%, 95th percentile "
              f"{100 * np.percentile(error, 95):.2f}% of the diagonal; A's map certified: "
              f"{c.map_a.valid}")

    maps = [m_a] + [sp.embed(sp.datasets.deformed_copy(m_a, level=4, bend=0.08, seed=s).mesh)
                    for s in range(4)]
    population = sp.correspond(maps, level=4, transform="rotation")
    variances, _ = population.modes(2)
    out = Path(args.out)
    sp.save(population.mean(), out / "mean.ply")
    print(f"population of {len(population)} on {population.points.shape[1]} points; variance "
          f"of the first two modes {variances[0]:.3g}, {variances[1]:.3g}; wrote {out / 'mean.ply'}")


if __name__ == "__main__":
    main()
