"""Headless pictures of meshes and sphere maps (matplotlib, Agg backend):
for the docs and for notebooks. ``pip install matplotlib`` (or the
``plot`` extra); importing this module does not need it, calling does.

    fig = sp.plot.mesh(mesh)                       # shaded surface
    fig = sp.plot.sphere(m, color="area")          # the map, coloured by distortion
    fig = sp.plot.rectangle(m)                     # theta-phi's rectangle (6.4)
    fig.savefig("map.png")  or  sp.plot.mesh(mesh, path="mesh.png")

Each returns the matplotlib Figure (and, with ``path``, also writes a PNG
and closes the figure).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, List, Optional, Tuple, Union

import numpy as np

from ._errors import MeshError
from ._mesh import MeshLike, as_mesh
from ._quality import face_quality
from ._spheremap import SphereMap, ThetaPhiMap

__all__ = ["COLORS", "UPS", "mesh", "rectangle", "sphere"]

#: What :func:`sphere` can colour by: the per-face measures of
#: :func:`spherify.face_quality`, and "flipped" (faces failing the exact test).
COLORS = ("area", "angle", "conformal", "stretch", "flipped", "none")
_LIGHT = np.array([0.3, 0.4, 0.85]) / np.linalg.norm([0.3, 0.4, 0.85])
#: Which axis of the model is drawn upwards (``up=``): most models from scans
#: and other tools (OBJ, glTF) are Y-up, spherify's generated shapes Z-up.
UPS = ("z", "y", "x")
# The rotations (cyclic permutations, so orientation is kept) that take each
# ``up`` axis to matplotlib's vertical z: new (x, y, z) = old columns.
_UP_COLUMNS = {"z": [0, 1, 2], "y": [2, 0, 1], "x": [1, 2, 0]}


def _check_up(up: str) -> None:
    if up not in _UP_COLUMNS:
        raise MeshError(f"up must be one of {', '.join(UPS)}, got {up!r}")


def _upright(V: np.ndarray, up: str) -> np.ndarray:
    """``V`` turned so that its ``up`` axis is drawn upwards."""
    _check_up(up)
    turned: np.ndarray = V[:, _UP_COLUMNS[up]]
    return turned


def _pyplot() -> Any:
    # Imported by name: matplotlib is optional, and the package type-checks
    # without it.
    try:
        matplotlib: Any = importlib.import_module("matplotlib")
    except ImportError as err:
        raise ImportError("spherify.plot needs matplotlib: pip install matplotlib") from err
    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        matplotlib.use("Agg")
    return importlib.import_module("matplotlib.pyplot")


def _draw(ax: Any, V: np.ndarray, F: np.ndarray, values: Optional[np.ndarray], cmap: str,
          limits: Optional[Tuple[float, float]], view: Tuple[float, float], edges: bool,
          rgb: Optional[np.ndarray] = None) -> Any:
    plt = _pyplot()
    poly3d: Any = importlib.import_module("mpl_toolkits.mplot3d.art3d").Poly3DCollection
    tri = V[F]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None] + 1e-300
    shade = 0.4 + 0.6 * np.clip(normal @ _LIGHT, 0, 1)
    mappable = None
    if rgb is not None:
        colours = np.c_[np.clip(np.nan_to_num(rgb[:, :3]), 0, 1) * shade[:, None],
                        np.ones(len(rgb))]
    elif values is None:
        colours = plt.cm.Greys(0.25 + 0.6 * shade)
    else:
        lo, hi = limits if limits is not None else (np.nanmin(values), np.nanmax(values))
        norm = plt.Normalize(lo, hi if hi > lo else lo + 1)
        colours = plt.get_cmap(cmap)(norm(np.nan_to_num(values, nan=lo)))
        colours[:, :3] *= shade[:, None]
        mappable = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    ax.add_collection3d(poly3d(tri, facecolors=colours, linewidth=0.15 if edges else 0,
                                         edgecolor=(0, 0, 0, 0.4) if edges else "none"))
    lo3, hi3 = V.min(0), V.max(0)
    c, r = (lo3 + hi3) / 2, max(float((hi3 - lo3).max()) / 2, 1e-300)
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1), zoom=1.3)
    ax.view_init(*view)
    ax.set_axis_off()
    return mappable


def _finish(fig: Any, path: Optional[Union[str, Path]]) -> Any:
    if path is not None:
        fig.savefig(path, dpi=100, bbox_inches="tight")
        _pyplot().close(fig)
    return fig


def mesh(surface: MeshLike, *, values: Any = None, colors: Any = None, cmap: str = "viridis",
         limits: Optional[Tuple[float, float]] = None, title: Optional[str] = None,
         view: Tuple[float, float] = (20, -60), edges: bool = False, ax: Any = None,
         path: Optional[Union[str, Path]] = None, up: str = "z") -> Any:
    """A shaded picture of a mesh, optionally coloured per face.

    Parameters
    ----------
    surface : Mesh or (V, F)
        The mesh (or another library's mesh, as for :class:`spherify.Mesh`).
    values : (m,) array_like of float, optional
        Per-face values drawn through ``cmap`` over ``limits`` (default their
        range; NaN drawn at the low end).
    colors : (m, 3) array_like of float, optional
        Per-face RGB in [0, 1], instead of ``values``.
    cmap : str
        A matplotlib colour map name.
    limits : (float, float), optional
        The range of ``values`` the colour map spans.
    title : str, optional
        The axis title (default: the mesh's repr).
    view : (float, float)
        Elevation and azimuth of the camera, in degrees.
    edges : bool
        Draw the triangle edges.
    ax : matplotlib 3D axis, optional
        An axis to draw into (default: a new figure).
    path : str or pathlib.Path, optional
        Also write the picture as PNG there, and close the figure.
    up : {"z", "y", "x"}
        The model's axis drawn upwards: ``"y"`` for the many models that are
        Y-up (scans, OBJ and glTF files), which ``"z"`` shows lying down.

    Returns
    -------
    matplotlib.figure.Figure
    """
    surface = as_mesh(surface)
    vertices = _upright(surface.vertices, up)
    plt = _pyplot()
    if ax is None:
        fig = plt.figure(figsize=(5, 5))
        ax = fig.add_subplot(projection="3d")
    fig = ax.figure
    vals = rgb = None
    if values is not None:
        vals = np.asarray(values, dtype=np.float64)
        if vals.shape != (surface.n_faces,):
            raise MeshError(f"values must have one entry per face ({surface.n_faces}), "
                            f"got shape {vals.shape}")
    if limits is not None:
        bounds = np.asarray(limits, dtype=np.float64)
        if bounds.shape != (2,) or not np.isfinite(bounds).all() or not bounds[0] < bounds[1]:
            raise MeshError(f"limits must be (low, high) with low < high, got {limits!r}")
        limits = (float(bounds[0]), float(bounds[1]))
    if colors is not None:
        rgb = np.asarray(colors, dtype=np.float64)
        if rgb.ndim != 2 or rgb.shape[0] != surface.n_faces or rgb.shape[1] not in (3, 4):
            raise MeshError(f"colors must be (m, 3) RGB per face, got shape {rgb.shape}")
    mappable = _draw(ax, vertices, surface.faces, vals, cmap, limits, view, edges, rgb)
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, shrink=0.6)
    ax.set_title(title if title is not None else repr(surface), fontsize=9)
    return _finish(fig, path)


def sphere(m: SphereMap, *, color: str = "area", view: Tuple[float, float] = (20, -60),
           edges: bool = False, path: Optional[Union[str, Path]] = None,
           up: str = "z") -> Any:
    """The map on the sphere beside the surface, both coloured by how the map
    distorts each face, so one sees where it stretches.

    Parameters
    ----------
    m : SphereMap
        The map to draw.
    color : str
        ``"area"`` (log of the face's area share on the sphere over its
        share on the mesh: red grows, blue shrinks), ``"angle"`` (largest
        angle change, degrees), ``"conformal"`` (sigma1 / sigma2),
        ``"stretch"`` (Sander et al.), ``"flipped"`` (faces failing the exact
        orientation test of 3.4 in red), or ``"none"``.
    view : (float, float)
        Elevation and azimuth of the camera, in degrees.
    edges : bool
        Draw the triangle edges.
    path : str or pathlib.Path, optional
        Also write the picture as PNG there, and close the figure.
    up : {"z", "y", "x"}
        The model's axis drawn upwards (``"y"`` for Y-up models); the sphere
        is turned the same way.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if color not in COLORS:
        raise MeshError(f"unknown color {color!r}; available: {', '.join(COLORS)}")
    _check_up(up)
    plt = _pyplot()
    values: Optional[np.ndarray] = None
    cmap, limits, label = "viridis", None, color
    if color == "flipped":
        values = np.zeros(m.mesh.n_faces)
        values[m.report.flipped_faces] = 1.0
        cmap, limits, label = "coolwarm", (0.0, 1.0), f"flipped ({m.flipped} faces)"
    elif color != "none":
        key = {"area": "area_log", "angle": "angle_max_deg", "conformal": "conformal",
               "stretch": "stretch"}[color]
        values = face_quality(m.mesh, m.points)[key]
        if color == "area":
            bound = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 1.0
            cmap, limits, label = "coolwarm", (-bound, bound), "log area ratio (sphere / mesh)"
        elif color == "conformal":
            limits = (1.0, float(np.nanpercentile(values, 99)))
    fig = plt.figure(figsize=(10, 5))
    for k, (V, title) in enumerate([(m.mesh.vertices, "surface"),
                                    (m.points, f"sphere ({m.method}, "
                                               f"{'valid' if m.valid else 'not valid'})")]):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        mappable = _draw(ax, _upright(V, up), m.mesh.faces, values, cmap, limits, view, edges)
        ax.set_title(title, fontsize=9)
    if mappable is not None:
        fig.colorbar(mappable, ax=fig.axes, shrink=0.6, label=label)
    return _finish(fig, path)


def rectangle(m: SphereMap, *, ax: Any = None, path: Optional[Union[str, Path]] = None) -> Any:
    """A theta-phi map's cut mesh in the rectangle [0, pi] x [0, 2 pi]
    (thesis 6.4), with the triangles that are not certified in red.

    Parameters
    ----------
    m : ThetaPhiMap
        A map made by ``method="theta_phi"``.
    ax : matplotlib axis, optional
        An axis to draw into (default: a new figure).
    path : str or pathlib.Path, optional
        Also write the picture as PNG there, and close the figure.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    MeshError
        ``m`` is not a theta-phi map.
    """
    if not isinstance(m, ThetaPhiMap):
        raise MeshError(f"rectangle needs a theta-phi map, got method {m.method!r}")
    plt = _pyplot()
    tp, faces = m.theta_phi, m.cut_mesh.faces
    if ax is None:
        ax = plt.figure(figsize=(4, 7)).add_subplot()
    fig = ax.figure
    ax.triplot(tp[:, 0], tp[:, 1], faces, linewidth=0.15, color="k")
    bad = np.concatenate([m.details["tp_flipped_faces"], m.details["tp_degenerate_faces"]])
    if len(bad):
        ax.triplot(tp[:, 0], tp[:, 1], faces[bad.astype(np.int64)], linewidth=0.5,
                   color="tab:red")
    ax.set_xlim(0, np.pi)
    ax.set_ylim(0, 2 * np.pi)
    ax.set_xlabel("theta")
    ax.set_ylabel("phi")
    ax.set_aspect("equal")
    verdict = "certified flip-free" if m.tp_valid else f"{len(bad)} triangles not certified"
    ax.set_title(f"theta-phi rectangle: {verdict}", fontsize=9)
    return _finish(fig, path)






def __dir__() -> List[str]:
    """Only the public names (PEP 562): dir() lists what __all__ does."""
    return sorted(__all__)
