"""sp.embed: one entry point for every spherical method, a thin call of the
core's own ``embed`` (validation, orientation, the method and its certificate
all happen in Rust)."""

from __future__ import annotations

import functools
import warnings
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _core
from ._errors import MeshError, SpherifyWarning, TopologyError
from ._landmarks import as_landmarks, recorded
from ._mesh import MeshLike, as_mesh
from ._progress import as_callback
from ._spheremap import SphereMap, ThetaPhiMap, warn_if_thin


def methods() -> List[str]:
    """Names accepted by :func:`embed`'s ``method``: the methods of the core."""
    return list(_core.methods())


@functools.lru_cache(maxsize=None)
def _option_table() -> Dict[str, Tuple[Dict[str, Any], ...]]:
    return {method: tuple(rows) for method, rows in _core.method_options().items()}


def method_options(method: str) -> Dict[str, Dict[str, Any]]:
    """The keyword options of ``method`` (a name of :func:`methods`, or
    ``"improve"`` for :func:`improve`), from the core's one table.

    Returns
    -------
    dict
        Option name -> a fresh dict: ``kind`` ("count", "number", "flag",
        "name", "name_or_vertex_pair", "name_or_point" or "points"),
        ``minimum`` (counts), ``choices`` (the names it accepts), ``default``
        (None when the method decides; see ``help``), ``depends_on`` and
        ``default_by`` (a default that depends on another option, such as
        the progressive method's ``max_iter`` on its ``energy``),
        ``requires`` (``(option, name)``: given only with that) and ``help``.

    Raises
    ------
    MeshError
        An unknown method.
    """
    table = _option_table()
    if method not in table:
        raise MeshError(f"unknown method {method!r}; sp.methods() lists {methods()}")
    return {row["name"]: dict(row) for row in table[method]}


def listed(words: Sequence[str], last: str = "and") -> str:
    """'a', 'a and b', 'a, b and c'; with ``last="or"``: 'a, b or c'."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} {last} {words[-1]}"


def methods_taking(names: Sequence[str]) -> List[str]:
    """The methods whose options include every one of ``names``."""
    return [m for m in methods() if all(name in method_options(m) for name in names)]


def stray_options(options: Dict[str, Any], method: str) -> Optional[Tuple[str, List[str], str]]:
    """When ``options`` holds options that ``method`` does not take but other
    methods do (``sp.embed(mesh, poles="graph")`` under the default method):
    what they are ("'poles' is an option of method 'theta_phi'"), the methods
    that take all of them, and the pronoun for them ("it", "them"); else
    None. Shared by :func:`embed` and ``sp.batch``, which refuse such calls
    with a hint; both read the core's table, not a list of their own."""
    taken = method_options(method)
    stray = [name for name in options
             if name not in taken and any(name in method_options(m) for m in methods())]
    if not stray:
        return None
    owners = methods_taking(stray)
    quoted = [repr(name) for name in stray]
    where = (f"method{'s' if len(owners) > 1 else ''} {listed([repr(m) for m in owners])}"
             if owners else "other methods (sp.method_options lists each method's)")
    what = (f"{listed(quoted)} is an option of {where}" if len(stray) == 1
            else f"{listed(quoted)} are options of {where}")
    return what, owners, ("it" if len(stray) == 1 else "them")


def pass_method(owners: List[str], quote: str = '"') -> str:
    """The hint: pass method="theta_phi" (or "relaxation", "gotsman" or "theta_phi")."""
    return f"pass method={listed([f'{quote}{m}{quote}' for m in owners], 'or')}"


def embed(mesh: MeshLike, method: str = "progressive", *, progress: Any = None,
          landmarks: Any = None, **options: Any) -> SphereMap:
    """Map a closed genus-0 mesh onto the unit sphere.

    Parameters
    ----------
    mesh : Mesh or (V, F)
        Closed, connected, manifold, genus 0. Faces that are not consistently
        outward are reoriented first (noted in ``SphereMap.notes``).
    method : str
        One of :func:`methods`; see each method's options in the README. The
        default, ``"progressive"`` with the isometric energy (thesis 9.3.3),
        is a certified GC-embedding of every genus-0 mesh with low
        distortion, long limbs and spikes included; its options are below.
        ``"theta_phi"`` (thesis ch. 6) is the fastest (about 2.5 times faster
        at 10^6 vertices) and gives the thesis's own bijection h, whose
        rectangle is certified on shapes without long limbs; name it to use
        it and its options (``poles``, ``weights``, ``symmetry_eps``, ...):
        given to the default method, they raise :class:`MeshError` saying so.
    progress : bool or callable
        ``True`` draws a text progress bar on stderr; a callable receives
        ``(done, total)``, with ``done`` increasing and ending at ``total``, at
        most about 100 times, from a worker thread. What is counted:
        sources for ``poles="graph"``, vertices inserted for the progressive
        method (below), iterations of at most ``max_iter`` for relaxation,
        Alexa and Gotsman (a run that converges early jumps to ``total``).
        If it raises, the method stops and the exception propagates. Ctrl-C
        stops it in any case. Default ``None``: silent.
    landmarks : mapping or pair, optional
        ``{vertex_id: (x, y, z)}`` or ``(vertex_ids (k,), points (k, 3))``:
        after the method's map, each landmark is moved onto its target
        direction exactly (its stored point is the normalised target)
        through valid maps only, then the method's energy (isometric for
        methods without one) is lowered with the landmarks held; see
        ``crates/sphere/src/methods/progressive/landmarks.rs``. The map
        records them (``m.landmarks``) and ``m.seconds`` gets a
        ``"landmarks"`` stage. Ids out of range or repeated, targets not
        finite or zero, two landmarks at one direction: :class:`MeshError`
        naming them. A method whose map is not valid, or a set no map
        realises (neighbours at opposite points, a face of three landmarks
        upside down, a drag that stalls after its bounded work):
        :class:`MapError` naming the landmarks.
    **options
        Passed to the method (for example ``energy=`` for ``"progressive"``,
        ``poles=`` for ``"theta_phi"``, ``center="kernel"`` for ``"radial"``,
        ``max_iter=`` and ``strict=`` for the iterative methods). An option
        the method does not read raises :class:`MeshError`; it is never
        ignored.

    Other Parameters
    ----------------
    poles : str or (int, int)
        *Theta-phi.* How to choose the poles and the cut path (thesis 6.2):

        * ``"fast_graph"`` (default): two Dijkstra sweeps (6.2.3), O(N log N).
        * ``"graph"``: the exact graph diameter (6.2.2), Dijkstra from every
          vertex in parallel: O(N^2 log N). Measured (bumpy_blob, 2 shared
          cores under load): 0.5 s at 2,000 vertices, 2.6 s at 5,000, 12 s
          at 10,000, 70-85 s at 20,000: about 4.5x per doubling, so some
          30 minutes at 10^5. See ``progress``.
        * ``"physical"``: the farthest pair of vertices in space (6.2.1).
        * ``"symmetry"``: poles and a cut path near a symmetry plane (6.2.5):
          the area-weighted confidence ellipsoid of the face centroids, its
          three principal planes scored by max(|D| / sum |d|, third-moment
          skew) (0 = mirror-symmetric), the vertices within ``symmetry_eps`` of
          the best plane, fast-graph poles and a shortest path inside the
          largest connected piece they form. O(N log N). When the best score
          is above ``symmetry_max_score``, the piece cannot hold a path of 4
          vertices, or the path between its poles is shorter than a quarter
          of the fast-graph pole distance (a plane meeting a helix's tube in
          small loops), it falls back to ``"fast_graph"`` and warns
          (:class:`SpherifyWarning`); ``SphereMap.details["symmetry"]`` records
          the planes, scores, the choice and the reason.
        * ``(north, south)``: the caller's pair of vertex ids.
    symmetry_eps : float or None
        *Theta-phi.* ``poles="symmetry"``: the band half-width of eq. 6.20 in the mesh's
        units (the thesis used 0.3 for its rabbit, whose size it does not
        give). ``None`` (default): the smallest width that holds both ends of
        every edge the plane crosses, so each curve where the plane meets the
        surface is connected.
    symmetry_max_score : float
        *Theta-phi.* ``poles="symmetry"``: fall back when the best plane scores above this
        (in [0, 1]; default 0.05).
    weights : str
        *Theta-phi.* ``"uniform"``, ``"chord"`` (with ``rho``) or ``"mean_value"``.
    max_refinements : int
        *Theta-phi.* Most double-double refinement steps per embedding (default 8). It
        stops earlier once the rectangle is flip-free, or once a step changes
        no coordinate (every further step would give the same bits).
    energy : str
        *Progressive.* ``"isometric"`` (default; symmetric Dirichlet, the
        fastest), ``"balanced"`` (the best quality: Sander's L2 stretch plus
        w (det J + 1 / det J), so that faces neither shrink nor swell, with w
        from 0.02 on nearly round meshes to 1.3 on limbed ones, chosen from the
        map's stretch; stretch and area distortion at or below Praun and
        Hoppe's on 25 of the 26 meshes of issue 22; like ``"stretch"``, it also pays for
        the chord triangles' total area, by which L2 stretch is normalised,
        and is followed by global L-BFGS steps
        on the coarse levels and at the end (not at the end on limbed meshes
        above 50k vertices), which ``max_iter`` and ``tol``
        do not bound; 2.5-3.5 times the isometric energy's CPU time at 200k
        vertices), ``"conformal"``
        (MIPS with a barrier below an area ratio of 1e-5: an exactly
        conformal map of a limbed shape cannot be stored in doubles; on
        smooth meshes the sweeps start from a certified global conformal map,
        or from the radial projection from the vertex mean where that is
        certified and lower in energy, as on nearly round meshes),
        ``"authalic"`` (area plus a small angle term, followed by global
        Gauss-Newton steps towards equal spherical areas on each level and at
        the end; ``max_iter`` and ``tol`` do not bound those) or
        ``"stretch"`` (Sander's L2 stretch, as Praun and Hoppe, with the
        chord-area term of ``"balanced"``).
    max_iter : int
        *Progressive.* Sweeps of the final optimisation (default 5 for ``"isometric"``, 16 for
        ``"balanced"``, 10 for ``"authalic"``, 50 for ``"stretch"``, 100 for
        ``"conformal"``). A ``"balanced"`` map of a limbed mesh above 50k
        vertices takes two sweeps more, in which only the vertices that
        still move (or a neighbour did) are moved.
        Most of the work is done level by level on the way up, and each new
        vertex is moved once as it is inserted; measured on a 200k-vertex
        ``tentacles``, 10 final sweeps instead of 5 change the mean angle
        distortion by under 2 degrees and cost 1.5 times the time.
    tol : float
        *Progressive.* Stop when a sweep lowers the energy by less than this fraction
        (default 1e-4 for ``"balanced"``, 1e-3 for ``"isometric"`` and
        ``"authalic"``, 1e-5 for ``"stretch"`` and ``"conformal"``, which keep
        improving in small steps).

    Returns
    -------
    SphereMap
        ``points`` (n, 3) on the unit sphere, and ``valid`` / ``flipped`` decided
        by the exact tests of thesis 3.4; a :class:`ThetaPhiMap` for
        ``method="theta_phi"``.

    Raises
    ------
    TopologyError
        Not a genus-0 surface; ``err.report`` says why.
    MeshError
        Unknown method or option, or a value out of range. Theta-phi's
        options given to the default method (``sp.embed(mesh,
        poles="symmetry")``) say to pass ``method="theta_phi"``.
    ConvergenceError
        An iterative method with ``strict=True`` did not converge;
        ``err.state["points"]`` holds where it stopped. Also the progressive
        method when a vertex finds no place in double precision even after
        its neighbourhood moved (``err.state["status"] == "insertion_failed"``;
        the message names the vertex).

    Notes
    -----
    ``method="progressive"`` (thesis 9.3.3; Praun and Hoppe 2003) collapses
    the mesh to a tetrahedron, maps that, and re-inserts the vertices one
    level at a time, each at the centre of its ring's kernel, lowering a
    distortion energy with flip-free moves between levels. Every step is
    decided by exact predicates, so the map is a GC-embedding as stored, and
    areas stay in proportion, so long limbs and spikes keep their triangles
    far above double precision (``m.report.min_area_ratio``).
    Its progress counts the method's work from the hierarchy to the final
    sweeps.
    """
    mesh = as_mesh(mesh)
    if "initial" in options and options["initial"] is not None:
        options["initial"] = np.ascontiguousarray(options["initial"], dtype=np.float64)
    pinned = None if landmarks is None else as_landmarks(landmarks)
    ids, targets = (None, None) if pinned is None else pinned
    try:
        core = _core.embed(mesh._core, method, dict(options),
                           as_callback(progress, "graph poles" if method == "theta_phi" else method),
                           ids, targets)
    except MeshError as err:
        stray = stray_options(options, method) if method in methods() else None
        if method != "progressive" or stray is None or isinstance(err, TopologyError):
            raise
        # Old code and habits call sp.embed(mesh, poles=...) without a method:
        # say which method those options belong to.
        what, owners, them = stray
        raise MeshError(f"{err}. {what}, and sp.embed's default method is "
                        f"\"progressive\": {pass_method(owners)} to use {them}") from err
    if core.tp_valid is None:
        plain = SphereMap(core, mesh)
        plain._options = dict(options)
        if ids is not None:
            plain._landmarks = recorded(plain, ids)
        warn_if_thin(plain)
        return plain
    result = ThetaPhiMap(core, mesh)
    result._options = dict(options)
    if not result.tp_valid:
        warnings.warn(f"theta-phi: {result.message}", SpherifyWarning, stacklevel=2)
    warn_if_thin(result)
    symmetry = result.details.get("symmetry")
    if symmetry is not None and symmetry["fallback"] is not None:
        warnings.warn(f"theta-phi: symmetry poles fell back to fast_graph: {symmetry['fallback']}",
                      SpherifyWarning, stacklevel=2)
    return result


def improve(sphere_map: SphereMap, *, progress: Any = None, landmarks: Any = None,
            **options: Any) -> SphereMap:
    """Lower a distortion energy of a valid map with flip-free moves.

    Thesis 9.3.2's local iteration: each vertex moves in the tangent plane by
    a Newton step of ``energy`` (see :func:`embed`'s progressive options), cut
    to the largest step that keeps its faces positive (each det is linear in
    the step) and accepted only after the exact orientation test of its faces
    on the stored doubles. Started from a theta-phi, Alexa or Gotsman map, it
    removes theta-phi's visible seam. The result is never less valid than the
    start: a plain GC-embedding with ``method == "improve"`` (theta-phi's map
    h no longer describes the moved points; ``to_sphere`` / ``to_surface``
    use the barycentric map of thesis 3.3).

    Parameters
    ----------
    sphere_map : SphereMap
        A valid map (``sphere_map.valid``).
    progress : callable or True, optional
        ``(done, total)`` after every sweep; ``True`` shows a bar.
    landmarks : mapping or pair, optional
        As for :func:`embed`: pinned exactly after the improvement, then the
        energy is lowered again with them held. Without it, a map that had
        landmarks keeps them only if they still sit on their points (they
        are not held by a plain ``improve``): pass ``m.landmarks`` to keep them.
    **options
        ``energy`` ("isometric"; any of the progressive method's), ``max_iter``
        (30 sweeps), ``tol`` (stop when a sweep lowers the energy by less
        than this fraction; 1e-3) and, with ``landmarks``, ``max_vertices``
        (the most vertices a layout may refine the mesh to, beyond which the
        set is refused with a MapError; unset: 16 times the mesh's
        vertices, or 200,000 more): ``sp.method_options("improve")`` gives
        the core's table with the defaults it runs with.

    Raises
    ------
    MapError
        ``sphere_map`` is not a valid GC-embedding (``sphere_map.valid`` is False).
    MeshError
        An unknown energy or a value out of range; bad landmarks (as for
        :func:`embed`).
    MapError
        Also a set of landmarks no map realises, or none within
        ``max_vertices``.
    """
    pinned = None if landmarks is None else as_landmarks(landmarks)
    ids, targets = (None, None) if pinned is None else pinned
    core = _core.improve(sphere_map._core, dict(options), as_callback(progress, "improve"),
                         ids, targets)
    result = SphereMap(core, sphere_map.mesh)
    if ids is not None:
        result._landmarks = recorded(result, ids)
    warn_if_thin(result)
    return result
