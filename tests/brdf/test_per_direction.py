"""Work that depends on ωo alone, done once per direction of a broadcast ωo: the same floats."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import MODELS
from brdfkit.brdf.base import per_direction
from brdfkit.brdf.kulla_conty import _clenshaw
from brdfkit.brdf.microfacet import GGX


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


class _Counted:
    """A per-direction method that records the batch shapes it is called with."""

    def __init__(self) -> None:
        self.calls: list[tuple[int, ...]] = []

    @per_direction
    def weights(self, w):
        self.calls.append(w.shape[:-1])
        return [w[..., 2] * 2.0, np.concatenate([w[..., :1], w[..., 2:] ** 2], axis=-1)]


def test_a_broadcast_direction_is_evaluated_once_and_broadcast_back():
    wo = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    counted = _Counted()
    fixed = np.broadcast_to(wo, (5, 7, 3))
    per_pixel = np.broadcast_to(np.stack([wo, -wo])[:, None, :], (2, 6, 3))  # (pixels, spp)
    for w in (fixed, per_pixel):
        cut = counted.weights(w)
        whole = counted.weights.__wrapped__(counted, np.ascontiguousarray(w))
        assert all(_same(c, x) for c, x in zip(cut, whole, strict=True))
    assert counted.calls[0] == (1, 1) and counted.calls[2] == (2, 1)


def test_a_contiguous_batch_goes_through_unchanged():
    counted = _Counted()
    w = np.random.default_rng(1).normal(size=(4, 3))
    counted.weights(w)
    assert counted.calls == [(4,)]


def test_a_parameter_varying_over_the_batch_is_evaluated_whole():
    """α per point: the frame of one ωo differs from point to point; the cut result has the
    batch's extent, and the method runs again on the whole batch (the same values)."""
    ggx = GGX(alpha_x=np.array([[0.1], [0.5], [0.3]]))
    wo = np.array([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9])
    u = np.random.default_rng(0).random((3, 2))
    broadcast = ggx.sample_visible(np.broadcast_to(wo, (3, 3)), u)
    contiguous = ggx.sample_visible(np.tile(wo, (3, 1)), u)
    assert _same(broadcast, contiguous)


@pytest.mark.parametrize(
    "name",
    [
        "kulla_conty",
        "kulla_conty_dielectric",
        "ggx",
        "beckmann",
        "rough_dielectric",
        "rough_plastic",
        "thin_film",
    ],
)
def test_sampling_with_a_broadcast_wo_is_bitwise_the_per_sample_result(name):
    rng = np.random.default_rng(2)
    u = rng.random((2000, 3))
    wi = rng.normal(size=(2000, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    for model in MODELS[name].examples():
        for wo in ([0.3, 0.1, 0.9], [0.2, -0.3, -0.8], [0.9, 0.0, 0.05]):
            wo = np.array(wo) / np.linalg.norm(wo)
            fixed, copied = np.broadcast_to(wo, (2000, 3)), np.tile(wo, (2000, 1))
            a, b = model.sample(fixed, u), model.sample(copied, u)
            for field in ("wi", "weight", "pdf", "delta"):
                assert _same(getattr(a, field), getattr(b, field)), (model, wo, field)
            assert _same(model.pdf(wi, fixed), model.pdf(wi, copied))


def test_clenshaw_in_place_is_the_recurrence_bit_for_bit():
    coefficients = tuple(np.random.default_rng(3).normal(size=(33, 3)))
    mu = np.random.default_rng(4).random((1000, 1))
    mu[:3, 0] = [0.0, 1.0, 0.25]
    x = 2 * np.sqrt(mu) - 1
    expected = []
    for c in range(3):  # the recurrence as array-API code runs it (no in-place steps)
        b1 = b2 = 0 * x
        for a in coefficients[:0:-1]:
            b1, b2 = float(a[c]) + 2 * x * b1 - b2, b1
        expected.append(float(coefficients[0][c]) + x * b1 - b2)
    assert _same(_clenshaw(coefficients, mu), np.concatenate(expected, axis=-1))
    np.testing.assert_allclose(
        _clenshaw(coefficients, mu),
        np.polynomial.chebyshev.chebval(x[:, 0], np.array(coefficients)).T,
        rtol=1e-12,
        atol=1e-12,
    )
