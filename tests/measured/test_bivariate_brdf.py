"""The bivariate (θh, θd) representation (Romeiro et al. 2008): it reproduces an isotropic
model, it is reciprocal and samples consistently; on the shared measurements, with its
smoothness chosen without the file (leave-one-out), its spheres differ from the measured by
CIEDE2000 < 5; and it keeps the colour of a BRDF whose colour turns with θd, where every
single analytic model fails."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from brdfkit._array import dot, normalize
from brdfkit.brdf import parse
from brdfkit.checks import check_reciprocity, check_sampling
from brdfkit.errors import ParameterError
from brdfkit.fit import sphere_difference
from brdfkit.fit.analytic import fit, fit_data
from brdfkit.fit.appearance import DEFAULT_LIGHT_DIRECTION
from brdfkit.light import DirectionalLight
from brdfkit.measured import read_cornell, read_rgl
from brdfkit.measured.bivariate_brdf import Bivariate, fit_bivariate
from brdfkit.measured.tabulated import CosineSampled
from brdfkit.sampling import hemisphere_pairs

LIGHTS = ((0.0, 0.0, 1.0), DEFAULT_LIGHT_DIRECTION, (0.8, 0.2, 0.56), (0.9, 0.1, 0.2))
"""The four light directions of benchmarks/bench_cornell_fits.py."""
SMOOTHNESS = (1e-4, 1e-3, 1e-2, 1e-1)
"""The smoothness weights leave-one-out chooses from."""
FILES = (
    "cornell/acryl_blue.brdf",
    "cornell/cayman.brdf",
    "cornell/garnet_red.brdf",
    "cornell/krylon_blue.brdf",
    "rgl/acrylic_felt_green_rgb.bsdf",
)


def _delta_e(reference, model, lights=(DEFAULT_LIGHT_DIRECTION,)) -> float:
    """Mean CIEDE2000 of the spheres (96 pixels) under each light, averaged over ``lights``."""
    return float(
        np.mean(
            [
                sphere_difference(
                    reference, model, [DirectionalLight(direction=d, irradiance=np.pi)], 96
                ).mean
                for d in lights
            ]
        )
    )


@pytest.mark.parametrize(
    ("spec", "median", "p95"),
    [
        # a function of θh alone: only the table's interpolation errs (measured 1e-6, 0.4 %)
        ("lambertian(albedo=[0.6, 0.3, 0.1]) + blinn_phong(kd=0, ks=0.3, n=40)", 1e-4, 0.01),
        # Smith masking depends on θi, θo apart: Romeiro's approximation (measured 2.8 %, 14 %)
        ("lambertian(albedo=[0.6, 0.3, 0.1]) + ggx(alpha=0.3)", 0.04, 0.2),
    ],
)
def test_reproduces_an_isotropic_model_from_scattered_samples(spec, median, p95):
    truth = parse(spec)
    table = fit_bivariate(fit_data(truth, samples=50_000, seed=1), smoothness=1e-3)
    wi, wo = hemisphere_pairs(5000, seed=2)
    expected = truth.eval(wi, wo) * wi[:, 2:3]
    relative = np.abs(table.eval(wi, wo) * wi[:, 2:3] - expected) / expected
    assert np.median(relative) < median
    assert np.percentile(relative, 95) < p95


def test_reciprocal_isotropic_and_samples_consistently():
    table = fit_bivariate(fit_data(parse("lambertian + ggx(alpha=0.2)"), samples=20_000))
    assert check_reciprocity(table, n=1024, seed=3, tolerance=1e-10).passed
    assert check_sampling(table, theta_o=(0.4, 1.2), samples=50_000, seed=4).passed
    wi, wo = hemisphere_pairs(10, seed=5)
    assert table.eval(wi, wo).shape == (10, 1)
    assert np.all(table.eval(wi * [1, 1, -1], wo) == 0)


def test_torch_matches_numpy():
    torch = pytest.importorskip("torch")
    table = Bivariate(np.random.default_rng(0).random((8, 5, 3)))
    wi, wo = hemisphere_pairs(100, seed=6)
    value = table.eval(torch.tensor(wi), torch.tensor(wo))
    np.testing.assert_allclose(value.numpy(), table.eval(wi, wo), rtol=1e-12)


@pytest.mark.parametrize(
    "table", [np.zeros((1, 4, 3)), -np.ones((4, 4, 1)), np.full((4, 4, 1), np.nan), [1.0]]
)
def test_bad_tables_are_refused(table):
    with pytest.raises(ParameterError, match="table"):
        Bivariate(table)


def _read(shared_data, name):
    path = shared_data / "measured" / name
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    return read_cornell(path) if path.suffix == ".brdf" else read_rgl(path)


@pytest.mark.slow
@pytest.mark.data
def test_leave_one_out_over_the_shared_measurements_keeps_spheres_within_5(shared_data):
    measured = {name: _read(shared_data, name) for name in FILES}
    data = {name: fit_data(m) for name, m in measured.items()}
    scores = {
        (name, s): _delta_e(measured[name], fit_bivariate(data[name], smoothness=s))
        for name in FILES
        for s in SMOOTHNESS
    }
    for held_out in FILES:
        others = [n for n in FILES if n != held_out]
        chosen = min(SMOOTHNESS, key=lambda s: np.mean([scores[(n, s)] for n in others]))
        assert scores[(held_out, chosen)] < 5, (held_out, chosen, scores[(held_out, chosen)])


@dataclass(frozen=True, eq=False)
class Turning(CosineSampled):
    """A measured paint whose colour turns with θd: acrylic blue at normal incidence, garnet
    red from θd = 45° on (a smoothstep between), both Cornell measurements."""

    first: object
    second: object
    channels = 3

    def eval(self, wi, wo):
        theta_d = np.arccos(np.clip(dot(wi, normalize(wi + wo)), -1, 1))[..., None]
        s = np.clip(theta_d / (np.pi / 4), 0, 1)
        s = s * s * (3 - 2 * s)
        return (1 - s) * self.first.eval(wi, wo) + s * self.second.eval(wi, wo)


@pytest.mark.slow
@pytest.mark.data
def test_colour_that_turns_with_theta_d_is_kept_where_analytic_models_fail(shared_data):
    turning = Turning(
        _read(shared_data, "cornell/acryl_blue.brdf"),
        _read(shared_data, "cornell/garnet_red.brdf"),
    )
    table = fit_bivariate(fit_data(turning, samples=100_000), smoothness=1e-2)
    assert _delta_e(turning, table, LIGHTS) < 5  # measured 2.4
    for spec in ("lambertian + cook_torrance", "lambertian + ggx", "lambertian + ward"):
        result = fit(turning, spec)
        assert _delta_e(turning, result.model, LIGHTS) > 5, spec  # measured 17.6–19.0
