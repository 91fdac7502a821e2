"""A mutation fuzzer for the readers that live in Python (docs/reliability.md,
"Fuzzing"): ``.npz`` meshes, GIfTI and FreeSurfer surfaces, sphere maps
(``sp.load_map``) and geometry images (``sp.load_geometry_image``).
``crates/mesh/examples/fuzz_readers.rs`` does the same for the core's OBJ,
OFF, PLY and STL readers.

Each input is a valid file written by spherify, mutated a few times (bytes
set, cut, inserted, swapped; a file cut short; a 32-bit field set to an
extreme; the first four bytes set to another format's magic; the shape in an
``.npy`` header changed). A finding is a read that raises anything other
than a ``SpherifyError``, leaves a file open (a ``ResourceWarning``), or
takes longer than ``--slow`` seconds. Findings are written to ``--out`` and
the exit status is 1 when there is any.

    python benches/fuzz_python_readers.py --inputs 20000 --seed 1
"""

from __future__ import annotations

import argparse
import gc
import random
import re
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Callable, Dict, List, Tuple

import numpy as np

import spherify as sp

#: Field values that break size and count checks.
EXTREMES = (0, 1, 2**31 - 1, 2**31, 2**31 + 5, 2**32 - 1)
#: The magic numbers of the formats read here and of a plain .npy array.
MAGICS = (b"\x93NUM", b"PK\x05\x06", b"PK\x03\x04", b"\x89PNG", b"\xff\xff\xfe\x00")
#: Shapes written into an .npy header in place of the real one.
SHAPES = (b"10000000000000, 3", b"-1, 3", b"3", b"60, 3, 2", b"", b"0, 3", b"4294967297, 3",
          b"99999999999999999999999,")
SHAPE_FIELD = re.compile(rb"'shape': \(([0-9, -]*)\)")


def seed_files(folder: Path) -> Dict[str, Tuple[bytes, Callable[[Path], object]]]:
    """Valid files of every Python-read format, with the call that reads each."""
    mesh = sp.datasets.make("bumpy_blob", 60)
    files: Dict[str, Callable[[Path], object]] = {"mesh.npz": sp.load}
    try:
        import nibabel  # noqa: F401
        files.update({"mesh.surf.gii": sp.load, "lh.pial": sp.load})
    except ImportError:
        print("nibabel missing: GIfTI and FreeSurfer are not fuzzed", file=sys.stderr)
    for name in files:
        sp.save(mesh, folder / name)
    sp.embed(mesh, "theta_phi").save(folder / "tp.spheremap.npz")
    sp.embed(mesh).save(folder / "pm.spheremap.npz")
    sp.save_geometry_image(np.random.default_rng(0).random((9, 9, 3)), folder / "image.png")
    files.update({"tp.spheremap.npz": sp.load_map, "pm.spheremap.npz": sp.load_map,
                  "image.png": sp.load_geometry_image})
    return {name: ((folder / name).read_bytes(), read) for name, read in files.items()}


def mutate(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        op = rng.random()
        if not b:
            b.extend(rng.randbytes(rng.randint(1, 16)))
        elif op < 0.35:
            b[rng.randrange(len(b))] = rng.randrange(256)
        elif op < 0.5:
            at = rng.randrange(len(b))
            del b[at:at + rng.randint(1, 64)]
        elif op < 0.65:
            at = rng.randrange(len(b) + 1)
            b[at:at] = rng.randbytes(rng.randint(1, 16))
        elif op < 0.72:
            del b[rng.randrange(len(b)):]
        elif op < 0.82 and len(b) >= 4:
            at = rng.randrange(len(b) - 3)
            b[at:at + 4] = rng.choice(EXTREMES).to_bytes(4, rng.choice(("little", "big")))
        elif op < 0.87:
            b[0:4] = rng.choice(MAGICS)
        elif op < 0.94:
            fields = list(SHAPE_FIELD.finditer(bytes(b)))
            if fields:
                field = rng.choice(fields)
                b[field.start(1):field.end(1)] = rng.choice(SHAPES)
        else:
            i, j = rng.randrange(len(b)), rng.randrange(len(b))
            b[i], b[j] = b[j], b[i]
    return bytes(b)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--inputs", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--slow", type=float, default=5.0, help="seconds that make a finding")
    parser.add_argument("--out", type=Path, default=Path("fuzz-python-findings"))
    args = parser.parse_args()
    rng = random.Random(args.seed)
    findings: List[str] = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        seeds = seed_files(folder)
        names = sorted(seeds)
        for k in range(args.inputs):
            name = rng.choice(names)
            data, read = seeds[name]
            path = folder / f"input-{name}"
            path.write_bytes(mutate(data, rng))
            began = time.perf_counter()
            problem = None
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    read(path)
                except sp.SpherifyError:
                    pass
                except Exception as err:  # the finding itself
                    problem = f"{type(err).__name__}: {err}"
                gc.collect(0)  # an unclosed file held in a cycle warns when collected
            leaks = [w for w in caught if issubclass(w.category, ResourceWarning)]
            if problem is None and leaks:
                problem = f"ResourceWarning: {leaks[0].message}"
            seconds = time.perf_counter() - began
            if problem is None and seconds > args.slow:
                problem = f"slow: {seconds:.1f} s"
            if problem is not None:
                args.out.mkdir(parents=True, exist_ok=True)
                kept = args.out / f"{len(findings):04d}-{name}"
                kept.write_bytes(path.read_bytes())
                findings.append(f"{kept}: input {k} of seed {args.seed}: {problem[:200]}")
                print(f"FINDING {findings[-1]}", flush=True)
    print(f"fuzz_python_readers: {args.inputs} inputs ({', '.join(names)}) from seed {args.seed} "
          f"in {time.perf_counter() - start:.1f} s: {len(findings)} findings")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
