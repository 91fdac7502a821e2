# Type stubs of the Rust extension spherify._core (checked by mypy.stubtest in CI).
from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Tuple, final

import numpy as np
import numpy.typing as npt

from ._report import MeshReport, SphereReport

__all__ = ["CoreMesh", "CorePointMap", "__version__", "boundary_loop", "check", "check_raw", "check_sphere", "dijkstra", "embed_alexa", "embed_gotsman", "embed_radial", "embed_relaxation", "embed_theta_phi", "load", "orient", "point_map_gc", "point_map_theta_phi", "quality", "save", "shortest_path", "tutte"]

__version__: str

@final
class CoreMesh:
    def __new__(cls, vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> CoreMesh: ...
    def vertices(self) -> npt.NDArray[np.float64]: ...
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def n_vertices(self) -> int: ...
    @property
    def n_faces(self) -> int: ...

@final
class CorePointMap:
    def to_sphere(
        self, face_ids: npt.NDArray[np.int64], bary: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]: ...
    def to_surface(
        self, points: npt.NDArray[np.float64]
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def not_bijective(self) -> Optional[str]: ...

def point_map_theta_phi(
    mesh: CoreMesh,
    cut_faces: npt.NDArray[np.int64],
    theta_phi: npt.NDArray[np.float64],
    poles: Tuple[int, int],
    tp_valid: bool,
) -> CorePointMap: ...
def point_map_gc(
    mesh: CoreMesh, points: npt.NDArray[np.float64], valid: bool, flipped: int
) -> CorePointMap: ...
def load(path: str | PathLike[str]) -> Tuple[CoreMesh, List[str], Dict[str, npt.NDArray[np.float64]]]: ...
def save(
    mesh: CoreMesh,
    path: str | PathLike[str],
    sphere: Optional[npt.NDArray[np.float64]] = None,
    uv: Optional[npt.NDArray[np.float64]] = None,
    ply_encoding: str = "binary_little_endian",
    stl_binary: bool = True,
) -> None: ...
def check(mesh: CoreMesh) -> MeshReport: ...
def check_raw(vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> MeshReport: ...
def check_sphere(mesh: CoreMesh, points: npt.NDArray[np.float64]) -> SphereReport: ...
def orient(mesh: CoreMesh) -> Tuple[CoreMesh, Dict[str, int]]: ...
def dijkstra(
    mesh: CoreMesh, source: int, weights: str = "length"
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...
def shortest_path(
    mesh: CoreMesh, source: int, target: int, weights: str = "length"
) -> Tuple[float, npt.NDArray[np.int64]]: ...
def boundary_loop(mesh: CoreMesh) -> npt.NDArray[np.int64]: ...
def tutte(
    mesh: CoreMesh,
    weights: str = "uniform",
    rho: float = 1.0,
    boundary: str = "circle",
    polygon: Optional[npt.NDArray[np.float64]] = None,
    solver: str = "auto",
    tol: float = 1e-10,
    max_iter: int = 10000,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def embed_radial(mesh: CoreMesh, center: str | npt.ArrayLike = "kernel") -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def embed_relaxation(
    mesh: CoreMesh,
    weights: str = "uniform",
    rho: float = 1.0,
    max_iter: int = 10000,
    check_every: int = 10,
    strict: bool = False,
    tol: float = 1e-12,
    center: Optional[str | npt.ArrayLike] = None,
    initial: Optional[npt.NDArray[np.float64]] = None,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def embed_alexa(
    mesh: CoreMesh,
    c: Optional[float] = None,
    max_iter: int = 10000,
    check_every: int = 10,
    strict: bool = False,
    tol: float = 1e-12,
    center: Optional[str | npt.ArrayLike] = None,
    initial: Optional[npt.NDArray[np.float64]] = None,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def embed_gotsman(
    mesh: CoreMesh,
    weights: str = "uniform",
    rho: float = 1.0,
    max_iter: int = 50,
    tol: float = 1e-10,
    strict: bool = False,
    initial: Optional[npt.NDArray[np.float64]] = None,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def embed_theta_phi(
    mesh: CoreMesh,
    poles: Optional[str | Tuple[int, int]] = None,
    weights: str = "uniform",
    rho: float = 1.0,
    max_refinements: int = 8,
    symmetry_eps: Optional[float] = None,
    symmetry_max_score: float = 0.05,
    progress: Optional[Callable[[int, int], object]] = None,
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...
def quality(mesh: CoreMesh, points: npt.NDArray[np.float64]) -> Dict[str, Any]: ...
