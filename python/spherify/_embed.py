"""sp.embed: one entry point for every spherical method."""

from __future__ import annotations

import warnings
from typing import Any, Callable, Dict, List

from . import _core
from ._errors import MeshError, SpherifyWarning, TopologyError
from ._mesh import MeshLike, as_mesh, check, orient
from ._spheremap import SphereMap


def _methods() -> Dict[str, Callable[..., Any]]:
    """The spherical methods the compiled core provides, by name."""
    prefix = "embed_"
    return {name[len(prefix):]: getattr(_core, name) for name in dir(_core)
            if name.startswith(prefix)}


def methods() -> List[str]:
    """Names accepted by :func:`embed`'s ``method``."""
    return sorted(_methods())


def embed(mesh: MeshLike, method: str = "theta_phi", **options: Any) -> SphereMap:
    """Map a closed genus-0 mesh onto the unit sphere.

    Parameters
    ----------
    mesh : Mesh or (V, F)
        Closed, connected, manifold, genus 0. Faces that are not consistently
        outward are reoriented first (noted in ``SphereMap.notes``).
    method : str
        One of :func:`methods`; see each method's options in the README. The
        default, ``"theta_phi"`` (thesis ch. 6), is a bijection for every
        genus-0 mesh; its options are ``poles`` ("fast_graph", "graph",
        "physical" or a ``(north, south)`` pair), ``weights`` ("uniform",
        "chord" with ``rho``, "mean_value") and ``max_refinements``.
    **options
        Passed to the method (for example ``center="kernel"`` for ``"radial"``,
        ``max_iter=`` and ``strict=`` for the iterative methods).

    Returns
    -------
    SphereMap
        ``points`` (n, 3) on the unit sphere, and ``valid`` / ``flipped`` decided
        by the exact tests of thesis 3.4.

    Raises
    ------
    TopologyError
        Not a genus-0 surface; ``err.report`` says why.
    MeshError
        Unknown method or option, or a value out of range.
    ConvergenceError
        An iterative method with ``strict=True`` did not converge;
        ``err.state["points"]`` holds where it stopped.
    """
    mesh = as_mesh(mesh)
    available = _methods()
    if method not in available:
        raise MeshError(f"unknown method {method!r}; available: {', '.join(sorted(available))}")
    report = check(mesh)
    if not report.is_sphere_topology:
        raise TopologyError("embed needs a closed, connected, manifold genus-0 mesh: "
                            + "; ".join(report.problems), report)
    notes: List[str] = []
    if not (report.consistently_oriented and report.outward):
        mesh, info = orient(mesh, return_info=True)
        notes.append(f"reoriented {info['flipped_faces']} faces to face outward")
    try:
        points, info = available[method](mesh._core, **options)
    except TypeError as err:
        raise MeshError(f"method {method!r}: {err}") from None
    result = SphereMap(mesh, points, method, info, notes)
    if method == "theta_phi" and not result.tp_valid:
        warnings.warn(f"theta-phi: {result.message}", SpherifyWarning, stacklevel=2)
    return result
