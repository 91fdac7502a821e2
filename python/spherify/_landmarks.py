"""Landmarks of a map: the ``landmarks=`` argument of :func:`spherify.embed`
and :func:`spherify.improve` read into arrays, :func:`move_towards`, the
soft moves towards per-vertex targets that registration builds on, and
:func:`pull_towards`, energy sweeps with a pull towards such targets.

The work is the core's (``crates/sphere/src/methods/progressive/landmarks.rs``
``move_towards.rs`` and ``target_pull.rs``): every check of the ids and targets (range,
repeats, direction, two at one point) and every move, decided by exact
predicates; here the arguments only become arrays.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, List, Mapping, Optional, Tuple

import numpy as np
import numpy.typing as npt

from . import _core
from ._errors import FormatError, MeshError
from ._files import file_errors, require_regular_file
from ._json_depth import too_deep
from ._npz_check import check_npz
from ._progress import as_callback
from ._spheremap import SphereMap, warn_if_thin

#: ``(ids (k,) int64, points (k, 3) float64)``.
LandmarkArrays = Tuple[np.ndarray, np.ndarray]


def _integer_ids(ids: Any, what: str) -> np.ndarray:
    array = np.asarray(ids)
    if array.size == 0:
        return np.zeros(0, dtype=np.int64)
    if array.dtype == np.bool_ or array.dtype.kind not in "iu":
        raise MeshError(f"{what} must be integer vertex ids, got {array.dtype}")
    if array.ndim != 1:
        raise MeshError(f"{what} must have shape (k,), got {array.shape}")
    if array.dtype.kind == "u" and array.size and int(array.max()) > np.iinfo(np.int64).max:
        raise MeshError(f"{what}: id {int(array.max())} is not a vertex of the mesh")
    return np.ascontiguousarray(array, dtype=np.int64)


def as_landmarks(landmarks: Any) -> LandmarkArrays:
    """``{vertex_id: (x, y, z)}`` or ``(ids (k,), points (k, 3))`` as arrays.

    Only the form is checked here; the core refuses ids out of range or
    repeated, targets that are not finite or zero and two at one direction
    (:class:`MeshError` naming them).
    """
    if isinstance(landmarks, Mapping):
        keys = list(landmarks.keys())
        if not all(isinstance(k, (int, np.integer)) and not isinstance(k, (bool, np.bool_))
                   for k in keys):
            bad = next(k for k in keys if not isinstance(k, (int, np.integer))
                       or isinstance(k, (bool, np.bool_)))
            raise MeshError(f"landmarks: key {bad!r} is not a vertex id (an int)")
        ids = np.array([int(k) for k in keys], dtype=np.int64)
        values = [landmarks[k] for k in keys]
    elif isinstance(landmarks, (tuple, list)) and len(landmarks) == 2:
        ids = _integer_ids(landmarks[0], "landmark ids")
        values = landmarks[1]
    else:
        raise MeshError("landmarks must be a mapping {vertex_id: (x, y, z)} or a pair "
                        f"(vertex_ids (k,), points (k, 3)), got {type(landmarks).__name__}")
    try:
        points = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MeshError(f"landmark points must be numbers of shape (k, 3): {err}") from None
    if len(ids) == 0 and points.size == 0:
        points = np.zeros((0, 3))
    if points.ndim != 2 or points.shape[1] != 3:
        raise MeshError(f"landmark points must have shape (k, 3), got {points.shape}")
    if len(points) != len(ids):
        raise MeshError(f"{len(ids)} landmark ids but {len(points)} points")
    return ids, np.ascontiguousarray(points)


@file_errors
def read_landmarks(path: "os.PathLike[str] | str") -> LandmarkArrays:
    """Landmarks from a file, for ``spherify map --landmarks FILE``:

    * ``.npz``: arrays ``ids`` (k,) and ``points`` (k, 3);
    * ``.json``: ``{"ids": [...], "points": [[x, y, z], ...]}`` or
      ``{"17": [x, y, z], ...}``;
    * ``.csv``: one landmark a line, ``id,x,y,z`` (a first line that is not
      numbers is a header).

    Raises
    ------
    FormatError
        The file is not one of these, naming it.
    FileError
        The file cannot be read.
    """
    file = Path(os.fspath(path))
    require_regular_file(file)
    suffix = file.suffix.lower()

    def fail(why: str) -> FormatError:
        return FormatError(f"{file}: {why}", str(file))

    try:
        if suffix == ".npz":
            with open(file, "rb") as handle:
                check_npz(handle, str(file))
                with np.load(handle, allow_pickle=False) as arrays:
                    return as_landmarks((arrays["ids"], arrays["points"]))
        if suffix == ".json":
            text = file.read_text(encoding="utf-8")
            if too_deep(text, 4):
                raise fail("landmarks nest deeper than a list of points")
            data = json.loads(text)
            if isinstance(data, dict) and set(data) == {"ids", "points"}:
                return as_landmarks((np.asarray(data["ids"]), data["points"]))
            if isinstance(data, dict):
                return as_landmarks({int(k): v for k, v in data.items()})
            raise fail("expected an object {\"ids\": [...], \"points\": [...]} or {id: [x, y, z]}")
        if suffix == ".csv":
            rows = [line.split(",") for line in file.read_text(encoding="utf-8").splitlines()
                    if line.strip()]
            if rows and not _numbers(rows[0]):
                rows = rows[1:]
            if not all(len(r) == 4 and _numbers(r) for r in rows):
                raise fail("each line must be id,x,y,z")
            return as_landmarks((np.array([int(r[0]) for r in rows], dtype=np.int64),
                                 np.array([[float(x) for x in r[1:]] for r in rows]).reshape(-1, 3)))
    except (KeyError, ValueError, TypeError) as err:
        if isinstance(err, FormatError):
            raise
        raise fail(f"not landmarks ({type(err).__name__}: {err})") from None
    raise fail("landmarks are read from .npz, .json or .csv files")


def _numbers(fields: List[str]) -> bool:
    try:
        [float(f) for f in fields]
    except ValueError:
        return False
    return True


def recorded(m: SphereMap, ids: np.ndarray) -> LandmarkArrays:
    """The landmarks a pinned map records: its ids and the points it stores
    for them, which are the normalised targets exactly."""
    ids = ids.copy()
    points = m.points[ids].copy()
    ids.flags.writeable = False
    points.flags.writeable = False
    return ids, points


def move_towards(sphere_map: SphereMap, targets: npt.ArrayLike, *,
                 weights: Optional[npt.ArrayLike] = None, fixed: Optional[npt.ArrayLike] = None,
                 energy_sweeps: int = 3, progress: Any = None) -> SphereMap:
    """Move a valid map's vertices towards targets on the sphere, flip-free.

    Every vertex with a weight moves along its great circle towards its
    target, a fraction ``min(weight, 1)`` of the way, as far as its faces
    stay positive (the straight-path test of thesis 9.3.2, decided exactly
    on the stored doubles), in three passes over colour classes (the same
    bits on every thread count). The ``fixed`` vertices never move; then
    ``energy_sweeps`` sweeps of the isometric energy with them held. Every
    state is a valid GC-embedding. Cost: O(n) per pass and sweep.

    Parameters
    ----------
    sphere_map : SphereMap
        A valid map (``sphere_map.valid``).
    targets : (n, 3) float
        One direction per vertex (normalised here; rows with weight 0 are
        not read).
    weights : (n,) float >= 0, optional
        Default: 1 for every vertex.
    fixed : (f,) int, optional
        Vertex ids that do not move (landmarks).
    energy_sweeps : int
        Isometric energy sweeps afterwards (0: none).

    Returns
    -------
    SphereMap
        Certified in the core (``method == "improve"``); ``landmarks`` is
        None.

    Raises
    ------
    MapError
        ``sphere_map`` is not a valid GC-embedding.
    MeshError
        Arrays of the wrong shape, a weight negative or not finite, a
        weighted target with no direction, a fixed id out of range.
    """
    n = len(sphere_map.points)
    target_rows = np.ascontiguousarray(targets, dtype=np.float64)
    weight_values = (np.ones(n) if weights is None
                     else np.ascontiguousarray(weights, dtype=np.float64))
    fixed_ids = _integer_ids([] if fixed is None else fixed, "fixed")
    if isinstance(energy_sweeps, bool) or not isinstance(energy_sweeps, (int, np.integer)) \
            or energy_sweeps < 0:
        raise MeshError(f"energy_sweeps must be an int >= 0, got {energy_sweeps!r}")
    core = _core.move_towards(sphere_map._core, target_rows, weight_values, fixed_ids,
                              int(energy_sweeps), as_callback(progress, "move_towards"))
    result = SphereMap(core, sphere_map.mesh)
    warn_if_thin(result)
    return result


def pull_towards(sphere_map: SphereMap, targets: npt.ArrayLike, weights: npt.ArrayLike, *,
                 fixed: Optional[npt.ArrayLike] = None, rest: Optional[npt.ArrayLike] = None,
                 energy: str = "isometric", sweeps: int = 10, tolerance: float = 1e-4,
                 progress: Any = None) -> SphereMap:
    """Lower a distortion plus a pull towards targets, flip-free.

    Sweeps of the flip-free Newton moves of thesis 9.3.2 over colour classes
    (the same bits on every thread count) lower ``E(x) = D(x) + sum_i
    weights[i] |x_i - targets[i]|^2`` over the sphere points ``x``, where ``D``
    is the ``energy`` of the map's chord triangles against ``rest``'s
    triangles (the mesh's own surface when None). The ``fixed`` vertices
    never move. Every move keeps every face positive under the exact test,
    so every state is a valid GC-embedding. Cost: O(n) per sweep
    (``crates/sphere/src/methods/progressive/target_pull.rs``).

    Parameters
    ----------
    sphere_map : SphereMap
        A valid map (``sphere_map.valid``).
    targets : (n, 3) float
        One direction per vertex (normalised in the core; rows with weight 0
        are not read).
    weights : (n,) float >= 0
        The pull's weight per vertex, in the units of ``D`` (whose density
        is about 4 per unit of the sphere's area at an isometry).
    fixed : (f,) int, optional
        Vertex ids that do not move (landmarks).
    rest : (n, 3) float, optional
        The triangles ``D`` measures against (default: the mesh's vertices).
    energy : str
        One of the core's energy names (default "isometric").
    sweeps : int
        Most sweeps; fewer when one lowers ``E`` by less than ``tolerance``.
    tolerance : float
        Relative fall of ``E`` in a sweep below which the sweeps stop.

    Returns
    -------
    SphereMap
        Certified in the core (``method == "improve"``); ``landmarks`` is
        None.

    Raises
    ------
    MapError
        ``sphere_map`` is not a valid GC-embedding.
    MeshError
        Arrays of the wrong shape, a weight negative or not finite, a
        weighted target with no direction, a fixed id out of range, an
        unknown energy.
    """
    target_rows = np.ascontiguousarray(targets, dtype=np.float64)
    weight_values = np.ascontiguousarray(weights, dtype=np.float64)
    fixed_ids = _integer_ids([] if fixed is None else fixed, "fixed")
    rest_rows = None if rest is None else np.ascontiguousarray(rest, dtype=np.float64)
    if isinstance(sweeps, bool) or not isinstance(sweeps, (int, np.integer)) or sweeps < 0:
        raise MeshError(f"sweeps must be an int >= 0, got {sweeps!r}")
    core = _core.pull_towards(sphere_map._core, target_rows, weight_values, fixed_ids, rest_rows,
                              str(energy), int(sweeps), float(tolerance),
                              as_callback(progress, "pull_towards"))
    result = SphereMap(core, sphere_map.mesh)
    warn_if_thin(result)
    return result
