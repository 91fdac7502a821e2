"""SphereMap and ThetaPhiMap: the results of :func:`spherify.embed`.

A map holds the core's result, certificate included. Everything that
describes the certificate is a read-only property read from the core, and
every array it hands out is read-only: ``to_surface`` asks the core, which
never takes a verdict back from Python.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Dict, List, Literal, Optional, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

from . import _args, _core
from ._errors import MeshError, SpherifyWarning
from ._mesh import Mesh, MeshLike, as_mesh
from ._report import SphereReport

#: A certified map whose smallest triangle is below this fraction of the mean
#: comes with a :class:`SpherifyWarning`: its thinnest triangles are within a
#: few thousand units in the last place of collapsing, so the map can send
#: distinct surface points to the same doubles (issue 13, item 8).
THIN_MARGIN = 1e-12

#: ``to_surface`` warns (:class:`SpherifyWarning`) when the error bound of
#: some answer exceeds this fraction of the mesh's bounding-box diagonal: the
#: sphere point then does not hold enough digits to say precisely where on the
#: surface it came from (a nearly flat triangle of the map; issue 13, item 7).
INACCURATE_POINT = 1e-9


def warn_if_thin(m: "SphereMap", stacklevel: int = 3) -> None:
    """The :data:`THIN_MARGIN` warning for a certified map ``m``."""
    certified = m.tp_valid if isinstance(m, ThetaPhiMap) else m.valid
    margin = m.margin
    if certified and margin < THIN_MARGIN:
        warnings.warn(f"the map is certified, but its smallest triangle is {margin:.2g} of the mean "
                      f"(below {THIN_MARGIN:g}): distinct surface points may map to the same "
                      "doubles", SpherifyWarning, stacklevel=stacklevel)


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def _refined_mesh(given: Mesh, core: _core.CoreSphereMap,
                  refinement: Tuple[np.ndarray, np.ndarray]) -> Mesh:
    """The refined mesh of a landmark layout, as a :class:`Mesh` whose
    per-vertex attributes are carried over from ``given`` through the map
    back. ``given`` is the input or an earlier refinement of it (an
    ``improve`` that refined again): edge splits only append vertices, so
    its first rows are the input's own, which the map back names."""
    source = core.refinement_input
    assert source is not None
    input_faces = Mesh._from_core(source, [], {}).faces[refinement[0]]
    n_input = source.n_vertices
    carried = {name: np.einsum("nk,nkd->nd", refinement[1], values[:n_input][input_faces])
               for name, values in given.attributes.items()
               if getattr(values, "ndim", 0) == 2 and len(values) == len(given.vertices)}
    added = len(refinement[0]) - len(given.vertices)
    note = (f"refined by {added} edge splits to lay out landmarks "
            "(SphereMap.refinement maps it back to SphereMap.input_mesh)")
    return Mesh._from_core(core.mesh, list(given.notes) + [note], carried)


class SphereMap:
    """Points on the unit sphere, one per vertex, and the verdict on them.

    Every map also has ``to_sphere`` (the map h from surface points to the
    sphere) and ``to_surface`` (its inverse), see below. All attributes are
    read-only.

    Attributes
    ----------
    mesh : Mesh
        The (consistently, outward oriented) mesh the map belongs to: the
        input itself when it needed no reorientation.
    points : (n, 3) float64
        One point on the unit sphere per input vertex, in the input's order.
    method : str
        The method that made the map (one of :func:`spherify.methods`), or
        ``"points"`` for a map given to :meth:`from_points`.
    iterations : int
        Iterations of an iterative method (refinement steps for theta-phi).
    converged : bool
        Whether the method reached its own stopping criterion.
    status : str
        ``"converged"``, ``"direct"``, ``"max_iterations"`` or ``"collapsed"``.
    message : str
        Why the method stopped, in words.
    seconds : dict of str to float
        Time per stage, ending with ``"certify"`` (the exact test of 3.4);
        ``"landmarks"`` when the map was pinned to landmarks.
    landmarks : (ids, points) or None
        The landmarks the map was pinned to (see the property).
    report : SphereReport
        The exact validity verdict of thesis 3.4 on ``points``, computed in
        the core with the points.
    valid, flipped
        See the properties below.
    notes : list of str
        What was done to the input on the way (e.g. faces reoriented).
    details : dict
        What the method computed besides the points (radial: ``center``,
        ``kernel_depth``, ``lp_pivots``; theta-phi: see :class:`ThetaPhiMap`).
    """

    def __init__(self, core: _core.CoreSphereMap, mesh: Mesh) -> None:
        self._core = core
        if core.reoriented_faces:
            mesh = Mesh._from_core(core.mesh, list(mesh.notes), dict(mesh.attributes))
        refinement = core.refinement
        if refinement is not None:
            for array in refinement:
                array.flags.writeable = False
            if len(mesh.vertices) != len(refinement[0]):
                mesh = _refined_mesh(mesh, core, refinement)
        self._refinement: Optional[Tuple[np.ndarray, np.ndarray]] = refinement
        self._mesh = mesh
        self._points = _read_only(core.points())
        self._report: SphereReport = core.report()
        _read_only(self._report.flipped_faces)
        self._details: Optional[Dict[str, Any]] = None
        self._notes = ([f"reoriented {core.reoriented_faces} faces to face outward"]
                       if core.reoriented_faces else [])
        self._options: Dict[str, Any] = {}
        # What a restored map carries over as information (seconds of the run
        # that made it, details the core does not recompute); None when made here.
        self._stored_seconds: Optional[List[Tuple[str, float]]] = None
        self._stored_details: Dict[str, Any] = {}
        self._diagonal_cache: Optional[float] = None
        # (ids, points) of a map pinned by landmarks= (see _landmarks.recorded).
        self._landmarks: Optional[Tuple[np.ndarray, np.ndarray]] = None

    @classmethod
    def _restored(cls, core: _core.CoreSphereMap, mesh: Mesh, *, seconds: List[Tuple[str, float]],
                  notes: List[str], options: Dict[str, Any],
                  details: Dict[str, Any]) -> "SphereMap":
        """A map rebuilt by :mod:`spherify._persist`: the core certified it
        again; the rest is what was stored."""
        m = cls(core, mesh)
        m._notes = list(notes) + m._notes
        m._options = dict(options)
        m._stored_seconds = list(seconds)
        m._stored_details = dict(details)
        return m

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        # Pickled as the bytes of its .spheremap.npz; unpickling reads them
        # as load_map reads a file and certifies the map again in the core.
        from . import _persist
        return (_persist.unpickle_map, (_persist.map_archive(self), "pickled SphereMap"))

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Write the map to ``path`` (by convention ``*.spheremap.npz``):
        the mesh, points, method, options, account and details, and for
        theta-phi the poles, cut path and rectangle, with a format version.
        Written under a temporary name and renamed into place.
        :func:`spherify.load_map` reads it back and certifies it again."""
        from . import _persist
        _persist.save_map(self, path)

    @property
    def options(self) -> Dict[str, Any]:
        """The options the method was called with (a fresh dict)."""
        return dict(self._options)

    @classmethod
    def from_points(cls, mesh: MeshLike, points: npt.ArrayLike) -> SphereMap:
        """Wrap a map made elsewhere (a FreeSurfer ``?h.sphere``, another
        tool's map, a saved one) as a certified :class:`SphereMap`.

        The core validates and orients the mesh like :func:`spherify.embed`,
        projects every point onto the unit sphere (divides it by its norm, so
        a map given on a sphere of radius 100 is the same map; ``message``
        gives the largest norm error before), and certifies the projected
        points with the exact tests of thesis 3.4. ``valid`` is that verdict,
        computed in the core; ``to_sphere`` and ``to_surface`` are the
        barycentric map of 3.3 and its inverse (``to_surface`` raises
        :class:`MapError` unless ``valid``). ``method`` is ``"points"``.
        Cost: O(n + m), plus O(m log m) on the first ``to_surface``.

        Parameters
        ----------
        mesh : Mesh or (V, F)
            Closed genus-0 mesh; faces that are not consistently outward are
            reoriented (the vertex order, and so the points' order, is kept).
        points : (n, 3) float
            One point per vertex of ``mesh``, in its vertex order: finite and
            not zero. Their orientation must agree with the surface's (faces
            counter-clockwise seen from outside on both): a mirrored map is
            not valid.

        Returns
        -------
        SphereMap

        Raises
        ------
        MeshError
            Wrong shape, not one point per vertex, or a point that is not
            finite or is zero (the row is named).
        TopologyError
            The mesh is not a closed genus-0 surface.
        """
        mesh = as_mesh(mesh)
        core = _core.from_points(mesh._core, _float_rows(points, "points"))
        # SphereMap, not cls: a ThetaPhiMap needs the core's theta-phi data.
        result = SphereMap(core, mesh)
        warn_if_thin(result)
        return result

    @property
    def mesh(self) -> Mesh:
        """The mesh the map belongs to, consistently outward oriented (the input itself when it
        needed no reorientation)."""
        return self._mesh

    @property
    def points(self) -> np.ndarray:
        """(n, 3) float64, read-only: one point on the unit sphere per input vertex, in the
        input's order."""
        return self._points

    @property
    def method(self) -> str:
        """The method that made the map (one of :func:`spherify.methods`), or ``"points"`` for
        :meth:`from_points`."""
        return self._core.method

    @property
    def iterations(self) -> int:
        """Iterations of an iterative method (refinement steps for theta-phi)."""
        return self._core.iterations

    @property
    def converged(self) -> bool:
        """Whether the method reached its own stopping criterion."""
        return self._core.converged

    @property
    def status(self) -> str:
        """``"converged"``, ``"direct"``, ``"max_iterations"`` or ``"collapsed"``."""
        return self._core.status

    @property
    def message(self) -> str:
        """Why the method stopped, in words."""
        return self._core.message

    @property
    def seconds(self) -> Dict[str, float]:
        """Time per stage of the run that made the map (for a loaded map, as
        stored)."""
        if self._stored_seconds is not None:
            return dict(self._stored_seconds)
        return dict(self._core.seconds)

    @property
    def notes(self) -> List[str]:
        """What was done to the input on the way (e.g. faces reoriented)."""
        return list(self._notes)

    @property
    def landmarks(self) -> Optional[Tuple[np.ndarray, np.ndarray]]:
        """``(ids (k,) int64, points (k, 3) float64)``, read-only: the
        landmarks the map was pinned to (``landmarks=`` of
        :func:`spherify.embed` / :func:`spherify.improve`), each point the
        normalised target, exactly the map's point for that id; None
        without landmarks."""
        return self._landmarks

    @property
    def refinement(self) -> Optional[Tuple[np.ndarray, np.ndarray]]:
        """The map back to the input mesh when landmarks were laid out on a
        refined mesh, else None.

        ``(faces (n,) int64, barycentric (n, 3) float64)``, read-only, one row
        per vertex of :attr:`mesh`: the input face ``F[faces[i]]`` that holds
        vertex ``i`` and its barycentric weights in that face's corner order,
        so ``(barycentric[:, :, None] * V[F[faces]]).sum(1)`` gives
        ``mesh.vertices``. Edge splits only append vertices: the first
        ``len(V)`` rows are the input's own vertices (weight 1 at a corner),
        with their ids unchanged. See docs/correspondence.md.
        """
        return self._refinement

    @property
    def input_mesh(self) -> Mesh:
        """The mesh the map was asked for: :attr:`mesh` itself, or for a map
        whose landmarks were laid out on a refined mesh the input before
        the edge splits (its vertices are the first rows of :attr:`mesh`;
        :attr:`refinement` names its faces). Saved and loaded with the map."""
        source = self._core.refinement_input
        if source is None:
            return self._mesh
        n_input = source.n_vertices
        attributes = {name: values[:n_input] for name, values in self._mesh.attributes.items()
                      if getattr(values, "ndim", 0) >= 1 and len(values) == len(self._mesh.vertices)}
        return Mesh._from_core(source, [], attributes)

    @property
    def report(self) -> SphereReport:
        """The exact validity verdict of thesis 3.4 on :attr:`points`, computed in the core."""
        return self._report

    @property
    def margin(self) -> float:
        """The smallest triangle of the certified drawing over the mean
        triangle: on the sphere (``report.min_area_ratio``), or for theta-phi
        in the rectangle, where the bijection h lives. Below
        :data:`THIN_MARGIN` distinct surface points may map to the same
        doubles, and :func:`spherify.embed` warns."""
        return float(self.report.min_area_ratio)

    @property
    def details(self) -> Dict[str, Any]:
        """A fresh dict on every access; its arrays are read-only."""
        if self._details is None:
            # The core's details (recomputed for a loaded map) win over stored ones.
            merged = {**self._stored_details, **self._core.details()}
            self._details = {key: _read_only(value) if isinstance(value, np.ndarray) else value
                             for key, value in merged.items()}
        return dict(self._details)

    @property
    def valid(self) -> bool:
        """True when the points with minor-arc edges form a valid GC-embedding
        (thesis 3.1), proven by the exact orientation test and the area test:
        the map from the mesh to the sphere is then a bijection."""
        return self._core.valid

    @property
    def flipped(self) -> int:
        """Faces failing the orientation test (3.9): upside down or collapsed."""
        return self._report.n_negative + self._report.n_zero

    def to_sphere(self, face_ids: npt.ArrayLike, bary: npt.ArrayLike) -> np.ndarray:
        """Map surface points to the sphere: the homeomorphism h.

        For theta-phi maps this is the thesis's own bijection (6.6): the
        barycentric map into the theta-phi rectangle (h1), the stretch of the
        pole triangles onto the rectangle's top and bottom lines (h2, eq.
        6.44-6.56) and the fold onto the sphere (h3, eq. 6.35). It is a
        bijection whenever ``tp_valid`` holds, even when the folded vertices do
        not form a valid GC-embedding. For the other methods it is the
        barycentric map of thesis 3.3: the same weights of the sphere
        triangle's corners, projected onto the sphere (a bijection when
        ``valid``).

        Parameters
        ----------
        face_ids : (k,) int
            A face per point (the faces of ``mesh`` and of the caller's mesh
            are the same, in the same order).
        bary : (k, 3) float
            Barycentric weights on that face's corners, in the order of the
            faces given to :func:`spherify.embed` (``mesh.faces`` unless faces
            were reoriented, see ``notes``: the reorientation stays inside):
            finite, >= 0 and summing to 1 (within 1e-6; they are rescaled).

        Returns
        -------
        (k, 3) float64
            Unit vectors.

        Raises
        ------
        MeshError
            Wrong shapes, a face id out of range or bad weights (the row is named).
        """
        _args.refuse_lossy(face_ids, "face_ids")
        ids = np.asarray(face_ids)
        if ids.dtype.kind not in "iu":
            raise MeshError(f"face_ids must be integers, got dtype {ids.dtype}")
        return self._core.to_sphere(ids.astype(np.int64, copy=False), _float_rows(bary, "bary"))

    @overload
    def to_surface(self, points: npt.ArrayLike, *, error_bound: Literal[False] = ...
                   ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    @overload
    def to_surface(self, points: npt.ArrayLike, *, error_bound: Literal[True]
                   ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...

    def to_surface(self, points: npt.ArrayLike, *, error_bound: bool = False
                   ) -> Union[Tuple[np.ndarray, np.ndarray, np.ndarray],
                              Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Map points of the unit sphere back to the surface: h^-1.

        Each point is located among the cells of the map (a box tree; O(log F)
        per point, in parallel) with exact orientation predicates, so that a
        certified map is inverted into the right cell however thin its
        triangles are; then the inverse of :meth:`to_sphere` gives the face and
        its barycentric weights. Points on an edge or a vertex get one of the
        faces that share it.

        Where a triangle of the map is nearly flat, the digits of a sphere
        point cannot say precisely where on the surface it came from. Every
        answer carries a bound on its error (``error_bound=True`` returns it);
        when some bound exceeds :data:`INACCURATE_POINT` of the mesh's
        bounding-box diagonal, a :class:`SpherifyWarning` gives their count.

        Parameters
        ----------
        points : (k, 3) float
            Unit vectors (norm within 1e-6 of 1; they are normalised).
        error_bound : bool
            Also return the error bounds.

        Returns
        -------
        face_ids : (k,) int64
            Faces in the order of the mesh given to :func:`spherify.embed`.
        bary : (k, 3) float64
            Barycentric weights on that face's corners, in the order the caller
            gave them (a reorientation by ``embed`` stays inside), >= 0,
            summing to 1.
        xyz : (k, 3) float64
            The surface points themselves.
        error : (k,) float64, only with ``error_bound=True``
            A bound on the distance from ``xyz`` to the exact preimage of every
            sphere point within the rounding error of :meth:`to_sphere` of the
            query (so it also bounds a round trip surface -> sphere ->
            surface); ``inf`` where the point's digits cannot place it.

        Raises
        ------
        MapError
            The map is not a certified bijection (``tp_valid`` False for
            theta-phi, ``valid`` False otherwise), so h^-1 is not defined. The
            verdict is the core's own, whatever was done to this object.
        MeshError
            Wrong shape, or a point that is not a unit vector (the row is named).
        """
        if not isinstance(error_bound, bool):
            raise TypeError(f"error_bound must be True or False, got {error_bound!r}")
        faces, bary, xyz, error = self._core.to_surface(_float_rows(points, "points"))
        diagonal = self._diagonal()
        inaccurate = int(np.count_nonzero(~(error <= INACCURATE_POINT * diagonal)))
        if inaccurate:
            worst = float(np.max(error)) / diagonal if diagonal > 0 else float("inf")
            warnings.warn(f"{inaccurate} of {len(error)} points lie where the map's triangles are "
                          f"nearly flat: their surface points may be off by up to {worst:.2g} of "
                          "the mesh size (to_surface(..., error_bound=True) gives each bound)",
                          SpherifyWarning, stacklevel=2)
        if error_bound:
            return faces, bary, xyz, _read_only(error)
        return faces, bary, xyz

    def _diagonal(self) -> float:
        """The mesh's bounding-box diagonal (computed once)."""
        if self._diagonal_cache is None:
            vertices = self._mesh.vertices
            self._diagonal_cache = (float(np.linalg.norm(np.ptp(vertices, axis=0)))
                                    if len(vertices) else 0.0)
        return self._diagonal_cache

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(method={self.method!r}, n_vertices={len(self.points)}, "
                f"valid={self.valid}, flipped={self.flipped}, status={self.status!r}, "
                f"iterations={self.iterations})")


class ThetaPhiMap(SphereMap):
    """A theta-phi map (thesis ch. 6): a :class:`SphereMap` with the poles,
    the cut and the rectangle it was made from.

    All attributes are read-only.

    Attributes
    ----------
    poles : (int, int)
        The north and south pole vertex ids (thesis 6.2).
    cut_path : (k + 2,) int64
        The path the mesh was cut open along, from north to south pole.
    cut_mesh : Mesh
        The mesh cut open into a disk (thesis 6.3): the input's vertices, then
        one duplicate per inner path vertex; ``cut_original`` maps each of its
        vertices to the input vertex it stands for.
    theta_phi : (n + k, 2) float64
        The (theta, phi) embedding of ``cut_mesh`` in the rectangle
        [0, pi] x [0, 2 pi] (thesis 6.4).
    tp_valid : bool
        The rectangle embedding has no flipped and no zero-area triangle under
        exact predicates: the thesis's bijectivity guarantee, checked in
        floating point. False means double precision could not hold it.
    details : dict
        Refinement steps, pole-fan monotonicity and re-embedding (6.5.1), the
        thinnest triangle relative to the rectangle, and the rectangle's
        flipped / collapsed triangle ids. With ``poles="symmetry"`` also
        ``details["symmetry"]`` (thesis 6.2.5), a dict with

        * ``normals`` (3, 3) float64: unit normals of the three principal
          planes, by ascending ``variances`` (area-weighted variance of the
          face centroids across each plane); ``centre``: the area-weighted
          centroid m (eq. 6.11) all three pass through;
        * ``signed_sums`` (D of eq. 6.18), ``balances`` (|D| / sum |d|),
          ``skews`` (|sum w d^3| / sum w |d|^3) and ``scores`` (the larger of
          the two; 0 for a mirror plane), one per plane;
        * ``chosen`` (index of the best plane or None), its ``normal`` and
          ``score``;
        * ``eps`` (band half-width used), ``band`` (vertices within it),
          ``component`` (vertices in its largest connected piece),
          ``symmetry_poles`` (the poles found in it, or None), ``spread``
          (the length of the path between them inside the piece over the
          fast-graph pole distance; NaN when not reached);
        * ``fallback``: None when the poles and cut path came from the plane,
          else why the fast-graph poles were used instead.
    """

    @property
    def margin(self) -> float:
        """The smallest triangle of the theta-phi rectangle over the mean
        triangle of the rectangle: the margin of the bijection h, which lives
        in the rectangle. (``details["min_area_ratio"]`` is over the whole
        rectangle, so it is multiplied by the number of cut-mesh faces: the
        mesh's own, since cutting relabels corners and adds no face. Asking
        ``cut_mesh`` for it would copy the cut mesh into the core on every
        ``sp.embed``, 0.1 s at a million vertices.)"""
        return float(self.details["min_area_ratio"]) * self.mesh.n_faces

    def __init__(self, core: _core.CoreSphereMap, mesh: Mesh) -> None:
        super().__init__(core, mesh)
        self._arrays: Dict[str, np.ndarray] = {}
        self._cut_mesh: Optional[Mesh] = None

    def _array(self, name: str) -> np.ndarray:
        """One of the core's arrays, copied out on first use and read-only:
        at a million vertices they are tens of MB, and most callers want none."""
        if name not in self._arrays:
            self._arrays[name] = _read_only(self._core.theta_phi_array(name))
        return self._arrays[name]

    @property
    def poles(self) -> Tuple[int, int]:
        """The north and south pole vertex ids (thesis 6.2)."""
        poles = self._core.poles
        if poles is None:
            raise AttributeError("the core map has no poles")
        return poles

    @property
    def cut_path(self) -> np.ndarray:
        """(k + 2,) int64: the path the mesh was cut open along, north pole to south pole."""
        return self._array("cut_path")

    @property
    def theta_phi(self) -> np.ndarray:
        """(n + k, 2) float64: the embedding of :attr:`cut_mesh` in the rectangle [0, pi] x [0,
        2 pi] (thesis 6.4)."""
        return self._array("theta_phi")

    @property
    def cut_original(self) -> np.ndarray:
        """(n + k,) int64: the input vertex each vertex of :attr:`cut_mesh` stands for."""
        return self._array("cut_original")

    @property
    def tp_valid(self) -> bool:
        """Whether the rectangle embedding has no flipped and no zero-area triangle under exact
        predicates (the thesis's bijectivity guarantee)."""
        return bool(self._core.tp_valid)

    @property
    def cut_mesh(self) -> Mesh:
        """The cut-open disk. Built on first use: copying it into the core
        costs as much as the exact validity test, and most callers never
        look at it."""
        if self._cut_mesh is None:
            self._cut_mesh = Mesh(self._array("cut_vertices"), self._array("cut_faces"))
        return self._cut_mesh


def _float_rows(data: npt.ArrayLike, what: str) -> np.ndarray:
    _args.refuse_lossy(data, what)
    try:
        array = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MeshError(f"{what} must be numbers: {err}") from None
    return np.ascontiguousarray(array)
