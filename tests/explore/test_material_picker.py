"""The explorer's material picker in headless Chromium: it lists every real-material preset,
and choosing one adds it as an entry whose sphere equals :func:`brdfkit.render.render_sphere`
of that preset."""

from __future__ import annotations

import numpy as np
import pytest
from _page import canvas_pixels, expected_pixels, light_world, settled

from brdfkit.brdf import parse
from brdfkit.brdf.presets import catalogue, preset
from brdfkit.light import DirectionalLight
from brdfkit.render import render_sphere

pytestmark = pytest.mark.slow


def test_choosing_a_preset_adds_it_as_an_entry(page):
    records = catalogue()
    options = page.locator(".bx-add-material option")
    assert options.count() == len(records) + 1  # the prompt, then every preset
    groups = page.evaluate(
        "[...document.querySelectorAll('.bx-add-material optgroup')].map((g) => g.label)"
    )
    assert groups == list(dict.fromkeys(r["fit"] for r in records))
    chosen = next(r for r in records if r["fit"] == "ngan_ward" and r["name"] == "gold-paint")
    before = page.evaluate("window.explorer.shown.seq")
    page.select_option(".bx-add-material", chosen["spec"])
    settled(page, before)
    entries = page.evaluate(
        "window.explorer.state.entries.map((e) => ({id: e.id, spec: e.info && e.info.spec}))"
    )
    assert len(entries) == 2
    assert parse(entries[1]["spec"]).to_spec() == chosen["spec"]
    brdf = preset("gold-paint", "ngan_ward")
    assert page.locator(".bx-add-material").input_value() == ""  # ready for the next one
    v = page.evaluate("window.explorer.state.view")
    light = DirectionalLight(
        direction=light_world(v["theta_i"], v["phi_i"]), irradiance=v["irradiance"]
    )
    expected = expected_pixels(render_sphere(brdf, light, resolution=v["resolution"]))
    shown = canvas_pixels(page, f'.bx-sphere[data-id="{entries[1]["id"]}"]')[..., :3]
    assert np.abs(shown.astype(np.int64) - expected).max() <= 1
    assert expected.std() > 10
    assert not page.errors
