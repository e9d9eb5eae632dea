"""Photometric stereo from a data set to a surface (:mod:`brdfkit.vision.reconstruction`): the
pipeline equals its steps run by hand, its measures, its lights when uncalibrated, its
integrators (the default keeps a depth step), its camera and its mesh."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.errors import FormatError, ParameterError
from brdfkit.vision import datasets
from brdfkit.vision.bilateral_integration import PIECES, bilateral_integration
from brdfkit.vision.depth_from_normals import depth_mesh, read_intrinsics
from brdfkit.vision.metrics import angular_error, depth_error
from brdfkit.vision.normal_integration import poisson_dct
from brdfkit.vision.photometric_stereo import least_squares, sphere_normals
from brdfkit.vision.reconstruction import reconstruct


@pytest.fixture(scope="module")
def ball():
    """A Lambertian sphere fully lit by 12 lights, with its ground-truth normals."""
    normals, mask = sphere_normals((30, 36), (17.5, 14.5), 12.0)
    lights = datasets.diligent_like_lights(4, 3, np.radians(30))
    lit = mask & np.all(normals @ lights.T > 0, axis=-1)
    return datasets.render_synthetic(normals, lit, lights, albedo=[0.7, 0.5, 0.3])


def test_the_pipeline_equals_its_steps(ball):
    stages = []
    surface = reconstruct(
        ball, method="least_squares", progress=lambda stage, done, total: stages.append(stage)
    )
    expected = least_squares(ball.images, ball.light_directions, ball.mask)
    np.testing.assert_array_equal(surface.result.normals, expected.normals)
    depth = bilateral_integration(expected.normals, ball.mask, pieces=PIECES).depth
    np.testing.assert_array_equal(surface.depth, depth)
    assert surface.angular_error == angular_error(expected.normals, ball.normals, ball.mask)
    truth = bilateral_integration(ball.normals, ball.mask, pieces=PIECES).depth
    relative = depth_error(depth, truth, ball.mask)["relative_rmse"]
    assert surface.depth_relative_rmse == relative
    assert stages[0] == "least_squares" and stages[-1] == "integrating (bilateral_pieces)"
    measures = surface.measures()
    assert list(measures) == [
        "dataset", "method", "integration", "lights", "pixels", "angular_error_deg",
        "depth_relative_rmse",
    ]  # fmt: skip
    assert measures["pixels"] == int(ball.mask.sum()) and measures["lights"] == 12
    assert len(surface.mesh.vertices) == ball.mask.sum()


def test_without_ground_truth_there_are_no_errors(ball):
    from dataclasses import replace

    surface = reconstruct(replace(ball, normals=None), method="least_squares")
    assert surface.angular_error is None and surface.error_map is None
    assert "angular_error_deg" not in surface.measures()


def test_uncalibrated_solves_with_the_estimated_lights(ball):
    surface = reconstruct(ball, method="least_squares", uncalibrated=True, gbr_cue="entropy")
    assert surface.light_error.shape == (12,)
    cosine = np.sum(surface.data.light_directions * ball.light_directions, axis=1)
    angles = np.degrees(np.arccos(np.clip(cosine, -1, 1)))
    np.testing.assert_allclose(surface.light_error, angles)
    assert not np.array_equal(surface.data.light_directions, ball.light_directions)
    measures = surface.measures()
    assert measures["gbr_cue"] == "entropy"
    assert measures["light_error_deg"]["median"] == float(np.median(angles))


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"method": "magic"}, "method must be one of"),
        ({"integration": "magic"}, "integration must be one of"),
        ({"camera": np.eye(3), "integration": "poisson_dct"}, "poisson_dct' is orthographic"),
    ],
)
def test_bad_choices_are_refused(ball, options, message):
    with pytest.raises(ParameterError, match=message):
        reconstruct(ball, **options)


def test_another_integrator(ball):
    surface = reconstruct(ball, method="least_squares", integration="poisson_dct")
    np.testing.assert_array_equal(surface.depth, poisson_dct(surface.result.normals, ball.mask))


def test_the_default_integrator_keeps_a_depth_step():
    """A flat left half and, on the right, a plane whose depth grows by 2 pixels per row, so
    that the step between them varies along the border (lights about the two planes' mean
    normal light both): from the photometric-stereo normals, the default keeps each half's
    shape (two pixels from the border on) where least squares bends both."""
    normals = np.zeros((16, 16, 3))
    normals[..., 2] = 1.0
    normals[:, 8:] = np.array([0.0, -2.0, 1.0]) / np.sqrt(5.0)
    rows = np.arange(16.0)[:, None] * np.ones(16)
    truth = np.where(np.arange(16) < 8, 0.0, 2.0 * rows)  # depth away from the camera
    tilt = np.arctan(0.5)  # (0, 0, 1) turned to (0, -1, 2) / √5, between the two normals
    turn = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    lights = datasets.diligent_like_lights(4, 4, np.radians(30)) @ turn.T
    data = datasets.render_synthetic(normals, np.ones((16, 16), bool), lights, albedo=0.5)
    np.testing.assert_allclose(least_squares(data.images, lights).normals, normals, atol=1e-6)

    def error(depth):
        halves = {"left": slice(None, 6), "right": slice(10, None)}
        return {half: float(np.ptp((depth - truth)[:, part])) for half, part in halves.items()}

    default = error(reconstruct(data, method="least_squares").depth)
    smeared = error(reconstruct(data, method="least_squares", integration="least_squares").depth)
    assert max(default.values()) < 1.0  # measured 0.82 and 0.41 pixels
    assert min(smeared.values()) > 5.0  # least squares bends each half by 8.8 pixels


def test_the_camera_matrix_is_scaled_to_the_step(tmp_path):
    path = tmp_path / "K.txt"
    np.savetxt(path, [[100.0, 0.0, 40.0], [0.0, 90.0, 30.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(
        read_intrinsics(path, 2), [[50.0, 0.0, 20.0], [0.0, 45.0, 15.0], [0.0, 0.0, 1.0]]
    )
    np.savetxt(path, np.eye(2))
    with pytest.raises(FormatError, match="3×3 camera matrix"):
        read_intrinsics(path)


def test_the_perspective_mesh_lies_on_the_rays():
    camera = np.array([[50.0, 0.0, 2.0], [0.0, 50.0, 1.5], [0.0, 0.0, 1.0]])
    depth = np.full((3, 4), 2.0)
    mesh = depth_mesh(depth, np.ones((3, 4), bool), camera)
    rows, columns = np.nonzero(np.ones((3, 4), bool))
    expected = np.stack([(columns - 2.0) / 50 * 2, -(rows - 1.5) / 50 * 2, -np.full(12, 2.0)], 1)
    np.testing.assert_allclose(mesh.vertices, expected)
    assert np.all(mesh.face_normals[:, 2] > 0)  # counter-clockwise seen from the camera
