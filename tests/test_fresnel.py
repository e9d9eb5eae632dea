"""Fresnel reflectance: closed forms, physical identities, Mitsuba 3 as oracle, backends."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from brdfkit.fresnel import (
    CONDUCTORS,
    IOR,
    conductor,
    dielectric,
    f0_from_conductor,
    f0_from_ior,
    fresnel,
    fresnel_conductor,
    fresnel_dielectric,
    rgb_from_spectrum,
    schlick,
)

COS = np.linspace(-1.0, 1.0, 81)
# Sweeps against float32 Mitsuba keep off the critical angle (a square-root branch point where
# float32 rounding of sin²θ is amplified without bound): with 0.025 steps in cos θ, none of
# these indices has a critical cosine on the grid.
ETAS = [0.7, 1.0, 1.333, 1.5, 2.419]


def _mitsuba():
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


# --------------------------------------------------------------------------- closed forms
def test_glass_normal_incidence_is_four_percent_from_either_side():
    cos = np.array([1.0, -1.0])
    np.testing.assert_allclose(fresnel_dielectric(cos, 1.5), 0.04, atol=1e-6)
    np.testing.assert_allclose(f0_from_ior(1.5), 0.04, atol=1e-6)


def test_diamond_f0():
    assert fresnel_dielectric(np.array(1.0), IOR["diamond"]) == pytest.approx(0.172, abs=5e-4)


def test_f0_from_ior_matches_exact_fresnel_for_eta_and_its_reciprocal():
    eta = np.array([1.0, 1.2, 1.333, 1.5, 2.0, 2.419, 4.0])
    exact = fresnel_dielectric(np.ones_like(eta), eta)
    np.testing.assert_allclose(f0_from_ior(eta), exact, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(f0_from_ior(1 / eta), exact, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("cos", [1.0, -1.0])
def test_s_and_p_agree_at_normal_incidence(cos):
    eta = np.array([0.5, 1.33, 1.5, 3.0])
    r_s, r_p = fresnel_dielectric(np.full(4, cos), eta, polarized=True)
    np.testing.assert_allclose(r_s, r_p, rtol=1e-12)
    r_s, r_p = fresnel_conductor(
        np.full(4, cos), eta, np.array([0.0, 0.5, 2.0, 5.0]), polarized=True
    )
    np.testing.assert_allclose(r_s, r_p, rtol=1e-12)


def test_conductor_reflectance_is_the_mean_of_s_and_p():
    """The unpolarised conductor reflectance (one ratio) is (Rs + Rp)/2 of the two ratios."""
    cos = np.linspace(-1.0, 1.0, 101)
    for eta, k in [(0.2, 3.6), (1.5, 0.0), (2.9, 3.1), (0.05, 0.3)]:
        r_s, r_p = fresnel_conductor(cos, eta, k, polarized=True)
        np.testing.assert_allclose(fresnel_conductor(cos, eta, k), (r_s + r_p) / 2, rtol=1e-14)


def test_conductor_reflectance_stays_in_zero_one_where_terms_cancel():
    """Found by hypothesis: η = 1, κ = 0 (no interface) cancels the numerators to −6e-17."""
    cos = np.array([0.46233092197667547, 0.0, 1.0])
    for eta, k in [(1.0, 0.0), (3.0, 0.0), (1.0, 1e-9)]:
        values = [fresnel_conductor(cos, eta, k), *fresnel_conductor(cos, eta, k, polarized=True)]
        for value in values:
            assert np.all((value >= 0) & (value <= 1)), (eta, k, value)
    np.testing.assert_array_equal(fresnel_conductor(cos[:1], 1.0, 0.0), [0.0])


def test_conductor_normal_incidence_closed_form():
    rng = np.random.default_rng(1)
    presets = np.array(list(CONDUCTORS.values()))  # (metal, eta/k, rgb)
    eta = np.concatenate([rng.uniform(0.05, 5.0, 50), presets[:, 0].ravel()])
    k = np.concatenate([rng.uniform(0.0, 10.0, 50), presets[:, 1].ravel()])
    expected = ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2)
    np.testing.assert_allclose(fresnel_conductor(np.ones_like(eta), eta, k), expected, rtol=1e-12)
    np.testing.assert_allclose(f0_from_conductor(eta, k), expected, rtol=1e-12)


def test_grazing_incidence_reflects_everything():
    eta = np.array([1.2, 1.5, 2.419])
    np.testing.assert_array_equal(fresnel_dielectric(np.zeros(3), eta), 1.0)
    np.testing.assert_array_equal(fresnel_dielectric(-np.zeros(3), eta), 1.0)
    # ... and the limit is continuous: F → 1 as cos θ → 0.
    np.testing.assert_allclose(fresnel_dielectric(np.full(3, 1e-9), eta), 1.0, atol=1e-7)
    for eta_rgb, k_rgb in CONDUCTORS.values():
        np.testing.assert_allclose(
            fresnel_conductor(0.0 * np.ones(3), eta_rgb, k_rgb), 1.0, rtol=1e-12
        )
        np.testing.assert_allclose(
            fresnel_conductor(np.full(3, 1e-9), eta_rgb, k_rgb), 1.0, atol=1e-7
        )


def test_matched_index_reflects_nothing():
    np.testing.assert_array_equal(fresnel_dielectric(COS, 1.0), 0.0)


def test_total_internal_reflection_above_critical_angle():
    eta = 1.5
    theta_c = math.asin(1 / eta)
    theta = np.linspace(0.0, math.pi / 2, 181)
    cos = -np.cos(theta)  # light inside the glass, going out
    r_s, r_p = fresnel_dielectric(cos, eta, polarized=True)
    beyond = theta > theta_c + 1e-9
    below = theta < theta_c - 1e-3
    np.testing.assert_array_equal(r_s[beyond], 1.0)
    np.testing.assert_array_equal(r_p[beyond], 1.0)
    assert np.all(fresnel_dielectric(cos[below], eta) < 1.0)
    _, cos_t, _, _ = fresnel(cos[beyond], eta)
    np.testing.assert_array_equal(cos_t, 0.0)
    # From outside there is no critical angle.
    assert np.all(fresnel_dielectric(np.cos(theta[:-1]), eta) < 1.0)


def test_brewster_angle_extinguishes_p():
    for eta in (1.333, 1.5, 2.419):
        _, r_p = fresnel_dielectric(np.array(math.cos(math.atan(eta))), eta, polarized=True)
        assert r_p == pytest.approx(0.0, abs=1e-15)
        # From inside, Brewster's angle is atan(1/eta).
        _, r_p = fresnel_dielectric(np.array(-math.cos(math.atan(1 / eta))), eta, polarized=True)
        assert r_p == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("eta", ETAS)
def test_reflectance_plus_transmittance_is_one(eta):
    """R + T = 1 per polarisation, with T from the transmission amplitudes (Born & Wolf 1.5.3)."""
    cos = COS[np.abs(COS) > 0]
    r_s, r_p = fresnel_dielectric(cos, eta, polarized=True)
    _, cos_t, eta_it, _ = fresnel(cos, eta)
    refracts = cos_t != 0
    cos_i, cos_t, eta_it = np.abs(cos)[refracts], np.abs(cos_t)[refracts], eta_it[refracts]
    t_s = 2 * cos_i / (cos_i + eta_it * cos_t)
    t_p = 2 * cos_i / (eta_it * cos_i + cos_t)
    ratio = eta_it * cos_t / cos_i  # the change of beam cross-section and of impedance
    np.testing.assert_allclose(r_s[refracts] + ratio * t_s**2, 1.0, rtol=1e-12)
    np.testing.assert_allclose(r_p[refracts] + ratio * t_p**2, 1.0, rtol=1e-12)


@pytest.mark.parametrize("eta", [1.333, 1.5, 2.419])
def test_reflectance_is_the_same_from_both_sides_of_a_refracted_pair(eta):
    cos_i = np.linspace(0.01, 1.0, 50)
    r_out, cos_t, eta_it, eta_ti = fresnel(cos_i, eta)
    r_in, cos_back, _, _ = fresnel(cos_t, eta)
    np.testing.assert_allclose(r_in, r_out, rtol=1e-10)
    np.testing.assert_allclose(cos_back, cos_i, rtol=1e-10)  # √ round trip: error ∝ 1/cos²
    np.testing.assert_allclose(eta_it * eta_ti, 1.0, rtol=1e-15)
    # Snell: sin θi = η sin θt.
    np.testing.assert_allclose(np.sqrt(1 - cos_i**2), eta * np.sqrt(1 - cos_t**2), rtol=1e-10)


@pytest.mark.parametrize("eta", [0.5, 0.8, 1.333, 1.5, 3.0])
def test_conductor_with_no_extinction_is_a_dielectric(eta):
    cos = np.linspace(0.0, 1.0, 101)
    # Off the critical angle (sin θ = η), where √ turns rounding into 1e-7 differences.
    cos = cos[np.abs(1 - cos**2 - eta**2) > 1e-9]
    np.testing.assert_allclose(
        np.stack(fresnel_conductor(cos, eta, 0.0 * cos, polarized=True)),
        np.stack(fresnel_dielectric(cos, eta, polarized=True)),
        atol=1e-12,
    )


def test_schlick_endpoints_and_channels():
    f0 = np.array([0.04, 0.5, 0.95])
    cos = np.array([[1.0], [0.0], [0.3]])
    value = schlick(cos, f0)
    assert value.shape == (3, 3)
    np.testing.assert_allclose(value[0], f0, rtol=1e-15)
    np.testing.assert_allclose(value[1], 1.0, rtol=1e-15)
    np.testing.assert_allclose(value[2], f0 + (1 - f0) * 0.7**5, rtol=1e-15)


def test_schlick_error_for_glass_matches_the_published_bound():
    """For η = 1.5 Schlick's largest relative error is 23.2 % (Chapman 2023), mid-range."""
    cos = np.linspace(0.0, 1.0, 100001)
    exact = fresnel_dielectric(cos, 1.5)
    approx = schlick(cos, f0_from_ior(1.5))
    relative = np.abs(approx - exact) / exact
    assert relative.max() == pytest.approx(0.232, abs=5e-4)
    assert 50 < math.degrees(math.acos(cos[np.argmax(relative)])) < 60
    assert np.abs(approx - exact).max() < 0.04  # absolute error, largest near grazing


# --------------------------------------------------------------------------- Mitsuba 3
@pytest.mark.oracle
@pytest.mark.parametrize("eta", ETAS)
def test_fresnel_matches_mitsuba(eta):
    mi = _mitsuba()
    ours = np.stack(fresnel(COS, eta), axis=-1)
    theirs = np.array([mi.fresnel(float(c), eta) for c in COS])
    np.testing.assert_allclose(ours, theirs, atol=1e-5, rtol=1e-5)


@pytest.mark.oracle
@pytest.mark.parametrize("eta", ETAS)
def test_polarized_dielectric_matches_mitsuba(eta):
    mi = _mitsuba()
    r_s, r_p = fresnel_dielectric(COS, eta, polarized=True)
    theirs = []
    for c in COS:
        a_s, a_p, *_ = mi.fresnel_polarized(float(c), eta)
        theirs.append(
            (abs(complex(a_s.real, a_s.imag)) ** 2, abs(complex(a_p.real, a_p.imag)) ** 2)
        )
    np.testing.assert_allclose(np.stack([r_s, r_p], -1), np.array(theirs), atol=1e-5)


@pytest.mark.oracle
@pytest.mark.parametrize("name", [*CONDUCTORS, "custom"])
def test_conductor_matches_mitsuba(name):
    mi = _mitsuba()
    eta, k = conductor(name) if name != "custom" else ((0.3, 1.5, 2.7), (0.0, 0.4, 7.5))
    cos = np.linspace(0.0, 1.0, 41)
    r = fresnel_conductor(cos[:, None], eta, k)
    r_s, r_p = fresnel_conductor(cos[:, None], eta, k, polarized=True)
    for j in range(3):
        ior = mi.ScalarComplex2f(eta[j], k[j])
        theirs = np.array([mi.fresnel_conductor(float(c), ior) for c in cos])
        np.testing.assert_allclose(r[:, j], theirs, atol=1e-5)
        amplitudes = [mi.fresnel_polarized(float(c), ior)[:2] for c in cos]
        theirs_sp = np.array([[a.real**2 + a.imag**2 for a in pair] for pair in amplitudes])
        np.testing.assert_allclose(np.stack([r_s[:, j], r_p[:, j]], -1), theirs_sp, atol=1e-5)


@pytest.mark.oracle
@pytest.mark.parametrize("name", list(CONDUCTORS))
def test_conductor_presets_are_mitsubas_rgb_values(name):
    mi = _mitsuba()
    params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
    eta, k = CONDUCTORS[name]
    np.testing.assert_allclose(eta, np.array(params["eta.value"]), rtol=1e-6)
    np.testing.assert_allclose(k, np.array(params["k.value"]), rtol=1e-6)


@pytest.mark.oracle
def test_dielectric_presets_are_mitsubas():
    mi = _mitsuba()
    for name in ("water", "bk7", "diamond", "polypropylene", "fused quartz"):
        bsdf = mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "air"})
        eta = mi.traverse(bsdf)["eta"]
        assert eta == pytest.approx(IOR[name] / IOR["air"], rel=1e-6)


@pytest.mark.oracle
@pytest.mark.parametrize("name", list(CONDUCTORS))
def test_rgb_from_spectrum_rederives_the_presets_from_the_spectral_tables(name):
    """colour-science's 1 nm CMFs vs Mitsuba's 5 nm table and 1000-step sum: ≤ 0.32 % apart."""
    mi = _mitsuba()
    folder = Path(mi.__file__).parent / "data" / "ior"
    for part, preset in zip(("eta", "k"), CONDUCTORS[name], strict=True):
        table = np.loadtxt(folder / f"{name}.{part}.spd", comments="#")
        rgb = rgb_from_spectrum(table[:, 0], table[:, 1])
        np.testing.assert_allclose(rgb, preset, rtol=3.5e-3)


def test_rgb_from_spectrum_is_linear_and_validates():
    wavelengths = np.array([350.0, 500.0, 650.0, 850.0])
    values = np.array([1.0, 2.0, 0.5, 3.0])
    np.testing.assert_allclose(
        rgb_from_spectrum(wavelengths, 2 * values),
        2 * rgb_from_spectrum(wavelengths, values),
        rtol=1e-12,
    )
    with pytest.raises(ValueError, match="wavelengths"):
        rgb_from_spectrum(wavelengths[::-1], values)
    with pytest.raises(ValueError, match="same length"):
        rgb_from_spectrum(wavelengths, values[:3])


# --------------------------------------------------------------------------- presets
def test_preset_lookups():
    assert dielectric("BK7") == 1.5046
    assert dielectric("water") == 1.333
    assert conductor("au") == CONDUCTORS["Au"]
    with pytest.raises(ValueError, match="Au") as info:
        conductor("unobtainium")
    assert "unobtainium" in str(info.value)
    with pytest.raises(ValueError, match="diamond"):
        dielectric("kryptonite")


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: fresnel_dielectric(np.array(0.5), 0.0), "eta"),
        (lambda: fresnel_dielectric(np.array(0.5), -1.5), "eta"),
        (lambda: fresnel(np.array(1.5), 1.5), "cos_theta_i"),
        (lambda: fresnel_dielectric(np.array([0.2, -1.01]), 1.5), "cos_theta_i"),
        (lambda: fresnel_dielectric(np.array(np.nan), 1.5), "cos_theta_i"),
        (lambda: fresnel_dielectric(np.array(0.5), np.inf), "eta"),
        (lambda: fresnel_conductor(np.array(0.5), 0.2, -0.1), "k"),
        (lambda: fresnel_conductor(np.array(0.5), 0.0, 3.0), "eta"),
        (lambda: fresnel_conductor(np.array(2.0), 0.2, 3.0), "cos_theta_i"),
        (lambda: schlick(np.array(0.5), 1.2), "f0"),
        (lambda: schlick(np.array(-1.5), 0.04), "cos_theta_i"),
        (lambda: f0_from_ior(np.array(-1.0)), "eta"),
        (lambda: f0_from_conductor(np.array(0.2), np.nan), "k"),
    ],
)
def test_bad_input_raises_naming_the_argument(call, name):
    with pytest.raises(ValueError, match=f"^{name} must"):
        call()


def test_rounding_beyond_one_is_accepted():
    cos = np.float32(1.0) + np.finfo(np.float32).eps
    assert fresnel_dielectric(np.array(cos), 1.5) == pytest.approx(0.04, abs=1e-7)


def test_python_scalars_work():
    assert float(fresnel_dielectric(1.0, 1.5)) == pytest.approx(0.04, abs=1e-12)
    assert float(schlick(0.0, 0.04)) == 1.0


# --------------------------------------------------------------------------- backends
def test_backends_keep_dtype_and_agree(backend):
    cos = backend(COS)
    eta_rgb, k_rgb = conductor("Cu")
    results = {
        "fresnel": fresnel(cos, 1.5),
        "polarized": fresnel_dielectric(cos, 1.5, polarized=True),
        "conductor": fresnel_conductor(
            backend(np.abs(COS))[:, None], eta_rgb, k_rgb, polarized=True
        ),
        "schlick": (schlick(cos[:, None], backend(np.array([0.04, 0.5, 0.9]))),),
    }
    reference = {
        "fresnel": fresnel(COS, 1.5),
        "polarized": fresnel_dielectric(COS, 1.5, polarized=True),
        "conductor": fresnel_conductor(np.abs(COS)[:, None], eta_rgb, k_rgb, polarized=True),
        "schlick": (schlick(COS[:, None], np.array([0.04, 0.5, 0.9])),),
    }
    for key, values in results.items():
        for value, ref in zip(values, reference[key], strict=True):
            assert type(value) is type(cos)
            assert value.dtype == cos.dtype
            tol = 1e-5 if "32" in str(cos.dtype) else 1e-12
            np.testing.assert_allclose(np.asarray(value), ref, atol=tol, rtol=tol)


def test_torch_gradients_flow_to_every_argument():
    torch = pytest.importorskip("torch")
    kw = {"dtype": torch.float64, "requires_grad": True}
    cos = torch.tensor([0.15, 0.5, 0.9, -0.95, -0.5], **kw)
    eta = torch.tensor(1.45, **kw)
    assert torch.autograd.gradcheck(lambda c, e: fresnel_dielectric(c, e), (cos, eta))
    assert torch.autograd.gradcheck(lambda c, e: fresnel(c, e)[1], (cos, eta))
    cos_out = torch.tensor([0.05, 0.3, 0.7, 0.99], **kw)
    eta_rgb = torch.tensor([0.2, 0.9, 1.1], **kw)
    k_rgb = torch.tensor([3.9, 2.4, 0.1], **kw)
    assert torch.autograd.gradcheck(
        lambda c, e, k: fresnel_conductor(c[:, None], e, k), (cos_out, eta_rgb, k_rgb)
    )
    assert torch.autograd.gradcheck(
        lambda c, f: schlick(c[:, None], f), (cos_out, torch.tensor([0.04, 0.5], **kw))
    )
    # Total internal reflection is flat: a zero, finite gradient.
    cos_tir = torch.tensor([-0.2], **kw)
    fresnel_dielectric(cos_tir, eta).sum().backward()
    assert cos_tir.grad.item() == 0.0
    assert torch.isfinite(eta.grad).all()


def test_torch_float32_kept():
    torch = pytest.importorskip("torch")
    cos = torch.linspace(0, 1, 5, dtype=torch.float32)
    eta, k = conductor("Au")
    assert fresnel_conductor(cos[:, None], eta, k).dtype == torch.float32
    assert fresnel_dielectric(cos, torch.tensor(1.5)).dtype == torch.float32
    assert all(v.dtype == torch.float32 for v in fresnel(cos, 1.5))


def test_jax_jit():
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    cos = jnp.asarray(COS, dtype=jnp.float32)
    value = jax.jit(lambda c: fresnel_dielectric(c, 1.5))(cos)
    np.testing.assert_allclose(np.asarray(value), fresnel_dielectric(COS, 1.5), atol=1e-5)


# --------------------------------------------------------------------------- properties
cosines = st.floats(-1.0, 1.0)
indices = st.floats(0.05, 20.0)


@settings(max_examples=300, deadline=None)
@given(cos=cosines, eta=indices, k=st.floats(0.0, 20.0), f0=st.floats(0.0, 1.0))
def test_reflectances_lie_in_zero_one(cos, eta, k, f0):
    c = np.array(cos)
    for value in (
        *fresnel_dielectric(c, eta, polarized=True),
        fresnel_dielectric(c, eta),
        *fresnel_conductor(c, eta, k, polarized=True),
        fresnel_conductor(c, eta, k),
        schlick(c, f0),
    ):
        assert 0.0 <= float(value) <= 1.0


@settings(max_examples=200, deadline=None)
@given(cos=st.floats(0.0, 1.0), eta=indices, k=st.floats(0.0, 20.0))
def test_conductor_reflectance_grows_towards_grazing_from_its_f0_side(cos, eta, k):
    """Rs is monotonic in θ (it never dips below its normal-incidence value)."""
    r_s, _ = fresnel_conductor(np.array(cos), eta, k, polarized=True)
    assert float(r_s) >= float(f0_from_conductor(np.array(eta), k)) - 1e-12


def test_conductor_without_validation_gives_the_same_values():
    cos = np.linspace(-1, 1, 41)
    eta, k = np.array([0.2, 0.4, 1.4]), np.array([3.6, 2.4, 1.8])
    checked = fresnel_conductor(cos[:, None], eta, k)
    np.testing.assert_array_equal(fresnel_conductor(cos[:, None], eta, k, validate=False), checked)
    with pytest.raises(ValueError, match="eta"):
        fresnel_conductor(cos, -1.0, 0.0)
