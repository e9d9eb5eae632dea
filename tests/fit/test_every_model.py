"""Every registered model fits a real measurement: the fit never leaves a model's domain."""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdfkit.brdf import MODELS, parse
from brdfkit.brdf.base import Scaled, Sum
from brdfkit.fit import fit, fit_data, fit_errors
from brdfkit.measured import MeasuredSamples, read_cornell_samples
from brdfkit.params import parameter_domains

SAMPLES = 120

TABULATED_SHAPE = {"kulla_conty_dielectric": ("alpha", "eta"), "rough_plastic": ("alpha", "eta")}
"""Parameters held in this test: these models tabulate their layer's energy by Monte Carlo for
each new roughness and η (seconds per value); their colours and factors are fitted here, all
of them in ``brdfkit fit`` (as the fit of every Cornell file by every model shows)."""


@pytest.fixture(scope="module")
def cornell(shared_data) -> MeasuredSamples:
    """A seeded subset of the Cornell acrylic blue paint (a diffuse body under a gloss)."""
    data = fit_data(read_cornell_samples(shared_data / "measured" / "cornell" / "acryl_blue.brdf"))
    rows = np.sort(np.random.default_rng(0).choice(data.wi.shape[0], SAMPLES, replace=False))
    return MeasuredSamples(data.wi[rows], data.wo[rows], data.values[rows], name="acryl_blue")


def _in_domain(model) -> list[str]:
    """The parameters of ``model``'s lobes that are not finite or lie outside their domain."""
    wrong = []
    for term in model.lobes if isinstance(model, Sum) else (model,):
        inner = term.inner if isinstance(term, Scaled) else term
        if isinstance(term, Scaled) and not np.all(np.isfinite(np.asarray(term.k, dtype=float))):
            wrong.append(f"scale {term.k}")
        unphysical = bool(getattr(inner, "allow_unphysical", False))
        for name, domain in parameter_domains(type(inner)).items():
            value = getattr(inner, name)
            if value is None:
                continue
            hi = domain.unphysical_hi if unphysical and domain.unphysical_hi else domain.hi
            values = np.asarray(value, dtype=float)
            if not (np.all(np.isfinite(values)) and np.all((domain.lo <= values) & (values <= hi))):
                wrong.append(f"{inner.spec_name}.{name} = {value}")
    return wrong


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_registered_model_fits_a_cornell_measurement(cornell, name):
    """Plain least squares of the cube-root residuals on all the samples: the fit starts at the
    model's own values, so it ends no worse than them, inside every domain (Lafortune's joint
    limit on its peak included), whatever the model's channels (principled's weights are one
    per point, its base colour one per channel)."""
    result = fit(cornell, name, loss="linear", starts=1, coarse_samples=SAMPLES,
                 max_samples=SAMPLES, max_nfev=4, fixed=TABULATED_SHAPE.get(name, ()))  # fmt: skip
    initial = fit_errors(parse(name), cornell)["cube_root_rmse"]
    assert math.isfinite(result.errors["cube_root_rmse"])
    assert result.errors["cube_root_rmse"] <= initial * (1 + 1e-9), (name, result.spec)
    assert _in_domain(result.model) == [], result.spec
    assert parse(result.spec).to_spec() == result.spec  # the spec reads back
