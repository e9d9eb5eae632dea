"""The atlas's text: docstrings rendered as HTML (MathML formulas, footnoted citations,
parameter lists), with no reStructuredText left for the reader to decode."""

from __future__ import annotations

import re
from collections import Counter
from html.parser import HTMLParser

import pytest

from brdfkit.brdf import MODELS, parse
from brdfkit.plot import model_label
from brdfkit.report.atlas import Card, _docs_of, atlas_html, default_cards, docstring_html

RAW_MARKS = {
    "a role (:math:, :class:, …)": r":[\w:]+:`",
    "double backticks": r"``",
    "a citation or directive (.. [1], .. math::)": r"^\s*\.\. ",
    "a section underline": r"^\s*-{4,}\s*$",
}
"""reStructuredText a reader would see raw if the docstrings were printed as text."""


class _VisibleText(HTMLParser):
    """The text a browser shows: outside <script>, <style> and MathML's TeX annotations."""

    _HIDDEN = ("script", "style", "annotation")

    def __init__(self) -> None:
        super().__init__()
        self.depth = 0
        self.chunks: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.depth += tag in self._HIDDEN

    def handle_endtag(self, tag):
        self.depth -= tag in self._HIDDEN

    def handle_data(self, data):
        if not self.depth:
            self.chunks.append(data)


def visible_text(page: str) -> str:
    parser = _VisibleText()
    parser.feed(page)
    return "".join(parser.chunks)


def raw_marks(text: str) -> Counter:
    """How many of each kind of raw reStructuredText mark ``text`` shows."""
    return Counter({k: len(re.findall(p, text, re.M)) for k, p in RAW_MARKS.items()})


def _text_card(title: str, models) -> Card:
    """A card with its text only (no renders or checks): what the page's prose is made of."""
    return Card(title, list(models), [model_label(m) for m in models], docs=_docs_of(models[0]))


@pytest.fixture(scope="module")
def default_page() -> str:
    """The default atlas page, text only."""
    return atlas_html([_text_card(t, models) for t, models in default_cards()], "test")


def test_raw_mark_counter_sees_what_the_old_page_showed():
    shown = "Smith :math:`G_2` (``masking``)\n\nReferences\n----------\n.. [1] B. Walter\n"
    assert sum(raw_marks(shown).values()) == 5


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_model_docstring_renders_without_a_docutils_message(name):
    for _, doc in _docs_of(MODELS[name]()):
        fragment = docstring_html(doc, strict=True)  # raises on any docutils message
        assert raw_marks(visible_text(fragment)).total() == 0, fragment
        if "math" in doc:
            assert "<math" in fragment


def test_default_page_shows_no_raw_restructuredtext(default_page):
    assert raw_marks(visible_text(default_page)).total() == 0
    assert "problematic" not in default_page and "system-message" not in default_page


def test_default_page_formulas_are_mathml(default_page):
    cards = default_page.split('<section class="card"')[1:]
    assert len(cards) == len(default_cards())
    for card in cards:
        assert '<math xmlns="http://www.w3.org/1998/Math/MathML"' in card, card[:80]
    assert default_page.count('<math display="block"') + default_page.count('display="block"') > 8
    assert 'class="math"' not in default_page  # the TeX fallback of a formula MathML lacks


def test_citations_are_footnotes_and_parameters_a_definition_list(default_page):
    ggx = default_page[default_page.index('id="ggx"') :]
    ggx = ggx[: ggx.index("<p><b>Examples</b>")]
    assert len(re.findall(r'<aside class="footnote brackets"', ggx)) == 3
    assert "B. Walter et al., EGSR 2007." in visible_text(ggx)
    assert "<ol" not in ggx.split('class="rubric">References')[1]  # "B. Walter" is no list
    terms = [visible_text(term) for term in re.findall(r"<dt>(.*?)</dt>", ggx)]
    assert terms[:3] == ["alpha", "alpha_u, alpha_v", "distribution"]


def test_ids_are_unique_across_cards_and_lobes():
    cards = [_text_card("ggx", [parse("ggx")]), _text_card("mix", [parse("lambertian + ggx")])]
    page = atlas_html(cards, "test")
    ids = Counter(re.findall(r'\sid="([^"]+)"', page))
    assert [i for i, n in ids.items() if n > 1] == []
    assert "<h3>Lambertian</h3>" in page and "<h3>GGXConductor</h3>" in page


_TYPESET_PROBE = """<script>
window.addEventListener('load', function () {
  var fractions = document.querySelectorAll('mfrac'), stacked = 0;
  fractions.forEach(function (f) {
    var top = f.children[0].getBoundingClientRect(), bottom = f.children[1].getBoundingClientRect();
    if (top.bottom <= bottom.top + 1 && top.height > 0) stacked++;
  });
  document.body.setAttribute('data-fractions', fractions.length);
  document.body.setAttribute('data-fractions-stacked', stacked);
});
</script></body>"""
"""Counts the page's MathML fractions whose numerator the browser lays out above the
denominator: true typesetting, which a browser without MathML would not do."""


def test_formulas_are_typeset_by_headless_chromium(default_page, tmp_path, browser_dom):
    page = tmp_path / "atlas.html"
    page.write_text(default_page.replace("</body>", _TYPESET_PROBE), encoding="utf-8")
    dom = browser_dom(page.as_uri())
    body = re.search(r"<body([^>]*)>", dom).group(1)
    counts = {k: int(v) for k, v in re.findall(r'data-([a-z-]+)="(\d+)"', body)}
    assert counts["fractions"] > 10
    assert counts["fractions-stacked"] == counts["fractions"]
    assert raw_marks(visible_text(dom)).total() == 0
