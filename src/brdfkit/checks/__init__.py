"""Physics checks: reciprocity, energy, isotropy, non-negativity, normalisation and samplers.

:func:`check` runs every check a model's claims call for (:mod:`~brdfkit.checks.properties`);
:func:`chi2_test` is Pearson's χ² test of a directional sampler against its own density, as
Mitsuba 3 and pbrt run it (:mod:`~brdfkit.checks.chi2`).
"""

from brdfkit.checks.chi2 import (
    Chi2Result,
    assert_chi2,
    assert_chi2_planar,
    brdf_sampler,
    chi2_test,
    chi2_test_planar,
)
from brdfkit.checks.properties import (
    CheckResult,
    PhysicsReport,
    check,
    check_energy,
    check_isotropy,
    check_nonnegativity,
    check_normalization,
    check_reciprocity,
    check_sampling,
    check_white_furnace,
)

__all__ = [
    "CheckResult",
    "Chi2Result",
    "PhysicsReport",
    "assert_chi2",
    "assert_chi2_planar",
    "brdf_sampler",
    "check",
    "check_energy",
    "check_isotropy",
    "check_nonnegativity",
    "check_normalization",
    "check_reciprocity",
    "check_sampling",
    "check_white_furnace",
    "chi2_test",
    "chi2_test_planar",
]
