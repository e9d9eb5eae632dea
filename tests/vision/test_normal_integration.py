"""Normal integration: closed-form surfaces, DiLiGenT ground truth, the normal-map convention."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.vision.datasets import load_normal_integration
from brdfkit.vision.metrics import angular_error, depth_error
from brdfkit.vision.normal_integration import (
    METHODS,
    frankot_chellappa,
    least_squares_integration,
    orthographic_gradients,
    perspective_gradients,
    poisson_dct,
)

OBJECTS = ("bear", "cat", "cow", "goblet", "harvest", "pot1", "pot2")


def _bump(height: int = 48, width: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """A Gaussian bump towards the camera (depth decreasing) and its exact normals."""
    v, u = np.indices((height, width), dtype=np.float64)
    sigma = 7.0
    bump = 12.0 * np.exp(-((u - 30) ** 2 + (v - 22) ** 2) / (2 * sigma**2))
    depth = 100.0 - bump
    d_u = bump * (u - 30) / sigma**2  # derivative of the depth along columns
    d_v = bump * (v - 22) / sigma**2
    # n ∝ (d_u, -d_v, 1) in x right, y up, z towards the camera (depth = -height).
    normals = np.stack([d_u, -d_v, np.ones_like(d_u)], axis=-1)
    return depth, normals / np.linalg.norm(normals, axis=-1, keepdims=True)


def test_gradients_of_the_bump_are_exact():
    depth, normals = _bump()
    d_u, d_v = orthographic_gradients(normals)
    v, u = np.indices(depth.shape, dtype=np.float64)
    bump = 100.0 - depth
    np.testing.assert_allclose(d_u, bump * (u - 30) / 49.0, atol=1e-12)
    np.testing.assert_allclose(d_v, bump * (v - 22) / 49.0, atol=1e-12)


@pytest.mark.parametrize("method", list(METHODS))
def test_orthographic_bump_is_recovered(method):
    depth, normals = _bump()
    estimate = METHODS[method](normals, None)
    error = depth_error(estimate, depth)
    # Second-order discretisations of a smooth bump 12 px high (measured 0.2-0.6 % of its span).
    assert error["relative_rmse"] < 0.01
    assert error["scale"] == pytest.approx(1.0, abs=0.02)
    assert np.nanmin(estimate) == 0.0


def test_masked_least_squares_ignores_what_is_outside():
    depth, normals = _bump()
    mask = np.zeros(depth.shape, bool)
    mask[8:40, 14:50] = True
    garbage = normals.copy()
    garbage[~mask] = [1.0, 0.0, 0.0]  # an occluding contour: infinite slope outside
    estimate = least_squares_integration(garbage, mask)
    assert np.isnan(estimate[~mask]).all()
    assert depth_error(estimate, depth, mask)["relative_rmse"] < 0.01


def _perspective_sphere(camera: np.ndarray, shape=(60, 80)):
    """Depth and normals of a sphere seen by a pinhole camera, by ray casting."""
    centre, radius = np.array([3.0, -2.0, 60.0]), 12.0  # OpenCV frame: y down, z forward
    v, u = np.indices(shape, dtype=np.float64)
    rays = np.stack(
        [(u - camera[0, 2]) / camera[0, 0], (v - camera[1, 2]) / camera[1, 1], np.ones(shape)],
        axis=-1,
    )
    a = np.sum(rays**2, axis=-1)
    b = -2 * rays @ centre
    c = centre @ centre - radius**2
    discriminant = b**2 - 4 * a * c
    mask = discriminant > 0.05 * b**2 / 4  # keep away from the grazing rim
    t = (-b - np.sqrt(np.where(mask, discriminant, 0.0))) / (2 * a)
    points = rays * t[..., None]
    m = (points - centre) / radius  # outward normal, OpenCV frame
    normals = np.stack([m[..., 0], -m[..., 1], -m[..., 2]], axis=-1)
    return np.where(mask, t, np.nan), normals * mask[..., None], mask


def test_perspective_sphere_is_recovered_up_to_scale():
    camera = np.array([[150.0, 0.0, 41.0], [0.0, 160.0, 28.0], [0.0, 0.0, 1.0]])
    depth, normals, mask = _perspective_sphere(camera)
    estimate = least_squares_integration(normals, mask, camera)
    ratio = estimate[mask] / depth[mask]
    # Up to scale only: the ratio is constant (measured spread 2e-5).
    assert np.std(ratio) / np.mean(ratio) < 1e-3
    assert np.exp(np.mean(np.log(estimate[mask]))) == pytest.approx(1.0, rel=1e-12)
    # The orthographic solver cannot explain the perspective depth as well.
    orthographic = least_squares_integration(normals, mask)
    assert depth_error(orthographic, depth, mask)["rmse"] > 5 * np.std(
        depth[mask] - ratio.mean() ** -1 * estimate[mask]
    )


def test_perspective_parts_each_have_a_geometric_mean_of_one():
    """A mask in two parts (the sphere cut by a gap): each part is up to its own scale, so
    each is given a geometric mean of 1, and each keeps the sphere's shape."""
    camera = np.array([[150.0, 0.0, 41.0], [0.0, 160.0, 28.0], [0.0, 0.0, 1.0]])
    depth, normals, mask = _perspective_sphere(camera)
    mask[:, 40:43] = False
    estimate = least_squares_integration(normals, mask, camera)
    for part in (np.s_[:, :40], np.s_[:, 43:]):
        inside = mask[part]
        assert np.exp(np.mean(np.log(estimate[part][inside]))) == pytest.approx(1.0, rel=1e-12)
        ratio = estimate[part][inside] / depth[part][inside]
        assert np.std(ratio) / np.mean(ratio) < 1e-3


def test_perspective_gradients_of_a_fronto_parallel_plane_vanish():
    camera = np.array([[100.0, 0.0, 10.0], [0.0, 100.0, 8.0], [0.0, 0.0, 1.0]])
    normals = np.zeros((16, 20, 3))
    normals[..., 2] = 1.0
    d_u, d_v = perspective_gradients(normals, None, camera)
    np.testing.assert_array_equal(d_u, 0.0)
    np.testing.assert_array_equal(d_v, 0.0)


def _normals_from_depth(depth: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """Normals (x right, y up, z to the camera) of back-projected depth, central differences.

    Returned for the interior pixels ``[1:-1, 1:-1]``.
    """
    v, u = np.indices(depth.shape, dtype=np.float64)
    rays = np.stack([u, v, np.ones_like(u)], axis=-1) @ np.linalg.inv(camera).T
    points = rays * depth[..., None]  # OpenCV frame: x right, y down, z forward
    p_u = points[1:-1, 2:] - points[1:-1, :-2]
    p_v = points[2:, 1:-1] - points[:-2, 1:-1]
    m = np.cross(p_v, p_u)  # points towards the camera (negative z forward)
    n = np.stack([m[..., 0], -m[..., 1], -m[..., 2]], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


@pytest.mark.parametrize("name", OBJECTS)
def test_normal_map_convention_agrees_with_the_ground_truth_depth(shared_data, name):
    data = load_normal_integration(shared_data / "normal_integration" / "diligent" / name)
    finite_differences = _normals_from_depth(data.depth, data.camera)
    m = data.mask  # pixels whose four neighbours are inside the mask
    inner = m[1:-1, 1:-1] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
    decoded = data.normals[1:-1, 1:-1]
    # x right, y up, z towards the camera: measured median 0.3-1.1° (mean 0.7-4.6°, the larger
    # ones from depth discontinuities that finite differences straddle) ...
    assert angular_error(finite_differences, decoded, inner)["median"] < 1.5
    # ... and every other sign convention is off by 37° or more on average.
    for flip in ([-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, -1.0]):
        assert angular_error(finite_differences, decoded * np.array(flip), inner)["mean"] > 30


@pytest.mark.parametrize("name", OBJECTS)
def test_real_diligent_depth_is_recovered(shared_data, name):
    data = load_normal_integration(shared_data / "normal_integration" / "diligent" / name)
    depth = least_squares_integration(data.normals, data.mask, data.camera)
    perspective = depth_error(depth, data.depth, data.mask)
    # Measured at full resolution: relative RMSE 0.7-2.6 % on the five smooth objects, 5 % on
    # goblet and 11 % on harvest (depth discontinuities that least squares smooths over).
    limit = {"goblet": 0.08, "harvest": 0.15}.get(name, 0.04)
    assert perspective["relative_rmse"] < limit
    # The depth comes back with the scale of the scene: mean depth / geometric mean ~ 1500 mm.
    assert 1000 < perspective["scale"] < 2500


def test_real_bear_all_solvers(shared_data):
    data = load_normal_integration(shared_data / "normal_integration" / "diligent" / "bear")
    step = 4
    normals, mask, depth_gt = (a[::step, ::step] for a in (data.normals, data.mask, data.depth))
    errors = {name: depth_error(f(normals, mask), depth_gt, mask) for name, f in METHODS.items()}
    # Orthographic on the real bear: the masked solver ~1 %, the whole-image ones ~6-8 %
    # (they integrate across the occluding contour, where the normals jump).
    assert errors["least_squares"]["relative_rmse"] < 0.02
    for name in ("poisson_dct", "frankot_chellappa"):
        assert errors[name]["relative_rmse"] < 0.12
        assert errors[name]["relative_rmse"] > errors["least_squares"]["relative_rmse"]


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="normals must have shape"):
        poisson_dct(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="mask must have shape"):
        frankot_chellappa(np.zeros((8, 8, 3)), np.ones((4, 4), bool))
    with pytest.raises(ValueError, match="no pixels"):
        least_squares_integration(np.zeros((8, 8, 3)), np.zeros((8, 8), bool))
    with pytest.raises(ValueError, match="camera"):
        least_squares_integration(
            np.dstack([np.zeros((8, 8, 2)), np.ones((8, 8))]), None, np.eye(2)
        )
    with pytest.raises(ValueError, match="finite"):
        least_squares_integration(np.full((8, 8, 3), np.nan))
