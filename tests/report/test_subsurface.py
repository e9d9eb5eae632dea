"""The atlas's subsurface-scattering section: BRDF and BSSRDF spheres side by side."""

from __future__ import annotations

import numpy as np

from brdfkit.report import subsurface
from brdfkit.report.atlas import _subsurface_html, atlas_html


def test_the_bssrdf_sphere_lights_the_shadow_the_brdf_sphere_leaves_dark():
    row = subsurface.subsurface_spheres_row(resolution=32, samples=8)
    assert row.shape == (32, 68, 3)
    left, right = row[:, :32].astype(int), row[:, 36:].astype(int)
    dark = left.sum(-1) == 0  # background and the BRDF sphere's unlit side
    assert np.any(dark & (right.sum(-1) > 0))  # light bled past the terminator
    assert np.all(
        right[dark & (right.sum(-1) > 0)][:, 0] >= right[dark & (right.sum(-1) > 0)][:, 2]
    )


def test_the_section_follows_the_cards_and_is_in_the_table_of_contents():
    section = _subsurface_html()
    page = atlas_html([], "test", [(subsurface.TITLE, section)])
    assert f'href="#{subsurface.TITLE}"' in page
    assert section in page and "data:image/png;base64," in section
    assert 'class="card"' not in section  # not one of the models' cards
