"""Pictures of the applications of a sphere map for docs/applications.md
(thesis ch. 8, Fig. 8.1-8.3).

    python benches/applications.py [--out docs] [--small] [--only harmonics ...]

``--small`` uses small generated shapes (the test suite runs it that way, so
the script cannot rot); without it the corpus meshes of ../shared/meshes are
used where present (the hand, as in Fig. 8.1), else generated shapes. Needs
matplotlib. Renders headless (Agg).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Callable, Dict, List

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import spherify as sp  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def corpus_or(name: str, fallback: Callable[[], sp.Mesh], small: bool) -> sp.Mesh:
    for ext in ("obj", "ply", "off"):
        path = SHARED / f"{name}.{ext}"
        if not small and path.exists():
            return sp.load(path)
    return fallback()


def certified_map(mesh: sp.Mesh) -> sp.SphereMap:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        m = sp.embed(mesh, "theta_phi")
    assert isinstance(m, sp.ThetaPhiMap) and m.tp_valid, "the theta-phi map is not certified"
    return m


def draw(ax, V: np.ndarray, F: np.ndarray, title: str, colors=None, view=(20, -60),
         edges: bool = False) -> None:
    """A shaded mesh on a 3D axis, through sp.plot.mesh."""
    sp.plot.mesh(sp.Mesh(V, F), ax=ax, title=title, colors=colors, view=view, edges=edges)


def harmonics_picture(out: Path, small: bool) -> List[str]:
    """Fig. 8.1's analogue: the hand low-passed at several cut-offs."""
    mesh = corpus_or("hand", lambda: sp.datasets.bumpy_blob(600 if small else 8000), small)
    m = certified_map(mesh)
    cutoffs = [2, 4, 8] if small else [8, 16, 32, 64, 128]
    start = time.perf_counter()
    c = sp.harmonics.fit(m, max(cutoffs), oversample=2)
    seconds = time.perf_counter() - start
    fig = plt.figure(figsize=(3.2 * (len(cutoffs) + 1), 3.6))
    fig.subplots_adjust(wspace=0, left=0, right=1)
    view = (75, -90)
    draw(fig.add_subplot(1, len(cutoffs) + 1, 1, projection="3d"), m.mesh.vertices, m.mesh.faces,
         f"input ({m.mesh.n_vertices} vertices)", view=view)
    for i, l in enumerate(cutoffs):
        rebuilt = c.lowpass(l).to_mesh(m)
        draw(fig.add_subplot(1, len(cutoffs) + 1, i + 2, projection="3d"), rebuilt.vertices,
             rebuilt.faces, f"degrees up to {l}", view=view)
    target = out / "harmonics_lowpass.png"
    fig.savefig(target, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return [f"wrote {target} (fit to degree {max(cutoffs)} in {seconds:.2f} s)"]


def remesh_picture(out: Path, small: bool) -> List[str]:
    """A corpus mesh, its icosphere remeshes and its octahedral geometry image."""
    mesh = corpus_or("spot", lambda: sp.datasets.bumpy_blob(600 if small else 3000), small)
    m = certified_map(mesh)
    levels = [2, 3] if small else [3, 4, 5]
    fig = plt.figure(figsize=(3.4 * (len(levels) + 2), 3.6))
    fig.subplots_adjust(wspace=0, left=0, right=1)
    view = (15, -30)
    panels = len(levels) + 2
    draw(fig.add_subplot(1, panels, 1, projection="3d"), m.mesh.vertices, m.mesh.faces,
         f"input ({m.mesh.n_vertices} vertices)", view=view, edges=True)
    lines = []
    for i, level in enumerate(levels):
        start = time.perf_counter()
        r = sp.remesh_map(m, level=level)
        seconds = time.perf_counter() - start
        d = sp.surface_distance(m, r, samples=20_000)
        draw(fig.add_subplot(1, panels, i + 2, projection="3d"), r.mesh.vertices, r.mesh.faces,
             f"icosphere level {level}: {r.mesh.n_vertices} vertices\n"
             f"distance max {d['max']:.1e}, rms {d['rms']:.1e}", view=view, edges=True)
        lines.append(f"remesh level {level}: {seconds:.3f} s, distance max {d['max']:.2e} "
                     f"rms {d['rms']:.2e}")
    g = sp.geometry_image(m, 65 if small else 257)
    lo, hi = g.reshape(-1, 3).min(0), g.reshape(-1, 3).max(0)
    ax = fig.add_subplot(1, panels, panels)
    ax.imshow((g - lo) / (hi - lo), origin="lower", interpolation="nearest")
    ax.set_axis_off()
    ax.set_title(f"octahedral geometry image {g.shape[0]} x {g.shape[1]}\n(x, y, z as RGB)",
                 fontsize=9)
    target = out / "remesh.png"
    fig.savefig(target, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return lines + [f"wrote {target}"]


def morph_picture(out: Path, small: bool) -> List[str]:
    """Fig. 8.2's analogue: frames of one corpus mesh morphing into another,
    as a strip and an animated GIF."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    a = corpus_or("spot", lambda: sp.datasets.bumpy_blob(500 if small else 3000), small)
    b = corpus_or("igea", lambda: sp.datasets.ellipsoid(400 if small else 3000,
                                                        axes=(1.4, 1.0, 0.7)), small)
    # Same centre and size, so that the frames between show both shapes.
    a, b = (sp.Mesh((x.vertices - x.vertices.mean(0)) / np.ptp(x.vertices, axis=0).max(), x.faces)
            for x in (a, b))
    m_a, m_b = certified_map(a), certified_map(b)
    start = time.perf_counter()
    mo = sp.morph(m_a, m_b)
    # Turn B into A's pose (the spatial rotation the alignment found) so that
    # the frames between do not pass through a flattened shape; same map.
    turned = sp.Mesh(m_b.mesh.vertices @ mo.alignment["spatial_rotation"], m_b.mesh.faces)
    m_b = sp.SphereMap.from_points(turned, m_b.points)
    mo = sp.morph(m_a, m_b)
    seconds = time.perf_counter() - start
    times = [0.0, 0.5, 1.0] if small else [0.0, 0.25, 0.5, 0.75, 1.0]
    frames = [mo.at(t).vertices for t in times]
    view = (15, -30)
    fig = plt.figure(figsize=(3.2 * len(times), 3.6))
    fig.subplots_adjust(wspace=0, left=0, right=1)
    for i, (t, v) in enumerate(zip(times, frames)):
        draw(fig.add_subplot(1, len(times), i + 1, projection="3d"), v, mo.faces, f"t = {t:g}",
             view=view)
    strip = out / "morph.png"
    fig.savefig(strip, dpi=80, bbox_inches="tight")
    plt.close(fig)
    fig = plt.figure(figsize=(3.6, 3.6))
    ax = fig.add_subplot(projection="3d")
    steps = np.linspace(0, 1, 5 if small else 25)

    def frame(k: int) -> None:
        ax.clear()
        t = steps[min(k, len(steps) - 1)] if k < len(steps) else steps[2 * len(steps) - 1 - k]
        draw(ax, mo.at(t).vertices, mo.faces, f"t = {t:.2f}", view=view)

    gif = out / "morph.gif"
    FuncAnimation(fig, frame, frames=2 * len(steps)).save(gif, writer=PillowWriter(fps=10),
                                                          dpi=60)
    plt.close(fig)
    al = mo.alignment
    return [f"morph: {len(mo.start)} -> {len(m_b.points)} vertices, aligned from {al['start']} "
            f"in {al['iterations']} steps, residual {al['residual']:.3g}, {seconds:.2f} s",
            f"wrote {strip} and {gif}"]


def texture_picture(out: Path, small: bool) -> List[str]:
    """Fig. 8.3's analogue: a checkerboard on a corpus animal through the cube
    projection, and a latitude-longitude grid through equirectangular."""
    mesh = corpus_or("spot", lambda: sp.datasets.bumpy_blob(500 if small else 3000), small)
    m = certified_map(mesh)
    fig = plt.figure(figsize=(14, 4.2))
    fig.subplots_adjust(wspace=0.02, left=0, right=1)
    lines = []
    for k, (projection, pattern) in enumerate([("cube", sp.datasets.checkerboard),
                                              ("equirectangular", sp.datasets.lat_long_grid)]):
        start = time.perf_counter()
        t = sp.texture.uv(m, projection)
        image = t.bake(pattern, 256 if small else 1024)
        seconds = time.perf_counter() - start
        # Each face cut in 16 for the picture; colour sampled from the atlas
        # at each small triangle's centre (its UV, interpolated linearly).
        V, F, uv = m.mesh.vertices, m.mesh.faces, t.uv
        n = 4
        tri_v, tri_c = [], []
        for i in range(n):
            for j in range(n - i):
                for w in ([(i, j), (i + 1, j), (i, j + 1)],
                          [(i + 1, j), (i + 1, j + 1), (i, j + 1)]):
                    if max(a + b for a, b in w) > n:
                        continue
                    bary = np.array([[1 - (a + b) / n, a / n, b / n] for a, b in w])
                    tri_v.append(np.einsum("kj,fjd->fkd", bary, V[F]))
                    centre = bary.mean(0)
                    tri_c.append(t.sample(image, np.arange(len(F)), np.tile(centre, (len(F), 1))))
        verts = np.concatenate(tri_v)
        colors = np.concatenate(tri_c)
        flat_v = verts.reshape(-1, 3)
        flat_f = np.arange(len(flat_v)).reshape(-1, 3)
        draw(fig.add_subplot(1, 4, 2 * k + 1, projection="3d"), flat_v, flat_f,
             f"{projection}: {pattern.__name__}", colors=colors, view=(15, -30))
        ax = fig.add_subplot(1, 4, 2 * k + 2)
        ax.imshow(image, interpolation="nearest")
        ax.set_axis_off()
        ax.set_title(f"its atlas ({image.shape[1]} x {image.shape[0]})", fontsize=9)
        lines.append(f"texture {projection}: {seconds:.3f} s")
    target = out / "texture.png"
    fig.savefig(target, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return lines + [f"wrote {target}"]


def plots_picture(out: Path, small: bool) -> List[str]:
    """sp.plot.sphere: where the map stretches, on the surface and the sphere."""
    mesh = corpus_or("spot", lambda: sp.datasets.bumpy_blob(500 if small else 3000), small)
    m = certified_map(mesh)
    lines = []
    for color in ("area", "conformal"):
        target = out / f"plot_sphere_{color}.png"
        sp.plot.sphere(m, color=color, view=(15, -30), path=target)
        lines.append(f"wrote {target}")
    return lines


PICTURES: Dict[str, Callable[[Path, bool], List[str]]] = {
    "harmonics": harmonics_picture,
    "remesh": remesh_picture,
    "morph": morph_picture,
    "texture": texture_picture,
    "plots": plots_picture,
}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    parser.add_argument("--small", action="store_true", help="small generated shapes only")
    parser.add_argument("--only", nargs="*", choices=list(PICTURES), default=list(PICTURES))
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in args.only:
        for line in PICTURES[name](out, args.small):
            print(line)


if __name__ == "__main__":
    main()
