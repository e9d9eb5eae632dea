"""The reflectance atlas and the material gallery: self-contained HTML pages.

:mod:`~brdfkit.report.atlas` writes a card per model (its docstring typeset, spheres, lobe,
albedo curve and physics checks) and ends the default atlas with
:mod:`~brdfkit.report.subsurface`'s BRDF and BSSRDF spheres side by side;
:mod:`~brdfkit.report.gallery` shows the named material presets.
"""

from brdfkit.report.atlas import (
    Card,
    atlas_html,
    build_atlas,
    build_card,
    card_html,
    default_cards,
    default_examples,
    env_sphere,
)
from brdfkit.report.gallery import (
    gallery_html,
)

__all__ = [
    "Card",
    "atlas_html",
    "build_atlas",
    "build_card",
    "card_html",
    "default_cards",
    "default_examples",
    "env_sphere",
    "gallery_html",
]
