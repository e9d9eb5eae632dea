"""The atlas: built by the README's first command, opened in a real (headless) browser."""

from __future__ import annotations

import re

import matplotlib
import pytest

matplotlib.use("Agg")

from test_atlas_text import raw_marks, visible_text
from typer.testing import CliRunner

from brdfkit.brdf import MODELS
from brdfkit.cli import app
from brdfkit.cli._output import MANIFEST
from brdfkit.report.atlas import DEFAULT_MODELS, atlas_html, build_card


def _body_counts(dom: str) -> dict[str, int]:
    body = re.search(r"<body([^>]*)>", dom).group(1)
    return {k: int(v) for k, v in re.findall(r'data-([a-z-]+)="(\d+)"', body)}


@pytest.mark.slow
def test_readme_atlas_command_renders_every_card_in_a_browser(tmp_path, browser_dom):
    result = CliRunner().invoke(app, ["atlas", "-o", str(tmp_path / "atlas")])
    assert result.exit_code == 0, result.output
    page = tmp_path / "atlas" / "index.html"
    left = [p.name for p in (tmp_path / "atlas").iterdir() if p != page]
    assert left == [MANIFEST]  # no temporaries left; the record of what brdfkit wrote
    assert raw_marks(visible_text(page.read_text())).total() == 0
    expected_cards = sum(name in MODELS for name in DEFAULT_MODELS)
    counts = _body_counts(browser_dom(page.as_uri()))
    assert counts["cards"] == expected_cards
    assert counts["images"] >= 4 * expected_cards
    assert counts["images-ok"] == counts["images"], "some images failed to load"
    html = page.read_text()
    for name in DEFAULT_MODELS:
        if name in MODELS:
            assert f'id="{name}"' in html
    assert "CONTRADICTS" not in html  # every model's checks agree with its claims


def test_card_has_formula_checks_and_citations(tmp_path, browser_dom):
    from brdfkit.brdf import Lambertian
    from brdfkit.light import DirectionalLight

    card = build_card(
        "lambertian",
        [Lambertian(0.2), Lambertian(0.8)],
        envmap=DirectionalLight((1, 0, 0)),
        resolution=16,
        samples=2,
    )
    assert {c["name"] for c in card.checks} >= {"reciprocity", "energy", "isotropy"}
    assert card.consistent
    page = atlas_html([card], "test")
    assert "Lambert" in page and "Physics checks" in page
    assert "<math" in page and "References" in page  # the formula as MathML, the citation
    (tmp_path / "a.html").write_text(page)
    counts = _body_counts(browser_dom((tmp_path / "a.html").as_uri()))
    assert counts["cards"] == 1 and counts["images-ok"] == counts["images"] >= 4


def test_atlas_rejects_a_missing_envmap(tmp_path):
    result = CliRunner().invoke(app, ["atlas", "-o", str(tmp_path), "--envmap", "nope.hdr"])
    assert result.exit_code == 2 and "envmap must be an existing" in result.output


def test_atlas_and_plots_take_measured_files(shared_data, tmp_path):
    from brdfkit.report.atlas import default_cards

    rgl = shared_data / "measured" / "rgl" / "acrylic_felt_green_rgb.bsdf"
    cornell = shared_data / "measured" / "cornell" / "garnet_red.brdf"
    cards = default_cards([str(rgl), str(cornell)])
    assert [title for title, _ in cards] == [rgl.name, cornell.name]
    out = tmp_path / "lobe.png"
    result = CliRunner().invoke(app, ["plot", "lobe", str(rgl), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 1000
    result = CliRunner().invoke(app, ["plot", "lobe", str(tmp_path / "none.bsdf"), "-o", str(out)])
    assert result.exit_code == 2 and "not found" in result.output
    args = [
        "atlas",
        "-o",
        str(tmp_path / "a"),
        "-m",
        str(cornell),
        "--no-checks",
        "-r",
        "16",
        "-s",
        "2",
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert f'id="{cornell.name}"' in (tmp_path / "a" / "index.html").read_text()


def test_atlas_command_reports_a_bad_spec_without_writing(tmp_path):
    result = CliRunner().invoke(app, ["atlas", "-o", str(tmp_path / "out"), "-m", "nope(x=1)"])
    assert result.exit_code == 2 and "unknown model 'nope'" in result.output
    assert not (tmp_path / "out" / "index.html").exists()


def test_env_sphere_refines_until_its_noise_goal_and_meets_it():
    import numpy as np

    from brdfkit.interop.mitsuba import relative_rmse
    from brdfkit.light import EnvironmentMap
    from brdfkit.render import render_sphere
    from brdfkit.render.scene import interior_mask
    from brdfkit.report.atlas import env_sphere

    env = EnvironmentMap(np.random.default_rng(3).random((16, 32, 3)) ** 4 * 4)
    ggx = MODELS["ggx"](alpha=0.3, material="Au")
    image, spp = env_sphere(ggx, env, 12, samples=4, noise=None, quadrature=False)
    assert spp == 4 and image.shape == (12, 12, 3)
    image, spp = env_sphere(
        ggx, env, 12, samples=4, noise=0.05, max_samples=1024, seed=1, quadrature=False
    )
    assert 4 < spp < 1024  # it refined, and stopped before the cap
    reference = render_sphere(ggx, env, 12, samples=16 * spp, seed=2, compiled=False)
    assert relative_rmse(image, reference, interior_mask(12)) <= 0.05


def test_env_sphere_uses_the_quadrature_where_it_applies():
    import numpy as np

    from brdfkit.interop.mitsuba import relative_rmse
    from brdfkit.light import EnvironmentMap
    from brdfkit.render import render_sphere
    from brdfkit.render.scene import interior_mask
    from brdfkit.report.atlas import env_sphere

    env = EnvironmentMap(np.random.default_rng(3).random((16, 32, 3)) ** 4 * 4)
    ggx = MODELS["ggx"](alpha=0.3, material="Au")
    image, spent = env_sphere(ggx, env, 12, samples=4, noise=0.01)
    assert spent.startswith("quadrature, ") and spent.endswith(" nodes")
    reference = render_sphere(ggx, env, 12, samples=1024, seed=2, compiled=False)
    assert relative_rmse(image, reference, interior_mask(12)) <= 0.02
    aniso = MODELS["ggx"](alpha_u=0.05, alpha_v=0.3)  # the quadrature's tangent angles
    assert env_sphere(aniso, env, 12, samples=4, noise=None)[1].startswith("quadrature, ")
    mirror = MODELS["mirror"]()  # delta: Monte Carlo, exact at one sample per replicate
    assert env_sphere(mirror, env, 12, samples=4, noise=None)[1] == 2


def test_env_sphere_renders_a_sample_independent_delta_model_at_two_samples():
    import numpy as np

    from brdfkit.light import EnvironmentMap
    from brdfkit.render import render_sphere
    from brdfkit.render.compiled_shading import compiled_shader
    from brdfkit.report.atlas import env_sphere

    env = EnvironmentMap(np.random.default_rng(3).random((16, 32, 3)) ** 4 * 4)
    for name in ("mirror", "smooth_dielectric"):
        model = MODELS[name]()
        image, spp = env_sphere(model, env, 12, samples=32, noise=None)
        assert spp == 2
        # a small atlas sphere takes the kernels only where they are built already
        built = compiled_shader(model, [env], method="auto", build=False) is not None
        reference = render_sphere(model, env, 12, samples=32, seed=5, compiled=built)
        np.testing.assert_allclose(image, reference, rtol=1e-12, atol=1e-12)
    # a delta lobe beside a glossy one: its samples disagree, so it gets all of its samples
    mixed = MODELS["mirror"]() + MODELS["ggx"](alpha=0.3, material="Au")
    assert env_sphere(mixed, env, 12, samples=8, noise=None, quadrature=False)[1] == 8


def test_build_card_records_the_cpu_seconds_of_its_parts():
    import numpy as np

    from brdfkit.light import EnvironmentMap
    from brdfkit.report.atlas import build_card

    env = EnvironmentMap(np.random.default_rng(3).random((16, 32, 3)) ** 4 * 4)
    models = [MODELS["lambertian"](), MODELS["phong"]()]
    card = build_card("t", models, envmap=env, resolution=8, samples=4, run_checks=False)
    parts = ["directional spheres", "environment spheres", "lobe plot", "albedo plot"]
    assert list(card.cpu_seconds) == parts and all(s >= 0 for s in card.cpu_seconds.values())
    assert len(card.env_cpu_seconds) == 2 and card.env_samples[0] == "quadrature, 0 nodes"
    assert card.env_samples[1].startswith("quadrature, ")  # phong: isotropic, no delta
    assert sum(card.env_cpu_seconds) <= card.cpu_seconds["environment spheres"] + 1e-6


def test_a_card_shows_its_model_on_an_object_when_asked():
    import base64
    import io

    import numpy as np
    from PIL import Image

    from brdfkit.light import EnvironmentMap
    from brdfkit.plot import encode_spheres
    from brdfkit.report.atlas import object_image

    pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")
    env = EnvironmentMap(np.random.default_rng(3).random((16, 32, 3)) ** 4 * 4)
    models = [MODELS["ggx"](alpha=0.2, material="Au")]
    options = {"envmap": env, "resolution": 12, "samples": 2, "run_checks": False}
    card = build_card("t", models, objects=True, **options)
    caption = "shaderball under the environment map, shadows (4 spp)"
    shown = np.asarray(Image.open(io.BytesIO(base64.b64decode(card.images[caption]))))
    expected = encode_spheres([object_image(models[0], env, 12)])[0]
    np.testing.assert_array_equal(shown, expected)
    assert card.cpu_seconds["object"] >= 0 and expected.std() > 5


def test_png_reuses_a_layout_and_draws_the_same_pixels(monkeypatch):
    import math

    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from brdfkit.plot import albedo_plot, lobe_plot
    from brdfkit.report import atlas as report

    monkeypatch.setattr(report, "_LAYOUTS", {})
    angles = [math.radians(a) for a in (0, 30, 60)]
    first, second = MODELS["lambertian"](), MODELS["ggx"](alpha=0.2)
    fresh = report._png(lobe_plot(second, angles))  # constrained layout, as ever
    report._png(lobe_plot(first, angles), layout=("lobe",))  # lays out, keeps the positions
    assert list(report._LAYOUTS) == [("lobe",)]
    reused = lobe_plot(second, angles)
    assert report._png(reused, layout=("lobe",)) == fresh
    assert not isinstance(reused.get_layout_engine(), ConstrainedLayoutEngine)
    # y limits that widen the tick labels move the axes: a key of their own, laid out afresh
    low, high = albedo_plot(first), albedo_plot(3000.0 * first)
    report._png(low, layout=("albedo", low.axes[0].get_ylim()))
    assert report._png(high, layout=("albedo", high.axes[0].get_ylim())) == report._png(
        albedo_plot(3000.0 * first)
    )
    positions = list(report._LAYOUTS.values())
    assert len(positions) == 3 and positions[1] != positions[2]


def test_png_draws_a_figure_with_a_kept_layout_once(monkeypatch):
    """A plot given the kept positions has no layout engine at all (not matplotlib's
    placeholder, for which savefig draws the figure a second time, to lay it out)."""
    import math

    from matplotlib.figure import Figure

    from brdfkit.plot import lobe_plot
    from brdfkit.report import atlas as report

    monkeypatch.setattr(report, "_LAYOUTS", {})
    angles = [math.radians(a) for a in (0, 30, 60)]
    report._png(lobe_plot(MODELS["lambertian"](), angles), layout=("lobe",))
    draws = []
    real = Figure.draw
    monkeypatch.setattr(
        Figure, "draw", lambda fig, renderer: draws.append(1) or real(fig, renderer)
    )
    reused = lobe_plot(MODELS["ggx"](alpha=0.2), angles)
    report._png(reused, layout=("lobe",))
    assert len(draws) == 1 and reused.get_layout_engine() is None


def test_default_examples_are_made_by_the_card_builders_not_the_parent(monkeypatch, tmp_path):
    from brdfkit.report import atlas as report

    made: list[str] = []
    real = report.default_examples
    monkeypatch.setattr(report, "default_examples", lambda name: made.append(name) or real(name))
    handed = []

    def build_cards(entries, options, progress):
        handed.extend(entries)
        return []

    monkeypatch.setattr(report, "_build_cards", build_cards)
    report.build_atlas(tmp_path / "index.html")
    assert made == []  # the parent made no example: the builders will, each its card's
    assert [title for title, _ in handed] == [n for n in DEFAULT_MODELS if n in MODELS]
    title, examples = handed[1]
    assert callable(examples) and made == []
    assert [m.to_spec() for m in examples()] == [m.to_spec() for m in MODELS[title].examples()[:4]]
    assert made == [title]


def test_a_card_is_built_from_what_makes_its_examples():
    import numpy as np

    from brdfkit.light import EnvironmentMap
    from brdfkit.report.atlas import _card

    options = {"envmap": EnvironmentMap(np.ones((8, 16, 3))), "resolution": 8, "samples": 4}
    models = [MODELS["lambertian"](), MODELS["phong"]()]
    made = _card("t", lambda: models, {**options, "run_checks": False})
    given = _card("t", models, {**options, "run_checks": False})
    assert made.models == given.models == models and made.labels == given.labels
    assert made.images == given.images
