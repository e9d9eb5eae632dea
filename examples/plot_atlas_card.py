"""
One card of the reflectance atlas
=================================

``brdfkit atlas`` (:func:`brdfkit.report.build_atlas`) writes an HTML page with a card per
model. :func:`brdfkit.report.build_card` makes one card's content: a row of spheres across the
model's example parameters under a directional light and under the bundled environment map, a
lobe plot (:func:`brdfkit.plot.lobe_plot`) and the directional albedo curves
(:func:`brdfkit.plot.albedo_plot`), and the physics checks (:func:`brdfkit.checks.check`:
non-negativity, reciprocity, energy, isotropy, sampling) with their numbers, set against what
the model claims. Here the Cook–Torrance card's images and checks are laid out with matplotlib;
the atlas page itself adds the formula and the docstring as HTML.

This is the README's picture ``docs/images/atlas_card.png``: running this file as a script
writes it.
"""

import base64
import io
import os
import textwrap
from pathlib import Path

import matplotlib.image
from matplotlib.figure import Figure

from brdfkit.data import default_envmap_path
from brdfkit.light import EnvironmentMap
from brdfkit.report.atlas import build_card, default_cards

title = "cook_torrance"
models = dict(default_cards())[title]  # the atlas's example instances of the model
card = build_card(title, models, envmap=EnvironmentMap.from_file(default_envmap_path()))
for label in card.labels:
    print(label)


def picture(caption: str):
    """One of the card's images (base64 PNG) as an array."""
    return matplotlib.image.imread(io.BytesIO(base64.b64decode(card.images[caption])))


# %%
# The card: its example instances, the four images, the checks table.
fig = Figure(figsize=(9.6, 8.4), layout="constrained")
top, middle, bottom = fig.subfigures(3, 1, height_ratios=[0.95, 3.6, 1.45])
top.text(
    0.01, 0.97, f"{card.title}: one card of the atlas", fontsize=12, fontweight="bold", va="top"
)
top.text(0.01, 0.62, "Examples (left to right)", fontsize=9, va="top")
examples = "\n".join(f"{i}. {label}" for i, label in enumerate(card.labels, 1))
top.text(0.01, 0.45, examples, fontsize=7, family="monospace", va="top")

grid = middle.subplots(2, 2, height_ratios=[1, 3.3])
for ax, caption in zip(grid.flat, card.images, strict=True):
    ax.imshow(picture(caption))
    ax.set_title(caption, fontsize=8, color="0.35")
    ax.axis("off")

ax = bottom.subplots()
ax.axis("off")
representative = len(card.models) // 2 + 1
verdict = "consistent with its claims" if card.consistent else "CONTRADICTS a claim"
ax.set_title(f"Physics checks on example #{representative}: {verdict}", fontsize=9, loc="left")
rows = [
    [
        c["name"],
        "pass" if c["passed"] else "fail",
        "—" if c.get("value") is None else f"{c['value']:.3g}",
        "—" if c.get("tolerance") is None else f"{c['tolerance']:.3g}",
        "—" if c.get("claimed") is None else ("yes" if c["claimed"] else "no"),
        textwrap.fill(c.get("detail", ""), 112),
    ]
    for c in card.checks
]
table = ax.table(
    rows,
    colLabels=["check", "result", "value", "tolerance", "claimed", "detail"],
    colWidths=[0.09, 0.05, 0.065, 0.065, 0.055, 0.675],
    cellLoc="left",
    colLoc="left",
    loc="upper center",
    edges="horizontal",
)
table.auto_set_font_size(False)
table.set_fontsize(7)
for (row, column), cell in table.get_celld().items():
    cell.set_edgecolor("0.85")
    lines = 1 if row == 0 else rows[row - 1][-1].count("\n") + 1
    cell.set_height(cell.get_height() * (1 + 0.8 * (lines - 1)))
    if row == 0:
        cell.set_text_props(fontweight="bold")
    elif column == 1:
        cell.set_text_props(color="#0a7a2f" if rows[row - 1][1] == "pass" else "#b00020")

# %%
# Running the file as a script writes the README's picture.
if "BRDFKIT_DOCS_BUILD" not in os.environ:
    fig.savefig(Path(__file__).resolve().parents[1] / "docs/images/atlas_card.png", dpi=100)
