"""A unit ball with long tentacles that leave it below the equator and curl."""

from __future__ import annotations

import math
from typing import List, Tuple

import numpy as np

from .._errors import MeshError
from .._mesh import Mesh
from ._arms import ArmRings, arm_separation, attach_arms, plan_arms
from .._args import integer
from ._checks import as_positive, shape_size
from ._guarantees import shape
from ._tubes import TAPER, check_clearance, ring_positions
from ._vectors import Floats, unit


@shape
def tentacles(n_vertices: int = 20000, arms: int = 8, arm_length: float = 4.0,
              arm_radius: float = 0.12, curl: float = 1.5, seed: int = 0) -> Mesh:
    """A unit ball with long curling tentacles below its equator; not
    star-shaped from any point.

    Parameters
    ----------
    n_vertices : int, default 20000
        Target vertex count, met within 10% above the minimum: 1,700 to 2,000
        vertices for the defaults, depending on the seed (smaller targets give
        that).
    arms : int, default 8
        Number of tentacles, evenly round the vertical axis 30 degrees below
        the equator (jittered).
    arm_length : float, default 4.0
        Length along the centre line, varied by -15%..+10% per arm.
    arm_radius : float, default 0.12
        Radius at the base, at most 0.25; arms thin to 40% of it at the tip.
    curl : float, default 1.5
        How far each arm curls, in half turns (pi radians): 0 gives straight
        arms; 1.5 turns the tip through 270 degrees. Varied by -15%..+10%.
    seed : int, default 0
        Seed of the jitter in placement, length and curl.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64. Smallest
        angle about 20 degrees, above 13 at the minimum size.

    Raises
    ------
    MeshError
        A parameter out of range, or arms that would bend into themselves, each
        other or the body (checked on their centre lines).

    Notes
    -----
    Each arm leaves the body radially, then follows a clothoid (curvature
    growing linearly) in the vertical half-plane through its base, so arms in
    different half-planes cannot meet. Its tube uses the plane curve's
    rotation-minimising frame (the plane normal); the body and joins are built
    as for :func:`urchin`. Cost O(n).
    """
    n = shape_size(n_vertices, "tentacles")
    arms = integer(arms, "arms", 1)
    length = as_positive("arm_length", arm_length)
    r = as_positive("arm_radius", arm_radius)
    curl = as_positive("curl", curl, allow_zero=True)
    R = 1.0
    if r > 0.25 * R:
        raise MeshError("arm_radius must be at most a quarter of the body radius (1)")
    if length < 6 * r:
        raise MeshError("arm_length must be at least 6 x arm_radius")
    rng = np.random.default_rng(seed)
    # arms leave below the equator, evenly round the vertical axis; each curls
    # in its own vertical half-plane, so arms stay apart however they curl
    azimuth = 2 * math.pi * (np.arange(arms) + rng.uniform(-0.05, 0.05, arms)) / arms
    polar = math.radians(120) + rng.uniform(-0.06, 0.06, arms)
    directions = np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                           np.cos(polar)], 1)
    lengths = length * rng.uniform(0.85, 1.1, arms)
    turn = curl * math.pi * rng.uniform(0.85, 1.1, arms)
    straight = np.maximum(0.2 * lengths, 3 * r)      # radial root before the curl starts
    separation = arm_separation(directions, R, r, "arms")

    def centre_line(i: int, d: Floats, s: Floats) -> Tuple[Floats, ...]:
        """Centre, tangent and in-plane unit vectors of arm ``i`` at arc lengths
        ``s``: straight from the body, then a clothoid (curvature growing linearly)
        turning through ``turn[i]`` towards +z, in the plane of d and the z axis."""
        out = unit(np.array([d[0], d[1], 0.0]))
        up = np.array([0.0, 0.0, 1.0])
        theta0 = math.atan2(d[2], d @ out)
        L, s0 = float(lengths[i]), float(straight[i])

        def theta(x: Floats) -> Floats:
            angle: Floats = theta0 + turn[i] * (np.clip((x - s0) / (L - s0), 0.0, 1.0)) ** 2
            return angle

        fine = np.linspace(0.0, L, 4097)
        th = theta(fine)
        half = 0.5 * (fine[1] - fine[0])
        x = np.concatenate([[0.0], np.cumsum(half * (np.cos(th[1:]) + np.cos(th[:-1])))])
        z = np.concatenate([[0.0], np.cumsum(half * (np.sin(th[1:]) + np.sin(th[:-1])))])
        base = math.sqrt(R * R - r * r) * d                   # first ring lies on the body
        C = base + np.interp(s, fine, x)[:, None] * out + np.interp(s, fine, z)[:, None] * up
        ts = theta(s)
        T = np.cos(ts)[:, None] * out + np.sin(ts)[:, None] * up
        return C, T, np.cross(out, up)

    h, m, spacing, body = plan_arms(n, R, r, separation, lengths, directions)
    bases = body.V[body.centres] / R                     # arms leave from body vertices

    # clearance of the arms from each other, themselves and the body, sampled at
    # half the tip radius; and the inner side of the tightest bend must not fold
    tip = (1 - TAPER) * r
    paths = []
    for i, d in enumerate(bases):
        s = np.linspace(0.0, lengths[i], int(2 * lengths[i] / tip) + 2)
        C = centre_line(i, d, s)[0]
        radius = r * (1 - TAPER * s / lengths[i])
        paths.append((s, C, radius))
        curvature = 2 * turn[i] / (lengths[i] - straight[i]) ** 2 * np.maximum(s - straight[i], 0)
        beyond = s > straight[i]
        if np.any(curvature * radius > 0.6) or \
                np.any(np.linalg.norm(C[beyond], axis=1) - R < 1.05 * radius[beyond]):
            raise MeshError("these tentacles parameters bend an arm too tightly or into the "
                            "body; use less curl, thinner or longer arms")
    check_clearance(paths, "tentacles")

    rings: List[ArmRings] = []
    for i, d in enumerate(bases):
        s = ring_positions(float(lengths[i]), TAPER, spacing)
        C, T, normal = centre_line(i, d, s)
        # a plane curve's rotation-minimising frame: the plane normal and T x it
        W = np.broadcast_to(normal, C.shape)
        rings.append((C, np.cross(W, T), W, T, r * (1 - TAPER * s / lengths[i])))
    return Mesh(*attach_arms(body, m, rings))
