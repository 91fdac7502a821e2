"""The application subcommands of the ``spherify`` command line (thesis ch. 8).

    spherify harmonics MESH -o OUT --lmax L [--lowpass L2] [--gaussian S] [--sharpen A]
                                   spherical-harmonic fit of the surface through
                                   its map; writes the rebuilt (filtered) surface
                                   and OUT's .npz (coefficients, spectrum)
    spherify remesh MESH -o OUT (--level K | --geometry-image SIZE)
                                   semi-regular icosphere remesh, or an octahedral
                                   geometry image (OUT's .png, 16-bit) and its mesh;
                                   prints the distance to the input
    spherify texture MESH -o OUT.obj|OUT.glb [--projection cube|equirectangular|octahedral]
                                   [--pattern checkerboard]
                                   per-corner UVs, a baked procedural texture; writes
                                   OUT.obj, OUT.mtl and OUT.png, or one glTF OUT.glb
    spherify morph A B -o OUT [--frames K] [--align rotation] [--landmarks I:J ...]
                                   morph A into B (A's connectivity); writes K
                                   frames OUT_000 .. OUT_{K-1} with OUT's suffix

Each maps the mesh first, with ``spherify map``'s method flags (``--method``,
default progressive, and a flag for each option of the core's table), and
refuses, with exit status 1, a map that is not a certified bijection.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from . import datasets
from . import harmonics, texture
from ._morph import morph
from ._geometry_image import (from_geometry_image, geometry_image, octahedral_points,
                              save_geometry_image)
from ._remesh import remesh_map, surface_distance
from ._cli_options import (add_input_flags, add_method_flags, add_progress_flag,
                           method_options_of, shows_progress)
from ._embed import embed
from ._errors import SpherifyError, SpherifyWarning
from ._limits import (ATLAS_HEIGHT_MAX, DISTANCE_SAMPLES_MAX, GEOMETRY_IMAGE_SIZE_MAX,
                      MORPH_FRAMES_MAX, REMESH_LEVEL_MAX)
from ._mesh import Mesh, save
from ._spheremap import SphereMap, ThetaPhiMap


def certified(m: SphereMap) -> bool:
    """h^-1 is defined: ``tp_valid`` for theta-phi, ``valid`` otherwise."""
    return m.tp_valid if isinstance(m, ThetaPhiMap) else m.valid


def bar(args: argparse.Namespace) -> Optional[bool]:
    """``progress=`` for the library's calls: a bar on a terminal or with
    ``--progress``."""
    return True if shows_progress(args) else None


def mapped(mesh: Mesh, args: argparse.Namespace) -> SphereMap:
    """The map the application works through, with the method and options given."""
    options = method_options_of(args)
    method = args.method or "progressive"
    progress = bar(args)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpherifyWarning)  # the verdict is printed instead
        m = embed(mesh, method, progress=progress, **options)
    print(f"map: {m.method}, {'certified' if certified(m) else 'NOT certified'} "
          f"({m.flipped} faces flipped); {sum(m.seconds.values()):.3f} s")
    return m


def output_path(args: argparse.Namespace) -> Path:
    out = Path(args.output)
    if out.is_dir():
        raise SpherifyError(f"-o {out}: this is a folder; name the output file in it")
    if not out.parent.is_dir():
        raise SpherifyError(f"the output folder {out.parent} does not exist")
    return out


def _cmd_harmonics(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh],
                   save_npz: Callable[..., None]) -> int:
    out = output_path(args)
    mesh = load(args)
    m = mapped(mesh, args)
    if not certified(m):
        print("refusing: the map is not a certified bijection")
        return 1
    start = time.perf_counter()
    c = harmonics.fit(m, args.lmax, oversample=args.oversample, progress=bar(args))
    fitted = time.perf_counter()
    filtered = c
    if args.lowpass is not None:
        filtered = filtered.lowpass(args.lowpass)
    if args.gaussian is not None:
        filtered = filtered.gaussian(args.gaussian)
    if args.sharpen is not None:
        filtered = filtered.sharpen(args.sharpen, args.sharpen_sigma)
    rebuilt = filtered.to_mesh(m)
    done = time.perf_counter()
    spectrum = c.spectrum()
    size = float(np.linalg.norm(np.ptp(m.mesh.vertices, axis=0)))
    error = np.linalg.norm(c.to_mesh(m).vertices - m.mesh.vertices, axis=1).max() / size
    print(f"harmonics: lmax {c.lmax}, grid {c.info['n_theta']} x {c.info['n_phi']}; "
          f"fit {fitted - start:.3f} s, filter and rebuild {done - fitted:.3f} s")
    share = ", ".join(f"{x:.3g}" for x in spectrum[: min(6, len(spectrum))] / spectrum.sum())
    print(f"energy share of degrees 0..{min(5, c.lmax)}: {share}")
    print(f"largest vertex error of the unfiltered rebuild: {error:.3e} of the bounding-box "
          "diagonal")
    save(rebuilt, out)
    npz = out.with_suffix(".npz")
    save_npz(npz, coefficients=c.coefficients, spectrum=spectrum,
             filtered=filtered.coefficients)
    print(f"wrote {out} (the rebuilt surface) and {npz}")
    return 0


def _cmd_remesh(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh]) -> int:
    out = output_path(args)
    if not 0 <= args.samples <= DISTANCE_SAMPLES_MAX:
        raise SpherifyError(f"--samples must be in 0..{DISTANCE_SAMPLES_MAX:,}, got {args.samples}")
    if args.geometry_image is None and not 0 <= args.level <= REMESH_LEVEL_MAX:
        raise SpherifyError(f"--level must be in 0..{REMESH_LEVEL_MAX}, got {args.level}")
    if args.geometry_image is not None and not (
            3 <= args.geometry_image <= GEOMETRY_IMAGE_SIZE_MAX and args.geometry_image % 2):
        raise SpherifyError("--geometry-image must be an odd size in "
                            f"3..{GEOMETRY_IMAGE_SIZE_MAX}, got {args.geometry_image}")
    m = mapped(load(args), args)
    if not certified(m):
        print("refusing: the map is not a certified bijection")
        return 1
    start = time.perf_counter()
    if args.geometry_image is not None:
        image = geometry_image(m, args.geometry_image, progress=bar(args))
        mesh = from_geometry_image(image)
        own = SphereMap.from_points(mesh, from_geometry_image(
            octahedral_points(args.geometry_image)).vertices)
        png = out.with_suffix(".png")
        size = save_geometry_image(image, png)
        what = (f"geometry image {args.geometry_image} x {args.geometry_image}: "
                f"{mesh.n_vertices} vertices, {size} bytes in {png} "
                f"({size / mesh.n_vertices:.2f} bytes per vertex)")
    else:
        own = remesh_map(m, level=args.level, progress=bar(args))
        mesh = own.mesh
        what = f"icosphere level {args.level}: {mesh.n_vertices} vertices, {mesh.n_faces} faces"
    made = time.perf_counter()
    d = surface_distance(m, own, samples=args.samples)
    print(f"remesh: {what}; {made - start:.3f} s")
    print(f"distance to the input (through the maps, relative to the bounding-box diagonal "
          f"{d['diagonal']:.4g}): max {d['max']:.3e}, rms {d['rms']:.3e} "
          f"({int(d['samples'])} point pairs)")
    save(mesh, out)
    print(f"wrote {out}")
    return 0


def _cmd_morph(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh]) -> int:
    out = output_path(args)
    if not 2 <= args.frames <= MORPH_FRAMES_MAX:
        raise SpherifyError(f"--frames must be in 2..{MORPH_FRAMES_MAX}, got {args.frames}")
    a = load(args)
    if args.target_dataset:
        b = datasets.make(args.target_dataset, args.n_vertices)
    elif args.target:
        b = load(argparse.Namespace(dataset=None, mesh=args.target, n_vertices=0, weld=args.weld))
    else:
        raise SpherifyError("give the target mesh file or --target-dataset NAME")
    m_a, m_b = mapped(a, args), mapped(b, args)
    if not certified(m_b):
        print("refusing: the target's map is not a certified bijection")
        return 1
    landmarks = None
    if args.landmarks:
        try:
            split = [pair.split(":") for pair in args.landmarks]
            landmarks = [(int(i), int(j)) for i, j in split]
        except ValueError:
            raise SpherifyError(f"landmarks must be I:J vertex pairs, got {args.landmarks}") \
                from None
    start = time.perf_counter()
    mo = morph(m_a, m_b, align=args.align, landmarks=landmarks,
               normalize=not args.no_normalize, progress=bar(args))
    aligned = time.perf_counter()
    al = mo.alignment
    extra = (f", landmark rms angle {al['landmark_residual']:.3g} rad"
             if "landmark_residual" in al else "")
    print(f"morph: align {args.align} from {al['start']} in {al['iterations']} steps, "
          f"residual {al['residual']:.3g} (unit rms radius){extra}; {aligned - start:.3f} s")
    width = max(3, len(str(args.frames - 1)))
    for k in range(args.frames):
        path = out.with_name(f"{out.stem}_{k:0{width}d}{out.suffix}")
        save(mo.at(k / (args.frames - 1)), path)
    print(f"wrote {args.frames} frames {out.stem}_{0:0{width}d}{out.suffix} .. "
          f"{out.stem}_{args.frames - 1:0{width}d}{out.suffix} in {out.parent}")
    return 0


def _cmd_texture(args: argparse.Namespace, load: Callable[[argparse.Namespace], Mesh]) -> int:
    out = output_path(args)
    if out.suffix.lower() not in (".obj", ".glb"):
        raise SpherifyError(f"texture writes OBJ (with MTL and PNG) or glTF: give OUT.obj or "
                            f"OUT.glb, got {out}")
    if not 2 <= args.size <= ATLAS_HEIGHT_MAX:
        raise SpherifyError(f"--size must be in 2..{ATLAS_HEIGHT_MAX}, got {args.size}")
    m = mapped(load(args), args)
    start = time.perf_counter()
    t = texture.uv(m, args.projection)
    pattern = (datasets.checkerboard if args.pattern == "checkerboard"
               else datasets.lat_long_grid)
    image = t.bake(pattern, args.size, progress=bar(args))
    made = time.perf_counter()
    e1, e2 = t.uv[:, 1] - t.uv[:, 0], t.uv[:, 2] - t.uv[:, 0]
    flipped = int(np.sum(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] <= 0))
    q = t.quality(m.mesh)
    print(f"texture: {args.projection}, atlas {image.shape[1]} x {image.shape[0]}; "
          f"{flipped} UV triangles not positive; texture stretch L2 {q['stretch_l2']:.3g} "
          f"(Linf {q['stretch_linf']:.3g}); {made - start:.3f} s")
    if out.suffix.lower() == ".glb":
        save(m.mesh, out, uv=t, texture=image, sphere=m.points)
        print(f"wrote {out} (mesh, normals, UVs, sphere points and the texture)")
    else:
        texture.save_obj(m.mesh, out, t, image)
        print(f"wrote {out}, {out.with_suffix('.mtl')} and {out.with_suffix('.png')}")
    return 0 if flipped == 0 and certified(m) else 1


def add_commands(sub: Any, load: Callable[[argparse.Namespace], Mesh],
                 save_npz: Callable[..., None]) -> None:
    """Registers the application subcommands on ``sub``: each takes the
    input, method and progress flags every mapping command takes."""
    def common(name: str, text: str) -> argparse.ArgumentParser:
        p: argparse.ArgumentParser = sub.add_parser(name, help=text, description=text)
        add_input_flags(p)
        add_method_flags(p)
        add_progress_flag(p)
        p.add_argument("-o", "--output", required=True, help="output mesh file")
        return p

    p = common("harmonics", "spherical-harmonic fit, filter and rebuild (thesis 8.3)")
    p.add_argument("--lmax", type=int, default=20, help="largest degree of the fit (default: 20)")
    p.add_argument("--oversample", type=int, default=1,
                   help="grid oversampling factor (default: 1)")
    p.add_argument("--lowpass", type=int, default=None, help="keep degrees up to this")
    p.add_argument("--gaussian", type=float, default=None,
                   help="heat-kernel smoothing of width SIGMA radians")
    p.add_argument("--sharpen", type=float, default=None, help="high-boost amount")
    p.add_argument("--sharpen-sigma", type=float, default=0.1,
                   help="width of the smoothing the high-boost subtracts (default: 0.1)")
    p.set_defaults(func=lambda args: _cmd_harmonics(args, load, save_npz))

    p = common("remesh", "semi-regular remesh or geometry image (thesis 8.1, 8.2)")
    kind = p.add_mutually_exclusive_group()
    kind.add_argument("--level", type=int, default=4,
                      help="icosphere subdivision level (default: 4)")
    kind.add_argument("--geometry-image", type=int, default=None, metavar="SIZE",
                      help="octahedral geometry image of odd SIZE instead")
    p.add_argument("--samples", type=int, default=100_000,
                   help="random sphere points for the distance, at most "
                        f"{DISTANCE_SAMPLES_MAX:,} (default: 100000)")
    p.set_defaults(func=lambda args: _cmd_remesh(args, load))

    p = common("texture", "per-corner UVs and a baked texture, as OBJ + MTL + PNG or as one "
               "glTF .glb (thesis 8.5)")
    p.add_argument("--projection", default="cube", choices=list(texture.PROJECTIONS),
                   help="how the sphere is unfolded into the texture atlas (default: cube)")
    p.add_argument("--pattern", default="checkerboard", choices=["checkerboard", "grid"],
                   help="the procedural texture baked into the atlas (default: checkerboard)")
    p.add_argument("--size", type=int, default=1024,
                   help=f"atlas height in pixels, 2..{ATLAS_HEIGHT_MAX} (default: 1024)")
    p.set_defaults(func=lambda args: _cmd_texture(args, load))

    p = common("morph", "morph one mesh into another through their maps (thesis 8.4)")
    p.add_argument("target", nargs="?", help="the mesh to morph into")
    p.add_argument("--target-dataset", choices=datasets.names(),
                   help="use a generated shape as the target")
    p.add_argument("--frames", type=int, default=5,
                   help=f"frames from A (first) to B (last), 2..{MORPH_FRAMES_MAX} (default: 5)")
    p.add_argument("--align", default="rotation",
                   choices=["rotation", "moebius", "warp", "landmarks", "none"],
                   help="how A's sphere map is brought onto B's before the morph: the rotation "
                        "or Moebius transformation that best matches the shapes, a flip-free "
                        "warp that also makes --landmarks meet exactly, the rotation that best "
                        "matches --landmarks, or none (default: rotation)")
    p.add_argument("--no-normalize", action="store_true",
                   help="morph between the shapes as given; by default both are centred, "
                        "scaled to unit rms radius and B is turned into A's pose")
    p.add_argument("--landmarks", nargs="*", metavar="I:J",
                   help="vertex I of A corresponds to vertex J of B")
    p.set_defaults(func=lambda args: _cmd_morph(args, load))
