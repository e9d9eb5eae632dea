"""A measured BRDF fitted end to end (:mod:`brdfkit.fit.measured_fit`): the fit of a spec, the
spheres compared under each light, the record written as fit.json, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.errors import ParameterError
from brdfkit.fit.analytic import fit
from brdfkit.fit.appearance import sphere_difference
from brdfkit.fit.measured_fit import fit_measured


@pytest.fixture(scope="module")
def matte():
    return parse("lambertian(albedo=[0.6, 0.4, 0.3])")


def test_a_spec_fit_equals_the_fit_and_its_spheres(matte):
    fitted = fit_measured(matte, "lambertian", starts=1, spheres=16)
    alone = fit(matte, "lambertian", starts=1)
    assert fitted.result.params.keys() == alone.params.keys()
    for name, value in alone.params.items():
        np.testing.assert_array_equal(fitted.result.params[name], value)
    assert fitted.selection is None and list(fitted.spheres) == ["directional"]
    difference = sphere_difference(matte, fitted.result.model, None, 16)
    assert fitted.spheres["directional"].to_dict() == difference.to_dict()
    record = fitted.record()
    assert record["delta_e_directional"] == difference.to_dict()
    assert record["spec"] == fitted.result.spec
    image = fitted.spheres_image()
    assert image.shape == (16, 32, 3)
    np.testing.assert_array_equal(image[:, :16], difference.reference)


def test_without_spheres_the_record_is_the_fit(matte):
    fitted = fit_measured(matte, "lambertian", starts=1)
    assert fitted.spheres == {} and fitted.record() == fitted.result.to_dict()


@pytest.mark.parametrize("model", ["auto", " bivariate "])
def test_fixed_parameters_need_a_spec(matte, model):
    with pytest.raises(ParameterError, match="fixed does not apply"):
        fit_measured(matte, model, fixed=["albedo"])
