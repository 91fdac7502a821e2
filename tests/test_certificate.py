"""The certificate of a map is the core's and cannot be forged from Python.

A ``SphereMap`` holds the core's result: ``valid``, ``tp_valid`` and the
report are read-only properties, every array it hands out is read-only, and
``to_surface`` asks the core, which decides from its own certificate whether
h^-1 is defined, whatever was done to the Python object.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import spherify as sp


def uncertified_theta_phi() -> sp.ThetaPhiMap:
    """A theta-phi map whose rectangle double precision cannot hold."""
    mesh = sp.datasets.tentacles(n_vertices=6000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        m = sp.embed(mesh, method="theta_phi")
    assert isinstance(m, sp.ThetaPhiMap)
    assert not m.tp_valid, "tentacles at 6,000 vertices was expected to be uncertified"
    return m


def invalid_radial() -> sp.SphereMap:
    """A radial map from outside the mesh: points, but not a GC-embedding."""
    m = sp.embed(sp.datasets.icosphere(subdivisions=2), "radial", center=(3.0, 0.5, 0.25))
    assert not m.valid and m.flipped > 0
    return m


@pytest.mark.parametrize("attribute", ["valid", "flipped", "report", "points", "method",
                                       "status", "message", "iterations", "mesh"])
def test_what_describes_a_map_cannot_be_assigned(attribute: str) -> None:
    m = invalid_radial()
    with pytest.raises(AttributeError):
        setattr(m, attribute, getattr(m, attribute))


def test_tp_valid_cannot_be_assigned_and_to_surface_still_refuses() -> None:
    m = uncertified_theta_phi()
    with pytest.raises(AttributeError):
        m.tp_valid = True  # type: ignore[misc]
    with pytest.raises(AttributeError):
        m.valid = True  # type: ignore[misc]
    with pytest.raises(sp.MapError, match="tp_valid"):
        m.to_surface(np.array([[0.0, 0.0, 1.0]]))


def test_arrays_are_read_only() -> None:
    m = uncertified_theta_phi()
    for array in (m.points, m.theta_phi, m.cut_path, m.cut_original, m.report.flipped_faces):
        with pytest.raises(ValueError):
            array[0] = 0
    # details is a fresh dict each time: editing it changes nothing.
    m.details["min_area_ratio"] = 1.0
    assert m.details["min_area_ratio"] != 1.0


def test_an_edited_copy_of_the_points_does_not_change_the_map() -> None:
    m = invalid_radial()
    forged = m.points.copy()
    forged[:] = sp.embed(sp.datasets.icosphere(subdivisions=2), "radial").points
    assert not m.valid
    with pytest.raises(sp.MapError, match="not a valid GC-embedding"):
        m.to_surface(np.array([[1.0, 0.0, 0.0]]))


def test_the_core_result_cannot_be_changed_either() -> None:
    m = invalid_radial()
    core = m._core
    with pytest.raises(AttributeError):
        core.valid = True  # type: ignore[misc]
    with pytest.raises(sp.MapError):
        core.to_surface(np.array([[1.0, 0.0, 0.0]]))


def test_a_certified_map_answers() -> None:
    m = sp.embed(sp.datasets.icosphere(subdivisions=2), "radial")
    assert m.valid
    faces, bary, xyz = m.to_surface(m.points[:5])
    np.testing.assert_allclose(xyz, m.mesh.vertices[:5], atol=1e-12)


def test_theta_phi_arrays_are_named_and_only_on_theta_phi_maps() -> None:
    m = sp.embed(sp.datasets.icosphere(subdivisions=1), method="theta_phi")
    assert isinstance(m, sp.ThetaPhiMap)
    np.testing.assert_array_equal(m._core.theta_phi_array("theta_phi"), m.theta_phi)
    with pytest.raises(sp.MeshError, match="no theta-phi array"):
        m._core.theta_phi_array("points")
    with pytest.raises(sp.MeshError, match="no theta-phi array"):
        invalid_radial()._core.theta_phi_array("theta_phi")
