"""Peak memory of the applications per unit of their size (issue 26, the
acceptance item "under a 4 GB address-space limit no documented call ends in
a signal"): the rates of docs/reliability.md's "Memory" table and of
``crates/sphere/src/memory_budget.rs``.

Each call runs in a fresh process: the map (a ``from_points`` icosphere, or
an ellipsoid for the second shape of a pair) and its point locator are made
first, then the resident peak is reset (``/proc/self/clear_refs``) and the
call made; the rate is the growth of ``VmHWM`` per unit (map vertex, point,
pixel, sample), at two sizes so that a rate that grows with the size shows.

    python benches/memory_rates.py [CALL ...]
"""

from __future__ import annotations

import subprocess
import sys
from typing import Dict, List, Tuple

# Setup, the call and its unit count, for a size n; the setup makes what the
# call is given (a made map, its built locator), the call is what is measured.
CALLS: Dict[str, Tuple[str, str, str]] = {
    "point_map": ("m = big_map(n)", "m.to_surface(np.array([[0, 0, 1.0]]))", "n"),
    "to_surface": ("m = small_map(); p = points(n)", "m.to_surface(p)", "n"),
    "to_sphere": ("m = small_map(); f = np.zeros(n, np.int64); b = np.full((n, 3), 1 / 3)",
                  "m.to_sphere(f, b)", "n"),
    "harmonics.fit": ("m = small_map(); lmax = int((n / 2) ** 0.5) - 1",
                      "sp.harmonics.fit(m, lmax)", "2 * (lmax + 1) ** 2"),
    "harmonics.evaluate": ("h = sp.harmonics.fit(small_map(), 32); p = points(n)",
                           "h.evaluate(p)", "n"),
    "remesh": ("m = small_map(); level = {100_000: 7, 400_000: 8}[n]",
               "sp.remesh(m, level=level)", "10 * 4 ** level + 2"),
    "geometry_image": ("m = small_map(); size = int(n ** 0.5) | 1",
                       "sp.geometry_image(m, size)", "size * size"),
    "from_geometry_image": ("size = int(n ** 0.5) | 1; g = sp.geometry_image(small_map(), size)",
                            "sp.from_geometry_image(g)", "size * size"),
    "uv.cube": ("m = big_map(n)", "sp.texture.uv(m, 'cube')", "n"),
    "uv.equirectangular": ("m = big_map(n)", "sp.texture.uv(m, 'equirectangular')", "n"),
    "uv.octahedral": ("m = big_map(n)", "sp.texture.uv(m, 'octahedral')", "n"),
    "bake": ("t = sp.texture.uv(small_map(), 'cube'); h = int((n / 1.5) ** 0.5)",
             "t.bake(sp.datasets.checkerboard, h)", "h * round(1.5 * h)"),
    "morph": ("a = big_map(n); b = other_map(n)", "sp.morph(a, b, align='none')", "n"),
    "register.rotation": ("a = big_map(n); b = other_map(n)",
                          "sp.register(a, b, transform='rotation')", "n"),
    "register.warp": ("a = big_map(n); b = other_map(n)",
                      "sp.register(a, b, transform='warp')", "n"),
    "correspond": ("a = big_map(n); b = other_map(n)",
                   "sp.correspond([a, b], level=5, transform='rotation')", "n"),
    "quality": ("m = big_map(n); mesh, p = m.mesh, m.points", "sp.quality(mesh, p)", "n"),
    "check": ("mesh = sp.datasets.icosphere(n)", "sp.check(mesh)", "n"),
    "load.ply": ("sp.save(sp.datasets.icosphere(n), path + '.ply')", "sp.load(path + '.ply')",
                 "os.path.getsize(path + '.ply')"),
    "load.stl": ("sp.save(sp.datasets.icosphere(n), path + '.stl')", "sp.load(path + '.stl')",
                 "os.path.getsize(path + '.stl')"),
    "load.obj": ("sp.save(sp.datasets.icosphere(n), path + '.obj')", "sp.load(path + '.obj')",
                 "os.path.getsize(path + '.obj')"),
}

CHILD = """
import os, numpy as np, spherify as sp
n, path = {n}, {path!r}
def unit(x): return x / np.linalg.norm(x, axis=1)[:, None]
def points(k): return unit(np.random.default_rng(0).normal(size=(k, 3)))
def big_map(k):
    ico = sp.datasets.icosphere(k)
    return sp.SphereMap.from_points(ico, ico.vertices)
def other_map(k):
    e = sp.datasets.ellipsoid(k)
    return sp.SphereMap.from_points(e, unit(e.vertices - e.vertices.mean(0)))
def small_map():
    m = big_map(2000)
    m.to_surface(np.array([[0, 0, 1.0]]))
    return m
{setup}
def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) * 1024
    return 0
with open("/proc/self/clear_refs", "w") as clear:
    clear.write("5")
before = status("VmHWM:")
result = {call}
print(status("VmHWM:") - before, {unit})
"""


def measure(name: str, n: int) -> Tuple[int, int]:
    """(bytes of resident growth, units) of ``name`` at size ``n``, in a fresh process."""
    setup, call, unit = CALLS[name]
    code = CHILD.format(n=n, path=f"/tmp/memory_rates_{n}", setup=setup, call=call, unit=unit)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{name} at {n}: {done.stderr[-2000:]}")
    grown, units = done.stdout.split()
    return int(grown), int(units)


def main(names: List[str]) -> None:
    """Print each call's growth per unit at 100k and 400k units."""
    for name in names or list(CALLS):
        row = [name]
        for n in (100_000, 400_000):
            grown, units = measure(name, n)
            row.append(f"{grown / units:,.0f} ({units:,})")
        print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
