"""The notebook widget in a real Jupyter kernel (nbclient), and its front end in Chromium."""

from __future__ import annotations

import base64
import json
import textwrap
import threading

import numpy as np
import pytest
from _page import canvas_pixels, expected_pixels, light_world

pytest.importorskip("anywidget")

SPEC = "lambertian(albedo=[0.2, 0.5, 0.8]) + ggx(alpha=0.25)"


@pytest.mark.slow
def test_the_widget_renders_in_a_jupyter_kernel(monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    from pathlib import Path

    import brdfkit
    from brdfkit.explore.views import sphere_disk

    src = str(Path(brdfkit.__file__).parents[1])
    cells = [
        f"import sys; sys.path.insert(0, {src!r})\nfrom brdfkit.explore import Explorer\n"
        f"w = Explorer({SPEC!r})\nw",
        textwrap.dedent(
            """
            import json
            sent = []
            w.send = lambda content, buffers=None: sent.append((content, buffers))
            message = {"type": "render", "seq": 7, "state": {
                "entries": [{"id": "b1", "visible": True, "source": {"spec": SPEC_HERE}}],
                "view": {"resolution": 64}}}
            w._handle_custom_msg(message, [])
            header, buffers = sent[0]
            types = [c["type"] for c, _ in sent]
            # the environment view: its passes come from a thread, the next message stops them
            message["seq"], message["state"]["view"]["envmap"] = 8, True
            w._handle_custom_msg(message, [])
            import time
            deadline = time.monotonic() + 90
            while time.monotonic() < deadline and not any(
                    c["type"] == "env" and c["samples"] >= 1 for c, _ in sent):
                time.sleep(0.05)
            entry = message["state"]["entries"][0]
            w._handle_custom_msg({"type": "checks", "seq": 9, "entry": entry}, [])
            w._passes.join(timeout=30)
            env = [c for c, _ in sent if c["type"] == "env"]
            print(json.dumps({"types": types, "seq": header["seq"],
                              "spec": header["entries"][0]["spec"],
                              "sphere": header["arrays"][header["views"]["b1"]["sphere"]],
                              "bytes": len(buffers[header["views"]["b1"]["sphere"]]),
                              "env": [[c["seq"], c["samples"]] for c in env],
                              "stopped": not w._passes.is_alive()}))
            """
        ).replace("SPEC_HERE", repr(SPEC)),
    ]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    client = nbclient.NotebookClient(nb, timeout=120, kernel_name="python3", resources={})
    monkeypatch.setenv("PYTHONPATH", src)  # the kernel imports this tree's brdfkit
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")
    client.execute()
    view = nb.cells[0].outputs[-1]["data"]["application/vnd.jupyter.widget-view+json"]
    widgets = nb.metadata["widgets"]["application/vnd.jupyter.widget-state+json"]["state"]
    state = widgets[view["model_id"]]["state"]
    assert "createExplorer" in state["_esm"] and "export default" in state["_esm"]
    config = json.loads(state["config"])
    assert config["initial"][0].startswith("lambertian(rho=[0.2, 0.5, 0.8]")
    reply = json.loads(nb.cells[1].outputs[0]["text"])
    assert reply["types"] == ["frame", "albedo"] and reply["seq"] == 7
    visible = int(sphere_disk(64).mask.sum())  # the sphere's visible pixels, as float16
    assert reply["sphere"] == {"dtype": "float16", "shape": [visible, 3]}
    assert reply["bytes"] == visible * 3 * 2
    assert reply["env"][0] == [8, 0]  # the exact diffuse term first, then passes
    assert [8, 2] in reply["env"] and reply["stopped"]  # 1 sample of each Sobol' replicate
    assert json.loads(state["config"])["envmap"]


MOCK_HOST = """
  const handlers = [];
  const values = { config: window.__config, state: "{}" };
  const model = {
    get: (k) => values[k], set: (k, v) => { values[k] = v; }, save_changes() {},
    on: (name, h) => { if (name === "msg:custom") handlers.push(h); },
    send: async (message) => {
      const replies = [...await window.pyHandle(message), ...await window.pyEnv(message)];
      for (const [header, buffers] of replies) {
        const views = buffers.map((b) => {
          const bytes = Uint8Array.from(atob(b), (c) => c.charCodeAt(0));
          return new DataView(bytes.buffer);
        });
        for (const h of handlers) h(header, views);
      }
    },
  };
  const url = URL.createObjectURL(new Blob([window.__esm], { type: "text/javascript" }));
  const widget = (await import(url)).default;
  const el = document.getElementById("cell");
  widget.render({ model, el });
  window.explorer = el.explorer;
  window.values = values;
"""


@pytest.mark.slow
def test_the_widget_front_end_draws_what_python_renders(browser):
    """anywidget's ``render({model, el})`` with a stand-in model whose messages reach the
    widget's Python handler: the widget draws the same sphere as render_sphere."""
    from _page import settled

    from brdfkit.brdf import parse
    from brdfkit.explore import Explorer
    from brdfkit.light import DirectionalLight
    from brdfkit.render import render_sphere

    widget = Explorer(SPEC)

    def handle(message):
        return [
            (header, [base64.b64encode(b).decode() for b in buffers])
            for header, buffers in widget.handle(message)
        ]

    def environment(message):  # the widget's passes, up to 2 spp, in the reply
        cancel, out = threading.Event(), []
        for header, buffers in widget.environment(message, cancel):
            out.append((header, [base64.b64encode(b).decode() for b in buffers]))
            if header["samples"] >= 2:
                cancel.set()
        return out

    context = browser.new_context(bypass_csp=True)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text))
    page.expose_function("pyHandle", handle)
    page.expose_function("pyEnv", environment)
    page.set_content('<div id="cell"></div>')
    page.evaluate(
        "([esm, config]) => { window.__esm = esm; window.__config = config; }",
        [widget._esm, widget.config],
    )
    page.add_script_tag(content=MOCK_HOST, type="module")
    try:
        settled(page)
    except Exception:
        raise AssertionError(errors) from None
    v = page.evaluate("window.explorer.state.view")
    light = DirectionalLight(direction=light_world(v["theta_i"], v["phi_i"]), irradiance=np.pi)
    expected = expected_pixels(render_sphere(parse(SPEC), light, resolution=v["resolution"]))
    shown = canvas_pixels(page, '.bx-sphere[data-id="b1"]')[..., :3].astype(np.int64)
    assert np.abs(shown - expected).max() <= 1
    assert json.loads(page.evaluate("window.values.state"))["entries"][0]["id"] == "b1"
    # the environment view: the widget's passes drawn as on the web page
    page.locator(".bx-envmap").check()
    page.wait_for_function("() => (window.explorer.env.b1 || {}).samples >= 2", timeout=120_000)
    values = np.asarray(page.evaluate("window.explorer.envImage('b1')"), np.float64)
    pixels = canvas_pixels(page, '.bx-env[data-id="b1"]')[..., :3].astype(np.int64)
    assert np.abs(pixels - expected_pixels(values.reshape(pixels.shape))).max() <= 1
    assert values.max() > 0
    assert "2 spp" in page.locator(".bx-env-box .bx-caption").first.inner_text()
    assert not errors
    context.close()
