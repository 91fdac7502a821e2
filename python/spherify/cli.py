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
                                   Each option of a method is a flag (--poles,
                                   --weights, --energy, --max-iter, ...), generated from
                                   the core's table (sp.method_options); one the method
                                   does not take is refused. A progress bar shows on a
                                   terminal (or with --progress)
    spherify check MESH [--weld]   load, validate, orient and print the report; --weld
                                   (also for map and orient) first merges vertices at
                                   exactly the same position (a seam a file splits)
    spherify orient MESH -o OUT    write a consistently, outward-oriented copy
    spherify harmonics|remesh|texture|morph ...
                                   the applications of thesis ch. 8 (_cli_apps.py);
                                   they take map's input, method and progress flags
    spherify register A B -o OUT.npz [--transform warp] [--landmarks I:J ...]
    spherify correspond MESH MESH ... -o FOLDER [--level 6]
                                   correspondence between shapes (_cli_correspondence.py):
                                   where A's vertices land on B; a population on one
                                   connectivity with its mean and modes
    spherify batch INPUT... -o OUTDIR [--method M] [the method's options as for map]
                   [--workers N] [--timeout S] [--scheduler tcp://...]
                                   map many meshes (files, folders, lists of paths),
                                   resumably; OUTDIR/journal.jsonl and summary.csv

Every command takes ``--dataset NAME [--n-vertices N]`` instead of MESH to
use a generated shape. Exit status: 0 for success (a valid mesh; a certified
map), 1 when the mesh has problems, the map could not be certified or the job
does not fit in memory (``ResourceError``), 2 for unreadable input or bad
arguments.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _args, _cli_apps, _cli_correspondence, _core, _files, _formats, datasets
from ._cli_options import (UsageError, add_input_flags, add_method_flags, add_progress_flag,
                           check_memory_first, method_options_of, shows_progress)
from ._embed import embed, methods
from ._errors import (MapError, MeshError, ResourceError, SpherifyError, SpherifyWarning,
                      TopologyError)
from ._landmarks import read_landmarks
from ._mesh import Mesh, check, check_sphere, load, orient, save, weld
from ._persist import record
from ._quality import quality
from ._spheremap import SphereMap, ThetaPhiMap
from ._threads import set_num_threads


#: Extensions of the mesh files spherify writes.
MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl")


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


def pair_is_consistent(out: Union[str, bytes, "os.PathLike[Any]"]) -> bool:
    """Whether ``OUT`` and ``OUT.npz`` written by ``spherify map`` belong
    together: the .npz records the SHA-256 of the sphere file it was written
    with (``sphere_sha256``; files written before it was named so call it
    ``mesh_sha256``). The sphere is written first and the .npz second, each
    atomically, so a run cut short between them leaves a pair this function
    tells apart."""
    sphere_path = Path(_args.path(out))
    npz = sphere_path.with_suffix(".npz")
    if not (sphere_path.is_file() and npz.is_file()):
        return False
    with np.load(npz) as data:
        key = "sphere_sha256" if "sphere_sha256" in data.files else "mesh_sha256"
        if key not in data.files or (key == "mesh_sha256" and "spherify_map_format" in data.files):
            return False
        recorded = str(data[key])
    return recorded == _files.file_sha256(sphere_path)


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


def _outcome(m: SphereMap) -> str:
    """How the method ended, where the message does not already say it: a
    direct solve, the iterations of an iterative method, or that it ran out
    of them. The progressive method's message counts its own sweeps, and its
    sweep limit is how it normally ends."""
    count = f"{m.iterations} iteration{'s' if m.iterations != 1 else ''}"
    if m.method == "progressive":
        return ""
    if m.status == "direct":
        return " (a direct solve)"
    if m.status == "converged":
        return f" (converged in {count})"
    if m.status == "max_iterations":
        return f" (stopped at its limit of {count})"
    return f" ({m.status} after {count})"


def _cmd_map(args: argparse.Namespace) -> int:
    options = method_options_of(args)
    method = args.method or "progressive"
    _check_output(args.output)
    out = Path(args.output)
    if out.exists() and not out.is_file():
        # OUT is read back for the hash its .npz records: a pipe would wait
        # for a writer for ever, a device would give a hash of nothing.
        what = _files.special_kind(out) or "not a regular file"
        raise UsageError(f"-o {out}: this is {what}; spherify map writes OUT and records its "
                         "hash in OUT's .npz, so OUT must be a regular file")
    start = time.perf_counter()
    landmarks = None if args.landmarks is None else read_landmarks(args.landmarks)
    check_memory_first(args, method, options, landmarks is not None)
    mesh = _load(args)
    loaded = time.perf_counter()
    report = check(mesh)
    source = args.mesh or f"dataset {args.dataset!r}"
    print(f"{source}: {mesh.n_vertices} vertices, {mesh.n_faces} faces")
    if not report.is_sphere_topology:
        print(report)
        print("refusing to map: the mesh is not a closed, connected, manifold genus-0 surface")
        return 1
    if (method == "progressive" or options.get("poles") == "graph") and shows_progress(args):
        options["progress"] = True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpherifyWarning)  # reported below instead
        try:
            m = embed(mesh, method, landmarks=landmarks, **options)
        except TopologyError:
            raise
        except MapError as err:
            # Landmarks no map realises, or a method whose map is not valid.
            print(f"refusing to pin the landmarks: {err}")
            return 1
        except MeshError as err:
            # The method refused this mesh (radial on a mesh that is not
            # star-shaped): a property of the input, like an invalid mesh.
            print(f"refusing to map: {err}")
            return 1
    mapped = time.perf_counter()
    for note in m.notes:
        print(f"note: {note}")
    print(f"method: {m.method}{_outcome(m)}: {m.message}")
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
    # The sphere first, then the .npz recording its hash: a run cut short in
    # between leaves a pair that pair_is_consistent refuses. The .npz is the
    # map itself (SphereMap.save's record: sp.load_map reads it back and
    # certifies it again), with the hashes of the sphere file and of the
    # input mesh file beside it.
    _save_sphere(m.mesh, m.points, out)
    arrays = dict(record(m))
    arrays["sphere_sha256"] = np.array(_files.file_sha256(out))
    if args.mesh:
        arrays["mesh_sha256"] = np.array(_files.file_sha256(Path(args.mesh)))
    if isinstance(m, ThetaPhiMap):
        arrays.update(cut_faces=m.cut_mesh.faces, cut_original=m.cut_original)
    npz = out.with_suffix(".npz")
    _save_npz(npz, **arrays)
    print(f"wrote {out} (the sphere as a mesh) and {npz}")
    return 0 if certified else 1


def _cmd_batch(args: argparse.Namespace) -> int:
    from ._batch import batch
    options = method_options_of(args)

    def show(message: Any, *_: Any, **__: Any) -> None:  # (a folder without meshes, ...)
        print(f"spherify: warning: {message}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", SpherifyWarning)  # shown, never raised
            warnings.showwarning = show
            result = batch(args.inputs, args.output, method=args.method or "progressive",
                           workers=args.workers, timeout=args.timeout,
                           scheduler=args.scheduler, weld=args.weld,
                           progress=shows_progress(args), **options)
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


DESCRIPTION = """\
Map closed genus-0 triangle meshes one-to-one onto the unit sphere, and certify
each map with exact predicates.

Every command takes a mesh file (.obj .off .ply .stl .npz, FreeSurfer, .gii) or
--dataset NAME [--n-vertices N] for a generated shape. Every command that maps
takes --method and the method's options (spherify map --help lists them, with
the methods that take each and their defaults).

exit status: 0 success (a valid mesh; a certified map), 1 when the mesh has
problems, a map could not be certified or the job does not fit in memory, 2 for
bad arguments or unreadable input.
"""

EPILOG = """\
examples:
  spherify map --dataset helix_tube --n-vertices 20000 -o helix_sphere.ply
  spherify map bunny.ply -o bunny_sphere.ply --method theta_phi --poles symmetry
  spherify check bunny.ply --weld
  spherify batch meshes/ -o spheres/ --workers 2
  spherify harmonics hand.obj -o hand_l32.ply --lmax 32
"""


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="spherify", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"spherify {_core.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, func, text in [("map", _cmd_map, "map a mesh onto the sphere and certify it"),
                             ("check", _cmd_check, "validate a mesh, orient it, print the report"),
                             ("orient", _cmd_orient, "write a consistently outward-oriented copy")]:
        p = sub.add_parser(name, help=text, description=text)
        add_input_flags(p)
        if name in ("orient", "map"):
            p.add_argument("-o", "--output", required=True, help="output mesh file")
        if name == "map":
            add_method_flags(p)
            add_progress_flag(p)
            p.add_argument("--landmarks", default=None, metavar="FILE",
                           help="pin vertices to directions exactly: a .npz (ids, points), .json "
                                "({\"ids\": [...], \"points\": [...]} or {id: [x, y, z]}) or "
                                ".csv (id,x,y,z lines)")
        p.set_defaults(func=func)
    text = "map many meshes, in parallel and resumably"
    p = sub.add_parser("batch", help=text, description=text)
    p.add_argument("inputs", nargs="+", help="mesh files, folders, or .txt files of paths")
    p.add_argument("-o", "--output", required=True, help="output folder")
    add_method_flags(p)
    p.add_argument("--weld", action="store_true",
                   help="first merge vertices at exactly the same position in each mesh")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: cores)")
    p.add_argument("--timeout", type=float, default=None,
                   help="seconds per mesh (default: no limit)")
    p.add_argument("--scheduler", default=None,
                   help="Dask scheduler address, tcp://host:port (default: local processes)")
    add_progress_flag(p, threads=False)
    p.set_defaults(func=_cmd_batch)
    _cli_apps.add_commands(sub, _load, _save_npz)
    _cli_correspondence.add_commands(sub, _load, _save_npz)
    args = parser.parse_args(argv)
    stdout, sys.stdout = sys.stdout, _ReaderMayLeave(sys.stdout)
    threads = getattr(args, "threads", None)
    try:
        if threads is not None:
            set_num_threads(threads)
        return int(args.func(args))
    except (TopologyError, ResourceError) as err:
        # A mesh that cannot be done (not manifold, not genus 0), or a job
        # within the documented sizes that does not fit in this process's
        # memory: 1, as map and check say it; 2 is for bad arguments and
        # unreadable inputs.
        print(f"spherify: error: {err}", file=sys.stderr)
        return 1
    except (SpherifyError, OSError) as err:
        print(f"spherify: error: {err}", file=sys.stderr)
        return 2
    finally:
        if threads is not None:
            set_num_threads(None)  # main() may run inside a program that goes on
        sys.stdout.flush()
        sys.stdout = stdout


if __name__ == "__main__":
    sys.exit(main())
