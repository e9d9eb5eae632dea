"""Real-material presets: every preset of every converted fit equals an independent NumPy
transcription of bbm's C++ (ngan.h, low.h, bagher.h and the headers they include) to 1e-10
relative, on random direction pairs and on pairs near the mirror direction; the shipped tables
equal the shared fit files; names, spec and errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.brdf.presets import (
    UNCONVERTED,
    Material,
    catalogue,
    citation,
    fits,
    materials,
    preset,
    tables,
)
from brdfkit.errors import ParameterError
from brdfkit.sampling import hemisphere_pairs

# --------------------------------------------------------------------------- bbm, transcribed
# Each function is the C++ eval() of its header, written again here from bbm's source (names as
# there: `in` = wi, `out` = wo), without brdfkit's code. Results are (n, 3) per channel.


def _halfway(wi, wo):
    h = wi + wo
    return h / np.linalg.norm(h, axis=-1, keepdims=True)


def _col(x):
    return np.asarray(x, dtype=np.float64)[..., None] if np.ndim(x) == 1 else x


def _schlick(r0, cos):  # fresnel_schlick.h
    return r0 + (1.0 - r0) * (1.0 - cos) ** 5.0


def _cook(eta, cos):  # fresnel_cook.h
    g = np.sqrt(np.maximum(eta * eta + cos * cos - 1.0, 0.0))
    a = (g - cos) / (g + cos)
    b = (cos * (g + cos) - 1.0) / (cos * (g - cos) + 1.0)
    return np.maximum(0.5 * (a * a) * (1.0 + b * b), 0.0)


def _vgroove(wi, wo, m):  # maskingshadowing/vgroove.h
    g = np.minimum(
        1.0,
        np.minimum(
            2.0 * m[:, 2] * wi[:, 2] / np.sum(wi * m, -1),
            2.0 * m[:, 2] * wo[:, 2] / np.sum(wo * m, -1),
        ),
    )
    return np.where((np.sum(wi * m, -1) > 0) & (np.sum(wo * m, -1) > 0), g, 0.0)


def _beckmann(m, alpha, normalize):  # ndf/beckmann.h, isotropic
    cos2 = m[:, 2] ** 2
    d = np.exp(-(m[:, 0] ** 2 + m[:, 1] ** 2) / alpha**2 / cos2) / (alpha * alpha * cos2 * cos2)
    return d / math.pi if normalize else d


def ngan_ward(wi, wo, p):  # ward.h
    h = wi + wo
    r = p["roughness"]
    norm = 4 * math.pi * np.sqrt(wi[:, 2] * wo[:, 2]) * r * r
    e = ((h[:, 0] / r) ** 2 + (h[:, 1] / r) ** 2) / h[:, 2] ** 2
    return np.asarray(p["albedo"]) * (np.exp(-e) / norm)[:, None]


def ngan_ward_duer(wi, wo, p):  # wardduer.h
    h = wi + wo
    r = p["roughness"]
    norm = 4 * math.pi * r * r * (wi[:, 2] * wo[:, 2])
    e = ((h[:, 0] / r) ** 2 + (h[:, 1] / r) ** 2) / h[:, 2] ** 2
    return np.asarray(p["albedo"]) * (np.exp(-e) / norm)[:, None]


def ngan_blinn_phong(wi, wo, p):  # phong.h (ngan.h: nganblinnphong = phong)
    reflected_in = wi * np.array([-1.0, -1.0, 1.0])
    cos_alpha = np.maximum(np.sum(reflected_in * wo, -1), 0.0)
    n = p["sharpness"]
    return np.asarray(p["albedo"]) * ((n + 2) / (2 * math.pi) * cos_alpha**n)[:, None]


def ngan_lafortune(wi, wo, p):  # lafortune.h times ngan.h's normalisation, in log space
    n, cxy, cz = p["sharpness"], p["Cxy"], p["Cz"]
    d = cxy * wi[:, 0] * wo[:, 0] + cxy * wi[:, 1] * wo[:, 1] + cz * wi[:, 2] * wo[:, 2]
    with np.errstate(divide="ignore"):
        log_fr = n * np.log(np.maximum(d, 0.0)) - 0.5 * n * np.log(max(cz * cz, cxy * cxy))
    value = (n + 2.0) / (2 * math.pi) * np.exp(log_fr)
    return np.asarray(p["albedo"]) * value[:, None]


def ngan_cook_torrance(wi, wo, p):  # microfacet<beckmann, vgroove, schlick, Cook> × albedo
    h = _halfway(wi, wo)
    d = _beckmann(h, p["roughness"], normalize=True)
    g = _vgroove(wi, wo, h)
    f = _schlick(p["eta"], 0.5 * (np.sum(wi * h, -1) + np.sum(wo * h, -1)))
    value = d * g * f / math.pi / (wi[:, 2] * wo[:, 2])
    return np.asarray(p["albedo"]) * value[:, None]


def low_cook_torrance(wi, wo, p):  # cooktorrance.h: beckmann without 1/π, cook Fresnel
    h = _halfway(wi, wo)
    d = _beckmann(h, p["roughness"], normalize=False)
    g = _vgroove(wi, wo, h)
    f = _cook(p["eta"], 0.5 * (np.sum(wi * h, -1) + np.sum(wo * h, -1)))
    value = d * g * f / math.pi / (wi[:, 2] * wo[:, 2])
    return np.asarray(p["albedo"]) * value[:, None]


def _ashikhmin_shirley(wi, wo, n, fresnel):  # ashikhminshirley.h, isotropic
    h = _halfway(wi, wo)
    h_dot_in = np.sum(h * wi, -1)
    denominator = h_dot_in * np.maximum(wi[:, 2], wo[:, 2])
    return (n + 1) / (8 * math.pi) * h[:, 2] ** n * fresnel(h_dot_in) / denominator


def ngan_ashikhmin_shirley(wi, wo, p):
    f0 = p["fresnelReflectance"]
    value = _ashikhmin_shirley(wi, wo, p["sharpness"], lambda c: _schlick(f0, c))
    return np.asarray(p["albedo"]) * value[:, None]


def low_ashikhmin_shirley(wi, wo, p):
    eta = p["fresnelReflectance"]
    value = _ashikhmin_shirley(wi, wo, p["sharpness"], lambda c: _cook(eta, c))
    return np.asarray(p["albedo"]) * value[:, None]


def low_microfacet(wi, wo, p):  # lowmicrofacet.h with microfacet_n::Cook, ndf/low.h
    h = _halfway(wi, wo)
    d = (1.0 + p["B"] * (1.0 - h[:, 2])) ** (-p["C"])
    g = _vgroove(wi, wo, h)
    f = _cook(p["eta"], 0.5 * (np.sum(wi * h, -1) + np.sum(wo * h, -1)))
    return np.asarray(p["A"]) * (d * g * f / math.pi / (wi[:, 2] * wo[:, 2]))[:, None]


def low_smooth(wi, wo, p):  # lowsmooth.h
    ip, op = wi[:, :2], wo[:, :2]
    dp2 = np.sum((ip + op) ** 2, -1)
    cos_theta_d = np.sqrt(np.maximum(1 - 0.25 * np.sum((ip - op) ** 2, -1), 0.0))
    s = (1.0 + p["B"] * dp2) ** (-p["C"])
    q = _cook(p["eta"], cos_theta_d)
    return np.asarray(p["A"]) * (s * q)[:, None]


def _bagher_g1(v, p):  # ndf/sgd.h, sgd::G1, unclamped
    theta = np.arccos(v[:, 2])[:, None]
    lam, c, k, theta0 = (np.asarray(p[n]) for n in ("Lambda", "c", "k", "theta0"))
    x = np.where(theta > theta0, theta - theta0, 1.0)
    # 1 − e^y written −expm1(y): bbm's 1 − exp(y) loses digits for tiny y (a relative error
    # up to 3e-9 once multiplied by Λ ~ 10⁷); the formula is the same.
    with np.errstate(over="ignore"):
        return np.where(theta > theta0, 1.0 + lam * -np.expm1(c * x**k), 1.0)


def bagher(wi, wo, p):  # bagher.h: microfacet<sgd, uncorrelated, bagher Fresnel, Cook> × albedo
    h = _halfway(wi, wo)
    alpha, pp, kk = (np.asarray(p[n]) for n in ("alpha", "p", "K"))
    tan2 = ((h[:, 0] ** 2 + h[:, 1] ** 2) / h[:, 2] ** 2)[:, None]
    temp = alpha + tan2 / alpha
    p22 = np.exp(-temp) / temp**pp
    d = kk * p22 / (math.pi * h[:, 2, None] ** 4.0)
    g1_in, g1_out = _bagher_g1(wi, p), _bagher_g1(wo, p)
    cos = (0.5 * (np.sum(wi * h, -1) + np.sum(wo * h, -1)))[:, None]
    f0, f1 = (np.asarray(x) for x in p["eta"])
    f = _schlick(f0, cos) - f1 * cos
    value = d * g1_in * g1_out * f / math.pi / (wi[:, 2] * wo[:, 2])[:, None]
    return np.asarray(p["albedo"]) * value, (g1_in >= 0) & (g1_out >= 0) & (f >= 0)


TRANSCRIPTIONS = {
    "NganWard": ngan_ward,
    "NganWardDuer": ngan_ward_duer,
    "NganBlinnPhong": ngan_blinn_phong,
    "NganLafortune": ngan_lafortune,
    "NganCookTorrance": ngan_cook_torrance,
    "NganAshikhminShirley": ngan_ashikhmin_shirley,
    "LowCookTorrance": low_cook_torrance,
    "LowAshikhminShirley": low_ashikhmin_shirley,
    "LowMicrofacetFit": low_microfacet,
    "LowSmooth": low_smooth,
}


def _pairs(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Uniform pairs, and as many with wi within a few degrees of wo's mirror direction."""
    wi, wo = hemisphere_pairs(n, seed=seed)
    rng = np.random.default_rng(seed + 1)
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    near = mirror + rng.normal(scale=rng.choice([1e-3, 1e-2, 5e-2], size=(n, 1)), size=(n, 3))
    near[:, 2] = np.abs(near[:, 2]) + 1e-3
    near /= np.linalg.norm(near, axis=-1, keepdims=True)
    return np.concatenate([wi, near]), np.concatenate([wo, wo])


TINY = 1e-290
"""Below the normal floats (2.2e-308) values lose relative precision; this absolute floor lets
them differ in their last subnormal digits."""

CONVERTED = [f for f in fits() if tables()["sources"][f]["model"] in TRANSCRIPTIONS]


@pytest.mark.parametrize("fit", CONVERTED)
def test_every_preset_equals_the_transcribed_bbm_formula(fit):
    source = tables()["sources"][fit]
    transcription = TRANSCRIPTIONS[source["model"]]
    wi, wo = _pairs(seed=len(fit))
    for name, entry in source["materials"].items():
        expected = transcription(wi, wo, entry["params"]) + np.asarray(entry["diffuse"]) / math.pi
        value = preset(name, fit).eval(wi, wo)
        np.testing.assert_allclose(value, expected, rtol=1e-10, atol=TINY, err_msg=f"{fit} {name}")


def test_bagher_presets_equal_the_transcription_where_its_factors_are_non_negative():
    source = tables()["sources"]["bagher_sgd"]
    wi, wo = _pairs(seed=7)
    clamped = total = 0
    for name, entry in source["materials"].items():
        with np.errstate(all="ignore"):
            spec, valid = bagher(wi, wo, entry["params"])
        expected = spec + np.asarray(entry["diffuse"]) / math.pi
        value = preset(name, "bagher_sgd").eval(wi, wo)
        ok = valid & np.isfinite(expected)
        np.testing.assert_allclose(value[ok], expected[ok], rtol=1e-10, atol=TINY, err_msg=name)
        # where bbm's fitted G1 or F is negative, brdfkit clamps the lobe to 0: the diffuse alone
        np.testing.assert_allclose(
            value[~ok], np.broadcast_to(np.asarray(entry["diffuse"]) / math.pi, value.shape)[~ok]
        )
        clamped += int(np.sum(~ok))
        total += ok.size
    assert clamped < 0.05 * total, (clamped, total)


def test_the_shipped_tables_are_the_shared_fit_files(shared_data):
    from brdfkit.brdf.presets import tables_from_fit_files

    folder = shared_data / "measured" / "ngan2005"
    if not folder.is_dir():
        pytest.skip(f"{folder} is absent")
    assert tables_from_fit_files(folder) == tables()


def test_counts_names_and_citations():
    assert len(materials("ngan_ward")) == 86
    assert len(materials("bagher_sgd")) == 100
    assert set(UNCONVERTED) == {"NganHe"}
    assert "ngan_he" not in fits()
    assert "Ngan et al. 2005" in citation("ngan_cooktorrance")
    assert "Low 2012" in citation("low_lowsmooth_E2")
    records = catalogue(model="ward")
    assert {r["fit"] for r in records} == {"ngan_ward", "ngan_wardduer"}
    assert len(catalogue()) == sum(len(materials(f)) for f in fits())


def test_spec_round_trip_and_errors():
    model = parse("material(name='gold-metallic-paint', fit='ngan_ashikhminshirley')")
    assert isinstance(model, Material)
    assert parse(model.to_spec()).to_spec() == model.to_spec()
    wi, wo = _pairs(50)
    np.testing.assert_array_equal(
        model.eval(wi, wo), preset("gold-metallic-paint", "ngan_ashikhminshirley").eval(wi, wo)
    )
    with pytest.raises(ParameterError, match="name"):
        Material("unobtainium")
    with pytest.raises(ParameterError, match="fit"):
        Material("alum-bronze", "ngan_he")
    with pytest.raises(ParameterError, match="name"):
        preset(["alum-bronze"])  # type: ignore[arg-type]


# --------------------------------------------------------------------------- energy
THETA_O = (0.0, 20.0, 40.0, 60.0, 75.0, 85.0)
EXCEEDING = {
    ("bagher_sgd", "gold-metallic-paint2"),
    ("bagher_sgd", "two-layer-silver"),
    ("bagher_sgd", "white-paint"),
}
"""The presets whose albedo exceeds 1 (ρ − 3σ > 1 at some θo ≤ 85°), as listed in
``brdfkit/data/materials/README.md`` (and printed by ``benchmarks/materials_albedo.py``)."""


def test_the_readme_lists_the_presets_whose_albedo_exceeds_one():
    from importlib.resources import files

    readme = (files("brdfkit.data") / "materials" / "README.md").read_text(encoding="utf-8")
    for fit, name in EXCEEDING:
        assert f"`{fit}` `{name}`" in readme


@pytest.mark.slow
def test_albedo_of_every_preset_at_most_one_where_claimed_and_the_exceptions_listed():
    from brdfkit.geometry import spherical_to_cartesian

    theta = np.radians(THETA_O)
    wo = spherical_to_cartesian(theta, np.zeros_like(theta))
    exceeding, claimed = set(), 0
    for record in catalogue():
        model = Material(record["name"], record["fit"])
        with np.errstate(all="ignore"):
            mean, stderr = model.albedo_estimate(wo, samples=2048, seed=1)
        assert np.all(np.isfinite(mean)), record
        if np.any(mean - 3 * stderr > 1):
            exceeding.add((record["fit"], record["name"]))
        if model.energy_conserving:
            claimed += 1
            assert np.all(mean - 3 * stderr <= 1), (record, mean.max())
    assert claimed > 400  # Ngan's Blinn–Phong, Cook–Torrance and Ashikhmin–Shirley presets
    assert exceeding == EXCEEDING
