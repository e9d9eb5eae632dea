"""``auto`` reports the best analytic fit and the data-driven one, each with its held-out
residual and the CIEDE2000 of its spheres against the measurement."""

from __future__ import annotations

from brdfkit.brdf import parse
from brdfkit.fit import fit_data, select_model, sphere_difference
from brdfkit.fit.measured_fit import MeasuredFit


def test_auto_reports_the_best_analytic_and_the_data_driven_fit():
    measured = parse("lambertian(rho=[0.5, 0.3, 0.2]) + 0.3 * ggx(alpha=0.2)")
    candidates = ("lambertian", "lambertian + ggx", "bivariate")
    selection = select_model(fit_data(measured, samples=1500), candidates, starts=1)
    assert selection.analytic_candidate == "lambertian + ggx"  # the model's own family
    assert selection.result is selection.analytic  # which is the better of the two kinds
    kinds = {
        kind: sphere_difference(measured, getattr(selection, kind).model, resolution=16)
        for kind in ("analytic", "data_driven")
    }
    record = MeasuredFit(measured, selection.result, selection, {}, kinds).record()
    analytic, data_driven = record["analytic"], record["data_driven"]
    assert data_driven["spec"].startswith("bivariate") and data_driven["candidate"] == "bivariate"
    assert analytic["held_out_rms"] < data_driven["held_out_rms"]
    assert analytic["delta_e_directional"]["mean"] < 1.0  # the same material, to the eye
    assert data_driven["delta_e_directional"]["mean"] > 0
    # without both kinds among the candidates there is nothing to set side by side
    alone = select_model(fit_data(measured, samples=1500), ("lambertian",), starts=1)
    assert (
        alone.analytic is None
        and MeasuredFit(measured, alone.result, alone).record().keys()
        == alone.result.to_dict().keys()
    )
