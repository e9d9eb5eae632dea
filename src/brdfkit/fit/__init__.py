"""Fitting: analytic models to measured data, model selection, and how alike two BRDFs look.

:func:`fit` fits any registered model or sum of models to a measured BRDF
(:mod:`~brdfkit.fit.analytic`); :func:`select_model` picks among candidates by held-out error
(:mod:`~brdfkit.fit.select`); :func:`sphere_difference` compares two BRDFs by the CIEDE2000
difference of their rendered spheres (:mod:`~brdfkit.fit.appearance`).
"""

from brdfkit.fit.analytic import (
    FitResult,
    fit,
    fit_data,
    fit_errors,
    log_scale,
    residuals,
)
from brdfkit.fit.appearance import (
    SphereDifference,
    delta_e_2000,
    sphere_difference,
)
from brdfkit.fit.select import (
    Selection,
    fit_any,
    select_model,
)

__all__ = [
    "FitResult",
    "Selection",
    "SphereDifference",
    "delta_e_2000",
    "fit",
    "fit_any",
    "fit_data",
    "fit_errors",
    "log_scale",
    "residuals",
    "select_model",
    "sphere_difference",
]
