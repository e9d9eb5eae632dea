"""The documentation site: the ``-W`` Sphinx build (gallery included) and a headless browser.

Needs the ``docs`` extra (``pip install -e ".[docs]"``) and ``node`` (formulas are prerendered
by KaTeX at build time); the browser test needs Debian's ``/usr/bin/chromium``.
"""

from __future__ import annotations

import functools
import http.server
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BUILD_TIMEOUT = 1200  # seconds; about six minutes on one core

for _module in ("sphinx", "numpydoc", "sphinx_gallery", "sphinxcontrib.katex"):
    pytest.importorskip(_module, reason=f"{_module} is not installed (pip install -e '.[docs]')")
pytest.importorskip("pydata_sphinx_theme", reason="the docs extra is not installed")
if shutil.which("node") is None:
    pytest.skip(
        "node is not installed: the docs prerender formulas with it", allow_module_level=True
    )


def _apidoc():
    spec = importlib.util.spec_from_file_location("_apidoc", DOCS / "_apidoc.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("docs_html")
    env = {**os.environ, "MPLBACKEND": "Agg", "BRDFKIT_DOCS_RERUN_EXAMPLES": "1"}  # run them all
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q", "-E", DOCS, out],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT,
    )
    assert proc.returncode == 0, f"sphinx-build -W failed:\n{proc.stderr[-6000:]}"
    return out


def test_build_passes_and_every_public_name_has_a_page(site):
    apidoc = _apidoc()
    modules = apidoc.public_modules()
    assert {"brdfkit.brdf", "brdfkit.measured", "brdfkit.vision.separation", "brdfkit.io"} <= set(
        modules
    )
    missing = []
    for (module, name), canonical in apidoc.canonical_map().items():
        page = site / "api" / "generated" / f"{canonical}.html"
        module_page = site / "api" / f"{module}.html"
        if not page.is_file():
            missing.append(f"{module}.{name}: no page {page.name}")
        elif f"generated/{canonical}.html" not in module_page.read_text(encoding="utf-8"):
            missing.append(f"{module}.{name}: {module_page.name} does not link {page.name}")
    assert not missing, "\n".join(missing)
    for page in ("index", "tutorials/radiometry", "tutorials/mitsuba", "auto_examples/index"):
        assert (site / f"{page}.html").is_file(), page
    # the formulas are prerendered to MathML: no LaTeX source left for a script to typeset
    text = (site / "tutorials" / "microfacets.html").read_text(encoding="utf-8")
    assert text.count("<math") > 10


# --------------------------------------------------------------------------- browser
CHECKER = """<!doctype html><meta charset="utf-8"><title>check</title>
<body><pre id="out">pending</pre>
<iframe id="f" style="width:1200px;height:2000px" src="%s"></iframe>
<script>
const frame = document.getElementById("f");
frame.addEventListener("load", async () => {
  const doc = frame.contentDocument;
  const sources = [...doc.images].map(img => img.src);
  const sizes = await Promise.all(sources.map(src => new Promise(done => {
    const probe = new Image();
    probe.onload = () => done(probe.naturalWidth);
    probe.onerror = () => done(0);
    probe.src = src;
  })));
  const text = doc.body.innerText;
  document.getElementById("out").textContent = "RESULT" + JSON.stringify({
    images: sources.map((src, i) => [src, sizes[i]]),
    math: doc.querySelectorAll("math").length,
    raw: ["$$", "\\\\(", "\\\\[", ":math:"].filter(s => text.includes(s)),
    title: doc.title,
  }) + "END";
});
</script>
"""


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def server(site):
    (site / "_check").mkdir(exist_ok=True)
    handler = functools.partial(_Quiet, directory=str(site))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield site, f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()


def _inspect(server, page: str, browser_dom) -> dict:
    site, base = server
    name = re.sub(r"\W", "_", page)
    (site / "_check" / f"{name}.html").write_text(CHECKER % f"/{page}", encoding="utf-8")
    dom = browser_dom(f"{base}/_check/{name}.html", budget_ms=20_000, timeout=120)
    found = re.search(r"RESULT(.*?)END", dom, re.S)
    assert found, f"chromium gave no result for {page}"
    return json.loads(found.group(1).replace("&amp;", "&").replace("&quot;", '"'))


@pytest.mark.parametrize(
    ("page", "min_images", "min_math"),
    [
        ("index.html", 2, 1),
        ("auto_examples/plot_roughness_gold.html", 1, 0),
        ("tutorials/microfacets.html", 0, 10),
    ],
)
def test_pages_in_a_browser(server, browser_dom, page, min_images, min_math):
    result = _inspect(server, page, browser_dom)
    assert result["title"], result
    broken = [src for src, width in result["images"] if width <= 0]
    assert not broken, f"images that did not load on {page}: {broken}"
    assert len(result["images"]) >= min_images, result
    assert result["math"] >= min_math, result
    assert not result["raw"], f"untypeset math on {page}: {result['raw']}"
