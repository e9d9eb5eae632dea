"""The reflectance atlas: one self-contained HTML page with a card per model.

Each card shows the model's docstring typeset by docutils (its formulas as MathML, parameters
and citations), a row of spheres across its example parameters under a directional light and
under an environment map, optionally (``objects``) the representative example on a bundled
object under the map with shadows (:func:`object_image`), a lobe plot, the directional albedo
curves, and the physics checks (reciprocity, energy, isotropy, sampling) as pass/fail with
their numbers, set against what the model claims. Images are embedded as base64 PNG and
browsers draw MathML natively, so the page opens from disk with no server, script or network.

References
----------
.. [1] B. Burley et al., Disney BRDF Explorer, 2012.
.. [2] W. Matusik et al., "A data-driven reflectance model", SIGGRAPH 2003 (sphere galleries).
"""

from __future__ import annotations

import base64
import functools
import html
import inspect
import io
import math
import re
import textwrap
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from brdfkit.brdf.base import BRDF, MODELS, Scaled, Sum

DEFAULT_MODELS = (
    "lambertian",
    "oren_nayar",
    "phong",
    "modified_phong",
    "blinn_phong",
    "lafortune",
    "ward",
    "torrance_sparrow",
    "cook_torrance",
    "ggx",
    "beckmann",
    "rough_dielectric",
    "mirror",
    "smooth_dielectric",
    "principled",
    "plastic",
    "rough_plastic",
    "charlie",
    "lommel_seeliger",
    "minnaert",
    "hapke",
    "kulla_conty",
    "kulla_conty_dielectric",
    "thin_film",
    "ashikhmin_shirley",
)
"""The models of the default atlas, in the order of the lectures (those registered are shown)."""


@dataclass
class Card:
    """One model's section of the atlas."""

    title: str
    models: list[BRDF]
    labels: list[str]
    docs: list[tuple[str, str]] = field(default_factory=list)  # (heading, docstring) per lobe
    images: dict[str, str] = field(default_factory=dict)  # caption -> base64 PNG
    checks: list[dict] = field(default_factory=list)
    consistent: bool = True
    # spp of each environment-lit sphere, or what its quadrature spent ("quadrature, N nodes")
    env_samples: list[int | str] = field(default_factory=list)
    cpu_seconds: dict[str, float] = field(default_factory=dict)  # CPU seconds of each part
    env_cpu_seconds: list[float] = field(default_factory=list)  # of each environment-lit sphere
    docs_html: str | None = None  # the docstrings typeset (:func:`_docs_html`), once made


_LAYOUTS: dict[tuple, list[tuple[float, float, float, float]]] = {}
"""The axes positions (figure fractions) constrained layout gave the first plot of each
``layout`` key :func:`_png` was handed, in this process."""


def _png(fig, layout: tuple | None = None) -> str:
    """``fig`` as a base64 PNG at 100 dpi.

    ``layout``: a key naming everything the figure's constrained layout depends on besides
    its data (the kind of plot, the axis limits that set its tick labels, its legend's
    labels). The first figure of a key is laid out as usual and its axes positions kept; the
    next get them and no layout engine, so that their savefig skips the layout's own draw
    (about 45 % of a savefig) and draws once: the same pixels, as the layout is a function
    of the key alone.
    """
    positions = None if layout is None else _LAYOUTS.get(layout)
    if positions is not None:
        for ax, bounds in zip(fig.axes, positions, strict=True):
            ax.set_position(bounds)
        _drop_layout_engine(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    if layout is not None and positions is None:
        _LAYOUTS[layout] = [ax.get_position(original=True).bounds for ax in fig.axes]
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _drop_layout_engine(fig) -> None:
    """Leave ``fig`` with no layout engine at all, so that ``savefig`` draws it once.

    ``set_layout_engine("none")`` on a figure that had one installs a
    ``PlaceHolderLayoutEngine``, and ``savefig`` draws any figure whose engine is not
    ``None`` twice: once (to a renderer with drawing disabled, but through every artist's
    layout of text and ticks) for the engine, then for the pixels. ``None`` is what the
    engine becomes only where the rc parameters name no automatic layout, so they are held
    off while it is set."""
    import matplotlib

    with matplotlib.rc_context(
        {"figure.autolayout": False, "figure.constrained_layout.use": False}
    ):
        fig.set_layout_engine(None)


def _image_png(image: np.ndarray) -> str:
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _docs_of(model: BRDF) -> list[tuple[str, str]]:
    """(heading, docstring) of each lobe of ``model``: one entry with no heading for a single
    model, one per lobe (headed by its class name) for a sum; factors are looked through."""
    target = model
    while isinstance(target, Scaled):
        target = target.inner
    if isinstance(target, Sum):
        return [(type(lobe).__name__, doc) for lobe in target.lobes for _, doc in _docs_of(lobe)]
    # A convenience subclass (``ggx`` of ``RoughConductor``) adds its parent's formula and
    # references to its own short docstring.
    docs = [inspect.cleandoc(cls.__doc__ or "") for cls in type(target).__mro__[:2]]
    own = docs[0]
    if "References" not in own and len(docs) > 1 and "References" in docs[1]:
        return [("", own + "\n\n" + docs[1])]
    return [("", own)]


_SECTION = re.compile(r"^([A-Z][A-Za-z ]*)\n-{3,}[ \t]*$", re.M)
"""A numpydoc section header: its name, underlined by dashes."""
_ITEM_SECTIONS = ("Parameters", "Other Parameters", "Attributes", "Returns", "Yields", "Raises")
"""numpydoc sections whose entries are ``name : description`` items."""
_ITEM = re.compile(r"^(\S.*?) : ?(.*)$")
"""The first line of a numpydoc item, ``names : description`` (or ``names : type``)."""
_SPHINX_ROLE = re.compile(r":(?:py:)?(?:class|func|data|meth|attr|mod|obj|exc|const):`([^`]+)`")
"""A role of Sphinx's Python domain, which docutils alone does not know."""
_INITIAL = re.compile(r"^(\.\. \[[^\]]+\][ \t]+)([A-Z])\.(?=\s)", re.M)
"""A citation starting with an initial ("B. Walter"), which docutils reads as a list item."""


def _literal_role(match: re.Match) -> str:
    """A Sphinx cross-reference as an inline literal of the name it shows (``~`` keeps the
    last component; an explicit title ``text <target>`` is kept as the text)."""
    text = match.group(1)
    titled = re.fullmatch(r"(.*?)\s*<[^>]*>", text)
    if titled:
        return f"``{titled.group(1)}``"
    if text.startswith("~"):
        text = text[1:].rsplit(".", 1)[-1]
    return f"``{text}``"


def _items_rest(body: str) -> str:
    """numpydoc ``name : description`` items as a reStructuredText definition list; lines
    outside any item (``All broadcast against …``) stay paragraphs."""
    items: list[tuple[str | None, list[str]]] = []  # (term or None for a paragraph, lines)
    for line in body.splitlines():
        header = _ITEM.match(line)
        if header:
            names = ", ".join(f"``{name.strip()}``" for name in header.group(1).split(","))
            items.append((names, [header.group(2)]))
        elif items and (not line.strip() or line[:1].isspace() or items[-1][0] is None):
            items[-1][1].append(line)
        else:
            items.append((None, [line]))
    out = []
    for term, lines in items:
        if term is None:
            out.append("\n".join(lines))
            continue
        rest = textwrap.dedent("\n".join(lines[1:])).splitlines()
        text = "\n".join([lines[0].strip(), *rest]).strip() or "—"
        out.append(term + "\n" + textwrap.indent(text, "    "))
    return "\n\n".join(out)


def _numpydoc_rest(doc: str) -> str:
    """A numpydoc docstring as plain reStructuredText that docutils renders alone: section
    headers as rubrics, parameter items as definition lists, Sphinx roles as literals."""
    doc = _INITIAL.sub(r"\1\2\\.", _SPHINX_ROLE.sub(_literal_role, doc))
    pieces = _SECTION.split(doc)
    parts = [pieces[0]]
    for name, body in zip(pieces[1::2], pieces[2::2], strict=True):
        body = _items_rest(body) if name in _ITEM_SECTIONS else body
        parts.append(f"\n.. rubric:: {name}\n\n{body.strip()}\n")
    return "\n".join(parts)


def docstring_html(doc: str, *, id_prefix: str = "", strict: bool = False) -> str:
    """A model's numpydoc docstring as an HTML fragment: formulas as MathML (native in
    browsers, so the page needs no script or network), citations as footnotes, parameter
    lists as definition lists.

    Parameters
    ----------
    doc : the docstring (cleaned of its indentation).
    id_prefix : prefix of the fragment's element ids, so that several fragments (one per
        card) can share a page.
    strict : raise on any docutils message (malformed markup, a formula MathML cannot
        typeset) instead of leaving the markup out of the page.

    Raises
    ------
    docutils.utils.SystemMessage
        With ``strict``, on the first message docutils reports.

    Examples
    --------
    >>> fragment = docstring_html("The albedo :math:`ρ` of the surface.")
    >>> fragment.startswith("<p>The albedo <math"), "<mi>ρ</mi>" in fragment
    (True, True)
    """
    from docutils.core import publish_parts
    from docutils.writers.html5_polyglot import Writer

    settings = {
        "math_output": "MathML",
        "id_prefix": id_prefix,
        "doctitle_xform": False,
        "report_level": 1 if strict else 5,
        "halt_level": 1 if strict else 5,
        "warning_stream": False,
        "input_encoding": "unicode",
    }
    parts = publish_parts(_numpydoc_rest(doc), writer=Writer(), settings_overrides=settings)
    return parts["body"]


ENV_NOISE = None
"""The default goal for a Monte Carlo sphere under the environment map, its estimated
relative RMSE against a 16×-spp render of itself (:func:`env_sphere`): none, ``samples`` spp.
A goal of 1 % (``brdfkit atlas --noise 0.01``) takes 64–1024 spp on the glossy spheres, many
times the default's work (``benchmarks/bench_atlas.py``). Spheres the quadrature renders
(:mod:`brdfkit.render.environment_quadrature`) meet ``noise``, or else its own 1 % goal, without
noise."""
ENV_MAX_SAMPLES = 2048
"""The most samples per pixel :func:`env_sphere` spends on one sphere by default."""
_MARGIN = 0.8
""":func:`env_sphere` stops once its noise estimate is this fraction of the goal: room for
the estimate's own error (a mean over the pixels of one replicate difference)."""


def env_sphere(
    model: BRDF,
    light,
    resolution: int = 96,
    *,
    samples: int = 32,
    noise: float | None = ENV_NOISE,
    max_samples: int = ENV_MAX_SAMPLES,
    seed: int = 0,
    quadrature: bool = True,
) -> tuple[np.ndarray, int | str]:
    r"""A sphere rendered progressively (:func:`brdfkit.render.progressive_sphere`) from
    ``samples`` spp, doubling, until its estimated relative RMSE against a 16×-spp render of
    itself is at most ``noise`` (``None``: ``samples`` spp, one pass), or ``max_samples``.

    With Sobol' points each pass carries two independent replicates A and B of every pixel's
    sequence, and ``Pass.error`` :math:`|A - B|/2` squared estimates the variance of the running
    mean :math:`M = (A + B)/2` without bias (:math:`E[(A - B)^2]/4 = (\operatorname{Var}A +
    \operatorname{Var}B)/4`); the per-sample spread, ``Pass.stderr``, over-estimates Sobol's
    error several times and is used only without replicates. Over the sphere's interior
    (:func:`~brdfkit.render.scene.interior_mask`) the estimate is
    :math:`\hat e = \sqrt{(1 + 1/16)\,\overline{e^2} / \overline{M^2}}`, the 1/16 for the
    reference's own noise; it stops once :math:`\hat e` is at most
    :data:`_MARGIN` × ``noise``. A sphere without Monte Carlo (Lambertian lobes:
    zero ``stderr``) stops after its first pass; a model with delta lobes is first rendered at 2
    spp (one sample per replicate), which is its image where the two agree exactly (a mirror,
    a smooth dielectric: every sample finds the same delta direction, and the map's samples
    add nothing), 12× less work than 32 spp for the same values to rounding. The compiled
    kernels render it where they apply and are built already (in this process or in
    :mod:`brdfkit.compiled.cache`), or where the most work it may take is worth their build
    (:data:`~brdfkit.render.compiled_shading.AUTO_COMPILE_WORK`; built once per machine, as
    :mod:`brdfkit.compiled.cache` keeps them). With ``quadrature`` (default), a model
    :func:`~brdfkit.render.quadrature_sphere` applies to is rendered by it instead,
    noise-free, to an estimated relative RMSE of ``noise`` (``None``:
    :data:`~brdfkit.render.environment_quadrature.GOAL`). Returns the linear image and the samples
    per pixel spent (the quadrature: ``"quadrature, N nodes"``, its BRDF evaluations)."""
    from brdfkit.light.environment import EnvironmentMap
    from brdfkit.render.compiled_shading import AUTO_COMPILE_WORK, compiled_shader
    from brdfkit.render.environment_quadrature import GOAL, quadrature_sphere, split_quadrature
    from brdfkit.render.passes import progressive_sphere
    from brdfkit.render.scene import interior_mask

    if quadrature and isinstance(light, EnvironmentMap):
        try:
            split_quadrature(model)
        except ValueError:
            pass
        else:
            q = quadrature_sphere(model, light, resolution, goal=GOAL if noise is None else noise)
            return q.image, f"quadrature, {q.nodes} nodes"
    mask = interior_mask(resolution)
    limit = samples if noise is None else max(samples, max_samples)
    # built (in this process or on disk) kernels serve any sphere; building them, only a big one
    built = compiled_shader(model, [light], method="auto", build=False) is not None
    compiled = built or math.pi / 4 * resolution**2 * limit >= AUTO_COMPILE_WORK
    if model.has_delta and samples > 2:
        # a mirror's or a smooth dielectric's estimate need not depend on its samples: where
        # one sample of each replicate already agrees exactly, that pass is the image
        probe = next(
            progressive_sphere(
                model, light, resolution, first_samples=2, max_samples=2, seed=seed,
                compiled=compiled,
            )
        )  # fmt: skip
        if not np.any(probe.stderr[mask]):
            return probe.image, probe.samples
    for shaded in progressive_sphere(
        model, light, resolution, first_samples=samples, max_samples=limit, seed=seed,
        compiled=compiled,
    ):  # fmt: skip
        if noise is None or not np.any(shaded.stderr[mask]):
            break
        error = shaded.stderr if shaded.error is None else shaded.error
        error2 = np.mean(error[mask] ** 2) * (1 + 1 / 16)
        if error2 <= (_MARGIN * noise) ** 2 * np.mean(shaded.image[mask] ** 2):
            break
    return shaded.image, shaded.samples


OBJECT_MESH = "shaderball"
"""The bundled mesh of the cards' object images (:mod:`brdfkit.render.bundled_meshes`)."""

OBJECT_CAMERA = ((1.6, 2.1, 2.8), (0.0, 0.6, 0.0), (0.0, 1.0, 0.0))
"""The object image's look-at camera (origin, target, up) in Mitsuba's frame, 40° wide."""

OBJECT_SAMPLES = 4
"""Samples per pixel of a card's object image."""


def object_image(
    model: BRDF, envmap, resolution: int = 96, samples: int = OBJECT_SAMPLES
) -> np.ndarray:
    """``model`` on the bundled :data:`OBJECT_MESH` over its ground, under ``envmap`` in
    Mitsuba's frame with shadows (:func:`brdfkit.render.mesh.render_mesh`, ``samples`` spp,
    seed 0), seen by :data:`OBJECT_CAMERA`: linear ``(R, R, C)``.

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.light import EnvironmentMap
    >>> image = object_image(Lambertian(rho=0.5), EnvironmentMap(np.ones((8, 16, 1))), 8, 2)
    >>> image.shape, bool(0 < image.mean() < 0.5)  # ρ = 0.5 where nothing occludes the sky
    ((8, 8, 1), True)
    """
    from brdfkit.render.bundled_meshes import bundled_scene
    from brdfkit.render.mesh import render_mesh
    from brdfkit.render.mitsuba_frame import look_at_camera, mitsuba_oriented

    camera = look_at_camera(*OBJECT_CAMERA, fov=40.0, size=(resolution, resolution))
    scene = bundled_scene(OBJECT_MESH)
    return render_mesh(scene, model, mitsuba_oriented(envmap), camera, resolution, samples=samples)


def _sphere_row(images: Sequence[np.ndarray], resolution: int) -> np.ndarray:
    from brdfkit.plot import encode_spheres

    gap = np.zeros((resolution, 4, 3), np.uint8)
    tiles = []
    for image in encode_spheres(images):
        tiles += [image, gap]
    return np.concatenate(tiles[:-1], axis=1)


def build_card(
    title: str,
    models: Sequence[BRDF],
    *,
    envmap,
    labels: Sequence[str] | None = None,
    resolution: int = 96,
    samples: int = 32,
    noise: float | None = ENV_NOISE,
    max_samples: int = ENV_MAX_SAMPLES,
    run_checks: bool = True,
    objects: bool = False,
) -> Card:
    """Render and measure one model family (its example instances) into a :class:`Card`:
    spheres under a directional light at ``samples`` spp, under ``envmap`` by
    :func:`env_sphere` (``samples``, ``noise``, ``max_samples``), with ``objects`` the
    representative example on an object (:func:`object_image`); the CPU seconds of each part
    go to ``cpu_seconds`` (and of each environment-lit sphere to ``env_cpu_seconds``)."""
    from brdfkit.checks.properties import check
    from brdfkit.light.analytic import DirectionalLight
    from brdfkit.plot import albedo_plot, lobe_plot, model_label
    from brdfkit.render.shading import render_sphere

    models = list(models)
    labels = list(labels) if labels is not None else [model_label(m) for m in models]
    card = Card(title, models, labels, docs=_docs_of(models[0]))
    clock = time.process_time()

    def lap(part: str) -> None:
        nonlocal clock
        card.cpu_seconds[part] = time.process_time() - clock
        clock += card.cpu_seconds[part]

    sun = DirectionalLight((1.0, 0.6, 0.8), 3.0)
    lit = [render_sphere(m, sun, resolution, samples=samples) for m in models]
    card.images["spheres under a directional light"] = _image_png(_sphere_row(lit, resolution))
    lap("directional spheres")
    spheres = []
    for m in models:
        start = time.process_time()
        spheres.append(
            env_sphere(m, envmap, resolution, samples=samples, noise=noise, max_samples=max_samples)
        )
        card.env_cpu_seconds.append(time.process_time() - start)
    card.env_samples = [spp for _, spp in spheres]
    card.images["spheres under the environment map"] = _image_png(
        _sphere_row([image for image, _ in spheres], resolution)
    )
    lap("environment spheres")
    representative = models[len(models) // 2]
    if objects:
        image = object_image(representative, envmap, resolution)
        caption = f"{OBJECT_MESH} under the environment map, shadows ({OBJECT_SAMPLES} spp)"
        card.images[caption] = _image_png(_sphere_row([image], resolution))
        lap("object")
    # the lobe plot's decorations are fixed (no radial tick labels); the albedo plot's y
    # tick labels follow its y limits
    card.images["lobe (plane of incidence)"] = _png(
        lobe_plot(representative, [math.radians(a) for a in (0, 30, 60)]), layout=("lobe",)
    )
    lap("lobe plot")
    names = [f"#{i + 1}" for i in range(len(models))]
    figure = albedo_plot(models, labels=names, samples=1024, angles=16)
    ax = figure.axes[0]
    card.images["directional albedo"] = _png(
        figure, layout=("albedo", ax.get_xlim(), ax.get_ylim(), *names)
    )
    lap("albedo plot")
    if run_checks:
        report = check(representative)
        card.checks = [r.to_dict() for r in report.results]
        card.consistent = report.consistent
        lap("checks")
    return card


def _registered_defaults() -> list[str]:
    """The names of :data:`DEFAULT_MODELS` that are registered: the default atlas's cards."""
    return [name for name in DEFAULT_MODELS if name in MODELS]


def default_examples(name: str) -> list[BRDF]:
    """The example instances of the default card of the registered model ``name``.

    Examples
    --------
    >>> [type(model).__name__ for model in default_examples("lambertian")]
    ['Lambertian', 'Lambertian', 'Lambertian', 'Lambertian']
    """
    return MODELS[name].examples()[:4]


def default_cards(models: Sequence[str | BRDF] | None = None) -> list[tuple[str, list[BRDF]]]:
    """Titles and example instances: every registered default model, or the given specs/files.

    Examples
    --------
    >>> [(title, len(examples)) for title, examples in default_cards(["ggx(alpha=0.2)"])]
    [('ggx(alpha=0.2)', 1)]
    """
    from brdfkit.interop.load import is_file_source, load

    if not models:
        return [(name, default_examples(name)) for name in _registered_defaults()]
    cards = []
    for item in models:
        if isinstance(item, BRDF):
            cards.append((item.to_spec(), [item]))
        else:
            cards.append((Path(item).name if is_file_source(item) else item, [load(item)]))
    return cards


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;margin:2rem auto;max-width:1150px;
color:#222;background:#fafafa}
h1{margin-bottom:.2rem} .sub{color:#666;margin-top:0}
.card,.subsurface{background:#fff;border:1px solid #ddd;border-radius:10px;
padding:1rem 1.4rem;margin:1.4rem 0;box-shadow:0 1px 3px rgba(0,0,0,.06)}
.card h2,.subsurface h2{margin:.2rem 0 .6rem;font-family:ui-monospace,monospace}
.row{display:flex;flex-wrap:wrap;gap:1rem;align-items:flex-start}
figure{margin:0} figcaption{font-size:.8rem;color:#666}
pre{white-space:pre-wrap;font-size:.82rem;background:#f4f4f4;padding:.6rem;border-radius:6px}
table{border-collapse:collapse;font-size:.85rem}
td,th{border-bottom:1px solid #eee;padding:.25rem .6rem;text-align:left}
.pass{color:#0a7a2f;font-weight:600} .fail{color:#b00020;font-weight:600}
.claim{color:#555} code{font-size:.82rem}
.doc{line-height:1.45} .doc h3{margin:.8rem 0 .2rem;font-size:1rem}
.doc p.rubric{font-weight:600;margin:.9rem 0 .3rem}
.doc dl{display:grid;grid-template-columns:max-content 1fr;gap:.2rem 1rem;margin:.2rem 0}
.doc dd{margin:0} .doc dd p{margin:0}
.doc math[display=block]{margin:.6rem 0;font-size:1.15em}
.doc .literal{font-family:ui-monospace,monospace;font-size:.85em;background:#f4f4f4;
padding:0 .2em;border-radius:3px}
.doc aside.footnote{display:flex;gap:.5rem;font-size:.88rem}
.doc aside.footnote p{margin:.1rem 0} .doc a.brackets{font-size:.8em;vertical-align:super}
"""

_SCRIPT = """
window.addEventListener('load', function () {
  var imgs = document.querySelectorAll('img'), ok = 0;
  imgs.forEach(function (im) { if (im.complete && im.naturalWidth > 0) ok++; });
  document.body.setAttribute('data-images', imgs.length);
  document.body.setAttribute('data-images-ok', ok);
  document.body.setAttribute('data-cards', document.querySelectorAll('.card').length);
});
"""


def _img(data: str, caption: str) -> str:
    return (
        f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
    )


def _docs_html(card: Card) -> str:
    """The card's docstrings as HTML, each lobe's under its heading (element ids prefixed by
    the card's title, so that the cards' footnotes do not collide); kept in
    ``card.docs_html``, where :func:`_build_cards` has them typeset already."""
    if card.docs_html is None:
        card.docs_html = _typeset_docs(card)
    return card.docs_html


def _typeset_docs(card: Card) -> str:
    slug = re.sub(r"\W+", "-", card.title).strip("-")
    parts = ['<div class="doc">']
    for i, (heading, doc) in enumerate(card.docs):
        if heading:
            parts.append(f"<h3>{html.escape(heading)}</h3>")
        parts.append(docstring_html(doc, id_prefix=f"{slug}-{i}-"))
    parts.append("</div>")
    return "\n".join(parts)


def card_html(card: Card) -> str:
    """The HTML of one card."""
    parts = [
        f'<section class="card" id="{html.escape(card.title)}"><h2>{html.escape(card.title)}</h2>'
    ]
    parts.append(_docs_html(card))
    parts.append("<p><b>Examples</b> (left to right)</p><ol>")
    parts.extend(f"<li><code>{html.escape(label)}</code></li>" for label in card.labels)
    parts.append("</ol>")
    if card.env_samples:
        spent = "; ".join(
            f"Monte Carlo, {n} spp" if isinstance(n, int) else n for n in card.env_samples
        )
        parts.append(f"<p class='claim'>Spheres under the environment map: {spent}</p>")
    parts.append('<div class="row">')
    parts.extend(_img(data, caption) for caption, data in card.images.items())
    parts.append("</div>")
    if card.checks:
        verdict = "consistent with its claims" if card.consistent else "CONTRADICTS a claim"
        parts.append(
            f"<p><b>Physics checks</b> on example #{len(card.models) // 2 + 1}: {verdict}</p>"
        )
        parts.append(
            "<table><tr><th>check</th><th>result</th><th>value</th><th>tolerance</th>"
            "<th>claimed</th><th>detail</th></tr>"
        )
        for c in card.checks:
            css = "pass" if c["passed"] else "fail"
            claimed = "—" if c.get("claimed") is None else ("yes" if c["claimed"] else "no")
            value = "—" if c.get("value") is None else f"{c['value']:.3g}"
            tol = "—" if c.get("tolerance") is None else f"{c['tolerance']:.3g}"
            parts.append(
                f'<tr><td>{html.escape(c["name"])}</td><td class="{css}">'
                f"{'pass' if c['passed'] else 'fail'}</td><td>{value}</td><td>{tol}</td>"
                f'<td class="claim">{claimed}</td>'
                f"<td>{html.escape(str(c.get('detail', '')))}</td></tr>"
            )
        parts.append("</table>")
    parts.append("</section>")
    return "\n".join(parts)


def atlas_html(
    cards: Sequence[Card], envmap_name: str, sections: Sequence[tuple[str, str]] = ()
) -> str:
    """The whole page; ``sections`` (title, HTML) follow the cards."""
    import brdfkit

    titles = [c.title for c in cards] + [title for title, _ in sections]
    toc = " · ".join(f'<a href="#{html.escape(t)}">{html.escape(t)}</a>' for t in titles)
    body = "\n".join([card_html(c) for c in cards] + [part for _, part in sections])
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>brdfkit atlas</title><style>{_CSS}</style><script>{_SCRIPT}</script></head><body>"
        f"<h1>brdfkit reflectance atlas</h1><p class='sub'>brdfkit {brdfkit.__version__} · "
        f"{len(cards)} models · spheres lit by a directional light and by "
        f"{html.escape(envmap_name)}"
        f"</p><p>{toc}</p>{body}</body></html>"
    )


_CARD_CPU_SECONDS = {
    "rough_dielectric": 3.9, "kulla_conty_dielectric": 2.7, "thin_film": 2.1,
    "torrance_sparrow": 1.7, "rough_plastic": 1.4, "ashikhmin_shirley": 1.3, "beckmann": 1.2,
}  # fmt: skip
"""The expected cost, in CPU seconds, of the heaviest default cards, the construction of their
examples included (as ``benchmarks/bench_atlas.py --profile`` reports it with a warm kernel
cache); a card not listed counts 1. Only the order in which :func:`_build_cards` hands cards to
its workers depends on it."""


_Examples = Sequence[BRDF] | Callable[[], Sequence[BRDF]]
"""A card's example instances, or what makes them (in the worker that builds the card)."""


def _card(title: str, examples: _Examples, options: dict) -> Card:
    """:func:`build_card` of ``examples``, made first where they are a callable: the default
    models' examples take seconds to construct (``kulla_conty_dielectric`` and
    ``rough_plastic`` tabulate albedos), work the workers share instead of the parent doing
    it alone before they start."""
    return build_card(title, examples() if callable(examples) else examples, **options)


_WORKER_OPTIONS: dict | None = None
""":func:`build_card`'s options in an atlas worker process, set once as it starts
(:func:`_start_worker`)."""


def _start_worker(options: dict) -> None:
    """Keep ``options`` for the cards this worker process builds (:func:`_worker_card`), hold
    its BLAS to one thread for its life (:func:`_one_blas_thread`) and have it reuse the
    memory it frees (:func:`_keep_freed_memory`)."""
    global _WORKER_OPTIONS
    _WORKER_OPTIONS = options
    _one_blas_thread()
    _keep_freed_memory()


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
"""glibc's ``mallopt`` parameters (``malloc.h``)."""


def _keep_freed_memory() -> None:
    """Have glibc's malloc serve blocks up to 32 MiB from its heap and keep up to 1 GiB of
    freed memory, in this process (an atlas worker, which lives for one atlas).

    A card's NumPy temporaries are megabytes (10⁵ samples × 3 in the checks, a quadrature
    ring's nodes), many above malloc's threshold for ``mmap``: each would be mapped afresh and
    its pages zeroed by the kernel on first touch, then unmapped when freed. Kept instead, they
    are reused, which saves most of the workers' system time. Nothing is changed where the C
    library is not glibc (no ``mallopt``)."""
    import ctypes
    import ctypes.util

    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c")).mallopt
    except (OSError, AttributeError, TypeError):
        return
    mallopt(_M_MMAP_THRESHOLD, 1 << 25)
    mallopt(_M_TRIM_THRESHOLD, 1 << 30)


def _one_blas_thread():
    """Limit the BLAS (OpenBLAS, MKL) of this process to one thread; returns threadpoolctl's
    limiter, whose ``restore_original_limits()`` (or ``with``) undoes it.

    The atlas's work is one process per core already, and its matrix products are narrow
    (``(n, 3) @ (3, m)``: the irradiance table's 18 k normals against 4.6 k cells, a map's
    rotation): BLAS threads gain nothing there, and on a busy machine their spin-waiting
    multiplies the time. The products split their outputs, not their sums, between threads:
    the same floats either way."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1, user_api="blas")


def _worker_card(title: str, examples: _Examples) -> Card:
    """:func:`_card` in an atlas worker, with the options it started with: they reach it once,
    inherited by the fork, not pickled with every card, so that its cards share one map object
    (its irradiance table, and :mod:`~brdfkit.render.environment_quadrature`'s cell averages of
    it, cached per map object)."""
    if _WORKER_OPTIONS is None:
        raise RuntimeError("_worker_card runs in a worker started by _start_worker")
    return _card(title, examples, _WORKER_OPTIONS)


def _heaviest_first(entries: Sequence[tuple[str, _Examples]]) -> list[int]:
    """Indices of ``entries`` in decreasing expected cost (:data:`_CARD_CPU_SECONDS`; a card
    not listed, 1 s), ties in their order: the longest-processing-time-first schedule, so that
    the last card a worker takes is a short one and the workers finish together."""
    return sorted(range(len(entries)), key=lambda k: -_CARD_CPU_SECONDS.get(entries[k][0], 1.0))


_CARD_MODULES = (
    "matplotlib.backends.backend_agg",
    "matplotlib.projections.polar",
    "PIL.PngImagePlugin",
    "scipy.stats",
)
"""The modules every card imports (its plots, its PNGs, its χ² tests and Sobol' points), whose
import costs more than a typical card's own work."""


def _import_card_modules() -> None:
    """Import :data:`_CARD_MODULES` in the process that forks the atlas's workers, so that
    they inherit them: imported once, not once in every worker."""
    import importlib

    for name in _CARD_MODULES:
        importlib.import_module(name)


def _build_cards(
    entries: Sequence[tuple[str, _Examples]],
    options: dict,
    progress: Callable[[str, int, int], None] | None,
) -> list[Card]:
    """:func:`_card` for every entry, on as many processes as this process has cores
    (cards are independent; NumPy work runs on one core at a time), handed out heaviest first
    (:func:`_heaviest_first`); returned in their order."""
    import multiprocessing
    import os
    import threading

    workers = min(len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1,
                  len(entries))  # fmt: skip
    # forked workers (no re-import, no __main__ guard needed), only from a single-threaded
    # process: a fork copies no other thread, and a lock one of them held would stay locked
    fork = "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1
    if workers <= 1 or not fork:
        cards = []
        for done, (title, examples) in enumerate(entries):
            if progress is not None:
                progress(title, done, len(entries))
            cards.append(_card(title, examples, options))
        return cards
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # the imports (Python, under the GIL) beside the table's NumPy loops (which release it);
    # both done before the fork, which copies no other thread
    importer = threading.Thread(target=_import_card_modules, name="atlas imports")
    importer.start()
    _ = options["envmap"].irradiance_table  # built once here, inherited by the workers
    importer.join()
    if options.get("objects"):  # the mesh made once here (NumPy); each worker builds its rays
        from brdfkit.render.bundled_meshes import bundled_scene

        bundled_scene(OBJECT_MESH)
    context = multiprocessing.get_context("fork")
    results: dict[int, Card] = {}
    with ProcessPoolExecutor(
        workers, mp_context=context, initializer=_start_worker, initargs=(options,)
    ) as pool:
        order = _heaviest_first(entries)
        futures = {pool.submit(_worker_card, *entries[k]): k for k in order}
        if progress is not None:
            progress(entries[order[0]][0], 0, len(entries))
        for future in as_completed(futures):
            k = futures[future]
            results[k] = future.result()
            # typeset here, in the parent (docutils beside Sphinx in a docs build needs it
            # there), while the workers build the other cards: not after the last one
            _docs_html(results[k])
            if progress is not None:
                progress(entries[k][0], len(results), len(entries))
    return [results[k] for k in range(len(entries))]


def _subsurface_html() -> str:
    """The default atlas's last section: :mod:`brdfkit.report.subsurface`'s spheres."""
    from brdfkit.report import subsurface

    title = html.escape(subsurface.TITLE)
    image = _img(_image_png(subsurface.subsurface_spheres_row()), subsurface.CAPTION)
    return (
        f'<section class="subsurface" id="{title}"><h2>{title}</h2>'
        f"<p>{html.escape(subsurface.SUMMARY)}</p>{image}</section>"
    )


def build_atlas(
    output: Path,
    models: Sequence[str | BRDF] | None = None,
    envmap: str | Path | None = None,
    *,
    resolution: int = 96,
    samples: int = 32,
    noise: float | None = ENV_NOISE,
    max_samples: int = ENV_MAX_SAMPLES,
    run_checks: bool = True,
    objects: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
) -> Path:
    """Write the atlas to ``output`` (an ``.html`` file), atomically; return its path
    (options as :func:`build_card`)."""
    from brdfkit.data import default_envmap_path
    from brdfkit.io import atomic_write
    from brdfkit.light.environment import EnvironmentMap
    from brdfkit.report import subsurface

    envmap_path = Path(envmap) if envmap is not None else default_envmap_path()
    # one BLAS thread: the map's sampling weights and irradiance table, the workers it forks
    with _one_blas_thread():
        light = EnvironmentMap.from_file(envmap_path)
        entries: Sequence[tuple[str, _Examples]] = (
            default_cards(models)
            if models
            else [
                (name, functools.partial(default_examples, name)) for name in _registered_defaults()
            ]
        )
        options = {
            "envmap": light,
            "resolution": resolution,
            "samples": samples,
            "noise": noise,
            "max_samples": max_samples,
        }
        cards = _build_cards(
            entries, {**options, "run_checks": run_checks, "objects": objects}, progress
        )
    sections = [] if models else [(subsurface.TITLE, _subsurface_html())]
    page = atlas_html(cards, envmap_path.name, sections)
    return atomic_write(output, lambda tmp: tmp.write_text(page, encoding="utf-8"))


__all__ = [
    "DEFAULT_MODELS",
    "ENV_MAX_SAMPLES",
    "ENV_NOISE",
    "OBJECT_CAMERA",
    "OBJECT_MESH",
    "OBJECT_SAMPLES",
    "Card",
    "atlas_html",
    "build_atlas",
    "build_card",
    "card_html",
    "default_cards",
    "default_examples",
    "env_sphere",
    "object_image",
]
