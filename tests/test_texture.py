"""sp.texture: per-corner UVs from a sphere map (thesis 8.5), the atlas, the
procedural textures of sp.datasets and OBJ + MTL export."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import spherify as sp

PROJECTIONS = ["cube", "equirectangular", "octahedral"]


def rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


@pytest.fixture(scope="module")
def blob() -> sp.SphereMap:
    # Theta-phi: the figures measured in the comments below are of its map.
    return sp.embed(sp.datasets.bumpy_blob(1500), "theta_phi")


def uv_areas(uv: np.ndarray) -> np.ndarray:
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    areas: np.ndarray = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    return areas


@settings(max_examples=10)
@given(seed=st.integers(0, 2**32 - 1), projection=st.sampled_from(PROJECTIONS))
def test_uvs_are_in_the_unit_square_positive_and_point_back_at_their_vertices(
        blob: sp.SphereMap, seed: int, projection: str) -> None:
    # A turned copy of the map puts seams and poles anywhere.
    m = sp.SphereMap.from_points(blob.mesh, blob.points @ rotation(seed).T)
    t = sp.texture.uv(m, projection)
    assert t.uv.shape == (m.mesh.n_faces, 3, 2)
    assert t.uv.min() >= 0.0 and t.uv.max() <= 1.0
    # No face smeared across a seam or a pole: every UV triangle is positive.
    assert uv_areas(t.uv).min() > 0
    # Each corner's UV shows its own vertex's point of the sphere; for the
    # octahedral projection, except the few faces it reversed or left thin
    # and so gave an octant's projection (measured at most 21 of 2880 here
    # over 300 turns), whose corners show their points to some degrees on
    # this coarse mesh (at most 19.5 over those turns; 6.2 at 20k vertices).
    shown, want = t.direction_at(t.uv), m.points[m.mesh.faces]
    exact = np.ones(m.mesh.n_faces, dtype=bool)
    if projection == "octahedral":
        exact[t.params["projected"]] = False
        assert len(t.params["projected"]) <= m.mesh.n_faces // 100
        angle = np.arccos(np.clip(np.sum(shown * want, axis=-1), -1, 1))
        assert np.degrees(angle.max()) < 30
    np.testing.assert_allclose(shown[exact], want[exact], atol=1e-12)


def test_a_theta_phi_map_needs_no_moebius_step(blob: sp.SphereMap) -> None:
    t = sp.texture.uv(blob, "equirectangular")
    assert t.params["shift"] == 0 and np.array_equal(t.params["rotation"], np.eye(3))
    assert set(t.params["poles"]) == set(blob.poles)


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_texture_stretch_is_the_maps_stretch_times_the_projections(
        blob: sp.SphereMap, projection: str) -> None:
    # The texture map is the sphere map followed by the projection, whose own
    # stretch is bounded: gnomonic on [-L, L]^2 stretches by 1 to 1 + 2 L^2;
    # equirectangular (with the Moebius step) by 1 / sin(theta) along phi,
    # bounded on the faces by the smallest corner sine. Measured here: 1.39
    # (cube) and 1.45 (equirectangular) against 1.35 for the sphere.
    t = sp.texture.uv(blob, projection)
    sphere = sp.quality(blob.mesh, blob.points)["stretch_l2"]
    texture = t.quality(blob.mesh)["stretch_l2"]
    # The octahedral map: gnomonic onto an octant's face and affine, 1.02 here
    # (1.006 to 1.26 times the sphere's over 30 turns of this mesh; without
    # the octant projection of the faces its bends leave thin, up to 31).
    bound = 1 + 2 * t.params["extent"] ** 2 if projection == "cube" else 3.0
    assert sphere / bound <= texture <= sphere * bound
    # And it is the core's measure of the exploded mesh against its UVs.
    corners = blob.mesh.vertices[blob.mesh.faces].reshape(-1, 3)
    flat = np.c_[t.uv.reshape(-1, 2), np.zeros(len(corners))]
    direct = sp.quality((corners, np.arange(len(corners)).reshape(-1, 3)), flat)
    assert direct["stretch_l2"] == texture


def test_baking_the_checkerboard_shows_it_on_the_surface(blob: sp.SphereMap) -> None:
    t = sp.texture.uv(blob, "cube")
    image = t.bake(sp.datasets.checkerboard, 600)
    assert image.shape == (600, 900, 3) and 0 <= image.min() and image.max() <= 1
    # The colour the atlas gives a surface point is the checkerboard's at its
    # sphere point, except within a pixel or so of a square's border.
    rng = np.random.default_rng(0)
    f = rng.integers(0, blob.mesh.n_faces, 2000)
    w = rng.dirichlet([1, 1, 1], 2000)
    seen = t.sample(image, f, w)
    want = sp.datasets.checkerboard(t.direction_at(np.einsum("kj,kjd->kd", w, t.uv[f])))
    assert np.mean(np.all(np.abs(seen - want) < 1e-12, axis=1)) > 0.97


def test_procedural_textures() -> None:
    d = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [np.nan, 0, 0]])
    c = sp.datasets.checkerboard(d, squares=4)
    assert c.shape == (4, 3) and np.isnan(c[3]).all() and np.all((0 <= c[:3]) & (c[:3] <= 1))
    assert not np.array_equal(c[1], c[2])  # a quarter turn apart: other colour or the marker
    g = sp.datasets.lat_long_grid(d, step_deg=30)
    assert g.shape == (4, 3)
    with pytest.raises(sp.MeshError):
        sp.datasets.checkerboard(d, squares=0)
    with pytest.raises(sp.MeshError):
        sp.datasets.lat_long_grid(d, step_deg=10, width_deg=20)


def test_obj_export_with_a_material_and_image(blob: sp.SphereMap, tmp_path: Path) -> None:
    t = sp.texture.uv(blob, "equirectangular")
    image = t.bake(sp.datasets.lat_long_grid, 64)
    path = tmp_path / "textured.obj"
    sp.texture.save_obj(blob.mesh, path, t, image)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["textured.mtl", "textured.obj",
                                                          "textured.png"]
    text = path.read_text().splitlines()
    assert "mtllib textured.mtl" in text and "map_Kd textured.png" in (tmp_path / "textured.mtl"
                                                                     ).read_text()
    vts = np.array([[float(x) for x in line.split()[1:]] for line in text if line.startswith("vt ")])
    np.testing.assert_array_equal(vts, t.uv.reshape(-1, 2))
    back = sp.load(path)
    np.testing.assert_allclose(back.vertices, blob.mesh.vertices)
    np.testing.assert_array_equal(back.faces, blob.mesh.faces)
    assert (tmp_path / "textured.png").read_bytes()[:4] == b"\x89PNG"


def test_octahedral_layout_is_praun_and_hoppes_square() -> None:
    # The unit octahedron's vertices: the north pole at the centre, the
    # equator's four at the edge midpoints of the square, the south pole at
    # the corners; its eight faces are the square's eight triangles.
    points = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5],
                      [3, 1, 5], [0, 3, 5]])
    m = sp.SphereMap.from_points(sp.Mesh(points, faces), points)
    t = sp.texture.uv(m, "octahedral")
    assert t.params["extent"] == pytest.approx(1.0) and len(t.params["projected"]) == 0
    st = t.uv * 2 - 1
    np.testing.assert_allclose(st[0], [[1, 0], [0, 1], [0, 0]], atol=1e-9)
    np.testing.assert_allclose(st[4], [[0, 1], [1, 0], [1, 1]], atol=1e-9)
    np.testing.assert_allclose(uv_areas(t.uv), 0.25)  # eight halves of quarters
    assert uv_areas(t.uv).min() > 0
    assert t.bake(sp.datasets.checkerboard, 32).shape == (32, 32, 3)


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_save_writes_per_corner_uvs_and_a_material(blob: sp.SphereMap, tmp_path: Path,
                                                   projection: str) -> None:
    t = sp.texture.uv(blob, projection)
    image = t.bake(sp.datasets.checkerboard, 32)
    # A layout or its array, with an image array: as sp.texture.save_obj.
    sp.save(blob.mesh, tmp_path / "a.obj", uv=t, texture=image)
    sp.texture.save_obj(blob.mesh, tmp_path / "b.obj", t, image)
    for suffix in (".obj", ".mtl", ".png"):
        assert ((tmp_path / f"a{suffix}").read_bytes().replace(b"a.", b"b.")
                == (tmp_path / f"b{suffix}").read_bytes())
    sp.save(blob.mesh, tmp_path / "c.obj", uv=t.uv, texture=image)
    vts = [line for line in (tmp_path / "c.obj").read_text().splitlines() if line.startswith("vt ")]
    assert len(vts) == 3 * blob.mesh.n_faces
    np.testing.assert_array_equal([[float(x) for x in v.split()[1:]] for v in vts],
                                  t.uv.reshape(-1, 2))
    back = sp.load(tmp_path / "c.obj")
    np.testing.assert_array_equal(back.faces, blob.mesh.faces)
    np.testing.assert_allclose(back.vertices, blob.mesh.vertices)


def test_save_references_a_texture_file(blob: sp.SphereMap, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    sp.texture.write_png(np.zeros((2, 2, 3)), "earth.png")
    t = sp.texture.uv(blob, "octahedral")
    sp.save(blob.mesh, "out/m.obj", uv=t.uv, texture="earth.png")
    assert "map_Kd ../earth.png" in (tmp_path / "out" / "m.mtl").read_text()
    assert "mtllib m.mtl" in (tmp_path / "out" / "m.obj").read_text()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["m.mtl", "m.obj"]
    # Per-vertex UVs with a texture go through the same writer, one vt per
    # corner; without a texture they stay the core's per-vertex vt.
    per_vertex = np.random.default_rng(0).random((blob.mesh.n_vertices, 2))
    sp.save(blob.mesh, "out/v.obj", uv=per_vertex, texture=tmp_path / "earth.png")
    vts = [line for line in (tmp_path / "out" / "v.obj").read_text().splitlines()
           if line.startswith("vt ")]
    assert len(vts) == 3 * blob.mesh.n_faces
    assert "map_Kd " + (tmp_path / "earth.png").as_posix() in (tmp_path / "out" / "v.mtl"
                                                                ).read_text()
    sp.save(blob.mesh, "out/w.obj", uv=per_vertex)
    assert not (tmp_path / "out" / "w.mtl").exists()
    np.testing.assert_array_equal(sp.load("out/w.obj").attributes["uv"], per_vertex)


def test_save_refuses_textures_it_cannot_write(blob: sp.SphereMap, tmp_path: Path) -> None:
    t = sp.texture.uv(blob, "cube")
    image = np.zeros((4, 4, 3))
    for name in ("m.ply", "m.stl", "m.off", "m.npz"):
        with pytest.raises(sp.MeshError, match="only"):
            sp.save(blob.mesh, tmp_path / name, uv=t, texture=image)
        with pytest.raises(sp.MeshError, match="only"):
            sp.save(blob.mesh, tmp_path / name, uv=t.uv)
    with pytest.raises(sp.MeshError, match="needs texture coordinates"):
        sp.save(blob.mesh, tmp_path / "m.obj", texture=image)
    with pytest.raises(sp.MeshError, match="shape"):
        sp.save(blob.mesh, tmp_path / "m.obj", uv=t.uv[:-1], texture=image)
    bad = t.uv.copy()
    bad[7, 1, 0] = np.nan
    with pytest.raises(sp.MeshError, match="face 7"):
        sp.save(blob.mesh, tmp_path / "m.obj", uv=bad)
    with pytest.raises(sp.FormatError, match="sphere"):
        sp.save(blob.mesh, tmp_path / "m.obj", uv=t, sphere=blob.points)
    assert list(tmp_path.iterdir()) == []


def test_bad_arguments(blob: sp.SphereMap) -> None:
    with pytest.raises(sp.MeshError, match="unknown projection"):
        sp.texture.uv(blob, "mercator")
    octa = sp.Mesh(np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                             [0, 0, -1]]),
                   np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5],
                             [3, 1, 5], [0, 3, 5]]))
    with pytest.raises(sp.MeshError, match="too large for the cube projection"):
        sp.texture.uv(sp.SphereMap.from_points(octa, octa.vertices), "cube")


@pytest.mark.parametrize("name", ["evil\nmap_Kd stolen.png.obj", "two words.obj", "tab\there.obj"])
def test_a_name_an_obj_cannot_reference_is_refused_before_anything_is_written(
        name: str, tmp_path: Path) -> None:
    # Issue 26, finding 9: a newline in the name wrote lines of its own
    # (mtllib, map_Kd) into the .obj and the .mtl.
    m = sp.embed(sp.datasets.make("icosphere", 200))
    layout = sp.texture.uv(m, "cube")
    with pytest.raises(sp.MeshError, match="cannot carry"):
        sp.texture.save_obj(m.mesh, tmp_path / name, layout, layout.bake(sp.datasets.checkerboard, 16))
    assert list(tmp_path.iterdir()) == []


def test_a_texture_that_is_not_finite_is_refused(tmp_path: Path) -> None:
    # Issue 26, finding 9: an all-NaN image was written (as black) without a word.
    m = sp.embed(sp.datasets.make("icosphere", 200))
    layout = sp.texture.uv(m, "cube")
    image = layout.bake(sp.datasets.checkerboard, 16)
    image[0, 0, 0] = np.nan
    with pytest.raises(sp.MeshError, match=r"1 of the image's \d+ values are not finite"):
        sp.texture.save_obj(m.mesh, tmp_path / "x.obj", layout, image)
    with pytest.raises(sp.MeshError, match="not finite"):
        sp.texture.write_png(np.full((4, 4, 3), np.nan), tmp_path / "x.png")
    assert list(tmp_path.iterdir()) == []
