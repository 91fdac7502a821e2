"""The ``spherify`` command line.

    spherify map MESH -o OUT [--method progressive] [--energy isometric]
    spherify map MESH -o OUT --method theta_phi [--poles fast_graph] [--weights uniform]
                                   map a mesh onto the sphere, print the certificate,
                                   write OUT (the sphere as a mesh; a FreeSurfer name
                                   such as lh.sphere gets radius 100) and OUT's .npz.
                                   The default, progressive with the isometric energy,
                                   gives a certified low-distortion map of every mesh;
                                   theta_phi is the fastest and the thesis's own
                                   bijection h (see README, "Which method when").
                                   --poles, --weights and --symmetry-eps are theta-phi
                                   options and need --method theta_phi; --energy needs
                                   --method progressive. A progress bar shows on a
                                   terminal (or with --progress) for progressive and
                                   for --poles graph
    spherify check MESH [--weld]   load, validate, orient and print the report; --weld
                                   (also for map and orient) first merges vertices at
                                   exactly the same position (a seam a file splits)
    spherify orient MESH -o OUT    write a consistently, outward-oriented copy
    spherify harmonics ...         the applications of thesis ch. 8: see
                                   ``spherify <command> --help`` and _cli_apps.py;
                                   they map with the same default, --method to change
    spherify batch INPUT... -o OUTDIR [--method M] [the method's options as for map]
                   [--workers N] [--timeout S] [--scheduler tcp://...]
                                   map many meshes (files, folders, lists of paths),
                                   resumably; OUTDIR/journal.jsonl and summary.csv

Every command takes ``--dataset NAME [--n-vertices N]`` instead of MESH to
use a generated shape. Exit status: 0 for success (a valid mesh; a certified
map), 1 when the mesh has problems or the map could not be certified, 2 for
unreadable input or bad arguments.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

import numpy as np

from . import _args, _cli_apps, _core, _files, _formats, datasets
from ._embed import embed, methods
from ._errors import MeshError, SpherifyError, SpherifyWarning, TopologyError
from ._mesh import Mesh, check, check_sphere, load, orient, save, weld
from ._quality import quality
from ._spheremap import ThetaPhiMap


#: Sizes of generated shapes the command line accepts (a 10^7-vertex shape
#: takes some 10 GB to map).
N_VERTICES = (4, 10_000_000)

#: Extensions of the mesh files spherify writes.
MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl")


class UsageError(SpherifyError):
    """Bad arguments, found before any work is done (exit status 2)."""


class _ReaderMayLeave(io.TextIOBase):
    """Standard output that goes quiet when its reader leaves. With
    ``spherify map ... | head -3`` the pipe closes after three lines; a
    ``print`` after that raised BrokenPipeError and the command stopped
    before it wrote its files. Now the command finishes its job and exits
    with the job's status; what it would have printed is dropped."""

    def __init__(self, stream: Any) -> None:
        super().__init__()
        self._stream = stream
        self._gone = False

    def _reader_left(self) -> None:
        self._gone = True
        try:
            # The interpreter flushes the real stdout at exit: let that go
            # nowhere instead of raising again.
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, io.UnsupportedOperation):
            pass  # not a file descriptor (a captured stream): nothing to flush

    def write(self, text: str) -> int:
        if not self._gone:
            try:
                return int(self._stream.write(text))
            except BrokenPipeError:
                self._reader_left()
        return len(text)

    def flush(self) -> None:
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._reader_left()

    def isatty(self) -> bool:
        return bool(self._stream.isatty())

    def fileno(self) -> int:
        return int(self._stream.fileno())


def _n_vertices(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    low, high = N_VERTICES
    if not low <= n <= high:
        raise argparse.ArgumentTypeError(f"{n} is outside the supported range {low} to {high:,}")
    return n


def _check_output(path: str) -> None:
    """Refuses an output the command could not write, before the work."""
    out = Path(path)
    try:
        _formats.writer_for(out, None)
    except SpherifyError:
        raise UsageError(f"-o {path}: unknown extension {out.suffix or '(none)'!r}; "
                         f"use one of {', '.join(MESH_EXTENSIONS)}, .npz, .gii or a FreeSurfer "
                         "surface name (lh.sphere, rh.pial, ...)") from None
    if out.is_dir():
        raise UsageError(f"-o {path}: this is a folder; name the output file in it")
    folder = out.parent
    if not folder.is_dir():
        raise UsageError(f"-o {path}: the output folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"-o {path}: the output folder {folder} is not writable")


def _load(args: argparse.Namespace) -> Mesh:
    if args.dataset and args.mesh:
        raise UsageError(f"give a mesh file or --dataset, not both (got {args.mesh!r} and "
                         f"--dataset {args.dataset})")
    if args.dataset:
        return datasets.make(args.dataset, args.n_vertices)
    if not args.mesh:
        raise UsageError("give a mesh file or --dataset NAME")
    mesh = load(args.mesh)
    return weld(mesh) if getattr(args, "weld", False) else mesh


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def pair_is_consistent(out: Union[str, bytes, "os.PathLike[Any]"]) -> bool:
    """Whether ``OUT`` and ``OUT.npz`` written by ``spherify map`` belong
    together: the .npz records the SHA-256 of the mesh file it was written
    with (``mesh_sha256``). The mesh is written first and the .npz second,
    each atomically, so a run cut short between them leaves a pair this
    function tells apart."""
    mesh_path = Path(_args.path(out))
    npz = mesh_path.with_suffix(".npz")
    if not (mesh_path.is_file() and npz.is_file()):
        return False
    with np.load(npz) as data:
        if "mesh_sha256" not in data.files:
            return False
        recorded = str(data["mesh_sha256"])
    return recorded == _sha256(mesh_path)


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
    _check_output(args.output)
    mesh = _load(args)
    fixed, info = orient(mesh, return_info=True)
    save(fixed, args.output)
    print(f"reversed {info['flipped_faces']} faces; wrote {args.output}")
    return 0


def _save_npz(path: Path, **arrays: Any) -> None:
    """Write an .npz through the core's atomic writer (the one meshes use:
    unique temporary, fsync, rename, mode and symbolic links kept)."""
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    _core.write_atomic(str(path), buffer.getvalue())


def _save_sphere(mesh: Mesh, points: np.ndarray, out: Path) -> None:
    """Write the sphere as a mesh. A FreeSurfer surface gets FreeSurfer's
    radius of 100 (as ``?h.sphere``); FreeSurfer and GIfTI store float32, so
    the rounded points are certified again and the verdict printed."""
    radius = _formats.FREESURFER_RADIUS if _formats.is_freesurfer_name(out) else 1.0
    save(Mesh(points * radius, mesh.faces), out)
    if _formats.is_freesurfer_name(out) or out.name.lower().endswith(".gii"):
        stored = (points * radius).astype(np.float32).astype(np.float64)
        verdict = check_sphere(mesh, stored)
        print(f"{out} stores float32 coordinates (radius {radius:g}); as stored they form "
              f"{'a valid' if verdict.valid else 'NOT a valid'} GC-embedding "
              f"({verdict.n_negative + verdict.n_zero} faces flipped or collapsed)")


#: ``spherify map`` options that only one method reads, with that method and
#: the default the method gets when the option is not given.
METHOD_OPTIONS = {"poles": ("theta_phi", "fast_graph"), "weights": ("theta_phi", "uniform"),
                  "symmetry_eps": ("theta_phi", None), "energy": ("progressive", "isometric")}


def _method_options(args: argparse.Namespace, defaults: bool = True) -> Dict[str, Any]:
    """The options of ``args.method``, refusing (UsageError, exit 2) an
    option of another method: under the default method a ``--poles`` would
    otherwise be ignored, and the map would not be the one asked for. With
    ``defaults=False`` only the options given (a batch's journal records
    them, and ``sp.batch`` with the same options must reuse its rows)."""
    method = args.method or "progressive"
    stray = [name for name, (owner, _) in METHOD_OPTIONS.items()
             if getattr(args, name) is not None and owner != method]
    if stray:
        owner = METHOD_OPTIONS[stray[0]][0]
        flags = [f"--{name.replace('_', '-')}" for name in stray
                 if METHOD_OPTIONS[name][0] == owner]
        what = (f"{flags[0]} is an option" if len(flags) == 1
                else f"{', '.join(flags)} are options")
        them = "it" if len(flags) == 1 else "them"
        if args.method is None:
            raise UsageError(f"{what} of --method {owner}, and the default method is {method}: "
                             f"add --method {owner} to use {them}")
        raise UsageError(f"{what} of --method {owner}, not of --method {method}: use "
                         f"--method {owner}, or leave {them} out")
    if args.symmetry_eps is not None and args.poles != "symmetry":
        raise UsageError(f"--symmetry-eps {args.symmetry_eps:g} sets the band of --poles symmetry: "
                         "add --poles symmetry to use it")
    options: Dict[str, Any] = {}
    for name, (owner, default) in METHOD_OPTIONS.items():
        value = getattr(args, name)
        if owner == method and value is not None:
            options[name] = value
        elif owner == method and defaults and default is not None:
            options[name] = default
    return options


def _cmd_map(args: argparse.Namespace) -> int:
    options = _method_options(args)
    method = args.method or "progressive"
    _check_output(args.output)
    out = Path(args.output)
    if out.exists() and not out.is_file():
        # OUT is read back for the hash its .npz records: a pipe would wait
        # for a writer for ever, a device would give a hash of nothing.
        what = _files.special_kind(out.stat().st_mode) or "not a regular file"
        raise UsageError(f"-o {out}: this is {what}; spherify map writes OUT and records its "
                         "hash in OUT's .npz, so OUT must be a regular file")
    start = time.perf_counter()
    mesh = _load(args)
    loaded = time.perf_counter()
    report = check(mesh)
    source = args.mesh or f"dataset {args.dataset!r}"
    print(f"{source}: {mesh.n_vertices} vertices, {mesh.n_faces} faces")
    if not report.is_sphere_topology:
        print(report)
        print("refusing to map: the mesh is not a closed, connected, manifold genus-0 surface")
        return 1
    if method == "progressive" or options.get("poles") == "graph":
        if args.progress or sys.stderr.isatty():
            options["progress"] = True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpherifyWarning)  # reported below instead
        try:
            m = embed(mesh, method, **options)
        except TopologyError:
            raise
        except MeshError as err:
            # The method refused this mesh (radial on a mesh that is not
            # star-shaped): a property of the input, like an invalid mesh.
            print(f"refusing to map: {err}")
            return 1
    mapped = time.perf_counter()
    for note in m.notes:
        print(f"note: {note}")
    print(f"method: {m.method} ({m.status}, {m.iterations} iterations): {m.message}")
    certified = m.valid
    if isinstance(m, ThetaPhiMap):
        print(f"poles: {m.poles[0]} (north), {m.poles[1]} (south); cut path of {len(m.cut_path)} vertices")
        symmetry = m.details.get("symmetry")
        if symmetry is not None:
            if symmetry["chosen"] is not None:
                normal = ", ".join(f"{x:.4f}" for x in symmetry["normal"])
                print(f"symmetry plane: normal ({normal}), score {symmetry['score']:.4f}, "
                      f"{symmetry['band']} vertices within eps {symmetry['eps']:.4g}")
            if symmetry["fallback"] is not None:
                print(f"symmetry poles fell back to fast_graph: {symmetry['fallback']}")
        print(f"theta-phi rectangle (the bijection h): "
              f"{'certified flip-free' if m.tp_valid else 'NOT certified'} under exact predicates")
        certified = m.tp_valid
    print(f"GC-embedding (minor-arc edges): {'valid' if m.valid else 'not valid'}, "
          f"{m.flipped} faces flipped or collapsed; area sum {m.report.area_sum:.12f} "
          f"(4 pi = {4 * np.pi:.12f})")
    q = quality(m.mesh, m.points)
    print(f"quality: angle distortion mean {q['angle_mean_deg']:.3g} deg (max "
          f"{q['angle_max_deg']:.3g}), conformal mean {q['conformal_mean']:.3g}, "
          f"log-area std {q['area_log_std']:.3g}, stretch L2 {q['stretch_l2']:.3g} "
          f"(Linf {q['stretch_linf']:.3g}), edge-length CV {q['edge_length_cv']:.3g}")
    stages = ", ".join(f"{k} {v:.3f}" for k, v in m.seconds.items())
    print(f"seconds: load {loaded - start:.3f}; {stages}; total {mapped - start:.3f}")
    # The mesh first, then the .npz recording the mesh file's hash: a run
    # cut short in between leaves a pair that pair_is_consistent refuses.
    _save_sphere(m.mesh, m.points, out)
    arrays = {"points": m.points, "faces": m.mesh.faces,
              "mesh_sha256": np.array(_sha256(out))}
    if isinstance(m, ThetaPhiMap):
        arrays.update(theta_phi=m.theta_phi, poles=np.array(m.poles), cut_path=m.cut_path,
                      cut_faces=m.cut_mesh.faces, cut_original=m.cut_original)
    npz = out.with_suffix(".npz")
    _save_npz(npz, **arrays)
    print(f"wrote {out} (the sphere as a mesh) and {npz}")
    return 0 if certified else 1


def _cmd_batch(args: argparse.Namespace) -> int:
    from ._batch import batch
    options = _method_options(args, defaults=False)

    def show(message: Any, *_: Any, **__: Any) -> None:  # (a folder without meshes, ...)
        print(f"spherify: warning: {message}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", SpherifyWarning)  # shown, never raised
            warnings.showwarning = show
            result = batch(args.inputs, args.output, method=args.method or "progressive",
                           workers=args.workers, timeout=args.timeout,
                           scheduler=args.scheduler, weld=args.weld,
                           progress=args.progress or sys.stderr.isatty(), **options)
    except KeyboardInterrupt:
        print(f"interrupted: {args.output}/journal.jsonl holds every mesh that finished; "
              "run the same command again to resume", file=sys.stderr)
        return 130
    c = result.counts
    print(f"{c['meshes']} meshes: {c['certified']} certified, {c['failed']} failed, "
          f"{c['skipped']} already done (skipped); summary in {result.summary}")
    for row in result.rows:
        if row.get("status") != "done":
            print(f"failed: {row['input']}: {row['error_type']}: {row['error']}")
        elif not row.get("certified"):
            print(f"not certified: {row['input']}")
    if c["meshes"] == 0:
        print("spherify: error: no mesh to map in the inputs given", file=sys.stderr)
        return 1
    return 0 if result.all_certified else 1


def _add_method_flags(p: argparse.ArgumentParser, names: Dict[str, Any]) -> None:
    """--method and the options of each method (:data:`METHOD_OPTIONS`), the
    same for ``map`` and ``batch``."""
    p.add_argument("--method", default=None, choices=methods(),
                   help="the spherical method (default: progressive, a certified "
                        "low-distortion map of every mesh; theta_phi is the fastest)")
    p.add_argument("--poles", default=None, choices=names["poles"],
                   help="--method theta_phi: how to choose the poles and the cut "
                        "(default: fast_graph)")
    p.add_argument("--symmetry-eps", type=float, default=None,
                   help="--method theta_phi --poles symmetry: band half-width around "
                        "the plane in mesh units (default: automatic)")
    p.add_argument("--weights", default=None, choices=names["theta_phi_weights"],
                   help="--method theta_phi: the Tutte weights (default: uniform)")
    p.add_argument("--energy", default=None, choices=names["energies"],
                   help="--method progressive: the distortion energy it lowers "
                        "(default: isometric)")


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="spherify", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    names = _core.choices()
    for name, func, text in [("map", _cmd_map, "map a mesh onto the sphere and certify it"),
                             ("check", _cmd_check, "validate a mesh, orient it, print the report"),
                             ("orient", _cmd_orient, "write a consistently outward-oriented copy")]:
        p = sub.add_parser(name, help=text)
        p.add_argument("mesh", nargs="?", help="mesh file (.obj .off .ply .stl .npz, a "
                       "FreeSurfer surface such as lh.pial, .gii)")
        p.add_argument("--dataset", choices=datasets.names(), help="use a generated shape instead")
        p.add_argument("--n-vertices", type=_n_vertices, default=5000,
                       help=f"size of the generated shape ({N_VERTICES[0]} to {N_VERTICES[1]:,})")
        p.add_argument("--weld", action="store_true",
                       help="first merge vertices at exactly the same position (a seam the "
                            "exporter split; the report of such an open mesh suggests it)")
        if name in ("orient", "map"):
            p.add_argument("-o", "--output", required=True, help="output mesh file")
        if name == "map":
            _add_method_flags(p, names)
            p.add_argument("--progress", action="store_true",
                           help="--method progressive and --poles graph: show a progress bar "
                                "even when stderr is not a terminal")
        p.set_defaults(func=func)
    p = sub.add_parser("batch", help="map many meshes, in parallel and resumably")
    p.add_argument("inputs", nargs="+", help="mesh files, folders, or .txt files of paths")
    p.add_argument("-o", "--output", required=True, help="output folder")
    _add_method_flags(p, names)
    p.add_argument("--weld", action="store_true",
                   help="first merge vertices at exactly the same position in each mesh")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: cores)")
    p.add_argument("--timeout", type=float, default=None, help="seconds per mesh")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address, tcp://host:port")
    p.add_argument("--progress", action="store_true",
                   help="show the progress bar even when stderr is not a terminal")
    p.set_defaults(func=_cmd_batch)
    _cli_apps.add_commands(sub, _load, _save_npz, datasets)
    args = parser.parse_args(argv)
    stdout, sys.stdout = sys.stdout, _ReaderMayLeave(sys.stdout)
    try:
        return int(args.func(args))
    except TopologyError as err:
        # A mesh that cannot be done (not manifold, not genus 0): 1, as map
        # and check say it; 2 is for bad arguments and unreadable inputs.
        print(f"spherify: error: {err}", file=sys.stderr)
        return 1
    except (SpherifyError, OSError) as err:
        print(f"spherify: error: {err}", file=sys.stderr)
        return 2
    finally:
        sys.stdout.flush()
        sys.stdout = stdout


if __name__ == "__main__":
    sys.exit(main())
