"""Argument checks shared by the shapes: each raises MeshError naming the argument.
Integer arguments go through the package's one checker, ``_args.integer``; the
size of a shape is also checked against the memory making it takes (ResourceError),
through the core's one memory check (``crates/sphere/src/memory_budget.rs``)."""

from __future__ import annotations

import math
from typing import Any, Dict

from .. import _core
from .._args import integer
from .._errors import MeshError

#: Peak growth of the address space while a shape is made, in bytes per
#: vertex of the shape: VmPeak less VmSize before the call at 10^6 vertices
#: (icosphere 163, ellipsoid 173, bumpy_blob 184, helix_tube 216, urchin
#: 329, tentacles 243; icosphere 177 and urchin 226 at 4 * 10^6), times 1.5
#: (docs/reliability.md, "Memory").
MAKING_BYTES_PER_VERTEX: Dict[str, float] = {
    "icosphere": 270.0,
    "ellipsoid": 270.0,
    "bumpy_blob": 280.0,
    "helix_tube": 330.0,
    "urchin": 500.0,
    "tentacles": 370.0,
}

#: What a made shape holds while it is mapped: vertices (n, 3) float64 and
#: faces (2n - 4, 3) int64 in numpy, and the core's copy (float64, uint32).
MESH_BYTES_PER_VERTEX = 24 + 48 + 24 + 24


def making_bytes(shape: str, n_vertices: int) -> int:
    """The bytes making ``shape`` with ``n_vertices`` vertices takes at its peak."""
    return int(MAKING_BYTES_PER_VERTEX[shape] * n_vertices) + (64 << 20)


def mesh_bytes(n_vertices: int) -> int:
    """The bytes a made shape of ``n_vertices`` holds (numpy's arrays and the core's copy)."""
    return MESH_BYTES_PER_VERTEX * n_vertices


def shape_size(n_vertices: Any, shape: str) -> int:
    """``n_vertices`` as an integer of at least 1 (MeshError naming it), once
    making ``shape`` that large is known to fit in what the process can still
    get (ResourceError naming the shape, the size and the bytes otherwise)."""
    n = integer(n_vertices, "n_vertices", 1)
    _core.check_memory(f"datasets.{shape}", n, making_bytes(shape, n))
    return n


def as_positive(name: str, value: Any, allow_zero: bool = False) -> float:
    """``value`` as a finite float above zero (or at zero, if allowed)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and (x > 0.0 or (allow_zero and x == 0.0))):
        raise MeshError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} "
                        f"finite number, got {value!r}")
    return x
