"""Fitting analytic models to measured data: recovery of known models, MERL, Cornell."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.errors import ParameterError, SpecError
from brdfkit.fit.analytic import fit, fit_data, fit_errors, log_scale, residuals
from brdfkit.measured import MeasuredSamples, TabulatedBRDF, read_cornell, read_merl, write_merl
from brdfkit.sampling import hemisphere_pairs, square_to_uniform_hemisphere

TRUE = "lambertian(rho=[0.3, 0.2, 0.1]) + ward(kd=0, ks=[0.05, 0.06, 0.08], alpha_x=0.15)"


def _samples(spec: str, n: int = 3000, seed: int = 0) -> MeasuredSamples:
    wi, wo = hemisphere_pairs(n, seed)
    return MeasuredSamples(wi, wo, parse(spec).eval(wi, wo), name="synthetic")


def test_recovers_a_known_model_from_samples():
    result = fit(_samples(TRUE), "lambertian + ward", starts=2)
    assert result.success
    np.testing.assert_allclose(result.params["0.lambertian.rho"], [0.3, 0.2, 0.1], rtol=1e-5)
    np.testing.assert_allclose(result.params["1.ward.ks"], [0.05, 0.06, 0.08], rtol=1e-5)
    np.testing.assert_allclose(result.params["1.ward.alpha_x"], 0.15, rtol=1e-5)
    assert result.errors["rmse"] < 1e-6
    # the spec string is a model that every other part of brdfkit reads
    data = _samples(TRUE, 100, seed=1)
    again = parse(result.spec)
    np.testing.assert_allclose(again.eval(data.wi, data.wo), result.model.eval(data.wi, data.wo))
    assert "kd=0" in result.spec  # Ward's own diffuse term is redundant beside the Lambertian


@pytest.mark.parametrize("objective", ["log", "cube_root"])
def test_compressed_objectives_recover_the_model(objective):
    result = fit(_samples(TRUE), "lambertian + ward", objective=objective, starts=1)
    np.testing.assert_allclose(result.params["1.ward.alpha_x"], 0.15, rtol=1e-4)
    assert result.objective == objective


def test_per_channel_mode_fits_each_channel():
    spec = "ward(kd=0, ks=[0.2, 0.1, 0.05], alpha_x=[0.1, 0.2, 0.3])"
    result = fit(_samples(spec), "ward(kd=0)", mode="per_channel", starts=1)
    np.testing.assert_allclose(result.params["0.ward.alpha_x"], [0.1, 0.2, 0.3], rtol=1e-4)
    np.testing.assert_allclose(result.params["0.ward.ks"], [0.2, 0.1, 0.05], rtol=1e-4)


def test_written_parameters_stay_fixed_and_fit_within_the_models_bounds():
    result = fit(_samples(TRUE), "lambertian + ward(alpha_x=0.3)", starts=1)
    assert "1.ward.alpha_x" not in result.params
    assert result.model.lobes[1].alpha_x == 0.3
    assert all(0 <= v <= 1 for v in np.ravel(result.params["0.lambertian.rho"]))


def test_bounds_follow_the_lobes_own_settings():
    """Cook–Torrance checks f0 only under Schlick's Fresnel: its bounds come from that lobe."""
    truth = "lambertian(rho=0.2) + cook_torrance(fresnel='schlick', f0=0.05, m=0.2)"
    result = fit(_samples(truth), "lambertian + cook_torrance(fresnel='schlick')", starts=2)
    np.testing.assert_allclose(result.params["1.cook_torrance.f0"], 0.05, rtol=1e-4)
    np.testing.assert_allclose(result.params["1.cook_torrance.m"], 0.2, rtol=1e-4)
    # a highlight brighter than f0 = 1 allows: f0 stops at its bound (it used to step past it
    # and raise)
    bright = _samples("lambertian(rho=0.2) + 3 * cook_torrance(fresnel='schlick', f0=0.5, m=0.2)")
    result = fit(bright, "lambertian + cook_torrance(fresnel='schlick')", starts=2)
    assert result.params["1.cook_torrance.f0"] == pytest.approx(1.0)


def test_a_lobe_without_colour_gets_a_scale():
    spec = "lambertian(rho=0.2) + [0.5, 0.4, 0.3] * ggx(alpha=0.2)"
    result = fit(_samples(spec), "lambertian + ggx", starts=1)
    np.testing.assert_allclose(result.params["1.ggx.alpha"], 0.2, rtol=1e-4)
    np.testing.assert_allclose(result.params["1.ggx.scale"], [0.5, 0.4, 0.3], rtol=1e-4)


def test_a_lobe_whose_colour_parameter_is_inert_gets_a_scale():
    """Cook–Torrance's f0 does nothing under its dielectric Fresnel term: the lobe gets the
    paper's specular weight s as a per-channel factor (without it the highlight's strength
    was F(η) alone)."""
    spec = "lambertian(rho=0.2) + [0.5, 0.4, 0.3] * cook_torrance(m=0.2)"
    result = fit(_samples(spec), "lambertian + cook_torrance", starts=1)
    assert "1.cook_torrance.f0" not in result.params
    np.testing.assert_allclose(result.params["1.cook_torrance.m"], 0.2, rtol=1e-3)
    np.testing.assert_allclose(result.params["1.cook_torrance.scale"], [0.5, 0.4, 0.3], rtol=1e-2)


def test_the_roughness_sweep_finds_a_highlight_much_sharper_than_the_start():
    """ggx starts at alpha = 0.1; a lobe at 0.004 lies in another basin of the objective."""
    spec = "lambertian(rho=0.2) + 0.03 * ggx(alpha=0.004)"
    data = _samples(spec, 4000)
    near = square_to_uniform_hemisphere(np.random.default_rng(3).random((2000, 2)))
    mirror = near * np.array([-1.0, -1.0, 1.0])  # mirror pairs sample the highlight itself
    data = MeasuredSamples(
        np.concatenate([data.wi, near]),
        np.concatenate([data.wo, mirror]),
        np.concatenate([data.values, parse(spec).eval(near, mirror)]),
    )
    result = fit(data, "lambertian + ggx", starts=4)
    assert result.params["1.ggx.alpha"] == pytest.approx(0.004, rel=1e-3)
    assert result.params["1.ggx.scale"] == pytest.approx(0.03, rel=1e-3)


BODY_AND_PEAK = "lambertian(rho=0.02) + 0.1 * ggx(alpha=0.3) + 0.3 * ggx(alpha=0.01)"
"""A broad coloured body lobe under a sharp clear-coat peak (as in a metallic paint): one
specular lobe cannot be both."""


def test_the_robust_loss_fits_the_body_rather_than_a_few_peak_samples():
    """Of 2000 uniform pairs a handful fall on the peak. Plain least squares spends the one
    lobe on them; soft-L1 counts their large residuals linearly and fits the body."""
    data = _samples(BODY_AND_PEAK, 2000, seed=1)
    linear = fit(data, "lambertian + ggx", loss="linear")
    robust = fit(data, "lambertian + ggx")
    assert robust.loss == "soft_l1" and linear.loss == "linear"
    assert linear.params["1.ggx.alpha"] < 0.05
    assert 0.15 < robust.params["1.ggx.alpha"] < 0.45
    np.testing.assert_allclose(robust.params["1.ggx.scale"], 0.1, rtol=0.1)


def test_each_start_levels_its_colours_before_its_shape_moves():
    """Started at m = 0.4 with every colour at 1 (ten times too bright), Cook–Torrance used to
    shrink m to 0.02 and tune η to dim itself; with the colours fitted first it keeps the body's
    broad lobe."""
    data = _samples(BODY_AND_PEAK, 2000, seed=1)
    result = fit(data, parse("lambertian + cook_torrance(m=0.4)"), starts=1)
    assert 0.15 < result.params["1.cook_torrance.m"] < 0.45


def test_the_loss_scale_follows_the_data():
    """The scale is relative to the measured values' median size, so scaling the data by k
    scales the (cube-root) residuals and the loss's scale alike, and the fit is the same."""
    data = _samples(BODY_AND_PEAK, 2000, seed=1)
    brighter = MeasuredSamples(data.wi, data.wo, 8 * data.values)
    one, other = fit(data, "lambertian + ggx"), fit(brighter, "lambertian + ggx")
    assert other.loss_scale == pytest.approx(2 * one.loss_scale)
    assert other.params["1.ggx.alpha"] == pytest.approx(one.params["1.ggx.alpha"], rel=1e-3)
    np.testing.assert_allclose(
        other.params["1.ggx.scale"], 8 * np.array(one.params["1.ggx.scale"]), rtol=1e-3
    )


def test_the_log_objective_follows_the_data_level():
    """The log objective's level is the data's own (``log_scale``), so a dark and a bright copy
    of one material fit the same lobe shape; at Löw et al.'s fixed 1 sr⁻¹ they did not (the
    dark copy's log is nearly linear: its highlight decides the fit)."""
    data = _samples(BODY_AND_PEAK, 2000, seed=1)
    fits = [
        fit(MeasuredSamples(data.wi, data.wo, k * data.values), "lambertian + ggx", objective="log")
        for k in (0.02, 1.0, 50.0)
    ]
    alphas = [f.params["1.ggx.alpha"] for f in fits]
    np.testing.assert_allclose(alphas, alphas[1], rtol=1e-3)
    for k, f in zip((0.02, 1.0, 50.0), fits, strict=True):
        np.testing.assert_allclose(
            f.params["0.lambertian.rho"],
            k * np.array(fits[1].params["0.lambertian.rho"]),
            rtol=1e-3,
        )
    brighter = MeasuredSamples(data.wi, data.wo, 4 * data.values)
    assert log_scale(brighter) == pytest.approx(4 * log_scale(data))


def test_residuals_and_errors_closed_forms():
    data = _samples("lambertian(rho=0.5)", 200)
    model = parse("lambertian(rho=0.25)")
    diff = (0.25 - 0.5) / np.pi
    np.testing.assert_allclose(residuals(model, data), diff * data.wi[:, 2:3])
    errors = fit_errors(model, data)
    np.testing.assert_allclose(errors["rmse"], abs(diff))
    np.testing.assert_allclose(errors["relative_l2"], 0.5)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"objective": "l1"}, "objective"),
        ({"loss": "l1"}, "loss must be one of"),
        ({"loss_scale": 0}, "loss_scale must be a positive number; got 0"),
        ({"loss_scale": float("nan")}, "loss_scale"),
        ({"mode": "both"}, "mode"),
        ({"starts": 0}, "starts"),
        ({"loss_scale": True}, "loss_scale must be a positive number; got True"),
        ({"loss_scale": float("inf")}, "loss_scale"),
        ({"loss_scale": "0.5"}, "loss_scale"),
        ({"starts": True}, r"starts must be an integer in \[1, 1000\]; got True"),
        ({"starts": 10**9}, "starts must be an integer"),
        ({"coarse_samples": 5}, "coarse_samples"),
        ({"max_samples": 2.5}, "max_samples"),
        ({"max_nfev": 0}, "max_nfev"),
        ({"seed": -1}, "seed"),
        ({"progress": 3}, "progress must be a callable"),
        ({"fixed": "rho"}, "fixed must be a collection of parameter names"),
        ({"fixed": ["unknown_name"]}, "'unknown_name', which is no parameter of the model"),
        ({"fixed": ["1.rho"]}, "'1.rho', which is no parameter"),
        ({"fixed": [3]}, "3, which is no parameter"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(ParameterError, match=message):
        fit(_samples(TRUE, 50), "lambertian", **kwargs)


def test_an_unknown_fixed_name_lists_the_models_parameters():
    with pytest.raises(ParameterError) as info:
        fit(_samples(TRUE, 50), "lambertian + ward", fixed=["alpha"])
    for name in ("0.rho", "1.alpha_x", "1.ks", "1.scale"):
        assert name in str(info.value)


def test_bad_models():
    with pytest.raises(SpecError, match="unknown model"):
        fit(_samples(TRUE, 50), "lambertan")
    with pytest.raises(SpecError, match="not a valid model expression"):
        fit(_samples(TRUE, 50), "lambertian(")
    with pytest.raises(SpecError, match="fitting supports a sum"):
        fit(_samples(TRUE, 50), "0.5 * (lambertian + ggx)")
    with pytest.raises(ParameterError, match="no free parameter"):
        fit(_samples(TRUE, 50), "lambertian(rho=0.5)")
    with pytest.raises(ParameterError, match="model must be a spec string or a BRDF"):
        fit(_samples(TRUE, 50), 3)


def test_fit_data_of_a_table_is_its_measured_nodes():
    table = TabulatedBRDF.from_brdf(parse("lambertian(rho=0.5)"), (8, 8, 16))
    data = fit_data(table)
    assert data.values.shape[1] == 1
    assert data.wi.shape[0] == np.count_nonzero(table.values[..., 0] >= 0)
    np.testing.assert_allclose(data.values, 0.5 / np.pi)


@pytest.mark.slow
def test_merl_file_of_ggx_gives_back_alpha(tmp_path):
    """A MERL file written from Lambertian + GGX: the fit recovers α to 2 % (and the rest)."""
    truth = "lambertian(rho=[0.2, 0.3, 0.4]) + [0.6, 0.5, 0.4] * ggx(alpha=0.15)"
    path = write_merl(tmp_path / "ggx.binary", parse(truth))
    result = fit(read_merl(path), "lambertian + ggx", starts=2)
    assert abs(result.params["1.ggx.alpha"] / 0.15 - 1) < 0.02
    np.testing.assert_allclose(result.params["1.ggx.scale"], [0.6, 0.5, 0.4], rtol=0.02)
    np.testing.assert_allclose(result.params["0.lambertian.rho"], [0.2, 0.3, 0.4], rtol=0.02)


CORNELL = ["acryl_blue", "cayman", "garnet_red", "krylon_blue"]
ALIKE = 12.0
"""Mean CIEDE2000 over the sphere below which two spheres look alike at a glance."""
TWO_LOBES = ["lambertian + cook_torrance", "lambertian + ggx", "lambertian + ward"]


@pytest.mark.slow
@pytest.mark.parametrize("material", CORNELL)
def test_cornell_fits_converge_and_look_like_the_measurement(shared_data, material):
    """Two-lobe fits converge and explain more than a Lambertian alone (by how much is a
    property of the model: see the README); their spheres look like the measured one: closer
    to it than the Lambertian fit's, alike at a glance (mean CIEDE2000 over the sphere below 12,
    brdfkit.fit.appearance) and less than half as far as from another Cornell material."""
    from brdfkit.fit import sphere_difference

    folder = shared_data / "measured" / "cornell"
    table = read_cornell(folder / f"{material}.brdf")
    other = read_cornell(folder / f"{CORNELL[(CORNELL.index(material) + 1) % 4]}.brdf")
    lambertian = fit(table, "lambertian", starts=1)
    lambertian_look = sphere_difference(table, lambertian.model, resolution=48).mean
    for spec in TWO_LOBES:
        result = fit(table, spec)
        assert result.success, (spec, result.message)
        for error in ("log_rmse", "cosine_rmse", "relative_l2"):
            assert result.errors[error] < lambertian.errors[error], (spec, error)
        look = sphere_difference(table, result.model, resolution=48).mean
        wrong = sphere_difference(other, result.model, resolution=48).mean
        assert look < lambertian_look, (spec, look, lambertian_look)
        assert look < min(wrong / 2, ALIKE), (spec, look, wrong)


@pytest.mark.parametrize("objective", ["cosine", "cube_root"])
def test_lobe_jacobian_equals_scipys_differences(objective):
    """The Jacobian that re-evaluates one lobe per column is scipy's "2-point" Jacobian of the
    whole model's residuals (same steps), to the rounding of the differences."""
    from scipy.optimize._numdiff import approx_derivative

    from brdfkit.fit import analytic as fitting

    data = _samples("lambertian(rho=[0.3, 0.2, 0.1]) + [0.4, 0.5, 0.6] * ggx(alpha=0.2)", 400)
    lobes = fitting._lobes(parse("lambertian + 0.5 * ggx(alpha=0.15)"))
    free = fitting._free_parameters(lobes, [set(), set()], (), 3)
    x = np.concatenate([p.initial for p in free])
    lower = np.concatenate([np.full(p.size, p.lower) for p in free])
    upper = np.concatenate([np.full(p.size, p.upper) for p in free])
    robust = fitting._Robust(objective, "linear", 1.0, fitting.log_scale(data))
    ours = fitting._LobeValues(lobes, free, data).jacobian(
        x, np.arange(x.size), lower, upper, robust, slice(None)
    )

    def whole(x_):
        model = fitting._assemble(lobes, free, x_, relax=True)
        return residuals(model, data, objective).ravel()

    theirs = approx_derivative(whole, x, method="2-point", bounds=(lower, upper))
    assert ours.shape == theirs.shape == (1200, x.size)
    scale = np.abs(theirs).max(axis=0)
    assert np.all(np.abs(ours - theirs).max(axis=0) <= 1e-6 * scale)
