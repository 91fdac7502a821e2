"""spherify: one-to-one maps of closed genus-0 triangle meshes onto the unit sphere.

The Rust core does the work; this package is its Python face. See README.md.
"""

from __future__ import annotations

from . import datasets
from ._core import __version__
from ._errors import (ConvergenceError, FormatError, MapError, MeshError, SpherifyError,
                      SpherifyWarning, TopologyError)
from ._mesh import Mesh, check, check_sphere, dijkstra, load, orient, save, shortest_path
from ._report import MeshReport, SphereReport
from ._spheremap import SphereMap, ThetaPhiMap
from ._tutte import TutteInfo, boundary_loop, tutte
from ._embed import embed, methods
from ._quality import quality
from ._persist import load_map
from ._batch import BatchResult, batch

__all__ = [
    "BatchResult",
    "ConvergenceError",
    "FormatError",
    "MapError",
    "Mesh",
    "MeshError",
    "MeshReport",
    "SphereMap",
    "SphereReport",
    "SpherifyError",
    "SpherifyWarning",
    "ThetaPhiMap",
    "TopologyError",
    "TutteInfo",
    "__version__",
    "batch",
    "boundary_loop",
    "check",
    "check_sphere",
    "datasets",
    "dijkstra",
    "embed",
    "load",
    "load_map",
    "methods",
    "orient",
    "quality",
    "save",
    "shortest_path",
    "tutte",
]
