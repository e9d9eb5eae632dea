"""Unconstrained coordinates: every value of the optimiser is a parameter inside its domain."""

from __future__ import annotations

import numpy as np

from brdfkit.brdf import parse
from brdfkit.brdf.lafortune import PEAK_MAX
from brdfkit.fit import analytic as fitting
from brdfkit.fit.coordinates import constrained, coordinate_bounds, unconstrained

LOWER = np.array([0.0, 1e-4, 0.0, -np.inf, -np.inf, -100.0])
UPPER = np.array([1.0, 10.0, np.inf, 5.0, np.inf, 100.0])
LOG = np.array([False, True, False, False, False, False])


def test_any_coordinates_map_inside_the_ranges_and_back():
    u = np.random.default_rng(0).normal(0, 30, (1000, LOWER.size))
    x = constrained(u, LOWER, UPPER, LOG)
    assert np.all(np.isfinite(x)) and np.all((LOWER <= x) & (x <= UPPER))
    t = np.random.default_rng(1).uniform(0.01, 0.99, (50, LOWER.size))
    values = np.stack(
        [t[:, 0], 1e-4 * (1e5**t[:, 1]), 10 * t[:, 2], 5 - 10 * t[:, 3], 20 * t[:, 4] - 10,
         200 * t[:, 5] - 100], axis=1,
    )  # fmt: skip
    back = constrained(unconstrained(values, LOWER, UPPER, LOG), LOWER, UPPER, LOG)
    np.testing.assert_allclose(back, values, rtol=1e-9, atol=1e-12)


def test_the_maps_increase_and_the_bounds_sit_just_inside_the_ends():
    u = np.linspace(-40, 40, 2001)[:, None]
    x = constrained(u, LOWER, UPPER, LOG)
    assert np.all(np.diff(x, axis=0) >= 0)
    low, high = coordinate_bounds(LOWER, UPPER, LOG)
    ends = constrained(np.stack([low, high]), LOWER, UPPER, LOG)
    finite = np.isfinite(LOWER) & np.isfinite(UPPER)
    assert np.all(ends[0][finite] > LOWER[finite]) and np.all(ends[1][finite] < UPPER[finite])
    assert np.all(np.isinf(high[~np.isfinite(UPPER)]))


def test_lafortunes_exponent_stays_under_its_peak_limit_whatever_the_coefficients():
    """The joint limit max|C|ⁿ ≤ 10¹² holds for every coordinate, the model always builds."""
    lobes = fitting._lobes(parse("lafortune"))
    free = fitting._free_parameters(lobes, [set()], (), 3)
    coordinates = fitting._Coordinates(lobes, free)
    names = [p.name for p in free for _ in range(p.size)]
    rng = np.random.default_rng(2)
    for u in rng.normal(0, 15, (200, len(names))):
        x = coordinates.values(u)
        values = dict(zip(names, x, strict=True))
        largest = max(abs(values["cx"]), abs(values["cy"]), abs(values["cz"]))
        assert values["n"] * np.log(max(largest, 1.0)) <= np.log(PEAK_MAX)
        fitting._assemble(lobes, free, x, relax=True)  # builds: no ParameterError
