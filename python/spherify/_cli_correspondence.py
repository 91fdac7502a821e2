"""The correspondence subcommands of the ``spherify`` command line.

    spherify register A B -o OUT.npz [--transform warp] [--landmarks I:J ...]
                                   where every vertex of A lands on B; writes
                                   OUT.npz (see ``register_arrays``)
    spherify correspond MESH MESH ... -o FOLDER [--level 6] [--reference 0]
                                   registers every mesh to the reference and
                                   resamples all on one connectivity; writes
                                   FOLDER/shape_000.ply ..., FOLDER/mean.ply and
                                   FOLDER/population.npz (points, faces, modes)

Both map each mesh first with ``spherify map``'s method flags and refuse, with
exit status 1, a map that is not a certified bijection.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

from ._cli_apps import certified, mapped, output_path
from ._cli_options import add_input_flags, add_method_flags, add_progress_flag, shows_progress
from ._errors import SpherifyError
from ._mesh import Mesh, save
from ._population import correspond
from ._register import TRANSFORMS, Correspondence, register


def parse_pairs(words: Optional[List[str]]) -> Optional[List[Tuple[int, int]]]:
    """``I:J`` words as (I, J) pairs; None when there are none."""
    if not words:
        return None
    try:
        split = [word.split(":") for word in words]
        return [(int(i), int(j)) for i, j in split]
    except ValueError:
        raise SpherifyError(f"landmarks must be I:J vertex pairs, got {' '.join(words)}") from None


def register_arrays(c: Correspondence) -> Dict[str, Any]:
    """What ``spherify register`` writes: ``a_on_b_faces``, ``a_on_b_bary``,
    ``a_on_b_positions`` (per vertex of A: face of B, weights, point),
    ``map_a_points`` (A's certified map in B's frame), ``rotation``,
    ``boost`` (zeros without a Möbius fit), ``landmarks`` (k, 2),
    ``residual_rms``, ``residual_max`` and ``transform``."""
    moebius = c.moebius
    return {
        "a_on_b_faces": c.a_on_b.faces, "a_on_b_bary": c.a_on_b.bary,
        "a_on_b_positions": c.a_on_b.positions, "map_a_points": c.map_a.points,
        "rotation": c.rotation,
        "boost": np.zeros(3) if moebius is None else moebius["boost"],
        "landmarks": c.landmarks, "residual_rms": np.float64(c.residual["rms"]),
        "residual_max": np.float64(c.residual["max"]), "transform": np.str_(c.transform),
    }


def _cmd_register(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh],
                  save_npz: Callable[..., None]) -> int:
    out = output_path(args)
    if out.suffix.lower() != ".npz":
        raise SpherifyError(f"register writes a .npz: give OUT.npz, got {out}")
    if not args.target:
        raise SpherifyError("give the second mesh file (B)")
    pairs = parse_pairs(args.landmarks)
    a = load(args)
    b = load(argparse.Namespace(dataset=None, mesh=args.target, n_vertices=0, weld=args.weld))
    m_a, m_b = mapped(a, args), mapped(b, args)
    if not (certified(m_a) and certified(m_b)):
        print("refusing: a map is not a certified bijection")
        return 1
    start = time.perf_counter()
    c = register(m_a, m_b, landmarks=pairs, transform=args.transform,
                 progress=True if shows_progress(args) else None)
    took = time.perf_counter() - start
    landmark = ""
    if c.landmark_error is not None:
        landmark = (f"; landmarks: largest angle {c.landmark_error['max_angle']:.2g} rad, "
                    f"distance {c.landmark_error['max_distance']:.2g} of B's diagonal")
    print(f"register: {c.transform}, A's map {'certified' if c.map_a.valid else 'NOT certified'}; "
          f"residual rms {c.residual['rms']:.4g}, max {c.residual['max']:.4g} of B's "
          f"diagonal{landmark}; {took:.3f} s")
    save_npz(out, **register_arrays(c))
    print(f"wrote {out}")
    return 0 if c.map_a.valid else 1


def _cmd_correspond(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh],
                    save_npz: Callable[..., None]) -> int:
    folder = Path(args.output)
    if not folder.is_dir():
        raise SpherifyError(f"-o {folder}: the output folder does not exist")
    if len(args.meshes) < 2:
        raise SpherifyError(f"correspond needs at least two meshes, got {len(args.meshes)}")
    level: Any = "reference" if args.level == "reference" else _level(args.level)
    maps = []
    for path in args.meshes:
        mesh = load(argparse.Namespace(dataset=None, mesh=path, n_vertices=0, weld=args.weld))
        m = mapped(mesh, args)
        if not certified(m):
            print(f"refusing: the map of {path} is not a certified bijection")
            return 1
        maps.append(m)
    start = time.perf_counter()
    population = correspond(maps, reference=args.reference, level=level,
                            transform=args.transform,
                            progress=True if shows_progress(args) else None)
    took = time.perf_counter() - start
    worst = max(r["rms"] for r in population.residuals)
    print(f"correspond: {len(population)} shapes on {population.points.shape[1]} points, "
          f"largest residual rms {worst:.4g} of the reference's diagonal; {took:.3f} s")
    width = max(3, len(str(len(population) - 1)))
    for i in range(len(population)):
        save(population.shape(i), folder / f"shape_{i:0{width}d}.ply")
    save(population.mean(), folder / "mean.ply")
    k = min(5, len(population) - 1)
    variances, modes = population.modes(k)
    save_npz(folder / "population.npz", points=population.points, faces=population.faces,
             scales=population.scales, variances=variances, modes=modes,
             inputs=np.array([str(p) for p in args.meshes]))
    print(f"wrote {len(population)} shapes, mean.ply and population.npz in {folder}")
    return 0


def _level(word: str) -> int:
    try:
        return int(word)
    except ValueError:
        raise SpherifyError(f"--level must be an icosphere level or 'reference', got {word}") \
            from None


def add_commands(sub: Any, load: Callable[[argparse.Namespace], Mesh],
                 save_npz: Callable[..., None]) -> None:
    """Registers ``register`` and ``correspond`` on ``sub``."""
    text = "where every vertex of A lands on B, through their certified sphere maps"
    p: argparse.ArgumentParser = sub.add_parser("register", help=text, description=text)
    add_input_flags(p, "mesh file A")
    p.add_argument("target", nargs="?", help="mesh file B")
    add_method_flags(p)
    add_progress_flag(p)
    p.add_argument("-o", "--output", required=True, help="output .npz")
    p.add_argument("--transform", default="warp", choices=list(TRANSFORMS),
                   help="rotation, Moebius transformation, or a flip-free warp that also makes "
                        "--landmarks meet exactly (default: warp)")
    p.add_argument("--landmarks", nargs="*", metavar="I:J",
                   help="vertex I of A corresponds to vertex J of B")
    p.set_defaults(func=lambda args: _cmd_register(args, load, save_npz))

    text = "register shapes to one and resample all on one connectivity (a population)"
    p = sub.add_parser("correspond", help=text, description=text)
    p.add_argument("meshes", nargs="+", help="mesh files")
    p.add_argument("--weld", action="store_true",
                   help="first merge vertices at exactly the same position")
    add_method_flags(p)
    add_progress_flag(p)
    p.add_argument("-o", "--output", required=True, help="output folder (must exist)")
    p.add_argument("--reference", type=int, default=0,
                   help="index of the shape the others are registered to (default: 0)")
    p.add_argument("--level", default="6",
                   help="common connectivity: an icosphere level or 'reference' (default: 6)")
    p.add_argument("--transform", default="warp", choices=list(TRANSFORMS),
                   help="how each shape is registered (default: warp)")
    p.set_defaults(func=lambda args: _cmd_correspond(args, load, save_npz))
