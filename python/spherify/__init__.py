"""spherify: one-to-one maps of closed genus-0 triangle meshes onto the unit sphere.

The Rust core does the work; this package is its Python face. See README.md.
"""

from __future__ import annotations

from typing import List

from . import datasets, harmonics, plot, texture
from ._core import __version__
from ._errors import (ConvergenceError, FileError, FormatError, MapError, MeshError,
                      ResourceError, SpherifyError, SpherifyWarning, TopologyError)
from ._mesh import Mesh, check, check_sphere, dijkstra, load, orient, save, shortest_path, weld
from ._report import MeshReport, SphereReport
from ._spheremap import SphereMap, ThetaPhiMap
from ._tutte import TutteInfo, boundary_loop, tutte
from ._embed import embed, improve, method_options, methods
from ._quality import face_quality, quality
from ._register import Correspondence, SurfacePoints, register
from ._morph import Morph, morph
from ._population import Population, correspond
from ._remesh import remesh, remesh_map, surface_distance
from ._geometry_image import (from_geometry_image, geometry_image, load_geometry_image,
                             save_geometry_image)
from ._persist import load_map
from ._batch import BatchResult, batch
from ._threads import get_num_threads, set_num_threads

__all__ = [
    "BatchResult",
    "Correspondence",
    "ConvergenceError",
    "FileError",
    "FormatError",
    "MapError",
    "Mesh",
    "MeshError",
    "MeshReport",
    "Morph",
    "Population",
    "ResourceError",
    "SphereMap",
    "SphereReport",
    "SurfacePoints",
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
    "correspond",
    "datasets",
    "dijkstra",
    "embed",
    "improve",
    "face_quality",
    "from_geometry_image",
    "geometry_image",
    "get_num_threads",
    "harmonics",
    "load",
    "load_geometry_image",
    "load_map",
    "method_options",
    "methods",
    "morph",
    "orient",
    "plot",
    "quality",
    "register",
    "remesh",
    "remesh_map",
    "save_geometry_image",
    "save",
    "set_num_threads",
    "shortest_path",
    "surface_distance",
    "texture",
    "tutte",
    "weld",
]


def __dir__() -> List[str]:
    """Only the public names (PEP 562): dir() lists what __all__ does."""
    return sorted(__all__)
