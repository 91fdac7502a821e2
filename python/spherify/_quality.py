"""sp.quality: how much a map onto the sphere distorts the mesh."""

from __future__ import annotations

from typing import Any, Dict, Union

from . import _core
from ._mesh import MeshLike, _as_vertices, as_mesh


def quality(mesh: MeshLike, points: Any) -> Dict[str, Union[float, int]]:
    r"""Distortion of a map from a mesh to the sphere (or to any positions).

    Each face is compared as a pair of flat triangles: the mesh triangle
    :math:`Q = (x_i, x_j, x_k)` and the triangle :math:`P = (v_i, v_j, v_k)`
    of the points joined by **chords** (straight segments through the ball,
    not great-circle arcs). The points are used as given, so ``points`` may
    be a spherical map (``SphereMap.points``) or any other per-vertex
    positions. Per face, :math:`T` is the linear map taking :math:`P` to
    :math:`Q`, written in local 2D frames (each triangle laid flat in its own
    plane), with singular values :math:`\sigma_1 \ge \sigma_2 > 0`
    (:math:`\sigma_1 \sigma_2 = A_Q / A_P`).

    Parameters
    ----------
    mesh : Mesh or (V, F)
        Any triangle mesh: ``V`` (n, 3) float64, ``F`` (m, 3) int64. It need
        not be closed or genus 0.
    points : (n, 3) array_like of float
        One point per vertex, for example ``sp.embed(mesh, ...).points``.

    Returns
    -------
    dict of str to float
        With :math:`\mathcal{F}` the non-degenerate faces, :math:`m = |\mathcal{F}|`,
        :math:`\theta` the corner angles, :math:`A` triangle areas:

        ``angle_mean_deg``, ``angle_max_deg``
            mean and max over the :math:`3m` corners of
            :math:`|\theta_{\text{mesh}} - \theta_{\text{sphere}}|`, in degrees
            (0 for a conformal map of every triangle).
        ``conformal_mean``, ``conformal_max``
            mean (unweighted, over faces) and max of :math:`\sigma_1 / \sigma_2`
            (1 for a similarity; it is the same for :math:`T` and :math:`T^{-1}`).
        ``area_log_mean``, ``area_log_std``, ``area_log_max_abs``
            of :math:`r_f = \log\big((A_{P,f} / \sum_{\mathcal{F}} A_P) /
            (A_{Q,f} / \sum_{\mathcal{F}} A_Q)\big)`: both total areas
            normalised to 1, so 0 means every face keeps its share of the
            area; the std is the population standard deviation over faces.
        ``area_ratio_min``, ``area_ratio_max``
            :math:`e^{\min r_f}` and :math:`e^{\max r_f}`.
        ``stretch_l2``, ``stretch_linf``
            Sander, Snyder, Gortler and Hoppe (2001) stretch of the map from
            the sphere triangles to the mesh triangles. The sphere side is first
            scaled by :math:`s` with :math:`s^2 = \sum A_Q / \sum A_P` (equal
            total areas), which divides the singular values by :math:`s`:
            :math:`\Gamma_f = \sigma_{1,f} / s`, :math:`\gamma_f = \sigma_{2,f} / s`. Then
            :math:`L^2 = \sqrt{\sum_f \tfrac12(\Gamma_f^2 + \gamma_f^2) A_{Q,f} / \sum_f A_{Q,f}}`
            and :math:`L^\infty = \max_f \Gamma_f`. Both are at least 1, and
            1 exactly when every face is mapped isometrically up to one global
            scale.
        ``edge_length_cv``
            coefficient of variation (population standard deviation / mean) of
            the chord lengths :math:`|v_a - v_b|` of all mesh edges, the
            "standard deviation in edge-lengths" of thesis 9.3.1 made
            scale-free; 0 when all edges on the sphere are equally long. Edges
            of degenerate faces count here.
        ``degenerate_faces``, ``n_faces`` : int
            A face is degenerate when its triangle on either side has twice its
            area at most 1e-12 times its longest edge squared (numerically
            zero area, where angles and singular values are rounding noise),
            or its longest edge squared is below the smallest normal double
            (about 1e-308).
            Degenerate faces are counted here and left out of every other
            measure, including the area totals used for normalising; no NaN or
            infinity is produced.

    Raises
    ------
    MeshError
        ``points`` not of shape (n, 3) for the mesh's n vertices, NaN or
        infinite values, or every face degenerate (nothing to measure).

    Notes
    -----
    The measures are unsigned: a face whose orientation the map reverses
    counts by its shape alone. Use :func:`check_sphere` (or
    ``SphereMap.valid``) to know whether a map is a valid embedding. Cost
    O(n + m), faces in parallel; the result is the same on every run.
    """
    mesh = as_mesh(mesh)
    result: Dict[str, Union[float, int]] = _core.quality(mesh._core, _as_vertices(points, "points"))
    return result


def face_quality(mesh: MeshLike, points: Any) -> Dict[str, Any]:
    """The measures of :func:`quality` face by face, to see where a map
    distorts (``sp.plot.sphere`` colours by them).

    Returns
    -------
    dict of str to (m,) float64
        ``angle_max_deg`` (the face's largest corner-angle change, degrees),
        ``conformal`` (sigma1 / sigma2), ``area_log`` (log of the face's
        share of the sphere's area over its share of the mesh's) and
        ``stretch`` (sqrt((Gamma^2 + gamma^2) / 2); its area-weighted rms is
        ``stretch_l2``). NaN for degenerate faces. O(m), in parallel.

    Raises
    ------
    MeshError
        As :func:`quality`.
    """
    mesh = as_mesh(mesh)
    result: Dict[str, Any] = _core.face_quality(mesh._core, _as_vertices(points, "points"))
    return result
