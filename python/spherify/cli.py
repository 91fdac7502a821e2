"""The ``spherify`` command line.

    spherify check MESH            load, validate, orient and print the report
    spherify check --dataset NAME  the same on a built-in generated shape
    spherify orient MESH -o OUT    write a consistently, outward-oriented copy

Exit status: 0 for a valid genus-0 mesh, 1 when the mesh has problems that
orientation cannot repair, 2 for unreadable input or bad arguments.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import List, Optional

from . import datasets
from ._errors import SpherifyError, TopologyError
from ._mesh import Mesh, check, load, orient, save


def _load(args: argparse.Namespace) -> Mesh:
    if args.dataset:
        return datasets.make(args.dataset, args.n_vertices)
    if not args.mesh:
        raise SpherifyError("give a mesh file or --dataset NAME")
    return load(args.mesh)


def _cmd_check(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    mesh = _load(args)
    loaded = time.perf_counter()
    report = check(mesh)
    checked = time.perf_counter()
    source = args.mesh or f"dataset {args.dataset!r} ({args.n_vertices} vertices requested)"
    print(f"{source}: {mesh.n_vertices} vertices, {mesh.n_faces} faces")
    print(report)
    status = 0 if report.valid else 1
    if report.is_sphere_topology and not report.valid:
        try:
            fixed, info = orient(mesh, return_info=True)
        except TopologyError as err:
            print(f"orient: {err}")
            return 1
        after = check(fixed)
        print(f"orient: reversed {info['flipped_faces']} faces "
              f"({info['components_turned_outward']} components turned outward)")
        print(after)
        status = 0 if after.valid else 1
    done = time.perf_counter()
    print(f"seconds: load {loaded - start:.3f}, check {checked - loaded:.3f}, "
          f"orient+recheck {done - checked:.3f}")
    return status


def _cmd_orient(args: argparse.Namespace) -> int:
    mesh = _load(args)
    fixed, info = orient(mesh, return_info=True)
    save(fixed, args.output)
    print(f"reversed {info['flipped_faces']} faces; wrote {args.output}")
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="spherify", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, func, text in [("check", _cmd_check, "validate a mesh, orient it, print the report"),
                             ("orient", _cmd_orient, "write a consistently outward-oriented copy")]:
        p = sub.add_parser(name, help=text)
        p.add_argument("mesh", nargs="?", help="mesh file (.obj .off .ply .stl)")
        p.add_argument("--dataset", choices=datasets.names(), help="use a generated shape instead")
        p.add_argument("--n-vertices", type=int, default=5000, help="size of the generated shape")
        if name == "orient":
            p.add_argument("-o", "--output", required=True, help="output mesh file")
        p.set_defaults(func=func)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except (SpherifyError, OSError) as err:
        print(f"spherify: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
