"""A gallery of the real-material presets: one small sphere per preset, fit by fit, as one
self-contained HTML page (``brdfkit materials --gallery OUT.html``).

Every sphere is lit by one directional light (the cheap path: one light sample a pixel, no
Monte Carlo), from the upper right at 45°, and seen from the front; the spheres of one fit share
an exposure (the 99th percentile of their luminance maps to white), so that they compare within
the fit. A sphere for every preset (over a thousand) is more than the atlas should carry, which
is why the gallery is its own page.
"""

from __future__ import annotations

import html
from collections.abc import Callable

from brdfkit.light.analytic import DirectionalLight

LIGHT = DirectionalLight(direction=(0.5, 0.5, 0.7071067811865476), irradiance=3.0)
"""The gallery's light: from the upper right, 45° from the view direction."""

_STYLE = """body{font:13px system-ui,sans-serif;margin:1.5em;background:#fafafa;color:#222}
h2{margin:1.4em 0 .2em;font-size:15px}p.cite{margin:0 0 .5em;color:#555}
div.grid{display:flex;flex-wrap:wrap;gap:6px}figure{margin:0;width:76px;text-align:center}
figure img{width:64px;height:64px;image-rendering:auto;background:#000;border-radius:3px}
figcaption{font-size:10px;overflow-wrap:anywhere;line-height:1.15}"""


def gallery_html(
    fit: str | None = None,
    model: str | None = None,
    resolution: int = 32,
    progress: Callable[[int, int], None] | None = None,
) -> str:
    """The gallery page of the presets that :func:`brdfkit.brdf.presets.catalogue` keeps for
    ``fit`` and ``model``, spheres of ``resolution`` pixels; ``progress(done, total)`` after
    each fit's row. Each sphere's tooltip is its spec (paste it into any command)."""
    from brdfkit.brdf.presets import catalogue, citation, preset
    from brdfkit.plot import sphere_images
    from brdfkit.report.atlas import _image_png

    records = catalogue(fit=fit, model=model)
    keys = list(dict.fromkeys(r["fit"] for r in records))
    sections, done = [], 0
    for key in keys:
        chosen = [r for r in records if r["fit"] == key]
        images = sphere_images(
            [preset(r["name"], key) for r in chosen], LIGHT, resolution=resolution, samples=1
        )
        figures = "".join(
            f'<figure title="{html.escape(r["spec"])}"><img alt="{html.escape(r["name"])}" '
            f'src="data:image/png;base64,{_image_png(image)}">'
            f"<figcaption>{html.escape(r['name'])}</figcaption></figure>"
            for r, image in zip(chosen, images, strict=True)
        )
        sections.append(
            f'<section id="{html.escape(key)}"><h2>{html.escape(key)} ({len(chosen)})</h2>'
            f'<p class="cite">{html.escape(citation(key))}</p><div class="grid">{figures}</div>'
            "</section>"
        )
        done += len(chosen)
        if progress is not None:
            progress(done, len(records))
    index = " · ".join(f'<a href="#{html.escape(k)}">{html.escape(k)}</a>' for k in keys)
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f"<title>brdfkit material presets</title><style>{_STYLE}</style></head><body>"
        f"<h1>Material presets ({len(records)})</h1><p>{index}</p>{''.join(sections)}"
        "</body></html>"
    )


__all__ = ["LIGHT", "gallery_html"]
