"""What every command of the ``spherify`` command line shares: the input
(a mesh file or a generated shape), the method and a flag for each of its
options (from the core's one table, ``sp.method_options``), the progress bar,
and the error for bad arguments. ``map``, ``batch`` and the application
commands (harmonics, remesh, texture, morph) all take them from here."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Dict, List, Tuple

from . import _core, datasets
from ._embed import listed, method_options, methods, methods_taking
from ._errors import MeshError, SpherifyError
from .datasets._checks import making_bytes, mesh_bytes

#: Sizes of generated shapes the command line accepts (mapping a 10^7-vertex
#: shape takes some 8 GB with the default method and more with most others;
#: check_memory_first refuses what cannot fit before the shape is made).
N_VERTICES = (4, 10_000_000)

class UsageError(SpherifyError):
    """Bad arguments, found before any work is done (exit status 2)."""


def n_vertices(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    low, high = N_VERTICES
    if not low <= n <= high:
        raise argparse.ArgumentTypeError(f"{n} is outside the supported range {low} to {high:,}")
    return n


def add_input_flags(p: argparse.ArgumentParser, what: str = "mesh file") -> None:
    """MESH, or --dataset NAME with --n-vertices N; --weld."""
    p.add_argument("mesh", nargs="?", help=f"{what} (.obj .off .ply .stl .npz, a FreeSurfer "
                   "surface such as lh.pial, .gii)")
    p.add_argument("--dataset", choices=datasets.names(), help="use a generated shape instead")
    p.add_argument("--n-vertices", type=n_vertices, default=5000,
                   help=f"size of the generated shape ({N_VERTICES[0]} to {N_VERTICES[1]:,}; "
                        "default: 5000)")
    p.add_argument("--weld", action="store_true",
                   help="first merge vertices at exactly the same position (a seam the "
                        "exporter split; the report of such an open mesh suggests it)")


def check_memory_first(args: argparse.Namespace, method: str, options: Dict[str, Any],
                       landmarks: bool = False) -> None:
    """For a generated shape, a map that cannot fit in memory is refused
    before the shape is made (ResourceError, exit status 1): making 10^7
    vertices takes seconds and gigabytes of its own. The need is the larger
    of making the shape and holding it while ``embed`` runs, whose estimate
    is the core's (``crates/sphere/src/memory_budget.rs``); the check is
    the core's too."""
    if not args.dataset or args.mesh:
        return
    n = args.n_vertices
    try:
        embedding = _core.embed_need(method, dict(options), n, 2 * n - 4, landmarks)
    except MeshError:
        return  # a bad option: embed says so, where it always has
    mapping = mesh_bytes(n) + embedding
    need = max(making_bytes(args.dataset, n), mapping)
    _core.check_memory(f"spherify map --dataset {args.dataset} --method {method}", n, need)


def shows_progress(args: argparse.Namespace) -> bool:
    """Whether to draw the progress bar: asked for, or stderr is a terminal."""
    return bool(args.progress) or sys.stderr.isatty()


def add_progress_flag(p: argparse.ArgumentParser, threads: bool = True) -> None:
    """--progress, and --threads (how many threads the map runs on; not for
    a batch, whose workers share the cores among them)."""
    p.add_argument("--progress", action="store_true",
                   help="show the progress bar even when stderr is not a terminal (it "
                        "shows on a terminal anyway)")
    if not threads:
        return
    p.add_argument("--threads", type=int, default=None,
                   help="worker threads of the map (default: RAYON_NUM_THREADS, else one "
                        "per CPU); the result is the same for every count")


def command_line_options() -> Dict[str, Dict[str, Dict[str, Any]]]:
    """Every option of every method that a command line can carry (all but
    ``initial`` points), from the core's table: option name -> {method: the
    table's row}, in the order the table lists them."""
    options: Dict[str, Dict[str, Dict[str, Any]]] = {}
    for method in methods():
        for name, row in method_options(method).items():
            if row["kind"] != "points":
                options.setdefault(name, {})[method] = row
    return options


def flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def method_options_of(args: argparse.Namespace) -> Dict[str, Any]:
    """The options given for ``args.method``, checked against the core's
    table: an option of another method is refused (UsageError, exit 2; under
    the default method a ``--poles`` would otherwise be ignored, and the map
    would not be the one asked for), and so are a name the method does not
    accept, a count below its minimum and an option without the value of
    the option it needs. Only the options given: the method fills in its own
    defaults, and a batch's journal records what was asked."""
    method = args.method or "progressive"
    takes = method_options(method)
    given = {name: getattr(args, name) for name in command_line_options()
             if getattr(args, name) is not None}
    stray = [name for name in given if name not in takes]
    if stray:
        owners = methods_taking(stray)
        flags = [flag(name) for name in stray]
        what = f"{flags[0]} is an option" if len(flags) == 1 else f"{', '.join(flags)} are options"
        them = "it" if len(flags) == 1 else "them"
        if not owners:
            raise UsageError(f"{', '.join(flags)} are not options of one method together: "
                             "spherify map --help says which method takes each")
        if args.method is None:
            raise UsageError(f"{what} of --method {listed(owners, 'or')}, and the default method is "
                             f"{method}: add --method {listed(owners, 'or')} to use {them}")
        raise UsageError(f"{what} of --method {listed(owners, 'or')}, not of --method {method}: use "
                         f"--method {listed(owners, 'or')}, or leave {them} out")
    for name, value in given.items():
        row = takes[name]
        if row["choices"] and isinstance(value, str) and value not in row["choices"]:
            raise UsageError(f"{flag(name)} {value} is not one of --method {method}'s: it "
                             f"takes {', '.join(row['choices'])}")
        if row["kind"] == "count" and value < row["minimum"]:
            raise UsageError(f"{flag(name)} must be at least {row['minimum']}, got {value}")
        if row["requires"] is not None:
            other, needed = row["requires"]
            if getattr(args, other) != needed:
                raise UsageError(f"{flag(name)} {value} only applies to {flag(other)} {needed}: "
                                 f"add {flag(other)} {needed} to use it")
    return given


def _default_words(row: Dict[str, Any]) -> str:
    if row["default_by"] is not None:
        by = ", ".join(f"{key} {value:g}" if isinstance(value, float) else f"{key} {value}"
                       for key, value in row["default_by"].items())
        return f"by {flag(row['depends_on'])}: {by}"
    value = row["default"]
    if value is None:
        return "automatic"
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


def _flag_help(rows: Dict[str, Dict[str, Any]]) -> str:
    """What the flag does, for which methods, and each one's default, from
    the core's table (methods that share a help text and a default are
    named together)."""
    groups: Dict[Tuple[str, str], List[str]] = {}
    for method, row in rows.items():
        groups.setdefault((row["help"], _default_words(row)), []).append(method)
    parts = [f"--method {', '.join(owners)}: {text} (default: {default})"
             for (text, default), owners in groups.items()]
    return "; ".join(parts).replace("%", "%%")


def add_method_flags(p: argparse.ArgumentParser) -> None:
    """--method and a flag for every option of the core's table (the same
    for ``map`` and ``batch``): its type, choices, help and defaults come
    from the table, so the command line cannot drift from the methods."""
    p.add_argument("--method", default=None, choices=methods(),
                   help="the spherical method (default: progressive, a certified "
                        "low-distortion map of every mesh; theta_phi is the fastest)")
    for name, rows in command_line_options().items():
        kinds = {row["kind"] for row in rows.values()}
        choices = sorted({c for row in rows.values() for c in row["choices"]})
        extra: Dict[str, Any] = {}
        if kinds == {"count"}:
            extra["type"] = int
        elif kinds == {"number"}:
            extra["type"] = float
        elif kinds == {"flag"}:
            extra["action"] = argparse.BooleanOptionalAction
        else:
            # A name (or on the API also a point or a vertex pair, which
            # the command line does not take).
            extra["choices"] = choices
        p.add_argument(flag(name), default=None, help=_flag_help(rows), **extra)


