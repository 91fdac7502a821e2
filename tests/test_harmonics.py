"""sp.harmonics: the real spherical-harmonic transform of a surface through
its map (thesis 8.3), filters and the rotation-invariant spectrum."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import spherify as sp


def ellipsoid_map(level: int, axes=(2.0, 1.0, 0.5)) -> sp.SphereMap:
    """An icosphere scaled to an ellipsoid, mapped by its own unit vertices."""
    ico = sp.datasets.icosphere(subdivisions=level)
    return sp.SphereMap.from_points(sp.Mesh(ico.vertices * np.array(axes), ico.faces),
                                    ico.vertices)


def rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def relative_error(a: np.ndarray, b: np.ndarray, mesh: sp.Mesh) -> float:
    scale = np.linalg.norm(np.ptp(mesh.vertices, axis=0))
    return float(np.abs(a - b).max() / scale)


def test_an_ellipsoid_is_degree_one_up_to_its_discretisation() -> None:
    # x, y, z of an ellipsoid over its own sphere are a x, b y, c z: degree 1.
    # The piecewise-linear mesh differs by O(h^2), so the rms of the part
    # above degree 1 falls about fourfold per subdivision (h halves) and its
    # energy about sixteenfold. Measured: 3.9e-4, 1.3e-4, 3.4e-5, 1.1e-5 of
    # the rms at levels 2..5 (lmax 16, oversample 2).
    fractions = []
    for level in (2, 3, 4, 5):
        s = sp.harmonics.fit(ellipsoid_map(level), 16, oversample=2).spectrum()
        assert s[2:].sum() < 1e-3 * s.sum()
        fractions.append(np.sqrt(s[2:].sum() / s.sum()))
    ratios = np.array(fractions[:-1]) / np.array(fractions[1:])
    assert np.all((ratios > 2.5) & (ratios < 6.0)), ratios
    # Degree 1 holds the axes: x = a sqrt(4 pi / 3) Y(1, 1), and so on (the
    # flat faces sit inside the ellipsoid: 2e-4 smaller at level 5).
    c = sp.harmonics.fit(ellipsoid_map(5), 4).coefficients
    k = np.sqrt(4 * np.pi / 3)
    np.testing.assert_allclose(c[[3, 1, 2]], np.diag([2.0, 1.0, 0.5]) * k, rtol=5e-4, atol=1e-9)


@given(seed=st.integers(0, 2**32 - 1))
def test_the_spectrum_does_not_change_when_the_surface_is_rotated(seed: int) -> None:
    m = sp.embed(sp.datasets.bumpy_blob(400), "theta_phi")
    q = rotation(seed)
    turned = sp.SphereMap.from_points(sp.Mesh(m.mesh.vertices @ q.T, m.mesh.faces), m.points)
    a = sp.harmonics.fit(sp.SphereMap.from_points(m.mesh, m.points), 12).spectrum()
    b = sp.harmonics.fit(turned, 12).spectrum()
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9 * a.sum())


def test_a_translation_moves_degree_zero_only_and_scaling_scales_everything() -> None:
    m = ellipsoid_map(2)
    c = sp.harmonics.fit(m, 6).coefficients
    moved = sp.SphereMap.from_points(
        sp.Mesh(3.0 * m.mesh.vertices + [1.0, -2.0, 0.5], m.mesh.faces), m.points)
    d = sp.harmonics.fit(moved, 6).coefficients
    expected = 3.0 * c
    expected[0] += np.sqrt(4 * np.pi) * np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(d, expected, atol=1e-12)


def test_reconstruction_error_falls_as_lmax_grows() -> None:
    m = sp.embed(sp.datasets.bumpy_blob(2000), "theta_phi")
    errors = [relative_error(sp.harmonics.fit(m, l).to_mesh(m).vertices, m.mesh.vertices, m.mesh)
              for l in (2, 6, 12, 24)]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.25 * errors[0], errors


@pytest.mark.corpus
@pytest.mark.parametrize("name", ["spot", "hand"])
def test_reconstruction_error_falls_as_lmax_grows_on_the_corpus(shared_meshes, name: str) -> None:
    mesh = sp.load(shared_meshes / f"{name}.obj")
    m = sp.embed(mesh, "theta_phi")
    errors = [relative_error(sp.harmonics.fit(m, l).to_mesh(m).vertices, m.mesh.vertices, m.mesh)
              for l in (4, 12, 32)]
    assert errors[0] > errors[1] > errors[2], errors


def test_lowpass_of_lmax_is_the_fit_and_lower_cut_offs_keep_the_low_degrees() -> None:
    c = sp.harmonics.fit(ellipsoid_map(2), 10)
    assert np.array_equal(c.lowpass(10).coefficients, c.coefficients)
    assert np.array_equal(c.lowpass(50).coefficients, c.coefficients)
    low = c.lowpass(4)
    assert low.lmax == 4 and np.array_equal(low.coefficients, c.coefficients[:25])
    np.testing.assert_array_equal(low.spectrum(), c.spectrum()[:5])


def test_filters_do_what_they_say_per_degree() -> None:
    c = sp.harmonics.fit(sp.embed(sp.datasets.bumpy_blob(800), "theta_phi"), 16)
    assert np.array_equal(c.gaussian(0.0).coefficients, c.coefficients)
    assert np.array_equal(c.sharpen(0.0, 0.2).coefficients, c.coefficients)
    l = np.arange(17)
    g = np.exp(-l * (l + 1) * 0.1**2 / 2)
    np.testing.assert_allclose(c.gaussian(0.1).spectrum(), c.spectrum() * g**2, rtol=1e-12)
    sharp = c.sharpen(1.5, 0.1).spectrum()
    np.testing.assert_array_equal(sharp[:2], c.spectrum()[:2])
    assert np.all(sharp[2:] > c.spectrum()[2:])
    # A smoothed surface is closer to its own low degrees than the input.
    m = sp.embed(sp.datasets.bumpy_blob(800), "theta_phi")
    rough = sp.harmonics.fit(m, 16)
    smooth = rough.gaussian(0.15)
    assert smooth.spectrum()[8:].sum() < 0.2 * rough.spectrum()[8:].sum()
    with pytest.raises(sp.MeshError, match="gains"):
        c.filter(np.ones(3))
    with pytest.raises(sp.MeshError, match="sigma"):
        c.gaussian(-1.0)


def test_evaluate_at_the_grid_and_at_vertices_agrees_with_the_surface_for_a_round_map() -> None:
    ico = sp.datasets.icosphere(subdivisions=4)
    m = sp.SphereMap.from_points(ico, ico.vertices)
    c = sp.harmonics.fit(m, 3)
    # The unit sphere's coordinates are degree 1: rebuilt to the PL error.
    assert relative_error(c.to_mesh(m).vertices, ico.vertices, ico) < 2e-3
    assert c.to_mesh(m).n_faces == ico.n_faces


def test_the_fit_is_deterministic() -> None:
    m = sp.embed(sp.datasets.bumpy_blob(1000), "theta_phi")
    a = sp.harmonics.fit(m, 20, oversample=2)
    b = sp.harmonics.fit(m, 20, oversample=2)
    assert np.array_equal(a.coefficients, b.coefficients)
    p = m.points[:100]
    assert np.array_equal(a.evaluate(p), b.evaluate(p))
    assert a.info["n_theta"] == 42 and a.info["n_phi"] == 84
    assert set(a.info["seconds"]) == {"sample", "transform"}


def test_coefficients_are_read_only() -> None:
    c = sp.harmonics.fit(ellipsoid_map(1), 2)
    with pytest.raises(ValueError):
        c.coefficients[0, 0] = 1.0


def test_an_uncertified_map_has_no_harmonics() -> None:
    ico = sp.datasets.icosphere(subdivisions=2)
    points = ico.vertices.copy()
    points[0] = -points[0]
    with pytest.raises(sp.MapError, match="not a bijection"):
        sp.harmonics.fit(sp.SphereMap.from_points(ico, points), 4)


@pytest.mark.parametrize("kwargs, match", [
    ({"lmax": -1}, "lmax must be an integer >= 0"),
    ({"lmax": 2.5}, "lmax must be an integer"),
    ({"lmax": 2001}, "lmax = 2001: must be at most 2000"),
    ({"lmax": 4, "oversample": 0}, "oversample must be an integer >= 1"),
    ({"lmax": 4, "oversample": 9}, "oversample = 9"),
])
def test_bad_parameters_are_mesh_errors(kwargs, match: str) -> None:
    with pytest.raises(sp.MeshError, match=match):
        sp.harmonics.fit(ellipsoid_map(1), **kwargs)


def test_bad_coefficients_and_points_are_mesh_errors() -> None:
    with pytest.raises(sp.MeshError, match="not \\(lmax \\+ 1\\)\\*\\*2"):
        sp.harmonics.Harmonics(np.zeros((5, 3)))
    with pytest.raises(sp.MeshError, match="finite"):
        sp.harmonics.Harmonics(np.full((4, 3), np.nan))
    c = sp.harmonics.Harmonics(np.ones((4, 3)))
    with pytest.raises(sp.MeshError, match="row 1: .* not a unit vector"):
        c.evaluate([[0, 0, 1.0], [0, 0, 2.0]])
