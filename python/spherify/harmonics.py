"""Spherical harmonics of a surface through its sphere map (thesis 8.3).

The surface's x, y and z, read as functions on the unit sphere through a
certified map, are expanded in real spherical harmonics up to a degree
``lmax``; filtering the coefficients (low-pass, Gaussian, high-boost) and
rebuilding gives a smoothed or sharpened surface with the input's
connectivity, and the energy per degree is a rotation-invariant shape
descriptor (Kazhdan, Funkhouser and Rusinkiewicz 2003, cited in 8.3)::

    c = sp.harmonics.fit(m, 30)          # Harmonics
    smooth = c.lowpass(8).to_mesh(m)     # Mesh: m.mesh's faces, new positions
    c.spectrum()                         # (31,) energy per degree

Conventions: row ``l**2 + l + m`` of ``coefficients`` (``m = -l..l``) holds
the (x, y, z) coefficients of the real harmonic ``Y(l, m)``: ``P(l, 0)`` for
``m = 0``, ``sqrt(2) P(l, m) cos(m phi)`` for ``m > 0`` and
``sqrt(2) P(l, |m|) sin(|m| phi)`` for ``m < 0``, with ``P`` the associated
Legendre functions normalised so that every ``Y`` has unit norm on the unit
sphere (no Condon-Shortley phase); theta from the north pole (0, 0, 1), phi
from the x axis towards y.
"""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional

import numpy as np
import numpy.typing as npt

from . import _args, _core
from ._errors import MeshError
from ._mesh import Mesh
from ._progress import as_callback
from ._spheremap import SphereMap, _float_rows

__all__ = ["Harmonics", "fit"]


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


class Harmonics:
    """Real spherical-harmonic coefficients of a surface's x, y and z.

    All attributes are read-only.

    Attributes
    ----------
    lmax : int
        The largest degree.
    coefficients : ((lmax + 1)**2, 3) float64
        Row ``l**2 + l + m`` for degree ``l``, order ``m`` (see the module doc).
    degrees : ((lmax + 1)**2,) int64
        The degree of each row.
    info : dict
        What :func:`fit` did: ``n_theta`` x ``n_phi`` samples, ``seconds``.
    """

    def __init__(self, coefficients: npt.ArrayLike, info: Optional[Dict[str, Any]] = None) -> None:
        c = np.array(_float_rows(coefficients, "coefficients"), dtype=np.float64)
        if c.ndim != 2 or c.shape[1] != 3:
            raise MeshError(f"coefficients must have shape (K, 3), got {c.shape}")
        lmax = math.isqrt(len(c)) - 1
        if len(c) == 0 or (lmax + 1) ** 2 != len(c):
            raise MeshError(f"coefficients have {len(c)} rows, which is not (lmax + 1)**2 "
                            "for any lmax")
        if not np.isfinite(c).all():
            raise MeshError("coefficients must be finite")
        self._c = _read_only(c)
        self._lmax = lmax
        self._info = dict(info or {})

    @property
    def lmax(self) -> int:
        """The largest degree."""
        return self._lmax

    @property
    def coefficients(self) -> np.ndarray:
        """((lmax + 1)**2, 3) float64: row ``l**2 + l + m`` for degree ``l``, order ``m``."""
        return self._c

    @property
    def degrees(self) -> np.ndarray:
        """((lmax + 1)**2,) int64: the degree of each row."""
        l = np.arange(self._lmax + 1)
        return _read_only(np.repeat(l, 2 * l + 1).astype(np.int64))

    @property
    def info(self) -> Dict[str, Any]:
        """What :func:`fit` did: ``n_theta`` x ``n_phi`` samples, ``seconds``."""
        return dict(self._info)

    def evaluate(self, points: npt.ArrayLike) -> np.ndarray:
        """The surface at sphere points: the sum of the harmonics.

        Parameters
        ----------
        points : (k, 3) float
            Unit vectors (norm within 1e-6 of 1; normalised).

        Returns
        -------
        (k, 3) float64
            O(lmax**2) per point, in parallel, without the GIL; deterministic;
            Ctrl-C stops it.

        Raises
        ------
        MeshError
            Wrong shape or a point that is not a unit vector (the row is named).
        """
        return _core.harmonics_evaluate(self._c, _float_rows(points, "points"))

    def to_mesh(self, m: SphereMap) -> Mesh:
        """The surface rebuilt at the map's own vertices: a :class:`Mesh` with
        ``m.mesh``'s faces and ``evaluate(m.points)`` as its vertices."""
        return Mesh(self.evaluate(m.points), m.mesh.faces)

    def filter(self, gains: npt.ArrayLike) -> Harmonics:
        """Every degree ``l`` multiplied by ``gains[l]``.

        Parameters
        ----------
        gains : (lmax + 1,) float
        """
        g = np.asarray(gains, dtype=np.float64)
        if g.shape != (self._lmax + 1,) or not np.isfinite(g).all():
            raise MeshError(f"gains must be {self._lmax + 1} finite numbers, one per degree, "
                            f"got shape {g.shape}")
        return Harmonics(self._c * g[self.degrees][:, None], self._info)

    def lowpass(self, l: int) -> Harmonics:
        """The coefficients of degree at most ``l`` (``l >= lmax`` keeps all);
        the result has ``lmax = min(l, self.lmax)``."""
        l = min(_args.integer(l, "l", 0), self._lmax)
        return Harmonics(self._c[: (l + 1) ** 2], self._info)

    def gaussian(self, sigma: float) -> Harmonics:
        """Smooth with the heat kernel: degree ``l`` times
        ``exp(-l (l + 1) sigma**2 / 2)``, which acts like a Gaussian of
        standard deviation about ``sigma`` radians on the sphere (the heat
        kernel smoothing of Chung et al. 2007, SPHARM). ``sigma = 0`` is the
        identity."""
        s = float(sigma)
        if not (math.isfinite(s) and s >= 0):
            raise MeshError(f"sigma must be a finite number >= 0, got {sigma!r}")
        l = np.arange(self._lmax + 1)
        return self.filter(np.exp(-l * (l + 1) * s * s / 2))

    def sharpen(self, amount: float, sigma: float) -> Harmonics:
        """High-boost (sharpening, as Zhou et al. in thesis 8.3): add
        ``amount`` times the detail above the Gaussian of ``sigma``: degree
        ``l`` times ``1 + amount (1 - exp(-l (l + 1) sigma**2 / 2))``. Degrees
        0 and 1 (position, and the affine part of the shape) are unchanged."""
        a, s = float(amount), float(sigma)
        if not (math.isfinite(a) and a >= 0 and math.isfinite(s) and s >= 0):
            raise MeshError(f"amount and sigma must be finite numbers >= 0, got {amount!r}, "
                            f"{sigma!r}")
        l = np.arange(self._lmax + 1)
        gains = 1 + a * (1 - np.exp(-l * (l + 1) * s * s / 2))
        gains[:2] = 1.0
        return self.filter(gains)

    def spectrum(self) -> np.ndarray:
        """Energy per degree: ``sum over m and x, y, z of c(l, m)**2``, shape
        (lmax + 1,). Its sum is the mean of ``|f|**2`` over the sphere times
        ``4 pi`` (Parseval). Unchanged when the surface is rotated (the x, y,
        z coefficients of each harmonic turn by the same rotation) and, for a
        band-limited function, when the sphere is."""
        energy = (self._c ** 2).sum(axis=1)
        return np.bincount(self.degrees, weights=energy, minlength=self._lmax + 1)

    def __repr__(self) -> str:
        return f"Harmonics(lmax={self._lmax})"


def fit(m: SphereMap, lmax: int, *, oversample: int = 1, progress: Any = None) -> Harmonics:
    """The real spherical-harmonic coefficients of ``m``'s surface up to ``lmax``.

    The surface is sampled through ``m.to_surface`` on a grid of the sphere,
    ``oversample * (lmax + 1)`` Gauss-Legendre rings in cos(theta) by
    ``2 * oversample * (lmax + 1)`` uniform points in phi, and transformed
    (a sum in phi per ring, then one Legendre recurrence per order:
    O(lmax**3)); no matrix of harmonics at the vertices is formed. The grid
    integrates harmonics up to ``lmax`` exactly; ``oversample > 1`` reduces
    the aliasing of the surface's finer detail into the coefficients. The GIL
    is released throughout, and Ctrl-C stops it. Deterministic.

    Parameters
    ----------
    m : SphereMap
        A certified map (``valid``, or ``tp_valid`` for theta-phi): any method,
        or :meth:`SphereMap.from_points`.
    lmax : int
        Largest degree, 0..2000.
    oversample : int, default 1
        1..8; the grid may hold at most 2**24 points.
    progress : bool or callable, optional
        ``True`` draws a bar on stderr, a callable receives ``(done, total)``
        (rings sampled, then rings summed and orders transformed), as for
        :func:`spherify.embed`. Worth it from a degree of a few hundred.

    Returns
    -------
    Harmonics

    Raises
    ------
    MapError
        The map is not a certified bijection.
    MeshError
        ``lmax`` or ``oversample`` out of range.
    """
    if not isinstance(m, SphereMap):
        raise MeshError(f"fit needs a SphereMap, got {type(m).__name__}")
    lmax = _args.integer(lmax, "lmax", 0)
    oversample = _args.integer(oversample, "oversample", 1)
    coefficients, info = _core.harmonics_fit(m._core, lmax, oversample,
                                             as_callback(progress, "harmonics"))
    info["seconds"] = dict(info["seconds"])
    return Harmonics(coefficients, info)


def __dir__() -> List[str]:
    """Only the public names (PEP 562): dir() lists what __all__ does."""
    return sorted(__all__)
