"""Sphinx configuration of brdfkit's documentation.

Build: ``pip install -e ".[docs]"`` then ``sphinx-build -W --keep-going -b html docs <out>``.

Math. The site must work offline (CI and the tests have no internet), so no formula may need a
CDN. We use sphinxcontrib-katex (a maintained Sphinx extension around KaTeX, the fast LaTeX
renderer) with **server-side prerendering**: at build time each formula goes through the copy of
KaTeX that sphinxcontrib-katex itself ships (``katex.min.js``, run by ``node``), and the page gets
the finished formula; a reader's browser runs no script for it. We ask KaTeX for **MathML**
output, which every current browser (Chromium ≥ 109, Firefox, Safari) lays out natively, so the
site needs neither KaTeX's stylesheet nor its web fonts (the npm package would bring those; this
way the only extra tool is ``node``, and nothing is downloaded at build or view time). The other
options: MathJax from a CDN does not load offline; the PyPI packages that bundle MathJax for
offline use are unmaintained (last release 2022); ``imgmath`` needs a LaTeX installation; KaTeX
in the browser would have to typeset every page on every view.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS))  # _apidoc
if (ROOT / "src" / "brdfkit").is_dir():
    sys.path.insert(0, str(ROOT / "src"))

import _apidoc  # noqa: E402

import brdfkit  # noqa: E402

os.environ.setdefault("MPLBACKEND", "Agg")
# The examples write their README pictures to docs/images/ only when run as scripts; in the
# gallery build they just show them (a docs build never changes the source tree).
os.environ["BRDFKIT_DOCS_BUILD"] = "1"

project = "brdfkit"
author = "brdfkit developers"
copyright = "brdfkit developers"
release = version = brdfkit.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "sphinxcontrib.katex",
]

exclude_patterns = ["_build", "inverse_optics.md", "**/README.md", "node_modules"]
templates_path = ["_templates"]
root_doc = "index"

# --------------------------------------------------------------------------- API reference
_apidoc.write_pages(DOCS / "api")
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # numpydoc's parameter lists carry the types
autoclass_content = "class"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# Docstrings written as prose ("Returns the ...") are fine; numpydoc's validation is not run.
numpydoc_validation_checks: set[str] = set()
suppress_warnings = [
    # several docstrings cite the same paper as [1]; numpydoc renames them per object, but
    # the re-exported modules show a docstring twice (module page + object page)
    "ref.citation",
    "ref.footnote",
]

intersphinx_mapping = {}  # offline: no inventories are fetched

# --------------------------------------------------------------------------- math
katex_prerender = True
katex_css_path = "brdfkit.css"  # ours; MathML needs no KaTeX stylesheet (see above)
katex_options = ""


def _mathml_output() -> None:
    """Ask the prerenderer for MathML (sphinxcontrib-katex passes these options to KaTeX), and
    start it race-free."""
    import sphinxcontrib.katex as sk

    sk.KATEX_DEFAULT_OPTIONS = {**sk.KATEX_DEFAULT_OPTIONS, "output": "mathml"}
    # sphinxcontrib-katex 0.9 connects to its Unix socket as soon as the file exists, which can
    # be before node listens on it (ConnectionRefusedError on a loaded machine); its start over
    # a loopback TCP port retries until the server answers, so it is used on POSIX too.
    network = sk.KaTeXServer.start_network_socket.__func__
    sk.KaTeXServer.start_server_process = classmethod(network)
    if shutil.which(sk.NODEJS_BINARY) is None:
        raise RuntimeError("the docs prerender formulas with node (Node.js); install it first")


_mathml_output()

# --------------------------------------------------------------------------- gallery
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    # explore_screenshot.py serves a page: not a gallery script
    "ignore_pattern": r"__init__\.py|explore_screenshot\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib", "_figure_scraper"),
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": True,
    "show_memory": False,
    "min_reported_time": 1,
    # sphinx-gallery reruns only examples whose source changed; the tests rerun them all
    "run_stale_examples": os.environ.get("BRDFKIT_DOCS_RERUN_EXAMPLES") == "1",
}

# --------------------------------------------------------------------------- HTML
html_theme = "pydata_sphinx_theme"
html_title = "brdfkit"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "icon_links": [],
}
html_show_sourcelink = False
