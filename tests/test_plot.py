"""sp.plot: headless pictures (matplotlib, Agg), and sp.face_quality, the
per-face measures they colour by."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import spherify as sp

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def blob() -> sp.ThetaPhiMap:
    m = sp.embed(sp.datasets.bumpy_blob(600), "theta_phi")
    assert isinstance(m, sp.ThetaPhiMap)
    return m


@pytest.fixture(scope="module")
def default_map() -> sp.SphereMap:
    """The map of sp.embed's default method (progressive): no rectangle."""
    m = sp.embed(sp.datasets.bumpy_blob(600))
    assert not isinstance(m, sp.ThetaPhiMap)
    return m


def is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 3000


@pytest.mark.parametrize("color", sp.plot.COLORS)
@pytest.mark.parametrize("which", ["blob", "default_map"])
def test_sphere_pictures_for_every_colouring(which: str, color: str, tmp_path: Path,
                                             request: pytest.FixtureRequest) -> None:
    m = request.getfixturevalue(which)
    path = tmp_path / f"{color}.png"
    sp.plot.sphere(m, color=color, path=path)
    assert is_png(path)


def test_mesh_and_rectangle_pictures(blob: sp.ThetaPhiMap, tmp_path: Path) -> None:
    sp.plot.mesh(blob.mesh, path=tmp_path / "a.png")
    q = sp.face_quality(blob.mesh, blob.points)
    sp.plot.mesh(blob.mesh, values=q["stretch"], edges=True, path=tmp_path / "b.png")
    sp.plot.mesh(blob.mesh, colors=np.tile([0.2, 0.5, 0.9], (blob.mesh.n_faces, 1)),
                 path=tmp_path / "c.png")
    sp.plot.rectangle(blob, path=tmp_path / "r.png")
    assert all(is_png(tmp_path / f"{n}.png") for n in "abcr")
    fig = sp.plot.mesh(blob.mesh)
    assert fig.axes
    import matplotlib.pyplot as plt

    plt.close(fig)
    # limits= fixes the colour scale (a signed quantity centred on 0).
    fig = sp.plot.mesh(blob.mesh, values=q["area_log"], cmap="coolwarm", limits=(-2, 2))
    colorbar = fig.axes[-1]
    assert colorbar.get_ylim() == (-2.0, 2.0)
    plt.close(fig)


def test_bad_arguments(blob: sp.ThetaPhiMap, default_map: sp.SphereMap) -> None:
    with pytest.raises(sp.MeshError, match="unknown color"):
        sp.plot.sphere(blob, color="rainbow")
    with pytest.raises(sp.MeshError, match="one entry per face"):
        sp.plot.mesh(blob.mesh, values=[1.0, 2.0])
    for limits in [(1.0, 1.0), (2.0, 1.0), (0.0, np.inf), (0.0, 1.0, 2.0)]:
        with pytest.raises(sp.MeshError, match="low < high"):
            sp.plot.mesh(blob.mesh, values=np.zeros(blob.mesh.n_faces), limits=limits)
    radial = sp.embed(sp.datasets.icosphere(subdivisions=1), "radial")
    with pytest.raises(sp.MeshError, match="theta-phi"):
        sp.plot.rectangle(radial)
    with pytest.raises(sp.MeshError, match="theta-phi"):
        sp.plot.rectangle(default_map)


def test_face_quality_agrees_with_quality(blob: sp.ThetaPhiMap) -> None:
    q = sp.quality(blob.mesh, blob.points)
    f = sp.face_quality(blob.mesh, blob.points)
    assert set(f) == {"angle_max_deg", "conformal", "area_log", "stretch"}
    assert all(v.shape == (blob.mesh.n_faces,) for v in f.values())
    assert np.nanmax(f["angle_max_deg"]) == pytest.approx(q["angle_max_deg"], rel=1e-12)
    assert np.nanmean(f["conformal"]) == pytest.approx(q["conformal_mean"], rel=1e-12)
    assert np.nanstd(f["area_log"]) == pytest.approx(q["area_log_std"], rel=1e-9)
    V, F = blob.mesh.vertices, blob.mesh.faces
    area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    l2 = np.sqrt(np.nansum(f["stretch"] ** 2 * area) / area.sum())
    assert l2 == pytest.approx(q["stretch_l2"], rel=1e-9)
    with pytest.raises(sp.MeshError):
        sp.face_quality(blob.mesh, blob.points[:-1])


def test_up_turns_a_y_up_model_upright(tmp_path: Path) -> None:
    """issue 24: Y-up models (most scans, OBJ and glTF files) were drawn lying
    down; up="y" draws their y axis upwards, by a rotation (no mirror)."""
    from spherify.plot import _upright

    V = np.eye(3)
    turned = _upright(V, "y")
    assert np.array_equal(turned[1], [0.0, 0.0, 1.0])  # y is drawn as the vertical
    assert np.linalg.det(turned) == 1.0  # a rotation: faces keep their orientation
    assert np.array_equal(_upright(V, "z"), V)
    tall = sp.datasets.ellipsoid(n_vertices=300, axes=(0.3, 1.0, 0.3))  # long along y
    fig = sp.plot.mesh(tall, up="y", path=tmp_path / "up.png")
    assert (tmp_path / "up.png").stat().st_size > 0 and fig is not None
    m = sp.embed(tall)
    sp.plot.sphere(m, up="y", path=tmp_path / "sphere.png")
    with pytest.raises(sp.MeshError, match="up must be one of z, y, x"):
        sp.plot.mesh(tall, up="w")
    with pytest.raises(sp.MeshError, match="up must be one of"):
        sp.plot.sphere(m, up="-y")
