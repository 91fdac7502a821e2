"""Map a folder of meshes in parallel and resumably (sp.batch).

    python examples/10_batch.py [FOLDER] [--out OUT] [--workers 2]

Without FOLDER it writes a few generated shapes into OUT/inputs first. Each
mesh gets a sphere mesh and a .spheremap.npz in OUT/spheres, with a row in
OUT/spheres/journal.jsonl and OUT/spheres/summary.csv; a second run skips what
is done.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import spherify as sp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("folder", nargs="?")
    parser.add_argument("--out", default=".")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    out = Path(args.out)
    if args.folder:
        inputs = Path(args.folder)
    else:
        inputs = out / "inputs"
        inputs.mkdir(parents=True, exist_ok=True)
        for name in ["ellipsoid", "bumpy_blob", "helix_tube", "tentacles"]:
            sp.save(sp.datasets.make(name, 1500), inputs / f"{name}.ply")

    result = sp.batch(inputs, out / "spheres", workers=args.workers)
    print(result.counts)
    for row in result.rows:
        print(f"  {Path(row['input']).name}: {row['status']}, certified {row['certified']}")
    again = sp.batch(inputs, out / "spheres", workers=args.workers)
    print(f"a second run skips {again.skipped} of {len(again.rows)} (already done)")
    first = next(r for r in result.rows if r["status"] == "done")
    m = sp.load_map(first["spheremap"])                  # read back, certified again
    print(f"{Path(first['spheremap']).name}: {m.method}, valid {m.valid}")


if __name__ == "__main__":
    main()
