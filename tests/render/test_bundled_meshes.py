"""The bundled meshes: exact unit normals, faces wound along them, concave parts, a ground."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.errors import ParameterError
from brdfkit.render.bundled_meshes import (
    BUNDLED_MESHES,
    GROUND_HALF_WIDTH,
    bundled_scene,
    is_mesh_source,
    load_mesh,
)

pytest.importorskip("trimesh", reason="trimesh (the mesh extra) is not installed")


@pytest.mark.parametrize("name", sorted(BUNDLED_MESHES))
def test_normals_are_unit_and_faces_wound_along_them(name):
    scene = bundled_scene(name)
    np.testing.assert_allclose(np.linalg.norm(scene.vertex_normals, axis=1), 1.0, atol=1e-12)
    corners = scene.vertices[scene.faces]
    geometric = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    agree = np.sum(geometric * scene.vertex_normals[scene.faces].mean(axis=1), axis=-1)
    assert np.all(agree > 0)
    # the object stands on the ground square (y = 0, normal +y), nothing below it
    assert scene.vertices[:, 1].min() == 0.0
    assert np.abs(scene.vertices[:, [0, 2]]).max() == GROUND_HALF_WIDTH


def test_knot_normals_point_away_from_its_centre_line():
    scene = bundled_scene("knot")
    tube = scene.vertices[:-4].reshape(192, 16, 3)
    normals = scene.vertex_normals[:-4].reshape(192, 16, 3)
    centre = tube.mean(axis=1, keepdims=True)  # a ring's centre is on the centre line
    np.testing.assert_allclose(tube - centre, 0.14 * normals, atol=1e-12)


def test_shaderball_has_a_concave_cup_and_neck():
    scene = bundled_scene("shaderball")
    v, n = scene.vertices[:-4], scene.vertex_normals[:-4]
    radial = np.hypot(v[:, 0], v[:, 2])
    outward = (v[:, 0] * n[:, 0] + v[:, 2] * n[:, 2]) / np.maximum(radial, 1e-12)
    cup = (v[:, 1] > 1.14) & (radial < 0.3)  # inside the rim, below it
    assert cup.sum() > 100 and np.all(outward[cup & (radial > 1e-9)] < 0)
    assert np.all(n[cup, 1] > 0)  # the cup's surface faces up, into the cup


def test_names_and_paths():
    assert is_mesh_source("bundled:knot") and is_mesh_source("scene.PLY")
    assert not is_mesh_source("sphere")
    assert load_mesh("bundled:knot") is bundled_scene("knot")
    with pytest.raises(ParameterError, match="knot, shaderball"):
        load_mesh("bundled:teapot")
