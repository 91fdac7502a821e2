"""Procedural textures on the sphere, so that examples and tests need no
downloaded image: colours as a function of the direction, to be baked into
any projection's atlas (``sp.texture.bake``)."""

from __future__ import annotations

from typing import Tuple

import numpy as np
import numpy.typing as npt

from .._args import integer
from .._errors import MeshError


def _directions(directions: npt.ArrayLike) -> np.ndarray:
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim < 1 or d.shape[-1] != 3:
        raise MeshError(f"directions must have shape (..., 3), got {d.shape}")
    return d


def _theta_phi(d: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    d = np.where(np.isnan(d).any(axis=-1)[..., None], [0.0, 0.0, 1.0], d)  # coloured NaN below
    theta = np.arccos(np.clip(d[..., 2] / np.maximum(np.linalg.norm(d, axis=-1), 1e-300), -1, 1))
    phi = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2 * np.pi)
    return theta, phi


def checkerboard(directions: npt.ArrayLike, squares: int = 8) -> np.ndarray:
    """A latitude-longitude checkerboard: ``squares`` cells from pole to pole
    and ``2 squares`` around, dark and light, with a red cell at theta, phi ~ 0
    so that orientation shows.

    Parameters
    ----------
    directions : (..., 3) float
        Nonzero vectors (NaN rows give NaN colours: unused atlas pixels).
    squares : int, default 8

    Returns
    -------
    (..., 3) float64
        RGB in [0, 1].
    """
    squares = integer(squares, "squares", 1)
    d = _directions(directions)
    theta, phi = _theta_phi(d)
    i = np.floor(theta / np.pi * squares).astype(np.int64)
    j = np.floor(phi / (2 * np.pi) * 2 * squares).astype(np.int64)
    light = (i + j) % 2 == 0
    rgb = np.where(light[..., None], [0.92, 0.9, 0.82], [0.15, 0.2, 0.35])
    marker = (i == squares // 2) & (j == 0)
    rgb = np.where(marker[..., None], [0.85, 0.15, 0.1], rgb)
    return np.where(np.isnan(d).any(axis=-1)[..., None], np.nan, rgb)


def lat_long_grid(directions: npt.ArrayLike, step_deg: float = 15.0,
                  width_deg: float = 1.0) -> np.ndarray:
    """Lines of latitude and longitude every ``step_deg`` degrees,
    ``width_deg`` wide, dark on a light ground; the equator and the zero
    meridian in colour.

    Returns
    -------
    (..., 3) float64
        RGB in [0, 1].
    """
    if not (0 < float(step_deg) <= 180 and 0 < float(width_deg) < float(step_deg)):
        raise MeshError(f"need 0 < width_deg < step_deg <= 180, got {width_deg!r}, {step_deg!r}")
    d = _directions(directions)
    theta, phi = _theta_phi(d)
    lat, lon, s = np.degrees(theta), np.degrees(phi), np.sin(theta)
    half = float(width_deg) / 2
    step = float(step_deg)
    # Distance (degrees of arc) to the nearest line of latitude, and of longitude.
    on_lat = np.abs((lat + step / 2) % step - step / 2) < half
    # Meridians stop one step short of the poles, where they would merge.
    on_lon = (np.abs((lon + step / 2) % step - step / 2) * s < half) & (np.abs(lat - 90) < 90 - step)
    rgb = np.full(d.shape[:-1] + (3,), 0.95)
    rgb = np.where((on_lat | on_lon)[..., None], [0.2, 0.2, 0.25], rgb)
    rgb = np.where((np.abs(lat - 90) < half)[..., None], [0.8, 0.2, 0.1], rgb)
    rgb = np.where((np.minimum(lon, 360 - lon) * s < half)[..., None], [0.1, 0.3, 0.8], rgb)
    return np.where(np.isnan(d).any(axis=-1)[..., None], np.nan, rgb)
