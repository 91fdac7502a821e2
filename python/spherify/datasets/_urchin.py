"""A unit ball with long thin spikes leaving it along rays from the centre."""

from __future__ import annotations

import math
from typing import List

import numpy as np

from .._errors import MeshError
from .._mesh import Mesh
from ._arms import ROOM, ArmRings, arm_separation, attach_arms, plan_arms, spread_directions
from .._args import integer
from ._checks import as_positive, shape_size
from ._guarantees import shape
from ._tubes import TAPER, ring_positions
from ._vectors import perpendicular


@shape
def urchin(n_vertices: int = 20000, spikes: int = 32, spike_length: float = 2.0,
           spike_radius: float = 0.05, seed: int = 0) -> Mesh:
    """A unit ball with long thin spikes.

    The spikes point away from the centre, but their tubes are triangulated
    with rings turned by half a step, so some tube faces face slightly away
    from the origin: the mesh is not star-shaped (radial projection from the
    kernel refuses it), though it comes close.

    Parameters
    ----------
    n_vertices : int, default 20000
        Target vertex count, met within 15% above the minimum. The smallest
        urchin (4 vertices around each spike, its rings 3x farther apart, a
        body fine enough to keep the spikes' holes apart) has 2,350 to 2,850
        vertices for the defaults, depending on the seed (about 80 per spike);
        smaller targets give it.
    spikes : int, default 32
        Number of spikes, spread evenly (a relaxed Fibonacci lattice).
    spike_length : float, default 2.0
        Length from the body's surface to the tip, varied by +-15% per spike.
    spike_radius : float, default 0.05
        Radius at the base, at most 0.25; spikes thin to 40% of it at the
        rounded tip.
    seed : int, default 0
        Seed of the spike directions and lengths.

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (2n - 4, 3) int64. Two
        thirds of the vertices lie on the spikes (about 400 per spike at the
        default size). Smallest angle above 15 degrees.

    Raises
    ------
    MeshError
        A parameter out of range, or too many or too thick spikes to fit.

    Notes
    -----
    The body is a geodesic sphere; under each spike the rings of body vertices
    round the nearest vertex are removed until the hole clears the spike, and
    the hole's loop is zipped to the first ring of the spike's tube. Cost O(n)
    plus O(spikes**2).
    """
    n = shape_size(n_vertices, "urchin")
    spikes = integer(spikes, "spikes", 1)
    length = as_positive("spike_length", spike_length)
    r = as_positive("spike_radius", spike_radius)
    R = 1.0
    if r > 0.25 * R:
        raise MeshError("spike_radius must be at most a quarter of the body radius (1)")
    if 3.8 / math.sqrt(spikes) < ROOM * r:   # even a perfect packing would not fit them
        raise MeshError(f"{spikes} spikes of radius {r} do not fit on the body; "
                        "use fewer or thinner spikes")
    rng = np.random.default_rng(seed)
    directions = spread_directions(spikes, rng)
    lengths = length * rng.uniform(0.85, 1.15, spikes)
    # spikes are rays from the centre, so they are closest at their bases
    separation = arm_separation(directions, R, r, "spikes")

    h, m, spacing, body = plan_arms(n, R, r, separation, lengths, directions)
    rings: List[ArmRings] = []
    for i, d in enumerate(body.V[body.centres] / R):     # spikes leave from body vertices
        s = ring_positions(float(lengths[i]), TAPER, spacing)
        C = (math.sqrt(R * R - r * r) + s)[:, None] * d        # first ring lies on the body
        U = perpendicular(d)
        ones = np.ones((len(s), 1))
        rings.append((C, ones * U, ones * np.cross(d, U), ones * d,
                      r * (1 - TAPER * s / lengths[i])))
    return Mesh(*attach_arms(body, m, rings))
