"""BRDF Explorer's analytic files: all 40 of its distribution load and evaluate finitely, a
handful equal their formulas transcribed here in NumPy, and the format's errors name the file
and line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brdfkit.errors import FormatError, ParameterError
from brdfkit.interop.brdf_explorer import ExplorerBRDF, read_brdf_explorer

CONSTRUCTS = Path(__file__).parent / "data" / "constructs.brdf"
PI_FILE = 3.14159265  # the truncated π that lambert.brdf and ward.brdf write


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


WI, WO = _directions(64, 3), _directions(64, 4)


def _explorer_files(folder: Path) -> list[Path]:
    return sorted((folder / "brdf_explorer").glob("*.brdf"))


@pytest.fixture(scope="module")
def explorer(shared_data):
    folder = shared_data / "brdf_explorer"
    if not folder.is_dir():
        pytest.skip(f"BRDF Explorer's files are not in {folder}")
    return folder


def test_the_distribution_holds_forty_files(explorer):
    assert len(list(explorer.glob("*.brdf"))) == 40


NAMES = [
    "ashikhman_shirley", "blinn", "blinnphong", "compare", "cooktorrance", "dAniso",
    "d_beckmann", "d_blinnphong", "d_exponential", "d_gaussian", "d_ggx", "d_nishino",
    "d_phong", "d_trowbridge_reitz", "disney", "edwards06", "f_cooktorrance", "f_schlick",
    "f_schlick_f0", "g_ap07", "g_as00", "g_cooktorrance", "g_duer", "g_kelemen", "g_kurt10",
    "g_neumann", "g_schlick", "g_walter07", "g_ward", "lambert", "minnaert", "modifiedphong",
    "orennayar", "phong", "schlick", "showAngles", "showVectors", "stretchedphong", "walter",
    "ward",
]  # fmt: skip


@pytest.mark.parametrize("name", NAMES)
def test_every_file_of_the_distribution_loads_and_evaluates_finitely(explorer, name):
    brdf = read_brdf_explorer(explorer / f"{name}.brdf")
    assert isinstance(brdf, ExplorerBRDF) and brdf.channels == 3
    value = brdf.eval(WI, WO)
    assert value.shape == (64, 3)
    assert np.all(np.isfinite(value)) and np.all(value >= 0)
    assert np.all(np.isfinite(brdf.shader_value(WI, WO)))


# --------------------------------------------------------------------------- transcriptions
def _frame(wi, wo):
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    return h, wi[:, 2], wo[:, 2], h[:, 2], np.sum(wo * h, axis=-1)


def _schlick(f0, u):
    return f0 + (1 - f0) * (1 - u) ** 5


def test_lambert_is_reflectance_over_pi(explorer):
    brdf = read_brdf_explorer(explorer / "lambert.brdf", reflectance=0.35)
    np.testing.assert_allclose(brdf.eval(WI, WO), np.full((64, 3), 0.35 / PI_FILE), rtol=1e-15)


def test_blinn_phong_is_the_half_vector_cosine_lobe_over_cos_theta_i(explorer):
    brdf = read_brdf_explorer(explorer / "blinnphong.brdf", n=37.0)
    _, nl, _, nh, _ = _frame(WI, WO)
    expected = np.maximum(nh, 0) ** 37 / nl
    np.testing.assert_allclose(brdf.eval(WI, WO), np.stack([expected] * 3, -1), rtol=1e-12)


def test_ward_is_walters_anisotropic_gaussian_lobe(explorer):
    values = {"alpha_x": 0.1, "alpha_y": 0.3, "Cs": [0.9, 0.5, 0.1], "Cd": [0.1, 0.2, 0.3]}
    brdf = read_brdf_explorer(explorer / "ward.brdf", **values)
    h, nl, nv, nh, _ = _frame(WI, WO)
    lobe = np.exp(-((h[:, 0] / 0.1) ** 2 + (h[:, 1] / 0.3) ** 2) / nh**2)
    lobe /= 4 * PI_FILE * 0.1 * 0.3 * np.sqrt(nl * nv)
    expected = np.array([0.1, 0.2, 0.3]) / PI_FILE + np.array([0.9, 0.5, 0.1]) * lobe[:, None]
    np.testing.assert_allclose(brdf.eval(WI, WO), expected, rtol=1e-12)


@pytest.mark.parametrize("include_g", [True, False])
def test_cook_torrance_is_beckmann_schlick_and_the_v_groove(explorer, include_g):
    brdf = read_brdf_explorer(explorer / "cooktorrance.brdf", m=0.2, f0=0.3, include_G=include_g)
    _, nl, nv, nh, vh = _frame(WI, WO)
    m2, t2 = 0.2**2, nh**2
    d = np.exp((t2 - 1) / (m2 * t2)) / (m2 * t2**2)  # Beckmann without its 1/π, as the file has
    # the file's include_G switch replaces the V-groove G by 1: G/(N·V) becomes 1/(N·V)
    g = 1.0 if include_g else np.minimum(1, np.minimum(2 * nh * nv / vh, 2 * nh * nl / vh))
    expected = d * _schlick(0.3, vh) * g / (nl * nv)
    np.testing.assert_allclose(brdf.eval(WI, WO), np.stack([expected] * 3, -1), rtol=1e-12)


def test_ashikhmin_shirley_anisotropic(explorer):
    values = {"Rs": 0.2, "Rd": 0.7, "nu": 10.0, "nv": 200.0, "isotropic": False}
    brdf = read_brdf_explorer(explorer / "ashikhman_shirley.brdf", **values)
    h, nl, nv, nh, vh = _frame(WI, WO)
    exponent = (10 * h[:, 0] ** 2 + 200 * h[:, 1] ** 2) / (1 - nh**2)
    specular = np.sqrt(11 * 201) / (8 * np.pi) * nh**exponent / (vh * np.maximum(nl, nv))
    specular *= _schlick(0.2, vh)
    diffuse = (
        28 / (23 * np.pi) * 0.7 * (1 - 0.2) * (1 - (1 - nl / 2) ** 5) * (1 - (1 - nv / 2) ** 5)
    )
    np.testing.assert_allclose(
        brdf.eval(WI, WO), np.stack([specular + diffuse] * 3, -1), rtol=1e-12
    )


def test_walter_is_ggx_with_smith_masking(explorer):
    brdf = read_brdf_explorer(explorer / "walter.brdf", Kd=0.2, Ks=0.5, alphaG=0.3)
    _, nl, nv, nh, _ = _frame(WI, WO)
    a2 = 0.09
    d = a2 / (np.pi * (nh**2 * (a2 - 1) + 1) ** 2)

    def g1(c):
        return 2 / (1 + np.sqrt(1 + a2 * (1 - c**2) / c**2))

    expected = 0.2 / np.pi + 0.5 * d * g1(nl) * g1(nv) / (4 * nl * nv)
    np.testing.assert_allclose(brdf.eval(WI, WO), np.stack([expected] * 3, -1), rtol=1e-12)


DISNEY = {
    "baseColor": [0.7, 0.3, 0.2], "metallic": 0.3, "subsurface": 0.4, "specular": 0.6,
    "roughness": 0.35, "specularTint": 0.5, "anisotropic": 0.6, "sheen": 0.7,
    "sheenTint": 0.4, "clearcoat": 0.6, "clearcoatGloss": 0.8,
}  # fmt: skip


def _disney(wi, wo, p):
    """Burley 2012, "Physically-based shading at Disney", §5 and appendix B, in NumPy."""
    h, nl, nv, nh, _ = _frame(wi, wo)
    lh = np.sum(wi * h, axis=-1)
    lin = np.asarray(p["baseColor"]) ** 2.2
    lum = 0.3 * lin[0] + 0.6 * lin[1] + 0.1 * lin[2]
    tint = lin / lum
    spec0 = (1 - p["metallic"]) * p["specular"] * 0.08 * (
        (1 - p["specularTint"]) + p["specularTint"] * tint
    ) + p["metallic"] * lin
    sheen_colour = (1 - p["sheenTint"]) + p["sheenTint"] * tint
    fl, fv, fh = ((1 - np.clip(c, 0, 1)) ** 5 for c in (nl, nv, lh))
    fd90 = 0.5 + 2 * lh**2 * p["roughness"]
    fd = (1 + (fd90 - 1) * fl) * (1 + (fd90 - 1) * fv)
    fss90 = lh**2 * p["roughness"]
    fss = (1 + (fss90 - 1) * fl) * (1 + (fss90 - 1) * fv)
    ss = 1.25 * (fss * (1 / (nl + nv) - 0.5) + 0.5)
    aspect = np.sqrt(1 - 0.9 * p["anisotropic"])
    ax, ay = max(0.001, p["roughness"] ** 2 / aspect), max(0.001, p["roughness"] ** 2 * aspect)
    ds = 1 / (np.pi * ax * ay * ((h[:, 0] / ax) ** 2 + (h[:, 1] / ay) ** 2 + nh**2) ** 2)
    fs = spec0 + (1 - spec0) * fh[:, None]

    def smith_aniso(w):
        return 1 / (w[:, 2] + np.sqrt((w[:, 0] * ax) ** 2 + (w[:, 1] * ay) ** 2 + w[:, 2] ** 2))

    gs = smith_aniso(wi) * smith_aniso(wo)
    a = 0.1 + (0.001 - 0.1) * p["clearcoatGloss"]
    dr = (a * a - 1) / (np.pi * np.log(a * a) * (1 + (a * a - 1) * nh**2))
    fr = 0.04 + 0.96 * fh

    def smith(c, alpha):
        return 1 / (c + np.sqrt(alpha**2 + c**2 - alpha**2 * c**2))

    gr = smith(nl, 0.25) * smith(nv, 0.25)
    diffuse = (1 / np.pi) * ((1 - p["subsurface"]) * fd + p["subsurface"] * ss)[:, None] * lin
    sheen = (fh * p["sheen"])[:, None] * sheen_colour
    return (
        (diffuse + sheen) * (1 - p["metallic"])
        + (gs * ds)[:, None] * fs
        + (0.25 * p["clearcoat"] * gr * fr * dr)[:, None]
    )


def test_disney_is_burleys_principled_brdf(explorer):
    brdf = read_brdf_explorer(explorer / "disney.brdf", **DISNEY)
    np.testing.assert_allclose(brdf.eval(WI, WO), _disney(WI, WO, DISNEY), rtol=1e-12)


# --------------------------------------------------------------------------- the convention
def test_below_the_horizon_is_zero_and_negative_values_clamp(explorer):
    lambert = read_brdf_explorer(explorer / "lambert.brdf")
    below = WI * np.array([1.0, 1.0, -1.0])
    np.testing.assert_array_equal(lambert.eval(below, WO), 0.0)
    np.testing.assert_allclose(lambert.shader_value(below, WO), 1 / PI_FILE)
    vectors = read_brdf_explorer(explorer / "showVectors.brdf", show_L=True)
    np.testing.assert_array_equal(vectors.shader_value(WI, WO), WI)
    np.testing.assert_array_equal(vectors.eval(WI, WO), np.maximum(WI, 0))


def test_parameters_are_validated_and_overridable(explorer):
    ward = read_brdf_explorer(explorer / "ward.brdf")
    assert ward.params()["alpha_x"] == 0.15 and ward.params()["isotropic"] is False
    with pytest.raises(ParameterError, match=r"alpha_x must be in \[0.0, 1.0\]; got 3"):
        ward.with_values(alpha_x=3.0)
    with pytest.raises(ParameterError, match="ward has no parameter 'roughness'; its parameters"):
        ward.with_values(roughness=0.1)
    with pytest.raises(ParameterError, match="isotropic"):
        ward.with_values(isotropic="yes")
    red = ward.with_values(Cd=[1.0, 0.0, 0.0], Cs=0.0)
    np.testing.assert_allclose(red.eval(WI, WO), np.broadcast_to([1 / PI_FILE, 0, 0], (64, 3)))


# --------------------------------------------------------------------------- the format's errors
GOOD_SHADER = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(k); }"

FORMAT_ERRORS = [
    ("0 0 0 0 1 2 3\n", 1, "is not an analytic BRDF Explorer file (first line '0'"),
    ("bparam\n", 1, "a 'bparam' file"),
    ("analytic\n::begin parameters\nfloat k 0 1\n::end parameters\n", 3, "expected 'float NAME"),
    ("analytic\n::begin parameters\nvector k 1 2 3\n::end parameters\n", 3, "'vector'"),
    ("analytic\n::begin parameters\nfloat k 0 1 x\n::end parameters\n", 3, "'x' is not a number"),
    ("analytic\n::begin parameters\nbool k 1\nbool k 0\n::end parameters\n", 4, "declared twice"),
    ("analytic\n::begin parameters\n::begin shader\n", 3, "'::begin shader' inside"),
    ("analytic\n\n::begin shader\nvec3 BRDF() { return vec3(1); }\n", 3, "has no '::end shader'"),
    ("analytic\n::begin shader\n::end parameters\n", 3, "closes no open section"),
]


@pytest.mark.parametrize(("text", "line", "reason"), FORMAT_ERRORS)
def test_format_errors_name_the_file_and_line(tmp_path, text, line, reason):
    path = tmp_path / "bad.brdf"
    path.write_text(text)
    with pytest.raises(FormatError) as caught:
        read_brdf_explorer(path)
    assert str(caught.value).startswith(f"{path} (line {line}): ")
    assert reason in str(caught.value)


def _file(tmp_path: Path, shader: str) -> Path:
    path = tmp_path / "s.brdf"
    path.write_text(
        "analytic\n# a comment\n::begin parameters\nfloat k 0 1 0.5\n::end parameters\n\n"
        f"::begin shader\n{shader}\n::end shader\n"
    )
    return path


def test_shader_errors_name_the_line_of_the_file(tmp_path):
    shader = "float f(float x)\n{\n    while (x > 0.0) x -= 1.0;\n    return x;\n}\n" + GOOD_SHADER
    with pytest.raises(FormatError) as caught:
        read_brdf_explorer(_file(tmp_path, shader))
    assert (
        str(caught.value)
        == f"{tmp_path / 's.brdf'} (line 10): GLSL: unsupported construct 'while' loop"
    )


@pytest.mark.parametrize(
    ("shader", "reason"),
    [
        ("float f() { return 1.0; }", "defines no 'vec3 BRDF("),
        ("float BRDF(vec3 L, vec3 V) { return 1.0; }", "expected vec3 BRDF(vec3 × 5)"),
        ("const float k = 2.0;\n" + GOOD_SHADER, "global 'k' redeclares the parameter 'k'"),
        ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec2(k); }", "is vec2"),
    ],
)
def test_a_shader_without_a_usable_brdf_function_is_refused(tmp_path, shader, reason):
    with pytest.raises(FormatError, match=r"s\.brdf") as caught:
        read_brdf_explorer(_file(tmp_path, shader))
    assert reason in str(caught.value)


def test_the_constructs_file_loads_with_its_declared_parameters():
    brdf = read_brdf_explorer(CONSTRUCTS)
    assert brdf.params() == {"which": 0.0, "gain": 1.5, "flip": False, "tint": (0.2, 0.4, 0.6)}


# --------------------------------------------------------------------------- brdfkit's own models
def test_walter_equals_brdfkits_ggx_with_separable_smith_masking(explorer):
    from brdfkit.brdf import parse

    shader = read_brdf_explorer(explorer / "walter.brdf", Kd=0.0, Ks=1.0, alphaG=0.3)
    ggx = parse("ggx(alpha=0.3, material='none', masking='smith_separable')")
    expected = np.broadcast_to(ggx.eval(WI, WO), (64, 3))
    np.testing.assert_allclose(shader.eval(WI, WO), expected, rtol=1e-12)


def test_cook_torrances_fresnel_equals_brdfkits_dielectric_fresnel(explorer):
    from brdfkit.fresnel import fresnel_dielectric

    shader = read_brdf_explorer(explorer / "f_cooktorrance.brdf", ior=1.7)
    h = (WI + WO) / np.linalg.norm(WI + WO, axis=-1, keepdims=True)
    expected = fresnel_dielectric(np.sum(WI * h, axis=-1), 1.7)
    np.testing.assert_allclose(shader.eval(WI, WO)[:, 0], expected, rtol=1e-12)


def test_an_importance_sampling_section_is_ignored_as_brdf_explorer_has_its_own(tmp_path):
    path = tmp_path / "with_is.brdf"
    path.write_text(
        "analytic\n::begin parameters\nfloat k 0 1 0.5\n::end parameters\n"
        f"::begin shader\n{GOOD_SHADER}\n::end shader\n"
        "::begin isFunc\nvec3 sample(float u, float v) { return mat3(1) * vec3(u); }\n"
        "::end isFunc\n"
    )
    brdf = read_brdf_explorer(path)
    np.testing.assert_array_equal(brdf.eval(WI, WO), 0.5)
