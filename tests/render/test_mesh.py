"""Meshes: reading, primary rays, shadow rays and the visibility factor."""

from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
import trimesh

from brdfkit.brdf import Lambertian
from brdfkit.errors import FormatError, ParameterError
from brdfkit.light import DirectionalLight, EnvironmentMap, PointLight, SunSky, UniformSky
from brdfkit.render import (
    Sphere,
    gbuffer,
    interior_mask,
    progressive,
    reflected_radiance,
    shade,
)
from brdfkit.render._mesh_kernels import shadow_rays as compiled_shadow_rays
from brdfkit.render.mesh import MeshScene, render_mesh, shadow_rays, torus_over_plane
from brdfkit.render.mitsuba_frame import (
    MITSUBA_ENVMAP_ROTATION,
    RotatedLight,
    look_at_camera,
    mitsuba_oriented,
)

FRONT = ((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def _square(size: float = 1.0, height: float = 0.0) -> trimesh.Trimesh:
    """A square of half-width ``size`` at z = ``height``, facing +z."""
    corners = [[-size, -size, height], [size, -size, height], [size, size, height]]
    corners.append([-size, size, height])
    return trimesh.Trimesh(corners, [[0, 1, 2], [0, 2, 3]], process=False)


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".glb"])
def test_every_format_reads_the_same_surface(suffix, tmp_path):
    torus = torus_over_plane(sections=12)
    path = tmp_path / f"scene{suffix}"
    torus.export(path)
    scene = MeshScene.from_file(path)
    triangles = scene.vertices[scene.faces]
    area = np.linalg.norm(
        np.cross(*(triangles[:, 1:] - triangles[:, :1]).transpose(1, 0, 2)), axis=-1
    )
    assert len(scene.faces) == len(torus.faces)
    assert math.isclose(area.sum() / 2, torus.area, rel_tol=1e-6)
    assert np.allclose(np.linalg.norm(scene.vertex_normals, axis=-1), 1.0)


def test_the_files_normals_are_kept(tmp_path):
    square = _square()
    tilted = np.tile([0.6, 0.0, 0.8], (4, 1))
    trimesh.Trimesh(square.vertices, square.faces, vertex_normals=tilted, process=False).export(
        tmp_path / "square.ply", vertex_normal=True
    )
    scene = MeshScene.from_file(tmp_path / "square.ply")
    assert np.allclose(scene.vertex_normals, tilted)
    g = scene.gbuffer(look_at_camera(*FRONT), 4)
    assert np.allclose(g.normals[g.mask], [0.6, 0.0, 0.8], atol=1e-6)
    assert np.allclose(g.geometric_normals[g.mask], [0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    ("name", "content", "expected"),
    [
        ("mesh.txt", b"", "must be one of"),
        ("mesh.ply", b"not a ply file", "cannot read"),
        ("mesh.obj", b"v 0 0 0\nv 1 0 0\n", "no triangles"),
    ],
)
def test_bad_files_raise_errors_naming_them(name, content, expected, tmp_path):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(FormatError, match=expected) as error:
        MeshScene.from_file(path)
    assert name in str(error.value)


def test_gbuffer_of_a_sphere_mesh_matches_the_analytic_sphere():
    ball = trimesh.creation.icosphere(subdivisions=5)
    scene = MeshScene.from_trimesh(ball)
    camera = look_at_camera((10.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    mesh, exact = scene.gbuffer(camera, 32), gbuffer(Sphere(), camera, 32)
    both = mesh.mask & exact.mask
    assert np.count_nonzero(mesh.mask ^ exact.mask) <= 0.02 * both.sum()  # the silhouette
    inner = both & interior_mask(32, margin=0.2)  # the depth of grazing hits varies more
    assert np.allclose(mesh.points[inner], exact.points[inner], atol=2e-3)
    assert np.allclose(mesh.normals[inner], exact.normals[inner], atol=2e-3)
    assert np.allclose(mesh.wo, exact.wo)
    frame_dot = np.sum(mesh.tangents * mesh.normals, axis=-1)
    assert np.allclose(frame_dot, 0.0, atol=1e-9)


def test_fov_spans_the_image_width():
    size = (30, 20)  # portrait: the width is the smaller side
    camera = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 50.0, size)
    _, directions = camera.rays(*size)
    # the outer pixel centres lie half a pixel inside the edges of the horizontal fov
    left, right = directions[15, 0], directions[15, -1]
    half_width = math.tan(math.radians(25)) * (1 - 1 / size[1])
    assert math.isclose(right[0] / -right[2], half_width, rel_tol=1e-9)
    assert math.isclose(left[0] / -left[2], -half_width, rel_tol=1e-9)


def test_cast_shadow_is_the_occluders_projection():
    """A roof at z = 1 over the floor, light towards (1, 0, 1): its shadow on the floor is
    the roof shifted by −1 in x; every other floor pixel reflects exactly ρE cos/π."""
    roof = _square(0.5, 1.0).apply_translation([0.5, 0.0, 0.0])
    scene = MeshScene.from_trimesh(trimesh.util.concatenate([_square(2.0), roof]))
    sun = DirectionalLight((1.0, 0.0, 1.0), irradiance=math.pi * math.sqrt(2))
    camera = look_at_camera((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    image = render_mesh(scene, Lambertian(0.5), sun, camera, 40)[..., 0]
    x = ((np.arange(40) + 0.5) / 20 - 1)[None, :] + 0 * image
    y = (1 - (np.arange(40) + 0.5) / 20)[:, None] + 0 * image
    in_shadow = (x > -1) & (x < 0) & (np.abs(y) < 0.5)
    assert np.all(image[in_shadow] == 0.0)
    assert np.allclose(image[~in_shadow], 0.5, rtol=1e-12)  # no shadow acne


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_compiled_shadow_rays_are_the_readable_ones_bit_for_bit(dtype):
    """Per point a pixel's samples (the compiled shader's layout): the compiled loop writes
    the rays of :func:`shadow_rays`, in its order, to the last bit; grazing directions
    (n·ω = 0, no offset), finite and infinite distances, and zero distances (no ray)."""
    rng = np.random.default_rng(3)
    points, normals = rng.normal(size=(2, 40, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    wi = rng.normal(size=(40, 6, 3)).astype(dtype)
    wi[0, 0] = np.cross(normals[0], [0.0, 0.0, 1.0])  # grazing
    distance = rng.choice([0.0, np.inf, 2.5, 1e-9], size=(40, 6))
    expected = shadow_rays(points[:, None], normals[:, None], wi, distance, 1e-4)
    origins, directions = np.empty((2, 240, 3), np.float32)
    far, index = np.empty(240, np.float32), np.empty(240, np.int64)
    written = compiled_shadow_rays()(
        points, normals, wi, distance, 1e-4, origins, directions, far, index
    )
    assert written == np.count_nonzero(distance > 0)
    got = origins[:written], directions[:written], far[:written], index[:written]
    for a, b in zip(got, expected, strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)


def test_shadow_rays_in_small_batches_wait_before_each_and_see_the_same():
    """``before_batch`` is called before each round of batches (one batch of at most 8192
    rays per core), and the answer is the same."""
    scene = MeshScene.from_trimesh(torus_over_plane(sections=12))
    rng = np.random.default_rng(5)
    points = rng.uniform(-1, 1, size=(60, 1, 3)) + np.array([0.0, 0.3, 0.0])
    normals = np.broadcast_to([0.0, 1.0, 0.0], points.shape)
    wi = rng.normal(size=(60, 500, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    distance = np.full((60, 500), np.inf)
    calls = []
    waited = scene.unoccluded(points, normals, wi, distance, lambda: calls.append(1))
    assert np.array_equal(waited, scene.unoccluded(points, normals, wi, distance))
    rounds = -(-math.ceil(30000 / 8192) // len(os.sched_getaffinity(0)))
    assert len(calls) == rounds and 0 < waited.mean() < 1


def test_point_lights_are_shadowed_only_by_what_lies_before_them():
    roof = _square(3.0, 2.0)
    scene = MeshScene.from_trimesh(trimesh.util.concatenate([_square(), roof]))
    camera = look_at_camera((0.0, 0.0, 1.5), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 60.0)
    below = PointLight((0.0, 0.0, 1.0), intensity=1.0)  # under the roof: it lights the floor
    above = PointLight((0.0, 0.0, 3.0), intensity=1.0)  # over the roof: the floor is dark
    lit = render_mesh(scene, Lambertian(0.5), below, camera, 8)
    dark = render_mesh(scene, Lambertian(0.5), above, camera, 8)
    assert np.all(lit > 0) and np.all(dark == 0)


def test_a_closed_box_keeps_out_every_light_and_brdf_sample():
    """Inside a closed box the floor sees no sky: every MIS sample is occluded."""
    box = trimesh.creation.box((4.0, 4.0, 4.0))
    box.invert()  # faces inwards, towards the camera inside
    box.unmerge_vertices()  # flat walls: vertex normals are the faces' (no light leaks)
    scene = MeshScene.from_trimesh(trimesh.util.concatenate([box, _square(1.0, -1.0)]))
    camera = look_at_camera((0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 60.0)
    env = EnvironmentMap(np.ones((8, 16, 1)))
    image = render_mesh(scene, Lambertian(0.5), [env, UniformSky(1.0)], camera, 8, samples=8)
    assert np.all(image == 0.0)


def test_white_out_holds_on_a_convex_mesh():
    """Nothing occludes a convex object's upper hemisphere: under a uniform map a Lambertian
    icosphere (flat faces) reflects ρL (MIS with the visibility factor stays unbiased)."""
    ball = trimesh.creation.icosphere(subdivisions=2)
    ball.unmerge_vertices()  # vertex normals are the faces': no direction is half-hidden
    scene = MeshScene.from_trimesh(ball)
    camera = look_at_camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    uniform = EnvironmentMap(np.full((8, 16, 1), 2.0))
    image = render_mesh(scene, Lambertian(0.5), uniform, camera, 8, samples=256)
    mask = scene.gbuffer(camera, 8).mask
    assert mask.sum() >= 16
    assert np.allclose(image[mask, 0], 1.0, atol=0.03)


def test_visibility_true_everywhere_changes_nothing_and_false_blacks_out():
    rng = np.random.default_rng(1)
    wo = rng.normal(size=(6, 3)) + np.array([0.0, 0.0, 2.0])
    env = EnvironmentMap(rng.random((8, 16, 3)))
    lights = [env, DirectionalLight((0.3, 0.2, 1.0), irradiance=2.0)]
    options = {"method": "mis", "samples": 16, "seed": 3}
    plain = reflected_radiance(Lambertian(0.5), lights, wo, **options).value
    seen = reflected_radiance(
        Lambertian(0.5), lights, wo, **options,
        visibility=lambda p, wi, d: np.ones(np.shape(wi)[:-1], dtype=bool),
    ).value  # fmt: skip
    hidden = reflected_radiance(
        Lambertian(0.5), lights, wo, **options,
        visibility=lambda p, wi, d: np.zeros(np.shape(wi)[:-1], dtype=bool),
    ).value  # fmt: skip
    assert np.array_equal(plain, seen)
    assert np.all(hidden == 0) and np.all(plain > 0)
    with pytest.raises(ValueError, match="quadrature"):
        reflected_radiance(Lambertian(0.5), env, wo, method="quadrature", visibility=np.ones)


def test_without_embree_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", None)  # import embreex now fails
    scene = MeshScene.from_trimesh(_square())
    with pytest.raises(ParameterError, match=r"brdfkit\[mesh\]"):
        scene.gbuffer(look_at_camera(*FRONT), 4)


def test_progressive_passes_carry_the_shadows():
    """Passes of a mesh render (with their noise estimate) converge to the one-shot image."""
    scene = MeshScene.from_trimesh(torus_over_plane(sections=12))
    camera = look_at_camera((0.0, 2.2, 3.2), (0.0, 0.4, 0.0), (0.0, 1.0, 0.0), 40.0, (6, 8))
    g = scene.gbuffer(camera, (6, 8))
    lights = [EnvironmentMap(np.ones((8, 16, 1))), DirectionalLight((0.5, 1.0, 0.3))]
    passes = list(
        progressive(g, Lambertian(0.5), lights, max_samples=16, visibility=scene.visibility(g))
    )
    once = render_mesh(scene, Lambertian(0.5), lights, camera, (6, 8), samples=16)
    last = passes[-1]
    assert last.samples == 16 and last.error is not None
    assert np.all(np.abs(last.image - once) <= 5 * last.error + 0.05)
    unshadowed = shade(g, Lambertian(0.5), lights, samples=16, compiled=False)
    assert np.abs(last.image - unshadowed).max() > 0.1  # the shadows are there


def test_skies_turn_to_mitsubas_up_axis_as_maps_do():
    """A sky's zenith becomes +y (the maps' pole); its samples keep value · pdf = radiance and
    a floor facing +y under the turned uniform sky shows white-out, ρL."""
    sky = SunSky(sun_direction=(0.0, 0.6, 0.8), resolution=(8, 16))
    turned = mitsuba_oriented(sky)
    zenith = sky.incident_radiance(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    assert np.allclose(turned.incident_radiance(np.zeros(3), np.array([0.0, 1.0, 0.0])), zenith)
    sun = MITSUBA_ENVMAP_ROTATION @ sky.sun_direction
    assert np.allclose(sun, [0.6, 0.8, 0.0])
    assert turned.incident_radiance(np.zeros(3), sun)[1] > 1e4
    u = np.random.default_rng(2).random((64, 2))
    s = turned.sample(np.zeros((64, 3)), u)
    radiance = turned.incident_radiance(np.zeros((64, 3)), s.wi)
    assert np.allclose(s.value * s.pdf[:, None], radiance)
    assert np.allclose(turned.pdf(np.zeros((64, 3)), s.wi), s.pdf)
    floor = trimesh.Trimesh(
        [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], [[0, 2, 1], [0, 3, 2]], process=False
    )
    camera = look_at_camera((0.0, 3.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0))
    uniform = mitsuba_oriented(UniformSky(2.0))
    image = render_mesh(MeshScene.from_trimesh(floor), Lambertian(0.5), uniform, camera, 4)
    assert np.allclose(image, 1.0, atol=0.05)
    with pytest.raises(ParameterError, match="delta"):
        RotatedLight(DirectionalLight(), MITSUBA_ENVMAP_ROTATION)


OBJ_TWO_MATERIALS = """mtllib two.mtl
v -1 -1 0
v 0 -1 0
v 0 1 0
v -1 1 0
v 1 -1 0
v 1 1 0
usemtl paint
f 1 2 3
f 1 3 4
usemtl chalk
f 2 5 6
f 2 6 3
"""


@pytest.mark.parametrize("suffix", [".obj", ".glb"])
def test_each_material_of_the_file_gets_its_brdf(suffix, tmp_path):
    """Two squares side by side, materials "paint" (left) and "chalk" (right): lit head-on
    with irradiance π, each reflects its own ρ."""
    (tmp_path / "two.mtl").write_text("newmtl paint\nKd 0.8 0.1 0.1\nnewmtl chalk\nKd 1 1 1\n")
    (tmp_path / "two.obj").write_text(OBJ_TWO_MATERIALS)
    path = tmp_path / f"two{suffix}"
    if suffix == ".glb":  # the same squares as glTF primitives with named materials
        parts = trimesh.load_scene(tmp_path / "two.obj", process=False).geometry
        for name, part in parts.items():
            material = trimesh.visual.material.PBRMaterial(name=name)
            part.visual = trimesh.visual.TextureVisuals(material=material)
        trimesh.Scene(list(parts.values())).export(path)
    scene = MeshScene.from_file(path)
    assert sorted(scene.materials) == ["chalk", "paint"]
    paint = scene.materials.index("paint")
    left = scene.vertices[scene.faces].mean(axis=1)[:, 0] < 0
    assert np.array_equal(scene.face_materials == paint, left)
    light = DirectionalLight((0.0, 0.0, 1.0), irradiance=math.pi)
    brdfs = {"paint": Lambertian(0.2), "chalk": Lambertian([0.9, 0.8, 0.7])}
    image = render_mesh(scene, brdfs, light, look_at_camera(*FRONT), (2, 4))
    assert np.allclose(image[:, :2], 0.2) and np.allclose(image[:, 2:], [0.9, 0.8, 0.7])
    with pytest.raises(ParameterError, match=r"missing.*chalk"):
        render_mesh(scene, {"paint": Lambertian(0.2)}, light, look_at_camera(*FRONT), 2)
    plain = MeshScene.from_trimesh(_square())
    assert plain.materials == () and plain.face_materials is None
    with pytest.raises(ParameterError, match="materials"):
        render_mesh(plain, brdfs, light, look_at_camera(*FRONT), 2)
