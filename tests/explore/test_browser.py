"""The explorer's real page in headless Chromium: what it shows equals what Python computes.

One page is driven through the steps a user takes (move a slider, drag the light on the sphere,
type a spec, load a measured file, add a second BRDF); after each, the lit sphere's pixels are
compared with :func:`brdfkit.render.render_sphere` (within 8-bit quantisation) and the plotted
curves with ``eval`` (to 1e-6); then the URL is opened in a new page, and requests without the
token are refused.
"""

from __future__ import annotations

import json
import math
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from _page import canvas_pixels, expected_pixels, light_world, settled

from brdfkit.brdf import parse
from brdfkit.checks import check
from brdfkit.geometry import from_half_diff
from brdfkit.light import DirectionalLight
from brdfkit.measured import read
from brdfkit.render import render_sphere

pytestmark = pytest.mark.slow

LUMA = np.array([0.2126, 0.7152, 0.0722])


def entry(page, index: int) -> dict:
    return page.evaluate(
        "(i) => { const e = window.explorer.state.entries[i];"
        " return {id: e.id, source: e.source, info: e.info}; }",
        index,
    )


def view(page) -> dict:
    return page.evaluate("window.explorer.state.view")


def assert_sphere_matches(page, brdf, entry_id: str) -> None:
    """The page's sphere canvas for ``entry_id`` equals render_sphere, after sRGB, within 1."""
    v = view(page)
    light = DirectionalLight(
        direction=light_world(v["theta_i"], v["phi_i"]), irradiance=v["irradiance"]
    )
    reference = render_sphere(brdf, light, resolution=v["resolution"])
    shown = canvas_pixels(page, f'.bx-sphere[data-id="{entry_id}"]')[..., :3].astype(np.int64)
    expected = expected_pixels(reference)
    assert shown.shape == expected.shape
    difference = np.abs(shown - expected)
    assert difference.max() <= 1, f"{(difference > 1).sum()} pixels differ by more than 1"
    assert expected.std() > 10  # a lit sphere, not a blank image


def assert_curves_match(page, brdf, entry_id: str) -> None:
    """The plotted θv (with cos θv) and θh curves equal brdf.eval at the same directions."""
    v = view(page)
    channel = page.evaluate("window.explorer.state.display.channel")
    plotted = page.evaluate("window.explorer.plotted")

    def grey(f: np.ndarray) -> np.ndarray:
        if f.shape[-1] == 1:
            return f[..., 0]
        index = {"r": 0, "g": 1, "b": 2}.get(channel)
        return f[..., index] if index is not None else f @ LUMA

    t, p = math.radians(v["theta_i"]), math.radians(v["phi_i"])
    wi = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    x = np.asarray(plotted["theta_v"][entry_id]["x"])
    y = np.asarray(plotted["theta_v"][entry_id]["y"])
    np.testing.assert_allclose(x, np.radians(np.linspace(-90, 90, 181)), atol=1e-12)
    wo = np.stack([-np.sin(x) * math.cos(p), -np.sin(x) * math.sin(p), np.cos(x)], -1)
    inside = np.abs(x) < math.radians(89.5)
    f = grey(np.asarray(brdf.eval(np.broadcast_to(wi, wo.shape), wo), np.float64))
    expected = f * np.cos(x)
    np.testing.assert_allclose(y[inside], expected[inside], rtol=1e-6, atol=1e-12)
    assert y[inside].max() > 0

    xh = np.asarray(plotted["theta_h"][entry_id]["x"])
    yh = np.asarray(plotted["theta_h"][entry_id]["y"])
    td, pd = math.radians(v["theta_d"]), math.radians(v["phi_d"])
    wi_h, wo_h = from_half_diff(xh, 0 * xh, np.full_like(xh, td), np.full_like(xh, pd))
    fh = grey(np.asarray(brdf.eval(wi_h, wo_h), np.float64))
    ok = (wi_h[..., 2] > 1e-3) & (wo_h[..., 2] > 1e-3)
    np.testing.assert_allclose(yh[ok], fh[ok], rtol=1e-6, atol=1e-12)


def test_initial_page_matches_python(page):
    e = entry(page, 0)
    brdf = parse(e["info"]["spec"])
    assert brdf.to_spec() == parse("lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)").to_spec()
    assert_sphere_matches(page, brdf, e["id"])
    assert_curves_match(page, brdf, e["id"])
    assert not page.errors


def test_moving_a_slider_updates_spec_sphere_and_curves(page):
    before = page.evaluate("window.explorer.shown.seq")
    param = page.locator('.bx-entry[data-id="b1"] .bx-param[data-path$="params.alpha"]')
    alpha = param.locator("input[type=range]")
    alpha.focus()
    for _ in range(40):
        page.keyboard.press("ArrowRight")
    settled(page, before)
    e = entry(page, 0)
    brdf = parse(e["info"]["spec"])
    new_alpha = brdf.lobes[1].alpha
    assert new_alpha > 0.25  # 40 steps of 1/1000 of the log range from 0.2
    shown = float(param.locator(".bx-number").input_value())
    assert math.isclose(shown, new_alpha, rel_tol=1e-9)
    assert_sphere_matches(page, brdf, "b1")
    assert_curves_match(page, brdf, "b1")


def test_dragging_on_the_sphere_moves_the_light(page):
    before = page.evaluate("window.explorer.shown.seq")
    box = page.locator('.bx-sphere[data-id="b1"]').bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.evaluate(
        "window.previews = 0;"
        " window.explorer.onFrame((h) => { if (h.preview) window.previews += 1; })"
    )
    page.mouse.move(cx, cy)
    page.mouse.down()
    # drag to the point (x, y) = (-0.4, 0.5) of the unit disc: its normal is the light; each
    # step drawn before the next, the steps after the first as previews
    for step in range(1, 5):
        page.mouse.move(cx - 0.1 * step * box["width"] / 2, cy - 0.125 * step * box["height"] / 2)
        page.wait_for_function("() => window.explorer.shown.seq === window.explorer.sent.seq")
    page.mouse.up()
    settled(page, before)
    assert page.evaluate("window.previews") >= 1
    v = view(page)
    x, y = -0.4, 0.5
    theta_i = math.degrees(math.acos(math.sqrt(1 - x * x - y * y)))
    assert math.isclose(v["theta_i"], theta_i, abs_tol=0.5)
    assert math.isclose(v["phi_i"], math.degrees(math.atan2(y, x)), abs_tol=0.5)
    slider = float(page.locator(".bx-theta_i").input_value())
    assert math.isclose(slider, v["theta_i"], abs_tol=0.1)
    brdf = parse(entry(page, 0)["info"]["spec"])
    assert_sphere_matches(page, brdf, "b1")
    assert_curves_match(page, brdf, "b1")


def test_typing_a_spec_and_choosing_a_channel(page):
    before = page.evaluate("window.explorer.shown.seq")
    spec = page.locator('.bx-entry[data-id="b1"] .bx-spec')
    spec.fill("0.8 * oren_nayar(rho=[0.9, 0.6, 0.3], sigma=0.4) + phong(n=40, ks=0.2)")
    spec.press("Enter")
    page.select_option(".bx-channel", "r")
    settled(page, before)
    e = entry(page, 0)
    brdf = parse(e["info"]["spec"])
    typed = parse("0.8 * oren_nayar(rho=[0.9, 0.6, 0.3], sigma=0.4) + phong(n=40, ks=0.2)")
    assert brdf.to_spec() == typed.to_spec()
    numbers = [c["name"] for c in e["info"]["controls"] if c["kind"] == "number"]
    assert numbers[:2] == ["k", "sigma"] and "n" in numbers  # the scale, then the lobes
    assert_curves_match(page, brdf, "b1")
    # the sphere in the red channel only: grey pixels equal to the red channel's encoding
    page.select_option(".bx-channel", "rgb")
    page.wait_for_timeout(100)
    assert_sphere_matches(page, brdf, "b1")


def test_a_bad_spec_is_reported_not_fatal(page):
    before = page.evaluate("window.explorer.shown.seq")
    spec = page.locator('.bx-entry[data-id="b1"] .bx-spec')
    good = spec.input_value()
    spec.fill("__import__('os').system('true')")
    spec.press("Enter")
    settled(page, before)
    assert "not allowed" in page.locator('.bx-entry[data-id="b1"] .bx-error').inner_text()
    spec.fill(good)
    spec.press("Enter")
    settled(page)
    assert page.locator('.bx-entry[data-id="b1"] .bx-error').inner_text() == ""


def test_loading_a_measured_file_and_a_second_brdf(page, merl_file):
    before = page.evaluate("window.explorer.shown.seq")
    page.select_option(".bx-add-file", merl_file.name)
    settled(page, before)
    before = page.evaluate("window.explorer.shown.seq")
    page.locator(".bx-add-spec").fill("ggx(alpha=0.3, material='Au')")
    page.locator(".bx-add-spec").press("Enter")
    settled(page, before)
    ids = page.evaluate("window.explorer.state.entries.map((e) => e.id)")
    assert len(ids) == 3
    measured = read(merl_file)
    assert entry(page, 1)["source"] == {"file": merl_file.name}
    assert_sphere_matches(page, measured, ids[1])
    assert_curves_match(page, measured, ids[1])
    gold = parse(entry(page, 2)["info"]["spec"])
    assert gold.to_spec() == parse("ggx(alpha=0.3, material='Au')").to_spec()
    assert_sphere_matches(page, gold, ids[2])
    assert_curves_match(page, gold, ids[2])
    # three visible BRDFs: three spheres and the difference of the first two, |first − second|
    assert page.locator(".bx-sphere").count() == 4
    v = view(page)
    light = DirectionalLight(
        direction=light_world(v["theta_i"], v["phi_i"]), irradiance=v["irradiance"]
    )
    first = render_sphere(parse(entry(page, 0)["info"]["spec"]), light, resolution=256)
    difference = np.abs(first - render_sphere(measured, light, resolution=256))
    shown = canvas_pixels(page, '.bx-sphere[data-id="difference"]')[..., :3].astype(np.int64)
    assert np.abs(shown - expected_pixels(difference)).max() <= 1
    # hiding one removes its sphere
    before = page.evaluate("window.explorer.shown.seq")
    page.locator(f'.bx-entry[data-id="{ids[0]}"] .bx-visible').uncheck()
    settled(page, before)
    assert page.locator(f'.bx-sphere[data-id="{ids[0]}"]').count() == 0
    assert not page.errors


def test_uploading_a_file(page, merl_file):
    before = page.evaluate("window.explorer.shown.seq")
    page.set_input_files(".bx-upload", str(merl_file))
    page.wait_for_function("window.explorer.state.entries.length === 4", timeout=60_000)
    settled(page, before)
    e = entry(page, 3)
    assert e["source"]["file"].endswith(".binary") and e["source"]["file"] != merl_file.name
    assert_sphere_matches(page, read(merl_file), e["id"])
    # a fit.json (brdfkit fit's result) becomes its fitted model
    fit = merl_file.with_name("fit.json")
    fit.write_text(json.dumps({"file": merl_file.name, "spec": "phong(n=12, ks=0.3)"}))
    before = page.evaluate("window.explorer.shown.seq")
    page.set_input_files(".bx-upload", str(fit))
    page.wait_for_function("window.explorer.state.entries.length === 5", timeout=60_000)
    settled(page, before)
    fitted = parse(entry(page, 4)["info"]["spec"])
    assert fitted.to_spec() == parse("phong(n=12, ks=0.3)").to_spec()
    assert_sphere_matches(page, fitted, entry(page, 4)["id"])


DROP = """(selector) => {
  const input = document.querySelector(selector);
  const data = new DataTransfer();
  for (const f of input.files) data.items.add(f);
  const root = document.querySelector('.brdfkit-explorer');
  const options = { dataTransfer: data, bubbles: true, cancelable: true };
  root.dispatchEvent(new DragEvent('dragover', options));
  root.dispatchEvent(new DragEvent('drop', options));
}"""


def drop(page, path: Path) -> None:
    """Drop ``path`` on the explorer as a user drags it from a file manager: the file enters
    the page through a test-only file input, then travels in a drop event's DataTransfer."""
    page.evaluate(
        "() => { const i = document.createElement('input'); i.type = 'file';"
        " i.id = 'test-drop'; i.hidden = true; document.body.append(i); }"
    )
    page.set_input_files("#test-drop", str(path))
    page.evaluate(DROP, "#test-drop")
    page.evaluate("() => document.getElementById('test-drop').remove()")


def test_dropping_a_measured_file_loads_it(page, merl_file, tmp_path):
    count = page.evaluate("window.explorer.state.entries.length")
    dropped = tmp_path / "dropped.binary"
    dropped.write_bytes(merl_file.read_bytes())
    before = page.evaluate("window.explorer.shown.seq")
    drop(page, dropped)
    page.wait_for_function(f"window.explorer.state.entries.length === {count + 1}", timeout=60_000)
    settled(page, before)
    e = entry(page, count)
    assert e["source"]["file"].endswith("dropped.binary")
    assert_sphere_matches(page, read(merl_file), e["id"])
    assert_curves_match(page, read(merl_file), e["id"])
    assert not page.errors


def test_a_file_over_64_mib_is_refused_with_a_clear_message(page, tmp_path):
    from brdfkit.explore.session import MAX_UPLOAD_BYTES

    count = page.evaluate("window.explorer.state.entries.length")
    big = tmp_path / "big.binary"
    with big.open("wb") as f:
        f.truncate(MAX_UPLOAD_BYTES + 1)
    drop(page, big)
    status = page.locator(".bx-status")
    status.filter(has_text="at most 64 MiB").wait_for(timeout=30_000)
    assert f"'big.binary' holds {MAX_UPLOAD_BYTES + 1} bytes" in status.inner_text()
    assert page.evaluate("window.explorer.state.entries.length") == count
    assert not page.errors


def test_solo_physics_checks_and_exports(page):
    ids = page.evaluate("window.explorer.state.entries.map((e) => e.id)")
    before = page.evaluate("window.explorer.shown.seq")
    page.locator(f'.bx-entry[data-id="{ids[2]}"] .bx-solo').click()
    settled(page, before)
    assert page.evaluate(
        "Array.from(document.querySelectorAll('.bx-sphere')).map(c => c.dataset.id)"
    ) == [ids[2]]
    # the physics checks of the gold GGX, with their numbers
    page.locator(f'.bx-entry[data-id="{ids[2]}"] .bx-check').click()
    page.wait_for_selector(".bx-checks table", timeout=120_000)
    rows = page.locator(".bx-checks tr").all_inner_texts()
    shown = [row.split("\t")[:2] for row in rows[1:]]
    report = check(parse(entry(page, 2)["info"]["spec"]))
    assert shown == [[r.name, r.verdict] for r in report.results]
    assert {"reciprocity", "energy"} <= {name for name, _ in shown}
    # exports: a PNG of a view, the specs, the parameters as JSON
    with page.expect_download() as png:
        page.locator(".bx-panel-polar .bx-png").click()
    assert png.value.suggested_filename == "polar.png"
    assert Path(png.value.path()).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with page.expect_download() as spheres:
        page.locator(".bx-panel-spheres .bx-png").click()
    assert Path(spheres.value.path()).read_bytes()[:4] == b"\x89PNG"
    with page.expect_download() as specs:
        page.locator(".bx-export-spec").click()
    lines = Path(specs.value.path()).read_text().splitlines()
    assert parse(lines[2]).to_spec() == parse(entry(page, 2)["info"]["spec"]).to_spec()
    with page.expect_download() as saved:
        page.locator(".bx-export-json").click()
    state = json.loads(Path(saved.value.path()).read_text())
    assert [e["id"] for e in state["entries"]] == ids
    before = page.evaluate("window.explorer.shown.seq")
    page.locator(f'.bx-entry[data-id="{ids[2]}"] .bx-solo').click()
    settled(page, before)
    assert page.locator(".bx-sphere").count() >= 3


def test_the_url_restores_the_state(page, browser):
    page.wait_for_timeout(400)  # the URL is written 150 ms after the last change
    url = page.url
    assert "#s=" in url
    state = page.evaluate("window.explorer.persistent()")
    context = browser.new_context(viewport={"width": 1500, "height": 1100}, bypass_csp=True)
    other = context.new_page()
    other.goto(url)
    settled(other)
    assert other.evaluate("window.explorer.persistent()") == state
    for e in state["entries"]:
        if e["visible"]:
            a = canvas_pixels(page, f'.bx-sphere[data-id="{e["id"]}"]')
            b = canvas_pixels(other, f'.bx-sphere[data-id="{e["id"]}"]')
            assert np.array_equal(a, b)
    context.close()


def test_requests_without_the_token_are_refused(page, server):
    base = f"http://127.0.0.1:{server.port}/"
    wrong = ("y" if server.token[0] == "x" else "x") + server.token[1:]  # one character off
    for url in (base, base + "static/explorer.js", base + wrong + "/"):
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(url, timeout=60)
        assert refused.value.code == 403
    with urllib.request.urlopen(server.url, timeout=60) as ok:
        assert ok.status == 200
    # the page's own WebSocket is refused without the token
    closed = page.evaluate(
        """(url) => new Promise((resolve) => { const ws = new WebSocket(url);
           ws.onopen = () => resolve('open'); ws.onclose = (e) => resolve('closed'); })""",
        f"ws://127.0.0.1:{server.port}/ws",
    )
    assert closed == "closed"


def test_the_environment_lit_sphere_refines_and_agrees_with_python(server, browser):
    from brdfkit.render import progressive_sphere

    server.session.warmed.wait(timeout=120)
    context = browser.new_context(viewport={"width": 1500, "height": 1100}, bypass_csp=True)
    page = context.new_page()
    page.goto(server.url)
    settled(page)
    page.locator(".bx-envmap").check()
    page.wait_for_function(
        "() => (window.explorer.env.b1 || {}).samples >= 8", timeout=120_000, polling=200
    )
    env = page.evaluate("window.explorer.env.b1")
    assert env["noise"] > 0
    caption = page.locator(".bx-env-box .bx-caption").first.inner_text()
    assert "spp" in caption and "noise" in caption
    # the pass's values and the canvas, read at once (a new pass may arrive at any time)
    values, pixels, samples = page.evaluate(
        """() => { const c = document.querySelector('.bx-env[data-id="b1"]');
           const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
           return [window.explorer.envImage('b1'), Array.from(d), window.explorer.env.b1.samples];
        }"""
    )
    brdf = parse(entry(page, 0)["info"]["spec"])
    reference = list(progressive_sphere(brdf, server.session.envmap, 256, max_samples=16))[-1]
    shown = np.asarray(values, np.float64).reshape(reference.image.shape)
    sigma = reference.stderr * math.sqrt(1 + reference.samples / samples)
    off = np.abs(shown - reference.image) > 5 * sigma + 1e-3
    assert off.mean() < 0.01, f"{off.mean():.3%} of pixels disagree beyond 5σ"
    # the canvas shows those values, tone-mapped as the directional sphere is
    pixels = np.asarray(pixels, np.int64).reshape(256, 256, 4)[..., :3]
    assert np.abs(pixels - expected_pixels(shown)).max() <= 1
    context.close()


def test_the_lit_object_orbits_and_equals_the_python_render(server, browser):
    """The lit-object view: a bundled mesh under the session's map, orbited by a drag; the
    pass shown equals :func:`brdfkit.render.progressive` of the same mesh, camera, map, tiles
    and samples (default seed) in Python, and its canvas that image within 8-bit quantisation.
    (Other tiles round the float32 sums otherwise: up to ~5e-5 relative at a few pixels.)"""
    from brdfkit.explore.views import LIT_RESOLUTION, LIT_TILE_EVALUATIONS, orbit_camera
    from brdfkit.render import progressive
    from brdfkit.render.bundled_meshes import load_mesh, object_bounds
    from brdfkit.render.mitsuba_frame import mitsuba_oriented

    server.session.warmed.wait(timeout=120)  # the kernels' builds, not this view's work
    context = browser.new_context(viewport={"width": 1500, "height": 1100}, bypass_csp=True)
    page = context.new_page()
    page.goto(server.url)
    settled(page)
    page.locator(".bx-mesh").select_option("bundled:knot")
    page.locator(".bx-lit").check()
    page.wait_for_function(
        "() => (window.explorer.lit.b1 || {}).mesh === 'bundled:knot'", timeout=60_000
    )
    before = page.evaluate("window.explorer.lit.b1")
    box = page.locator('.bx-lit-image[data-id="b1"]').bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x - 60, y + 30)
    page.mouse.up()
    v = view(page)
    assert (v["azimuth"], v["elevation"]) != (before["azimuth"], before["elevation"])
    page.wait_for_function(
        "([a, e]) => { const l = window.explorer.lit.b1 || {};"
        " return l.azimuth === a && l.elevation === e && l.samples >= 4; }",
        arg=[v["azimuth"], v["elevation"]],
        timeout=60_000,
        polling=100,
    )
    values, pixels, shown = page.evaluate(
        """() => { const c = document.querySelector('.bx-lit-image[data-id="b1"]');
           const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
           return [window.explorer.litImage('b1'), Array.from(d), window.explorer.lit.b1]; }"""
    )
    brdf = parse(entry(page, 0)["info"]["spec"])
    scene = load_mesh("bundled:knot")
    camera = orbit_camera(object_bounds("knot"), v["azimuth"], v["elevation"], LIT_RESOLUTION)
    g = scene.gbuffer(camera, LIT_RESOLUTION)
    light = mitsuba_oriented(server.session.envmap)
    passes = progressive(
        g, brdf, light, max_samples=shown["samples"], visibility=scene.visibility(g),
        max_evaluations=LIT_TILE_EVALUATIONS,
    )  # fmt: skip
    reference = next(p for p in passes if p.samples == shown["samples"]).image
    image = np.asarray(values, np.float64).reshape(reference.shape)
    np.testing.assert_allclose(image, reference, rtol=1e-6, atol=1e-6)  # float32 on the wire
    expected = expected_pixels(reference)
    pixels = np.asarray(pixels, np.int64).reshape(LIT_RESOLUTION, LIT_RESOLUTION, 4)[..., :3]
    assert np.abs(pixels - expected).max() <= 1
    assert expected.std() > 10 and g.mask.mean() > 0.5  # an object over its ground, lit
    assert not page.evaluate("document.querySelector('.bx-status').textContent")
    context.close()
