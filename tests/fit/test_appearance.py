"""Rendered-sphere likeness: CIEDE2000 between two BRDFs' spheres, exposed alike."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.fit import delta_e_2000, sphere_difference
from brdfkit.fit.appearance import BODY_LEVEL


def test_delta_e_2000_of_known_colours():
    white, black = np.ones(3), np.zeros(3)
    assert delta_e_2000(white, white) == pytest.approx(0.0, abs=1e-9)
    assert delta_e_2000(white, black) == pytest.approx(100.0, rel=1e-6)  # L* 100 against 0
    # a just-visible step in grey is about one unit
    assert 0.5 < delta_e_2000(np.full(3, 0.18), np.full(3, 0.19)) < 2


def test_a_brdf_looks_like_itself_and_the_exposure_is_the_references():
    model = parse("lambertian(rho=[0.5, 0.3, 0.2]) + [0.05, 0.05, 0.05] * ggx(alpha=0.2)")
    same = sphere_difference(model, model, resolution=32)
    assert same.mean == same.p95 == 0.0
    lit = same.reference[np.any(same.reference > 0, axis=-1)]
    # the median pixel's brightest channel is exposed to BODY_LEVEL (clipping leaves it alone)
    assert np.median(lit.max(axis=-1)) == pytest.approx(BODY_LEVEL, rel=0.05)


def test_differences_grow_with_the_change():
    reference = parse("lambertian(rho=[0.5, 0.3, 0.2])")
    slightly = sphere_difference(reference, parse("lambertian(rho=[0.52, 0.3, 0.2])"), None, 32)
    other = sphere_difference(reference, parse("lambertian(rho=[0.2, 0.3, 0.5])"), None, 32)
    assert 0 < slightly.mean < 2 < 20 < other.mean
    # a highlight the reference lacks shows in the upper percentiles first
    glossy = sphere_difference(
        reference, parse("lambertian(rho=[0.5, 0.3, 0.2]) + 0.1 * ggx(alpha=0.1)"), None, 32
    )
    assert glossy.p95 > 5 * max(glossy.median, 0.5)


def test_bad_input():
    with pytest.raises(ValueError, match="renders black"):
        black, grey = parse("lambertian(rho=[0, 0, 0])"), parse("lambertian(rho=[0.5, 0.5, 0.5])")
        sphere_difference(black, grey, resolution=16)
    with pytest.raises(ValueError, match="3 channels"):
        sphere_difference(parse("lambertian(rho=0.5)"), parse("lambertian"), resolution=16)
